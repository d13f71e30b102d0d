/*
 * Closest points on triangles and a linear bounding-volume hierarchy (see
 * bvh.h for the contract).
 *
 * The point-to-triangle routine classifies p against the Voronoi regions of
 * the triangle's vertices, edges and face, using only dot products of the
 * edge vectors with p's offsets from the corners. It needs a non-zero area;
 * degenerate triangles take the edge path instead.
 */
#include "metrics/bvh.h"

#include <math.h>
#include <string.h>

#include "common/alloc.h"

enum { BVH_LEAF_MAX = 4, BVH_STACK = 256 };

static inline void vsub(double r[3], const double a[3], const double b[3])
{
    r[0] = a[0] - b[0];
    r[1] = a[1] - b[1];
    r[2] = a[2] - b[2];
}

static inline double vdot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline void vcross(double r[3], const double a[3], const double b[3])
{
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}

/* q = a + s*u + t*v */
static inline void vcombine(double q[3], const double a[3], double s, const double u[3], double t,
                            const double v[3])
{
    q[0] = a[0] + s * u[0] + t * v[0];
    q[1] = a[1] + s * u[1] + t * v[1];
    q[2] = a[2] + s * u[2] + t * v[2];
}

static inline double dist2(const double p[3], const double q[3])
{
    double d[3];
    vsub(d, p, q);
    return vdot(d, d);
}

static int degenerate_normal(const double n[3], double l2max)
{
    /* note: l2max^2 * 1e-24 underflows only for edges below ~1e-70, where the
     * triangle is a point for every purpose of this tool. */
    return vdot(n, n) <= 1e-24 * l2max * l2max;
}

static double longest_edge2(const double a[3], const double b[3], const double c[3])
{
    double ab = dist2(a, b), bc = dist2(b, c), ca = dist2(c, a);
    double m = ab > bc ? ab : bc;
    return m > ca ? m : ca;
}

int en_tri_is_degenerate(const double a[3], const double b[3], const double c[3])
{
    double ab[3], ac[3], n[3];
    vsub(ab, b, a);
    vsub(ac, c, a);
    vcross(n, ab, ac);
    return degenerate_normal(n, longest_edge2(a, b, c));
}

double en_closest_on_segment(const double p[3], const double a[3], const double b[3], double q[3])
{
    double ab[3], ap[3];
    vsub(ab, b, a);
    vsub(ap, p, a);
    double len2 = vdot(ab, ab);
    double t = len2 > 0 ? vdot(ap, ab) / len2 : 0;
    if (t <= 0) {
        memcpy(q, a, 3 * sizeof *q);
    } else if (t >= 1) {
        memcpy(q, b, 3 * sizeof *q);
    } else {
        q[0] = a[0] + t * ab[0];
        q[1] = a[1] + t * ab[1];
        q[2] = a[2] + t * ab[2];
    }
    return dist2(p, q);
}

static double closest_on_edges(const double p[3], const double a[3], const double b[3],
                               const double c[3], double q[3])
{
    double qb[3], qc[3];
    double d = en_closest_on_segment(p, a, b, q);
    double db = en_closest_on_segment(p, b, c, qb);
    double dc = en_closest_on_segment(p, c, a, qc);
    if (db < d) {
        d = db;
        memcpy(q, qb, sizeof qb);
    }
    if (dc < d) {
        d = dc;
        memcpy(q, qc, sizeof qc);
    }
    return d;
}

/*
 * Voronoi-region classification of p against a non-degenerate triangle.
 * ab/ac are the edges from a; the d* are projections of p's offsets from
 * the corners on those edges, and the v* are (scaled) barycentric
 * coordinates built from them, so no normal or division is needed until p
 * is known to project inside a region.
 */
static double closest_on_proper_triangle(const double p[3], const double a[3], const double b[3],
                                         const double c[3], const double ab[3], const double ac[3],
                                         double q[3])
{
    double ap[3], bp[3], cp[3];
    vsub(ap, p, a);
    double d1 = vdot(ab, ap), d2 = vdot(ac, ap);
    if (d1 <= 0 && d2 <= 0) {
        memcpy(q, a, 3 * sizeof *q);
        return dist2(p, q);
    }
    vsub(bp, p, b);
    double d3 = vdot(ab, bp), d4 = vdot(ac, bp);
    if (d3 >= 0 && d4 <= d3) {
        memcpy(q, b, 3 * sizeof *q);
        return dist2(p, q);
    }
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        double t = d1 / (d1 - d3);
        vcombine(q, a, t, ab, 0, ac);
        return dist2(p, q);
    }
    vsub(cp, p, c);
    double d5 = vdot(ab, cp), d6 = vdot(ac, cp);
    if (d6 >= 0 && d5 <= d6) {
        memcpy(q, c, 3 * sizeof *q);
        return dist2(p, q);
    }
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        double t = d2 / (d2 - d6);
        vcombine(q, a, 0, ab, t, ac);
        return dist2(p, q);
    }
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
        double bc[3];
        vsub(bc, c, b);
        double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        vcombine(q, b, t, bc, 0, bc);
        return dist2(p, q);
    }
    double inv = 1.0 / (va + vb + vc);
    vcombine(q, a, vb * inv, ab, vc * inv, ac);
    return dist2(p, q);
}

double en_closest_on_triangle(const double p[3], const double a[3], const double b[3],
                              const double c[3], double q[3])
{
    if (en_tri_is_degenerate(a, b, c))
        return closest_on_edges(p, a, b, c, q);
    double ab[3], ac[3];
    vsub(ab, b, a);
    vsub(ac, c, a);
    return closest_on_proper_triangle(p, a, b, c, ab, ac, q);
}

/* ---- building ---- */

/* Spread the low 21 bits of x to every third bit of a 63-bit code. */
static uint64_t spread3(uint64_t x)
{
    x &= 0x1fffff;
    x = (x | x << 32) & 0x1f00000000ffffULL;
    x = (x | x << 16) & 0x1f0000ff0000ffULL;
    x = (x | x << 8) & 0x100f00f00f00f00fULL;
    x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
    x = (x | x << 2) & 0x1249249249249249ULL;
    return x;
}

static const double *corner(const en_bvh *bvh, uint32_t t, int k)
{
    return bvh->xyz + 3 * (size_t)bvh->tri[3 * (size_t)t + k];
}

/*
 * Morton codes of the triangle centroids on a cubic grid of 2^21 cells per
 * side over their bounding box: cubic so that a bit split halves space the
 * same way along every axis.
 */
static void morton_codes(const en_bvh *bvh, uint64_t *code)
{
    double lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (uint32_t t = 0; t < bvh->nt; t++)
        for (int k = 0; k < 3; k++) {
            double c = (corner(bvh, t, 0)[k] + corner(bvh, t, 1)[k] + corner(bvh, t, 2)[k]) / 3;
            lo[k] = c < lo[k] ? c : lo[k];
            hi[k] = c > hi[k] ? c : hi[k];
        }
    double extent = 0;
    for (int k = 0; k < 3; k++)
        extent = hi[k] - lo[k] > extent ? hi[k] - lo[k] : extent;
    double scale = extent > 0 && isfinite(extent) ? 2097151.0 / extent : 0;
    for (uint32_t t = 0; t < bvh->nt; t++) {
        uint64_t m = 0;
        for (int k = 0; k < 3; k++) {
            double c = (corner(bvh, t, 0)[k] + corner(bvh, t, 1)[k] + corner(bvh, t, 2)[k]) / 3;
            double cell = (c - lo[k]) * scale;
            uint64_t ic = cell > 0 ? (cell < 2097151.0 ? (uint64_t)cell : 2097151u) : 0;
            m |= spread3(ic) << k;
        }
        code[t] = m;
    }
}

/* Stable LSD radix sort of (code, id) by code, 8 bits a pass; passes where
 * every key has the same digit are skipped. */
static void radix_sort(uint64_t *code, uint32_t *id, uint64_t *code_tmp, uint32_t *id_tmp, uint32_t n)
{
    for (int shift = 0; shift < 64; shift += 8) {
        size_t count[256] = { 0 };
        for (uint32_t i = 0; i < n; i++)
            count[(code[i] >> shift) & 255]++;
        if (count[(code[0] >> shift) & 255] == n)
            continue;
        size_t sum = 0;
        for (int d = 0; d < 256; d++) {
            size_t c = count[d];
            count[d] = sum;
            sum += c;
        }
        for (uint32_t i = 0; i < n; i++) {
            size_t slot = count[(code[i] >> shift) & 255]++;
            code_tmp[slot] = code[i];
            id_tmp[slot] = id[i];
        }
        memcpy(code, code_tmp, n * sizeof *code);
        memcpy(id, id_tmp, n * sizeof *id);
    }
}

/* First index in (lo, hi) whose code has bit `bit` set; codes in [lo, hi)
 * are sorted and agree above that bit, so the set ones form a suffix. */
static uint32_t first_with_bit(const uint64_t *code, uint32_t lo, uint32_t hi, int bit)
{
    uint64_t mask = 1ULL << bit;
    uint32_t a = lo + 1, b = hi - 1;
    while (a < b) {
        uint32_t m = a + (b - a) / 2;
        if (code[m] & mask)
            b = m;
        else
            a = m + 1;
    }
    return a;
}

static uint32_t split_point(const uint64_t *code, uint32_t lo, uint32_t hi)
{
    uint64_t diff = code[lo] ^ code[hi - 1];
    if (diff == 0)
        return lo + (hi - lo) / 2;
    return first_with_bit(code, lo, hi, 63 - __builtin_clzll(diff));
}

/* Float boxes halve the nodes (and the cache misses of a query); rounding
 * outward keeps every box around its triangles, so pruning stays exact. */
static float float_below(double x)
{
    float f = (float)x;
    return (double)f > x ? nextafterf(f, -INFINITY) : f;
}

static float float_above(double x)
{
    float f = (float)x;
    return (double)f < x ? nextafterf(f, INFINITY) : f;
}

static void leaf_box(const en_bvh *bvh, en_bvh_node *node)
{
    double lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (uint32_t i = node->first; i < node->first + node->count; i++)
        for (int c = 0; c < 3; c++) {
            const double *v = bvh->packed + 9 * (size_t)i + 3 * c;
            for (int k = 0; k < 3; k++) {
                lo[k] = v[k] < lo[k] ? v[k] : lo[k];
                hi[k] = v[k] > hi[k] ? v[k] : hi[k];
            }
        }
    for (int k = 0; k < 3; k++) {
        node->lo[k] = float_below(lo[k]);
        node->hi[k] = float_above(hi[k]);
    }
}

/* Copy the corners in leaf order: a query then reads one contiguous run per
 * leaf instead of chasing indices into the vertex array. */
static void pack_triangles(en_bvh *bvh)
{
    for (uint32_t i = 0; i < bvh->nt; i++) {
        double *dst = bvh->packed + 9 * (size_t)i;
        for (int c = 0; c < 3; c++)
            memcpy(dst + 3 * c, corner(bvh, bvh->order[i], c), 3 * sizeof *dst);
        bvh->degenerate[i] = (uint8_t)en_tri_is_degenerate(dst, dst + 3, dst + 6);
    }
}

/*
 * Top-down over the sorted codes. Children are allocated as a pair after
 * their parent, so a reverse sweep over the nodes sees every child before its
 * parent and the boxes can be merged bottom-up without recursion.
 */
static void build_nodes(en_bvh *bvh, const uint64_t *code)
{
    uint32_t stack_node[BVH_STACK], stack_lo[BVH_STACK], stack_hi[BVH_STACK];
    int sp = 0;
    bvh->nnodes = 1;
    stack_node[sp] = 0;
    stack_lo[sp] = 0;
    stack_hi[sp] = bvh->nt;
    sp++;
    while (sp > 0) {
        sp--;
        uint32_t node = stack_node[sp], lo = stack_lo[sp], hi = stack_hi[sp];
        en_bvh_node *nd = &bvh->nodes[node];
        if (hi - lo <= BVH_LEAF_MAX) {
            nd->first = lo;
            nd->count = hi - lo;
            leaf_box(bvh, nd);
            continue;
        }
        uint32_t mid = split_point(code, lo, hi);
        uint32_t left = bvh->nnodes;
        bvh->nnodes += 2;
        nd->first = left;
        nd->count = 0;
        /* note: depth is at most 63 bit splits + 32 middle splits, and the
         * stack holds at most one pending sibling per level. */
        stack_node[sp] = left + 1;
        stack_lo[sp] = mid;
        stack_hi[sp] = hi;
        sp++;
        stack_node[sp] = left;
        stack_lo[sp] = lo;
        stack_hi[sp] = mid;
        sp++;
    }
    for (uint32_t i = bvh->nnodes; i-- > 0;) {
        en_bvh_node *nd = &bvh->nodes[i];
        if (nd->count)
            continue;
        const en_bvh_node *l = &bvh->nodes[nd->first], *r = &bvh->nodes[nd->first + 1];
        for (int k = 0; k < 3; k++) {
            nd->lo[k] = l->lo[k] < r->lo[k] ? l->lo[k] : r->lo[k];
            nd->hi[k] = l->hi[k] > r->hi[k] ? l->hi[k] : r->hi[k];
        }
    }
}

int en_bvh_build(en_bvh *bvh, const double *xyz, const uint32_t *tri, uint32_t nt)
{
    memset(bvh, 0, sizeof *bvh);
    bvh->xyz = xyz;
    bvh->tri = tri;
    bvh->nt = nt;
    if (nt == 0)
        return 0;
    uint64_t *code = en_malloc(nt * sizeof *code);
    uint64_t *code_tmp = en_malloc(nt * sizeof *code_tmp);
    uint32_t *id_tmp = en_malloc(nt * sizeof *id_tmp);
    bvh->order = en_malloc(nt * sizeof *bvh->order);
    bvh->nodes = en_malloc((2 * (size_t)nt - 1) * sizeof *bvh->nodes);
    bvh->packed = en_malloc(9 * (size_t)nt * sizeof *bvh->packed);
    bvh->degenerate = en_malloc(nt);
    if (!code || !code_tmp || !id_tmp || !bvh->order || !bvh->nodes || !bvh->packed || !bvh->degenerate) {
        en_free(code);
        en_free(code_tmp);
        en_free(id_tmp);
        en_bvh_free(bvh);
        return -1;
    }
    for (uint32_t t = 0; t < nt; t++)
        bvh->order[t] = t;
    morton_codes(bvh, code);
    radix_sort(code, bvh->order, code_tmp, id_tmp, nt);
    en_free(code_tmp);
    en_free(id_tmp);
    pack_triangles(bvh);
    build_nodes(bvh, code);
    en_free(code);
    /* note: room was made for the worst case, 2n - 1 nodes; leaves of up to
     * four triangles need far fewer */
    en_bvh_node *fitted = en_realloc(bvh->nodes, bvh->nnodes * sizeof *bvh->nodes);
    if (fitted)
        bvh->nodes = fitted;
    return 0;
}

void en_bvh_free(en_bvh *bvh)
{
    en_free(bvh->nodes);
    en_free(bvh->order);
    en_free(bvh->packed);
    en_free(bvh->degenerate);
    memset(bvh, 0, sizeof *bvh);
}

/* ---- queries ---- */

/* Branch-free: lo <= hi, so at most one of the two offsets is positive. */
static inline double box_dist2(const en_bvh_node *nd, const double p[3])
{
    double d2 = 0;
    for (int k = 0; k < 3; k++) {
        double below = (double)nd->lo[k] - p[k], above = p[k] - (double)nd->hi[k];
        double d = below > above ? below : above;
        d = d > 0 ? d : 0;
        d2 += d * d;
    }
    return d2;
}

/*
 * Query state. min_* is the exact nearest distance so far (ties to the lower
 * triangle id); pick_* is the normal rule's choice among the triangles within
 * tie_dist of that distance.
 */
typedef struct query {
    const double *p, *prefer;
    double tie_dist;
    double min_d2, min_point[3];
    uint32_t min_face, min_slot;
    double bound;             /* prune beyond: min_d2, widened by tie_dist with prefer */
    double pick_d2, pick_dot;
    uint32_t pick_face;
} query;

static inline double tie_bound(const query *qs)
{
    if (!qs->prefer)
        return qs->min_d2;
    double r = sqrt(qs->min_d2) + qs->tie_dist;
    return r * r;
}

/* Distance from p to the box of one packed triangle: a cheap rejection
 * before the exact test, since most triangles of an opened leaf are far. */
static inline double corner_box_dist2(const double *v, const double p[3])
{
    double d2 = 0;
    for (int k = 0; k < 3; k++) {
        double lo = v[k], hi = v[k];
        lo = v[3 + k] < lo ? v[3 + k] : lo;
        hi = v[3 + k] > hi ? v[3 + k] : hi;
        lo = v[6 + k] < lo ? v[6 + k] : lo;
        hi = v[6 + k] > hi ? v[6 + k] : hi;
        double below = lo - p[k], above = p[k] - hi;
        double d = below > above ? below : above;
        d = d > 0 ? d : 0;
        d2 += d * d;
    }
    return d2;
}

static void visit_slot(const en_bvh *bvh, query *qs, uint32_t slot)
{
    const double *v = bvh->packed + 9 * (size_t)slot;
    if (corner_box_dist2(v, qs->p) > qs->bound)
        return;
    uint32_t t = bvh->order[slot];
    double q[3], d2;
    int degenerate = bvh->degenerate[slot];
    double ab[3], ac[3];
    vsub(ab, v + 3, v);
    vsub(ac, v + 6, v);
    if (degenerate)
        d2 = closest_on_edges(qs->p, v, v + 3, v + 6, q);
    else
        d2 = closest_on_proper_triangle(qs->p, v, v + 3, v + 6, ab, ac, q);
    if (d2 < qs->min_d2 || (d2 == qs->min_d2 && t < qs->min_face)) {
        qs->min_d2 = d2;
        qs->min_face = t;
        qs->min_slot = slot;
        memcpy(qs->min_point, q, sizeof q);
        qs->bound = tie_bound(qs);
    }
    if (!qs->prefer || degenerate || d2 > qs->bound)
        return;
    double n[3];
    vcross(n, ab, ac);
    double dot = vdot(n, qs->prefer) / sqrt(vdot(n, n));
    int stale = qs->pick_face == UINT32_MAX || qs->pick_d2 > qs->bound;
    if (stale || dot > qs->pick_dot || (dot == qs->pick_dot && t < qs->pick_face)) {
        qs->pick_face = t;
        qs->pick_d2 = d2;
        qs->pick_dot = dot;
    }
}

int en_bvh_nearest(const en_bvh *bvh, const double p[3], uint32_t hint, const double *prefer,
                   double tie_dist, en_bvh_hit *hit)
{
    if (bvh->nt == 0)
        return -1;
    query qs = { .p = p, .prefer = prefer, .tie_dist = tie_dist, .min_d2 = INFINITY,
                 .min_face = UINT32_MAX, .min_slot = UINT32_MAX, .bound = INFINITY, .pick_face = UINT32_MAX, .pick_dot = -2 };
    if (hint < bvh->nt)
        visit_slot(bvh, &qs, hint);
    uint32_t stack[BVH_STACK];
    double stack_d2[BVH_STACK];
    int sp = 0;
    stack[sp] = 0;
    stack_d2[sp] = box_dist2(&bvh->nodes[0], p);
    sp++;
    while (sp > 0) {
        sp--;
        if (stack_d2[sp] > qs.bound)
            continue;
        const en_bvh_node *nd = &bvh->nodes[stack[sp]];
        if (nd->count) {
            for (uint32_t i = nd->first; i < nd->first + nd->count; i++)
                if (i != hint)
                    visit_slot(bvh, &qs, i);
            continue;
        }
        uint32_t near = nd->first, far = nd->first + 1;
        double dn = box_dist2(&bvh->nodes[near], p), df = box_dist2(&bvh->nodes[far], p);
        if (df < dn) {
            uint32_t t = near;
            near = far;
            far = t;
            double d = dn;
            dn = df;
            df = d;
        }
        double bound = qs.bound;
        /* the far child goes below the near one so the near one is opened
         * first and tightens the bound before the far one is looked at */
        if (df <= bound) {
            stack[sp] = far;
            stack_d2[sp] = df;
            sp++;
        }
        if (dn <= bound) {
            stack[sp] = near;
            stack_d2[sp] = dn;
            sp++;
        }
    }
    hit->d2 = qs.min_d2;
    memcpy(hit->point, qs.min_point, sizeof hit->point);
    int picked = qs.prefer && qs.pick_face != UINT32_MAX && qs.pick_d2 <= qs.bound;
    hit->face = picked ? qs.pick_face : qs.min_face;
    hit->slot = qs.min_slot;
    hit->face_dot = picked ? qs.pick_dot : -2;
    return 0;
}
