/*
 * Half-edge collapses of non-samples, cheapest first (paper §4.2, §5; docs/method.md §9).
 *
 * Papers implemented:
 *   Garland, Heckbert. Surface simplification using quadric error metrics.
 *     SIGGRAPH 1997 (the plane quadrics and their accumulation).
 *   Dey, Edelsbrunner, Guha, Nekhayev. Topology preserving edge contraction.
 *     1999 (the link condition).
 *
 * The outline: quadrics per vertex -> best target per removable vertex ->
 * a priority queue of (cost, v, u) -> pop, re-check, collapse -> refresh the
 * ring around u -> repeat until the queue is empty.
 *
 * note: the queue is an indexed heap with exactly one entry per removable
 * vertex (its best target), updated in place; a stale-entry heap grew to
 * several entries per vertex and its sift-downs missed the cache at every
 * level, which made large meshes superlinear.
 *
 * note: a vertex is queued with its cheapest target *unchecked*; the checks
 * (link condition, normals, duplicates: O(deg v * deg u)) run only when the
 * entry is popped, and an entry that fails is replaced by the vertex's
 * cheapest *valid* target. A vertex's valid cost is never below its
 * unchecked cost, so the entry that pops valid is still the cheapest valid
 * collapse in the mesh, as docs/method.md §9 asks; checking lazily keeps a run linear
 * where checking every neighbour after every collapse was quadratic in the
 * degree of the vertices that absorb many faces.
 */
#include "core/collapse.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "core/attr_quadric.h"
#include "epsnet/epsnet.h"

/* ---- quadrics ---- */

/* The area-weighted plane quadric of face t into k, its unit normal into
 * un (0 for a zero-area face, whose quadric is then 0 too). */
static void face_quadric(const double *pos, const uint32_t *t, en_quadric *k, double un[3])
{
    double n[3];
    en_triangle_normal(pos, t, n);
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (len == 0) {
        un[0] = un[1] = un[2] = 0;
        memset(k, 0, sizeof *k);
        return;
    }
    /* note: weight = area, so a plane counts by how much surface it
     * carries and sliver triangles do not dominate. */
    double area = 0.5 * len, a = n[0] / len, b = n[1] / len, c = n[2] / len;
    un[0] = a, un[1] = b, un[2] = c;
    const double *p = pos + 3 * (size_t)t[0];
    double d = -(a * p[0] + b * p[1] + c * p[2]);
    *k = (en_quadric){ area * a * a, area * a * b, area * a * c, area * a * d, area * b * b,
                       area * b * c, area * b * d, area * c * c, area * c * d, area * d * d };
}

void en_quadrics_from_faces(const en_slab *s, en_quadric *q, double *unit_normal)
{
    memset(q, 0, (size_t)s->nv * sizeof *q);
    for (uint32_t f = 0; f < s->nt; f++) {
        const uint32_t *t = s->tri + 3 * (size_t)f;
        en_quadric k;
        face_quadric(s->pos, t, &k, unit_normal + 3 * (size_t)f);
        for (int i = 0; i < 3; i++)
            en_quadric_add(&q[t[i]], &k);
    }
}

/* ---- the dynamic mesh ---- */

/* note: ties break on local ids, which a slab assigns in global-id order,
 * so the order is the same on every run and for every slab split. */
typedef struct heap_entry {
    double cost;
    uint32_t v, u;
} heap_entry;

typedef struct target {
    double cost;
    uint32_t u;
} target;

/*
 * note: everything the queue keeps per vertex, its quadric included, sits in
 * one 128-byte record (two cache lines, the queue's fields in the first). A
 * collapse visits a ring of vertices scattered over the slab, and with one
 * array per field each visit missed the cache once per field.
 */
typedef struct vrec {
    double self_err;          /* the quadrics of v and of its copies (wedge) at v's position */
    double best_cost;         /* cost of v's cheapest queued entry */
    uint32_t vf_start, vf_count, vf_cap;
    uint32_t heap_pos;        /* v's index in heap, or UINT32_MAX */
    uint32_t best_u;          /* its target, UINT32_MAX when none */
    uint32_t mark;            /* stamp per vertex for neighbour sets */
    uint8_t removable;
    uint8_t alive;            /* not collapsed away (mirrors vertex_alive) */
    uint8_t fallback;         /* v's queued entry is its cheapest *valid* one */
    uint8_t refused;          /* EN_REFUSE_* seen on the last evaluation */
    uint32_t wedge;           /* the next copy of v's position (en_slab.wedge); v when none */
    en_quadric q;             /* accumulates through the collapses; copied back to the caller's q */
} vrec;
_Static_assert(sizeof(vrec) == 128, "a vertex record is two cache lines");

typedef struct state {
    const en_slab *s;
    double cos_bound;
    uint32_t *tri;
    uint8_t *falive, *valive;
    const double *ref_normal; /* unit normal each face had in the input (0 if none) */

    /* vertex -> alive faces: list of v is pool[vx[v].vf_start .. + vx[v].vf_count) */
    uint32_t *pool;
    size_t pool_len, pool_cap;

    vrec *vx;                 /* per vertex, 64-byte aligned */
    void *vx_alloc;
    uint32_t stamp;

    heap_entry *heap;
    size_t heap_len, heap_cap;

    target *cand;             /* scratch: one vertex's targets */
    size_t cand_cap;
    uint32_t *faces;          /* scratch: one vertex's faces */
    size_t faces_cap;
    uint32_t *ends;           /* scratch: a long seam fan's corners (open_ends) */
    size_t ends_cap;

    uint64_t collapses;
    int welds;                /* the slab has copies of positions (en_slab.has_welds) */

    /* Attribute weights (en_collapse_settings.attr_*): k channels, value k
     * per vertex, aq na per vertex (the caller's, accumulated in place). */
    uint32_t k;
    size_t na;
    const double *value;
    double *aq;

    /* Limits (en_collapse_settings) and what they count. */
    const uint8_t *tier;      /* removable[] as the core takes it (seam_tiers): 2 = second tier */
    int by_error;
    double max_cost;          /* by_error: max_error squared; otherwise +inf */
    uint64_t keep_faces, keep_vertices;
    uint64_t faces_alive, vertices_alive;
    uint64_t given_up;
    int stopped_by_error;
    double ceiling;           /* cost_ceiling, +inf when none */
    double top_cost;          /* the highest cost collapsed so far */
    int stopped_by_ceiling;
} state;

static int entry_less(const heap_entry *a, const heap_entry *b)
{
    if (a->cost != b->cost)
        return a->cost < b->cost;
    if (a->v != b->v)
        return a->v < b->v;
    return a->u < b->u;
}

/* A 4-ary indexed heap: half the levels of a binary one, and the four
 * children of a node share a cache line or two. */
static void heap_place(state *st, size_t i, heap_entry e)
{
    st->heap[i] = e;
    st->vx[e.v].heap_pos = (uint32_t)i;
}

static void sift_up(state *st, size_t i, heap_entry e)
{
    while (i > 0) {
        size_t parent = (i - 1) / 4;
        if (!entry_less(&e, &st->heap[parent]))
            break;
        heap_place(st, i, st->heap[parent]);
        i = parent;
    }
    heap_place(st, i, e);
}

/* The smallest of the children from first on (first < n): a full family,
 * the common case, as a two-round tournament, without a loop. */
static size_t min_child(const heap_entry *h, size_t first, size_t n)
{
    if (first + 4 <= n) {
        size_t a = entry_less(&h[first + 1], &h[first]) ? first + 1 : first;
        size_t b = entry_less(&h[first + 3], &h[first + 2]) ? first + 3 : first + 2;
        return entry_less(&h[b], &h[a]) ? b : a;
    }
    size_t c = first;
    for (size_t k = first + 1; k < n; k++)
        if (entry_less(&h[k], &h[c]))
            c = k;
    return c;
}

static void sift_down(state *st, size_t i, heap_entry e)
{
    size_t n = st->heap_len;
    for (;;) {
        size_t first = 4 * i + 1;
        if (first >= n)
            break;
        size_t c = min_child(st->heap, first, n);
        if (!entry_less(&st->heap[c], &e))
            break;
        heap_place(st, i, st->heap[c]);
        i = c;
    }
    heap_place(st, i, e);
}

/* Insert v's entry, or move it to its new cost. */
static int heap_set(state *st, uint32_t v, double cost, uint32_t u)
{
    heap_entry e = { cost, v, u };
    uint32_t i = st->vx[v].heap_pos;
    if (i == UINT32_MAX) {
        if (st->heap_len == st->heap_cap &&
            en_grow((void **)&st->heap, &st->heap_cap, st->heap_len + 1, sizeof *st->heap))
            return EPSNET_ENOMEM;
        sift_up(st, st->heap_len++, e);
    } else if (entry_less(&e, &st->heap[i])) {
        sift_up(st, i, e);
    } else {
        sift_down(st, i, e);
    }
    return 0;
}

static void heap_remove(state *st, uint32_t v)
{
    uint32_t i = st->vx[v].heap_pos;
    if (i == UINT32_MAX)
        return;
    st->vx[v].heap_pos = UINT32_MAX;
    heap_entry last = st->heap[--st->heap_len];
    if (i == st->heap_len)
        return;
    if (entry_less(&last, &st->heap[i]))
        sift_up(st, i, last);
    else
        sift_down(st, i, last);
}

/* note: the root's hole goes down along the smaller children to a leaf and
 * the last entry rises from there (Floyd): it saves the comparison with the
 * last entry at every level, which nearly always sinks to the bottom anyway. */
static heap_entry heap_pop(state *st)
{
    heap_entry top = st->heap[0];
    st->vx[top.v].heap_pos = UINT32_MAX;
    size_t n = --st->heap_len;
    if (n == 0)
        return top;
    heap_entry last = st->heap[n];
    size_t i = 0;
    for (;;) {
        size_t first = 4 * i + 1;
        if (first >= n)
            break;
        size_t c = min_child(st->heap, first, n);
        heap_place(st, i, st->heap[c]);
        i = c;
    }
    sift_up(st, i, last);
    return top;
}

static int has_corner(const uint32_t *t, uint32_t v)
{
    return t[0] == v || t[1] == v || t[2] == v;
}

/* The two corners of triangle t other than v, in counter-clockwise order. */
static void other_corners(const uint32_t *t, uint32_t v, uint32_t *x, uint32_t *y)
{
    int k = t[0] == v ? 0 : t[1] == v ? 1 : 2;
    *x = t[(k + 1) % 3];
    *y = t[(k + 2) % 3];
}

static int list_append(state *st, uint32_t v, uint32_t f)
{
    if (st->vx[v].vf_count == st->vx[v].vf_cap) {
        /* Move the list to the end of the pool with room to grow. */
        uint32_t cap = st->vx[v].vf_cap ? 2 * st->vx[v].vf_cap : 8;
        if (en_grow((void **)&st->pool, &st->pool_cap, st->pool_len + cap, sizeof *st->pool))
            return EPSNET_ENOMEM;
        memcpy(st->pool + st->pool_len, st->pool + st->vx[v].vf_start, st->vx[v].vf_count * sizeof *st->pool);
        st->vx[v].vf_start = (uint32_t)st->pool_len;
        st->vx[v].vf_cap = cap;
        st->pool_len += cap;
    }
    st->pool[st->vx[v].vf_start + st->vx[v].vf_count++] = f;
    return 0;
}

/* note: the last entry takes f's place. The order within a list decides
 * nothing that is kept: targets are chosen and ranked by (cost, id), the
 * queue pops by (cost, v, u), and the checks give the same verdict in any
 * order (only which reason a refused collapse reports first may change).
 * Measured: the same bytes and statistics as removal in order on the
 * shared scans, textured and streamed runs; 0.55% fewer instructions at
 * 131K faces, a wall time no different within this machine's noise
 * (bench/RESULTS.md, session 14). */
static void list_remove(state *st, uint32_t v, uint32_t f)
{
    uint32_t *l = st->pool + st->vx[v].vf_start;
    for (uint32_t i = 0; i < st->vx[v].vf_count; i++)
        if (l[i] == f) {
            l[i] = l[--st->vx[v].vf_count];
            return;
        }
}

/* Does u have an alive face on both x and y? */
static int has_face_on(const state *st, uint32_t u, uint32_t x, uint32_t y)
{
    const uint32_t *l = st->pool + st->vx[u].vf_start;
    for (uint32_t i = 0; i < st->vx[u].vf_count; i++) {
        const uint32_t *t = st->tri + 3 * (size_t)l[i];
        if (has_corner(t, x) && has_corner(t, y))
            return 1;
    }
    return 0;
}

/* ---- seams (docs/method.md §6) ---- */

/* Is p a copy of u's position (u itself included)? */
static int is_copy_of(const state *st, uint32_t p, uint32_t u)
{
    for (uint32_t c = u;;) {
        if (c == p)
            return 1;
        if ((c = st->vx[c].wedge) == u)
            return 0;
    }
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* The open ends of a seam vertex in the faces alive now: out, the corner
 * after v that no face of v has before it (the open edge v -> out), and in
 * the other way round. UINT32_MAX when there is none (or out of memory,
 * which then refuses the move). note: without the marks, which the callers
 * are using: a scan in O(deg^2) for a short fan, and for a long one (a seam
 * vertex that took in many collapses: the scan was a quarter of a textured
 * 2M-face run) both corner lists sorted and merged. */
static void open_ends(state *st, uint32_t v, uint32_t *out, uint32_t *in)
{
    const uint32_t *lv = st->pool + st->vx[v].vf_start;
    uint32_t n = st->vx[v].vf_count;
    *out = *in = UINT32_MAX;
    if (n > 12) {
        if (en_grow((void **)&st->ends, &st->ends_cap, 2 * (size_t)n, sizeof *st->ends))
            return;
        uint32_t *after = st->ends, *before = st->ends + n;
        for (uint32_t i = 0; i < n; i++) {
            const uint32_t *t = st->tri + 3 * (size_t)lv[i];
            int k = t[0] == v ? 0 : t[1] == v ? 1 : 2;
            after[i] = t[(k + 1) % 3];
            before[i] = t[(k + 2) % 3];
        }
        qsort(after, n, sizeof *after, cmp_u32);
        qsort(before, n, sizeof *before, cmp_u32);
        uint32_t i = 0, j = 0;
        while (i < n || j < n) {
            if (i < n && j < n && after[i] == before[j])
                i++, j++;
            else if (j == n || (i < n && after[i] < before[j]))
                *out = after[i++];
            else
                *in = before[j++];
        }
        return;
    }
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t *t = st->tri + 3 * (size_t)lv[i];
        int k = t[0] == v ? 0 : t[1] == v ? 1 : 2;
        uint32_t after = t[(k + 1) % 3], before = t[(k + 2) % 3];
        int after_closed = 0, before_closed = 0;
        for (uint32_t j = 0; j < n; j++) {
            const uint32_t *h = st->tri + 3 * (size_t)lv[j];
            int m = h[0] == v ? 0 : h[1] == v ? 1 : 2;
            after_closed |= h[(m + 2) % 3] == after;
            before_closed |= h[(m + 1) % 3] == before;
        }
        if (!after_closed)
            *out = after;
        if (!before_closed)
            *in = before;
    }
}

/*
 * A seam pair (v, t = its wedge) moves along the seam, both sides together
 * (as meshoptimizer's seam vertices do): v onto u, one of v's open ends,
 * and t onto p, the copy of u at t's opposite open end. The two such moves
 * into u[] and p[]; u[k] is UINT32_MAX when the other side does not lead
 * to a copy of it (the two sides meet there, as at the tip of a cut, whose
 * single vertex stays).
 */
static void seam_moves(state *st, uint32_t v, uint32_t u[2], uint32_t p[2])
{
    uint32_t ot, it;
    open_ends(st, v, &u[0], &u[1]);
    open_ends(st, st->vx[v].wedge, &ot, &it);
    p[0] = it, p[1] = ot;
    for (int k = 0; k < 2; k++)
        if (u[k] == UINT32_MAX || p[k] == UINT32_MAX || p[k] == u[k] || !is_copy_of(st, p[k], u[k]))
            u[k] = UINT32_MAX;
    if (u[1] == u[0])
        u[1] = UINT32_MAX;
}

/* The copy of u that v's twin moves onto with v -> u, or UINT32_MAX when
 * v -> u is no move along the seam (seam_moves). */
static uint32_t seam_partner(state *st, uint32_t v, uint32_t u)
{
    uint32_t us[2], ps[2];
    seam_moves(st, v, us, ps);
    return u == us[0] ? ps[0] : u == us[1] ? ps[1] : UINT32_MAX;
}

static int is_seam(const state *st, uint32_t v)
{
    return (st->s->vflags[v] & EN_V_SEAM) != 0;
}

/*
 * Can v collapse onto u, on its side alone? Returns 0 or the EN_REFUSE_*
 * reason; opp gets the corners opposite the edge v-u (twice the same when
 * open: a seam collapse, along the one face of a seam edge).
 * Link condition: the neighbours v and u share must be exactly the
 * vertices opposite the edge v-u, else the collapse pinches the surface.
 */
static inline int check_side(state *st, uint32_t v, uint32_t u, int open, uint32_t opp[2])
{
    if (!(st->s->vflags[u] & EN_V_TARGET))
        return EN_REFUSE_INCOMPLETE;
    uint32_t stamp = ++st->stamp;
    const uint32_t *lu = st->pool + st->vx[u].vf_start;
    for (uint32_t i = 0; i < st->vx[u].vf_count; i++) {
        const uint32_t *t = st->tri + 3 * (size_t)lu[i];
        for (int k = 0; k < 3; k++)
            st->vx[t[k]].mark = stamp;
    }
    const uint32_t *lv = st->pool + st->vx[v].vf_start;
    uint32_t nedge = 0;
    for (uint32_t i = 0; i < st->vx[v].vf_count; i++) {
        const uint32_t *t = st->tri + 3 * (size_t)lv[i];
        if (!has_corner(t, u))
            continue;
        if (nedge == 2)
            return EN_REFUSE_LINK; /* edge with more than two faces */
        opp[nedge++] = t[0] != v && t[0] != u ? t[0] : t[1] != v && t[1] != u ? t[1] : t[2];
    }
    if (nedge + (uint32_t)open != 2)
        return EN_REFUSE_LINK;
    opp[1] = opp[nedge - 1];
    /* note: unmarking the allowed shared vertices leaves one test per corner;
     * 0 is below every stamp. */
    st->vx[v].mark = st->vx[u].mark = st->vx[opp[0]].mark = st->vx[opp[1]].mark = 0;
    for (uint32_t i = 0; i < st->vx[v].vf_count; i++) {
        const uint32_t *t = st->tri + 3 * (size_t)lv[i];
        if (st->vx[t[0]].mark == stamp || st->vx[t[1]].mark == stamp || st->vx[t[2]].mark == stamp)
            return EN_REFUSE_LINK;
    }
    for (uint32_t i = 0; i < st->vx[v].vf_count; i++) {
        uint32_t f = lv[i];
        const uint32_t *t = st->tri + 3 * (size_t)f;
        if (has_corner(t, u))
            continue;
        uint32_t nt[3] = { t[0] == v ? u : t[0], t[1] == v ? u : t[1], t[2] == v ? u : t[2] };
        double n[3];
        en_triangle_normal(st->s->pos, nt, n);
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len == 0)
            return EN_REFUSE_ZERO_AREA;
        /* note: measured against the face's *input* normal, not its current
         * one, so that turns cannot add up over many collapses into a fold. */
        const double *c = st->ref_normal + 3 * (size_t)f;
        if ((c[0] != 0 || c[1] != 0 || c[2] != 0) &&
            (n[0] * c[0] + n[1] * c[1] + n[2] * c[2]) / len < st->cos_bound)
            return EN_REFUSE_NORMAL;
        uint32_t x, y;
        other_corners(t, v, &x, &y);
        /* note: a face of u on x and y makes both shared neighbours, which
         * the link condition just limited to opp: other corners spare the
         * O(deg u) search. */
        if ((x == opp[0] || x == opp[1]) && (y == opp[0] || y == opp[1]) && has_face_on(st, u, x, y))
            return EN_REFUSE_DUPLICATE;
    }
    return 0;
}

/* Mark every copy of w's position (w included) with stamp. */
static void mark_position(state *st, uint32_t w, uint32_t stamp)
{
    uint32_t c = w;
    do {
        st->vx[c].mark = stamp;
        c = st->vx[c].wedge;
    } while (c != w);
}

/*
 * The link condition on the surface the copies stand for (positions, not
 * records: each side passing its own is not enough, since two sides may
 * meet again further along a seam). The vertices around any copy of u
 * and those around v (and its twin, when a seam pair moves) may share only
 * v, u and the corners opposite the collapsed edges. Only in a slab with
 * copies of positions.
 */
static int check_welded(state *st, uint32_t v, uint32_t u, const uint32_t opp[4])
{
    uint32_t stamp = ++st->stamp;
    uint32_t c = u;
    do {
        const uint32_t *l = st->pool + st->vx[c].vf_start;
        for (uint32_t i = 0; i < st->vx[c].vf_count; i++) {
            const uint32_t *t = st->tri + 3 * (size_t)l[i];
            for (int k = 0; k < 3; k++)
                mark_position(st, t[k], stamp);
        }
        c = st->vx[c].wedge;
    } while (c != u);
    mark_position(st, v, 0);
    mark_position(st, u, 0);
    for (int k = 0; k < 4; k++)
        mark_position(st, opp[k], 0);
    uint32_t d = v;
    do {
        const uint32_t *l = st->pool + st->vx[d].vf_start;
        for (uint32_t i = 0; i < st->vx[d].vf_count; i++) {
            const uint32_t *t = st->tri + 3 * (size_t)l[i];
            if (st->vx[t[0]].mark == stamp || st->vx[t[1]].mark == stamp || st->vx[t[2]].mark == stamp)
                return EN_REFUSE_LINK;
        }
        d = st->vx[d].wedge; /* its twin; an interior v is its own wedge */
    } while (d != v);
    return 0;
}

/* check_collapse in a slab with copies of positions. */
static int check_with_copies(state *st, uint32_t v, uint32_t u)
{
    uint32_t opp[4];
    int why;
    if (is_seam(st, v)) {
        uint32_t p = seam_partner(st, v, u);
        if (p == UINT32_MAX)
            return EN_REFUSE_LINK;
        if ((why = check_side(st, v, u, 1, opp)) || (why = check_side(st, st->vx[v].wedge, p, 1, opp + 2)))
            return why;
    } else {
        if ((why = check_side(st, v, u, 0, opp)))
            return why;
        opp[2] = opp[0], opp[3] = opp[1];
    }
    return check_welded(st, v, u, opp);
}

/* Can v collapse onto u (with its twin onto the copy of u beside it, when
 * v is one of a seam pair)? Returns 0 or the EN_REFUSE_* reason. */
static inline int check_collapse(state *st, uint32_t v, uint32_t u)
{
    uint32_t opp[2];
    return st->welds ? check_with_copies(st, v, u) : check_side(st, v, u, 0, opp);
}

static int target_less(const target *a, const target *b)
{
    return a->cost != b->cost ? a->cost < b->cost : a->u < b->u;
}

/* The area a quadric carries: each plane enters with its area times a unit
 * normal's outer product, whose trace is 1. */
static double quadric_area(const en_quadric *q)
{
    return q->a2 + q->b2 + q->c2;
}

/* w's attribute part at position p and x's values (0 without weights). */
static inline double attr_err(const state *st, uint32_t w, const double *p, uint32_t x)
{
    return st->k ? en_aq_eval(st->aq + st->na * w, st->k, p, st->value + (size_t)st->k * x) : 0;
}

/* w's quadric at x: its position, and its values (which a collapse keeps). */
static inline double err_at(const state *st, uint32_t w, uint32_t x)
{
    const double *p = st->s->pos + 3 * (size_t)x;
    return en_quadric_eval(&st->vx[w].q, p) + attr_err(st, w, p, x);
}

/* The quadrics of x's position at it: x's own, and its copies' (the sides
 * of a seam stand for one vertex of the surface), each at its own values. */
static double position_err(const state *st, uint32_t x)
{
    double e = err_at(st, x, x);
    for (uint32_t c = st->vx[x].wedge; c != x; c = st->vx[c].wedge)
        e += err_at(st, c, c);
    return e;
}

/* After a copy of x's position took in a quadric: each copy's self_err. */
static void update_position_err(state *st, uint32_t x)
{
    double e = position_err(st, x);
    uint32_t c = x;
    do {
        st->vx[c].self_err = e;
        c = st->vx[c].wedge;
    } while (c != x);
}

/* The cost of w -> x for a w that is not one of a seam pair (see
 * move_cost). */
static inline double pair_cost_with(const state *st, uint32_t w, uint32_t x, int attrs)
{
    const double *p = st->s->pos + 3 * (size_t)x;
    double c = en_quadric_eval(&st->vx[w].q, p) + (attrs ? attr_err(st, w, p, x) : 0) + st->vx[x].self_err;
    /* Huge coordinates (1e200) overflow quadrics to inf - inf = NaN. NaN is
     * unequal to itself, so the queue's staleness test would requeue such a
     * pair forever: such pairs go last, at +inf, where the test holds. */
    return c == c ? c : INFINITY;
}

static double pair_cost(const state *st, uint32_t w, uint32_t x)
{
    return pair_cost_with(st, w, x, st->k != 0);
}

/* The cost of moving w onto x: pair_cost, and for one of a seam pair the
 * twin's quadric at x too (it goes onto px, the copy of x on its side,
 * whose values it takes; seam_moves). */
static double move_cost(const state *st, uint32_t w, uint32_t x, uint32_t px)
{
    double c = pair_cost(st, w, x);
    if (st->welds && is_seam(st, w)) {
        if (st->k && px == UINT32_MAX)
            return INFINITY; /* no move along the seam: refused at the check */
        uint32_t t = st->vx[w].wedge;
        const double *p = st->s->pos + 3 * (size_t)x;
        c += en_quadric_eval(&st->vx[t].q, p) + attr_err(st, t, p, px);
        c = c == c ? c : INFINITY;
    }
    return c;
}

/* The squared error of collapsing w onto x at quadric cost c: the cost per
 * unit of the area the merged quadric carries, an area-weighted mean squared
 * distance to its planes (en_collapse_settings.max_error). */
static double collapse_error2(const state *st, uint32_t w, uint32_t x, double c)
{
    double area = quadric_area(&st->vx[w].q) + quadric_area(&st->vx[x].q);
    if (st->k) /* the folds' traces are not area (core/attr_quadric.h) */
        area -= st->aq[st->na * w + 1] + st->aq[st->na * x + 1];
    double e = area > 0 ? c / area : c;
    return e > 0 ? e : 0; /* rounding can take a sum of squares below zero */
}

/* Corner of t at v (the first, should a face repeat v), as stars list it. */
static int corner_at(const uint32_t *t, uint32_t v)
{
    return t[0] == v ? 0 : t[1] == v ? 1 : 2;
}

/* Targets of v with their costs, cheapest first, in st->cand; @return count
 * or -1 when out of memory. Each neighbour is the corner after v in exactly
 * one face of v's (manifold, closed) star, so it is listed once. */
static int64_t rank_targets(state *st, uint32_t v)
{
    if (en_grow((void **)&st->cand, &st->cand_cap, st->vx[v].vf_count + 2, sizeof *st->cand))
        return -1;
    target *cand = st->cand;
    uint32_t n = 0;
    const uint32_t *lv = st->pool + st->vx[v].vf_start;
    if (st->welds && is_seam(st, v)) {
        /* along the seam only */
        uint32_t us[2], ps[2];
        seam_moves(st, v, us, ps);
        for (int k = 0; k < 2; k++)
            if (us[k] != UINT32_MAX)
                cand[n++] = (target){ move_cost(st, v, us[k], ps[k]), us[k] };
    }
    for (uint32_t i = 0; i < st->vx[v].vf_count && !(st->welds && is_seam(st, v)); i++) {
        const uint32_t *t = st->tri + 3 * (size_t)lv[i];
        int k = corner_at(t, v);
        cand[n].cost = pair_cost(st, v, t[(k + 1) % 3]);
        cand[n].u = t[(k + 1) % 3];
        n++;
    }
    /* insertion sort: stars are small (a vertex that absorbed a fan is the
     * rare long one) */
    for (uint32_t i = 1; i < n; i++) {
        target t = cand[i];
        uint32_t j = i;
        while (j > 0 && target_less(&t, &cand[j - 1])) {
            cand[j] = cand[j - 1];
            j--;
        }
        cand[j] = t;
    }
    return n;
}

/*
 * Queue v's cheapest target, unchecked, among those that may receive a
 * collapse at all (EN_V_TARGET; a neighbour whose star is not whole here
 * never may, so queueing onto it only meant a refusal and a full re-ranking
 * at its pop). The entry stays a lower bound on v's cheapest valid
 * collapse, and exact when valid, so the collapses done and their order are
 * the same as when such neighbours were queued (measured: identical
 * output; at 100M faces, where slabs are thin bands, that re-ranking had
 * become a ninth of the run, bench/RESULTS.md). None: v leaves the queue
 * until a collapse next to it gives it a target.
 */
/* v's cheapest neighbour by cost (best.u UINT32_MAX: none); attrs is a
 * constant at each call, so that the run without weights pays nothing
 * for them in its hottest loop. */
static inline target cheapest_in_fan(const state *st, uint32_t v, int attrs)
{
    const uint32_t *lv = st->pool + st->vx[v].vf_start;
    target best = { 0, UINT32_MAX };
    for (uint32_t i = 0; i < st->vx[v].vf_count; i++) {
        const uint32_t *tr = st->tri + 3 * (size_t)lv[i];
        uint32_t u = tr[(corner_at(tr, v) + 1) % 3];
        if (!(st->s->vflags[u] & EN_V_TARGET))
            continue;
        target t = { pair_cost_with(st, v, u, attrs), u };
        if (best.u == UINT32_MAX || target_less(&t, &best))
            best = t;
    }
    return best;
}

/* v's cheapest target by cost (best.u UINT32_MAX: none). */
static target cheapest_target(state *st, uint32_t v)
{
    if (st->welds && is_seam(st, v)) {
        target best = { 0, UINT32_MAX };
        /* along the seam only, onto copies that may both receive */
        uint32_t us[2], ps[2];
        seam_moves(st, v, us, ps);
        for (int k = 0; k < 2; k++) {
            uint32_t u = us[k];
            if (u == UINT32_MAX || !(st->s->vflags[u] & st->s->vflags[ps[k]] & EN_V_TARGET))
                continue;
            target t = { move_cost(st, v, u, ps[k]), u };
            if (best.u == UINT32_MAX || target_less(&t, &best))
                best = t;
        }
        return best;
    }
    return st->k ? cheapest_in_fan(st, v, 1) : cheapest_in_fan(st, v, 0);
}

static int queue_cheapest(state *st, uint32_t v)
{
    if (!st->vx[v].removable || !st->vx[v].alive || st->vx[v].vf_count == 0)
        return 0;
    target best = cheapest_target(st, v);
    st->vx[v].best_cost = best.cost;
    st->vx[v].best_u = best.u;
    st->vx[v].fallback = 0;
    if (best.u == UINT32_MAX) {
        heap_remove(st, v);
        return 0;
    }
    return heap_set(st, v, best.cost, best.u);
}

/* Queue v's cheapest valid target (checked), or record why there is none. */
static int queue_best_valid(state *st, uint32_t v)
{
    int64_t n = rank_targets(st, v);
    if (n < 0)
        return EPSNET_ENOMEM;
    uint8_t reasons = 0;
    for (int64_t i = 0; i < n; i++) {
        target t = st->cand[i];
        int why = check_collapse(st, v, t.u);
        if (why == 0) {
            st->vx[v].refused = 0;
            st->vx[v].best_cost = t.cost;
            st->vx[v].best_u = t.u;
            st->vx[v].fallback = 1;
            return heap_set(st, v, t.cost, t.u);
        }
        reasons |= (uint8_t)why;
    }
    st->vx[v].refused = reasons;
    st->vx[v].best_u = UINT32_MAX;
    st->vx[v].fallback = 1;
    heap_remove(st, v);
    return 0;
}

static int is_neighbour(const state *st, uint32_t v, uint32_t u)
{
    const uint32_t *lv = st->pool + st->vx[v].vf_start;
    for (uint32_t i = 0; i < st->vx[v].vf_count; i++)
        if (has_corner(st->tri + 3 * (size_t)lv[i], u))
            return 1;
    return 0;
}

/* v's faces onto u: those on the edge v-u die, the others are rewritten
 * and join u's list; v goes, and its quadric joins u's. */
static inline int rewrite_onto(state *st, uint32_t v, uint32_t u)
{
    /* v's list is consumed here; copy it since u's list may move in the pool */
    uint32_t nf = st->vx[v].vf_count;
    if (en_grow((void **)&st->faces, &st->faces_cap, nf, sizeof *st->faces))
        return EPSNET_ENOMEM;
    uint32_t *faces = st->faces;
    memcpy(faces, st->pool + st->vx[v].vf_start, nf * sizeof *faces);
    for (uint32_t i = 0; i < nf; i++) {
        uint32_t f = faces[i];
        uint32_t *t = st->tri + 3 * (size_t)f;
        if (has_corner(t, u)) {
            st->falive[f] = 0;
            st->faces_alive--;
            for (int k = 0; k < 3; k++)
                if (t[k] != v)
                    list_remove(st, t[k], f);
        } else {
            for (int k = 0; k < 3; k++)
                if (t[k] == v)
                    t[k] = u;
            if (list_append(st, u, f))
                return EPSNET_ENOMEM;
        }
    }
    st->vx[v].vf_count = 0;
    st->valive[v] = 0;
    st->vx[v].alive = 0;
    st->vertices_alive--;
    /* (a seam pair's follower has tier 0: its primary's counts) */
    st->given_up += st->tier[v] == 2 || (st->welds && st->tier[st->vx[v].wedge] == 2);
    en_quadric_add(&st->vx[u].q, &st->vx[v].q);
    if (st->k)
        en_aq_add(st->aq + st->na * u, st->aq + st->na * v, st->k);
    st->collapses++;
    return 0;
}

/*
 * What changed after a collapse onto u (v and v2 gone): u's quadric (so
 * every cost *from* u, and the cost of every pair *into* u), and the
 * neighbourhoods in u's ring (validity, checked lazily at pop). A
 * neighbour w needs a full re-ranking only when its queued target was u or
 * a vertex gone, its entry was a checked fallback (a cheaper target may be
 * valid now), or it moves along a seam (its targets are its open ends);
 * otherwise only w -> u is priced.
 */
static inline int requeue_around(state *st, uint32_t u, uint32_t v, uint32_t v2)
{
    int rc = queue_cheapest(st, u);
    const int welds = st->welds;
    uint32_t stamp = ++st->stamp;
    st->vx[u].mark = stamp;
    uint32_t count = st->vx[u].vf_count;
    for (uint32_t i = 0; i < count && rc == 0; i++) {
        const uint32_t *t = st->tri + 3 * (size_t)st->pool[st->vx[u].vf_start + i];
        for (int k = 0; k < 3 && rc == 0; k++) {
            uint32_t w = t[k];
            if (st->vx[w].mark == stamp)
                continue;
            st->vx[w].mark = stamp;
            if (!st->vx[w].removable)
                continue;
            uint32_t b = st->vx[w].best_u;
            if (b == u || b == v || b == UINT32_MAX || st->vx[w].fallback ||
                (welds && (b == v2 || is_seam(st, w)))) {
                rc = queue_cheapest(st, w);
                continue;
            }
            target cand = { pair_cost(st, w, u), u };
            target best = { st->vx[w].best_cost, b };
            if (target_less(&cand, &best)) {
                st->vx[w].best_cost = cand.cost;
                st->vx[w].best_u = u;
                rc = heap_set(st, w, cand.cost, u);
            }
        }
    }
    return rc;
}

/* Collapse v onto u; one of a seam pair takes its twin onto the copy of u
 * on the twin's side. Every copy of u's position then has a new error. */
static int do_collapse(state *st, uint32_t v, uint32_t u)
{
    uint32_t t = v, p = u;
    if (st->welds && is_seam(st, v)) {
        t = st->vx[v].wedge;
        p = seam_partner(st, v, u); /* checked: a copy of u */
    }
    int rc = rewrite_onto(st, v, u);
    if (rc == 0 && t != v)
        rc = rewrite_onto(st, t, p);
    if (rc)
        return rc;
    if (!st->welds) {
        st->vx[u].self_err = err_at(st, u, u);
        return requeue_around(st, u, v, v);
    }
    update_position_err(st, u);
    uint32_t c = u;
    do {
        rc = requeue_around(st, c, v, t);
        c = st->vx[c].wedge;
    } while (rc == 0 && c != u);
    return rc;
}

/* Every vertex's quadric from the faces alive now, as
 * en_quadrics_from_faces() takes them from the input's (the reference
 * normals of the normal bound stay the input's). */
static void refresh_quadrics(state *st)
{
    const en_slab *s = st->s;
    for (uint32_t v = 0; v < s->nv; v++)
        memset(&st->vx[v].q, 0, sizeof st->vx[v].q);
    if (st->k)
        memset(st->aq, 0, (size_t)s->nv * st->na * sizeof *st->aq);
    double aqf[2 + 4 * EN_AQ_MAX_CHANNELS];
    for (uint32_t f = 0; f < s->nt; f++) {
        if (!st->falive[f])
            continue;
        const uint32_t *t = st->tri + 3 * (size_t)f;
        en_quadric k, fold;
        double un[3];
        face_quadric(s->pos, t, &k, un);
        if (st->k) {
            /* the corners' values now: those of the vertices kept */
            en_attr_face_quadric(s->pos, st->value, st->k, t, &fold, aqf);
            en_quadric_add(&k, &fold);
        }
        for (int i = 0; i < 3; i++) {
            en_quadric_add(&st->vx[t[i]].q, &k);
            if (st->k)
                en_aq_add(st->aq + st->na * t[i], aqf, st->k);
        }
    }
    for (uint32_t v = 0; v < s->nv; v++)
        st->vx[v].self_err = position_err(st, v);
}

/* One set of the working arrays, kept between calls in an
 * en_collapse_arrays_new() pool: a state's arrays with their capacities. */
typedef struct arrays {
    uint32_t *pool;
    void *vx_alloc;
    heap_entry *heap;
    target *cand;
    uint32_t *faces;
    uint8_t *tiers;
    uint32_t *ends;
    size_t pool_cap, vx_bytes, heap_cap, cand_cap, faces_cap, tiers_cap, ends_cap;
} arrays;

static void arrays_destroy(void *item)
{
    arrays *a = item;
    en_free(a->pool);
    en_free(a->vx_alloc);
    en_free(a->heap);
    en_free(a->cand);
    en_free(a->faces);
    en_free(a->tiers);
    en_free(a->ends);
    en_free(a);
}

int en_collapse_arrays_new(en_ctxpool **pool)
{
    return en_ctxpool_new(pool, arrays_destroy);
}

/* The caller's tiers as the core takes them: one of a seam pair is queued
 * for both (the copy with the smaller id; its twin follows it, so its own
 * entry is 0), and only when both copies are in the same tier. */
static void seam_tiers(const en_slab *s, const uint8_t *removable, uint8_t *tiers)
{
    for (uint32_t v = 0; v < s->nv; v++) {
        tiers[v] = removable[v];
        if (!(s->vflags[v] & EN_V_SEAM))
            continue;
        uint32_t t = s->wedge[v];
        if (t < v || removable[t] != removable[v])
            tiers[v] = 0;
    }
}

int en_collapse_slab(const en_slab *s, const uint8_t *removable, en_quadric *q, const double *ref_normal,
                     const en_collapse_settings *cs, uint8_t *face_alive, uint8_t *vertex_alive,
                     uint32_t *tri_out, en_collapse_counts *counts, en_ctxpool *pool)
{
    arrays *own = en_ctxpool_take(pool);
    if (!own && !(own = en_calloc(1, sizeof *own)))
        return EPSNET_ENOMEM;
    state st = { 0 };
    st.s = s;
    st.cos_bound = cos(cs->max_normal_dev_deg * (M_PI / 180.0));
    st.tri = tri_out;
    st.falive = face_alive;
    st.valive = vertex_alive;
    memcpy(st.tri, s->tri, 3 * sizeof *st.tri * (size_t)s->nt);
    memset(st.falive, 1, s->nt);
    memset(st.valive, 1, s->nv);
    st.ref_normal = ref_normal;
    st.pool = own->pool, st.pool_cap = own->pool_cap;
    st.heap = own->heap, st.heap_cap = own->heap_cap;
    st.cand = own->cand, st.cand_cap = own->cand_cap;
    st.faces = own->faces, st.faces_cap = own->faces_cap;
    st.ends = own->ends, st.ends_cap = own->ends_cap;
    int rc = 0;
    st.welds = s->has_welds;
    if (st.welds) {
        if (en_grow((void **)&own->tiers, &own->tiers_cap, (size_t)s->nv + 1, 1)) {
            rc = EPSNET_ENOMEM;
            goto out;
        }
        seam_tiers(s, removable, own->tiers);
        removable = own->tiers;
    }
    /* (vx's old contents need no keeping, but growing it as the others
     * grow keeps a run of slightly larger slabs from allocating anew) */
    if (en_grow((void **)&st.pool, &st.pool_cap, 3 * (size_t)s->nt + 8, sizeof *st.pool) ||
        en_grow(&own->vx_alloc, &own->vx_bytes, ((size_t)s->nv + 1) * sizeof *st.vx + 63, 1)) {
        rc = EPSNET_ENOMEM;
        goto out;
    }
    st.vx_alloc = own->vx_alloc;
    st.vx = (vrec *)(((uintptr_t)st.vx_alloc + 63) & ~(uintptr_t)63);
    memcpy(st.pool, s->star, s->star_start[s->nv] * sizeof *st.pool);
    st.pool_len = s->star_start[s->nv];
    for (uint32_t v = 0; v < s->nv; v++) {
        vrec *r = &st.vx[v];
        memset(r, 0, sizeof *r);
        r->vf_start = s->star_start[v];
        r->vf_count = r->vf_cap = en_slab_degree(s, v);
        r->q = q[v];
        r->wedge = st.welds ? s->wedge[v] : v;
        r->best_u = UINT32_MAX;
        r->heap_pos = UINT32_MAX;
        r->removable = removable[v] == 1;
        r->alive = 1;
    }
    if (cs->attr_channels) {
        st.k = cs->attr_channels;
        st.na = en_aq_doubles(st.k);
        st.value = cs->attr_value;
        st.aq = cs->aq;
    }
    /* each copy's error is its position's */
    for (uint32_t v = 0; v < s->nv; v++)
        st.vx[v].self_err = st.welds ? position_err(&st, v) : err_at(&st, v, v);

    st.tier = removable;
    st.by_error = cs->by_error;
    st.max_cost = cs->by_error && cs->max_error >= 0 ? cs->max_error * cs->max_error : INFINITY;
    st.keep_faces = cs->keep_faces;
    st.keep_vertices = cs->keep_vertices;
    st.ceiling = cs->cost_ceiling != 0 ? cs->cost_ceiling : INFINITY;
    st.faces_alive = s->nt;
    for (uint32_t v = 0; v < s->nv; v++) {
        st.vertices_alive += st.vx[v].vf_count > 0;
        st.vx[v].removable = removable[v] == 1;
    }
    int tier2 = 0, met = 0;
    uint64_t refresh = cs->refresh_faces;
    for (;;) {
        for (uint32_t v = 0; v < s->nv && rc == 0; v++)
            if (!tier2 || removable[v] == 2)
                rc = queue_cheapest(&st, v);
        while (rc == 0 && st.heap_len) {
            met = (st.keep_faces && st.faces_alive <= st.keep_faces) ||
                  (st.keep_vertices && st.vertices_alive <= st.keep_vertices);
            if (met)
                break;
            if (refresh && st.faces_alive <= refresh) {
                /* every price changes: queue every vertex again */
                refresh = 0;
                refresh_quadrics(&st);
                for (uint32_t v = 0; v < s->nv && rc == 0; v++)
                    rc = queue_cheapest(&st, v);
                continue;
            }
            heap_entry e = heap_pop(&st);
            if (!st.vx[e.u].alive || !is_neighbour(&st, e.v, e.u) ||
                (st.welds ? move_cost(&st, e.v, e.u, st.k && is_seam(&st, e.v) ? seam_partner(&st, e.v, e.u) : e.u)
                          : pair_cost(&st, e.v, e.u)) != e.cost) {
                /* its target went away or got dearer: rank v's targets again */
                rc = queue_cheapest(&st, e.v);
                continue;
            }
            if (e.cost > st.ceiling) {
                /* the cheapest collapse left is above the round's ceiling,
                 * and so is every other (the queue holds lower bounds):
                 * the round ends here; v waits for the next one */
                rc = heap_set(&st, e.v, e.cost, e.u);
                st.stopped_by_ceiling = 1;
                break;
            }
            if (st.by_error && collapse_error2(&st, e.v, e.u, e.cost) > st.max_cost) {
                /* over the error bound: v waits (a later collapse nearby
                 * may bring its error down, since the area grows too) */
                st.stopped_by_error = 1;
                continue;
            }
            if (check_collapse(&st, e.v, e.u)) {
                rc = queue_best_valid(&st, e.v); /* replace it by v's cheapest valid target */
                continue;
            }
            rc = do_collapse(&st, e.v, e.u);
            st.top_cost = e.cost > st.top_cost ? e.cost : st.top_cost;
            if (cs->taken && en_in_ranges(cs->taken_ranges, cs->taken_nranges, s->gid[e.v]))
                cs->taken[en_cost_bucket(st.top_cost)]++;
            if (cs->progress && (st.collapses & 1023) == 0) {
                atomic_store_explicit(cs->progress, st.collapses, memory_order_relaxed);
                if (cs->stop && atomic_load_explicit(cs->stop, memory_order_relaxed))
                    rc = EPSNET_EINTR; /* cancelled: the caller drops the slab */
            }
        }
        met = (st.keep_faces && st.faces_alive <= st.keep_faces) ||
              (st.keep_vertices && st.vertices_alive <= st.keep_vertices);
        if (rc || met || tier2 || st.stopped_by_ceiling || !(st.keep_faces || st.keep_vertices))
            break;
        /* The first tier is spent and the target is not met: the second
         * tier joins, cheapest first like the rest. */
        tier2 = 1;
        for (uint32_t v = 0; v < s->nv; v++)
            st.vx[v].removable |= removable[v] == 2;
    }
    if (rc == 0) {
        for (uint32_t v = 0; v < s->nv; v++)
            q[v] = st.vx[v].q;
        memset(counts, 0, sizeof *counts);
        counts->collapses = st.collapses;
        counts->given_up = st.given_up;
        counts->faces_left = st.faces_alive;
        counts->vertices_left = st.vertices_alive;
        counts->stopped_by_error = st.stopped_by_error;
        counts->top_cost = st.top_cost;
        if (cs->bucket_of) {
            for (uint32_t v = 0; v < s->nv; v++)
                cs->bucket_of[v] = EN_COST_NONE;
            for (size_t i = 0; i < st.heap_len; i++)
                if (removable[st.heap[i].v] == 1)
                    cs->bucket_of[st.heap[i].v] = (uint16_t)en_cost_bucket(st.heap[i].cost);
            for (uint32_t v = 0; v < s->nv; v++) {
                if (removable[v] != EN_TIER_PRICED || !st.vx[v].alive || st.vx[v].vf_count == 0)
                    continue;
                target t = cheapest_target(&st, v);
                if (t.u != UINT32_MAX)
                    cs->bucket_of[v] = (uint16_t)en_cost_bucket(t.cost);
            }
        }
        for (uint32_t v = 0; v < s->nv && rc == 0; v++) {
            if (!st.vx[v].removable || !st.vx[v].alive)
                continue;
            counts->remaining++;
            if (met || st.stopped_by_ceiling)
                continue; /* left by the target, not refused */
            rc = queue_best_valid(&st, v); /* fresh reasons; the queue is not used again */
            for (int k = 0; k < EN_REFUSE_KINDS; k++)
                counts->refused[k] += (st.vx[v].refused >> k) & 1;
        }
    }
out:
    /* the arrays, grown or not, back to the pool (or freed with the call's own) */
    own->pool = st.pool, own->pool_cap = st.pool_cap;
    own->heap = st.heap, own->heap_cap = st.heap_cap;
    own->cand = st.cand, own->cand_cap = st.cand_cap;
    own->faces = st.faces, own->faces_cap = st.faces_cap;
    own->ends = st.ends, own->ends_cap = st.ends_cap;
    if (pool)
        en_ctxpool_give(pool, own);
    else
        arrays_destroy(own);
    return rc;
}
