/*
 * The module: its functions and exceptions. Everything a user reads about
 * them is in python/epsnet/__init__.py, which wraps these.
 */
#define EB_MODULE_MAIN
#include "binding.h"

static PyObject *eb_version(PyObject *self, PyObject *args)
{
    (void)self;
    (void)args;
    return PyUnicode_FromString(epsnet_version());
}

static PyMethodDef methods[] = {
    { "simplify", eb_simplify, METH_VARARGS,
      "simplify(vertices, faces, attributes, options, progress) -> (v, f, attrs, stats, warnings)" },
    { "simplify_file", eb_simplify_file, METH_VARARGS,
      "simplify_file(src, dst, options, progress) -> (stats, warnings)" },
    { "sample", eb_sample, METH_VARARGS, "sample(vertices, faces, options) -> (is_sample, gvertex, stats)" },
    { "hausdorff", eb_hausdorff, METH_VARARGS,
      "hausdorff(va, fa, vb, fb, samples_per_face, seed, threads) -> dict" },
    { "read_mesh", eb_read_mesh, METH_VARARGS, "read_mesh(path) -> (vertices, faces, attributes)" },
    { "version", eb_version, METH_NOARGS, "version() -> the linked library's version" },
    { NULL, NULL, 0, NULL },
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_epsnet", "epsnet's C binding (see the epsnet package)", -1, methods,
    NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__epsnet(void);

PyMODINIT_FUNC PyInit__epsnet(void)
{
    import_array();
    PyObject *m = PyModule_Create(&module);
    if (!m)
        return NULL;
    if (eb_errors_init(m)) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
