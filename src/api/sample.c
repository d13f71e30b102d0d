/*
 * epsnet_sample_file(): the classification. Sample points stream through
 * the pipeline (src/api/stream_files.c); the whole-mesh view is read into
 * one slab that owns every vertex — the one-slab case of the per-slab core
 * (docs/architecture.md §14) — classified, and written with a flag per vertex.
 */
#include <stdio.h>
#include <string.h>

#include "api/jobs.h"
#include "api/stream_files.h"
#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"
#include "io/samples_ply.h"

int epsnet_sample_file(epsnet_context *ctx, const char *in_path, const char *out_path,
                       epsnet_sample_output what, int ascii, epsnet_error *err)
{
    if (!ctx || !in_path || !out_path)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_sample_file: NULL argument");
    memset(&ctx->stats, 0, sizeof ctx->stats);
    snprintf(ctx->command, sizeof ctx->command, "sample");
    if (what == EPSNET_SAMPLES_POINTS)
        return en_sample_points_streamed(ctx, in_path, out_path, ascii, err);
    /* The whole mesh with a flag per vertex: in memory, as one slab. */
    ctx->stats.gaussian_vertices = ctx->sphere.nverts;
    en_slab slab;
    en_slab_init(&slab);
    en_classification c = { 0 };
    uint8_t *is_sample = NULL;
    epsnet_coord_type ct = EPSNET_COORD_FLOAT32;
    int rc = en_job_load(ctx, in_path, NULL, &slab, &ct, err);
    if (rc == 0)
        rc = en_job_classify(ctx, &ctx->sphere, &slab, &c, in_path, err);
    if (rc == 0) {
        is_sample = en_malloc((size_t)slab.nv + 1);
        if (!is_sample)
            rc = en_error_set(err, EPSNET_ENOMEM, in_path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    if (rc == 0) {
        double t0 = en_now();
        for (uint32_t v = 0; v < slab.nv; v++)
            is_sample[v] = (c.vclass[v] & EN_C_SAMPLE) != 0;
        if (what == EPSNET_SAMPLES_MESH)
            rc = en_write_sample_mesh(out_path, ascii, ct, slab.nv, slab.pos, is_sample, c.vgvertex, slab.nt,
                                      slab.tri, err);
        else
            rc = en_write_sample_points(out_path, ascii, ct, slab.nv, slab.pos, is_sample, c.vgvertex, err);
        ctx->stats.seconds_write = en_now() - t0;
        en_job_count(ctx, &c.counts);
    }
    ctx->stats.peak_rss = en_peak_rss_bytes();
    en_free(is_sample);
    en_classification_free(&c);
    en_slab_free(&slab);
    return rc;
}
