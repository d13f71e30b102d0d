/*
 * Arithmetic the generator needs to give the same bytes on every machine:
 * trigonometry of rational turns from + - * / alone (libm's sin/cos may
 * differ by an ulp between platforms), an exact orientation predicate for
 * float coordinates (the convexity of the convex shapes is decided on the
 * coordinates as written), and a keyed permutation for shuffled output.
 */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "gen/gen_internal.h"

__extension__ typedef __int128 en_i128;
__extension__ typedef unsigned __int128 en_u128;

/* Taylor series on [0, pi/4]: the first omitted term is below 2^-60. */
static double sin_kernel(double x)
{
    double x2 = x * x;
    double p = 1.0 / 355687428096000.0;          /* 1/17! */
    p = p * x2 - 1.0 / 1307674368000.0;          /* 1/15! */
    p = p * x2 + 1.0 / 6227020800.0;             /* 1/13! */
    p = p * x2 - 1.0 / 39916800.0;               /* 1/11! */
    p = p * x2 + 1.0 / 362880.0;                 /* 1/9! */
    p = p * x2 - 1.0 / 5040.0;                   /* 1/7! */
    p = p * x2 + 1.0 / 120.0;                    /* 1/5! */
    p = p * x2 - 1.0 / 6.0;                      /* 1/3! */
    return x + x * x2 * p;
}

static double cos_kernel(double x)
{
    double x2 = x * x;
    double p = 1.0 / 6402373705728000.0;         /* 1/18! */
    p = p * x2 - 1.0 / 20922789888000.0;         /* 1/16! */
    p = p * x2 + 1.0 / 87178291200.0;            /* 1/14! */
    p = p * x2 - 1.0 / 479001600.0;              /* 1/12! */
    p = p * x2 + 1.0 / 3628800.0;                /* 1/10! */
    p = p * x2 - 1.0 / 40320.0;                  /* 1/8! */
    p = p * x2 + 1.0 / 720.0;                    /* 1/6! */
    p = p * x2 - 1.0 / 24.0;                     /* 1/4! */
    p = p * x2 + 0.5;                            /* 1/2! */
    return 1.0 - x2 * p;
}

void en_gen_sincos_turn(int64_t num, int64_t den, double *s, double *c)
{
    /* note: the reduction is done on integers, so symmetric angles (k/4
     * turns apart or mirrored) give exactly symmetric values and multiples
     * of a quarter turn give exact 0 and 1. */
    int64_t n = num % den;
    if (n < 0)
        n += den;
    int64_t quadrant = (int64_t)(((en_i128)4 * n) / den);
    int64_t rem = 4 * n - quadrant * den; /* angle in quadrant = rem/den quarter turns */
    double sv, cv;
    if (2 * rem <= den) {
        double x = (M_PI / 2) * ((double)rem / (double)den);
        sv = sin_kernel(x);
        cv = cos_kernel(x);
    } else {
        double x = (M_PI / 2) * ((double)(den - rem) / (double)den);
        sv = cos_kernel(x);
        cv = sin_kernel(x);
    }
    switch (quadrant) {
    case 0: *s = sv; *c = cv; break;
    case 1: *s = cv; *c = -sv; break;
    case 2: *s = -sv; *c = -cv; break;
    default: *s = -cv; *c = sv; break;
    }
}

uint64_t en_gen_mix64(uint64_t x)
{
    /* splitmix64 finaliser */
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

/* a - b, and whether the double result is exact (TwoDiff error term). */
static int diff_exact(double a, double b, double *d)
{
    double x = a - b;
    double bv = a - x;
    double av = x + bv;
    double br = bv - b;
    double ar = a - av;
    *d = x;
    return ar + br == 0.0;
}

/* Scale nine exact doubles to integers of at most 40 bits sharing one
 * power of two. @return 1 when that is possible. */
static int to_common_integers(const double v[9], int64_t out[9])
{
    uint64_t mant[9];
    int shift[9];
    int lo = INT32_MAX, hi = INT32_MIN;
    for (int i = 0; i < 9; i++) {
        uint64_t bits;
        memcpy(&bits, &v[i], sizeof bits);
        int biased = (int)((bits >> 52) & 0x7ff);
        mant[i] = (bits & ((1ull << 52) - 1)) | (biased ? 1ull << 52 : 0);
        shift[i] = (biased ? biased : 1) - 1075; /* |v| = mant * 2^shift */
        if (!mant[i])
            continue;
        int low = shift[i] + __builtin_ctzll(mant[i]);
        int top = shift[i] + 64 - __builtin_clzll(mant[i]);
        lo = low < lo ? low : lo;
        hi = top > hi ? top : hi;
    }
    if (lo == INT32_MAX) {
        memset(out, 0, 9 * sizeof *out);
        return 1;
    }
    if (hi - lo > 40)
        return 0;
    for (int i = 0; i < 9; i++) {
        int64_t m = 0;
        if (mant[i])
            m = (int64_t)(shift[i] >= lo ? mant[i] << (shift[i] - lo) : mant[i] >> (lo - shift[i]));
        out[i] = v[i] < 0 ? -m : m;
    }
    return 1;
}

/* ---- exact fallback: 1024-bit two's complement integers ----
 * note: every float is an integer multiple of 2^-149, below 2^128, so in
 * units of 2^-149 a coordinate takes 277 bits, a product of three
 * differences about 840: the determinant fits, exactly. */
#define BIG_LIMBS 16

typedef struct big {
    uint64_t w[BIG_LIMBS]; /* little-endian limbs */
} big;

static void big_from_float(float f, big *out)
{
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    unsigned biased = (bits >> 23) & 0xff;
    uint64_t man = (bits & 0x7fffffu) | (biased ? 0x800000u : 0);
    unsigned shift = (biased ? biased : 1) - 1; /* f = man * 2^(shift - 149) */
    memset(out, 0, sizeof *out);
    unsigned limb = shift / 64, off = shift % 64;
    out->w[limb] = man << off;
    if (off > 40 && limb + 1 < BIG_LIMBS)
        out->w[limb + 1] = man >> (64 - off);
    if (bits >> 31) {
        uint64_t carry = 1;
        for (int i = 0; i < BIG_LIMBS; i++) {
            uint64_t v = ~out->w[i] + carry;
            carry = carry && v == 0;
            out->w[i] = v;
        }
    }
}

static void big_add(const big *a, const big *b, big *out)
{
    uint64_t carry = 0;
    for (int i = 0; i < BIG_LIMBS; i++) {
        en_u128 t = (en_u128)a->w[i] + b->w[i] + carry;
        out->w[i] = (uint64_t)t;
        carry = (uint64_t)(t >> 64);
    }
}

static void big_neg(const big *a, big *out)
{
    uint64_t carry = 1;
    for (int i = 0; i < BIG_LIMBS; i++) {
        uint64_t v = ~a->w[i] + carry;
        carry = carry && v == 0;
        out->w[i] = v;
    }
}

static void big_sub(const big *a, const big *b, big *out)
{
    big nb;
    big_neg(b, &nb);
    big_add(a, &nb, out);
}

static int big_negative(const big *a)
{
    return (int)(a->w[BIG_LIMBS - 1] >> 63);
}

static int big_sign(const big *a)
{
    if (big_negative(a))
        return -1;
    for (int i = 0; i < BIG_LIMBS; i++)
        if (a->w[i])
            return 1;
    return 0;
}

/* Product truncated to BIG_LIMBS limbs; exact while it fits (see above). */
static void big_mul(const big *a, const big *b, big *out)
{
    big ma, mb, r;
    int neg = big_negative(a) != big_negative(b);
    if (big_negative(a))
        big_neg(a, &ma);
    else
        ma = *a;
    if (big_negative(b))
        big_neg(b, &mb);
    else
        mb = *b;
    memset(&r, 0, sizeof r);
    for (int i = 0; i < BIG_LIMBS; i++) {
        if (!ma.w[i])
            continue;
        uint64_t carry = 0;
        for (int j = 0; i + j < BIG_LIMBS; j++) {
            en_u128 t = (en_u128)ma.w[i] * mb.w[j] + r.w[i + j] + carry;
            r.w[i + j] = (uint64_t)t;
            carry = (uint64_t)(t >> 64);
        }
    }
    if (neg)
        big_neg(&r, out);
    else
        *out = r;
}

static int orient_big(const float a[3], const float b[3], const float c[3], const float d[3])
{
    big pa[3], u[3], v[3], w[3], t;
    for (int k = 0; k < 3; k++) {
        big_from_float(a[k], &pa[k]);
        big_from_float(b[k], &t);
        big_sub(&t, &pa[k], &u[k]);
        big_from_float(c[k], &t);
        big_sub(&t, &pa[k], &v[k]);
        big_from_float(d[k], &t);
        big_sub(&t, &pa[k], &w[k]);
    }
    big det, p, q, n;
    memset(&det, 0, sizeof det);
    for (int k = 0; k < 3; k++) {
        int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
        big_mul(&u[k1], &v[k2], &p);
        big_mul(&u[k2], &v[k1], &q);
        big_sub(&p, &q, &n);          /* normal component k */
        big_mul(&n, &w[k], &p);
        big_add(&det, &p, &det);
    }
    return big_sign(&det);
}

int en_gen_orient(const float a[3], const float b[3], const float c[3], const float d[3])
{
    double u[9];
    int exact = 1;
    for (int k = 0; k < 3; k++) {
        exact &= diff_exact(b[k], a[k], &u[k]);
        exact &= diff_exact(c[k], a[k], &u[3 + k]);
        exact &= diff_exact(d[k], a[k], &u[6 + k]);
    }
    double nx = u[1] * u[5] - u[2] * u[4];
    double ny = u[2] * u[3] - u[0] * u[5];
    double nz = u[0] * u[4] - u[1] * u[3];
    double det = nx * u[6] + ny * u[7] + nz * u[8];
    /* note: static filter; the bound is a generous multiple of the rounding
     * error of the expression above (Shewchuk's orient3d bound is 7.8e-16) */
    double perm = (fabs(u[1] * u[5]) + fabs(u[2] * u[4])) * fabs(u[6]) +
                  (fabs(u[2] * u[3]) + fabs(u[0] * u[5])) * fabs(u[7]) +
                  (fabs(u[0] * u[4]) + fabs(u[1] * u[3])) * fabs(u[8]);
    if (exact && fabs(det) > 1e-15 * perm)
        return det > 0 ? 1 : -1;
    int64_t m[9];
    if (exact && to_common_integers(u, m)) {
        en_i128 inx = (en_i128)m[1] * m[5] - (en_i128)m[2] * m[4];
        en_i128 iny = (en_i128)m[2] * m[3] - (en_i128)m[0] * m[5];
        en_i128 inz = (en_i128)m[0] * m[4] - (en_i128)m[1] * m[3];
        en_i128 idet = inx * m[6] + iny * m[7] + inz * m[8];
        return idet > 0 ? 1 : idet < 0 ? -1 : 0;
    }
    return orient_big(a, b, c, d);
}

void en_gen_perm_init(en_gen_perm *p, uint64_t n, uint64_t seed)
{
    p->n = n;
    unsigned bits = 2;
    while (bits < 64 && (1ull << bits) < n)
        bits++;
    p->left_bits = bits / 2;
    p->right_bits = bits - bits / 2;
    uint64_t k = seed ^ 0x5851f42d4c957f2dull;
    for (int i = 0; i < 4; i++) {
        k = en_gen_mix64(k);
        p->keys[i] = k;
    }
}

/* note: an unbalanced Feistel network that updates one half per round, so
 * the domain is the next power of two above n (not of four) and cycle
 * walking takes at most two steps on average. */
static uint64_t feistel(const en_gen_perm *p, uint64_t x, int inverse)
{
    uint64_t lmask = (1ull << p->left_bits) - 1, rmask = (1ull << p->right_bits) - 1;
    uint64_t l = x >> p->right_bits, r = x & rmask;
    for (int step = 0; step < 4; step++) {
        int i = inverse ? 3 - step : step;
        if (i & 1)
            r ^= en_gen_mix64(l ^ p->keys[i]) & rmask;
        else
            l ^= en_gen_mix64(r ^ p->keys[i]) & lmask;
    }
    return (l << p->right_bits) | r;
}

/* note: cycle walking keeps the bijection inside [0, n); the Feistel domain
 * is below 2n, so a step takes fewer than two rounds on average. */
uint64_t en_gen_perm_fwd(const en_gen_perm *p, uint64_t x)
{
    if (p->n <= 1)
        return x;
    do
        x = feistel(p, x, 0);
    while (x >= p->n);
    return x;
}

uint64_t en_gen_perm_inv(const en_gen_perm *p, uint64_t y)
{
    if (p->n <= 1)
        return y;
    do
        y = feistel(p, y, 1);
    while (y >= p->n);
    return y;
}
