/*
 * The library's errors as exceptions (epsnet.h §1): one class per code,
 * each also the built-in kind Python code already catches, carrying the C
 * message (file, position, reason) and its parts as attributes.
 *
 *   Error                      every failure of the library
 *   ├ FormatError(ValueError)  malformed input: a bad file, a NaN, an index out of range
 *   ├ ArgumentError(ValueError) a bad option or argument
 *   ├ UnsupportedError(ValueError) valid input the library does not handle
 *   ├ FileError(OSError)       cannot read or write (missing file, full disk)
 *   ├ LimitError(MemoryError)  out of memory, or over a budget (mem=)
 *   └ InternalError(RuntimeError) a bug: an invariant did not hold
 *
 * A run cancelled by Ctrl-C raises KeyboardInterrupt, and one cancelled by
 * an exception of the progress callback raises that exception.
 */
#include <stdarg.h>

#include "binding.h"

static PyObject *error_base, *format_error, *argument_error, *unsupported_error, *file_error, *limit_error,
    *internal_error;

static int add(PyObject *m, PyObject **slot, const char *name, PyObject *builtin, const char *doc)
{
    PyObject *bases = builtin ? PyTuple_Pack(2, error_base, builtin) : PyTuple_Pack(1, PyExc_Exception);
    if (!bases)
        return -1;
    char full[64];
    snprintf(full, sizeof full, "epsnet.%s", name);
    *slot = PyErr_NewExceptionWithDoc(full, doc, bases, NULL);
    Py_DECREF(bases);
    if (!*slot)
        return -1;
    Py_INCREF(*slot);
    if (PyModule_AddObject(m, name, *slot)) {
        Py_DECREF(*slot);
        return -1;
    }
    return 0;
}

int eb_errors_init(PyObject *m)
{
    if (add(m, &error_base, "Error", NULL,
            "A failure of the epsnet library. Attributes: code (the EPSNET_E* number), file, "
            "line and offset (None when unknown), reason."))
        return -1;
    return add(m, &format_error, "FormatError", PyExc_ValueError,
               "Malformed input: a file that breaks its format, a non-finite coordinate, a face index "
               "out of range.") ||
           add(m, &argument_error, "ArgumentError", PyExc_ValueError, "A bad option or argument.") ||
           add(m, &unsupported_error, "UnsupportedError", PyExc_ValueError,
               "Valid input that epsnet does not handle (an unknown format, coordinates beyond 1e75).") ||
           add(m, &file_error, "FileError", PyExc_OSError,
               "A file cannot be read or written (missing, unreadable, a full disk).") ||
           add(m, &limit_error, "LimitError", PyExc_MemoryError, "Out of memory, or over a budget (mem=).") ||
           add(m, &internal_error, "InternalError", PyExc_RuntimeError, "A bug: an invariant did not hold.")
               ? -1
               : 0;
}

static PyObject *class_of(int code)
{
    switch (code) {
    case EPSNET_EFORMAT: return format_error;
    case EPSNET_EINVAL: return argument_error;
    case EPSNET_EUNSUPPORTED: return unsupported_error;
    case EPSNET_EIO: return file_error;
    case EPSNET_ENOMEM:
    case EPSNET_ELIMIT: return limit_error;
    default: return internal_error;
    }
}

static PyObject *position(uint64_t p)
{
    if (p == EPSNET_POS_NONE)
        Py_RETURN_NONE;
    return PyLong_FromUnsignedLongLong(p);
}

/* Set e.name = value, taking the reference. @return -1 on failure. */
static int set(PyObject *e, const char *name, PyObject *value)
{
    int rc = value ? PyObject_SetAttrString(e, name, value) : -1;
    Py_XDECREF(value);
    return rc;
}

PyObject *eb_raise(int code, const epsnet_error *err)
{
    if (PyErr_Occurred())
        return NULL;
    if (code == EPSNET_EINTR) {
        /* note: only a signal or a cancelling callback interrupts; the
         * callback's exception was restored already, so this is Ctrl-C */
        PyErr_SetNone(PyExc_KeyboardInterrupt);
        return NULL;
    }
    int known = err && err->code;
    PyObject *cls = class_of(code);
    const char *msg = known ? epsnet_error_message(err) : epsnet_strerror(code);
    const char *why = known ? err->reason : msg;
    PyObject *e = PyObject_CallFunction(cls, "s", msg);
    if (!e)
        return NULL;
    if (set(e, "code", PyLong_FromLong(code)) ||
        set(e, "file", known && err->file[0] ? PyUnicode_DecodeFSDefault(err->file) : Py_NewRef(Py_None)) ||
        set(e, "line", position(known ? err->line : EPSNET_POS_NONE)) ||
        set(e, "offset", position(known ? err->offset : EPSNET_POS_NONE)) ||
        set(e, "reason", PyUnicode_DecodeUTF8(why, (Py_ssize_t)strlen(why), "replace"))) {
        Py_DECREF(e);
        return NULL;
    }
    PyErr_SetObject(cls, e);
    Py_DECREF(e);
    return NULL;
}

PyObject *eb_value_error(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    PyObject *msg = PyUnicode_FromFormatV(fmt, ap);
    va_end(ap);
    if (msg) {
        PyErr_SetObject(argument_error, msg);
        Py_DECREF(msg);
    }
    return NULL;
}
