/*
 * What a run says while the GIL is released (epsnet.h §6, settings.progress
 * and settings.warning): the library calls these on its own threads'
 * schedule, so each takes the GIL only for the moment it needs it.
 *
 * Progress: the user's callable gets (done, total), and Ctrl-C is looked
 * for (PyErr_CheckSignals: it acts on the main thread only, which is where
 * Python delivers signals). Either one's exception cancels the run: the
 * callback returns non-zero, the library unwinds with EPSNET_EINTR and
 * removes what it wrote, and the exception, kept here meanwhile (it may
 * have been raised on a thread state that is not the caller's), is raised
 * to the caller when the call returns.
 *
 * Warnings are copied into the run and become Python warnings afterwards.
 */
#include "binding.h"

static int on_progress(void *opaque, uint64_t done, uint64_t total)
{
    eb_run *run = opaque;
    PyGILState_STATE g = PyGILState_Ensure();
    int stop = run->exc != NULL;
    if (!stop && run->progress) {
        PyObject *r = PyObject_CallFunction(run->progress, "KK", (unsigned long long)done,
                                            (unsigned long long)total);
        stop = r == NULL;
        Py_XDECREF(r);
    }
    if (!stop)
        stop = PyErr_CheckSignals() != 0;
    if (stop && !run->exc) {
        PyObject *type, *value, *tb;
        PyErr_Fetch(&type, &value, &tb);
        PyErr_NormalizeException(&type, &value, &tb);
        if (value && tb)
            PyException_SetTraceback(value, tb);
        run->exc = value;
        Py_XDECREF(type);
        Py_XDECREF(tb);
    }
    PyGILState_Release(g);
    return stop;
}

static void on_warning(void *opaque, const char *message)
{
    eb_run *run = opaque;
    if (run->nwarn < EB_WARNINGS_MAX)
        snprintf(run->warn[run->nwarn++], sizeof run->warn[0], "%s", message);
}

void eb_run_attach(eb_run *run, PyObject *progress, epsnet_settings *s)
{
    memset(run, 0, sizeof *run);
    run->progress = progress == Py_None ? NULL : progress;
    s->progress = on_progress;
    s->progress_opaque = run;
    s->warning = on_warning;
    s->warning_opaque = run;
}

PyObject *eb_run_warnings(eb_run *run)
{
    PyObject *list = PyList_New(run->nwarn);
    for (int i = 0; list && i < run->nwarn; i++) {
        PyObject *w = PyUnicode_DecodeUTF8(run->warn[i], (Py_ssize_t)strlen(run->warn[i]), "replace");
        if (!w) {
            Py_DECREF(list);
            return NULL;
        }
        PyList_SET_ITEM(list, i, w);
    }
    return list;
}

void eb_run_restore(eb_run *run)
{
    if (!run->exc)
        return;
    PyErr_SetObject((PyObject *)Py_TYPE(run->exc), run->exc);
    Py_CLEAR(run->exc);
}
