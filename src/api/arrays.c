/*
 * Meshes in the caller's arrays (epsnet.h §13, docs/architecture.md §14):
 * simplify, sample and measure them with the very paths files take. The
 * input is a reader over the arrays (io/arrays_reader.c), so a
 * simplification is the file run's (stream_files.c: sort, chain) with a
 * collector as its output stage instead of a writer: the records a writer
 * would put in the file, in the same order, land in growing arrays.
 */
#include <stdio.h>
#include <string.h>

#include "api/context.h"
#include "api/jobs.h"
#include "api/stream_files.h"
#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"

void epsnet_free(void *p)
{
    en_free(p);
}

void epsnet_arrays_out_free(epsnet_arrays_out *out)
{
    if (!out)
        return;
    en_free(out->xyz);
    en_free(out->faces);
    for (uint32_t i = 0; i < EPSNET_ATTR_MAX; i++)
        en_free(out->attr[i]);
    memset(out, 0, sizeof *out);
}

/* The output stage: vertex records append a row to xyz and to every
 * attribute column, triangle records a row to faces; finalizations say
 * nothing an array needs. Rows grow by doubling, at most to the input's
 * counts (every output vertex is an input vertex, method §11). */
typedef struct collector {
    epsnet_arrays_out *out;
    const char *name;
    uint64_t in_verts;
    uint64_t vcap, fcap;          /* rows the buffers hold */
    size_t xyz_bytes;             /* of one coordinate */
} collector;

static int grow(void **p, uint64_t rows, size_t row_bytes)
{
    size_t n = (size_t)(rows * row_bytes);
    void *q = en_realloc(*p, n ? n : 1);
    if (!q)
        return -1;
    *p = q;
    return 0;
}

static uint64_t next_cap(uint64_t cap, uint64_t bound)
{
    uint64_t n = cap < 4096 ? 4096 : 2 * cap;
    return bound > cap && n > bound ? bound : n;
}

static int collect_vertex(collector *c, const epsnet_record *rec, epsnet_error *err)
{
    epsnet_arrays_out *o = c->out;
    if (o->nverts == c->vcap) {
        uint64_t cap = next_cap(c->vcap, c->in_verts);
        int bad = grow(&o->xyz, cap, 3 * c->xyz_bytes);
        for (uint32_t i = 0; !bad && i < o->attrs.count; i++)
            bad = grow(&o->attr[i], cap, epsnet_attr_type_size(o->attrs.attr[i].type));
        if (bad)
            return en_error_set(err, EPSNET_ENOMEM, c->name, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "out of memory collecting %llu output vertices", (unsigned long long)cap);
        c->vcap = cap;
    }
    uint64_t v = o->nverts++;
    if (o->coord_type == EPSNET_COORD_FLOAT32) {
        /* note: exact: every output vertex is an input float32 vertex */
        float *f = (float *)o->xyz + 3 * v;
        f[0] = (float)rec->xyz[0], f[1] = (float)rec->xyz[1], f[2] = (float)rec->xyz[2];
    } else {
        memcpy((double *)o->xyz + 3 * v, rec->xyz, 3 * sizeof(double));
    }
    for (uint32_t i = 0; i < o->attrs.count; i++) {
        size_t n = epsnet_attr_type_size(o->attrs.attr[i].type);
        memcpy((uint8_t *)o->attr[i] + n * v, rec->attr + o->attrs.attr[i].offset, n);
    }
    return 0;
}

static int collect_face(collector *c, const epsnet_record *rec, epsnet_error *err)
{
    epsnet_arrays_out *o = c->out;
    for (int k = 0; k < 3; k++)
        if (rec->v[k] >= o->nverts)
            return en_error_set(err, EPSNET_EINTERNAL, c->name, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "output face %llu names vertex %llu of %llu", (unsigned long long)o->nfaces,
                                (unsigned long long)rec->v[k], (unsigned long long)o->nverts);
    if (o->nfaces == c->fcap) {
        uint64_t cap = next_cap(c->fcap, 0);
        if (grow(&o->faces, cap, 3 * (size_t)o->index_bytes))
            return en_error_set(err, EPSNET_ENOMEM, c->name, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "out of memory collecting %llu output faces", (unsigned long long)cap);
        c->fcap = cap;
    }
    uint64_t f = o->nfaces++;
    for (int k = 0; k < 3; k++) {
        if (o->index_bytes == 4)
            ((int32_t *)o->faces)[3 * f + (uint64_t)k] = (int32_t)rec->v[k];
        else
            ((int64_t *)o->faces)[3 * f + (uint64_t)k] = (int64_t)rec->v[k];
    }
    return 0;
}

static int collect_put(void *self, const epsnet_record *rec, epsnet_error *err)
{
    if (rec->kind == EPSNET_REC_VERTEX)
        return collect_vertex(self, rec, err);
    if (rec->kind == EPSNET_REC_TRIANGLE)
        return collect_face(self, rec, err);
    return 0;
}

/* The stream's layout is known once the input is (its attributes, as the
 * sort carries them: all of the arrays' columns). */
static int open_collector(void *opaque, const epsnet_mesh_info *in, struct en_pool *pool, en_stage *out,
                          epsnet_error *err)
{
    (void)pool;
    (void)err;
    collector *c = opaque;
    c->out->attrs = in->vertex_attrs;
    *out = (en_stage){ collect_put, NULL, c };
    return 0;
}

int epsnet_simplify_arrays(epsnet_context *ctx, const epsnet_arrays *in, epsnet_arrays_out *out, epsnet_error *err)
{
    if (out)
        memset(out, 0, sizeof *out);
    if (!ctx || !in || !out)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_simplify_arrays: NULL argument");
    snprintf(ctx->command, sizeof ctx->command, "simplify");
    const char *name = in->name ? in->name : "arrays";
    out->coord_type = in->coord_type;
    out->index_bytes = in->index_bytes;
    collector c = { out, name, in->nverts, 0, 0, in->coord_type == EPSNET_COORD_FLOAT32 ? sizeof(float) : sizeof(double) };
    int rc = en_simplify_streamed(ctx, name, in, NULL, NULL, open_collector, NULL, &c, err);
    if (rc)
        epsnet_arrays_out_free(out);
    else
        en_warn_unreferenced(ctx, name, "in the output");
    ctx->stats.peak_rss = en_peak_rss_bytes();
    return rc;
}

int epsnet_sample_arrays(epsnet_context *ctx, const epsnet_arrays *in, uint8_t *is_sample, int32_t *gvertex,
                         epsnet_error *err)
{
    if (!ctx || !in || ((!is_sample || !gvertex) && in->nverts))
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_sample_arrays: NULL argument");
    memset(&ctx->stats, 0, sizeof ctx->stats);
    snprintf(ctx->command, sizeof ctx->command, "sample");
    ctx->stats.gaussian_vertices = ctx->sphere.nverts;
    const char *name = in->name ? in->name : "arrays";
    en_slab slab;
    en_slab_init(&slab);
    en_classification c = { 0 };
    epsnet_coord_type ct;
    int rc = en_job_load(ctx, name, in, &slab, &ct, err);
    if (rc == 0)
        rc = en_job_classify(ctx, &ctx->sphere, &slab, &c, name, err);
    if (rc == 0) {
        /* note: the slab owns every vertex in input order (en_slab_read) */
        for (uint32_t v = 0; v < slab.nv; v++) {
            is_sample[v] = (c.vclass[v] & EN_C_SAMPLE) != 0;
            gvertex[v] = c.vgvertex[v];
        }
        en_job_count(ctx, &c.counts);
    }
    ctx->stats.peak_rss = en_peak_rss_bytes();
    en_classification_free(&c);
    en_slab_free(&slab);
    return rc;
}
