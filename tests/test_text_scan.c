/*
 * Text numbers (src/io/text_scan.c): the token scanners, the float-text rule
 * that decides the coordinate type of OBJ, SMA and OFF streams, and the
 * exact shortest printing behind en_format_coord(), each against an
 * independent snprintf/strtod-based reference on many random values.
 */
#include <float.h>
#include <stdint.h>

#include "io/format.h"
#include "io/source.h"
#include "io/text_scan.h"
#include "testlib.h"

/* splitmix64: a fixed seed, so a failure reproduces. */
static uint64_t next_random(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15u);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9u;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebu;
    return z ^ (z >> 31);
}

static double double_from_bits(uint64_t u)
{
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}

static float float_from_bits(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* ---- scanners ---- */

TEST(scan_int64_reads_the_digits_and_refuses_overflow)
{
    char text[] = "123abc -9223372036854775807 9223372036854775808 +5 - x -9223372036854775808";
    char *p = text;
    int64_t v = 0;
    CHECK_EQ_INT(en_text_scan_int64(&p, &v), 0);
    CHECK_EQ_INT(v, 123);
    CHECK(p == text + 3);                 /* what follows is the caller's business */
    p = strchr(text, ' ') + 1;
    CHECK_EQ_INT(en_text_scan_int64(&p, &v), 0);
    CHECK(v == -INT64_MAX);
    p++;
    char *before = p;
    CHECK_EQ_INT(en_text_scan_int64(&p, &v), -1);
    CHECK(p == before);
    p = strstr(text, "+5");
    CHECK_EQ_INT(en_text_scan_int64(&p, &v), 0);
    CHECK_EQ_INT(v, 5);
    p = strstr(text, "- x");
    CHECK_EQ_INT(en_text_scan_int64(&p, &v), -1);
    p = strstr(text, "x");
    CHECK_EQ_INT(en_text_scan_int64(&p, &v), -1);
    /* INT64_MIN has no positive twin: refused like any overflow */
    p = strrchr(text, ' ') + 1;
    CHECK_EQ_INT(en_text_scan_int64(&p, &v), -1);
}

TEST(significant_digits_ignore_leading_and_trailing_zeros)
{
    static const struct {
        const char *text;
        int digits, last_exp10;
    } cases[] = {
        { "0.0120", 2, -3 }, { "1.5e3", 2, 2 },   { "100", 1, 2 },     { "-0.000", 0, 0 },
        { "123.456", 6, -3 }, { "1e-7", 1, -7 },  { "+12300.0e-2", 3, 0 }, { "0.1", 1, -1 },
        { "16777217", 8, 0 }, { "1.0E+2", 1, 2 }, { "1001", 4, 0 },    { ".5", 1, -1 },
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        int last = 99;
        const char *t = cases[i].text;
        int k = en_text_significant_digits(t, t + strlen(t), &last);
        CHECK_EQ_INT(k, cases[i].digits);
        if (k)
            CHECK_EQ_INT(last, cases[i].last_exp10);
        if (k != cases[i].digits)
            fprintf(stderr, "  text '%s'\n", t);
    }
}

static int is_float_text(const char *t)
{
    return en_text_is_float_text(t, t + strlen(t), strtof(t, NULL));
}

TEST(float_texts_are_floats_printed_at_their_own_precision)
{
    CHECK(is_float_text("0.1"));
    CHECK(is_float_text("0.100000001"));          /* %.9g of 0.1f */
    CHECK(is_float_text("0.100000"));             /* %f of 0.1f */
    CHECK(is_float_text("16777216"));
    CHECK(!is_float_text("16777217"));            /* reads as 16777216 */
    CHECK(is_float_text("1e-45"));                /* the smallest subnormal, 1 digit */
    CHECK(is_float_text("1.40129846e-45"));
    CHECK(is_float_text("0"));
    CHECK(is_float_text("-0.0"));
    CHECK(!is_float_text("0.30000000000000004"));
    CHECK(is_float_text("0.1000000015"));         /* 0.1f is 0.100000001490116... */
    CHECK(!is_float_text("0.1000000016"));
    CHECK(!is_float_text("1e39"));                /* no float */
    CHECK(!is_float_text("3.4028236e38"));        /* rounds to infinity */
    CHECK(is_float_text("3.40282347e+38"));       /* FLT_MAX */
}

TEST(scan_coord_reads_float_texts_as_floats_only_in_float32_streams)
{
    char line[] = "  0.1 0.30000000000000004\t-2 1.5x";
    char *p = line;
    double v = 0;
    CHECK_EQ_INT(en_text_scan_coord(&p, EPSNET_COORD_FLOAT32, &v), 1);
    CHECK(v == (double)0.1f);
    CHECK(p == line + 5);
    CHECK_EQ_INT(en_text_scan_coord(&p, EPSNET_COORD_FLOAT32, &v), 1);
    CHECK(v == 0.30000000000000004);
    CHECK_EQ_INT(en_text_scan_coord(&p, EPSNET_COORD_FLOAT32, &v), 1);
    CHECK(v == -2.0);
    char *bad = p;
    CHECK_EQ_INT(en_text_scan_coord(&p, EPSNET_COORD_FLOAT32, &v), -1);
    CHECK(p == bad + 1);                          /* at the token, after the blank */
    char tail[] = "0.1   ";
    p = tail;
    CHECK_EQ_INT(en_text_scan_coord(&p, EPSNET_COORD_FLOAT64, &v), 1);
    CHECK(v == 0.1);
    CHECK_EQ_INT(en_text_scan_coord(&p, EPSNET_COORD_FLOAT64, &v), 0);
}

TEST(copy_token_stops_at_blanks_newlines_and_capacity)
{
    static const char text[] = "vertex\t1\nnext";
    char buf[4];
    CHECK_EQ_INT(en_text_copy_token(text, text + sizeof text - 1, buf, sizeof buf), 3);
    CHECK(strcmp(buf, "ver") == 0);
    char big[16];
    CHECK_EQ_INT(en_text_copy_token(text, text + sizeof text - 1, big, sizeof big), 6);
    CHECK(strcmp(big, "vertex") == 0);
    CHECK_EQ_INT(en_text_copy_token(text + 7, text + sizeof text - 1, big, sizeof big), 1);
    CHECK(strcmp(big, "1") == 0);
    CHECK_EQ_INT(en_text_copy_token(text, text + 2, big, sizeof big), 2);
    CHECK(strcmp(big, "ve") == 0);
    CHECK_EQ_INT(en_text_quoted_len("abc def"), 3);
}

static epsnet_coord_type peek_file(const char *name, const char *text, const char *keyword,
                                   uint64_t max_lines)
{
    en_source *src = NULL;
    epsnet_error err;
    if (en_source_open(&src, tl_write_str(name, text), &err) != 0) {
        CHECK(!"source opens");
        return (epsnet_coord_type)-1;
    }
    epsnet_coord_type t = en_text_peek_coord_type(src, keyword, max_lines);
    CHECK_EQ_U64(en_source_offset(src), 0);       /* nothing consumed */
    CHECK(!src->failed);
    en_source_close(&src);
    return t;
}

TEST(peek_judges_keyword_lines_or_all_lines_up_to_the_limit)
{
    static const char obj[] = "# 0.30000000000000004\nvt 0.30000000000000004 0\nv 1 2 3\nv 0.5 0.25 1e-3\n";
    CHECK_EQ_INT(peek_file("a.obj", obj, "v", UINT64_MAX), EPSNET_COORD_FLOAT32);
    static const char obj64[] = "v 1 2 3\n  v\t0.1 0.2 0.30000000000000004\n";
    CHECK_EQ_INT(peek_file("b.obj", obj64, "v", UINT64_MAX), EPSNET_COORD_FLOAT64);
    /* only three tokens count, and a cut last line proves nothing */
    static const char fourth[] = "v 1 2 3 0.30000000000000004\nv 1 2 0.30000000000000004";
    CHECK_EQ_INT(peek_file("c.obj", fourth, "v", UINT64_MAX), EPSNET_COORD_FLOAT32);
    /* keyword NULL: every line but blanks and comments, at most max_lines */
    static const char off[] = "\n# x\n0.5 1 2 # 0.30000000000000004\n1 2 3\n1 2 0.30000000000000004\n";
    CHECK_EQ_INT(peek_file("d.off", off, NULL, 2), EPSNET_COORD_FLOAT32);
    CHECK_EQ_INT(peek_file("e.off", off, NULL, 3), EPSNET_COORD_FLOAT64);
}

TEST(peek_looks_no_further_than_64_kib)
{
    size_t cap = EN_TEXT_PEEK_BYTES + 4096, n = 0;
    char *text = malloc(cap);
    CHECK(text != NULL);
    if (!text)
        return;
    while (n + 16 < EN_TEXT_PEEK_BYTES)
        n += (size_t)snprintf(text + n, cap - n, "v 0.5 1 2\n");
    snprintf(text + n, cap - n, "v 0.30000000000000004 0 0\n");
    CHECK_EQ_INT(peek_file("far.obj", text, "v", UINT64_MAX), EPSNET_COORD_FLOAT32);
    snprintf(text + n - 10, cap - n + 10, "v 0.30000000000000004 0 0\n");
    CHECK_EQ_INT(peek_file("near.obj", text, "v", UINT64_MAX), EPSNET_COORD_FLOAT64);
    free(text);
}

/* ---- the float-text rule against an exact reference ---- */

/* Decimal text as sign, significant digits and the power of ten of the
 * first one ("-0.0120" -> '-', "12", -2). @return the digit count. */
static int decimal_digits(const char *t, int *negative, char *digits, size_t cap, long *first_exp10)
{
    *negative = *t == '-';
    if (*t == '+' || *t == '-')
        t++;
    long point = -1, pos = 0, first = -1;
    size_t n = 0;
    for (; *t && *t != 'e' && *t != 'E'; t++) {
        if (*t == '.') {
            point = pos;
            continue;
        }
        if (first < 0 && *t == '0') {
            pos++;
            continue;
        }
        if (first < 0)
            first = pos;
        if (n + 1 < cap)
            digits[n++] = *t;
        pos++;
    }
    if (point < 0)
        point = pos;
    while (n > 0 && digits[n - 1] == '0')
        n--;
    digits[n] = '\0';
    long e = *t ? strtol(t + 1, NULL, 10) : 0;
    *first_exp10 = n ? point - first - 1 + e : 0;
    return (int)n;
}

/* The text is exactly f printed (correctly rounded) with as many
 * significant digits as the text has, or it reads as exactly f even as a
 * double (then reading it as a float changes nothing). */
static int reference_is_float_text(const char *text, float f)
{
    char want[64], got[64];
    int neg_t, neg_f;
    long e_t, e_f;
    int k = decimal_digits(text, &neg_t, want, sizeof want, &e_t);
    if (k == 0)
        return f == 0;
    if (!isfinite(f))
        return 0;
    if (strtod(text, NULL) == (double)f)
        return 1;
    char printed[96];
    snprintf(printed, sizeof printed, "%.*e", k - 1, (double)f);
    decimal_digits(printed, &neg_f, got, sizeof got, &e_f);
    return strcmp(want, got) == 0 && e_t == e_f && neg_t == neg_f;
}

/* A random finite float: half of them uniform in bits, the rest in [0, 1000). */
static float random_float(uint64_t *rng)
{
    uint64_t r = next_random(rng);
    if (r & 1)
        return (float)((double)(r >> 11) * 0x1p-53 * 1000.0);
    float f;
    do
        f = float_from_bits((uint32_t)(next_random(rng) >> 32));
    while (!isfinite(f));
    return f;
}

TEST(float_text_check_agrees_with_the_exact_reference_on_random_texts)
{
    uint64_t rng = 42;
    long mismatches = 0, float_texts = 0, total = 0;
    for (int i = 0; i < 300000; i++) {
        float f = random_float(&rng);
        uint64_t r = next_random(&rng);
        char text[96];
        int digits = 1 + (int)(r % 17);
        switch (r >> 8 & 3) {
        case 0:                  /* f itself at any precision */
            snprintf(text, sizeof text, "%.*g", digits, (double)f);
            break;
        case 1:                  /* %f style, zeros and all */
            snprintf(text, sizeof text, "%.*f", digits % 10, (double)f);
            break;
        case 2: {                /* a double near f: mostly not float text */
            double near = (double)f * (1 + ((double)(r >> 20 & 0xffff) - 32768) * 0x1p-40);
            snprintf(text, sizeof text, "%.*e", digits - 1, near);
            break;
        }
        default: {               /* f printed, then its last digit nudged */
            snprintf(text, sizeof text, "%.*e", digits - 1, (double)f);
            char *e = strchr(text, 'e');
            if (e && e[-1] >= '1' && e[-1] <= '8')
                e[-1] = (char)(e[-1] + ((r >> 40 & 1) ? 1 : -1));
            break;
        }
        }
        float parsed = strtof(text, NULL);
        int got = en_text_is_float_text(text, text + strlen(text), parsed);
        int want = reference_is_float_text(text, parsed);
        total++;
        float_texts += want;
        if (got != want && mismatches++ < 10)
            fprintf(stderr, "  '%s': got %d, reference %d\n", text, got, want);
    }
    CHECK_EQ_INT(mismatches, 0);
    printf("  %ld of %ld texts are float texts\n", float_texts, total);
    /* both answers are well represented, so the comparison means something */
    CHECK(float_texts > total / 10 && float_texts < total * 9 / 10);
}

/* ---- printing against the snprintf search ---- */

static int reference_format(char *buf, double v, epsnet_coord_type type)
{
    if (type == EPSNET_COORD_FLOAT32) {
        float f = (float)v;
        for (int prec = 6; prec <= 9; prec++) {
            int n = snprintf(buf, 32, "%.*g", prec, (double)f);
            if (prec == 9 || strtof(buf, NULL) == f)
                return n;
        }
    }
    for (int prec = 15; prec <= 17; prec++) {
        int n = snprintf(buf, 32, "%.*g", prec, v);
        if (prec == 17 || strtod(buf, NULL) == v)
            return n;
    }
    return -1;
}

typedef struct format_tally {
    long values, mismatches, undecided;
    long undecided_finite;       /* not counting floats beyond float range */
} format_tally;

/* en_format_coord() must give the reference text; its fast method, when it
 * decides, must too. */
static void check_format(double v, epsnet_coord_type type, format_tally *t)
{
    char want[32], got[32], fast[32];
    int nw = reference_format(want, v, type);
    int ng = en_format_coord(got, v, type);
    int nf = en_text_format_coord_fast(fast, v, type);
    t->values++;
    t->undecided += nf == 0;
    t->undecided_finite += nf == 0 && (type == EPSNET_COORD_FLOAT64 || isfinite((float)v));
    int bad = ng != nw || strcmp(got, want) != 0 || (nf != 0 && (nf != nw || strcmp(fast, want) != 0));
    if (bad && t->mismatches++ < 10)
        fprintf(stderr, "  %a (%s): reference '%s', got '%s', fast '%s'\n", v,
                type == EPSNET_COORD_FLOAT32 ? "float" : "double", want, got, nf ? fast : "(undecided)");
}

static void check_both_types(double v, format_tally *t)
{
    check_format(v, EPSNET_COORD_FLOAT64, t);
    check_format(v, EPSNET_COORD_FLOAT32, t);
}

TEST(format_coord_pins_known_texts)
{
    static const struct {
        double v;
        epsnet_coord_type type;
        const char *text;
    } cases[] = {
        { 0.1, EPSNET_COORD_FLOAT32, "0.1" },
        { 0.1, EPSNET_COORD_FLOAT64, "0.1" },
        { 1.0 / 3.0, EPSNET_COORD_FLOAT64, "0.3333333333333333" },
        { 1.0 / 3.0, EPSNET_COORD_FLOAT32, "0.33333334" },
        { 16777216.0, EPSNET_COORD_FLOAT32, "16777216" },
        { -0.0, EPSNET_COORD_FLOAT64, "-0" },
        { -0.0, EPSNET_COORD_FLOAT32, "-0" },
        { 0.0, EPSNET_COORD_FLOAT32, "0" },
        { 0x1p-149, EPSNET_COORD_FLOAT32, "1.4013e-45" },
        { 0x1p-1074, EPSNET_COORD_FLOAT64, "4.94065645841247e-324" },
        { DBL_MAX, EPSNET_COORD_FLOAT64, "1.7976931348623157e+308" },
        { FLT_MAX, EPSNET_COORD_FLOAT32, "3.4028235e+38" },
        { 1e15, EPSNET_COORD_FLOAT64, "1e+15" },
        { 1e-5, EPSNET_COORD_FLOAT64, "1e-05" },
        { 1e-4, EPSNET_COORD_FLOAT64, "0.0001" },
        { 123456.789, EPSNET_COORD_FLOAT64, "123456.789" },
        { 1234567.0, EPSNET_COORD_FLOAT32, "1234567" },
        { -2.5, EPSNET_COORD_FLOAT32, "-2.5" },
        { 100.0, EPSNET_COORD_FLOAT32, "100" },
        { 1e300, EPSNET_COORD_FLOAT32, "inf" },       /* writers refuse it before printing */
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        char buf[32];
        int n = en_format_coord(buf, cases[i].v, cases[i].type);
        CHECK_EQ_INT(n, (int)strlen(cases[i].text));
        if (strcmp(buf, cases[i].text) != 0) {
            CHECK(!"known text");
            fprintf(stderr, "  %a: '%s', expected '%s'\n", cases[i].v, buf, cases[i].text);
        }
    }
}

TEST(format_coord_equals_the_search_on_random_doubles_and_floats)
{
    uint64_t rng = 7;
    format_tally t = { 0, 0, 0, 0 };
    for (int i = 0; i < 1500000; i++) {
        double v = double_from_bits(next_random(&rng));
        if (isfinite(v))
            check_format(v, EPSNET_COORD_FLOAT64, &t);
        float f = float_from_bits((uint32_t)next_random(&rng));
        if (isfinite(f))
            check_format(f, EPSNET_COORD_FLOAT32, &t);
        /* coordinates as meshes hold them: doubles of a few digits, and
         * doubles rounded by a float32 writer */
        double mesh = ((double)(next_random(&rng) >> 11) * 0x1p-53 - 0.5) * 2000.0;
        check_both_types(mesh, &t);
    }
    CHECK_EQ_INT(t.mismatches, 0);
    /* the fast method decides them all, exact ties included (else nothing
     * was sped up, or its tie rules go untested) */
    CHECK_EQ_INT(t.undecided_finite, 0);
    printf("  %ld values, %ld left to the search\n", t.values, t.undecided);
}

TEST(format_coord_equals_the_search_on_edge_values)
{
    format_tally t = { 0, 0, 0, 0 };
    uint64_t rng = 99;
    /* every power of two, each with its neighbours */
    for (int e = -1074; e <= 1023; e++) {
        double p = ldexp(1.0, e);
        check_both_types(p, &t);
        check_both_types(nextafter(p, 0), &t);
        check_both_types(nextafter(p, INFINITY), &t);
        check_both_types(-p, &t);
    }
    for (int e = -149; e <= 127; e++) {
        float p = ldexpf(1.0f, e);
        check_format(nextafterf(p, 0), EPSNET_COORD_FLOAT32, &t);
        check_format(nextafterf(p, INFINITY), EPSNET_COORD_FLOAT32, &t);
    }
    /* powers of ten and their neighbours, where digit counts change */
    for (int e = -325; e <= 308; e++) {
        char text[16];
        snprintf(text, sizeof text, "1e%d", e);
        double p = strtod(text, NULL);
        check_both_types(p, &t);
        check_both_types(nextafter(p, 0), &t);
        check_both_types(nextafter(p, INFINITY), &t);
        float pf = strtof(text, NULL);
        check_format(nextafterf(pf, 0), EPSNET_COORD_FLOAT32, &t);
        check_format(nextafterf(pf, INFINITY), EPSNET_COORD_FLOAT32, &t);
    }
    /* subnormals, integers, and the extremes */
    for (int i = 0; i < 200000; i++) {
        uint64_t r = next_random(&rng);
        check_format(double_from_bits(r >> (12 + r % 40)), EPSNET_COORD_FLOAT64, &t);
        check_format(float_from_bits((uint32_t)(r >> (41 + r % 20))), EPSNET_COORD_FLOAT32, &t);
        check_both_types((double)(int64_t)(r >> (11 + r % 50)), &t);
        check_both_types((double)(r % 100000) / 1000.0, &t);
    }
    static const double extremes[] = { DBL_MAX, -DBL_MAX, DBL_MIN, DBL_TRUE_MIN, FLT_MAX, FLT_MIN,
                                       FLT_TRUE_MIN, 0.0, -0.0, 1.0, 9007199254740993.0 };
    for (size_t i = 0; i < sizeof extremes / sizeof *extremes; i++)
        check_both_types(extremes[i], &t);
    CHECK_EQ_INT(t.mismatches, 0);
    CHECK_EQ_INT(t.undecided_finite, 0);   /* only floats that overflow are left */
    printf("  %ld values, %ld left to the search\n", t.values, t.undecided);
}

int main(void)
{
    RUN(scan_int64_reads_the_digits_and_refuses_overflow);
    RUN(significant_digits_ignore_leading_and_trailing_zeros);
    RUN(float_texts_are_floats_printed_at_their_own_precision);
    RUN(scan_coord_reads_float_texts_as_floats_only_in_float32_streams);
    RUN(copy_token_stops_at_blanks_newlines_and_capacity);
    RUN(peek_judges_keyword_lines_or_all_lines_up_to_the_limit);
    RUN(peek_looks_no_further_than_64_kib);
    RUN(float_text_check_agrees_with_the_exact_reference_on_random_texts);
    RUN(format_coord_pins_known_texts);
    RUN(format_coord_equals_the_search_on_random_doubles_and_floats);
    RUN(format_coord_equals_the_search_on_edge_values);
    int rc = tl_finish();
    tl_cleanup();
    return rc;
}
