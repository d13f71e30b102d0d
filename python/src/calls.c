/*
 * The library's jobs with the GIL released: simplify (arrays and files),
 * sample, hausdorff. Each call makes its own context from its options, so
 * calls on several Python threads share nothing and run at once; the output
 * never depends on the thread count (docs/architecture.md §11).
 */
#include "binding.h"

#define STAT(field) { #field, offsetof(epsnet_stats, field) }

PyObject *eb_stats_dict(const epsnet_stats *st)
{
    static const struct {
        const char *name;
        size_t at;
    } counts[] = {
        STAT(vertices), STAT(faces), STAT(zero_area_faces), STAT(gaussian_vertices), STAT(feature_edges),
        STAT(candidates), STAT(samples), STAT(locked), STAT(boundary_vertices), STAT(nonmanifold_vertices),
        STAT(needle_vertices), STAT(multi_cover_samples), STAT(isolated_vertices), STAT(output_vertices),
        STAT(output_faces), STAT(collapses), STAT(passes), STAT(remaining_nonsamples), STAT(refused_link),
        STAT(refused_normal), STAT(refused_zero_area), STAT(refused_duplicate), STAT(max_active), STAT(slabs),
        STAT(seam_faces), STAT(seam_collapses), STAT(peak_rss), STAT(dropped), STAT(target_faces),
        STAT(skeleton_vertices), STAT(samples_given_up), STAT(membrane_faces), STAT(budget_total),
    };
    static const struct {
        const char *name;
        size_t at;
    } seconds[] = {
        STAT(seconds_read), STAT(seconds_classify), STAT(seconds_simplify), STAT(seconds_sort), STAT(cpu_main),
        STAT(cpu_workers),
    };
    PyObject *d = PyDict_New();
    int bad = !d;
    for (size_t i = 0; !bad && i < sizeof counts / sizeof *counts; i++) {
        uint64_t v;
        memcpy(&v, (const char *)st + counts[i].at, sizeof v);
        PyObject *o = PyLong_FromUnsignedLongLong(v);
        bad = !o || PyDict_SetItemString(d, counts[i].name, o);
        Py_XDECREF(o);
    }
    for (size_t i = 0; !bad && i < sizeof seconds / sizeof *seconds; i++) {
        double v;
        memcpy(&v, (const char *)st + seconds[i].at, sizeof v);
        PyObject *o = PyFloat_FromDouble(v);
        bad = !o || PyDict_SetItemString(d, seconds[i].name, o);
        Py_XDECREF(o);
    }
    PyObject *o = bad ? NULL : PyLong_FromUnsignedLong(st->skeleton_finest_frequency);
    bad = bad || !o || PyDict_SetItemString(d, "skeleton_finest_frequency", o);
    Py_XDECREF(o);
    o = bad ? NULL : PyLong_FromUnsignedLong(st->target_rounds);
    bad = bad || !o || PyDict_SetItemString(d, "target_rounds", o);
    Py_XDECREF(o);
    o = bad ? NULL : PyLong_FromUnsignedLong(st->target_round_retries);
    bad = bad || !o || PyDict_SetItemString(d, "target_round_retries", o);
    Py_XDECREF(o);
    o = bad ? NULL : PyLong_FromUnsignedLong(st->attribute_channels);
    bad = bad || !o || PyDict_SetItemString(d, "attribute_channels", o);
    Py_XDECREF(o);
    if (bad) {
        Py_XDECREF(d);
        return NULL;
    }
    return d;
}

/* A context for one call, its callbacks pointing at run. */
static epsnet_context *open_context(PyObject *options, PyObject *progress, eb_run *run)
{
    epsnet_settings s;
    if (eb_settings(options, &s))
        return NULL;
    eb_run_attach(run, progress, &s);
    epsnet_context *ctx = NULL;
    epsnet_error err;
    int rc = epsnet_context_new(&ctx, &s, &err);
    if (rc)
        eb_raise(rc, &err);
    return ctx;
}

/* After a run: its exception or error, else (stats, warnings). */
static PyObject *finish(epsnet_context *ctx, eb_run *run, int rc, const epsnet_error *err)
{
    eb_run_restore(run);
    if (rc)
        return eb_raise(rc, err);
    if (PyErr_Occurred())
        return NULL;
    return Py_BuildValue("(NN)", eb_stats_dict(epsnet_context_stats(ctx)), eb_run_warnings(run));
}

PyObject *eb_simplify(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *vertices, *faces, *attrs, *options, *progress;
    if (!PyArg_ParseTuple(args, "OOOO!O:simplify", &vertices, &faces, &attrs, &PyDict_Type, &options, &progress))
        return NULL;
    epsnet_arrays in;
    if (eb_arrays_in(vertices, faces, attrs, "arrays", &in))
        return NULL;
    eb_run run;
    epsnet_context *ctx = open_context(options, progress, &run);
    if (!ctx)
        return NULL;
    epsnet_arrays_out out;
    epsnet_error err;
    int rc;
    Py_BEGIN_ALLOW_THREADS
    rc = epsnet_simplify_arrays(ctx, &in, &out, &err);
    Py_END_ALLOW_THREADS
    PyObject *report = finish(ctx, &run, rc, &err);
    PyObject *mesh = report ? eb_arrays_out(&out) : NULL;
    epsnet_arrays_out_free(&out);
    epsnet_context_free(&ctx);
    Py_XDECREF(run.exc);
    if (!mesh) {
        Py_XDECREF(report);
        return NULL;
    }
    PyObject *r = Py_BuildValue("(OOOOO)", PyTuple_GET_ITEM(mesh, 0), PyTuple_GET_ITEM(mesh, 1),
                                PyTuple_GET_ITEM(mesh, 2), PyTuple_GET_ITEM(report, 0), PyTuple_GET_ITEM(report, 1));
    Py_DECREF(mesh);
    Py_DECREF(report);
    return r;
}

PyObject *eb_simplify_file(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *src, *dst, *options, *progress;
    if (!PyArg_ParseTuple(args, "O&O&O!O:simplify_file", PyUnicode_FSConverter, &src, PyUnicode_FSConverter, &dst,
                          &PyDict_Type, &options, &progress))
        return NULL;
    eb_run run;
    epsnet_context *ctx = open_context(options, progress, &run);
    PyObject *r = NULL;
    if (ctx) {
        const char *in = PyBytes_AS_STRING(src), *out = PyBytes_AS_STRING(dst);
        epsnet_error err;
        int rc;
        Py_BEGIN_ALLOW_THREADS
        rc = epsnet_simplify_file(ctx, in, out, &err);
        Py_END_ALLOW_THREADS
        r = finish(ctx, &run, rc, &err);
        epsnet_context_free(&ctx);
        Py_XDECREF(run.exc);
    }
    Py_DECREF(src);
    Py_DECREF(dst);
    return r;
}

PyObject *eb_sample(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *vertices, *faces, *options;
    if (!PyArg_ParseTuple(args, "OOO!:sample", &vertices, &faces, &PyDict_Type, &options))
        return NULL;
    epsnet_arrays in;
    if (eb_arrays_in(vertices, faces, Py_None, "arrays", &in))
        return NULL;
    npy_intp n = (npy_intp)in.nverts;
    PyObject *flags = PyArray_ZEROS(1, &n, NPY_UINT8, 0), *gv = PyArray_ZEROS(1, &n, NPY_INT32, 0);
    eb_run run;
    epsnet_context *ctx = flags && gv ? open_context(options, Py_None, &run) : NULL;
    PyObject *r = NULL;
    if (ctx) {
        uint8_t *f = PyArray_DATA((PyArrayObject *)flags);
        int32_t *g = PyArray_DATA((PyArrayObject *)gv);
        epsnet_error err;
        int rc;
        Py_BEGIN_ALLOW_THREADS
        rc = epsnet_sample_arrays(ctx, &in, f, g, &err);
        Py_END_ALLOW_THREADS
        PyObject *report = finish(ctx, &run, rc, &err);
        if (report)
            r = Py_BuildValue("(OOO)", flags, gv, PyTuple_GET_ITEM(report, 0));
        Py_XDECREF(report);
        epsnet_context_free(&ctx);
        Py_XDECREF(run.exc);
    }
    Py_XDECREF(flags);
    Py_XDECREF(gv);
    return r;
}

static PyObject *side_dict(const epsnet_hausdorff_side *s, double diagonal)
{
    return Py_BuildValue("{s:d,s:d,s:d,s:d,s:d,s:d,s:K,s:d,s:d,s:K,s:d,s:(ddd)}", "max", s->max, "mean", s->mean,
                         "rms", s->rms, "max_relative", diagonal > 0 ? s->max / diagonal : 0.0, "mean_relative",
                         diagonal > 0 ? s->mean / diagonal : 0.0, "rms_relative",
                         diagonal > 0 ? s->rms / diagonal : 0.0, "samples", (unsigned long long)s->samples,
                         "normal_max_deg", s->normal_max, "normal_mean_deg", s->normal_mean, "normal_samples",
                         (unsigned long long)s->normal_samples, "area", s->area, "max_at", s->max_at[0],
                         s->max_at[1], s->max_at[2]);
}

PyObject *eb_hausdorff(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *va, *fa, *vb, *fb;
    unsigned int samples_per_face;
    unsigned long long seed;
    int threads;
    if (!PyArg_ParseTuple(args, "OOOOIKi:hausdorff", &va, &fa, &vb, &fb, &samples_per_face, &seed, &threads))
        return NULL;
    epsnet_arrays a, b;
    if (eb_arrays_in(va, fa, Py_None, "a", &a) || eb_arrays_in(vb, fb, Py_None, "b", &b))
        return NULL;
    epsnet_hausdorff_settings s;
    epsnet_hausdorff_default_settings(&s);
    s.samples_per_face = samples_per_face;
    s.seed = seed;
    s.threads = threads;
    epsnet_hausdorff_result r;
    epsnet_error err;
    int rc;
    Py_BEGIN_ALLOW_THREADS
    rc = epsnet_hausdorff_arrays(&a, &b, &s, &r, &err);
    Py_END_ALLOW_THREADS
    if (rc)
        return eb_raise(rc, &err);
    double d = r.diagonal;
    return Py_BuildValue("{s:d,s:d,s:d,s:N,s:N,s:{s:K,s:K,s:K},s:{s:K,s:K,s:K}}", "hausdorff", r.hausdorff,
                         "hausdorff_relative", d > 0 ? r.hausdorff / d : 0.0, "diagonal", d, "a_to_b",
                         side_dict(&r.a_to_b, d), "b_to_a", side_dict(&r.b_to_a, d), "a", "vertices",
                         (unsigned long long)r.a_vertices, "faces", (unsigned long long)r.a_faces, "zero_area_faces",
                         (unsigned long long)r.a_zero_area_faces, "b", "vertices", (unsigned long long)r.b_vertices,
                         "faces", (unsigned long long)r.b_faces, "zero_area_faces",
                         (unsigned long long)r.b_zero_area_faces);
}
