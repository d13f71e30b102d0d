/*
 * SMA, the ASCII streaming mesh of Isenburg & Lindstrom, "Streaming Meshes"
 * (2005).
 *
 *   # nverts N            header comments before the first record
 *   # nfaces N            (other comments are ignored anywhere)
 *   # bb_min x y z
 *   # bb_max x y z
 *   v x y z               a vertex, the next global index
 *   f a b c               a triangle; a positive index is 1-based and
 *                         absolute, a negative one counts back from the
 *                         newest vertex (-1 = newest) and finalizes it
 *   x k                   finalizes vertex k
 *
 * note: `x k` reads k exactly like a triangle corner, as the authors' reader
 * (smreader_sma.cpp) does: positive = 1-based absolute, negative = relative
 * to the newest vertex. Only the relative form in `f` lines finalizes by
 * itself.
 *
 * Reader: emits the TRIANGLE record, then one FINALIZE per distinct
 * negatively referenced corner, in corner order. Header counts, when given,
 * must match the records at the end (a shorter file is truncated). The
 * reader needs pre-order streams (each triangle after its vertices), which
 * is what the epsnet pipeline consumes (docs/architecture.md §6).
 *
 * note: like OBJ, SMA has no coordinate type; info.coord_type is decided
 * from the `v` lines of the first 64 KiB by the rule of src/io/text_scan.h.
 *
 * Writer: the last triangle is held back until the next record, so that
 * FINALIZE records right after it become negative corners; any other
 * finalization is an `x` line with an absolute index. Count comments are
 * written with fixed width and patched at the end on seekable outputs, so
 * they always match; on compressed or piped outputs they are written only
 * when announced, and a mismatch is an error.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "io/format.h"
#include "io/text_scan.h"

#define SMA_MAX_LINE ((size_t)1 << 16)
#define SMA_FILL_BATCH 4096
/* "# nverts " + this many characters, so counts can be patched in place. */
#define SMA_COUNT_WIDTH 20

/* An index token after blanks, by the SMA grammar: the whole token must be
 * the integer. @return 1 with *out set, 0 at the end of the line, -1 on a
 * bad token (*pp then points at it). */
static int scan_index(char **pp, int64_t *out)
{
    char *p = en_text_skip_blanks(*pp);
    *pp = p;
    if (*p == '\0')
        return 0;
    if (en_text_scan_int64(&p, out) || !en_text_ends_token(*p))
        return -1;
    *pp = p;
    return 1;
}

/* ---- reader ---- */

typedef struct sma_header {
    int has_bb_min, has_bb_max;
} sma_header;

static int source_failed(epsnet_reader *r, int rc)
{
    r->failed = 1;
    return rc;
}

/* A header count: negative means unknown, as the authors' writer uses -1. */
static int parse_header_count(epsnet_reader *r, char *p, const char *what, uint64_t *out)
{
    int64_t n;
    if (scan_index(&p, &n) != 1 || n < 0)
        return 0;
    int rc = en_reader_check_count(r, (uint64_t)n, what);
    if (rc == 0)
        *out = (uint64_t)n;
    return rc;
}

static void parse_header_point(char *p, epsnet_coord_type type, double xyz[3], int *has)
{
    for (int k = 0; k < 3; k++)
        if (en_text_scan_coord(&p, type, &xyz[k]) != 1)
            return;
    *has = 1;
}

/* Header comments are advisory text; ones that do not parse are ignored. */
static int parse_header_comment(epsnet_reader *r, sma_header *h, char *line)
{
    char *p = en_text_skip_blanks(line + 1);
    char word[16];
    size_t n = en_text_copy_token(p, p + strlen(p), word, sizeof word);
    p += n;
    if (strcmp(word, "nverts") == 0)
        return parse_header_count(r, p, "vertex count", &r->info.nverts);
    if (strcmp(word, "nfaces") == 0)
        return parse_header_count(r, p, "face count", &r->info.nfaces);
    if (strcmp(word, "bb_min") == 0)
        parse_header_point(p, r->info.coord_type, r->info.bbox_min, &h->has_bb_min);
    else if (strcmp(word, "bb_max") == 0)
        parse_header_point(p, r->info.coord_type, r->info.bbox_max, &h->has_bb_max);
    return 0;
}

/* Consume the leading comment and blank lines: the header. */
static int read_header(epsnet_reader *r)
{
    sma_header h = { 0, 0 };
    for (;;) {
        size_t avail = en_source_fill(r->src, 2);
        if (avail == 0)
            break;
        const char *c = (const char *)r->src->cur;
        int blank_line = c[0] == '\n' || (c[0] == '\r' && avail > 1 && c[1] == '\n');
        if (c[0] != '#' && !blank_line)
            break;
        char *line;
        size_t len;
        int rc = en_source_line(r->src, &line, &len, SMA_MAX_LINE, &r->err);
        if (rc < 0)
            return source_failed(r, rc);
        if (rc == 0)
            break;
        if (line[0] == '#' && (rc = parse_header_comment(r, &h, line)))
            return rc;
    }
    if (r->src->failed)
        return source_failed(r, en_source_error(r->src, &r->err));
    r->info.has_bbox = h.has_bb_min && h.has_bb_max;
    return 0;
}

static int sma_open_reader(epsnet_reader *r)
{
    r->text = 1;
    r->info.encoding = "ascii";
    r->info.streaming = 1;
    r->info.coord_type = en_text_peek_coord_type(r->src, "v", UINT64_MAX);
    return read_header(r);
}

/* SMA index -> 0-based global index (see the file comment). */
static int resolve_index(epsnet_reader *r, int64_t k, uint64_t *out)
{
    if (k > 0) {
        *out = (uint64_t)k - 1;
        return 0;
    }
    if (k == 0)
        return en_reader_fail(r, EPSNET_EFORMAT, "vertex index 0 (SMA indices start at 1, or -1 backwards)");
    uint64_t back = (uint64_t)(-(k + 1)) + 1;
    if (back > r->nverts)
        return en_reader_fail(r, EPSNET_EFORMAT,
                              "relative index %lld reaches before the first vertex (%llu vertices so far)",
                              (long long)k, (unsigned long long)r->nverts);
    *out = r->nverts - back;
    return 0;
}

/* Parse exactly n integers; anything missing or extra is an error. */
static int scan_ints(epsnet_reader *r, char *p, int64_t *out, int n, const char *what)
{
    for (int k = 0; k < n; k++) {
        int rc = scan_index(&p, &out[k]);
        if (rc == 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "%s has %d indices, expected %d", what, k, n);
        if (rc < 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "%s: '%.*s' is not an integer index", what,
                                  en_text_quoted_len(p), p);
    }
    p = en_text_skip_blanks(p);
    if (*p)
        return en_reader_fail(r, EPSNET_EFORMAT, "%s: unexpected '%.*s' after %d indices", what,
                              en_text_quoted_len(p), p, n);
    return 0;
}

static int parse_vertex(epsnet_reader *r, char *p)
{
    double xyz[3];
    for (int k = 0; k < 3; k++) {
        int rc = en_text_scan_coord(&p, r->info.coord_type, &xyz[k]);
        if (rc == 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu has %d coordinates, expected 3",
                                  (unsigned long long)r->nverts + 1, k);
        if (rc < 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu: '%.*s' is not a number",
                                  (unsigned long long)r->nverts + 1, en_text_quoted_len(p), p);
    }
    p = en_text_skip_blanks(p);
    if (*p)
        return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu: unexpected '%.*s' after 3 coordinates",
                              (unsigned long long)r->nverts + 1, en_text_quoted_len(p), p);
    return en_reader_push_vertex(r, xyz[0], xyz[1], xyz[2]);
}

static int parse_triangle(epsnet_reader *r, char *p)
{
    int64_t idx[3];
    uint64_t v[3];
    int rc = scan_ints(r, p, idx, 3, "triangle");
    for (int k = 0; k < 3 && rc == 0; k++)
        rc = resolve_index(r, idx[k], &v[k]);
    if (rc || (rc = en_reader_push_triangle(r, v[0], v[1], v[2])))
        return rc;
    for (int k = 0; k < 3; k++) {
        int first = 1;
        for (int j = 0; j < k; j++)
            if (idx[j] < 0 && v[j] == v[k])
                first = 0;
        if (idx[k] < 0 && first && (rc = en_reader_push_finalize(r, v[k])))
            return rc;
    }
    return 0;
}

static int parse_finalize(epsnet_reader *r, char *p)
{
    int64_t k;
    uint64_t v = 0;
    int rc = scan_ints(r, p, &k, 1, "finalization");
    if (rc || (rc = resolve_index(r, k, &v)))
        return rc;
    return en_reader_push_finalize(r, v);
}

static int parse_statement(epsnet_reader *r, char *line)
{
    char *p = en_text_skip_blanks(line);
    if (*p == '\0' || *p == '#')
        return 0;
    if (en_text_ends_token(p[1])) {
        if (p[0] == 'v')
            return parse_vertex(r, p + 1);
        if (p[0] == 'f')
            return parse_triangle(r, p + 1);
        if (p[0] == 'x')
            return parse_finalize(r, p + 1);
    }
    return en_reader_fail(r, EPSNET_EFORMAT, "unknown SMA statement '%.*s' (expected v, f, x or #)",
                          en_text_quoted_len(p), p);
}

/* Lying or truncated files: the header counts are a promise. */
static int check_counts(epsnet_reader *r)
{
    if (r->info.nverts != EPSNET_COUNT_UNKNOWN && r->info.nverts != r->nverts)
        return en_reader_fail(r, EPSNET_EFORMAT, "the header announces %llu vertices but the file has %llu",
                              (unsigned long long)r->info.nverts, (unsigned long long)r->nverts);
    if (r->info.nfaces != EPSNET_COUNT_UNKNOWN && r->info.nfaces != r->ntris)
        return en_reader_fail(r, EPSNET_EFORMAT, "the header announces %llu triangles but the file has %llu",
                              (unsigned long long)r->info.nfaces, (unsigned long long)r->ntris);
    return 0;
}

static int sma_fill(epsnet_reader *r)
{
    while (r->qlen < SMA_FILL_BATCH) {
        char *line;
        size_t len;
        int rc = en_source_line(r->src, &line, &len, SMA_MAX_LINE, &r->err);
        if (rc < 0)
            rc = source_failed(r, rc);
        else if (rc == 0 && (rc = check_counts(r)) == 0)
            return r->qlen > 0;
        else if (rc > 0)
            rc = parse_statement(r, line);
        if (rc < 0)
            return rc;
    }
    return 1;
}

/* Content probe: SMA shares `v`/`f` with OBJ; its header comments and `x`
 * lines are what tell it apart. */
static int sma_probe(const uint8_t *head, size_t n)
{
    const char *p = (const char *)head, *end = p + n;
    while (p < end) {
        const char *eol = memchr(p, '\n', (size_t)(end - p));
        const char *stop = eol ? eol : end;
        char word[16];
        if (stop - p > 2 && p[0] == '#') {
            const char *q = p + 1;
            while (q < stop && en_text_is_blank(*q))
                q++;
            en_text_copy_token(q, stop, word, sizeof word);
            if (!strcmp(word, "nverts") || !strcmp(word, "nfaces") || !strcmp(word, "bb_min"))
                return 70;
        } else if (stop - p > 2 && p[0] == 'x' && en_text_is_blank(p[1])) {
            return 70;
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

typedef struct sma_pending {
    int active;
    uint64_t v[3];
    uint64_t nverts_then;       /* vertices written before it: the base of relative indices */
    int negative[3];
    int last_absorbed;          /* corner of the last FINALIZE folded in, -1 none */
} sma_pending;

typedef struct sma_writer {
    uint64_t nverts, ntris;
    sma_pending tri;
    int patchable;
    uint64_t nverts_field, nfaces_field;   /* sink offsets of the count text */
    int wrote_nverts, wrote_nfaces;
} sma_writer;

static int write_count_comment(epsnet_writer *w, const char *name, uint64_t n, uint64_t *field,
                               int *wrote)
{
    char line[64];
    int len = snprintf(line, sizeof line, "# %s %*llu\n", name, SMA_COUNT_WIDTH, (unsigned long long)n);
    *field = en_sink_offset(w->sink) + strlen(name) + 3;
    *wrote = 1;
    return en_writer_bytes(w, line, (size_t)len);
}

static int write_point_comment(epsnet_writer *w, const char *name, const double xyz[3])
{
    char c[3][32];
    for (int k = 0; k < 3; k++)
        en_format_coord(c[k], xyz[k], w->coord_type);
    return en_writer_printf(w, "# %s %s %s %s\n", name, c[0], c[1], c[2]);
}

static int sma_open_writer(epsnet_writer *w)
{
    sma_writer *st = en_calloc(1, sizeof *st);
    if (!st)
        return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory");
    w->state = st;
    st->patchable = en_sink_can_patch(w->sink);
    int known_v = w->info.nverts != EPSNET_COUNT_UNKNOWN;
    int known_f = w->info.nfaces != EPSNET_COUNT_UNKNOWN;
    int rc = 0;
    if (st->patchable || known_v)
        rc = write_count_comment(w, "nverts", known_v ? w->info.nverts : 0, &st->nverts_field,
                                 &st->wrote_nverts);
    if (rc == 0 && (st->patchable || known_f))
        rc = write_count_comment(w, "nfaces", known_f ? w->info.nfaces : 0, &st->nfaces_field,
                                 &st->wrote_nfaces);
    if (rc == 0 && w->info.has_bbox) {
        rc = write_point_comment(w, "bb_min", w->info.bbox_min);
        if (rc == 0)
            rc = write_point_comment(w, "bb_max", w->info.bbox_max);
    }
    return rc;
}

static int flush_pending(epsnet_writer *w, sma_writer *st)
{
    sma_pending *t = &st->tri;
    if (!t->active)
        return 0;
    t->active = 0;
    long long idx[3];
    for (int k = 0; k < 3; k++)
        idx[k] = t->negative[k] ? (long long)t->v[k] - (long long)t->nverts_then
                                : (long long)t->v[k] + 1;
    return en_writer_printf(w, "f %lld %lld %lld\n", idx[0], idx[1], idx[2]);
}

/* Fold a FINALIZE into the held triangle when the reader will give it back
 * in the same place: right after the triangle, in corner order. */
static int absorb_finalize(sma_pending *t, uint64_t v)
{
    if (!t->active)
        return 0;
    int pos = -1;
    for (int k = 2; k >= 0; k--)
        if (t->v[k] == v)
            pos = k;
    if (pos < 0 || pos <= t->last_absorbed || t->negative[pos])
        return 0;
    for (int k = pos; k < 3; k++)
        if (t->v[k] == v)
            t->negative[k] = 1;
    t->last_absorbed = pos;
    return 1;
}

static int sma_put(epsnet_writer *w, const epsnet_record *rec)
{
    sma_writer *st = w->state;
    if (rec->kind == EPSNET_REC_FINALIZE && absorb_finalize(&st->tri, rec->v[0]))
        return 0;
    int rc = flush_pending(w, st);
    if (rc)
        return rc;
    switch (rec->kind) {
    case EPSNET_REC_VERTEX: {
        if ((rc = check_coord_range(w, rec->xyz, st->nverts + 1)))
            return rc;
        char c[3][32];
        for (int k = 0; k < 3; k++)
            en_format_coord(c[k], rec->xyz[k], w->coord_type);
        st->nverts++;
        return en_writer_printf(w, "v %s %s %s\n", c[0], c[1], c[2]);
    }
    case EPSNET_REC_TRIANGLE:
        st->tri = (sma_pending){ .active = 1, .v = { rec->v[0], rec->v[1], rec->v[2] },
                                 .nverts_then = st->nverts, .last_absorbed = -1 };
        st->ntris++;
        return 0;
    case EPSNET_REC_FINALIZE:
        return en_writer_printf(w, "x %llu\n", (unsigned long long)rec->v[0] + 1);
    }
    return 0;
}

static int finish_count(epsnet_writer *w, const sma_writer *st, int wrote, uint64_t field,
                        uint64_t announced, uint64_t actual, const char *what)
{
    if (!wrote || announced == actual)
        return 0;
    if (st->patchable) {
        char text[SMA_COUNT_WIDTH + 1];
        snprintf(text, sizeof text, "%*llu", SMA_COUNT_WIDTH, (unsigned long long)actual);
        return en_sink_patch(w->sink, field, text, SMA_COUNT_WIDTH, &w->err);
    }
    return en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "%llu %s were announced but %llu written", (unsigned long long)announced, what,
                        (unsigned long long)actual);
}

static int sma_finish(epsnet_writer *w)
{
    sma_writer *st = w->state;
    int rc = flush_pending(w, st);
    uint64_t announced_v = w->info.nverts != EPSNET_COUNT_UNKNOWN ? w->info.nverts : 0;
    uint64_t announced_f = w->info.nfaces != EPSNET_COUNT_UNKNOWN ? w->info.nfaces : 0;
    if (rc == 0)
        rc = finish_count(w, st, st->wrote_nverts, st->nverts_field, announced_v, st->nverts, "vertices");
    if (rc == 0)
        rc = finish_count(w, st, st->wrote_nfaces, st->nfaces_field, announced_f, st->ntris, "triangles");
    return rc;
}

static void sma_close_writer(epsnet_writer *w)
{
    en_free(w->state);
    w->state = NULL;
}

const en_format en_format_sma = {
    .name = "sma",
    .extensions = "sma",
    .probe = sma_probe,
    .open_reader = sma_open_reader,
    .fill = sma_fill,
    .open_writer = sma_open_writer,
    .put = sma_put,
    .finish = sma_finish,
    .close_writer = sma_close_writer,
};
