/*
 * A mesh file into arrays, through the library's reader (epsnet.h §3): any
 * readable format, optionally .zst, its vertex attributes as columns. It is
 * what the tests compare the CLI's output with, and a user's way to load
 * what the CLI wrote. Finalizations are skipped: arrays hold the whole mesh.
 */
#include <stdlib.h>

#include "binding.h"

typedef struct loaded {
    double *xyz;                     /* 3 per vertex */
    int64_t *tri;                    /* 3 per face */
    uint8_t *attr[EPSNET_ATTR_MAX];  /* one column per attribute */
    uint64_t nv, nt, vcap, tcap;
    epsnet_attr_layout layout;
    epsnet_coord_type ct;
} loaded;

static void loaded_free(loaded *m)
{
    free(m->xyz);
    free(m->tri);
    for (uint32_t i = 0; i < EPSNET_ATTR_MAX; i++)
        free(m->attr[i]);
}

static int grow(void **p, uint64_t n, size_t each)
{
    void *q = realloc(*p, (size_t)(n * each) + 1);
    if (!q)
        return -1;
    *p = q;
    return 0;
}

/* Fill err for an allocation of ours that failed. @return EPSNET_ENOMEM. */
static int nomem(epsnet_error *err, const char *path)
{
    memset(err, 0, sizeof *err);
    err->code = EPSNET_ENOMEM;
    snprintf(err->file, sizeof err->file, "%s", path);
    err->line = err->offset = EPSNET_POS_NONE;
    snprintf(err->reason, sizeof err->reason, "out of memory holding the mesh");
    return EPSNET_ENOMEM;
}

/* Read every record of path into m. @return 0 or a negative code. */
static int load(const char *path, loaded *m, epsnet_error *err)
{
    epsnet_reader *r = NULL;
    int rc = epsnet_reader_open(&r, path, NULL, err);
    if (rc)
        return rc;
    m->layout = epsnet_reader_info(r)->vertex_attrs;
    m->ct = epsnet_reader_info(r)->coord_type;
    epsnet_record rec;
    while ((rc = epsnet_reader_next(r, &rec, err)) == 1) {
        if (rec.kind == EPSNET_REC_VERTEX) {
            if (m->nv == m->vcap) {
                m->vcap = m->vcap ? 2 * m->vcap : 4096;
                int bad = grow((void **)&m->xyz, m->vcap, 3 * sizeof(double));
                for (uint32_t i = 0; !bad && i < m->layout.count; i++)
                    bad = grow((void **)&m->attr[i], m->vcap, epsnet_attr_type_size(m->layout.attr[i].type));
                if (bad) {
                    rc = EPSNET_ENOMEM;
                    break;
                }
            }
            memcpy(m->xyz + 3 * m->nv, rec.xyz, sizeof rec.xyz);
            for (uint32_t i = 0; i < m->layout.count; i++) {
                size_t n = epsnet_attr_type_size(m->layout.attr[i].type);
                memcpy(m->attr[i] + n * m->nv, rec.attr + m->layout.attr[i].offset, n);
            }
            m->nv++;
        } else if (rec.kind == EPSNET_REC_TRIANGLE) {
            if (m->nt == m->tcap) {
                m->tcap = m->tcap ? 2 * m->tcap : 4096;
                if (grow((void **)&m->tri, m->tcap, 3 * sizeof(int64_t))) {
                    rc = EPSNET_ENOMEM;
                    break;
                }
            }
            for (int k = 0; k < 3; k++)
                m->tri[3 * m->nt + (uint64_t)k] = (int64_t)rec.v[k];
            m->nt++;
        }
    }
    epsnet_reader_close(&r);
    if (rc == EPSNET_ENOMEM && err->code != EPSNET_ENOMEM)
        nomem(err, path);
    return rc < 0 ? rc : 0;
}

PyObject *eb_read_mesh(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *path;
    if (!PyArg_ParseTuple(args, "O&:read_mesh", PyUnicode_FSConverter, &path))
        return NULL;
    loaded m;
    memset(&m, 0, sizeof m);
    epsnet_error err = { 0 };
    int rc;
    const char *p = PyBytes_AS_STRING(path);
    Py_BEGIN_ALLOW_THREADS
    rc = load(p, &m, &err);
    if (rc == 0 && m.ct == EPSNET_COORD_FLOAT32 && m.xyz) {
        /* note: exact: the file's coordinates were float32 */
        float *f = malloc(3 * sizeof *f * (size_t)m.nv + 1);
        for (uint64_t i = 0; f && i < 3 * m.nv; i++)
            f[i] = (float)m.xyz[i];
        free(m.xyz);
        m.xyz = (double *)(void *)f;
        if (!f)
            rc = nomem(&err, p);
    }
    Py_END_ALLOW_THREADS
    Py_DECREF(path);
    if (rc) {
        loaded_free(&m);
        return eb_raise(rc, &err);
    }
    PyObject *mesh = eb_mesh_out((void **)&m.xyz, m.ct == EPSNET_COORD_FLOAT32 ? NPY_FLOAT32 : NPY_FLOAT64, m.nv,
                                 (void **)&m.tri, NPY_INT64, m.nt, &m.layout, (void **)m.attr, 0);
    loaded_free(&m); /* what was not handed over */
    return mesh;
}
