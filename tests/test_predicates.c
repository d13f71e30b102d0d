/*
 * Exact predicates (src/core/predicates.c) against a slow, independent
 * reference: every double vector is rewritten as integers times a power of
 * two (when that fits in 60 bits), and the sign is computed in 128-bit
 * integer arithmetic. Inputs are random, near-degenerate (rounded
 * combinations, one-ulp nudges) and exactly degenerate (coplanar, parallel,
 * zero). The symbolic tie-break is checked against coefficients extracted
 * from the perturbed determinant itself, not against its derivation.
 */
#include "core/predicates.h"
#include "testlib.h"

typedef __int128 i128;

/* ---- deterministic random numbers ---- */

static uint64_t rng_state = 0x1234567887654321ull;

static uint64_t rnd(void)
{
    uint64_t z = (rng_state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static int64_t rnd_range(int64_t lo, int64_t hi)
{
    return lo + (int64_t)(rnd() % (uint64_t)(hi - lo + 1));
}

/* A random double with a 53-bit mantissa and exponent in [e_lo, e_hi]. */
static double rnd_double(int e_lo, int e_hi)
{
    double m = (double)(rnd() >> 11) * 0x1p-53;
    if (m == 0.0)
        m = 0.5;
    double v = ldexp(m, (int)rnd_range(e_lo, e_hi));
    return rnd() & 1 ? -v : v;
}

/* ---- the reference ---- */

/*
 * v[0..k-1] = 2^e * out[0..k-1] exactly with |out| < 2^60, for one e.
 * @return 0 when that does not fit (the case is then skipped).
 */
static int to_ints(const double *v, int k, int64_t *out)
{
    int emin = INT32_MAX;
    for (int i = 0; i < k; i++) {
        if (v[i] == 0.0)
            continue;
        int e;
        double f = frexp(v[i], &e);
        uint64_t mant = (uint64_t)fabs(ldexp(f, 53));
        int low = e - 53 + __builtin_ctzll(mant); /* exponent of the lowest set bit */
        if (low < emin)
            emin = low;
    }
    for (int i = 0; i < k; i++) {
        if (v[i] == 0.0) {
            out[i] = 0;
            continue;
        }
        double m = ldexp(v[i], -emin);
        if (fabs(m) >= 0x1p60 || m != floor(m))
            return 0;
        out[i] = (int64_t)m;
    }
    return 1;
}

static int sign128(i128 x)
{
    return (x > 0) - (x < 0);
}

/* sign(sum_i a_i * m_i) for |a_i| < 2^60, |m_i| < 2^122, via 64-bit halves. */
static int sign_sum_products(const int64_t a[3], const i128 m[3])
{
    i128 hi = 0, lo = 0;
    for (int i = 0; i < 3; i++) {
        i128 mh = m[i] >> 64;                       /* floor */
        i128 ml = m[i] - (mh * ((i128)1 << 64));    /* 0 .. 2^64 - 1 */
        hi += (i128)a[i] * mh;
        lo += (i128)a[i] * ml;
    }
    i128 carry = lo >> 64;
    lo -= carry * ((i128)1 << 64);
    hi += carry;
    return hi ? sign128(hi) : (lo > 0);
}

static int ref_det_int(const int64_t a[3], const int64_t b[3], const int64_t c[3])
{
    i128 m[3] = {
        (i128)b[1] * c[2] - (i128)b[2] * c[1],
        (i128)b[2] * c[0] - (i128)b[0] * c[2],
        (i128)b[0] * c[1] - (i128)b[1] * c[0],
    };
    return sign_sum_products(a, m);
}

/* @return the reference sign, or 2 when the input cannot be represented. */
static int ref_orient3(const double a[3], const double b[3], const double c[3])
{
    int64_t ia[3], ib[3], ic[3];
    if (!to_ints(a, 3, ia) || !to_ints(b, 3, ib) || !to_ints(c, 3, ic))
        return 2;
    return ref_det_int(ia, ib, ic);
}

static int ref_dot3(const double a[3], const double b[3])
{
    int64_t ia[3], ib[3];
    if (!to_ints(a, 3, ia) || !to_ints(b, 3, ib))
        return 2;
    i128 s = 0;
    for (int k = 0; k < 3; k++)
        s += (i128)ia[k] * ib[k];
    return sign128(s);
}

static int ref_minor2(double a, double b, double c, double d)
{
    double r1[2] = {a, b}, r2[2] = {c, d};
    int64_t i1[2], i2[2];
    if (!to_ints(r1, 2, i1) || !to_ints(r2, 2, i2))
        return 2;
    return sign128((i128)i1[0] * i2[1] - (i128)i1[1] * i2[0]);
}

/* ---- input families ---- */

/* A vector whose components share a scale 2^e, each with its own small
 * offset, so that to_ints() always fits. */
static void rnd_vector(double v[3])
{
    int e = (int)rnd_range(-250, 250);
    for (int k = 0; k < 3; k++)
        v[k] = rnd_double(e - 6, e);
}

/* One ulp on a non-zero component (a zero one would become a subnormal,
 * outside the predicates' range precondition). */
static void nudge(double v[3])
{
    int k = (int)rnd_range(0, 2);
    for (int tries = 0; tries < 3 && v[k] == 0.0; tries++)
        k = (k + 1) % 3;
    if (v[k] != 0.0)
        v[k] = nextafter(v[k], rnd() & 1 ? INFINITY : -INFINITY);
}

static int checked;  /* cases the reference could represent */
static int skipped;

#define CHECK_AGAINST_REF(got, ref)          \
    do {                                     \
        int r_ = (ref);                      \
        if (r_ == 2) {                       \
            skipped++;                       \
        } else {                             \
            checked++;                       \
            CHECK_EQ_INT((got), r_);         \
        }                                    \
    } while (0)

TEST(orient3_matches_reference_on_random_vectors)
{
    for (int it = 0; it < 20000; it++) {
        double a[3], b[3], c[3];
        rnd_vector(a);
        rnd_vector(b);
        rnd_vector(c);
        CHECK_AGAINST_REF(en_orient3_sign(a, b, c), ref_orient3(a, b, c));
    }
}

TEST(orient3_matches_reference_on_rounded_coplanar_vectors)
{
    /* c = fl(alpha a + beta b): coplanar up to one rounding, the hardest
     * case for a filter. Half of them get one more one-ulp nudge. */
    for (int it = 0; it < 40000; it++) {
        double a[3], b[3], c[3];
        rnd_vector(a);
        for (int k = 0; k < 3; k++)
            b[k] = a[k] * rnd_double(-3, 3) + rnd_double(-40, 0) * a[(k + 1) % 3];
        double alpha = rnd_double(-2, 2), beta = rnd_double(-2, 2);
        for (int k = 0; k < 3; k++)
            c[k] = alpha * a[k] + beta * b[k];
        if (it & 1)
            nudge(c);
        int s = en_orient3_sign(a, b, c);
        CHECK_AGAINST_REF(s, ref_orient3(a, b, c));
        /* antisymmetry and cyclic symmetry of the determinant */
        CHECK_EQ_INT(en_orient3_sign(b, a, c), -s);
        CHECK_EQ_INT(en_orient3_sign(c, a, b), s);
    }
}

TEST(orient3_is_zero_exactly_on_degenerate_inputs)
{
    /* Exactly coplanar integer combinations (small mantissas, so a, b and
     * p a + q b are all exact doubles), parallel and zero vectors. */
    for (int it = 0; it < 20000; it++) {
        int e = (int)rnd_range(-200, 200);
        double a[3], b[3], c[3];
        for (int k = 0; k < 3; k++) {
            a[k] = ldexp((double)rnd_range(-(1 << 30), 1 << 30), e);
            b[k] = ldexp((double)rnd_range(-(1 << 30), 1 << 30), e);
        }
        double p = (double)rnd_range(-8, 8), q = (double)rnd_range(-8, 8);
        for (int k = 0; k < 3; k++)
            c[k] = p * a[k] + q * b[k];
        CHECK_EQ_INT(en_orient3_sign(a, b, c), 0);
        CHECK_EQ_INT(en_orient3_sign(c, a, b), 0);
        CHECK_EQ_INT(ref_orient3(a, b, c), 0);
        /* one ulp off the plane is never zero, and agrees with the reference */
        nudge(c);
        int s = en_orient3_sign(a, b, c);
        CHECK_AGAINST_REF(s, ref_orient3(a, b, c));
        double two_a[3] = {2 * a[0], 2 * a[1], 2 * a[2]};
        CHECK_EQ_INT(en_orient3_sign(a, two_a, b), 0);
    }
    double z[3] = {0, 0, 0}, a[3] = {1, 2, 3}, b[3] = {-4, 5, 0.5};
    CHECK_EQ_INT(en_orient3_sign(z, a, b), 0);
    CHECK_EQ_INT(en_orient3_sign(a, b, z), 0);
    double ex[3] = {1, 0, 0}, ey[3] = {0, 1, 0}, ez[3] = {0, 0, 1};
    CHECK_EQ_INT(en_orient3_sign(ex, ey, ez), 1);
    CHECK_EQ_INT(en_orient3_sign(ey, ex, ez), -1);
}

TEST(orient3_sign_survives_power_of_two_scaling)
{
    /* Scaling one vector by 2^k leaves the sign unchanged; across the whole
     * supported range this exercises the exponent handling. */
    for (int it = 0; it < 5000; it++) {
        double a[3], b[3], c[3];
        rnd_vector(a);
        rnd_vector(b);
        double alpha = rnd_double(-2, 2), beta = rnd_double(-2, 2);
        for (int k = 0; k < 3; k++)
            c[k] = alpha * a[k] + beta * b[k];
        int s = en_orient3_sign(a, b, c);
        int k = (int)rnd_range(-40, 40);
        double sa[3] = {ldexp(a[0], k), ldexp(a[1], k), ldexp(a[2], k)};
        CHECK_EQ_INT(en_orient3_sign(sa, b, c), s);
    }
}

TEST(dot_and_minor_match_reference_near_zero)
{
    for (int it = 0; it < 40000; it++) {
        double a[3], b[3];
        rnd_vector(a);
        rnd_vector(b);
        /* make b nearly orthogonal to a: b2 = -(a0 b0 + a1 b1) / a2, rounded */
        if (it & 1)
            b[2] = -(a[0] * b[0] + a[1] * b[1]) / a[2];
        if (it & 2)
            nudge(b);
        CHECK_AGAINST_REF(en_dot3_sign(a, b), ref_dot3(a, b));

        double p = rnd_double(-100, 100), q = rnd_double(-100, 100);
        double r = rnd_double(-100, 100);
        double s = (it & 1) ? q * r / p : rnd_double(-100, 100); /* p s ~ q r */
        CHECK_AGAINST_REF(en_minor2_sign(p, q, r, s), ref_minor2(p, q, r, s));
    }
    /* exact zeros */
    double a[3] = {3, -4, 0}, b[3] = {4, 3, 17};
    CHECK_EQ_INT(en_dot3_sign(a, b), 0);
    CHECK_EQ_INT(en_minor2_sign(3, 6, 5, 10), 0);
    CHECK_EQ_INT(en_minor2_sign(0x1p-200, 1, 1, 0x1p200), 0);
    CHECK_EQ_INT(en_minor2_sign(0, 0, 5, 7), 0);
    /* b = 1 + 2^-26: b^2 = 1 + 2^-25 + 2^-52 is an exact double, so
     * |1 b; b d| is 0 for d = b^2 and -2^-52 for d = 1 + 2^-25, far below
     * the filter's bound: only the exact path can tell. */
    double b26 = 1 + 0x1p-26;
    CHECK_EQ_INT(en_minor2_sign(1, b26, b26, 1 + 0x1p-25 + 0x1p-52), 0);
    CHECK_EQ_INT(en_minor2_sign(1, b26, b26, 1 + 0x1p-25), -1);
    CHECK_EQ_INT(en_minor2_sign(b26, 1, 1 + 0x1p-25, b26), 1);
}

/* ---- the symbolic tie-break, checked by brute force ---- */

/*
 * Independent evaluation of sign det(g_i', g_j', n): the perturbed
 * determinant is multilinear in the six perturbation variables x_{v,c}
 * (v in {i, j}, c in 0..2). Each monomial's coefficient is extracted by
 * inclusion-exclusion from exact evaluations with x in {0, 1}, and the
 * monomials are ranked by their exponent sum_{(v,c) in S} 2^(3 id_v + c)
 * (smaller exponent = larger term). The first non-zero coefficient decides.
 */
static int brute_sos_edge(const int64_t gi[3], uint32_t i, const int64_t gj[3], uint32_t j,
                          const int64_t n[3])
{
    uint32_t id[2] = {i, j};
    const int64_t *g[2] = {gi, gj};
    i128 value[64];
    for (int mask = 0; mask < 64; mask++) {
        int64_t p[2][3];
        for (int v = 0; v < 2; v++)
            for (int c = 0; c < 3; c++)
                p[v][c] = g[v][c] + ((mask >> (3 * v + c)) & 1);
        i128 m[3] = {
            (i128)p[1][1] * n[2] - (i128)p[1][2] * n[1],
            (i128)p[1][2] * n[0] - (i128)p[1][0] * n[2],
            (i128)p[1][0] * n[1] - (i128)p[1][1] * n[0],
        };
        value[mask] = 0;
        for (int c = 0; c < 3; c++)
            value[mask] += p[0][c] * m[c];
    }
    int best_sign = 0;
    uint64_t best_exp = UINT64_MAX;
    for (int s = 0; s < 64; s++) {
        i128 coef = 0;
        for (int t = 0; t < 64; t++) {
            if ((t & s) != t)
                continue;
            int parity = __builtin_popcount((unsigned)(s ^ t)) & 1;
            coef += parity ? -value[t] : value[t];
        }
        if (coef == 0)
            continue;
        uint64_t exp = 0;
        for (int b = 0; b < 6; b++)
            if ((s >> b) & 1)
                exp += 1ull << (3 * id[b / 3] + b % 3);
        if (exp < best_exp) {
            best_exp = exp;
            best_sign = sign128(coef);
        }
    }
    return best_sign;
}

static int brute_sos_point(const int64_t a[3], const int64_t b[3], const int64_t gk[3])
{
    /* det(a, b, g + x) is linear in x = (x_0, x_1, x_2): the constant term
     * is det(a, b, g), the coefficient of x_c is det(a, b, e_c); the single
     * variables rank by c. */
    int s = ref_det_int(a, b, gk);
    if (s)
        return s;
    for (int c = 0; c < 3; c++) {
        int64_t e[3] = {0, 0, 0};
        e[c] = 1;
        s = ref_det_int(a, b, e);
        if (s)
            return s;
    }
    return 0;
}

static void to_double3(const int64_t v[3], double d[3])
{
    for (int k = 0; k < 3; k++)
        d[k] = (double)v[k];
}

TEST(sos_edge_matches_brute_force_perturbation)
{
    /* Small lattice points, normals chosen to hit every tie: on the plane of
     * g_i and g_j, parallel to either, along axes, and random. */
    int tested_ties = 0;
    for (int it = 0; it < 20000; it++) {
        int64_t gi[3], gj[3], n[3];
        for (int k = 0; k < 3; k++) {
            gi[k] = rnd_range(-3, 3);
            gj[k] = rnd_range(-3, 3);
        }
        int kind = it % 5;
        for (int k = 0; k < 3; k++) {
            switch (kind) {
            case 0: n[k] = rnd_range(-5, 5); break;
            case 1: n[k] = gi[k] * rnd_range(-2, 2) + gj[k] * rnd_range(-2, 2); break;
            case 2: n[k] = gi[k]; break;
            case 3: n[k] = gj[k] * 2; break;
            default: n[k] = k == (it / 5) % 3 ? rnd_range(-1, 1) : 0; break;
            }
        }
        if (!n[0] && !n[1] && !n[2])
            continue;
        uint32_t i = (uint32_t)rnd_range(0, 20), j = (uint32_t)rnd_range(0, 20);
        if (i == j)
            continue;
        double di[3], dj[3], dn[3];
        to_double3(gi, di);
        to_double3(gj, dj);
        to_double3(n, dn);
        int want = brute_sos_edge(gi, i, gj, j, n);
        int got = en_sos_edge(di, i, dj, j, dn);
        CHECK(got != 0);
        CHECK_EQ_INT(got, want);
        CHECK_EQ_INT(en_sos_edge(dj, j, di, i, dn), -got);
        /* the winding test's form: the pair's cross product once, a
         * filtered dot product per normal, the rest only when undecided */
        double w[3] = { di[1] * dj[2] - di[2] * dj[1], di[2] * dj[0] - di[0] * dj[2], di[0] * dj[1] - di[1] * dj[0] };
        int fast = en_dot3_sign_filtered(w, dn);
        CHECK_EQ_INT(fast ? fast : en_sos_edge_cross_undecided(di, i, dj, j, w, dn), want);
        CHECK_EQ_INT(en_sos_edge_cross_undecided(di, i, dj, j, w, dn), want);
        if (ref_det_int(gi, gj, n) == 0)
            tested_ties++;
    }
    CHECK(tested_ties > 5000);
}

TEST(sos_point_matches_brute_force_and_is_zero_only_for_parallel_normals)
{
    for (int it = 0; it < 20000; it++) {
        int64_t a[3], b[3], g[3];
        for (int k = 0; k < 3; k++) {
            a[k] = rnd_range(-4, 4);
            g[k] = rnd_range(-3, 3);
        }
        int kind = it % 4;
        for (int k = 0; k < 3; k++) {
            switch (kind) {
            case 0: b[k] = rnd_range(-4, 4); break;
            case 1: b[k] = g[k] * rnd_range(1, 2) - a[k] * rnd_range(0, 1); break; /* ties */
            case 2: b[k] = a[k] * 3; break;                                        /* parallel */
            default: b[k] = g[k]; break;
            }
        }
        double da[3], db[3], dg[3];
        to_double3(a, da);
        to_double3(b, db);
        to_double3(g, dg);
        int got = en_sos_point(da, db, dg);
        CHECK_EQ_INT(got, brute_sos_point(a, b, g));
        int parallel = (a[1] * b[2] == a[2] * b[1]) && (a[2] * b[0] == a[0] * b[2]) &&
                       (a[0] * b[1] == a[1] * b[0]);
        CHECK_EQ_INT(got == 0, parallel);
    }
}

int main(void)
{
    RUN(orient3_matches_reference_on_random_vectors);
    RUN(orient3_matches_reference_on_rounded_coplanar_vectors);
    RUN(orient3_is_zero_exactly_on_degenerate_inputs);
    RUN(orient3_sign_survives_power_of_two_scaling);
    RUN(dot_and_minor_match_reference_near_zero);
    RUN(sos_edge_matches_brute_force_perturbation);
    RUN(sos_point_matches_brute_force_and_is_zero_only_for_parallel_normals);
    printf("reference cases %d, unrepresentable (skipped) %d\n", checked, skipped);
    CHECK(checked > 100000);
    return tl_finish();
}
