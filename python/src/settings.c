/*
 * The keyword options of epsnet.simplify() and friends, as
 * python/epsnet/_options.py names them, into an epsnet_settings
 * (epsnet.h §6). Missing keys and None keep the library's defaults, which
 * are the CLI's.
 */
#include <math.h>

#include "binding.h"

/* The value of key, or NULL when it is missing or None (never an error). */
static PyObject *get(PyObject *options, const char *key)
{
    PyObject *v = PyDict_GetItemString(options, key);
    return v == Py_None ? NULL : v;
}

static int get_u64(PyObject *options, const char *key, uint64_t *out)
{
    PyObject *v = get(options, key);
    if (!v)
        return 0;
    unsigned long long x = PyLong_AsUnsignedLongLong(v);
    if (x == (unsigned long long)-1 && PyErr_Occurred()) {
        PyErr_Clear();
        eb_value_error("%s must be a non-negative integer", key);
        return -1;
    }
    *out = x;
    return 0;
}

static int get_int(PyObject *options, const char *key, int *out)
{
    PyObject *v = get(options, key);
    if (!v)
        return 0;
    long x = PyLong_AsLong(v);
    if ((x == -1 && PyErr_Occurred()) || x < INT32_MIN || x > INT32_MAX) {
        PyErr_Clear();
        eb_value_error("%s must be an integer", key);
        return -1;
    }
    *out = (int)x;
    return 0;
}

static int get_double(PyObject *options, const char *key, double *out)
{
    PyObject *v = get(options, key);
    if (!v)
        return 0;
    double x = PyFloat_AsDouble(v);
    if (x == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        eb_value_error("%s must be a number", key);
        return -1;
    }
    if (!isfinite(x)) {
        eb_value_error("%s must be finite", key);
        return -1;
    }
    *out = x;
    return 0;
}

static int get_str(PyObject *options, const char *key, const char **out)
{
    PyObject *v = get(options, key);
    if (!v)
        return 0;
    const char *s = PyUnicode_Check(v) ? PyUnicode_AsUTF8(v) : NULL;
    if (!s) {
        if (!PyErr_Occurred())
            eb_value_error("%s must be a str", key);
        return -1;
    }
    *out = s;
    return 0;
}

int eb_settings(PyObject *options, epsnet_settings *s)
{
    epsnet_default_settings(s);
    if (!PyDict_Check(options)) {
        PyErr_SetString(PyExc_TypeError, "options must be a dict");
        return -1;
    }
    uint64_t frequency = 0, slab = 0;
    const char *rotation = NULL;
    if (get_int(options, "level", &s->level) || get_u64(options, "frequency", &frequency) ||
        get_str(options, "rotation", &rotation) || get_u64(options, "seed", &s->seed) ||
        get_int(options, "threads", &s->threads) || get_u64(options, "mem", &s->mem) ||
        get_u64(options, "slab_vertices", &slab) || get_int(options, "passes", &s->passes) ||
        get_double(options, "max_normal_dev", &s->max_normal_dev) ||
        get_u64(options, "target_faces", &s->target_faces) || get_double(options, "target_ratio", &s->target_ratio) ||
        get_u64(options, "target_vertices", &s->target_vertices) ||
        get_double(options, "target_error", &s->target_error) ||
        get_int(options, "target_level_given", &s->target_level_given) ||
        get_str(options, "lock_property", &s->lock_property) || get_int(options, "drop_normals", &s->drop_normals) ||
        get_str(options, "attribute_weights", &s->attribute_weights) ||
        get_str(options, "tmpdir", &s->tmpdir))
        return -1;
    if (frequency > UINT32_MAX || slab > UINT32_MAX) {
        eb_value_error("frequency and slab_vertices must be below 2^32");
        return -1;
    }
    s->frequency = (uint32_t)frequency;
    s->slab_vertices = (uint32_t)slab;
    if (rotation && epsnet_parse_rotation(rotation, s)) {
        eb_value_error("rotation '%s' is not \"default\", \"identity\", \"AX,AY,AZ,DEG\" or \"q:W,X,Y,Z\"",
                       rotation);
        return -1;
    }
    /* note: seed alone selects a random rotation, as the CLI's --seed does */
    if (!rotation && get(options, "seed"))
        s->rotation_mode = EPSNET_ROTATION_SEED;
    return 0;
}
