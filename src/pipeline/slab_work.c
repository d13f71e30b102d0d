#include "pipeline/slab_work.h"

#include <math.h>
#include <string.h>

#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"
#include "core/membrane.h"

void en_slab_work_init(en_slab_work *w)
{
    memset(w, 0, sizeof *w);
    en_slab_init(&w->s);
    w->quadric_at = UINT32_MAX;
}

void en_slab_work_free(en_slab_work *w)
{
    en_slab_free(&w->s);
    en_free(w->owner);
    en_free(w->fflags);
    en_free(w->vclass);
    en_free(w->vgvertex);
    en_free(w->vlevel);
    en_free(w->q);
    en_free(w->aq);
    en_free(w->avalue);
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
    en_free(w->attr);
    en_free(w->cost_hist);
    en_free(w->level_hist);
    en_free(w->taken_hist);
    en_free(w->bucket_of);
    en_slab_work_init(w);
}

void en_slab_work_shed(en_slab_work *w)
{
    /* (the rest of a run's scratch is lent for the run only: w->scratch;
     * q, aq, tri and ref come back packed: en_slab_work.packed) */
#define SHED(f)                                                                                                       \
    do {                                                                                                              \
        en_free(w->f);                                                                                                \
        w->f = NULL;                                                                                                  \
        w->cap.f = 0;                                                                                                 \
    } while (0)
    SHED(vgvertex);
    SHED(q);
    SHED(aq);
    SHED(tri);
    SHED(ref);
#undef SHED
}

uint64_t en_slab_work_bytes(const en_slab_work *w)
{
    const en_slab *s = &w->s;
    uint64_t b = (uint64_t)s->cap_v * (sizeof *s->gid + 3 * sizeof *s->pos + sizeof *s->vflags) +
                 (uint64_t)s->cap_t * 3 * sizeof *s->tri + s->cap_star_start * sizeof *s->star_start +
                 s->cap_star * sizeof *s->star + s->cap_star_fill * sizeof *s->star_fill +
                 s->cap_wedge * sizeof *s->wedge;
#define ARR(f, n) b += (uint64_t)w->cap.f * (n) * sizeof *w->f
    ARR(owner, 1), ARR(fflags, 1), ARR(vclass, 1), ARR(vgvertex, 1), ARR(q, 1), ARR(ref, 1), ARR(tri, 1);
    ARR(falive, 1), ARR(valive, 1), ARR(border, 1), ARR(future, 1), ARR(degree, 1), ARR(band, 1), ARR(fnormal, 1);
    ARR(ftri, 1), ARR(removable, 1), ARR(attr, 1), ARR(bucket_of, 1), ARR(vlevel, 1), ARR(aq, 1), ARR(avalue, 1);
#undef ARR
    return b;
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
    KEEP(attr), KEEP(cost_hist), KEEP(bucket_of), KEEP(vlevel), KEEP(level_hist), KEEP(taken_hist), KEEP(aq), KEEP(avalue);
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

/* Classify w at w->g; with levels, each sample's halvings too (vlevel,
 * en_classify_vertices_levels). */
static int classify_levels(en_slab_work *w, int levels)
{
    const en_slab *s = &w->s;
    size_t nv = (size_t)s->nv + 1, nt = (size_t)s->nt + 1;
    if (room(&w->fnormal, &w->cap.fnormal, 3 * nt, sizeof *w->fnormal) ||
        room(&w->ftri, &w->cap.ftri, nt, sizeof *w->ftri) ||
        zeroed(&w->vclass, &w->cap.vclass, nv, sizeof *w->vclass) ||
        room(&w->vgvertex, &w->cap.vgvertex, nv, sizeof *w->vgvertex) ||
        (levels && zeroed(&w->vlevel, &w->cap.vlevel, nv, sizeof *w->vlevel)))
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
    if (en_classify_vertices_levels(w->g, s, fnormal, ftri, 0, w->nowned, w->vclass, w->vgvertex,
                                    levels ? w->vlevel : NULL, &w->counts))
        return oom(w);
    /* A face is held by every slab owning one of its corners: count it once, at its home. */
    for (uint32_t f = 0; f < s->nt; f++)
        w->counts.zero_area_faces += ftri[f] < 0 && (w->fflags[f] & EN_F_HOME);
    return 0;
}

static int classify(en_slab_work *w)
{
    return classify_levels(w, 0);
}

static uint64_t vertices_on_faces(const en_slab *s)
{
    uint64_t n = 0;
    for (uint32_t v = 0; v < s->nv; v++)
        n += en_slab_degree(s, v) > 0;
    return n;
}

/* Is the owned vertex v inside the slab (no neighbour owned elsewhere)? */
static int inner(const en_slab_work *w, uint32_t v)
{
    return v < w->nowned && w->border[v] == EN_BORDER_INNER;
}

/* A paced pass whose one slab holds all of its input: no seams are left
 * to end it at the goal, so the slab aims at it. */
static int aims_at_goal(const en_slab_work *w)
{
    return w->plan->seams == EN_SEAMS_PACED && w->index == 0 && w->last;
}

/* The units a slab keeps when it keeps `share` of what its own collapses
 * can reach (after mark_frozen): the faces on inner vertices only (or the
 * inner vertices, with by_vertices or share_of_vertices); the faces of
 * frozen vertices go to the seams, whose share the stitcher takes.
 * Measured: a share of all the slab's faces over-thins the inside of small
 * slabs, whose seams cannot give their part. */
static void share_limits(const en_slab_work *w, double share, uint64_t *keep_faces, uint64_t *keep_vertices)
{
    uint64_t reach = 0;
    if (w->plan->by_vertices || w->plan->share_of_vertices) {
        for (uint32_t v = 0; v < w->nowned; v++)
            reach += inner(w, v) && en_slab_degree(&w->s, v) > 0;
        uint64_t drop = (uint64_t)((1 - share) * (double)reach), on = vertices_on_faces(&w->s);
        *keep_faces = 0;
        *keep_vertices = on > drop ? on - drop : 1;
        return;
    }
    for (uint32_t f = 0; f < w->s.nt; f++) {
        const uint32_t *c = w->s.tri + 3 * (size_t)f;
        reach += (w->fflags[f] & EN_F_INTERIOR) && inner(w, c[0]) && inner(w, c[1]) && inner(w, c[2]);
    }
    uint64_t drop = (uint64_t)((1 - share) * (double)reach);
    *keep_faces = w->s.nt > drop ? w->s.nt - drop : 1;
    *keep_vertices = 0;
}

/* Faces and vertices the slab may keep under its plan (0: no limit). */
static void target_limits(const en_slab_work *w, uint64_t *keep_faces, uint64_t *keep_vertices)
{
    const en_pass_plan *t = w->plan;
    if (t->keep_share > 0) {
        /* streamed: a share of what the slab's own collapses can reach */
        share_limits(w, t->keep_share, keep_faces, keep_vertices);
        if (aims_at_goal(w))
            *(t->by_vertices ? keep_vertices : keep_faces) = t->goal ? t->goal : 1;
        return;
    }
    if (t->floor_share > 0) {
        /* a round: its ceiling stops it; the floor only guards the target */
        share_limits(w, t->floor_share, keep_faces, keep_vertices);
        return;
    }
    /* a count (or none: the bound or the ceiling alone); a ratio is of the
     * faces the slab came with, membranes included */
    *keep_faces = t->faces ? t->faces : t->ratio > 0 ? (uint64_t)llround(t->ratio * (double)w->faces_in) : 0;
    *keep_vertices = t->vertices;
    /* 0 means "no limit" to the collapse core: a target of no faces at all
     * is the nearest it can get, one face */
    if ((t->faces || t->ratio > 0) && *keep_faces == 0)
        *keep_faces = 1;
}

/* The diagonal of the bounding box of the slab's vertices on faces: the
 * whole mesh's when the slab is the whole mesh (the target stage's case). */
static double slab_diagonal(const en_slab *s)
{
    double lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (uint32_t v = 0; v < s->nv; v++) {
        if (en_slab_degree(s, v) == 0)
            continue;
        for (int k = 0; k < 3; k++) {
            double x = s->pos[3 * (size_t)v + k];
            lo[k] = x < lo[k] ? x : lo[k];
            hi[k] = x > hi[k] ? x : hi[k];
        }
    }
    double d2 = 0;
    for (int k = 0; k < 3; k++)
        d2 += hi[k] >= lo[k] ? (hi[k] - lo[k]) * (hi[k] - lo[k]) : 0;
    return sqrt(d2);
}

/* The vertices the plan keeps of this slab, which the skeleton takes a
 * share of (docs/method.md §13); 0 with no count (an error bound alone). */
static uint64_t target_goal(const en_slab_work *w)
{
    uint64_t on_faces = vertices_on_faces(&w->s);
    if (w->plan->goal_share > 0)
        return (uint64_t)((double)on_faces * w->plan->goal_share);
    uint64_t keep_faces, keep_vertices;
    target_limits(w, &keep_faces, &keep_vertices);
    uint64_t goal = keep_vertices;
    if (!goal && keep_faces && w->s.nt)
        goal = (uint64_t)((double)on_faces * (double)keep_faces / (double)w->s.nt);
    return goal;
}

/*
 * Classify w at geodesic frequency n (in w->chosen). *samples: how many.
 */
static int classify_at(en_slab_work *w, uint32_t n, uint64_t *samples)
{
    gauss_rotation rot = w->g->rot;
    if (gauss_init(&w->chosen, n, &rot))
        return oom(w);
    w->g = &w->chosen;
    memset(&w->counts, 0, sizeof w->counts);
    int rc = classify(w);
    *samples = w->counts.samples;
    return rc;
}

/* The samples the skeleton may have in this slab: skeleton_share of the
 * vertices the target keeps of it (0: no count to aim at). */
static double skeleton_budget(en_slab_work *w)
{
    return w->plan->skeleton_share * (double)target_goal(w);
}

int en_level_of(uint32_t n)
{
    int k = 0;
    while (n > 1) {
        n >>= 1;
        k++;
    }
    return k;
}

int en_skeleton_level(const uint64_t *level_count, int top, double budget)
{
    double sum = 0;
    int pick = 0; /* even the coarsest over: frequency 1, samples may go */
    for (int k = 0; k <= top; k++) {
        sum += (double)level_count[k];
        if (sum > budget)
            break;
        pick = k;
    }
    return pick;
}

/*
 * EN_SKELETON_CHOSEN (docs/method.md §13): the skeleton is the ε-net at the
 * finest power-of-two frequency whose samples are at most the skeleton's
 * budget, decided from the whole pass's counts. G at f/2 is a subset of G
 * at f (classify.h), so one classification at the pass's candidate for
 * this slab (w->g, a power of two) gives each sample the coarsest power of
 * two it is still a sample at (vlevel, as log2 of that frequency), and the
 * counts by it (level_count) add up over slabs to the count at every
 * coarser candidate. The count of a vertex is its own (its whole star is
 * here), so the sums, and the choice, do not depend on where slabs are
 * cut or in what order the mesh comes. A slab of a streamed pass keeps
 * every sample at its candidate (the chain lowers the candidate, at fixed
 * slabs, once the counts so far exclude it: chain.c, lower_candidate); the
 * pass decides at its end, and the marks carry each sample's level to the
 * passes after it. A one-slab pass decides here, and is classified again
 * at the frequency chosen.
 */
static int nested_density(en_slab_work *w)
{
    w->chosen = *w->g;
    int top = en_level_of(w->g->n);
    int rc = classify_levels(w, 1);
    if (rc)
        return rc;
    memset(w->level_count, 0, sizeof w->level_count);
    const en_pass_plan *t = w->plan;
    w->counted_vertices = 0;
    for (uint32_t v = 0; v < w->nowned; v++) {
        /* a pricing pass's window cuts are borders, whose vertices are
         * samples at every level: they stand for no density */
        int counted = !en_cut_end(t, &w->s, v);
        w->counted_vertices += (uint64_t)counted;
        if (!(w->vclass[v] & EN_C_SAMPLE))
            continue;
        if (!counted) {
            w->vlevel[v] = 0;
            continue;
        }
        int kept = w->vlevel[v] < top ? w->vlevel[v] : top; /* locked and needles: at every one */
        w->vlevel[v] = (uint8_t)(top - kept);
        w->level_count[top - kept]++;
    }
    w->has_levels = 1;
    if (!w->plan->one_slab)
        return 0;
    int pick = en_skeleton_level(w->level_count, top, skeleton_budget(w));
    if (pick == top)
        return 0;
    w->has_levels = 0;
    uint64_t samples;
    return classify_at(w, 1u << pick, &samples);
}

/* The finish of a streamed target: the first pass classified, and its
 * samples came marked (EN_V_SKELETON); nothing is classified again, since
 * the skeleton is the input's ε-net, not the thinned mesh's. */
static int skeleton_from_marks(en_slab_work *w)
{
    const en_slab *s = &w->s;
    size_t nv = (size_t)s->nv + 1;
    if (zeroed(&w->vclass, &w->cap.vclass, nv, sizeof *w->vclass) ||
        room(&w->vgvertex, &w->cap.vgvertex, nv, sizeof *w->vgvertex))
        return oom(w);
    for (uint32_t v = 0; v < s->nv; v++) {
        /* the marks are the sample rule's; topology locks are found here
         * again and kept as samples, as the classification does (§6) */
        w->vclass[v] = (s->vflags[v] & EN_V_SKELETON) ? EN_C_SAMPLE : 0;
        if (!(s->vflags[v] & EN_V_ISOLATED) && en_seam_locked(s->vflags[v]))
            w->vclass[v] = EN_C_LOCKED | EN_C_SAMPLE;
        w->vgvertex[v] = -1;
    }
    return 0;
}

/* Is local vertex v's lock property non-zero (settings.lock_property)? A
 * NaN is; -0 is zero. */
static int user_locked(const en_slab_work *w, uint32_t v)
{
    return en_attr_value(w->attr + (size_t)v * w->attr_size + w->lock_offset, w->lock_type) != 0;
}

/* The user's locks join the topology's: an owned vertex whose lock property
 * is non-zero is EN_C_LOCKED, kept by every mode (never a collapse's v,
 * still a target), and EN_C_USER, which the stitcher keeps with the vertex
 * so that no seam of any pass removes it (a sample may go in a target's
 * second tier, a user's lock never). */
static void apply_user_locks(en_slab_work *w)
{
    if (!w->lock_type || !w->attr)
        return;
    for (uint32_t v = 0; v < w->nowned; v++)
        if (user_locked(w, v))
            w->vclass[v] |= EN_C_LOCKED | EN_C_USER;
}

/* Is owned vertex v locked for being non-manifold alone (not on a
 * boundary, not isolated, not locked by the user)? */
static int nonmanifold_only(const en_slab_work *w, uint32_t v)
{
    uint8_t f = w->s.vflags[v];
    return (f & EN_V_NONMANIFOLD) && !(f & (EN_V_BOUNDARY | EN_V_ISOLATED)) && !(w->vclass[v] & EN_C_USER);
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
    /* A seam pair moves together (core/collapse.c), so it is decided in
     * one place: a frozen copy takes its twin to the stitcher with it. */
    for (uint32_t v = 0; v < w->nowned; v++)
        if ((s->vflags[v] & EN_V_SEAM) && w->border[v] == EN_BORDER_FROZEN)
            w->border[s->wedge[v]] = EN_BORDER_FROZEN;
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
    uint32_t channels = w->weights && w->attr ? w->weights->channels : 0;
    size_t na = en_aq_doubles(channels);
    int carried = w->quadric_at != UINT32_MAX && w->attr;
    if (channels) {
        if (room(&w->aq, &w->cap.aq, na * nv, sizeof *w->aq) ||
            room(&w->avalue, &w->cap.avalue, channels * nv, sizeof *w->avalue))
            return oom(w);
        double diagonal = w->weights->diagonal > 0 ? w->weights->diagonal : slab_diagonal(s);
        for (uint32_t v = 0; v < s->nv; v++)
            en_attr_weights_values(w->weights, diagonal, w->attr + (size_t)v * w->attr_size,
                                   w->avalue + (size_t)channels * v);
        if (!carried)
            en_attr_quadrics_from_faces(s, w->avalue, channels, w->q, w->aq);
    }
    if (carried)
        /* what the passes before took in, so that costs go on rising from
         * where they stood (a target's rounds, pipeline/target_stage.h) */
        for (uint32_t v = 0; v < s->nv; v++) {
            const uint8_t *block = w->attr + (size_t)v * w->attr_size + w->quadric_at;
            memcpy(&w->q[v], block, sizeof w->q[v]);
            if (channels)
                memcpy(w->aq + na * v, block + sizeof w->q[v], na * sizeof *w->aq);
        }
    mark_frozen(w);
    /* The seam rules (pipeline/seam.h): an owned inner vertex has its whole
     * star here; a frozen one and the ghosts do not. */
    uint64_t nremovable = 0, held_finer = 0;
    for (uint32_t v = 0; v < s->nv; v++) {
        en_vertex_kind k = EN_VK_OPEN;
        if (owned_here(w, v))
            k = en_vertex_kind_of(w->border[v] == EN_BORDER_INNER, 0,
                                  en_seam_locked(s->vflags[v]) || (w->vclass[v] & EN_C_LOCKED),
                                  (w->vclass[v] & EN_C_SAMPLE) != 0);
        if (k == EN_VK_LOCKED && en_cut_end(w->plan, s, v))
            k = EN_VK_OPEN;
        removable[v] = (uint8_t)en_removable(k);
        /* under a target, samples are the second tier (en_collapse_slab),
         * and so are the non-manifold vertices, which are kept as samples
         * (docs/method.md §6, §13); boundaries and the user's locks stay */
        if (w->plan && w->plan->samples_may_go &&
            (k == EN_VK_SAMPLE || (k == EN_VK_LOCKED && nonmanifold_only(w, v))))
            removable[v] = 2;
        /* a sample finer than the coarsest density is priced: the pass's
         * choice may free it, and the rounds' first ceiling then counts it
         * (nested_density) */
        if (w->plan && w->plan->priced && w->has_levels && owned_here(w, v) && k == EN_VK_SAMPLE &&
            w->vlevel[v] > 0) {
            removable[v] = EN_TIER_PRICED;
            held_finer += w->border[v] == EN_BORDER_INNER;
        }
        s->vflags[v] = (uint8_t)((s->vflags[v] & ~EN_V_TARGET) | (en_receives(k) ? EN_V_TARGET : 0));
        nremovable += removable[v];
        if (!owned_here(w, v))
            continue;
        int nonsample = !(s->vflags[v] & EN_V_ISOLATED) && !(w->vclass[v] & EN_C_SAMPLE);
        w->band_nonsamples += nonsample && w->band[v];
        w->inner_nonsamples += nonsample && !w->band[v];
    }
    en_collapse_settings cs = { .max_normal_dev_deg = w->max_normal_dev,
                                .attr_channels = channels,
                                .attr_value = w->avalue,
                                .aq = w->aq };
    const en_pass_plan *t = w->plan;
    if (t) {
        target_limits(w, &cs.keep_faces, &cs.keep_vertices);
        /* note: the finer candidates' samples are held through a thinning
         * and freed after it; those past the slab's part of the skeleton's
         * budget (its choice keeps no more) get room beside the share, two
         * faces each, so that the rest is not thinned deeper for them: at
         * `gen bumpy` 2M and 10%, 3.96 times the one-slab Hausdorff without
         * this room (bench/RESULTS.md, session 20) */
        double past = (double)held_finer - skeleton_budget(w);
        if (t->keep_share > 0 && !aims_at_goal(w) && past >= 1) {
            if (cs.keep_faces)
                cs.keep_faces += 2 * (uint64_t)past;
            else if (cs.keep_vertices)
                cs.keep_vertices += (uint64_t)past;
        }
        w->keep_faces = cs.keep_faces;
        if (t->faces > w->faces_in || t->vertices > vertices_on_faces(s))
            return en_error_set(&w->err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "a target of %llu %s is more than the input's %llu",
                                (unsigned long long)(t->faces ? t->faces : t->vertices), t->faces ? "faces" : "vertices",
                                (unsigned long long)(t->faces ? w->faces_in : vertices_on_faces(s)));
        if (t->by_vertices) {
            for (uint32_t v = 0; v < w->nowned; v++)
                w->units_in += en_slab_degree(s, v) > 0;
        } else {
            w->units_in = w->membrane_faces;
            for (uint32_t f = 0; f < s->nt; f++)
                w->units_in += (w->fflags[f] & EN_F_HOME) != 0;
        }
        cs.by_error = 1;
        /* the diagonal is the whole mesh's: one slab's, or the header's in
         * a streamed bound (a slab's own would bound each slab differently) */
        double diagonal = t->diagonal > 0 ? t->diagonal : slab_diagonal(s);
        cs.max_error = t->max_error >= 0 ? t->max_error * diagonal : -1;
        /* note: the quadrics are taken afresh once 1.25 times the target is
         * left (a vertex target: twice that in faces, a closed surface's
         * count), measured on the real scans and CAD parts of
         * bench/quality: mean error 7-10% lower on the scans, 0-13% on the
         * CAD parts, normal deviation 2-5% (bench/RESULTS.md). Not with an error bound, which measures
         * against the input's planes, nor in a thinning pass, whose finish
         * takes them afresh anyway (its quadrics start from its own input). */
        if (t->refresh)
            cs.refresh_faces = cs.keep_faces ? cs.keep_faces + cs.keep_faces / 4 : 5 * cs.keep_vertices / 2;
        cs.cost_ceiling = t->cost_ceiling;
        if (t->priced) {
            if ((!w->cost_hist && !(w->cost_hist = en_malloc(EN_COST_BUCKETS * sizeof *w->cost_hist))) ||
                room(&w->bucket_of, &w->cap.bucket_of, nv, sizeof *w->bucket_of))
                return oom(w);
            memset(w->cost_hist, 0, EN_COST_BUCKETS * sizeof *w->cost_hist);
            if (w->has_levels) {
                size_t n = (size_t)EN_LEVELS * EN_COST_BUCKETS;
                if (!w->level_hist && !(w->level_hist = en_malloc(n * sizeof *w->level_hist)))
                    return oom(w);
                memset(w->level_hist, 0, n * sizeof *w->level_hist);
            }
            cs.bucket_of = w->bucket_of; /* filled by the collapse core, when it runs */
        }
        if (t->count_nranges) {
            if (!w->taken_hist && !(w->taken_hist = en_malloc(EN_COST_BUCKETS * sizeof *w->taken_hist)))
                return oom(w);
            memset(w->taken_hist, 0, EN_COST_BUCKETS * sizeof *w->taken_hist);
            cs.taken = w->taken_hist;
            cs.taken_ranges = t->count_ranges;
            cs.taken_nranges = t->count_nranges;
        }
    }
    if (w->progress) {
        /* what the limits leave to do: each collapse takes two faces, or one vertex */
        uint64_t on = cs.keep_vertices ? vertices_on_faces(s) : 0, todo = 0;
        if (cs.keep_faces && s->nt > cs.keep_faces)
            todo = (s->nt - cs.keep_faces) / 2;
        else if (cs.keep_vertices && on > cs.keep_vertices)
            todo = on - cs.keep_vertices;
        atomic_store_explicit(&w->progress->total, todo, memory_order_relaxed);
        cs.progress = &w->progress->done;
        cs.stop = &w->progress->stop;
    }
    en_collapse_counts cc;
    int crc;
    /* nothing to remove, or a plan that keeps everything and prices
     * nothing (a pricing pass's count of samples alone) */
    if (nremovable == 0 || (t && t->keep_share >= 1 && !t->priced)) {
        if (s->nt) /* a slab of isolated vertices has no face array at all */
            memcpy(w->tri, s->tri, 3 * sizeof *w->tri * (size_t)s->nt);
        memset(w->falive, 1, nt);
        memset(w->valive, 1, nv);
    } else if ((crc = en_collapse_slab(s, removable, w->q, w->ref, &cs, w->falive, w->valive, w->tri, &cc,
                                       w->collapse_arrays)) != 0) {
        return crc == EPSNET_EINTR ? en_error_set(&w->err, crc, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "cancelled")
                                   : oom(w);
    } else {
        w->collapses = cc.collapses;
        memcpy(w->refused, cc.refused, sizeof w->refused);
        w->given_up = cc.given_up;
        w->stopped_by_error = cc.stopped_by_error;
        w->level = cc.top_cost;
    }
    if (t)
        for (uint32_t v = 0; v < w->nowned; v++)
            w->skeleton_kept += (w->vclass[v] & EN_C_SAMPLE) && w->valive[v] && !(s->vflags[v] & EN_V_ISOLATED);
    mark_bands(w);
    if (cs.bucket_of && nremovable) /* what this slab decides; the ring is the seams' to count */
        for (uint32_t v = 0; v < w->nowned; v++)
            if (w->valive[v] && cs.bucket_of[v] != EN_COST_NONE &&
                (w->border[v] == EN_BORDER_INNER || w->border[v] == EN_BORDER_OUTER))
                *(w->has_levels && (w->vclass[v] & EN_C_SAMPLE)
                      ? &w->level_hist[(size_t)w->vlevel[v] * EN_COST_BUCKETS + cs.bucket_of[v]]
                      : &w->cost_hist[cs.bucket_of[v]]) += 1;
    return 0;
}

/*
 * Under a target, the glued membranes go first (core/membrane.h,
 * docs/method.md §13) when their corners crowd the skeleton: the faces are
 * compacted and the stars built again, so that their corners are
 * classified as the surface they are on, not locked as non-manifold. A
 * streamed slab drops only sheets of interior faces (the others are held by
 * other slabs too, and stay: the seams keep them); a target they alone would
 * overshoot keeps them all.
 */
static int drop_membranes(en_slab_work *w)
{
    w->rc = 0;
    en_slab *s = &w->s;
    if (room(&w->falive, &w->cap.falive, (size_t)s->nt + 1, 1)) /* scratch until simplify */
        return w->rc = oom(w);
    uint8_t *drop = w->falive;
    int streamed = w->plan->seams != EN_SEAMS_NONE;
    int64_t n = en_find_membranes(s, streamed ? w->fflags : NULL, EN_F_INTERIOR, drop);
    if (n < 0)
        return w->rc = oom(w);
    if (n == 0)
        return 0;
    uint64_t keep_faces = 0, keep_vertices = 0;
    uint64_t on = vertices_on_faces(s);
    if (streamed && on) /* this slab's share of the final target */
        keep_faces = (uint64_t)llround((double)target_goal(w) / (double)on * (double)s->nt);
    else
        target_limits(w, &keep_faces, &keep_vertices);
    if (keep_faces && s->nt - (uint64_t)n < keep_faces)
        return 0;
    if (keep_vertices) {
        uint64_t left = 0;
        for (uint32_t v = 0; v < s->nv; v++)
            for (uint32_t i = s->star_start[v]; i < s->star_start[v + 1]; i++)
                if (!drop[s->star[i]]) {
                    left++;
                    break;
                }
        if (left < keep_vertices)
            return 0;
    }
    /* The sheets' corners are non-manifold, kept as samples (§6): part of
     * the skeleton. Like samples they stay while they fit its share of
     * what the target keeps, and go when they crowd it. An error bound
     * alone has no count, and keeps them: dropping a sheet is an error
     * (its height) that the bound does not see. */
    uint64_t goal = target_goal(w), locked = 0;
    for (uint32_t v = 0; v < s->nv; v++) {
        if (!(s->vflags[v] & EN_V_NONMANIFOLD))
            continue;
        for (uint32_t i = s->star_start[v]; i < s->star_start[v + 1]; i++)
            if (drop[s->star[i]]) {
                locked++;
                break;
            }
    }
    if (!goal || (double)locked <= w->plan->skeleton_share * (double)goal)
        return 0;
    uint32_t nt = 0;
    for (uint32_t f = 0; f < s->nt; f++) {
        if (drop[f])
            continue;
        memmove(s->tri + 3 * (size_t)nt, s->tri + 3 * (size_t)f, 3 * sizeof *s->tri);
        w->fflags[nt++] = w->fflags[f];
    }
    s->nt = nt;
    w->membrane_faces = (uint64_t)n;
    return w->rc = en_slab_build_stars(s) ? oom(w) : 0;
}

/* What a slab work's run uses and nothing reads after it (vgvertex stays
 * the work's: a sample run's retire reads it). */
typedef struct en_slab_scratch {
    double *fnormal, *avalue;
    int32_t *ftri;
    uint8_t *removable;
    uint16_t *bucket_of;
    uint32_t *star_start, *star, *star_fill, *wedge;
    size_t cap_fnormal, cap_avalue, cap_ftri, cap_removable, cap_bucket_of;
    size_t cap_star_start, cap_star, cap_star_fill, cap_wedge;
} en_slab_scratch;

static void destroy_scratch(void *item)
{
    en_slab_scratch *x = item;
    en_free(x->fnormal), en_free(x->avalue), en_free(x->ftri), en_free(x->removable), en_free(x->bucket_of);
    en_free(x->star_start), en_free(x->star), en_free(x->star_fill), en_free(x->wedge);
    en_free(x);
}

int en_slab_scratch_pool_new(en_ctxpool **pool)
{
    return en_ctxpool_new(pool, destroy_scratch);
}

/* Trade w's scratch for x's (twice: back as it was). */
static void swap_scratch(en_slab_work *w, en_slab_scratch *x)
{
#define SWAP(a, b)                                                                                                    \
    do {                                                                                                              \
        _Static_assert(sizeof(a) == sizeof(b), "one type on both sides");                                            \
        unsigned char t_[sizeof(a)];                                                                                  \
        memcpy(t_, &(a), sizeof t_);                                                                                  \
        memcpy(&(a), &(b), sizeof t_);                                                                                \
        memcpy(&(b), t_, sizeof t_);                                                                                  \
    } while (0)
    SWAP(w->fnormal, x->fnormal);
    SWAP(w->cap.fnormal, x->cap_fnormal);
    SWAP(w->avalue, x->avalue);
    SWAP(w->cap.avalue, x->cap_avalue);
    SWAP(w->ftri, x->ftri);
    SWAP(w->cap.ftri, x->cap_ftri);
    SWAP(w->removable, x->removable);
    SWAP(w->cap.removable, x->cap_removable);
    SWAP(w->bucket_of, x->bucket_of);
    SWAP(w->cap.bucket_of, x->cap_bucket_of);
    SWAP(w->s.star_start, x->star_start);
    SWAP(w->s.cap_star_start, x->cap_star_start);
    SWAP(w->s.star, x->star);
    SWAP(w->s.cap_star, x->cap_star);
    SWAP(w->s.star_fill, x->star_fill);
    SWAP(w->s.cap_star_fill, x->cap_star_fill);
    SWAP(w->s.wedge, x->wedge);
    SWAP(w->s.cap_wedge, x->cap_wedge);
#undef SWAP
}

static int run(en_slab_work *w);

int en_slab_work_run(void *arg)
{
    en_slab_work *w = arg;
    if (!w->scratch)
        return run(w);
    en_slab_scratch *x = en_ctxpool_take(w->scratch);
    if (!x && !(x = en_calloc(1, sizeof *x))) {
        en_error_clear(&w->err);
        return w->rc = oom(w);
    }
    swap_scratch(w, x);
    int rc = run(w);
    swap_scratch(w, x);
    en_ctxpool_give(w->scratch, x);
    return rc;
}

static int run(en_slab_work *w)
{
    double t0 = en_now();
    en_error_clear(&w->err);
    w->faces_in = w->s.nt;
    if (en_slab_build_stars(&w->s))
        w->rc = oom(w);
    else if (w->plan && w->mode == EN_SLAB_SIMPLIFY && drop_membranes(w))
        ; /* w->rc and w->err are set */
    else if (w->plan && w->plan->skeleton == EN_SKELETON_MARKED)
        w->rc = skeleton_from_marks(w);
    else if (w->plan && w->plan->skeleton == EN_SKELETON_CHOSEN && w->mode == EN_SLAB_SIMPLIFY)
        w->rc = nested_density(w);
    else
        w->rc = classify(w);
    if (w->rc == 0 && w->mode == EN_SLAB_SIMPLIFY) {
        apply_user_locks(w);
        w->rc = simplify(w);
    }
    w->seconds = en_now() - t0;
    return w->rc;
}
