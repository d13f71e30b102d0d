/*
 * The extension module epsnet._epsnet: numpy arrays in and out of the
 * public API (epsnet.h §13), the GIL released while the library works.
 * The Python modules beside it (python/epsnet/) hold the manual and turn
 * user input into what these functions take; these check it again, so that
 * nothing a caller passes can crash the interpreter.
 *
 * One concern per file: errors.c (C errors as exceptions), arrays.c
 * (ndarrays <-> epsnet_arrays), settings.c (keyword options ->
 * epsnet_settings), callbacks.c (progress, Ctrl-C, warnings), calls.c
 * (simplify, sample, hausdorff), read.c (a mesh file into arrays).
 */
#ifndef EPSNET_PY_BINDING_H
#define EPSNET_PY_BINDING_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#ifndef EB_MODULE_MAIN
#define NO_IMPORT_ARRAY
#endif
#include <numpy/arrayobject.h>

#include <epsnet/epsnet.h>

/* ---- errors.c ---- */

/* Create the exception classes and add them to module m. @return 0 or -1. */
int eb_errors_init(PyObject *m);
/* Raise the exception of a failed call (code < 0, err filled): a pending
 * Python exception (a progress callback's, KeyboardInterrupt) wins.
 * @return NULL, for `return eb_raise(...)`. */
PyObject *eb_raise(int code, const epsnet_error *err);
/* Raise epsnet's ValueError kind (an ArgumentError) with a formatted message. @return NULL. */
PyObject *eb_value_error(const char *fmt, ...);

/* ---- arrays.c ---- */

/* Describe vertices (n, 3) float32/float64 and faces (m, 3) int32/int64,
 * both C-contiguous, aligned, native ndarrays, and attrs (None or a dict of
 * name -> (n,) arrays of an epsnet_attr_type) as a, without copying. The
 * arrays must stay referenced (the caller's arguments are) while a is used.
 * @return 0, or -1 with ValueError/TypeError set. */
int eb_arrays_in(PyObject *vertices, PyObject *faces, PyObject *attrs, const char *name, epsnet_arrays *a);
/* A mesh as (vertices, faces, attributes): ndarrays that own the buffers
 * (*xyz, *faces and attr[i] are NULL afterwards, also on failure, when the
 * ones not yet handed over stay the caller's to free); library: they were
 * allocated by the library (epsnet_free), else by malloc (free). Types are
 * numpy type numbers. @return NULL on failure. */
PyObject *eb_mesh_out(void **xyz, int xyz_type, uint64_t nv, void **faces, int face_type, uint64_t nf,
                      const epsnet_attr_layout *layout, void **attr, int library);
/* The result of a call on arrays (eb_mesh_out of out's buffers). */
PyObject *eb_arrays_out(epsnet_arrays_out *out);
/* numpy type number of an attribute type, or -1. */
int eb_attr_typenum(epsnet_attr_type t);

/* ---- settings.c ---- */

/* Fill s from the option dict (keys as epsnet/_options.py builds them:
 * level, frequency, rotation, seed, threads, mem, slab_vertices, passes,
 * max_normal_dev, target_faces, target_ratio, target_vertices,
 * target_error, target_level_given, lock_property, drop_normals, tmpdir).
 * String values are borrowed from the dict, which must outlive s.
 * @return 0, or -1 with an exception set. */
int eb_settings(PyObject *options, epsnet_settings *s);

/* ---- callbacks.c ---- */

#define EB_WARNINGS_MAX 16

/* What a run reports while the GIL is released: the progress callback's
 * exception, Ctrl-C, warnings (kept in C until the run returns). */
typedef struct eb_run {
    PyObject *progress;          /* callable(done, total) or None; borrowed */
    PyObject *exc;               /* the exception that cancelled, owned */
    int nwarn;
    char warn[EB_WARNINGS_MAX][1024];
} eb_run;

/* Point s's progress and warning callbacks at run. */
void eb_run_attach(eb_run *run, PyObject *progress, epsnet_settings *s);
/* After the run, with the GIL: the warnings as a list of str (NULL on
 * failure), and a cancelling exception restored as the current one
 * (eb_raise then raises it). */
PyObject *eb_run_warnings(eb_run *run);
void eb_run_restore(eb_run *run);

/* ---- calls.c, read.c ---- */

PyObject *eb_simplify(PyObject *self, PyObject *args);
PyObject *eb_simplify_file(PyObject *self, PyObject *args);
PyObject *eb_sample(PyObject *self, PyObject *args);
PyObject *eb_hausdorff(PyObject *self, PyObject *args);
PyObject *eb_read_mesh(PyObject *self, PyObject *args);
/* The statistics of a run as a dict of numbers. */
PyObject *eb_stats_dict(const epsnet_stats *st);

#endif
