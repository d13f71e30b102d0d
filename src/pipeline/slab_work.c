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
    en_free(w->fnormal);
    en_free(w->ftri);
    en_free(w->removable);
    en_slab_work_init(w);
}

void en_slab_work_reset(en_slab_work *w)
{
    en_slab_work keep = *w;
    en_slab_work_init(w);
    en_slab_reset(&keep.s);
    w->s = keep.s;
#define KEEP(field) w->field = keep.field
    KEEP(owner), KEEP(fflags), KEEP(vclass), KEEP(vgvertex), KEEP(q), KEEP(ref), KEEP(tri), KEEP(falive);
    KEEP(valive), KEEP(border), KEEP(future), KEEP(degree), KEEP(band), KEEP(fnormal), KEEP(ftri), KEEP(removable);
    KEEP(cap);
#undef KEEP
}

/* Room for n elements in *p, grown only when the last job's was too small. */
static int room(void *p, size_t *cap, size_t n, size_t size)
{
    return en_grow((void **)p, cap, n, size);
}

/* The same, zeroed. */
static int zeroed(void *p, size_t *cap, size_t n, size_t size)
{
    if (room(p, cap, n, size))
        return -1;
    memset(*(void **)p, 0, n * size);
    return 0;
}

static int oom(en_slab_work *w)
{
    return en_error_set(&w->err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "out of memory in slab %u (%u vertices, %u faces)", w->index, w->s.nv, w->s.nt);
}

static int classify(en_slab_work *w)
{
    const en_slab *s = &w->s;
    size_t nv = (size_t)s->nv + 1, nt = (size_t)s->nt + 1;
    if (room(&w->fnormal, &w->cap.fnormal, 3 * nt, sizeof *w->fnormal) ||
        room(&w->ftri, &w->cap.ftri, nt, sizeof *w->ftri) ||
        zeroed(&w->vclass, &w->cap.vclass, nv, sizeof *w->vclass) ||
        room(&w->vgvertex, &w->cap.vgvertex, nv, sizeof *w->vgvertex))
        return oom(w);
    double *fnormal = w->fnormal;
    int32_t *ftri = w->ftri;
    int rc = 0;
    en_classify_counts faces;
    memset(&faces, 0, sizeof faces);
    uint32_t bad = 0;
    rc = en_classify_faces(w->g, s, 0, s->nt, fnormal, ftri, &faces, &bad);
    if (rc) {
        const uint32_t *t = s->tri + 3 * (size_t)bad;
        return en_error_set(&w->err, rc, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            rc == EPSNET_EFORMAT
                                ? "face (%llu %llu %llu): its normal overflows (coordinates too large)"
                                : "face (%llu %llu %llu): Gaussian point location failed (a bug)",
                            (unsigned long long)s->gid[t[0]], (unsigned long long)s->gid[t[1]],
                            (unsigned long long)s->gid[t[2]]);
    }
    if (en_classify_vertices(w->g, s, fnormal, ftri, 0, w->nowned, w->vclass, w->vgvertex, &w->counts))
        return oom(w);
    /* A face is held by every slab owning one of its corners: count it once, at its home. */
    for (uint32_t f = 0; f < s->nt; f++)
        w->counts.zero_area_faces += ftri[f] < 0 && (w->fflags[f] & EN_F_HOME);
    return 0;
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
    if (room(&w->q, &w->cap.q, nv, sizeof *w->q) || room(&w->ref, &w->cap.ref, 3 * nt, sizeof *w->ref) ||
        room(&w->tri, &w->cap.tri, 3 * nt, sizeof *w->tri) || room(&w->falive, &w->cap.falive, nt, 1) ||
        room(&w->valive, &w->cap.valive, nv, 1) || zeroed(&w->border, &w->cap.border, nv, 1) ||
        zeroed(&w->future, &w->cap.future, nv, sizeof *w->future) ||
        zeroed(&w->degree, &w->cap.degree, nv, sizeof *w->degree) || zeroed(&w->band, &w->cap.band, nv, 1) ||
        zeroed(&w->removable, &w->cap.removable, nv, 1))
        return oom(w);
    uint8_t *removable = w->removable;
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
        return oom(w);
    } else {
        w->collapses = cc.collapses;
        memcpy(w->refused, cc.refused, sizeof w->refused);
    }
    mark_bands(w);
    return 0;
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
