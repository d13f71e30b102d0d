/*
 * ndarrays in and out of epsnet_arrays (epsnet.h §13). Input is read in
 * place: only C-contiguous, aligned, native-order arrays of the listed types
 * are taken (python/epsnet/__init__.py converts or refuses others before),
 * so that no call copies the caller's mesh. Output arrays own the buffers
 * the library allocated, through a capsule that frees them with
 * epsnet_free(): no copy on the way out either.
 */
#include "binding.h"

int eb_attr_typenum(epsnet_attr_type t)
{
    switch (t) {
    case EPSNET_ATTR_INT8: return NPY_INT8;
    case EPSNET_ATTR_UINT8: return NPY_UINT8;
    case EPSNET_ATTR_INT16: return NPY_INT16;
    case EPSNET_ATTR_UINT16: return NPY_UINT16;
    case EPSNET_ATTR_INT32: return NPY_INT32;
    case EPSNET_ATTR_UINT32: return NPY_UINT32;
    case EPSNET_ATTR_FLOAT32: return NPY_FLOAT32;
    case EPSNET_ATTR_FLOAT64: return NPY_FLOAT64;
    }
    return -1;
}

static int attr_type_of(int typenum, epsnet_attr_type *t)
{
    static const epsnet_attr_type all[] = { EPSNET_ATTR_INT8,   EPSNET_ATTR_UINT8,  EPSNET_ATTR_INT16,
                                            EPSNET_ATTR_UINT16, EPSNET_ATTR_INT32,  EPSNET_ATTR_UINT32,
                                            EPSNET_ATTR_FLOAT32, EPSNET_ATTR_FLOAT64 };
    for (size_t i = 0; i < sizeof all / sizeof *all; i++)
        if (PyArray_EquivTypenums(eb_attr_typenum(all[i]), typenum)) {
            *t = all[i];
            return 0;
        }
    return -1;
}

/* a is an ndarray we can read in place: C-contiguous, aligned, native. */
static PyArrayObject *plain(PyObject *o, const char *what)
{
    if (!PyArray_Check(o)) {
        eb_value_error("%s must be a numpy array, not %s", what, Py_TYPE(o)->tp_name);
        return NULL;
    }
    PyArrayObject *a = (PyArrayObject *)o;
    if (!PyArray_IS_C_CONTIGUOUS(a) || !PyArray_ISALIGNED(a) || !PyArray_ISNOTSWAPPED(a)) {
        eb_value_error("%s must be C-contiguous, aligned and in native byte order", what);
        return NULL;
    }
    return a;
}

static int rows3(PyArrayObject *a, const char *what)
{
    if (PyArray_NDIM(a) != 2 || PyArray_DIM(a, 1) != 3) {
        eb_value_error("%s must have shape (n, 3)", what);
        return -1;
    }
    return 0;
}

int eb_arrays_in(PyObject *vertices, PyObject *faces, PyObject *attrs, const char *name, epsnet_arrays *a)
{
    epsnet_arrays_init(a);
    a->name = name;
    PyArrayObject *v = plain(vertices, "vertices"), *f = v ? plain(faces, "faces") : NULL;
    if (!f || rows3(v, "vertices") || rows3(f, "faces"))
        return -1;
    int vt = PyArray_TYPE(v), ft = PyArray_TYPE(f);
    if (PyArray_EquivTypenums(vt, NPY_FLOAT32))
        a->coord_type = EPSNET_COORD_FLOAT32;
    else if (PyArray_EquivTypenums(vt, NPY_FLOAT64))
        a->coord_type = EPSNET_COORD_FLOAT64;
    else
        return eb_value_error("vertices must be float32 or float64"), -1;
    if (PyArray_EquivTypenums(ft, NPY_INT32))
        a->index_bytes = 4;
    else if (PyArray_EquivTypenums(ft, NPY_INT64))
        a->index_bytes = 8;
    else
        return eb_value_error("faces must be int32 or int64"), -1;
    a->nverts = (uint64_t)PyArray_DIM(v, 0);
    a->xyz = PyArray_DATA(v);
    a->nfaces = (uint64_t)PyArray_DIM(f, 0);
    a->faces = PyArray_DATA(f);
    if (attrs == Py_None)
        return 0;
    if (!PyDict_Check(attrs))
        return eb_value_error("attributes must be a dict of name -> array"), -1;
    PyObject *key, *value;
    Py_ssize_t pos = 0;
    while (PyDict_Next(attrs, &pos, &key, &value)) {
        const char *n = PyUnicode_Check(key) ? PyUnicode_AsUTF8(key) : NULL;
        if (!n)
            return PyErr_Occurred() ? -1 : (eb_value_error("attribute names must be str"), -1);
        PyArrayObject *col = plain(value, "an attribute");
        if (!col)
            return -1;
        epsnet_attr_type t;
        if (PyArray_NDIM(col) != 1 || (uint64_t)PyArray_DIM(col, 0) != a->nverts)
            return eb_value_error("attribute '%s' must have shape (%llu,): one value per vertex", n,
                                  (unsigned long long)a->nverts), -1;
        if (attr_type_of(PyArray_TYPE(col), &t))
            return eb_value_error("attribute '%s' must be int8, uint8, int16, uint16, int32, uint32, "
                                  "float32 or float64", n), -1;
        int rc = epsnet_attr_layout_add(&a->attrs, n, t);
        if (rc == EPSNET_ELIMIT)
            return eb_value_error("more than %d attributes", EPSNET_ATTR_MAX), -1;
        if (rc)
            return eb_value_error("attribute name '%s' is empty, longer than %d bytes, has white space or "
                                  "appears twice", n, EPSNET_ATTR_NAME_MAX - 1), -1;
        a->attr[a->attrs.count - 1] = PyArray_DATA(col);
    }
    return 0;
}

static void free_library(PyObject *capsule)
{
    epsnet_free(PyCapsule_GetPointer(capsule, "epsnet.buffer"));
}

static void free_malloc(PyObject *capsule)
{
    free(PyCapsule_GetPointer(capsule, "epsnet.malloc"));
}

static PyObject *wrap(void *p, int ndim, npy_intp *dims, int typenum, int library)
{
    if (!p)
        return PyArray_ZEROS(ndim, dims, typenum, 0);
    PyObject *arr = PyArray_SimpleNewFromData(ndim, dims, typenum, p);
    PyObject *capsule = !arr ? NULL
                        : library ? PyCapsule_New(p, "epsnet.buffer", free_library)
                                  : PyCapsule_New(p, "epsnet.malloc", free_malloc);
    if (!capsule) {
        Py_XDECREF(arr);
        if (library)
            epsnet_free(p);
        else
            free(p);
        return NULL;
    }
    if (PyArray_SetBaseObject((PyArrayObject *)arr, capsule)) { /* steals capsule, which frees p */
        Py_DECREF(arr);
        return NULL;
    }
    return arr;
}

PyObject *eb_mesh_out(void **xyz, int xyz_type, uint64_t nv, void **faces, int face_type, uint64_t nf,
                      const epsnet_attr_layout *layout, void **attr, int library)
{
    npy_intp vd[2] = { (npy_intp)nv, 3 }, fd[2] = { (npy_intp)nf, 3 }, n = (npy_intp)nv;
    PyObject *v = wrap(*xyz, 2, vd, xyz_type, library);
    *xyz = NULL;
    PyObject *f = wrap(*faces, 2, fd, face_type, library);
    *faces = NULL;
    PyObject *attrs = PyDict_New();
    int bad = !v || !f || !attrs;
    for (uint32_t i = 0; i < layout->count && !bad; i++) {
        PyObject *col = wrap(attr[i], 1, &n, eb_attr_typenum(layout->attr[i].type), library);
        attr[i] = NULL;
        bad = !col || PyDict_SetItemString(attrs, layout->attr[i].name, col);
        Py_XDECREF(col);
    }
    if (bad) {
        Py_XDECREF(v);
        Py_XDECREF(f);
        Py_XDECREF(attrs);
        return NULL;
    }
    return Py_BuildValue("(NNN)", v, f, attrs);
}

PyObject *eb_arrays_out(epsnet_arrays_out *out)
{
    return eb_mesh_out(&out->xyz, out->coord_type == EPSNET_COORD_FLOAT32 ? NPY_FLOAT32 : NPY_FLOAT64, out->nverts,
                       &out->faces, out->index_bytes == 4 ? NPY_INT32 : NPY_INT64, out->nfaces, &out->attrs, out->attr,
                       1);
}
