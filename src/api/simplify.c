/*
 * In-core simplification: sampling followed by the removal of non-samples
 * (paper §4.2, §5), repeated under new rotations for the ε-net passes, on
 * the whole mesh as one slab. epsnet_render_file() uses it (it needs the
 * result in memory); epsnet_simplify_file() streams (src/pipeline/).
 */
#include <stdio.h>
#include <string.h>

#include "api/jobs.h"
#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"
#include "core/collapse.h"

/* One pass: classify s under g, collapse its removable vertices, and replace
 * s (and q) by what remains. *removed = vertices collapsed away. */
static int simplify_pass(epsnet_context *ctx, const gauss_sphere *g, en_slab *s, en_quadric **q, double **ref,
                         const char *path, uint64_t *removed, int first, epsnet_error *err)
{
    en_classification c;
    int rc = en_job_classify(ctx, g, s, &c, path, err);
    uint8_t *removable = NULL, *falive = NULL, *valive = NULL;
    uint32_t *tri = NULL;
    if (rc)
        goto out;
    if (first)
        en_job_count(ctx, &c.counts);
    removable = en_malloc((size_t)s->nv + 1);
    valive = en_malloc((size_t)s->nv + 1);
    falive = en_malloc((size_t)s->nt + 1);
    tri = en_malloc(3 * sizeof *tri * (size_t)s->nt + 4);
    if (!removable || !valive || !falive || !tri) {
        rc = en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        goto out;
    }
    uint64_t nremovable = 0;
    for (uint32_t v = 0; v < s->nv; v++) {
        uint8_t f = s->vflags[v];
        removable[v] = (f & EN_V_OWNED) && (f & EN_V_TARGET) &&
                       !(f & (EN_V_BOUNDARY | EN_V_NONMANIFOLD | EN_V_ISOLATED)) && !(c.vclass[v] & EN_C_SAMPLE);
        nremovable += removable[v];
    }
    *removed = 0;
    if (nremovable == 0)
        goto out;
    en_collapse_settings cs = { ctx->settings.max_normal_dev };
    en_collapse_counts cc;
    double t0 = en_now();
    if (en_collapse_slab(s, removable, *q, *ref, &cs, falive, valive, tri, &cc)) {
        rc = en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory simplifying");
        goto out;
    }
    ctx->stats.collapses += cc.collapses;
    ctx->stats.remaining_nonsamples = cc.remaining;
    ctx->stats.refused_link = cc.refused[0];
    ctx->stats.refused_normal = cc.refused[1];
    ctx->stats.refused_zero_area = cc.refused[2];
    ctx->stats.refused_duplicate = cc.refused[3];
    *removed = cc.collapses;
    en_slab next;
    en_quadric *nq = NULL;
    double *nref = NULL;
    if (en_slab_compact(s, tri, falive, *q, *ref, &next, &nq, &nref)) {
        rc = en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory simplifying");
        goto out;
    }
    en_slab_free(s);
    *s = next;
    en_free(*q);
    *q = nq;
    en_free(*ref);
    *ref = nref;
    ctx->stats.seconds_simplify += en_now() - t0;
out:
    en_free(removable);
    en_free(valive);
    en_free(falive);
    en_free(tri);
    en_classification_free(&c);
    return rc;
}

int en_job_simplify(epsnet_context *ctx, const char *in_path, en_slab *slab, epsnet_coord_type *ct,
                    epsnet_error *err)
{
    epsnet_stats *st = &ctx->stats;
    st->gaussian_vertices = ctx->sphere.nverts;
    en_quadric *q = NULL;
    double *ref = NULL;
    *ct = EPSNET_COORD_FLOAT32;
    int rc = en_job_load(ctx, in_path, slab, ct, err);
    if (rc == 0) {
        q = en_malloc(((size_t)slab->nv + 1) * sizeof *q);
        ref = en_malloc(3 * sizeof *ref * ((size_t)slab->nt + 1));
        if (!q || !ref) {
            rc = en_error_set(err, EPSNET_ENOMEM, in_path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        } else {
            en_quadrics_from_faces(slab, q, ref);
        }
    }
    for (int pass = 1; rc == 0 && pass <= ctx->settings.passes; pass++) {
        gauss_sphere g = ctx->sphere;
        if (pass > 1) {
            gauss_rotation r;
            gauss_pass_rotation(ctx->settings.seed, pass, &r);
            gauss_init(&g, ctx->sphere.n, &r);
        }
        uint64_t removed = 0;
        rc = simplify_pass(ctx, &g, slab, &q, &ref, in_path, &removed, pass == 1, err);
        st->passes = (uint64_t)pass;
        if (rc == 0 && removed == 0 && pass > 1)
            break; /* converged: this rotation found nothing more to remove */
    }
    if (rc == 0) {
        st->output_vertices = slab->nv;
        st->output_faces = slab->nt;
    }
    en_free(q);
    en_free(ref);
    return rc;
}
