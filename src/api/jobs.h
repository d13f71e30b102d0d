/* The whole-mesh classification behind `sample --mesh` and render's
 * samples panel: the one-slab case of the per-slab core (docs/
 * architecture.md §14). Simplification always runs through the stage chain. */
#ifndef EN_API_JOBS_H
#define EN_API_JOBS_H

#include "api/context.h"
#include "core/classify.h"
#include "core/slab.h"

/* Per-slab classification results. */
typedef struct en_classification {
    double *fnormal;      /* 3 per face, G frame */
    int32_t *ftri;        /* Gaussian triangle per face, -1 zero-area */
    uint8_t *vclass;      /* EN_C_* per vertex */
    int32_t *vgvertex;    /* covered Gaussian vertex per vertex, -1 none */
    en_classify_counts counts;
} en_classification;

void en_classification_free(en_classification *c);

/* Read in_path, or arrays when not NULL (in_path then names them), into a
 * one-slab slab (every vertex owned, in input order, every star complete);
 * stats: vertices, faces, seconds_read. */
int en_job_load(epsnet_context *ctx, const char *in_path, const epsnet_arrays *arrays, en_slab *s,
                epsnet_coord_type *ct, epsnet_error *err);

/* Classify every face and vertex of s against g; adds the stage times to
 * ctx->stats. path names the input in messages. */
int en_job_classify(epsnet_context *ctx, const gauss_sphere *g, const en_slab *s, en_classification *c,
                    const char *path, epsnet_error *err);

/* Copy classification counts into ctx->stats. */
void en_job_count(epsnet_context *ctx, const en_classify_counts *c);

#endif
