/*
 * Exact sign predicates: floating-point filter plus an exact fallback in
 * expansion arithmetic.
 *
 * References: J. R. Shewchuk, "Adaptive Precision Floating-Point Arithmetic
 * and Fast Robust Geometric Predicates", DCG 18 (1997) — error-free sums and
 * products, expansions; H. Edelsbrunner, E. P. Mücke, "Simulation of
 * Simplicity", ACM TOG 9 (1990) — the symbolic tie-break.
 *
 * note: the build uses -ffp-contract=off, so a*b-c is never fused behind our
 * back; the error-free product below uses Dekker's splitting, which is exact
 * under round-to-nearest without any hardware FMA.
 */
#include "core/predicates.h"

#include <math.h>

/*
 * Filter constants, each a proven bound on |computed - exact| divided by the
 * "permanent" (the same expression with every term made non-negative),
 * with generous slack for the rounding of the permanent itself:
 *   det3: two products and a difference per minor (2 eps), one product per
 *         term (1 eps), two sums (2 eps): 5 eps + O(eps^2) -> 8 eps;
 *   dot3: products (1 eps) and two sums (2 eps) -> 6 eps (predicates.h);
 *   minor2: products (1 eps) and one difference (1 eps) -> 4 eps.
 */
#define EN_DET3_BOUND (8.0 * EN_EPS)
#define EN_MINOR2_BOUND (4.0 * EN_EPS)

/* Dekker's splitter 2^27 + 1: a = hi + lo with both halves of 26 bits. */
#define EN_SPLITTER 134217729.0

/* ---- error-free transformations ---- */

/* x + y = a + b exactly, x = fl(a + b) (Knuth's two-sum). */
static inline void two_sum(double a, double b, double *x, double *y)
{
    double s = a + b;
    double bv = s - a;
    double av = s - bv;
    *x = s;
    *y = (a - av) + (b - bv);
}

static inline void split(double a, double *hi, double *lo)
{
    double c = EN_SPLITTER * a;
    double big = c - a;
    *hi = c - big;
    *lo = a - *hi;
}

/* x + y = a * b exactly, x = fl(a * b) (Dekker's two-product). */
static inline void two_product(double a, double b, double *x, double *y)
{
    double p = a * b;
    double ahi, alo, bhi, blo;
    split(a, &ahi, &alo);
    split(b, &bhi, &blo);
    double err = p - ahi * bhi;
    err -= alo * bhi;
    err -= ahi * blo;
    *x = p;
    *y = alo * blo - err;
}

/* ---- expansions: arrays of non-overlapping doubles, increasing magnitude,
 * zero components removed; the value is the exact sum of the components. ---- */

/*
 * h = e + b (Shewchuk's Grow-Expansion with zero elimination). h may not
 * alias e. @return the length of h (at most elen + 1).
 */
static int grow(const double *e, int elen, double b, double *h)
{
    double q = b;
    int hlen = 0;
    for (int i = 0; i < elen; i++) {
        double sum, tail;
        two_sum(q, e[i], &sum, &tail);
        if (tail != 0.0)
            h[hlen++] = tail;
        q = sum;
    }
    if (q != 0.0)
        h[hlen++] = q;
    return hlen;
}

/* e += b in place through a scratch buffer of capacity elen + 1. */
static int grow_in_place(double *e, int elen, double b, double *scratch)
{
    int n = grow(e, elen, b, scratch);
    for (int i = 0; i < n; i++)
        e[i] = scratch[i];
    return n;
}

/* The sign of an expansion is the sign of its largest (last) component. */
static int expansion_sign(const double *e, int elen)
{
    if (elen == 0)
        return 0;
    return e[elen - 1] > 0.0 ? 1 : -1;
}

/* m = exact value of a*d - b*c as an expansion (at most 4 components). */
static int minor2_expansion(double a, double b, double c, double d, double *m)
{
    double ad, ad_tail, bc, bc_tail, scratch[5];
    two_product(a, d, &ad, &ad_tail);
    two_product(b, c, &bc, &bc_tail);
    int n = 0;
    n = grow_in_place(m, n, ad_tail, scratch);
    n = grow_in_place(m, n, ad, scratch);
    n = grow_in_place(m, n, -bc_tail, scratch);
    n = grow_in_place(m, n, -bc, scratch);
    return n;
}

/* acc += s * e exactly; acc has room for accn + 2*elen components. */
static int add_scaled(double *acc, int accn, const double *e, int elen, double s)
{
    double scratch[32];
    for (int i = 0; i < elen; i++) {
        double p, p_tail;
        two_product(e[i], s, &p, &p_tail);
        accn = grow_in_place(acc, accn, p_tail, scratch);
        accn = grow_in_place(acc, accn, p, scratch);
    }
    return accn;
}

static int sign_of(double x)
{
    return (x > 0.0) - (x < 0.0);
}

/* ---- public predicates ---- */

static int orient3_exact(const double a[3], const double b[3], const double c[3])
{
    /* det = a0 (b1 c2 - b2 c1) + a1 (b2 c0 - b0 c2) + a2 (b0 c1 - b1 c0):
     * three minors of 4 components, scaled (8 each), summed (<= 24). */
    double m[4], acc[26];
    int accn = 0, mn;
    mn = minor2_expansion(b[1], b[2], c[1], c[2], m);
    accn = add_scaled(acc, accn, m, mn, a[0]);
    mn = minor2_expansion(b[2], b[0], c[2], c[0], m);
    accn = add_scaled(acc, accn, m, mn, a[1]);
    mn = minor2_expansion(b[0], b[1], c[0], c[1], m);
    accn = add_scaled(acc, accn, m, mn, a[2]);
    return expansion_sign(acc, accn);
}

int en_orient3_sign(const double a[3], const double b[3], const double c[3])
{
    double p0 = b[1] * c[2], q0 = b[2] * c[1];
    double p1 = b[2] * c[0], q1 = b[0] * c[2];
    double p2 = b[0] * c[1], q2 = b[1] * c[0];
    double det = a[0] * (p0 - q0) + a[1] * (p1 - q1) + a[2] * (p2 - q2);
    double perm = fabs(a[0]) * (fabs(p0) + fabs(q0)) + fabs(a[1]) * (fabs(p1) + fabs(q1)) +
                  fabs(a[2]) * (fabs(p2) + fabs(q2));
    double bound = EN_DET3_BOUND * perm;
    if (det > bound)
        return 1;
    if (-det > bound)
        return -1;
    if (perm == 0.0)
        return 0;
    return orient3_exact(a, b, c);
}

int en_dot3_sign(const double a[3], const double b[3])
{
    int s = en_dot3_sign_filtered(a, b);
    if (s != 0 || (a[0] * b[0] == 0.0 && a[1] * b[1] == 0.0 && a[2] * b[2] == 0.0))
        return s;
    double acc[6], scratch[7];
    int n = 0;
    for (int k = 0; k < 3; k++) {
        double p, p_tail;
        two_product(a[k], b[k], &p, &p_tail);
        n = grow_in_place(acc, n, p_tail, scratch);
        n = grow_in_place(acc, n, p, scratch);
    }
    return expansion_sign(acc, n);
}

int en_minor2_sign(double a, double b, double c, double d)
{
    double ad = a * d, bc = b * c;
    double m = ad - bc;
    double bound = EN_MINOR2_BOUND * (fabs(ad) + fabs(bc));
    if (m > bound)
        return 1;
    if (-m > bound)
        return -1;
    if (ad == 0.0 && bc == 0.0)
        return 0;
    double e[4];
    int n = minor2_expansion(a, b, c, d, e);
    return expansion_sign(e, n);
}

int en_cross_sign(const double a[3], const double b[3], int k)
{
    int u = (k + 1) % 3, v = (k + 2) % 3;
    return en_minor2_sign(a[u], a[v], b[u], b[v]);
}

/*
 * det(g_i', g_j', n) with i < j expands (multilinearity, delta_k = g_k' - g_k) to
 *   det(g_i, g_j, n)
 *   + sum_c eps_{i,c} det(e_c, g_j, n)           = eps_{i,c} (g_j x n)_c
 *   + sum_d eps_{j,d} det(g_i, e_d, n)           = -eps_{j,d} (g_i x n)_d
 *   + sum_{c,d} eps_{i,c} eps_{j,d} det(e_c, e_d, n) = (e_c x e_d) . n.
 * With eps_{k,c} = eps^(2^(3k+c)) every monomial has a distinct exponent (a
 * sum of distinct powers of two), and a smaller exponent dominates. For i < j
 * the order is
 *   eps_{i,0}, eps_{i,1}, eps_{i,2}, eps_{j,0}, eps_{j,0} eps_{i,0..2},
 *   eps_{j,1}, eps_{j,1} eps_{i,0..2}, eps_{j,2}, eps_{j,2} eps_{i,0..2}.
 * (e_c x e_d) . n is 0 for c == d and +-n_k for the third axis k, signed by
 * the parity of (c, d, k); so the product terms include every component of
 * n, and the sign is never 0 for n != 0. test_predicates.c checks this order
 * against a determinant with a small actual perturbation.
 */
static int sos_edge_ordered(const double gi[3], const double gj[3], const double n[3])
{
    int s = en_orient3_sign(gi, gj, n);
    if (s)
        return s;
    for (int c = 0; c < 3; c++) {
        s = en_cross_sign(gj, n, c);
        if (s)
            return s;
    }
    for (int d = 0; d < 3; d++) {
        s = -en_cross_sign(gi, n, d);
        if (s)
            return s;
        for (int c = 0; c < 3; c++) {
            if (c == d)
                continue;
            /* (e_c x e_d) = +e_k for (c, d, k) cyclic, -e_k otherwise. */
            int k = 3 - c - d;
            int cyclic = (d == (c + 1) % 3);
            s = sign_of(n[k]);
            if (s)
                return cyclic ? s : -s;
        }
    }
    return 0;
}

int en_sos_edge(const double gi[3], uint32_t i, const double gj[3], uint32_t j,
                const double n[3])
{
    if (i == j)
        return 0;
    if (i < j)
        return sos_edge_ordered(gi, gj, n);
    return -sos_edge_ordered(gj, gi, n);
}

int en_sos_edge_cross_undecided(const double gi[3], uint32_t i, const double gj[3], uint32_t j,
                                const double w[3], const double n[3])
{
    if (i == j)
        return 0;
    /* det(gi, gj, n) = n . (gi x gj) in exact arithmetic, so the exact
     * sign of the dot product is the determinant's exact sign */
    int s = en_dot3_sign(w, n);
    if (s)
        return s;
    return i < j ? sos_edge_ordered(gi, gj, n) : -sos_edge_ordered(gj, gi, n);
}

/*
 * det(a, b, g_k') = det(a, b, g_k) + sum_c eps_{k,c} det(a, b, e_c), and
 * det(a, b, e_c) = (a x b)_c, taken in the order c = 0, 1, 2.
 */
int en_sos_point(const double a[3], const double b[3], const double g[3])
{
    int s = en_orient3_sign(a, b, g);
    if (s)
        return s;
    for (int c = 0; c < 3; c++) {
        s = en_cross_sign(a, b, c);
        if (s)
            return s;
    }
    return 0;
}
