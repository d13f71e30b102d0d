#include "pipeline/slab_work.h"

#include <string.h>

#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"

void en_slab_work_init(en_slab_work *w)
{
    memset(w, 0, sizeof *w);
    en_slab_init(&w->s);
}

void en_slab_work_free(en_slab_work *w)
{
    en_slab_free(&w->s);
    en_free(w->owner);
    en_free(w->fflags);
    en_free(w->vclass);
    en_free(w->vgvertex);
    en_free(w->q);
    en_free(w->ref);
    en_free(w->tri);
    en_free(w->falive);
    en_free(w->valive);
    en_free(w->border);
    en_free(w->future);
    en_free(w->degree);
    en_free(w->band);
    en_slab_work_init(w);
}

static int oom(en_slab_work *w)
{
    return en_error_set(&w->err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "out of memory in slab %u (%u vertices, %u faces)", w->index, w->s.nv, w->s.nt);
}

static int classify(en_slab_work *w)
{
    const en_slab *s = &w->s;
    double *fnormal = en_malloc(3 * sizeof *fnormal * (size_t)s->nt + 8);
    int32_t *ftri = en_malloc(sizeof *ftri * (size_t)s->nt + 8);
    w->vclass = en_calloc((size_t)s->nv + 1, sizeof *w->vclass);
    w->vgvertex = en_malloc(sizeof *w->vgvertex * (size_t)s->nv + 8);
    int rc = 0;
    if (!fnormal || !ftri || !w->vclass || !w->vgvertex) {
        rc = oom(w);
        goto out;
    }
    en_classify_counts faces;
    memset(&faces, 0, sizeof faces);
    uint32_t bad = 0;
    rc = en_classify_faces(w->g, s, 0, s->nt, fnormal, ftri, &faces, &bad);
    if (rc) {
        const uint32_t *t = s->tri + 3 * (size_t)bad;
        rc = en_error_set(&w->err, rc, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                          rc == EPSNET_EFORMAT
                              ? "face (%llu %llu %llu): its normal overflows (coordinates too large)"
                              : "face (%llu %llu %llu): Gaussian point location failed (a bug)",
                          (unsigned long long)s->gid[t[0]], (unsigned long long)s->gid[t[1]],
                          (unsigned long long)s->gid[t[2]]);
        goto out;
    }
    if (en_classify_vertices(w->g, s, fnormal, ftri, 0, w->nowned, w->vclass, w->vgvertex, &w->counts)) {
        rc = oom(w);
        goto out;
    }
    /* A face is held by every slab owning one of its corners: count it once, at its home. */
    for (uint32_t f = 0; f < s->nt; f++)
        w->counts.zero_area_faces += ftri[f] < 0 && (w->fflags[f] & EN_F_HOME);
out:
    en_free(fnormal);
    en_free(ftri);
    return rc;
}

static int owned_here(const en_slab_work *w, uint32_t v)
{
    return v < w->nowned;
}

/* Frozen: an owned vertex with a face that is not interior, i.e. a neighbour
 * owned elsewhere. Only inner vertices may collapse or be collapsed onto. */
static void mark_frozen(en_slab_work *w)
{
    en_slab *s = &w->s;
    for (uint32_t v = 0; v < w->nowned; v++) {
        w->border[v] = EN_BORDER_INNER;
        for (uint32_t i = s->star_start[v]; i < s->star_start[v + 1]; i++)
            if (!(w->fflags[s->star[i]] & EN_F_INTERIOR))
                w->border[v] = EN_BORDER_FROZEN;
    }
    /* The band whose treatment the seam density is measured on (stats). */
    for (uint32_t v = 0; v < w->nowned; v++) {
        if (w->border[v] != EN_BORDER_FROZEN)
            continue;
        w->band[v] = 1;
        for (uint32_t i = s->star_start[v]; i < s->star_start[v + 1]; i++) {
            const uint32_t *t = s->tri + 3 * (size_t)s->star[i];
            for (int k = 0; k < 3; k++)
                if (owned_here(w, t[k]))
                    w->band[t[k]] = 1;
        }
    }
}

/* After the collapses: the ring of inner vertices next to a frozen one, and
 * the outer corners of their faces, go to the stitcher with them. */
static void mark_bands(en_slab_work *w)
{
    const en_slab *s = &w->s;
    for (int pass = 0; pass < 2; pass++) {
        uint8_t from = pass == 0 ? EN_BORDER_FROZEN : EN_BORDER_RING;
        uint8_t to = pass == 0 ? EN_BORDER_RING : EN_BORDER_OUTER;
        for (uint32_t f = 0; f < s->nt; f++) {
            if (!w->falive[f])
                continue;
            const uint32_t *t = w->tri + 3 * (size_t)f;
            int hit = 0;
            for (int k = 0; k < 3; k++)
                hit |= owned_here(w, t[k]) &&
                       (w->border[t[k]] == from || (pass == 1 && w->border[t[k]] == EN_BORDER_FROZEN));
            if (!hit)
                continue;
            for (int k = 0; k < 3; k++)
                if (owned_here(w, t[k]) && w->border[t[k]] == EN_BORDER_INNER)
                    w->border[t[k]] = to;
        }
    }
    for (uint32_t f = 0; f < s->nt; f++) {
        if (!w->falive[f])
            continue;
        const uint32_t *t = w->tri + 3 * (size_t)f;
        for (int k = 0; k < 3; k++) {
            if (!owned_here(w, t[k]))
                continue;
            w->degree[t[k]]++;
            w->future[t[k]] += !(w->fflags[f] & EN_F_HOME);
        }
    }
}

static int simplify(en_slab_work *w)
{
    en_slab *s = &w->s;
    size_t nv = (size_t)s->nv + 1, nt = (size_t)s->nt + 1;
    w->q = en_malloc(nv * sizeof *w->q);
    w->ref = en_malloc(3 * nt * sizeof *w->ref);
    w->tri = en_malloc(3 * nt * sizeof *w->tri);
    w->falive = en_malloc(nt);
    w->valive = en_malloc(nv);
    w->border = en_calloc(nv, 1);
    w->future = en_calloc(nv, sizeof *w->future);
    w->degree = en_calloc(nv, sizeof *w->degree);
    w->band = en_calloc(nv, 1);
    uint8_t *removable = en_calloc(nv, 1);
    int rc = 0;
    if (!w->q || !w->ref || !w->tri || !w->falive || !w->valive || !w->border || !w->future || !w->degree ||
        !w->band || !removable) {
        rc = oom(w);
        goto out;
    }
    en_quadrics_from_faces(s, w->q, w->ref);
    mark_frozen(w);
    /* The seam rules (pipeline/seam.h): an owned inner vertex has its whole
     * star here; a frozen one and the ghosts do not. */
    uint64_t nremovable = 0;
    for (uint32_t v = 0; v < s->nv; v++) {
        en_vertex_kind k = EN_VK_OPEN;
        if (owned_here(w, v))
            k = en_vertex_kind_of(w->border[v] == EN_BORDER_INNER, 0, en_seam_locked(s->vflags[v]),
                                  (w->vclass[v] & EN_C_SAMPLE) != 0);
        removable[v] = (uint8_t)en_removable(k);
        s->vflags[v] = (uint8_t)((s->vflags[v] & ~EN_V_TARGET) | (en_receives(k) ? EN_V_TARGET : 0));
        nremovable += removable[v];
        if (!owned_here(w, v))
            continue;
        int nonsample = !(s->vflags[v] & EN_V_ISOLATED) && !(w->vclass[v] & EN_C_SAMPLE);
        w->band_nonsamples += nonsample && w->band[v];
        w->inner_nonsamples += nonsample && !w->band[v];
    }
    en_collapse_settings cs = { w->max_normal_dev };
    en_collapse_counts cc;
    if (nremovable == 0) {
        if (s->nt) /* a slab of isolated vertices has no face array at all */
            memcpy(w->tri, s->tri, 3 * sizeof *w->tri * (size_t)s->nt);
        memset(w->falive, 1, nt);
        memset(w->valive, 1, nv);
    } else if (en_collapse_slab(s, removable, w->q, w->ref, &cs, w->falive, w->valive, w->tri, &cc)) {
        rc = oom(w);
        goto out;
    } else {
        w->collapses = cc.collapses;
        memcpy(w->refused, cc.refused, sizeof w->refused);
    }
    mark_bands(w);
out:
    en_free(removable);
    return rc;
}

int en_slab_work_run(void *arg)
{
    en_slab_work *w = arg;
    double t0 = en_now();
    en_error_clear(&w->err);
    if (en_slab_build_stars(&w->s))
        w->rc = oom(w);
    else
        w->rc = classify(w);
    if (w->rc == 0 && w->mode == EN_SLAB_SIMPLIFY)
        w->rc = simplify(w);
    w->seconds = en_now() - t0;
    return w->rc;
}
