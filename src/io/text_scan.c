/*
 * Numbers in text formats: see text_scan.h for the coordinate-type rule.
 *
 * Printing. The text must be what the search "first %.{p}g that reads back
 * exactly" produces (the writer's contract since the first version, and what
 * round-trip tests pin), but that search costs up to three snprintf() and
 * strtod() calls per coordinate, which dominated writing large text meshes.
 * The fast method gets the same answer with integer arithmetic:
 *   1. v = m·2^e exactly. Scale it by a power of ten to X = v·10^j with
 *      X in [10^(P-1), 10^P), P the largest precision (9 or 17), as a 64.64
 *      fixed-point number. 10^j comes from a 128-bit truncated table entry
 *      times an exact power of five, so the computed X is below the exact
 *      one by less than 2 units of 2^-64 (relative error < 2^-126 on X <
 *      2^60, plus the truncation of the shift).
 *   2. For p digits, round X to a multiple of 10^(P-p); the round trip holds
 *      when that multiple lies strictly between the midpoints to v's
 *      neighbours, scaled the same way (a neighbour at a power of two is
 *      twice as close below).
 *   3. Every comparison allows for that error. Where 10^j is exact the
 *      scaled values are exact too, and ties are settled the way printf
 *      (half to even) and strtod (midpoint to the even mantissa) settle
 *      them; with an inexact 10^j (j < 0, so v is an integer) a possible tie
 *      is checked with exact integer arithmetic. What is still undecided
 *      (none in millions of random values; floats that overflow to
 *      infinity) goes to the slow search, so the text is always the
 *      search's text.
 */
#include "io/text_scan.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- scanning ---- */

int en_text_quoted_len(const char *p)
{
    int n = 0;
    while (n < 40 && !en_text_ends_token(p[n]))
        n++;
    return n;
}

int en_text_scan_int64(char **pp, int64_t *out)
{
    char *p = *pp;
    int neg = 0;
    if (*p == '+' || *p == '-')
        neg = *p++ == '-';
    if (*p < '0' || *p > '9')
        return -1;
    uint64_t v = 0;
    while (*p >= '0' && *p <= '9') {
        unsigned digit = (unsigned)(*p++ - '0');
        if (v > ((uint64_t)INT64_MAX - digit) / 10)
            return -1;
        v = v * 10 + digit;
    }
    *out = neg ? -(int64_t)v : (int64_t)v;
    *pp = p;
    return 0;
}

int en_text_significant_digits(const char *p, const char *end, int *last_exp10)
{
    while (p < end && (*p == '+' || *p == '-'))
        p++;
    int int_len = 0;
    while (p + int_len < end && p[int_len] >= '0' && p[int_len] <= '9')
        int_len++;
    int digits = 0, zeros = 0, started = 0, index = 0, frac = 0, in_frac = 0;
    long exp10 = 0;
    for (; p < end && *p != 'e' && *p != 'E'; p++) {
        if (*p == '.') {
            in_frac = 1;
            continue;
        }
        if (*p < '0' || *p > '9')
            continue;
        int at = in_frac ? -++frac : int_len - 1 - index++;
        if (*p == '0') {
            zeros += started;
            continue;
        }
        started = 1;
        digits += zeros + 1;
        zeros = 0;
        exp10 = at;
    }
    if (p < end) {
        long e = strtol(p + 1, NULL, 10);
        exp10 += e < -1000 ? -1000 : e > 1000 ? 1000 : e;
    }
    *last_exp10 = (int)exp10;
    return digits;
}

/*
 * f is within half a unit of the text's last digit.
 * note: FLT_DIG is 6, so up to 6 digits every decimal is such a text, which
 * keeps the common case at one strtof(); near the half-unit border the
 * answer comes from printing f, which is exact.
 */
int en_text_is_float_text(const char *p, const char *end, float f)
{
    int last_exp10;
    int k = en_text_significant_digits(p, end, &last_exp10);
    if (k == 0)
        return f == 0;
    if (!isfinite(f))
        return 0;
    if (k <= 6 && isnormal(f))
        return 1;
    double d = strtod(p, NULL);
    if ((double)f == d)
        return 1;
    if (k >= 17)
        return 0;       /* f printed at 17+ digits reads back as exactly f */
    /* slack: d is the text rounded to a double, and pow() may be off by an
     * ulp; within it, only printing f decides exactly */
    double half = 0.5 * pow(10.0, last_exp10), diff = fabs((double)f - d);
    double slack = 4.5e-16 * fabs(d) + 1e-15 * half;
    if (diff + slack < half)
        return 1;
    if (diff - slack > half)
        return 0;
    char printed[64];
    snprintf(printed, sizeof printed, "%.*e", k - 1, (double)f);
    return strtod(printed, NULL) == d;
}

int en_text_scan_coord(char **pp, epsnet_coord_type type, double *out)
{
    char *p = en_text_skip_blanks(*pp);
    *pp = p;
    if (*p == '\0')
        return 0;
    char *end;
    if (type == EPSNET_COORD_FLOAT64) {
        *out = strtod(p, &end);
    } else {
        float f = strtof(p, &end);
        if (end != p)
            *out = en_text_is_float_text(p, end, f) ? (double)f : strtod(p, NULL);
    }
    if (end == p || !en_text_ends_token(*end))
        return -1;
    *pp = end;
    return 1;
}

size_t en_text_copy_token(const char *p, const char *end, char *buf, size_t cap)
{
    size_t n = 0;
    while (p + n < end && !en_text_ends_token(p[n]) && p[n] != '\n' && n + 1 < cap) {
        buf[n] = p[n];
        n++;
    }
    buf[n] = '\0';
    return n;
}

/* Does the line [p, eol) hold coordinates? Sets *coords to where they start. */
static int is_coordinate_line(const char *p, const char *eol, const char *keyword, const char **coords)
{
    while (p < eol && en_text_is_blank(*p))
        p++;
    if (p == eol || *p == '#')
        return 0;
    if (!keyword) {
        *coords = p;
        return 1;
    }
    size_t n = strlen(keyword);
    if ((size_t)(eol - p) <= n || memcmp(p, keyword, n) != 0 || !en_text_is_blank(p[n]))
        return 0;
    *coords = p + n;
    return 1;
}

/* The first three tokens of a coordinate line are all float texts. */
static int line_is_float_text(const char *q, const char *eol)
{
    const char *hash = memchr(q, '#', (size_t)(eol - q));
    if (hash)
        eol = hash;
    for (int k = 0; k < 3; k++) {
        char tok[64];
        while (q < eol && en_text_is_blank(*q))
            q++;
        size_t n = en_text_copy_token(q, eol, tok, sizeof tok);
        if (n == 0)
            break;
        if (!en_text_is_float_text(tok, tok + n, strtof(tok, NULL)))
            return 0;
        q += n;
    }
    return 1;
}

epsnet_coord_type en_text_peek_coord_type(en_source *src, const char *keyword, uint64_t max_lines)
{
    size_t avail = en_source_fill(src, EN_TEXT_PEEK_BYTES);
    if (avail > EN_TEXT_PEEK_BYTES)
        avail = EN_TEXT_PEEK_BYTES;  /* the same window whatever read() returned */
    const char *p = (const char *)src->cur, *end = p + avail;
    uint64_t seen = 0;
    while (p < end && seen < max_lines) {
        const char *eol = memchr(p, '\n', (size_t)(end - p));
        if (!eol)
            break;              /* a cut line proves nothing */
        const char *coords;
        if (is_coordinate_line(p, eol, keyword, &coords)) {
            seen++;
            if (!line_is_float_text(coords, eol))
                return EPSNET_COORD_FLOAT64;
        }
        p = eol + 1;
    }
    return EPSNET_COORD_FLOAT32;
}

/* ---- printing ---- */

/* The search the fast method reproduces (and falls back to). */
static int format_by_search(char *buf, double v, epsnet_coord_type type)
{
    if (type == EPSNET_COORD_FLOAT32) {
        float f = (float)v;
        for (int prec = 6; prec < 9; prec++) {
            int n = snprintf(buf, 32, "%.*g", prec, (double)f);
            if (strtof(buf, NULL) == f)
                return n;
        }
        return snprintf(buf, 32, "%.9g", (double)f);
    }
    for (int prec = 15; prec < 17; prec++) {
        int n = snprintf(buf, 32, "%.*g", prec, v);
        if (strtod(buf, NULL) == v)
            return n;
    }
    return snprintf(buf, 32, "%.17g", v);
}

/* A 64.64 fixed-point number: integer part and fraction. */
typedef struct fixed {
    uint64_t i, f;
} fixed;

static int fixed_less(fixed a, fixed b)
{
    return a.i < b.i || (a.i == b.i && a.f < b.f);
}

/* a + units·2^-64; a.i never overflows here (a < 2^60). */
static fixed fixed_add_units(fixed a, uint64_t units)
{
    fixed r = { a.i, a.f + units };
    r.i += r.f < units;
    return r;
}

static void mul_64x64(uint64_t a, uint64_t b, uint64_t *hi, uint64_t *lo)
{
#if defined(__SIZEOF_INT128__)
    __extension__ typedef unsigned __int128 u128;
    u128 p = (u128)a * b;
    *hi = (uint64_t)(p >> 64);
    *lo = (uint64_t)p;
#else
    uint64_t a0 = a & 0xffffffffu, a1 = a >> 32, b0 = b & 0xffffffffu, b1 = b >> 32;
    uint64_t p00 = a0 * b0, p01 = a0 * b1, p10 = a1 * b0, p11 = a1 * b1;
    uint64_t mid = (p00 >> 32) + (p01 & 0xffffffffu) + (p10 & 0xffffffffu);
    *lo = (mid << 32) | (p00 & 0xffffffffu);
    *hi = p11 + (p01 >> 32) + (p10 >> 32) + (mid >> 32);
#endif
}

static int leading_zeros(uint64_t x)
{
#if defined(__GNUC__) || defined(__clang__)
    return x ? __builtin_clzll(x) : 64;
#else
    int n = 0;
    for (int step = 32; step; step /= 2)
        if (!(x >> (64 - step))) {
            n += step;
            x <<= step;
        }
    return n + !x;
#endif
}

static int floor_div(int a, int b)
{
    int q = a / b;
    return (a % b != 0 && a < 0) ? q - 1 : q;
}

/* 10^(28a) for a in [POW10_MIN_A, POW10_MIN_A + POW10_ROWS) as hi:lo·2^-shift,
 * truncated to 128 bits with the top bit set (generated exactly with Python
 * fractions: T = floor(10^(28a)·2^shift)). 28 because 5^27 still fits in 64
 * bits, so any 10^j is one row times an exact 5^b·2^b. */
#define POW10_STEP 28
#define POW10_MIN_A (-11)
#define POW10_ROWS 24
static const struct pow10_row {
    uint64_t hi, lo;
    int shift;
    int exact;
} pow10_rows[POW10_ROWS] = {
    { 0xe61acf033d1a45df, 0x6fb92487298e33bd, 1151, 0 },  /* 10^-308 */
    { 0xe858ad248f5c22c9, 0xd1b3400f8f9cff68, 1058, 0 },  /* 10^-280 */
    { 0xea9c227723ee8bcb, 0x465e15a979c1cadc, 965, 0 },   /* 10^-252 */
    { 0xece53cec4a314ebd, 0xa4f8bf5635246428, 872, 0 },   /* 10^-224 */
    { 0xef340a98172aace4, 0x86fb897116c87c34, 779, 0 },   /* 10^-196 */
    { 0xf18899b1bc3f8ca1, 0xdc44e6c3cb279ac1, 686, 0 },   /* 10^-168 */
    { 0xf3e2f893dec3f126, 0x5a89dba3c3efccfa, 593, 0 },   /* 10^-140 */
    { 0xf64335bcf065d37d, 0x4d4617b5ff4a16d5, 500, 0 },   /* 10^-112 */
    { 0xf8a95fcf88747d94, 0x75a44c6397ce912a, 407, 0 },   /* 10^-84 */
    { 0xfb158592be068d2e, 0xeed6e2f0f0d56712, 314, 0 },   /* 10^-56 */
    { 0xfd87b5f28300ca0d, 0x8bca9d6e188853fc, 221, 0 },   /* 10^-28 */
    { 0x8000000000000000, 0x0000000000000000, 127, 1 },   /* 10^0, exact */
    { 0x813f3978f8940984, 0x4000000000000000, 34, 1 },    /* 10^28, exact */
    { 0x82818f1281ed449f, 0xbff8f10e7a8921a4, -59, 0 },   /* 10^56 */
    { 0x83c7088e1aab65db, 0x792667c6da79e0fa, -152, 0 },  /* 10^84 */
    { 0x850fadc09923329e, 0x03e2cf6bc604ddb0, -245, 0 },  /* 10^112 */
    { 0x865b86925b9bc5c2, 0x0b8a2392ba45a9b2, -338, 0 },  /* 10^140 */
    { 0x87aa9aff79042286, 0x90fb44d2f05d0842, -431, 0 },  /* 10^168 */
    { 0x88fcf317f22241e2, 0x441fece3bdf81f03, -524, 0 },  /* 10^196 */
    { 0x8a5296ffe33cc92f, 0x82bd6b70d99aaa6f, -617, 0 },  /* 10^224 */
    { 0x8bab8eefb6409c1a, 0x1ad089b6c2f7548e, -710, 0 },  /* 10^252 */
    { 0x8d07e33455637eb2, 0xdb0b487b6423e1e8, -803, 0 },  /* 10^280 */
    { 0x8e679c2f5e44ff8f, 0x570f09eaa7ea7648, -896, 0 },  /* 10^308 */
    { 0x8fcac257558ee4e6, 0x213a4f0aa5e8a7b1, -989, 0 },  /* 10^336 */
};

static const uint64_t pow10_u64[20] = {
    1, 10, 100, 1000, 10000, 100000, 1000000, 10000000, 100000000, 1000000000,
    10000000000u, 100000000000u, 1000000000000u, 10000000000000u, 100000000000000u,
    1000000000000000u, 10000000000000000u, 100000000000000000u, 1000000000000000000u,
    10000000000000000000u,
};

static const uint64_t pow5_u64[POW10_STEP] = {
    1u, 5u, 25u, 125u, 625u, 3125u, 15625u, 78125u, 390625u, 1953125u, 9765625u, 48828125u,
    244140625u, 1220703125u, 6103515625u, 30517578125u, 152587890625u, 762939453125u,
    3814697265625u, 19073486328125u, 95367431640625u, 476837158203125u, 2384185791015625u,
    11920928955078125u, 59604644775390625u, 298023223876953125u, 1490116119384765625u,
    7450580596923828125u,
};

/* 10^j ≈ (p[0]:p[1])·2^-*shift, truncated, top bit set; *exact when nothing
 * was truncated. @return -1 when j is outside the table (never for finite
 * floats and doubles). */
static int pow10_approx(int j, uint64_t p[2], int *shift, int *exact)
{
    int a = floor_div(j, POW10_STEP), b = j - POW10_STEP * a;
    if (a < POW10_MIN_A || a >= POW10_MIN_A + POW10_ROWS)
        return -1;
    const struct pow10_row *row = &pow10_rows[a - POW10_MIN_A];
    if (b == 0) {
        p[0] = row->hi;
        p[1] = row->lo;
        *shift = row->shift;
        *exact = row->exact;
        return 0;
    }
    uint64_t five = pow5_u64[b];
    uint64_t h0, l0, h1, l1;
    mul_64x64(row->lo, five, &h0, &l0);
    mul_64x64(row->hi, five, &h1, &l1);
    uint64_t q1 = h0 + l1, q2 = h1 + (q1 < l1);
    int lz = leading_zeros(q2);      /* q2 >= 2 since five >= 5 */
    p[0] = lz ? q2 << lz | q1 >> (64 - lz) : q2;
    p[1] = lz ? q1 << lz | l0 >> (64 - lz) : q1;
    /* 10^j = row·2^-row.shift · five·2^b, and the 192-bit product lost
     * 64 - lz bits */
    *shift = row->shift - b + lz - 64;
    *exact = row->exact && (lz ? l0 << lz : l0) == 0;
    return 0;
}

/* floor(n·p·2^-sh) as 64.64 fixed point; *exact when no set bit was shifted
 * out. @return -1 if sh is not in (0, 128) or the result does not fit. */
static int scale(uint64_t n, const uint64_t p[2], int sh, fixed *out, int *exact)
{
    if (sh <= 0 || sh >= 128)
        return -1;
    uint64_t h0, l0, h1, l1;
    mul_64x64(p[1], n, &h0, &l0);
    mul_64x64(p[0], n, &h1, &l1);
    uint64_t r0 = l0, r1 = h0 + l1, r2 = h1 + (r1 < l1);
    if (sh < 64) {
        if (r2 >> sh)
            return -1;
        out->f = r0 >> sh | r1 << (64 - sh);
        out->i = r1 >> sh | r2 << (64 - sh);
        *exact = r0 << (64 - sh) == 0;
    } else if (sh == 64) {
        out->f = r1;
        out->i = r2;
        *exact = r0 == 0;
    } else {
        out->f = r1 >> (sh - 64) | r2 << (128 - sh);
        out->i = r2 >> (sh - 64);
        *exact = r0 == 0 && r1 << (128 - sh) == 0;
    }
    return 0;
}

/* The exact value m·2^e of a positive finite float or double, and whether
 * its lower neighbour is half as far as its upper one. */
typedef struct binary_value {
    uint64_t m;
    int e;
    int closer_below;
} binary_value;

static binary_value decompose_double(double v)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    uint64_t frac = bits & (((uint64_t)1 << 52) - 1);
    int biased = (int)(bits >> 52 & 0x7ff);
    binary_value b = { frac, -1074, 0 };
    if (biased > 0) {
        b.m = frac | (uint64_t)1 << 52;
        b.e = biased - 1075;
        b.closer_below = frac == 0 && biased > 1;
    }
    return b;
}

static binary_value decompose_float(float v)
{
    uint32_t bits;
    memcpy(&bits, &v, sizeof bits);
    uint32_t frac = bits & ((1u << 23) - 1);
    int biased = (int)(bits >> 23 & 0xff);
    binary_value b = { frac, -149, 0 };
    if (biased > 0) {
        b.m = frac | 1u << 23;
        b.e = biased - 150;
        b.closer_below = frac == 0 && biased > 1;
    }
    return b;
}

/* A scaled value: computed below the exact one by less than
 * SCALE_ERROR_UNITS units of 2^-64 (file comment, step 1), or exact. */
typedef struct bound {
    fixed at;
    int exact;
    uint64_t n;                  /* the exact value is n·2^e2·10^j */
} bound;

#define SCALE_ERROR_UNITS 2

/* v, and the midpoints to its neighbours, scaled by 10^j. */
typedef struct scaled_value {
    bound x, lo, hi;
    int e2, j;
    int even;                    /* v's mantissa is even: midpoints read as v */
} scaled_value;

static int scale_bound(uint64_t n, const uint64_t p[2], int sh, int p_exact, bound *out)
{
    if (scale(n, p, sh, &out->at, &out->exact))
        return -1;
    out->exact &= p_exact;
    out->n = n;
    return 0;
}

static int scale_value(binary_value b, int j, scaled_value *s)
{
    uint64_t p[2];
    int shift, exact;
    if (pow10_approx(j, p, &shift, &exact))
        return -1;
    /* 4m·2^(e-2), so that both midpoints are integers times 2^(e-2) */
    int sh = shift - (b.e - 2) - 64;
    uint64_t n = 4 * b.m;
    s->even = (b.m & 1) == 0;
    s->e2 = b.e - 2;
    s->j = j;
    return scale_bound(n, p, sh, exact, &s->x) || scale_bound(n + 2, p, sh, exact, &s->hi) ||
           scale_bound(n - (b.closer_below ? 1 : 2), p, sh, exact, &s->lo) ? -1 : 0;
}

enum { DECIDED_NO = 0, DECIDED_YES = 1, UNDECIDED = 2 };

/* Is n·2^e2·10^j exactly c/2? Decided by integer arithmetic for j in
 * [-19, 0) and results within 128 bits; otherwise 0 (not known to be).
 * note: this is the only question left when 10^j is inexact. For j >= 0 the
 * table is exact wherever a tie can occur, and for j < 0 (v an integer) a
 * value within 2^-63 of c/2 without equalling it would need a numerator
 * difference of 1 over 2·10^-j > 2^63, i.e. j <= -19. */
static int exactly_half_of(uint64_t n, int e2, int j, uint64_t c)
{
    if (j >= 0 || j < -19 || e2 < 0 || 64 - leading_zeros(n) + e2 + 1 > 127)
        return 0;
    int sh = e2 + 1;
    uint64_t left_hi = sh >= 64 ? n << (sh - 64) : n >> (64 - sh);
    uint64_t left_lo = sh >= 64 ? 0 : n << sh;
    uint64_t right_hi, right_lo;
    mul_64x64(c, pow10_u64[-j], &right_hi, &right_lo);
    return left_hi == right_hi && left_lo == right_lo;
}

/* Sign of c minus the exact value behind b: -1, 0 or 1, or UNDECIDED. c is
 * an integer or a half (fraction 0 or 2^63). */
static int compare(fixed c, const bound *b, const scaled_value *s)
{
    if (fixed_less(c, b->at))
        return -1;
    if (b->exact)
        return fixed_less(b->at, c) ? 1 : 0;
    if (!fixed_less(c, fixed_add_units(b->at, SCALE_ERROR_UNITS)))
        return 1;
    return exactly_half_of(b->n, s->e2, s->j, 2 * c.i + (c.f != 0)) ? 0 : UNDECIDED;
}

/* Round x to a multiple of t (a power of ten), an exact half to even as
 * printf does; *d gets the multiplier. */
/* x / 10^k for the few k a precision search needs, as constant divisions. */
static uint64_t div_pow10(uint64_t x, int k)
{
    switch (k) {
    case 0:
        return x;
    case 1:
        return x / 10;
    case 2:
        return x / 100;
    case 3:
        return x / 1000;
    default:
        return x / pow10_u64[k];
    }
}

static int round_to_multiple(const scaled_value *s, int k, uint64_t *d)
{
    uint64_t t = pow10_u64[k];
    *d = div_pow10(s->x.at.i, k);
    fixed half = { *d * t + t / 2, t == 1 ? (uint64_t)1 << 63 : 0 };
    int side = compare(half, &s->x, s);
    if (side == UNDECIDED)
        return UNDECIDED;
    if (side < 0 || (side == 0 && (*d & 1)))
        (*d)++;
    return DECIDED_YES;
}

/* Does the integer c read back as v: strictly between the midpoints, or on
 * one when v's mantissa is even (strtod rounds half to even)? */
static int between_midpoints(uint64_t c, const scaled_value *s)
{
    fixed cf = { c, 0 };
    int side_lo = compare(cf, &s->lo, s), side_hi = compare(cf, &s->hi, s);
    if (side_lo < 0 || side_hi == 1 || ((side_lo == 0 || side_hi == 0) && !s->even))
        return DECIDED_NO;
    if (side_lo == UNDECIDED || side_hi == UNDECIDED)
        return UNDECIDED;
    return DECIDED_YES;
}

/* %.{precision}g of (-1)^negative · digits·10^(exp10 - ndigits + 1), where
 * digits has exactly ndigits digits. */
static int print_g(char *buf, int negative, uint64_t digits, int ndigits, int exp10, int precision)
{
    char d[20];
    for (int i = ndigits - 1; i >= 0; i--) {
        d[i] = (char)('0' + digits % 10);
        digits /= 10;
    }
    while (ndigits > 1 && d[ndigits - 1] == '0')
        ndigits--;
    int n = 0;
    if (negative)
        buf[n++] = '-';
    if (exp10 < -4 || exp10 >= precision) {
        buf[n++] = d[0];
        if (ndigits > 1) {
            buf[n++] = '.';
            memcpy(buf + n, d + 1, (size_t)ndigits - 1);
            n += ndigits - 1;
        }
        buf[n++] = 'e';
        buf[n++] = exp10 < 0 ? '-' : '+';
        int mag = exp10 < 0 ? -exp10 : exp10;
        if (mag >= 100)
            buf[n++] = (char)('0' + mag / 100);
        buf[n++] = (char)('0' + mag / 10 % 10);
        buf[n++] = (char)('0' + mag % 10);
    } else if (exp10 < 0) {
        buf[n++] = '0';
        buf[n++] = '.';
        for (int i = -1; i > exp10; i--)
            buf[n++] = '0';
        memcpy(buf + n, d, (size_t)ndigits);
        n += ndigits;
    } else {
        for (int i = 0; i <= exp10; i++)
            buf[n++] = i < ndigits ? d[i] : '0';
        if (ndigits > exp10 + 1) {
            buf[n++] = '.';
            memcpy(buf + n, d + exp10 + 1, (size_t)(ndigits - exp10 - 1));
            n += ndigits - exp10 - 1;
        }
    }
    buf[n] = '\0';
    return n;
}

int en_text_format_coord_fast(char *buf, double v, epsnet_coord_type type)
{
    int is_float = type == EPSNET_COORD_FLOAT32;
    double value = is_float ? (double)(float)v : v;
    if (!isfinite(value))
        return 0;
    int negative = signbit(value) != 0;
    if (value == 0)
        return print_g(buf, negative, 0, 1, 0, 1);
    binary_value b = is_float ? decompose_float(fabsf((float)v)) : decompose_double(fabs(v));
    const int pmin = is_float ? 6 : 15, pmax = is_float ? 9 : 17;
    int top_bit = b.e + 63 - leading_zeros(b.m);
    /* floor(top_bit·log10 2), checked exactly for |top_bit| < 1200 */
    int exp10 = floor_div(top_bit * 78913, 1 << 18);
    scaled_value s;
    if (scale_value(b, pmax - 1 - exp10, &s))
        return 0;
    if (s.x.at.i >= pow10_u64[pmax]) {
        exp10++;
        if (scale_value(b, pmax - 1 - exp10, &s))
            return 0;
    }
    for (int p = pmin; p <= pmax; p++) {
        uint64_t t = pow10_u64[pmax - p], d;
        if (round_to_multiple(&s, pmax - p, &d) != DECIDED_YES)
            return 0;
        if (d < pow10_u64[p - 1] || d > pow10_u64[p])
            return 0;
        if (p < pmax) {
            int fits = between_midpoints(d * t, &s);
            if (fits == UNDECIDED)
                return 0;
            if (fits == DECIDED_NO)
                continue;
        }
        if (d == pow10_u64[p])
            return print_g(buf, negative, d / 10, p, exp10 + 1, p);
        return print_g(buf, negative, d, p, exp10, p);
    }
    return 0;
}

int en_text_format_coord(char *buf, double v, epsnet_coord_type type)
{
    int n = en_text_format_coord_fast(buf, v, type);
    return n > 0 ? n : format_by_search(buf, v, type);
}
