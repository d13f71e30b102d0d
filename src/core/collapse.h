/*
 * Shape approximation on a slab (paper §4.2 and §5, docs/method.md §9): remove the
 * removable vertices by half-edge collapses v -> u, cheapest first by
 * Garland-Heckbert quadric error, refusing any collapse that would change
 * topology, flip or over-turn a face, create a zero-area or duplicate face.
 * Only v moves (onto u, an input vertex), so every surviving vertex keeps its
 * input coordinates bit for bit.
 */
#ifndef EN_CORE_COLLAPSE_H
#define EN_CORE_COLLAPSE_H

#include <math.h>
#include <stdatomic.h>
#include <stdint.h>
#include <string.h>

#include "common/ctxpool.h"
#include "core/slab.h"

/* Symmetric 4x4 plane quadric, upper triangle (Garland & Heckbert 1997). */
typedef struct en_quadric {
    double a2, ab, ac, ad, b2, bc, bd, c2, cd, d2;
} en_quadric;

static inline void en_quadric_add(en_quadric *a, const en_quadric *b)
{
    a->a2 += b->a2, a->ab += b->ab, a->ac += b->ac, a->ad += b->ad, a->b2 += b->b2;
    a->bc += b->bc, a->bd += b->bd, a->c2 += b->c2, a->cd += b->cd, a->d2 += b->d2;
}

/* The quadric's value at p: the area-weighted sum of squared distances to
 * the planes it holds. */
static inline double en_quadric_eval(const en_quadric *q, const double p[3])
{
    double x = p[0], y = p[1], z = p[2];
    return q->a2 * x * x + 2 * q->ab * x * y + 2 * q->ac * x * z + 2 * q->ad * x + q->b2 * y * y +
           2 * q->bc * y * z + 2 * q->bd * y + q->c2 * z * z + 2 * q->cd * z + q->d2;
}

/* Why a vertex's collapses were refused (bits, one vertex may have several). */
enum {
    EN_REFUSE_LINK = 1 << 0,      /* link condition: would change topology */
    EN_REFUSE_NORMAL = 1 << 1,    /* a face would flip or turn past the bound */
    EN_REFUSE_ZERO_AREA = 1 << 2, /* a face would have no normal */
    EN_REFUSE_DUPLICATE = 1 << 3, /* a face would duplicate an existing one */
    EN_REFUSE_INCOMPLETE = 1 << 4,/* the target's star is not all in this slab */
};
#define EN_REFUSE_KINDS 5

/*
 * What a run may do. Zero-initialised fields past the first mean "no limit",
 * which is the ε-net pass (docs/method.md §9): every removable vertex that
 * can go, goes. The target stage (docs/method.md §13) sets the limits.
 */
typedef struct en_collapse_settings {
    double max_normal_dev_deg;   /* no face may end up turned further than this from its input normal */
    /* Stop once at most this many faces (of the slab's, alive) or vertices
     * (alive and on a face) remain; 0: no such stop. A collapse removes
     * every face on its edge, two inside a surface, so a face target can
     * end one below. */
    uint64_t keep_faces, keep_vertices;
    /* With by_error, no collapse whose error exceeds max_error (a
     * distance). The error of a collapse is the root of its quadric cost
     * divided by the area the merged quadric carries (the trace of its 3x3
     * part): the area-weighted RMS distance to the planes it stands for.
     * The order stays by quadric cost (measured against ordering by this
     * error: bench/RESULTS.md). */
    int by_error;
    double max_error;
    /* Once at most this many faces are alive (0: never), every quadric is
     * taken afresh from the faces then alive, once (docs/method.md §13:
     * the target's last collapses measure against the mesh near the
     * target, not against every plane each vertex has absorbed). */
    uint64_t refresh_faces;
    /* A target's round (docs/architecture.md §7): stop before the first
     * collapse whose quadric cost is above cost_ceiling (0: no such stop;
     * below 0: before any collapse, only pricing what waits, bucket_of).
     * Every collapse below it is done, cheapest first, so the same
     * ceiling held by every slab and seam is the streaming form of one
     * global order. */
    double cost_ceiling;
    /* When not NULL (one per vertex): at the end, the cost bucket
     * (en_cost_bucket) of each first-tier vertex's cheapest collapse still
     * waiting, EN_COST_NONE for every other vertex: what the target stage
     * counts to set its next round's ceiling. */
    uint16_t *bucket_of;
    /* When not NULL (EN_COST_BUCKETS counts): one count for each collapse
     * that took a vertex whose global id (en_slab.gid) lies in one of the
     * taken_nranges ranges [lo, hi) of taken_ranges (sorted), at the
     * bucket of the highest cost collapsed so far (the run's level then):
     * the counts up to a ceiling's bucket are what a run under that
     * ceiling would have taken there. What the target stage's pricing
     * pass measures (docs/architecture.md §7). */
    uint64_t *taken;
    const uint64_t *taken_ranges;
    uint32_t taken_nranges;
    /* When not NULL: the collapses done so far, stored now and then
     * (relaxed) for a progress report read on another thread; and a flag
     * that other thread may raise to stop the run (EPSNET_EINTR). */
    _Atomic uint64_t *progress;
    _Atomic int *stop;
    /* Attribute weights (core/attr_quadric.h, docs/method.md §9); 0
     * channels: none. attr_value holds attr_channels weighted values per
     * vertex; aq en_aq_doubles(attr_channels) per vertex, the attribute
     * parts whose folds q already holds, accumulated through the
     * collapses like q (updated in place). A collapse v -> u is priced at
     * u's position and u's values, which the output keeps. */
    uint32_t attr_channels;
    const double *attr_value;
    double *aq;
} en_collapse_settings;

/* Log buckets of quadric costs, sixteen to an octave (a ceiling between
 * two is then at most 4.4% off), from 2^-300 up; bucket 0 holds zero and
 * everything below. Histograms of them add up across slabs, seams and
 * threads in any order (integer counts). */
#define EN_COST_BUCKETS 8192
#define EN_COST_BUCKET_EXP0 (-300)
#define EN_COST_NONE UINT16_MAX
#define EN_TIER_PRICED 3
static inline int en_cost_bucket(double c)
{
    if (!(c > 0))
        return 0;
    /* note: for c > 0 the top 16 bits of its IEEE-754 pattern are its
     * biased exponent and its mantissa's top 4 bits: 16 steps to an
     * octave, in order, so the bucket needs no frexp() (checked equal to
     * the frexp() form on the edge cases and 5e7 random patterns). */
    uint64_t bits;
    memcpy(&bits, &c, sizeof bits);
    long b = (long)(bits >> 48) - (1023 + EN_COST_BUCKET_EXP0) * 16 + 1;
    return b < 1 ? 1 : b >= EN_COST_BUCKETS ? EN_COST_BUCKETS - 1 : (int)b;
}
/* Does id lie in one of the n sorted ranges [lo, hi) of r (2n values)? */
static inline int en_in_ranges(const uint64_t *r, uint32_t n, uint64_t id)
{
    uint32_t lo = 0, hi = n;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (id >= r[2 * mid + 1])
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < n && id >= r[2 * lo];
}

/* The upper edge of bucket b, which holds the costs from the edge of b - 1
 * up to it: a ceiling there takes the whole bucket. */
static inline double en_cost_bucket_top(int b)
{
    if (b <= 0)
        return 0;
    int k = b - 1;
    return ldexp(0.5 + (k % 16 + 1) / 32.0, k / 16 + EN_COST_BUCKET_EXP0 + 1);
}

typedef struct en_collapse_counts {
    uint64_t collapses;
    uint64_t given_up;           /* collapses of second-tier vertices (removable == 2) */
    uint64_t faces_left, vertices_left; /* alive faces; alive vertices on a face */
    int stopped_by_error;        /* a collapse past max_error was left undone */
    double top_cost;             /* the highest quadric cost of a collapse done (0: none): the
                                  * level a run stopped by a count reached */
    uint64_t remaining;          /* removable vertices still present */
    uint64_t refused[EN_REFUSE_KINDS]; /* remaining vertices refused for each reason */
} en_collapse_counts;

/* Per-vertex quadrics of the slab's faces (area-weighted planes; q has one
 * entry per vertex, overwritten) and the unit normal of every face (3
 * doubles per face, 0 for a zero-area face): the reference the normal bound
 * is measured against. One pass, since both need the same normal. */
void en_quadrics_from_faces(const en_slab *s, en_quadric *q, double *unit_normal);

/* A pool of the collapse's working arrays (per-vertex records, face
 * lists, queue), for callers that collapse slab after slab on several
 * threads (a chain's slabs and seams): each call borrows one set and gives
 * it back, so they stay warm. Returning them to the system between slabs
 * and faulting them in again cost a third of a 20M-face run's time
 * (bench/RESULTS.md, session 10). @return 0 or EPSNET_ENOMEM. */
int en_collapse_arrays_new(en_ctxpool **arrays);

/*
 * Collapse every vertex v with removable[v] 1 or 2 that can go, cheapest
 * first, until a limit of cs is met. removable[v] == 2 marks a second tier:
 * such a vertex is queued only once no first-tier collapse is left and a
 * face or vertex limit is still unmet (the target stage gives up skeleton
 * samples this way, docs/method.md §13). removable[v] == EN_TIER_PRICED: v
 * never goes here, but cs.bucket_of prices its cheapest collapse (a sample
 * a later pass may free).
 * Needs the slab's stars. q (per vertex) accumulates through the collapses.
 * ref_normal (per face, from en_quadrics_from_faces() on the input) bounds
 * how far any face may turn.
 * On return face_alive[f] says which faces remain (nt entries) and
 * vertex_alive[v] which vertices were not collapsed away (nv entries).
 * arrays: a pool (en_collapse_arrays_new) the working arrays are
 * borrowed from (NULL: this call's own).
 * @return 0 or EPSNET_ENOMEM.
 */
int en_collapse_slab(const en_slab *s, const uint8_t *removable, en_quadric *q, const double *ref_normal,
                     const en_collapse_settings *cs, uint8_t *face_alive, uint8_t *vertex_alive,
                     uint32_t *tri_out, en_collapse_counts *counts, en_ctxpool *arrays);

#endif
