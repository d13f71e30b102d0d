/*
 * OFF reader (docs/architecture.md §13). Geomview's text format: a keyword
 * line "[ST][C][N]OFF", a counts line "nv nf ne", nv vertex lines and nf face
 * lines "n i0 .. i(n-1) [colour]", with 0-based indices and '#' comments.
 *
 * The keyword's prefixes announce extra per-vertex values (texture, colour,
 * normal) whose number varies between writers (colours come as 3 or 4
 * values), so vertex lines are read as "x y z" followed by any numbers,
 * which covers every variant without counting them. The 4D and n-D variants
 * and binary OFF are refused as unsupported.
 *
 * note: OFF declares no coordinate type either. Like OBJ and SMA, the type
 * comes from the vertex lines in the first 64 KiB and coordinates are read
 * by the rule of src/io/text_scan.h, so a float mesh round-trips bit-exact
 * and a float32 writer never rounds a value that was read as a double.
 */
#include <inttypes.h>
#include <stdio.h>
#include <string.h>

#include "common/alloc.h"
#include "io/format.h"
#include "io/text_scan.h"

#define OFF_LINE_MAX ((size_t)1 << 20)
#define OFF_MAX_POLYGON ((uint64_t)1 << 20)
#define OFF_BATCH 4096

typedef struct off_reader {
    uint64_t nverts, nfaces;     /* from the counts line */
    uint64_t verts_read, faces_read;
    uint64_t short_polygons;     /* faces with fewer than 3 corners, skipped */
} off_reader;

static int adopt_error(epsnet_reader *r, const epsnet_error *e)
{
    if (!r->failed) {
        r->failed = 1;
        r->err = *e;
    }
    return r->err.code;
}

static char *next_token(char **cursor)
{
    char *s = *cursor;
    while (*s == ' ' || *s == '\t' || *s == '\r' || *s == '\f' || *s == '\v')
        s++;
    if (!*s) {
        *cursor = s;
        return NULL;
    }
    char *t = s;
    while (*s && *s != ' ' && *s != '\t' && *s != '\r' && *s != '\f' && *s != '\v')
        s++;
    if (*s)
        *s++ = '\0';
    *cursor = s;
    return t;
}

/* Next line that holds something once its '#' comment is cut off.
 * @return 1, 0 at the end of input, or a negative code. */
static int significant_line(epsnet_reader *r, char **line)
{
    size_t len;
    epsnet_error e;
    for (;;) {
        int rc = en_source_line(r->src, line, &len, OFF_LINE_MAX, &e);
        if (rc < 0)
            return adopt_error(r, &e);
        if (rc == 0)
            return 0;
        char *hash = memchr(*line, '#', len);
        if (hash)
            *hash = '\0';
        char *s = *line;
        while (*s == ' ' || *s == '\t' || *s == '\r' || *s == '\f' || *s == '\v')
            s++;
        if (*s)
            return 1;
    }
}

static int parse_count(const char *s, uint64_t *out)
{
    if (!s || *s < '0' || *s > '9')
        return -1;
    uint64_t v = 0;
    for (; *s; s++) {
        if (*s < '0' || *s > '9')
            return -1;
        unsigned d = (unsigned)(*s - '0');
        if (v > (UINT64_MAX - d) / 10)
            return -1;
        v = v * 10 + d;
    }
    *out = v;
    return 0;
}

/* A whole token as a coordinate of a stream of the given type. */
static int parse_number(char *s, epsnet_coord_type type, double *out)
{
    return en_text_scan_coord(&s, type, out) == 1 ? 0 : -1;
}

/* Index token: an integer, negative ones reported as such by the caller. */
static int parse_index(const char *s, int64_t *out)
{
    int neg = *s == '-';
    if (*s == '-' || *s == '+')
        s++;
    uint64_t u;
    if (parse_count(s, &u) || u > (uint64_t)INT64_MAX)
        return -1;
    *out = neg ? -(int64_t)u : (int64_t)u;
    return 0;
}

/* "[ST][C][N]OFF", optionally followed on the same line by the counts. */
static int read_keyword(epsnet_reader *r, char **rest)
{
    char *line;
    int rc = significant_line(r, &line);
    if (rc < 0)
        return rc;
    if (rc == 0)
        return en_reader_fail(r, EPSNET_EFORMAT, "empty file: no OFF header");
    *rest = line;
    char *kw = next_token(rest);
    size_t n = strlen(kw);
    if (n < 3 || strcmp(kw + n - 3, "OFF") != 0)
        return en_reader_fail(r, EPSNET_EFORMAT, "not an OFF file: the header is '%s', not 'OFF'", kw);
    const char *p = kw;
    if (strncmp(p, "ST", 2) == 0)
        p += 2;
    if (*p == 'C')
        p++;
    if (*p == 'N')
        p++;
    if (*p == '4' || *p == 'n')
        return en_reader_fail(r, EPSNET_EUNSUPPORTED, "'%s': 4D and n-dimensional OFF are not supported", kw);
    if (p != kw + n - 3)
        return en_reader_fail(r, EPSNET_EFORMAT, "unknown OFF variant '%s'", kw);
    const char *after = *rest;
    while (*after == ' ' || *after == '\t')
        after++;
    if (strncmp(after, "BINARY", 6) == 0)
        return en_reader_fail(r, EPSNET_EUNSUPPORTED, "binary OFF is not supported");
    return 0;
}

static int off_open_reader(epsnet_reader *r)
{
    off_reader *o = en_calloc(1, sizeof *o);
    if (!o)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    r->state = o;
    r->text = 1;
    char *rest;
    int rc = read_keyword(r, &rest);
    if (rc)
        return rc;
    char *tok = next_token(&rest);
    if (!tok) {
        if ((rc = significant_line(r, &rest)) < 0)
            return rc;
        if (rc == 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "truncated file: no counts line after 'OFF'");
        tok = next_token(&rest);
    }
    char *nf = next_token(&rest), *ne = next_token(&rest);
    uint64_t nedges_ignored;
    if (parse_count(tok, &o->nverts) || parse_count(nf, &o->nfaces) || (ne && parse_count(ne, &nedges_ignored)) ||
        next_token(&rest))
        return en_reader_fail(r, EPSNET_EFORMAT, "expected the counts line 'vertices faces edges'");
    if ((rc = en_reader_check_count(r, o->nverts, "vertex count")) ||
        (rc = en_reader_check_count(r, o->nfaces, "face count")))
        return rc;
    r->info.encoding = "ascii";
    r->info.coord_type = en_text_peek_coord_type(r->src, NULL, o->nverts);
    if (r->src->failed) {
        r->failed = 1;
        return en_source_error(r->src, &r->err);
    }
    r->info.nverts = o->nverts;
    r->info.nfaces = o->nfaces == 0 ? 0 : EPSNET_COUNT_UNKNOWN;
    return 0;
}

static int missing_record(epsnet_reader *r, const char *what, uint64_t index, uint64_t total)
{
    return en_reader_fail(r, EPSNET_EFORMAT, "truncated file: %s %" PRIu64 " of %" PRIu64 " is missing",
                          what, index + 1, total);
}

/* Extra values after a record (colours, normals, texture coordinates) must
 * still be numbers: anything else is garbage. They are not carried: each
 * record that has some is counted under one name in the dropped warning
 * (docs/architecture.md §5: nothing is dropped without a word). */
static int check_extras(epsnet_reader *r, const char *what, uint64_t index, char **cursor)
{
    int any = 0;
    for (char *tok; (tok = next_token(cursor)); any = 1) {
        double ignored;
        if (parse_number(tok, EPSNET_COORD_FLOAT64, &ignored))
            return en_reader_fail(r, EPSNET_EFORMAT, "%s %" PRIu64 ": '%s' is not a number", what,
                                  index + 1, tok);
    }
    if (any)
        en_reader_drop(r, what[0] == 'v' ? "vertex values past x y z (colour, normal, texture)" : "face colour", 1,
                       1);
    return 0;
}

static int read_vertex(epsnet_reader *r, off_reader *o)
{
    char *line;
    int rc = significant_line(r, &line);
    if (rc <= 0)
        return rc < 0 ? rc : missing_record(r, "vertex", o->verts_read, o->nverts);
    double xyz[3];
    for (int k = 0; k < 3; k++) {
        char *tok = next_token(&line);
        if (!tok)
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %" PRIu64 ": expected 3 coordinates, found %d",
                                  o->verts_read + 1, k);
        if (parse_number(tok, r->info.coord_type, &xyz[k]))
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %" PRIu64 ": '%s' is not a number",
                                  o->verts_read + 1, tok);
    }
    if ((rc = check_extras(r, "vertex", o->verts_read, &line)))
        return rc;
    o->verts_read++;
    return en_reader_push_vertex(r, xyz[0], xyz[1], xyz[2]);
}

static int read_face(epsnet_reader *r, off_reader *o)
{
    char *line;
    int rc = significant_line(r, &line);
    if (rc <= 0)
        return rc < 0 ? rc : missing_record(r, "face", o->faces_read, o->nfaces);
    const uint64_t face = o->faces_read + 1;
    uint64_t n;
    char *tok = next_token(&line);
    if (parse_count(tok, &n))
        return en_reader_fail(r, EPSNET_EFORMAT, "face %" PRIu64 ": '%s' is not a corner count", face, tok);
    if (n > OFF_MAX_POLYGON)
        return en_reader_fail(r, EPSNET_EFORMAT, "face %" PRIu64 ": %" PRIu64 " corners is more than %" PRIu64,
                              face, n, OFF_MAX_POLYGON);
    uint64_t first = 0, prev = 0;
    for (uint64_t i = 0; i < n; i++) {
        int64_t v;
        tok = next_token(&line);
        if (!tok)
            return en_reader_fail(r, EPSNET_EFORMAT, "face %" PRIu64 ": expected %" PRIu64 " indices, found %" PRIu64,
                                  face, n, i);
        if (parse_index(tok, &v))
            return en_reader_fail(r, EPSNET_EFORMAT, "face %" PRIu64 ": '%s' is not a vertex index", face, tok);
        if (v < 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "face %" PRIu64 ": negative vertex index %" PRId64, face, v);
        if (i == 0)
            first = (uint64_t)v;
        else if (i >= 2 && (rc = en_reader_push_triangle(r, first, prev, (uint64_t)v)))
            return rc;
        prev = (uint64_t)v;
    }
    if (n < 3)
        o->short_polygons++;
    o->faces_read++;
    return check_extras(r, "face", face - 1, &line);
}

static int off_fill(epsnet_reader *r)
{
    off_reader *o = r->state;
    const uint64_t pushed = r->nverts + r->ntris;
    for (int i = 0; i < OFF_BATCH; i++) {
        int rc;
        if (o->verts_read < o->nverts)
            rc = read_vertex(r, o);
        else if (o->faces_read < o->nfaces)
            rc = read_face(r, o);
        else
            break;
        if (rc)
            return rc;
    }
    if (r->nverts + r->ntris != pushed)
        return 1;
    if (o->verts_read < o->nverts || o->faces_read < o->nfaces)
        return 1;
    char *line;
    int rc = significant_line(r, &line);
    if (rc < 0)
        return rc;
    if (rc > 0)
        return en_reader_fail(r, EPSNET_EFORMAT, "trailing data after the last face (do the header counts lie?)");
    return 0;
}

static void off_close_reader(epsnet_reader *r)
{
    en_free(r->state);
    r->state = NULL;
}

static int off_probe(const uint8_t *head, size_t n)
{
    size_t i = 0;
    if (n >= 2 && memcmp(head, "ST", 2) == 0)
        i = 2;
    if (i < n && head[i] == 'C')
        i++;
    if (i < n && head[i] == 'N')
        i++;
    if (i + 3 > n || memcmp(head + i, "OFF", 3) != 0)
        return 0;
    i += 3;
    if (i == n || head[i] == '\n' || head[i] == '\r' || head[i] == ' ' || head[i] == '\t')
        return 80;
    return 0;
}

/* ---- writer ----
 *
 * OFF wants both counts before the vertices, and every vertex before the
 * first face, while a stream interleaves them and may not know its counts.
 * So vertices go straight to the output after a counts line reserved at
 * its widest and patched at the end, and faces wait in a temporary file;
 * an output that cannot be patched (a pipe, .zst) keeps the vertices there
 * too and writes both after the counts. Coordinates are printed in their
 * shortest exact text (src/io/text_scan.h), so reading the file back gives
 * the same bits. */

#define OFF_COUNTS_WIDTH 20 /* digits of the widest count */

typedef struct off_writer {
    int patch;               /* the counts line is reserved and patched */
    uint64_t counts_at;      /* its offset */
    en_spill *verts, *faces; /* verts: only without patch */
} off_writer;

/* The counts line, padded to its widest when it is to be patched. */
static int off_counts(epsnet_writer *w, int patch, char *buf, size_t cap)
{
    int width = patch ? OFF_COUNTS_WIDTH : 0;
    return snprintf(buf, cap, "%-*" PRIu64 " %-*" PRIu64 " 0\n", width, w->nverts, width, w->ntris);
}

static int off_open_writer(epsnet_writer *w)
{
    off_writer *o = en_calloc(1, sizeof *o);
    if (!o)
        return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    w->state = o;
    o->patch = en_sink_can_patch(w->sink);
    if (!o->patch)
        return 0;
    int rc = en_writer_printf(w, "OFF\n");
    o->counts_at = en_sink_offset(w->sink);
    char line[2 * OFF_COUNTS_WIDTH + 8];
    return rc ? rc : en_writer_bytes(w, line, (size_t)off_counts(w, 1, line, sizeof line));
}

static int off_vertex_line(epsnet_writer *w, const double xyz[3])
{
    char c[3][32]; /* en_text_format_coord: 32 bytes */
    for (int k = 0; k < 3; k++)
        en_format_coord(c[k], xyz[k], w->coord_type);
    return en_writer_printf(w, "%s %s %s\n", c[0], c[1], c[2]);
}

static int off_put(epsnet_writer *w, const epsnet_record *rec)
{
    off_writer *o = w->state;
    int rc;
    switch (rec->kind) {
    case EPSNET_REC_VERTEX:
        if (o->patch)
            return off_vertex_line(w, rec->xyz);
        rc = en_writer_open_spill(w, &o->verts);
        return rc ? rc : en_spill_write(o->verts, rec->xyz, sizeof rec->xyz, &w->err);
    case EPSNET_REC_TRIANGLE:
        rc = en_writer_open_spill(w, &o->faces);
        return rc ? rc : en_spill_write(o->faces, rec->v, sizeof rec->v, &w->err);
    default:
        return 0;
    }
}

/* Replay a spill of records of `size` bytes (3 doubles, or 3 uint64) as lines. */
static int off_replay(epsnet_writer *w, en_spill *sp, int vertices)
{
    if (!sp)
        return 0;
    int rc = en_spill_rewind(sp, &w->err);
    uint64_t buf[3 * 4096];
    while (rc == 0) {
        int64_t got = en_spill_read(sp, buf, sizeof buf, &w->err);
        if (got <= 0)
            return (int)got;
        if ((size_t)got % (3 * sizeof *buf))
            return en_error_set(&w->err, EPSNET_EIO, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "temporary file ended in the middle of a record");
        for (size_t i = 0; rc == 0 && i < (size_t)got / (3 * sizeof *buf); i++) {
            if (vertices) {
                double xyz[3];
                memcpy(xyz, buf + 3 * i, sizeof xyz);
                rc = off_vertex_line(w, xyz);
            } else {
                rc = en_writer_printf(w, "3 %" PRIu64 " %" PRIu64 " %" PRIu64 "\n", buf[3 * i], buf[3 * i + 1],
                                      buf[3 * i + 2]);
            }
        }
    }
    return rc;
}

static int off_finish(epsnet_writer *w)
{
    off_writer *o = w->state;
    char line[2 * OFF_COUNTS_WIDTH + 8];
    int n = off_counts(w, o->patch, line, sizeof line), rc;
    if (o->patch)
        rc = en_sink_patch(w->sink, o->counts_at, line, (size_t)n, &w->err);
    else if ((rc = en_writer_printf(w, "OFF\n")) == 0 && (rc = en_writer_bytes(w, line, (size_t)n)) == 0)
        rc = off_replay(w, o->verts, 1);
    return rc ? rc : off_replay(w, o->faces, 0);
}

static void off_close_writer(epsnet_writer *w)
{
    off_writer *o = w->state;
    if (!o)
        return;
    en_spill_close(&o->verts);
    en_spill_close(&o->faces);
    en_free(o);
    w->state = NULL;
}

const en_format en_format_off = {
    .name = "off",
    .extensions = "off",
    .probe = off_probe,
    .open_reader = off_open_reader,
    .fill = off_fill,
    .close_reader = off_close_reader,
    .open_writer = off_open_writer,
    .put = off_put,
    .finish = off_finish,
    .close_writer = off_close_writer,
};
