/* Helpers for sampling tests: generate or build a mesh, classify it. */
#ifndef EPSNET_TEST_SAMPLE_UTIL_H
#define EPSNET_TEST_SAMPLE_UTIL_H

#include "common/alloc.h"
#include "core/classify.h"
#include "core/gauss.h"
#include "core/slab.h"
#include "testlib.h"

typedef struct classified {
    double *fnormal;
    int32_t *ftri;
    uint8_t *vclass;
    int32_t *vgvertex;
    en_classify_counts counts;
} classified;

static inline void classified_free(classified *c)
{
    free(c->fnormal);
    free(c->ftri);
    free(c->vclass);
    free(c->vgvertex);
    memset(c, 0, sizeof *c);
}

static inline int classify_all(const gauss_sphere *g, const en_slab *s, classified *c)
{
    memset(c, 0, sizeof *c);
    c->fnormal = malloc(3 * sizeof(double) * (s->nt + 1));
    c->ftri = malloc(sizeof(int32_t) * (s->nt + 1));
    c->vclass = calloc(s->nv + 1, 1);
    c->vgvertex = malloc(sizeof(int32_t) * (s->nv + 1));
    uint32_t bad;
    if (en_classify_faces(g, s, 0, s->nt, c->fnormal, c->ftri, &c->counts, &bad))
        return -1;
    return en_classify_vertices(g, s, c->fnormal, c->ftri, 0, s->nv, c->vclass, c->vgvertex, &c->counts);
}

/* Generate shape into a temporary file and read it into a one-slab slab. */
static inline int gen_slab(const char *shape, uint64_t faces, double param, uint64_t seed, int shuffle,
                           en_slab *s)
{
    epsnet_error err;
    char name[128];
    snprintf(name, sizeof name, "gen_%s_%llu_%d.smb", shape, (unsigned long long)faces, shuffle);
    const char *path = tl_path(name);
    int rc = tl_gen_file(path, shape, faces, param, seed, shuffle, &err);
    epsnet_reader *r = NULL;
    if (rc == 0)
        rc = epsnet_reader_open(&r, path, NULL, &err);
    en_slab_init(s);
    if (rc == 0)
        rc = en_slab_read_all(s, r, path, &err);
    epsnet_reader_close(&r);
    remove(path);
    if (rc)
        fprintf(stderr, "gen_slab(%s): %s\n", shape, epsnet_error_message(&err));
    return rc;
}

#endif
