/*
 * epsnet_sample_file(): the whole-mesh run of the classification. The mesh is
 * read into one slab that owns every vertex — the one-slab case of the
 * per-slab core (SPEC §2) — classified, and written as samples.
 */
#include <stdio.h>
#include <string.h>

#include "api/context.h"
#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"
#include "core/classify.h"
#include "core/slab.h"
#include "io/samples_ply.h"

typedef struct sample_arrays {
    double *fnormal;
    int32_t *ftri;
    uint8_t *vclass;
    int32_t *vgvertex;
    uint8_t *is_sample;
} sample_arrays;

static void arrays_free(sample_arrays *a)
{
    en_free(a->fnormal);
    en_free(a->ftri);
    en_free(a->vclass);
    en_free(a->vgvertex);
    en_free(a->is_sample);
    memset(a, 0, sizeof *a);
}

static int arrays_alloc(sample_arrays *a, const en_slab *s)
{
    a->fnormal = en_malloc(3 * sizeof *a->fnormal * (size_t)s->nt + 1);
    a->ftri = en_malloc(sizeof *a->ftri * (size_t)s->nt + 1);
    a->vclass = en_calloc((size_t)s->nv + 1, sizeof *a->vclass);
    a->vgvertex = en_malloc(sizeof *a->vgvertex * (size_t)s->nv + 1);
    a->is_sample = en_malloc((size_t)s->nv + 1);
    return a->fnormal && a->ftri && a->vclass && a->vgvertex && a->is_sample ? 0 : -1;
}

int epsnet_sample_file(epsnet_context *ctx, const char *in_path, const char *out_path,
                       epsnet_sample_output what, int ascii, epsnet_error *err)
{
    if (!ctx || !in_path || !out_path)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_sample_file: NULL argument");
    memset(&ctx->stats, 0, sizeof ctx->stats);
    snprintf(ctx->command, sizeof ctx->command, "sample");
    epsnet_stats *st = &ctx->stats;
    st->gaussian_vertices = ctx->sphere.nverts;

    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    rs.mem_limit = ctx->settings.mem;
    epsnet_reader *r = NULL;
    en_slab slab;
    en_slab_init(&slab);
    sample_arrays a = { 0 };
    en_classify_counts counts = { 0 };

    double t0 = en_now();
    int rc = epsnet_reader_open(&r, in_path, &rs, err);
    epsnet_coord_type ct = EPSNET_COORD_FLOAT32;
    if (rc == 0) {
        ct = epsnet_reader_info(r)->coord_type;
        rc = en_slab_read_all(&slab, r, err);
    }
    epsnet_reader_close(&r);
    double t1 = en_now();
    st->seconds_read = t1 - t0;
    if (rc)
        goto out;
    st->vertices = slab.nv;
    st->faces = slab.nt;
    st->max_active = (uint64_t)slab.nv + slab.nt;
    if (arrays_alloc(&a, &slab)) {
        rc = en_error_set(err, EPSNET_ENOMEM, in_path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                          "out of memory for the classification of %u vertices", slab.nv);
        goto out;
    }
    uint32_t bad_face = 0;
    rc = en_classify_faces(&ctx->sphere, &slab, 0, slab.nt, a.fnormal, a.ftri, &counts, &bad_face);
    if (rc) {
        rc = en_error_set(err, rc, in_path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                          rc == EPSNET_EFORMAT ? "face %u: its normal overflows (coordinates too large)"
                                               : "face %u: Gaussian point location failed (a bug)",
                          bad_face + 1);
        goto out;
    }
    double t2 = en_now();
    st->seconds_normals = t2 - t1;
    if (en_classify_vertices(&ctx->sphere, &slab, a.fnormal, a.ftri, 0, slab.nv, a.vclass, a.vgvertex, &counts)) {
        rc = en_error_set(err, EPSNET_ENOMEM, in_path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                          "out of memory classifying vertices");
        goto out;
    }
    double t3 = en_now();
    st->seconds_classify = t3 - t2;

    for (uint32_t v = 0; v < slab.nv; v++)
        a.is_sample[v] = (a.vclass[v] & EN_C_SAMPLE) != 0;
    if (what == EPSNET_SAMPLES_MESH)
        rc = en_write_sample_mesh(out_path, ascii, ct, slab.nv, slab.pos, a.is_sample, a.vgvertex,
                                  slab.nt, slab.tri, err);
    else
        rc = en_write_sample_points(out_path, ascii, ct, slab.nv, slab.pos, a.is_sample, a.vgvertex, err);
    st->seconds_write = en_now() - t3;

    st->zero_area_faces = counts.zero_area_faces;
    st->feature_edges = counts.feature_edges;
    st->candidates = counts.candidates;
    st->samples = counts.samples;
    st->locked = counts.locked;
    st->boundary_vertices = counts.boundary;
    st->nonmanifold_vertices = counts.nonmanifold;
    st->needle_vertices = counts.needles;
    st->multi_cover_samples = counts.multi_cover;
out:
    st->peak_rss = en_peak_rss_bytes();
    arrays_free(&a);
    en_slab_free(&slab);
    return rc;
}
