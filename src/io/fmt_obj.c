/*
 * Wavefront OBJ (docs/architecture.md §13, ordinary formats): geometry only.
 *
 * Reader: `v x y z [w | r g b [a]]` and `f` with corners `a`, `a/b`, `a/b/c`
 * or `a//c`; indices are 1-based, or negative and relative to the newest
 * vertex (-1 = newest). Polygons are fan-triangulated around their first
 * corner. Faces may come between vertices, as OBJ allows. Vertex colours
 * become the attributes red, green, blue (float32, epsnet.h §2) when the
 * first `v` line of the file's first 64 KiB has them (OBJ has no header:
 * the attributes must be known before the first record); a later `v`
 * without colours then gets 0 0 0 and is counted as dropped ("vertex
 * without colour"). Every other statement (vt, vn, vp, o, g, s, usemtl,
 * mtllib, l, p, unknown ones) is skipped and named by
 * epsnet_reader_dropped(), as are w, alpha, and colours in a file whose
 * first `v` has none; the numbers of a `v` or `f` statement must all parse.
 * A trailing backslash continues a statement on the next line.
 *
 * note: OBJ has no header, so info.coord_type is decided by looking ahead at
 * the `v` lines, by the rule of src/io/text_scan.h.
 *
 * Writer: `v` lines in the shortest exact text for the writer's coordinate
 * type (with `r g b` when the stream has float32 red, green and blue, in
 * the shortest text that reads back to the same bits) and `f a b c` lines with 1-based absolute indices, in stream order
 * (OBJ allows interleaving, so nothing is buffered). FINALIZE records have no
 * OBJ form and are dropped.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "io/format.h"
#include "io/text_scan.h"

/* note: en_source_line() caps lines at half its 2 MiB window. */
#define OBJ_MAX_LINE ((size_t)1 << 20)
/* Records queued per fill(): amortises the front end's call overhead. */
#define OBJ_FILL_BATCH 4096
/* Beyond x y z: w, or r g b, or r g b a. */
#define OBJ_MAX_VERTEX_VALUES 7

typedef struct obj_reader {
    char *joined;                    /* backslash-continued statement */
    size_t joined_cap;
    int colours;                     /* the records carry red, green, blue */
} obj_reader;

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

static int parse_vertex(epsnet_reader *r, obj_reader *st, char *p)
{
    double val[OBJ_MAX_VERTEX_VALUES];
    float rgb[3] = { 0, 0, 0 };
    int n = 0;
    for (;;) {
        double d;
        /* note: a colour is read as a float directly (strtof), so the bits
         * are those of the text, as a float32 PLY reader would give them */
        if (st->colours && n >= 3 && n < 6) {
            char *q = en_text_skip_blanks(p);
            if (*q && *q != '#') {
                char *e;
                rgb[n - 3] = strtof(q, &e);
                if (e != q && en_text_ends_token(*e)) {
                    p = e;
                    val[n] = rgb[n - 3];
                    n++;
                    continue;
                }
            }
        }
        /* w and colours are not kept: plain strtod is enough for them */
        int rc = en_text_scan_coord(&p, n < 3 ? r->info.coord_type : EPSNET_COORD_FLOAT64, &d);
        if (rc == 0)
            break;
        if (rc < 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu: '%.*s' is not a number",
                                  (unsigned long long)r->nverts + 1, en_text_quoted_len(p), p);
        if (n == OBJ_MAX_VERTEX_VALUES)
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu has more than %d values",
                                  (unsigned long long)r->nverts + 1, OBJ_MAX_VERTEX_VALUES);
        val[n++] = d;
    }
    if (n < 3)
        return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu has %d coordinates, expected 3",
                              (unsigned long long)r->nverts + 1, n);
    if (st->colours) {
        if (n == 4 || n == 5)
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu has %d values, expected 3 or 6 (x y z r g b)",
                                  (unsigned long long)r->nverts + 1, n);
        if (n == 3)
            en_reader_drop(r, "vertex without colour", 1, 1);
        if (n == 7)
            en_reader_drop(r, "vertex colour alpha", 1, 1);
        uint8_t attr[12];
        memcpy(attr, rgb, sizeof attr);
        return en_reader_push_vertex_attr(r, val[0], val[1], val[2], attr);
    }
    if (n > 3)
        en_reader_drop(r, n == 4 ? "vertex w" : "vertex colour", 1, 1);
    return en_reader_push_vertex(r, val[0], val[1], val[2]);
}

/* Whether the first `v` line in the first EN_TEXT_PEEK_BYTES has colours
 * (6 or 7 numbers), without consuming anything. */
static int peek_colours(en_source *src)
{
    size_t avail = en_source_fill(src, EN_TEXT_PEEK_BYTES);
    if (avail > EN_TEXT_PEEK_BYTES)
        avail = EN_TEXT_PEEK_BYTES;
    const char *p = (const char *)src->cur, *end = p + avail;
    while (p < end) {
        const char *eol = memchr(p, '\n', (size_t)(end - p));
        if (!eol)
            return 0;
        while (p < eol && (*p == ' ' || *p == '\t'))
            p++;
        if (eol - p > 2 && p[0] == 'v' && (p[1] == ' ' || p[1] == '\t')) {
            int n = 0;
            for (const char *q = p + 1; q < eol && *q != '#';) {
                while (q < eol && (*q == ' ' || *q == '\t' || *q == '\r'))
                    q++;
                if (q == eol || *q == '#')
                    break;
                n++;
                while (q < eol && *q != ' ' && *q != '\t' && *q != '\r')
                    q++;
            }
            return n == 6 || n == 7;
        }
        p = eol + 1;
    }
    return 0;
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
    if (en_text_scan_int64(&p, vertex))
        return -1;
    if (*p == '/') {
        p++;
        if (*p != '/' && en_text_scan_int64(&p, &ignored))
            return -1;
        if (*p == '/') {
            p++;
            if (en_text_scan_int64(&p, &ignored))
                return -1;
        }
    }
    if (!en_text_ends_token(*p))
        return -1;
    *pp = p;
    return 0;
}

static int parse_face(epsnet_reader *r, char *p)
{
    uint64_t first = 0, prev = 0;
    int ncorners = 0;
    for (;;) {
        p = en_text_skip_blanks(p);
        if (*p == '\0')
            break;
        int64_t k;
        uint64_t v = 0;
        if (scan_corner(&p, &k))
            return en_reader_fail(r, EPSNET_EFORMAT, "face %llu: bad corner '%.*s'",
                                  (unsigned long long)r->ntris + 1, en_text_quoted_len(p), p);
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

/* docs/architecture.md §5: a statement kind the records do not carry is named, by its
 * keyword, with how many there were. Keywords are printed, so bytes that
 * are not printable ASCII are shown as '?'. */
static void drop_statement(epsnet_reader *r, const char *p)
{
    char kw[33];
    size_t n = 0;
    while (n < sizeof kw - 1 && !en_text_ends_token(p[n])) {
        unsigned char c = (unsigned char)p[n];
        kw[n++] = c > 0x20 && c < 0x7f ? (char)c : '?';
    }
    kw[n] = '\0';
    en_reader_drop(r, kw, 1, 1);
}

static int parse_statement(epsnet_reader *r, char *stmt)
{
    char *p = en_text_skip_blanks(stmt);
    if (p[0] == 'v' && en_text_ends_token(p[1]))
        return parse_vertex(r, r->state, p + 1);
    if (p[0] == 'f' && en_text_ends_token(p[1]))
        return parse_face(r, p + 1);
    if (p[0] != '\0' && p[0] != '#')
        drop_statement(r, p);
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
    r->info.coord_type = en_text_peek_coord_type(r->src, "v", UINT64_MAX);
    if (r->src->failed)
        return source_failed(r, en_source_error(r->src, &r->err));
    st->colours = peek_colours(r->src);
    if (r->src->failed)
        return source_failed(r, en_source_error(r->src, &r->err));
    if (st->colours)
        for (int k = 0; k < 3; k++)
            if (en_reader_add_attr(r, k == 0 ? "red" : k == 1 ? "green" : "blue", EPSNET_ATTR_FLOAT32) < 0)
                return r->err.code;
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
        if (rc < 0)
            return rc;
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
        while (p < stop && en_text_is_blank(*p))
            p++;
        if (p < stop && *p != '#') {
            char word[16];
            en_text_copy_token(p, stop, word, sizeof word);
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

/* OBJ holds vertex colours as `v x y z r g b`: red, green and blue, all
 * three float32 (epsnet.h epsnet_writer_dropped()). */
static int obj_holds_attr(const epsnet_attr_layout *l, uint32_t i)
{
    static const char *rgb[3] = { "red", "green", "blue" };
    int is_rgb = 0;
    for (int k = 0; k < 3; k++) {
        int at = epsnet_attr_layout_find(l, rgb[k]);
        if (at < 0 || l->attr[at].type != EPSNET_ATTR_FLOAT32)
            return 0;
        is_rgb |= (uint32_t)at == i;
    }
    return is_rgb;
}

static int obj_put(epsnet_writer *w, const epsnet_record *rec)
{
    char line[6 * 33 + 8];
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
        if (w->attrs.count == 3) {
            static const char *rgb[3] = { "red", "green", "blue" };
            for (int k = 0; k < 3; k++) {
                float c;
                memcpy(&c, rec->attr + w->attrs.attr[epsnet_attr_layout_find(&w->attrs, rgb[k])].offset, 4);
                line[n++] = ' ';
                n += (size_t)en_format_coord(line + n, c, EPSNET_COORD_FLOAT32);
            }
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
    .holds_attr = obj_holds_attr,
};
