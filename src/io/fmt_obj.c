/*
 * Wavefront OBJ (SPEC §3, ordinary formats): geometry only.
 *
 * Reader: `v x y z [w | r g b [a]]` and `f` with corners `a`, `a/b`, `a/b/c`
 * or `a//c`; indices are 1-based, or negative and relative to the newest
 * vertex (-1 = newest). Polygons are fan-triangulated around their first
 * corner. Faces may come between vertices, as OBJ allows. Every other
 * statement (vt, vn, vp, o, g, s, usemtl, mtllib, l, p, unknown ones) is
 * skipped, but the numbers of a `v` or `f` statement must all parse. A
 * trailing backslash continues a statement on the next line.
 *
 * note: OBJ has no header, so info.coord_type is decided by looking ahead:
 * FLOAT32 when every coordinate in the first 64 KiB is a float printed at
 * its own precision (is_float_text), FLOAT64 otherwise. In a FLOAT32 stream
 * such texts read as their float, so a float mesh round-trips bit-exact; any
 * text more precise than a float (even after the first 64 KiB) keeps its
 * correctly rounded double value. Nothing written is lost either way.
 *
 * Writer: `v` lines in the shortest exact text for the writer's coordinate
 * type and `f a b c` lines with 1-based absolute indices, in stream order
 * (OBJ allows interleaving, so nothing is buffered). FINALIZE records have no
 * OBJ form and are dropped.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "io/format.h"

/* note: en_source_line() caps lines at half its 2 MiB window. */
#define OBJ_MAX_LINE ((size_t)1 << 20)
#define OBJ_PEEK_BYTES ((size_t)64 << 10)
/* Records queued per fill(): amortises the front end's call overhead. */
#define OBJ_FILL_BATCH 4096
/* Beyond x y z: w, or r g b, or r g b a. */
#define OBJ_MAX_VERTEX_VALUES 7

typedef struct obj_reader {
    char *joined;                    /* backslash-continued statement */
    size_t joined_cap;
} obj_reader;

/* ---- text scanning ---- */

static int is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

static char *skip_blanks(char *p)
{
    while (is_blank(*p))
        p++;
    return p;
}

static int ends_token(char c)
{
    return c == '\0' || is_blank(c);
}

/* Length of the token at p, capped for quoting in messages. */
static int quoted_len(const char *p)
{
    int n = 0;
    while (n < 40 && !ends_token(p[n]))
        n++;
    return n;
}

/* Signed decimal integer at *pp with no leading blanks; @return 0 or -1. */
static int scan_int64(char **pp, int64_t *out)
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

/* Significant decimal digits of the number text [p, end), and the power of
 * ten of the last one: leading and trailing zeros of the mantissa do not
 * count ("0.0120" has 2 digits, the last at 10^-3). */
static int significant_digits(const char *p, const char *end, int *last_exp10)
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
 * True when the text [p, end) is the float f printed at the text's own
 * precision, as any float printer (shortest, %.9g, %f) writes it: f is
 * within half a unit of the text's last digit.
 * note: FLT_DIG is 6, so up to 6 digits every decimal is such a text, which
 * keeps the common case at one strtof(); near the half-unit border the
 * answer comes from printing f, which is exact.
 */
static int is_float_text(const char *p, const char *end, float f)
{
    int last_exp10;
    int k = significant_digits(p, end, &last_exp10);
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

/*
 * @return 1 with *out set, 0 at the end of the line, -1 on a token that is
 * not a number.
 * note: in a float32 stream a float text stands for its float, so float
 * meshes come back bit-exact (SPEC §1); a text more precise than any float
 * keeps its double value, so nothing written is lost.
 */
static int scan_coord(char **pp, epsnet_coord_type type, double *out)
{
    char *p = skip_blanks(*pp);
    *pp = p;
    if (*p == '\0')
        return 0;
    char *end;
    if (type == EPSNET_COORD_FLOAT64) {
        *out = strtod(p, &end);
    } else {
        float f = strtof(p, &end);
        if (end != p)
            *out = is_float_text(p, end, f) ? (double)f : strtod(p, NULL);
    }
    if (end == p || !ends_token(*end))
        return -1;
    *pp = end;
    return 1;
}

/* Copy the first blank-delimited token of a window line into buf. */
static size_t copy_token(const char *p, const char *end, char *buf, size_t cap)
{
    size_t n = 0;
    while (p + n < end && !ends_token(p[n]) && p[n] != '\n' && n + 1 < cap) {
        buf[n] = p[n];
        n++;
    }
    buf[n] = '\0';
    return n;
}

/* Look at the `v` lines of the first OBJ_PEEK_BYTES without consuming them. */
static epsnet_coord_type peek_coord_type(en_source *src)
{
    size_t avail = en_source_fill(src, OBJ_PEEK_BYTES);
    if (avail > OBJ_PEEK_BYTES)
        avail = OBJ_PEEK_BYTES;  /* the same window whatever read() returned */
    const char *p = (const char *)src->cur, *end = p + avail;
    while (p < end) {
        const char *eol = memchr(p, '\n', (size_t)(end - p));
        if (!eol)
            break;              /* a cut line proves nothing */
        while (p < eol && is_blank(*p))
            p++;
        if (eol - p > 2 && p[0] == 'v' && is_blank(p[1])) {
            const char *q = p + 1;
            for (int k = 0; k < 3; k++) {
                char tok[64];
                while (q < eol && is_blank(*q))
                    q++;
                size_t n = copy_token(q, eol, tok, sizeof tok);
                if (n == 0)
                    break;
                if (!is_float_text(tok, tok + n, strtof(tok, NULL)))
                    return EPSNET_COORD_FLOAT64;
                q += n;
            }
        }
        p = eol + 1;
    }
    return EPSNET_COORD_FLOAT32;
}

/* ---- reader ---- */

static int source_failed(epsnet_reader *r, int rc)
{
    r->failed = 1;
    return rc;
}

/*
 * Next statement with its continuation lines joined. @return 1 with *stmt
 * set, 0 at the end of input, or a negative code with r->err filled.
 */
static int next_statement(epsnet_reader *r, obj_reader *st, char **stmt)
{
    char *line;
    size_t len;
    int rc = en_source_line(r->src, &line, &len, OBJ_MAX_LINE, &r->err);
    if (rc <= 0)
        return rc < 0 ? source_failed(r, rc) : 0;
    if (len == 0 || line[len - 1] != '\\') {
        *stmt = line;
        return 1;
    }
    size_t used = 0;
    for (;;) {
        int continued = len > 0 && line[len - 1] == '\\';
        size_t keep = continued ? len - 1 : len;
        if (used + keep + 2 > OBJ_MAX_LINE)
            return en_reader_fail(r, EPSNET_EFORMAT, "continued statement longer than %zu bytes",
                                  OBJ_MAX_LINE);
        if (en_grow((void **)&st->joined, &st->joined_cap, used + keep + 2, 1))
            return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
        memcpy(st->joined + used, line, keep);
        used += keep;
        st->joined[used++] = ' ';
        st->joined[used] = '\0';
        if (!continued)
            break;
        rc = en_source_line(r->src, &line, &len, OBJ_MAX_LINE, &r->err);
        if (rc < 0)
            return source_failed(r, rc);
        if (rc == 0)
            break;              /* a backslash on the last line continues nothing */
    }
    *stmt = st->joined;
    return 1;
}

static int parse_vertex(epsnet_reader *r, char *p)
{
    double val[OBJ_MAX_VERTEX_VALUES];
    int n = 0;
    for (;;) {
        double d;
        /* w and colours are not kept: plain strtod is enough for them */
        int rc = scan_coord(&p, n < 3 ? r->info.coord_type : EPSNET_COORD_FLOAT64, &d);
        if (rc == 0)
            break;
        if (rc < 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu: '%.*s' is not a number",
                                  (unsigned long long)r->nverts + 1, quoted_len(p), p);
        if (n == OBJ_MAX_VERTEX_VALUES)
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu has more than %d values",
                                  (unsigned long long)r->nverts + 1, OBJ_MAX_VERTEX_VALUES);
        val[n++] = d;
    }
    if (n < 3)
        return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu has %d coordinates, expected 3",
                              (unsigned long long)r->nverts + 1, n);
    return en_reader_push_vertex(r, val[0], val[1], val[2]);
}

/* OBJ index -> 0-based global index; the front end checks the upper bound. */
static int resolve_index(epsnet_reader *r, int64_t k, uint64_t *out)
{
    if (k > 0) {
        *out = (uint64_t)k - 1;
        return 0;
    }
    if (k == 0)
        return en_reader_fail(r, EPSNET_EFORMAT, "face %llu: vertex index 0 (OBJ indices start at 1)",
                              (unsigned long long)r->ntris + 1);
    uint64_t back = (uint64_t)(-(k + 1)) + 1;
    if (back > r->nverts)
        return en_reader_fail(r, EPSNET_EFORMAT,
                              "face %llu: relative index %lld reaches before the first vertex "
                              "(%llu vertices so far)",
                              (unsigned long long)r->ntris + 1, (long long)k,
                              (unsigned long long)r->nverts);
    *out = r->nverts - back;
    return 0;
}

/* One corner `a`, `a/b`, `a/b/c` or `a//c`; b and c must be integers too,
 * though only a is used. */
static int scan_corner(char **pp, int64_t *vertex)
{
    char *p = *pp;
    int64_t ignored;
    if (scan_int64(&p, vertex))
        return -1;
    if (*p == '/') {
        p++;
        if (*p != '/' && scan_int64(&p, &ignored))
            return -1;
        if (*p == '/') {
            p++;
            if (scan_int64(&p, &ignored))
                return -1;
        }
    }
    if (!ends_token(*p))
        return -1;
    *pp = p;
    return 0;
}

static int parse_face(epsnet_reader *r, char *p)
{
    uint64_t first = 0, prev = 0;
    int ncorners = 0;
    for (;;) {
        p = skip_blanks(p);
        if (*p == '\0')
            break;
        int64_t k;
        uint64_t v = 0;
        if (scan_corner(&p, &k))
            return en_reader_fail(r, EPSNET_EFORMAT, "face %llu: bad corner '%.*s'",
                                  (unsigned long long)r->ntris + 1, quoted_len(p), p);
        int rc = resolve_index(r, k, &v);
        if (rc)
            return rc;
        if (ncorners == 0)
            first = v;
        else if (ncorners >= 2 && (rc = en_reader_push_triangle(r, first, prev, v)))
            return rc;
        prev = v;
        if (ncorners < 3)
            ncorners++;
    }
    if (ncorners < 3)
        return en_reader_fail(r, EPSNET_EFORMAT, "face %llu has %d corners, needs at least 3",
                              (unsigned long long)r->ntris + 1, ncorners);
    return 0;
}

static int parse_statement(epsnet_reader *r, char *stmt)
{
    char *p = skip_blanks(stmt);
    if (p[0] == 'v' && ends_token(p[1]))
        return parse_vertex(r, p + 1);
    if (p[0] == 'f' && ends_token(p[1]))
        return parse_face(r, p + 1);
    return 0;
}

static int obj_open_reader(epsnet_reader *r)
{
    obj_reader *st = en_calloc(1, sizeof *st);
    if (!st)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    r->state = st;
    r->text = 1;
    r->info.encoding = "ascii";
    r->info.coord_type = peek_coord_type(r->src);
    if (r->src->failed)
        return source_failed(r, en_source_error(r->src, &r->err));
    return 0;
}

static int obj_fill(epsnet_reader *r)
{
    obj_reader *st = r->state;
    while (r->qlen < OBJ_FILL_BATCH) {
        char *stmt = NULL;
        int rc = next_statement(r, st, &stmt);
        if (rc == 0)
            return r->qlen > 0;
        if (rc > 0)
            rc = parse_statement(r, stmt);
        /* note: records queued before a bad line are still delivered; the
         * front end reports r->err once the queue is empty. */
        if (rc < 0)
            return r->qlen > 0 ? 1 : rc;
    }
    return 1;
}

static void obj_close_reader(epsnet_reader *r)
{
    obj_reader *st = r->state;
    if (st) {
        en_free(st->joined);
        en_free(st);
    }
    r->state = NULL;
}

/* Content probe: the first statements of an OBJ are comments, groups,
 * materials or vertex data. */
static int obj_probe(const uint8_t *head, size_t n)
{
    static const char *const keywords[] = { "v", "vt", "vn", "f", "o", "g", "mtllib", "usemtl", "s" };
    const char *p = (const char *)head, *end = p + n;
    while (p < end) {
        const char *eol = memchr(p, '\n', (size_t)(end - p));
        const char *stop = eol ? eol : end;
        while (p < stop && is_blank(*p))
            p++;
        if (p < stop && *p != '#') {
            char word[16];
            copy_token(p, stop, word, sizeof word);
            for (size_t i = 0; i < sizeof keywords / sizeof *keywords; i++)
                if (strcmp(word, keywords[i]) == 0)
                    return 60;
            return 0;
        }
        if (!eol)
            break;
        p = eol + 1;
    }
    return 0;
}

/* ---- writer ---- */

/* note: a float32 file cannot hold a finite double beyond float range; writing
 * "inf" would make a file that no reader accepts. */
static int check_coord_range(epsnet_writer *w, const double xyz[3], uint64_t vertex)
{
    if (w->coord_type != EPSNET_COORD_FLOAT32)
        return 0;
    for (int k = 0; k < 3; k++)
        if (isfinite(xyz[k]) && !isfinite((float)xyz[k]))
            return en_error_set(&w->err, EPSNET_EUNSUPPORTED, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "vertex %llu: coordinate %g does not fit in float32",
                                (unsigned long long)vertex, xyz[k]);
    return 0;
}

/* Decimal text of v into buf (at least 21 bytes); @return its length. */
static size_t format_u64(char *buf, uint64_t v)
{
    char tmp[21];
    size_t n = 0;
    do {
        tmp[n++] = (char)('0' + v % 10);
        v /= 10;
    } while (v);
    for (size_t i = 0; i < n; i++)
        buf[i] = tmp[n - 1 - i];
    return n;
}

static int obj_open_writer(epsnet_writer *w)
{
    (void)w;
    return 0;
}

static int obj_put(epsnet_writer *w, const epsnet_record *rec)
{
    char line[3 * 33 + 8];
    size_t n = 0;
    if (rec->kind == EPSNET_REC_VERTEX) {
        int rc = check_coord_range(w, rec->xyz, w->nverts);
        if (rc)
            return rc;
        line[n++] = 'v';
        for (int k = 0; k < 3; k++) {
            line[n++] = ' ';
            n += (size_t)en_format_coord(line + n, rec->xyz[k], w->coord_type);
        }
    } else if (rec->kind == EPSNET_REC_TRIANGLE) {
        line[n++] = 'f';
        for (int k = 0; k < 3; k++) {
            line[n++] = ' ';
            n += format_u64(line + n, rec->v[k] + 1);
        }
    } else {
        return 0;
    }
    line[n++] = '\n';
    return en_writer_bytes(w, line, n);
}

static int obj_finish(epsnet_writer *w)
{
    (void)w;
    return 0;
}

const en_format en_format_obj = {
    .name = "obj",
    .extensions = "obj",
    .probe = obj_probe,
    .open_reader = obj_open_reader,
    .fill = obj_fill,
    .close_reader = obj_close_reader,
    .open_writer = obj_open_writer,
    .put = obj_put,
    .finish = obj_finish,
};
