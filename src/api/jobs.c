#include "api/jobs.h"

#include <string.h>

#include "api/budget.h"
#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"
#include "io/format.h"

void en_classification_free(en_classification *c)
{
    en_free(c->fnormal);
    en_free(c->ftri);
    en_free(c->vclass);
    en_free(c->vgvertex);
    memset(c, 0, sizeof *c);
}

int en_job_load(epsnet_context *ctx, const char *in_path, const epsnet_arrays *arrays, en_slab *s,
                epsnet_coord_type *ct, epsnet_error *err)
{
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    en_budget b; /* the whole mesh in memory: all of the budget is the reader's */
    en_budget_split(&b, &ctx->settings, EN_BUDGET_IN_CORE);
    rs.mem_limit = b.reader;
    epsnet_reader *r = NULL;
    double t0 = en_now();
    int rc = arrays ? epsnet_reader_open_arrays(&r, arrays, &rs, err) : epsnet_reader_open(&r, in_path, &rs, err);
    if (rc == 0) {
        /* note: the in-core jobs' outputs carry no attributes: named as
         * dropped, never lost silently (docs/architecture.md §5) */
        en_reader_keep_attrs(r, NULL, 0, 0);
        *ct = epsnet_reader_info(r)->coord_type;
        rc = en_slab_read_all(s, r, in_path, err);
    }
    if (rc == 0)
        ctx->stats.dropped = en_reader_warn_dropped(r, ctx->settings.warning, ctx->settings.warning_opaque);
    epsnet_reader_close(&r);
    ctx->stats.seconds_read += en_now() - t0;
    ctx->stats.vertices = s->nv;
    ctx->stats.faces = s->nt;
    ctx->stats.max_active = (uint64_t)s->nv + s->nt;
    return rc;
}

int en_job_classify(epsnet_context *ctx, const gauss_sphere *g, const en_slab *s, en_classification *c,
                    const char *path, epsnet_error *err)
{
    memset(c, 0, sizeof *c);
    c->fnormal = en_malloc(3 * sizeof *c->fnormal * (size_t)s->nt + 8);
    c->ftri = en_malloc(sizeof *c->ftri * (size_t)s->nt + 8);
    c->vclass = en_calloc((size_t)s->nv + 1, sizeof *c->vclass);
    c->vgvertex = en_malloc(sizeof *c->vgvertex * (size_t)s->nv + 8);
    if (!c->fnormal || !c->ftri || !c->vclass || !c->vgvertex)
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory for the classification of %u vertices", s->nv);
    double t0 = en_now();
    uint32_t bad_face = 0;
    int rc = en_classify_faces(g, s, 0, s->nt, c->fnormal, c->ftri, &c->counts, &bad_face);
    if (rc)
        return en_error_set(err, rc, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            rc == EPSNET_EFORMAT ? "face %u: its normal overflows (coordinates too large)"
                                                 : "face %u: Gaussian point location failed (a bug)",
                            bad_face + 1);
    double t1 = en_now();
    rc = en_classify_vertices(g, s, c->fnormal, c->ftri, 0, s->nv, c->vclass, c->vgvertex, &c->counts);
    ctx->stats.seconds_normals += t1 - t0;
    ctx->stats.seconds_classify += en_now() - t1;
    if (rc)
        return en_error_set(err, rc, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory classifying vertices");
    return 0;
}

void en_job_count(epsnet_context *ctx, const en_classify_counts *c)
{
    epsnet_stats *st = &ctx->stats;
    st->zero_area_faces = c->zero_area_faces;
    st->feature_edges = c->feature_edges;
    st->candidates = c->candidates;
    st->samples = c->samples;
    st->locked = c->locked;
    st->boundary_vertices = c->boundary;
    st->nonmanifold_vertices = c->nonmanifold;
    st->seam_vertices = c->seam;
    st->cut_end_vertices = c->cut_ends;
    st->needle_vertices = c->needles;
    st->multi_cover_samples = c->multi_cover;
    st->isolated_vertices = c->isolated;
}
