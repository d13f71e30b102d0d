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
 * Reader, vt and vn: a pre-scan (scan_corners) finds the vt and vn each
 * position gets from the faces; when no position gets two different ones,
 * they are carried as the vertex attributes texture_u, texture_v and nx,
 * ny, nz (float32); otherwise (per-corner seams) they are named as dropped.
 *
 * Writer: `v` lines in the shortest exact text for the writer's coordinate
 * type (with `r g b` when the stream has float32 red, green and blue, in
 * the shortest text that reads back to the same bits), a `vt` and a `vn`
 * line after each `v` when the stream has float32 texture coordinates
 * (texture_u/texture_v, u/v or s/t) or normals (nx/ny/nz), and `f a b c`
 * (`f a/a/a ...` with them) lines with 1-based absolute indices, in stream order
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
    /* vt / vn per position, from the pre-scan (scan_corners): carried when
     * every position has at most one of each (epsnet.h §2) */
    int has_vt, has_vn;
    float *vt, *vn;                  /* 2 and 3 floats per vt / vn statement */
    uint32_t *vt_of, *vn_of;         /* per position: 1 + index, 0 none */
    uint64_t npos;                   /* positions the pre-scan saw */
    uint64_t no_vt, no_vn;           /* positions used by faces without one */
} obj_reader;

#define OBJ_SEVERAL UINT32_MAX       /* a position with several different vt (vn) */

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
    }
    if (!st->colours && n > 3)
        en_reader_drop(r, n == 4 ? "vertex w" : "vertex colour", 1, 1);
    if (!st->colours && !st->has_vt && !st->has_vn)
        return en_reader_push_vertex(r, val[0], val[1], val[2]);
    /* the attribute bytes in the order obj_open_reader declared them */
    uint8_t attr[12 + 8 + 12];
    size_t at = 0;
    if (st->colours) {
        memcpy(attr, rgb, 12);
        at = 12;
    }
    uint64_t pos = r->nverts;
    if (st->has_vt) {
        uint32_t k = pos < st->npos ? st->vt_of[pos] : 0;
        float uv[2] = { 0, 0 };
        if (k)
            memcpy(uv, st->vt + 2 * (size_t)(k - 1), sizeof uv);
        memcpy(attr + at, uv, sizeof uv);
        at += sizeof uv;
    }
    if (st->has_vn) {
        uint32_t k = pos < st->npos ? st->vn_of[pos] : 0;
        float nrm[3] = { 0, 0, 0 };
        if (k)
            memcpy(nrm, st->vn + 3 * (size_t)(k - 1), sizeof nrm);
        memcpy(attr + at, nrm, sizeof nrm);
    }
    return en_reader_push_vertex_attr(r, val[0], val[1], val[2], attr);
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
    obj_reader *st = r->state;
    char *p = en_text_skip_blanks(stmt);
    if (p[0] == 'v' && en_text_ends_token(p[1]))
        return parse_vertex(r, st, p + 1);
    /* carried per vertex: the pre-scan took them */
    if (p[0] == 'v' && ((p[1] == 't' && st->has_vt) || (p[1] == 'n' && st->has_vn)) && en_text_ends_token(p[2]))
        return 0;
    if (p[0] == 'f' && en_text_ends_token(p[1]))
        return parse_face(r, p + 1);
    if (p[0] != '\0' && p[0] != '#')
        drop_statement(r, p);
    return 0;
}

/* One vt/vn index of a corner, resolved as OBJ does (1-based, or negative
 * from the newest of seen); @return 0 with *out 0-based, -1 when invalid. */
static int scan_ref(int64_t k, uint64_t seen, uint64_t *out)
{
    if (k > 0 && (uint64_t)k <= seen) {
        *out = (uint64_t)k - 1;
        return 0;
    }
    if (k < 0 && (uint64_t)(-(k + 1)) < seen) {
        *out = seen - (uint64_t)(-(k + 1)) - 1;
        return 0;
    }
    return -1;
}

/* Note a position's vt (vn) index: a second, different one makes it
 * OBJ_SEVERAL. @return 1 when it became several. */
static int note_ref(uint32_t *of, uint64_t pos, uint64_t idx)
{
    if (of[pos] == OBJ_SEVERAL)
        return 0;
    if (of[pos] == 0) {
        of[pos] = (uint32_t)idx + 1;
        return 0;
    }
    if (of[pos] != (uint32_t)idx + 1) {
        of[pos] = OBJ_SEVERAL;
        return 1;
    }
    return 0;
}

static int grow_u32(uint32_t **p, uint64_t *cap, uint64_t need)
{
    if (need <= *cap)
        return 0;
    uint64_t n = *cap ? *cap * 2 : 4096;
    while (n < need)
        n *= 2;
    uint32_t *q = en_realloc(*p, (size_t)n * sizeof *q);
    if (!q)
        return -1;
    memset(q + *cap, 0, (size_t)(n - *cap) * sizeof *q);
    *p = q;
    *cap = n;
    return 0;
}

static int grow_f32(float **p, uint64_t *cap, uint64_t need)
{
    if (need <= *cap)
        return 0;
    uint64_t n = *cap ? *cap * 2 : 4096;
    while (n < need)
        n *= 2;
    float *q = en_realloc(*p, (size_t)n * sizeof *q);
    if (!q)
        return -1;
    *p = q;
    *cap = n;
    return 0;
}

/*
 * Pre-scan of a file with vt or vn statements (OBJ has no header): which
 * vt and vn each position gets from the faces' corners, so that the
 * vertices can carry them when they are read (docs/architecture.md §6).
 * It reads the file a second time through its own source, so it needs a
 * path (not "-"), and holds 8 bytes per vt, 12 per vn and 8 per position.
 * A position given several different vt (or vn) by different corners is a
 * seam: then vt (vn) are not carried at all and are named as dropped with
 * the count of such positions (per-corner attributes are a later step).
 * @return 0 (also when nothing is carried), or a negative code with r->err
 * filled (out of memory; errors of the file itself are left to the main
 * pass, which reports them with their line).
 */
static int scan_corners(epsnet_reader *r, obj_reader *st)
{
    en_source *src = NULL;
    epsnet_error e;
    if (strcmp(r->path, "-") == 0 || en_source_open(&src, r->path, &e))
        return 0;
    uint64_t nv = 0, nvt = 0, nvn = 0, cap_pos = 0, cap_vt = 0, cap_vn = 0, several_vt = 0, several_vn = 0;
    int rc = 0, usable = 1;
    char *line;
    size_t len;
    while (usable && (rc = en_source_line(src, &line, &len, OBJ_MAX_LINE, &e)) == 1) {
        if (len && line[len - 1] == '\\') {
            usable = 0;          /* continued statements: keep it simple, carry nothing */
            break;
        }
        char *p = en_text_skip_blanks(line);
        if (p[0] == 'v' && en_text_ends_token(p[1])) {
            nv++;
        } else if (p[0] == 'v' && (p[1] == 't' || p[1] == 'n') && en_text_ends_token(p[2])) {
            int is_vt = p[1] == 't', want = is_vt ? 2 : 3;
            float f[3] = { 0, 0, 0 };
            char *q = p + 2;
            for (int k = 0; k < want; k++) {
                q = en_text_skip_blanks(q);
                char *end;
                float x = strtof(q, &end);
                if (end == q || !en_text_ends_token(*end))
                    break;
                f[k] = x;
                q = end;
            }
            uint64_t *n = is_vt ? &nvt : &nvn;
            if (is_vt ? grow_f32(&st->vt, &cap_vt, 2 * (nvt + 1)) : grow_f32(&st->vn, &cap_vn, 3 * (nvn + 1))) {
                rc = EPSNET_ENOMEM;
                break;
            }
            memcpy((is_vt ? st->vt : st->vn) + (size_t)want * *n, f, (size_t)want * sizeof *f);
            (*n)++;
        } else if (p[0] == 'f' && en_text_ends_token(p[1])) {
            if (grow_u32(&st->vt_of, &cap_pos, nv)) {
                rc = EPSNET_ENOMEM;
                break;
            }
            /* vn_of follows vt_of's capacity */
            uint32_t *vn_of = en_realloc(st->vn_of, (size_t)(cap_pos ? cap_pos : 1) * sizeof *vn_of);
            if (!vn_of) {
                rc = EPSNET_ENOMEM;
                break;
            }
            if (st->npos < cap_pos)
                memset(vn_of + st->npos, 0, (size_t)(cap_pos - st->npos) * sizeof *vn_of);
            st->vn_of = vn_of;
            st->npos = cap_pos;
            char *q = p + 1;
            for (;;) {
                q = en_text_skip_blanks(q);
                if (*q == '\0' || *q == '#')
                    break;
                int64_t a, b = 0, c = 0;
                if (en_text_scan_int64(&q, &a))
                    break;
                if (*q == '/') {
                    q++;
                    if (*q != '/' && en_text_scan_int64(&q, &b))
                        break;
                    if (*q == '/') {
                        q++;
                        if (en_text_scan_int64(&q, &c))
                            break;
                    }
                }
                uint64_t pos, idx;
                if (scan_ref(a, nv, &pos))
                    break;
                if (b && scan_ref(b, nvt, &idx) == 0)
                    several_vt += (uint64_t)note_ref(st->vt_of, pos, idx);
                if (c && scan_ref(c, nvn, &idx) == 0)
                    several_vn += (uint64_t)note_ref(st->vn_of, pos, idx);
                if (!en_text_ends_token(*q))
                    break;
            }
        }
    }
    en_source_close(&src);
    if (rc == EPSNET_ENOMEM)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    if (!usable || rc < 0)
        return 0;                /* the main pass reports what is wrong, with its line */
    char what[EN_DROP_NAME];
    st->has_vt = nvt > 0 && several_vt == 0;
    st->has_vn = nvn > 0 && several_vn == 0;
    if (nvt && several_vt) {
        snprintf(what, sizeof what, "per-corner vt (positions with several: %llu)", (unsigned long long)several_vt);
        en_reader_drop(r, what, 0, 0);
    }
    if (nvn && several_vn) {
        snprintf(what, sizeof what, "per-corner vn (positions with several: %llu)", (unsigned long long)several_vn);
        en_reader_drop(r, what, 0, 0);
    }
    for (uint64_t i = 0; i < st->npos && i < nv; i++) {
        st->no_vt += st->has_vt && st->vt_of[i] == 0;
        st->no_vn += st->has_vn && st->vn_of[i] == 0;
    }
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
    int rc = scan_corners(r, st);
    if (rc)
        return rc;
    static const char *names[] = { "red", "green", "blue", "texture_u", "texture_v", "nx", "ny", "nz" };
    for (int k = 0; k < 8; k++) {
        if ((k < 3 && !st->colours) || ((k == 3 || k == 4) && !st->has_vt) || (k > 4 && !st->has_vn))
            continue;
        if (en_reader_add_attr(r, names[k], EPSNET_ATTR_FLOAT32) < 0)
            return r->err.code;
    }
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
        en_free(st->vt);
        en_free(st->vn);
        en_free(st->vt_of);
        en_free(st->vn_of);
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

/* What OBJ holds (epsnet.h epsnet_writer_dropped()): groups of float32
 * attributes, each group only whole. */
static const char *const obj_groups[][4] = {
    { "red", "green", "blue", NULL },            /* v x y z r g b */
    { "texture_u", "texture_v", NULL, NULL },    /* vt */
    { "u", "v", NULL, NULL },
    { "s", "t", NULL, NULL },
    { "nx", "ny", "nz", NULL },                  /* vn */
};
#define OBJ_GROUPS 5

/* Attribute index of member k of group g in l, or -1 when the group is not
 * whole and float32 in l. */
static int obj_group_at(const epsnet_attr_layout *l, int g, int k)
{
    for (int m = 0; m < 4 && obj_groups[g][m]; m++) {
        int at = epsnet_attr_layout_find(l, obj_groups[g][m]);
        if (at < 0 || l->attr[at].type != EPSNET_ATTR_FLOAT32)
            return -1;
    }
    return epsnet_attr_layout_find(l, obj_groups[g][k]);
}

/* Which texture group the stream has (the first whole one), or -1. */
static int obj_uv_group(const epsnet_attr_layout *l)
{
    for (int g = 1; g <= 3; g++)
        if (obj_group_at(l, g, 0) >= 0)
            return g;
    return -1;
}

static int obj_holds_attr(const epsnet_attr_layout *l, uint32_t i)
{
    int uv = obj_uv_group(l);
    for (int g = 0; g < OBJ_GROUPS; g++) {
        if (g >= 1 && g <= 3 && g != uv)
            continue;
        for (int k = 0; k < 4 && obj_groups[g][k]; k++)
            if (obj_group_at(l, g, k) == (int)i)
                return 1;
    }
    return 0;
}

/* The group's floats of a vertex as " a b [c]" into line. */
static size_t obj_group_text(char *line, const epsnet_attr_layout *l, int g, const uint8_t *attr)
{
    size_t n = 0;
    for (int k = 0; k < 4 && obj_groups[g][k]; k++) {
        float c;
        memcpy(&c, attr + l->attr[obj_group_at(l, g, k)].offset, 4);
        line[n++] = ' ';
        n += (size_t)en_format_coord(line + n, c, EPSNET_COORD_FLOAT32);
    }
    return n;
}

static int obj_put(epsnet_writer *w, const epsnet_record *rec)
{
    char line[12 * 33 + 64];
    size_t n = 0;
    const epsnet_attr_layout *l = &w->attrs;
    int uv = l->count ? obj_uv_group(l) : -1, nrm = l->count && obj_group_at(l, 4, 0) >= 0;
    if (rec->kind == EPSNET_REC_VERTEX) {
        int rc = check_coord_range(w, rec->xyz, w->nverts);
        if (rc)
            return rc;
        line[n++] = 'v';
        for (int k = 0; k < 3; k++) {
            line[n++] = ' ';
            n += (size_t)en_format_coord(line + n, rec->xyz[k], w->coord_type);
        }
        if (l->count && obj_group_at(l, 0, 0) >= 0)
            n += obj_group_text(line + n, l, 0, rec->attr);
        /* one vt and one vn per vertex, numbered as the vertex is */
        if (uv >= 0) {
            memcpy(line + n, "\nvt", 3);
            n += 3;
            n += obj_group_text(line + n, l, uv, rec->attr);
        }
        if (nrm) {
            memcpy(line + n, "\nvn", 3);
            n += 3;
            n += obj_group_text(line + n, l, 4, rec->attr);
        }
    } else if (rec->kind == EPSNET_REC_TRIANGLE) {
        line[n++] = 'f';
        for (int k = 0; k < 3; k++) {
            line[n++] = ' ';
            size_t at = n;
            n += format_u64(line + n, rec->v[k] + 1);
            size_t idx = n - at;
            if (uv >= 0 || nrm) {
                line[n++] = '/';
                if (uv >= 0) {
                    memcpy(line + n, line + at, idx);
                    n += idx;
                }
                if (nrm) {
                    line[n++] = '/';
                    memcpy(line + n, line + at, idx);
                    n += idx;
                }
            }
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
