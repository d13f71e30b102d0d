/*
 * Wavefront OBJ (docs/architecture.md §13, ordinary formats).
 *
 * Reader: `v x y z [w | r g b [a]]`, `vt`, `vn` and `f` with corners `a`,
 * `a/b`, `a/b/c` or `a//c`; indices are 1-based, or negative and relative
 * to the newest v, vt or vn (-1 = newest). Polygons are fan-triangulated
 * around their first corner. Faces may come between vertices, as OBJ
 * allows. Vertex colours become the attributes red, green, blue (float32,
 * epsnet.h §2) when the first `v` line of the file's first 64 KiB has them
 * (OBJ has no header: the attributes must be known before the first
 * record); a later `v` without colours then gets 0 0 0 and is counted as
 * dropped ("vertex without colour").
 *
 * Texture coordinates and normals are given per face corner. When the
 * faces name them (decided by reading ahead to the first `f`, see
 * prescan_corners()), a record is one distinct (position, vt, vn) with the
 * attributes texture_u, texture_v and/or nx, ny, nz: a position that faces
 * use with different values (a seam) becomes several records at the same
 * coordinates, which cuts the mesh open along the seam
 * (docs/architecture.md §13, docs/method.md §6). The v, vt and vn tables
 * are then held to the end of the file, within settings.mem_limit, and a
 * record is pushed when a face first names it.
 *
 * Face labels: when a `usemtl` comes before the first face, each face's
 * material travels as the attribute material_index (uint16) of its corners,
 * keyed with vt and vn, so a position whose faces have two materials is two
 * records (a seam); the names, in order of first use, and the first
 * `mtllib` are the reader's epsnet_face_names (info.materials). A `g`
 * before the first face does the same for groups (group_index,
 * info.groups).
 *
 * Every other statement (vp, o, s, l, p, unknown ones, usemtl, mtllib and g
 * in a file whose first face comes before any of them, and vt or vn that no
 * face names) is skipped and named by
 * epsnet_reader_dropped(), as are w, alpha, a vt's w, and colours in a file
 * whose first `v` has none; the numbers of a `v`, `vt`, `vn` or `f`
 * statement must all parse. A trailing backslash continues a statement on
 * the next line.
 *
 * note: OBJ has no header, so info.coord_type is decided by looking ahead at
 * the `v` lines, by the rule of src/io/text_scan.h.
 *
 * Writer: `v` lines in the shortest exact text for the writer's coordinate
 * type (with `r g b` when the stream has float32 red, green and blue, in
 * the shortest text that reads back to the same bits) and `f a b c` lines
 * with 1-based absolute indices, in stream order (OBJ allows interleaving,
 * so nothing is buffered). A stream with texture coordinates or normals
 * also gets `vt` and `vn` lines and `f a/b/c` corners, and its records at
 * one position are welded into one `v` line (put_corner_vertex()). A
 * stream with material_index and info.materials gets `mtllib` and a
 * `usemtl` before each face whose material differs from the face before,
 * and `g` likewise with group_index and info.groups (put_labels(); faces
 * come in stream order, so a run of one label in the input may be written
 * as several).
 * FINALIZE records have no OBJ form and are dropped.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "common/hash64.h"
#include "common/key_table.h"
#include "common/u64map.h"
#include "io/format.h"
#include "io/text_scan.h"

/* note: en_source_line() caps lines at half its 2 MiB window. */
#define OBJ_MAX_LINE ((size_t)1 << 20)
/* Records queued per fill(): amortises the front end's call overhead. */
#define OBJ_FILL_BATCH 4096
/* Beyond x y z: w, or r g b, or r g b a. */
#define OBJ_MAX_VERTEX_VALUES 7

/* Bytes a face corner adds to its position: texture_u, texture_v and nx,
 * ny, nz, all float32, then material_index and group_index, uint16. */
#define OBJ_KEY_MAX 24
/* Indices of the corner tables are uint32 (they are held in memory). */
#define OBJ_TABLE_MAX ((size_t)UINT32_MAX - 1)

/* A `v` statement of a file whose records are corners. */
typedef struct obj_position {
    double xyz[3];
    float rgb[3];
    uint32_t first;                  /* newest record at this position + 1; 0: none yet */
} obj_position;

/* The face labels (epsnet.h epsnet_face_names), [0] materials and [1]
 * groups, for the reader and the writer alike: the statement each is (its
 * attribute: en_face_label_attr). */
static const char *const label_keyword[2] = { "usemtl", "g" };

/* A face label of the reader (label_keyword[k]).
 * file_on when its statement comes before the first face, on while its
 * attribute is kept; the current one (UINT16_MAX: none yet), the names,
 * a name's hash -> its first index, and (materials) the `mtllib` text. */
typedef struct obj_label {
    int file_on, on;
    uint16_t cur;
    epsnet_face_names tab;
    char **names;
    size_t names_cap;
    en_u64map by_name;
    char *library;
} obj_label;

/* A vertex record of such a file: one distinct (position, vt, vn). */
typedef struct obj_corner {
    uint32_t next;                   /* older record at the same position + 1; 0: none */
    uint8_t key[OBJ_KEY_MAX];        /* its texture_u texture_v nx ny nz bytes */
} obj_corner;

typedef struct obj_reader {
    char *joined;                    /* backslash-continued statement */
    size_t joined_cap;
    int colours;                     /* the records carry red, green, blue */

    /* Corners (docs/architecture.md §13): the records carry texture_u,
     * texture_v (uv) and/or nx, ny, nz (normals), one record per distinct
     * (position, vt values, vn values); key_size is 0 in a file without.
     * file_uv, file_normals: the attributes declared; uv, normals: those
     * whose values are read (see follow_kept_attrs()); mute_vt, mute_vn:
     * vt or vn statements skipped without a word, as their attributes are
     * named already. */
    int file_uv, file_normals;
    int uv, normals;
    int mute_vt, mute_vn;
    /* label[0]: materials, label[1]: groups; their key bytes follow the
     * vt and vn bytes, in that order */
    obj_label label[2];
    int started;
    size_t key_size;
    obj_position *pos;
    size_t npos, pos_cap;
    float *vt;                       /* u v of each vt */
    size_t nvt, vt_cap;
    float *vn;                       /* x y z of each vn */
    size_t nvn, vn_cap;
    obj_corner *rec;
    size_t nrec, rec_cap;
    size_t bytes;                    /* of the four tables, held to settings.mem_limit */
    int at_end;                      /* the statements are all read */
    size_t tail;                     /* next position to check for a record at the end */
    uint64_t unknown_line;           /* line of the first statement that is not OBJ's (0: none) */
    char unknown[33];                /* ... its keyword */
    uint64_t first_line;             /* line of the first statement of any kind (0: none yet) */
    char first[33];                  /* ... its keyword */
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

/* Grow one of the corner tables to hold need elements, keeping all four
 * within the reader's memory budget (they live until the end of the file). */
static int table_grow(epsnet_reader *r, obj_reader *st, void **buf, size_t *cap, size_t need, size_t elem)
{
    if (need > OBJ_TABLE_MAX)
        return en_reader_fail(r, EPSNET_ELIMIT, "more than %zu v, vt, vn or corner vertices", OBJ_TABLE_MAX);
    size_t bytes = 0;
    int rc = en_reader_grow_held(r, &st->bytes, buf, cap, need, elem, &bytes);
    if (rc == EPSNET_ELIMIT)
        return en_reader_fail(r, EPSNET_ELIMIT,
                              "an OBJ with vt/vn is held in memory until its faces are read: %zu v, %zu vt, "
                              "%zu vn and %zu corner vertices need %zu bytes, over the memory budget of %llu bytes",
                              st->npos, st->nvt, st->nvn, st->nrec, bytes,
                              (unsigned long long)r->settings.mem_limit);
    return rc;
}

/* A position of a file whose records are corners: kept until faces name it. */
static int store_position(epsnet_reader *r, obj_reader *st, const double xyz[3], const float rgb[3])
{
    if (!isfinite(xyz[0]) || !isfinite(xyz[1]) || !isfinite(xyz[2]))
        return en_reader_fail(r, EPSNET_EFORMAT, "vertex %zu has a non-finite coordinate (%g %g %g)",
                              st->npos + 1, xyz[0], xyz[1], xyz[2]);
    int rc = table_grow(r, st, (void **)&st->pos, &st->pos_cap, st->npos + 1, sizeof *st->pos);
    if (rc)
        return rc;
    obj_position *p = &st->pos[st->npos++];
    memcpy(p->xyz, xyz, sizeof p->xyz);
    memcpy(p->rgb, rgb, sizeof p->rgb);
    p->first = 0;
    return 0;
}

static int parse_vertex(epsnet_reader *r, obj_reader *st, char *p)
{
    double val[OBJ_MAX_VERTEX_VALUES];
    float rgb[3] = { 0, 0, 0 };
    unsigned long long label = (unsigned long long)(st->key_size ? st->npos : r->nverts) + 1;
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
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu: '%.*s' is not a number", label,
                                  en_text_quoted_len(p), p);
        if (n == OBJ_MAX_VERTEX_VALUES)
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu has more than %d values", label,
                                  OBJ_MAX_VERTEX_VALUES);
        val[n++] = d;
    }
    if (n < 3)
        return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu has %d coordinates, expected 3", label, n);
    if (st->colours) {
        if (n == 4 || n == 5)
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu has %d values, expected 3 or 6 (x y z r g b)",
                                  label, n);
        if (n == 3)
            en_reader_drop(r, "vertex without colour", 1, 1);
        if (n == 7)
            en_reader_drop(r, "vertex colour alpha", 1, 1);
    } else if (n > 3) {
        en_reader_drop(r, n == 4 ? "vertex w" : "vertex colour", 1, 1);
    }
    if (st->key_size)
        return store_position(r, st, val, rgb);
    if (st->colours) {
        uint8_t attr[12];
        memcpy(attr, rgb, sizeof attr);
        return en_reader_push_vertex_attr(r, val[0], val[1], val[2], attr);
    }
    return en_reader_push_vertex(r, val[0], val[1], val[2]);
}

/* Up to max float32 values read as floats (strtof: the bits of the text, as
 * for colours). @return how many, or -1 with *pp at a token that is not a
 * number, or max + 1 when there are more. */
static int scan_floats(char **pp, float *out, int max)
{
    int n = 0;
    char *p = *pp;
    for (;;) {
        p = en_text_skip_blanks(p);
        if (*p == '\0' || *p == '#')
            break;
        char *e;
        float f = strtof(p, &e);
        if (e == p || !en_text_ends_token(*e)) {
            *pp = p;
            return -1;
        }
        if (n == max)
            return max + 1;
        out[n++] = f;
        p = e;
    }
    *pp = p;
    return n;
}

/* `vt u [v [w]]`: v is 0 when absent (as OBJ defines it); w, the depth of
 * a 3D texture, has no attribute and is named as dropped. */
static int parse_texcoord(epsnet_reader *r, obj_reader *st, char *p)
{
    float uvw[3] = { 0, 0, 0 };
    int n = scan_floats(&p, uvw, 3);
    if (n < 0)
        return en_reader_fail(r, EPSNET_EFORMAT, "vt %zu: '%.*s' is not a number", st->nvt + 1,
                              en_text_quoted_len(p), p);
    if (n == 0 || n > 3)
        return en_reader_fail(r, EPSNET_EFORMAT, "vt %zu has %s values, expected 1 to 3 (u [v [w]])",
                              st->nvt + 1, n ? "more than 3" : "no");
    if (n == 3)
        en_reader_drop(r, "vt w", 1, 1);
    int rc = table_grow(r, st, (void **)&st->vt, &st->vt_cap, st->nvt + 1, 2 * sizeof *st->vt);
    if (rc)
        return rc;
    memcpy(st->vt + 2 * st->nvt++, uvw, 2 * sizeof *uvw);
    return 0;
}

static int parse_normal(epsnet_reader *r, obj_reader *st, char *p)
{
    float xyz[3];
    int n = scan_floats(&p, xyz, 3);
    if (n < 0)
        return en_reader_fail(r, EPSNET_EFORMAT, "vn %zu: '%.*s' is not a number", st->nvn + 1,
                              en_text_quoted_len(p), p);
    if (n != 3)
        return en_reader_fail(r, EPSNET_EFORMAT, "vn %zu has %s values, expected 3 (x y z)", st->nvn + 1,
                              n > 3 ? "more than 3" : n == 2 ? "2" : n == 1 ? "1" : "no");
    int rc = table_grow(r, st, (void **)&st->vn, &st->vn_cap, st->nvn + 1, 3 * sizeof *st->vn);
    if (rc)
        return rc;
    memcpy(st->vn + 3 * st->nvn++, xyz, sizeof xyz);
    return 0;
}

/* What the three index spaces of a face corner are called in messages. */
static const char *const index_one[3] = { "vertex", "vt", "vn" };
static const char *const index_many[3] = { "vertices", "vt", "vn" };

/* OBJ index k of space s (0 v, 1 vt, 2 vn) -> 0-based, with count items so
 * far; check_upper: say so when k is past them (for positions of a plain
 * file the front end checks that). */
static int resolve_index(epsnet_reader *r, int s, int64_t k, uint64_t count, int check_upper, uint64_t *out)
{
    if (k > 0) {
        *out = (uint64_t)k - 1;
        if (check_upper && *out >= count)
            return en_reader_fail(r, EPSNET_EFORMAT, "face %llu: %s index %lld, but only %llu %s precede it",
                                  (unsigned long long)r->ntris + 1, index_one[s], (long long)k,
                                  (unsigned long long)count, index_many[s]);
        return 0;
    }
    if (k == 0)
        return en_reader_fail(r, EPSNET_EFORMAT, "face %llu: %s index 0 (OBJ indices start at 1)",
                              (unsigned long long)r->ntris + 1, index_one[s]);
    uint64_t back = (uint64_t)(-(k + 1)) + 1;
    if (back > count)
        return en_reader_fail(r, EPSNET_EFORMAT,
                              "face %llu: relative %sindex %lld reaches before the first %s "
                              "(%llu %s so far)",
                              (unsigned long long)r->ntris + 1, s ? (s == 1 ? "vt " : "vn ") : "", (long long)k,
                              index_one[s], (unsigned long long)count, index_many[s]);
    *out = count - back;
    return 0;
}

/* One corner `a`, `a/b`, `a/b/c` or `a//c`: idx[0..2] and has[1], has[2]
 * (whether b and c are given). All given indices must be integers. */
static int scan_corner(char **pp, int64_t idx[3], int has[3])
{
    char *p = *pp;
    has[0] = 1;
    has[1] = has[2] = 0;
    if (en_text_scan_int64(&p, &idx[0]))
        return -1;
    if (*p == '/') {
        p++;
        if (*p != '/') {
            if (en_text_scan_int64(&p, &idx[1]))
                return -1;
            has[1] = 1;
        }
        if (*p == '/') {
            p++;
            if (en_text_scan_int64(&p, &idx[2]))
                return -1;
            has[2] = 1;
        }
    }
    if (!en_text_ends_token(*p))
        return -1;
    *pp = p;
    return 0;
}

/* The record of position v with the corner bytes key: an earlier one with
 * the same bytes (so a position keeps one record wherever its vt and vn
 * agree, bit for bit), or a new record pushed now. */
static int corner_record(epsnet_reader *r, obj_reader *st, uint64_t v, const uint8_t *key, uint64_t *out)
{
    for (uint32_t k = st->pos[v].first; k; k = st->rec[k - 1].next)
        if (memcmp(st->rec[k - 1].key, key, st->key_size) == 0) {
            *out = k - 1;
            return 0;
        }
    int rc = table_grow(r, st, (void **)&st->rec, &st->rec_cap, st->nrec + 1, sizeof *st->rec);
    if (rc)
        return rc;
    obj_position *p = &st->pos[v];
    uint8_t attr[12 + OBJ_KEY_MAX];
    size_t at = 0;
    if (st->colours) {
        memcpy(attr, p->rgb, 12);
        at = 12;
    }
    memcpy(attr + at, key, st->key_size);
    if ((rc = en_reader_push_vertex_attr(r, p->xyz[0], p->xyz[1], p->xyz[2], attr)))
        return rc;
    obj_corner *c = &st->rec[st->nrec];
    memset(c->key, 0, sizeof c->key);
    memcpy(c->key, key, st->key_size);
    c->next = p->first;
    p->first = (uint32_t)++st->nrec;
    *out = st->nrec - 1;
    return 0;
}

static int label_is(const obj_label *l, uint32_t i, const char *name, size_t n)
{
    return i < l->tab.count && strlen(l->names[i]) == n && memcmp(l->names[i], name, n) == 0;
}

/* `usemtl name` or `g name`: the label of the faces that follow, its index
 * the order of first use. Names are found by a hash of their bytes, so a
 * file that switches often among many labels is not quadratic; a hash
 * shared by two names falls back to the list. */
static int use_label(epsnet_reader *r, obj_reader *st, int k, const char *name, size_t n)
{
    obj_label *l = &st->label[k];
    uint64_t h = en_hash_bytes(name, n);
    h = h == UINT64_MAX ? 0 : h; /* the map's empty key */
    uint32_t at;
    if (en_u64map_get(&l->by_name, h, &at) && label_is(l, at, name, n)) {
        l->cur = (uint16_t)at;
        return 0;
    }
    for (uint32_t i = 0; i < l->tab.count; i++)
        if (label_is(l, i, name, n)) {
            l->cur = (uint16_t)i;
            return 0;
        }
    if (l->tab.count >= EPSNET_FACE_NAMES_MAX)
        return en_reader_fail(r, EPSNET_ELIMIT, "more than %d names of %s", EPSNET_FACE_NAMES_MAX,
                              label_keyword[k]);
    if (en_grow((void **)&l->names, &l->names_cap, l->tab.count + 1, sizeof *l->names))
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    char *copy = en_malloc(n + 1);
    if (!copy)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    memcpy(copy, name, n);
    copy[n] = '\0';
    l->names[l->tab.count] = copy;
    l->tab.names = (const char *const *)l->names;
    if (!en_u64map_get(&l->by_name, h, &at) && en_u64map_put(&l->by_name, h, l->tab.count))
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    l->cur = (uint16_t)l->tab.count++;
    return 0;
}

/* The record a corner names: in a plain file the position itself; in a file
 * whose records are corners, the record of (position, vt, vn). */
static int corner_vertex(epsnet_reader *r, obj_reader *st, const int64_t idx[3], const int has[3], uint64_t *v)
{
    if (!st->key_size)
        return resolve_index(r, 0, idx[0], r->nverts, 0, v);
    uint64_t at[3];
    int rc = resolve_index(r, 0, idx[0], st->npos, 1, &at[0]);
    uint8_t key[OBJ_KEY_MAX];
    memset(key, 0, sizeof key);
    size_t o = st->file_uv ? 8 : 0;
    if (!rc && st->uv) {
        if (!has[1])
            en_reader_drop(r, "face corner without vt", 1, 1);
        else if (!(rc = resolve_index(r, 1, idx[1], st->nvt, 1, &at[1])))
            memcpy(key, st->vt + 2 * at[1], 8);
    }
    if (!rc && st->normals) {
        if (!has[2])
            en_reader_drop(r, "face corner without vn", 1, 1);
        else if (!(rc = resolve_index(r, 2, idx[2], st->nvn, 1, &at[2])))
            memcpy(key + o, st->vn + 3 * at[2], 12);
    }
    size_t lo = 8 * (size_t)st->file_uv + 12 * (size_t)st->file_normals;
    for (int k = 0; k < 2 && !rc; k++) {
        obj_label *l = &st->label[k];
        if (!l->on)
            continue;
        if (l->cur == UINT16_MAX) /* a face before the first usemtl (g) */
            rc = use_label(r, st, k, "", 0);
        memcpy(key + lo, &l->cur, 2);
        lo += 2;
    }
    return rc ? rc : corner_record(r, st, at[0], key, v);
}

static int parse_face(epsnet_reader *r, obj_reader *st, char *p)
{
    uint64_t first = 0, prev = 0;
    int ncorners = 0;
    for (;;) {
        p = en_text_skip_blanks(p);
        if (*p == '\0')
            break;
        int64_t idx[3];
        int has[3];
        uint64_t v = 0;
        if (scan_corner(&p, idx, has))
            return en_reader_fail(r, EPSNET_EFORMAT, "face %llu: bad corner '%.*s'",
                                  (unsigned long long)r->ntris + 1, en_text_quoted_len(p), p);
        int rc = corner_vertex(r, st, idx, has, &v);
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

/* A statement's keyword, printable: bytes that are not printable ASCII
 * are shown as '?'. */
static void statement_keyword(const char *p, char kw[33])
{
    size_t n = 0;
    while (n < 32 && !en_text_ends_token(p[n])) {
        unsigned char c = (unsigned char)p[n];
        kw[n++] = c > 0x20 && c < 0x7f ? (char)c : '?';
    }
    kw[n] = '\0';
}

/* Is kw one of the statements of the OBJ format (its geometry, grouping,
 * display and free-form keywords), whether the records carry it or not? */
static int is_obj_keyword(const char *kw)
{
    static const char *const keywords[] = {
        "v", "vt", "vn", "vp", "f", "l", "p", "g", "o", "s", "mg", "mtllib", "usemtl", "usemap", "maplib",
        "cstype", "deg", "bmat", "step", "curv", "curv2", "surf", "parm", "trim", "hole", "scrv", "sp", "end",
        "con", "lod", "shadow_obj", "trace_obj", "ctech", "stech", "bevel", "c_interp", "d_interp", "call", "csh",
    };
    for (size_t i = 0; i < sizeof keywords / sizeof *keywords; i++)
        if (strcmp(kw, keywords[i]) == 0)
            return 1;
    return 0;
}

/* docs/architecture.md §5: a statement kind the records do not carry is
 * named, by its keyword, with how many there were. The first that is no
 * OBJ statement at all is kept, to say what the file is not. */
static void drop_statement(epsnet_reader *r, const char *p)
{
    char kw[33];
    statement_keyword(p, kw);
    en_reader_drop(r, kw, 1, 1);
    obj_reader *st = r->state;
    if (!st->unknown_line && !is_obj_keyword(kw)) {
        st->unknown_line = r->src->lineno;
        memcpy(st->unknown, kw, sizeof kw);
    }
}

static int parse_statement(epsnet_reader *r, char *stmt)
{
    obj_reader *st = r->state;
    char *p = en_text_skip_blanks(stmt);
    if (!st->first_line && p[0] != '\0' && p[0] != '#') {
        st->first_line = r->src->lineno;
        statement_keyword(p, st->first);
    }
    if (p[0] == 'v' && en_text_ends_token(p[1]))
        return parse_vertex(r, st, p + 1);
    if (p[0] == 'f' && en_text_ends_token(p[1]))
        return parse_face(r, st, p + 1);
    if (st->uv && p[0] == 'v' && p[1] == 't' && en_text_ends_token(p[2]))
        return parse_texcoord(r, st, p + 2);
    if (st->normals && p[0] == 'v' && p[1] == 'n' && en_text_ends_token(p[2]))
        return parse_normal(r, st, p + 2);
    if (p[0] == 'v' && ((st->mute_vt && p[1] == 't') || (st->mute_vn && p[1] == 'n')) && en_text_ends_token(p[2]))
        return 0;
    for (int k = 0; k < 2; k++) {
        obj_label *l = &st->label[k];
        size_t kw = strlen(label_keyword[k]), n;
        if (l->on && strncmp(p, label_keyword[k], kw) == 0 && en_text_ends_token(p[kw])) {
            const char *name = en_text_trim(p + kw, &n);
            return use_label(r, st, k, name, n);
        }
    }
    obj_label *mat = &st->label[0];
    if (mat->on && strncmp(p, "mtllib", 6) == 0 && en_text_ends_token(p[6]) && !mat->library) {
        size_t n;
        const char *lib = en_text_trim(p + 6, &n);
        if (!(mat->library = en_malloc(n + 1)))
            return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
        memcpy(mat->library, lib, n);
        mat->library[n] = '\0';
        mat->tab.library = mat->library;
        return 0;
    }
    if (p[0] != '\0' && p[0] != '#')
        drop_statement(r, p);
    return 0;
}

/* Prescan of one line: notes vt and vn statements until the first `f`,
 * then whether that face's first corner names a vt and a vn.
 * @return 1 at the first face (the scan ends), else 0. */
static int prescan_line(const char *p, const char *eol, int seen[4], int *uv, int *normals)
{
    while (p < eol && en_text_is_blank(*p))
        p++;
    if (eol - p >= 6 && memcmp(p, "usemtl", 6) == 0 && (eol - p == 6 || en_text_is_blank(p[6])))
        seen[2] = 1;
    if (eol - p >= 1 && p[0] == 'g' && (eol - p == 1 || en_text_is_blank(p[1])))
        seen[3] = 1;
    if (eol - p >= 2 && p[0] == 'v' && (p[1] == 't' || p[1] == 'n') && (eol - p == 2 || en_text_is_blank(p[2])))
        seen[p[1] == 'n'] = 1;
    if (eol - p < 2 || p[0] != 'f' || !en_text_is_blank(p[1]))
        return 0;
    p += 2;
    while (p < eol && en_text_is_blank(*p))
        p++;
    while (p < eol && (*p == '-' || *p == '+' || (*p >= '0' && *p <= '9')))
        p++;
    int has_vt = 0, has_vn = 0;
    if (p < eol && *p == '/') {
        p++;
        has_vt = p < eol && *p != '/' && !en_text_is_blank(*p);
        while (p < eol && *p != '/' && !en_text_is_blank(*p))
            p++;
        has_vn = p + 1 < eol && *p == '/' && !en_text_is_blank(p[1]);
    }
    *uv = seen[0] && has_vt;
    *normals = seen[1] && has_vn;
    return 1;
}

/*
 * Whether the records are corners (docs/architecture.md §13): OBJ gives vt
 * and vn only at the faces, after the positions, so the layout is decided
 * before the first record by reading ahead to the first `f`. texture_u and
 * texture_v are carried when vt statements come before it and its first
 * corner names one, nx ny nz likewise for vn, and material_index
 * (group_index) when a `usemtl` (`g`) comes before it. A regular file is read ahead
 * through a second source (the v lines before the first face are scanned,
 * not parsed); a pipe only in the window of src.
 */
static int prescan_corners(epsnet_reader *r, obj_reader *st)
{
    int seen[4] = { 0, 0, 0, 0 };
    int *uv = &st->uv, *normals = &st->normals;
    *uv = *normals = 0;
    if (r->src->file_size == 0) {
        size_t avail = en_source_fill(r->src, EN_TEXT_PEEK_BYTES);
        if (r->src->failed)
            return source_failed(r, en_source_error(r->src, &r->err));
        const char *p = (const char *)r->src->cur, *end = p + avail;
        while (p < end) {
            const char *eol = memchr(p, '\n', (size_t)(end - p));
            if (!eol || prescan_line(p, eol, seen, uv, normals))
                break;
            p = eol + 1;
        }
        st->label[0].file_on = seen[2];
        st->label[1].file_on = seen[3];
        return 0;
    }
    en_source *s = NULL;
    int rc = en_source_open(&s, r->path, &r->err);
    if (rc)
        return source_failed(r, rc);
    for (;;) {
        char *line;
        size_t len;
        rc = en_source_line(s, &line, &len, OBJ_MAX_LINE, &r->err);
        if (rc < 0)
            r->failed = 1;
        if (rc <= 0 || prescan_line(line, line + len, seen, uv, normals))
            break;
    }
    en_source_close(&s);
    st->label[0].file_on = seen[2];
    st->label[1].file_on = seen[3];
    return rc < 0 ? rc : 0;
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
    int rc = prescan_corners(r, st);
    if (rc)
        return rc;
    for (int k = 0; k < 2; k++) {
        st->label[k].on = st->label[k].file_on;
        st->label[k].cur = UINT16_MAX;
    }
    st->file_uv = st->uv;
    st->file_normals = st->normals;
    st->key_size = (size_t)(8 * st->uv + 12 * st->normals + 2 * st->label[0].on + 2 * st->label[1].on);
    if (st->colours)
        for (int k = 0; k < 3; k++)
            if (en_reader_add_attr(r, k == 0 ? "red" : k == 1 ? "green" : "blue", EPSNET_ATTR_FLOAT32) < 0)
                return r->err.code;
    /* note: texture_u and texture_v are the per-vertex texture coordinate
     * names that MeshLab writes and reads in PLY, and that Blender's and
     * trimesh's PLY readers also accept, so an OBJ converted to PLY keeps
     * its texture coordinates in those tools too (u/v and s/t are each
     * read by fewer of them); nx ny nz are the normal names all of them
     * use. */
    if (st->uv && (en_reader_add_attr(r, "texture_u", EPSNET_ATTR_FLOAT32) < 0 ||
                   en_reader_add_attr(r, "texture_v", EPSNET_ATTR_FLOAT32) < 0))
        return r->err.code;
    if (st->normals)
        for (int k = 0; k < 3; k++)
            if (en_reader_add_attr(r, k == 0 ? "nx" : k == 1 ? "ny" : "nz", EPSNET_ATTR_FLOAT32) < 0)
                return r->err.code;
    for (int k = 0; k < 2; k++) {
        obj_label *l = &st->label[k];
        if (!l->on)
            continue;
        if (en_u64map_init(&l->by_name))
            return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
        if (en_reader_add_attr_of(r, en_face_label_attr[k], EPSNET_ATTR_UINT16, 1) < 0)
            return r->err.code;
        *(k ? &r->info.groups : &r->info.materials) = &l->tab;
    }
    return 0;
}

/*
 * Before the first record: the corner attributes that the consumer keeps
 * (en_reader_keep_attrs() may have left some out, and named them). Values
 * no one keeps are not read, so they split no position; when neither vt
 * nor vn is kept, positions are the records, as in a file without them:
 * an output that cannot hold texture coordinates gets the mesh uncut.
 */
static void follow_kept_attrs(epsnet_reader *r, obj_reader *st)
{
    static const char *const uv[2] = { "texture_u", "texture_v" };
    static const char *const n[3] = { "nx", "ny", "nz" };
    const epsnet_attr_layout *kept = &r->info.vertex_attrs;
    int keeps_uv = 0, keeps_n = 0;
    for (int k = 0; k < 2; k++)
        keeps_uv |= epsnet_attr_layout_find(kept, uv[k]) >= 0;
    for (int k = 0; k < 3; k++)
        keeps_n |= epsnet_attr_layout_find(kept, n[k]) >= 0;
    if (st->uv && !keeps_uv) {
        st->uv = 0;
        st->mute_vt = 1;
    }
    if (st->normals && !keeps_n) {
        st->normals = 0;
        st->mute_vn = 1;
    }
    for (int k = 0; k < 2; k++)
        if (st->label[k].on && epsnet_attr_layout_find(kept, en_face_label_attr[k]) < 0) {
            st->label[k].on = 0;
            *(k ? &r->info.groups : &r->info.materials) = NULL;
        }
    if (!st->uv && !st->normals && !st->label[0].on && !st->label[1].on)
        st->key_size = 0;
}

static int obj_fill(epsnet_reader *r)
{
    obj_reader *st = r->state;
    static const uint8_t none[OBJ_KEY_MAX];
    if (!st->started) {
        st->started = 1;
        follow_kept_attrs(r, st);
    }
    while (r->qlen < OBJ_FILL_BATCH) {
        int rc;
        if (st->at_end) {
            /* positions that no face names are vertices all the same, as
             * in a plain file; they come last, with zero vt and vn */
            /* statements that give no vertex are no mesh, not an empty
             * one (comments alone are one): a file with a statement that
             * is none of OBJ's is not an OBJ; one of OBJ's statements
             * alone (vt, g, usemtl) is an OBJ without its geometry */
            if (r->nverts == 0 && st->npos == 0 && r->ntris == 0 && st->first_line)
                return st->unknown_line
                           ? en_reader_fail(r, EPSNET_EFORMAT,
                                            "no vertex: not an OBJ file (its first statement '%s', on line %llu, "
                                            "is none of OBJ's)",
                                            st->unknown, (unsigned long long)st->unknown_line)
                           : en_reader_fail(r, EPSNET_EFORMAT,
                                            "no vertex: the file has OBJ statements ('%s' first, on line %llu) "
                                            "but no 'v'",
                                            st->first, (unsigned long long)st->first_line);
            if (st->tail == st->npos)
                return r->qlen > 0;
            uint64_t ignored;
            if (st->pos[st->tail].first == 0 && (rc = corner_record(r, st, st->tail, none, &ignored)))
                return rc;
            st->tail++;
            continue;
        }
        char *stmt = NULL;
        rc = next_statement(r, st, &stmt);
        if (rc == 0) {
            st->at_end = 1;
            continue;
        }
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
        en_free(st->pos);
        en_free(st->vt);
        en_free(st->vn);
        en_free(st->rec);
        for (int k = 0; k < 2; k++) {
            obj_label *l = &st->label[k];
            for (uint32_t i = 0; i < l->tab.count; i++)
                en_free(l->names[i]);
            en_free(l->names);
            en_u64map_free(&l->by_name);
            en_free(l->library);
        }
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

/* The texture coordinate names the OBJ writer takes for `vt`, in order of
 * preference: what the OBJ reader gives, then the other common PLY names. */
static const char *const uv_names[][2] = { { "texture_u", "texture_v" }, { "s", "t" }, { "u", "v" } };

/* Index in l of each of n names, all float32; @return 1 when all are. */
static int find_float32(const epsnet_attr_layout *l, const char *const *names, int n, int *at)
{
    for (int k = 0; k < n; k++) {
        at[k] = epsnet_attr_layout_find(l, names[k]);
        if (at[k] < 0 || l->attr[at[k]].type != EPSNET_ATTR_FLOAT32)
            return 0;
    }
    return 1;
}

/* The attributes of l that go to `vt` (uv[0..1]) and `vn` (n[0..2]);
 * @return bit 1 for vt, bit 2 for vn. */
static int corner_attrs(const epsnet_attr_layout *l, int uv[2], int n[3])
{
    static const char *const normal[3] = { "nx", "ny", "nz" };
    int found = 0;
    for (size_t k = 0; k < sizeof uv_names / sizeof *uv_names && !found; k++)
        found = find_float32(l, uv_names[k], 2, uv);
    return found | (find_float32(l, normal, 3, n) ? 2 : 0);
}

typedef struct obj_writer {
    int rgb[3];                      /* attributes of `v x y z r g b`; -1: none */
    int uv[2], n[3];                 /* of `vt` and `vn`; uv[0] / n[0] -1: none */
    int corners;                     /* vt or vn are written */
    /* Weld (docs/architecture.md §13): records at the same position (xyz
     * and colour bits) share one `v` line unless that line already has a
     * record with the same vt and vn, so reading the file back gives the
     * same records. */
    en_key_table vline;                 /* v line text bits -> newest v line */
    en_key_table used;                  /* v line + vt/vn bits -> present */
    en_key_table vts, vns;              /* vt / vn bits -> their line */
    uint64_t nv, nvt, nvn;
    uint64_t (*corner)[3];           /* per record: its v, vt, vn lines */
    size_t corner_cap;
    /* Face labels (epsnet.h epsnet_face_names), [0] materials, [1]
     * groups: the attribute (-1: none), each record's index, the index last
     * written (UINT32_MAX: none yet); and whether `mtllib` was written. */
    struct {
        int at;
        uint16_t *of;
        size_t cap;
        uint32_t current;
    } label[2];
    int library_written;
} obj_writer;

static const epsnet_face_names *label_names(const epsnet_writer *w, int k)
{
    return k ? w->info.groups : w->info.materials;
}

static int writer_nomem(epsnet_writer *w)
{
    return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
}

static int obj_open_writer(epsnet_writer *w)
{
    obj_writer *st = en_calloc(1, sizeof *st);
    if (!st)
        return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    w->state = st;
    static const char *const rgb[3] = { "red", "green", "blue" };
    if (!find_float32(&w->attrs, rgb, 3, st->rgb))
        st->rgb[0] = -1;
    int which = corner_attrs(&w->attrs, st->uv, st->n);
    if (!(which & 1))
        st->uv[0] = -1;
    if (!(which & 2))
        st->n[0] = -1;
    st->corners = which != 0;
    for (int k = 0; k < 2; k++) {
        st->label[k].at = -1;
        st->label[k].current = UINT32_MAX;
        int m = epsnet_attr_layout_find(&w->attrs, en_face_label_attr[k]);
        char what[80];
        snprintf(what, sizeof what, "vertex property %s (no names to write)", en_face_label_attr[k]);
        if (m >= 0 && label_names(w, k))
            st->label[k].at = m;
        else if (m >= 0 && en_writer_drop(w, what))
            return writer_nomem(w);
    }
    const char *lib = st->label[0].at >= 0 ? w->info.materials->library : NULL; /* known now unless a
                                                                              * reader is still at it */
    if (lib && (en_writer_bytes(w, "mtllib ", 7) || en_writer_bytes(w, lib, strlen(lib)) ||
                en_writer_bytes(w, "\n", 1)))
        return w->err.code ? w->err.code : EPSNET_EIO;
    st->library_written = lib != NULL;
    en_key_init(&st->vline, 3 * 8 + 3 * 4);
    en_key_init(&st->used, 8 + 5 * 4);
    en_key_init(&st->vts, 2 * 4);
    en_key_init(&st->vns, 3 * 4);
    return 0;
}

static void obj_close_writer(epsnet_writer *w)
{
    obj_writer *st = w->state;
    if (st) {
        en_key_free(&st->vline);
        en_key_free(&st->used);
        en_key_free(&st->vts);
        en_key_free(&st->vns);
        en_free(st->corner);
        en_free(st->label[0].of);
        en_free(st->label[1].of);
        en_free(st);
    }
    w->state = NULL;
}

/* OBJ holds vertex colours as `v x y z r g b` (red, green and blue, all
 * three float32), texture coordinates as `vt u v` (texture_u and
 * texture_v, else s and t, else u and v, float32) and normals as `vn`
 * (nx, ny, nz, float32): see epsnet.h epsnet_writer_dropped(). */
static int obj_holds_attr(const epsnet_attr_layout *l, uint32_t i)
{
    static const char *const rgb[3] = { "red", "green", "blue" };
    int at[3], uv[2], n[3];
    if (find_float32(l, rgb, 3, at) && ((uint32_t)at[0] == i || (uint32_t)at[1] == i || (uint32_t)at[2] == i))
        return 1;
    int which = corner_attrs(l, uv, n);
    if ((which & 1) && ((uint32_t)uv[0] == i || (uint32_t)uv[1] == i))
        return 1;
    if ((which & 2) && ((uint32_t)n[0] == i || (uint32_t)n[1] == i || (uint32_t)n[2] == i))
        return 1;
    /* a face's material and group, as usemtl and g (epsnet.h epsnet_face_names) */
    const char *name = l->attr[i].name;
    return (strcmp(name, en_face_label_attr[0]) == 0 || strcmp(name, en_face_label_attr[1]) == 0) &&
           l->attr[i].type == EPSNET_ATTR_UINT16;
}

/* usemtl (with mtllib) and g, for a material_index or group_index held
 * (obj_holds_attr: uint16). */
static int obj_holds_names(const epsnet_attr_layout *l, int k)
{
    return epsnet_attr_layout_find(l, en_face_label_attr[k]) >= 0;
}

/* Copy the 4-byte values of attributes at[0..n) of rec into key. */
static void attr_bits(const epsnet_writer *w, const epsnet_record *rec, const int *at, int n, uint8_t *key)
{
    for (int k = 0; k < n; k++)
        memcpy(key + 4 * k, rec->attr + w->attrs.attr[at[k]].offset, 4);
}

/* `keyword a b c` of n float32 attributes of rec, appended at line + *len. */
static void put_floats(char *line, size_t *len, const char *keyword, const epsnet_writer *w,
                       const epsnet_record *rec, const int *at, int n)
{
    size_t m = *len;
    if (keyword) {
        size_t kl = strlen(keyword);
        memcpy(line + m, keyword, kl);
        m += kl;
    }
    for (int k = 0; k < n; k++) {
        float f;
        memcpy(&f, rec->attr + w->attrs.attr[at[k]].offset, 4);
        line[m++] = ' ';
        m += (size_t)en_format_coord(line + m, f, EPSNET_COORD_FLOAT32);
    }
    if (keyword)
        line[m++] = '\n';
    *len = m;
}

/* "v x y z", with the colours when the output carries them (no newline). */
static void put_v(char *line, size_t *n, const epsnet_writer *w, const obj_writer *st, const epsnet_record *rec)
{
    line[(*n)++] = 'v';
    for (int k = 0; k < 3; k++) {
        line[(*n)++] = ' ';
        *n += (size_t)en_format_coord(line + *n, rec->xyz[k], w->coord_type);
    }
    if (st->rgb[0] >= 0)
        put_floats(line, n, NULL, w, rec, st->rgb, 3);
}

/* A vertex record of a file with vt or vn: its `v` line unless it welds
 * into an earlier one, its `vt` and `vn` lines unless the same values have
 * one already; the face corners then name those lines. */
static int put_corner_vertex(epsnet_writer *w, obj_writer *st, const epsnet_record *rec, char *line, size_t *len)
{
    if (en_grow((void **)&st->corner, &st->corner_cap, w->nverts, sizeof *st->corner))
        return writer_nomem(w);
    uint64_t *c = st->corner[w->nverts - 1];
    uint8_t vkey[36], ukey[28];
    memset(vkey, 0, sizeof vkey);
    memset(ukey, 0, sizeof ukey);
    memcpy(vkey, rec->xyz, 24);
    if (st->rgb[0] >= 0)
        attr_bits(w, rec, st->rgb, 3, vkey + 24);
    if (st->uv[0] >= 0)
        attr_bits(w, rec, st->uv, 2, ukey + 8);
    if (st->n[0] >= 0)
        attr_bits(w, rec, st->n, 3, ukey + 16);
    int added;
    if (en_key_find(&st->vline, vkey, st->nv, &c[0], &added))
        return writer_nomem(w);
    memcpy(ukey, &c[0], 8);
    uint64_t ignored;
    int fresh;
    if (en_key_find(&st->used, ukey, 0, &ignored, &fresh))
        return writer_nomem(w);
    if (!added && !fresh) {
        /* the v line has a record with these vt and vn bits already: a
         * distinct vertex at the same place gets a line of its own */
        c[0] = st->nv;
        en_key_set(&st->vline, vkey, c[0]);
        memcpy(ukey, &c[0], 8);
        if (en_key_find(&st->used, ukey, 0, &ignored, &fresh))
            return writer_nomem(w);
        added = 1;
    }
    size_t n = 0;
    if (added) {
        st->nv++;
        put_v(line, &n, w, st, rec);
        line[n++] = '\n';
    }
    c[1] = c[2] = 0;
    if (st->uv[0] >= 0) {
        if (en_key_find(&st->vts, ukey + 8, st->nvt, &c[1], &added))
            return writer_nomem(w);
        if (added) {
            st->nvt++;
            put_floats(line, &n, "vt", w, rec, st->uv, 2);
        }
    }
    if (st->n[0] >= 0) {
        if (en_key_find(&st->vns, ukey + 16, st->nvn, &c[2], &added))
            return writer_nomem(w);
        if (added) {
            st->nvn++;
            put_floats(line, &n, "vn", w, rec, st->n, 3);
        }
    }
    *len = n;
    return 0;
}

/* Before a face: `g` and `usemtl` when its group or material is not the
 * last one written (and `mtllib` before the first usemtl). */
static int put_labels(epsnet_writer *w, obj_writer *st, uint64_t corner)
{
    if (corner >= w->nverts)
        return 0; /* the writer's front end refuses such a face */
    for (int k = 1; k >= 0; k--) { /* g, then usemtl */
        if (st->label[k].at < 0)
            continue;
        uint32_t m = st->label[k].of[corner];
        if (m == st->label[k].current)
            continue;
        const epsnet_face_names *names = label_names(w, k);
        if (m >= names->count)
            return en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "%s %u of vertex %llu names nothing (%u names known)", en_face_label_attr[k], m,
                                (unsigned long long)corner, names->count);
        st->label[k].current = m;
        int rc = 0;
        if (k == 0 && !st->library_written && names->library) {
            st->library_written = 1;
            if ((rc = en_writer_bytes(w, "mtllib ", 7)) ||
                (rc = en_writer_bytes(w, names->library, strlen(names->library))) ||
                (rc = en_writer_bytes(w, "\n", 1)))
                return rc;
        }
        const char *name = names->names[m];
        if ((rc = en_writer_bytes(w, label_keyword[k], strlen(label_keyword[k]))) ||
            (*name && (rc = en_writer_bytes(w, " ", 1))) || (rc = en_writer_bytes(w, name, strlen(name))) ||
            (rc = en_writer_bytes(w, "\n", 1)))
            return rc;
    }
    return 0;
}

static int obj_put(epsnet_writer *w, const epsnet_record *rec)
{
    obj_writer *st = w->state;
    for (int k = 0; k < 2 && rec->kind == EPSNET_REC_VERTEX; k++)
        if (st->label[k].at >= 0) {
            if (en_grow((void **)&st->label[k].of, &st->label[k].cap, w->nverts, sizeof *st->label[k].of))
                return writer_nomem(w);
            memcpy(&st->label[k].of[w->nverts - 1], rec->attr + w->attrs.attr[st->label[k].at].offset, 2);
        }
    if (rec->kind == EPSNET_REC_TRIANGLE && (st->label[0].at >= 0 || st->label[1].at >= 0)) {
        int rc = put_labels(w, st, rec->v[0]);
        if (rc)
            return rc;
    }
    /* v with colours, vt and vn lines, or f with three v/vt/vn corners */
    char line[3 * (6 * 33 + 8)];
    size_t n = 0;
    if (rec->kind == EPSNET_REC_VERTEX) {
        int rc = check_coord_range(w, rec->xyz, w->nverts);
        if (rc)
            return rc;
        if (st->corners) {
            if ((rc = put_corner_vertex(w, st, rec, line, &n)))
                return rc;
            return n ? en_writer_bytes(w, line, n) : 0;
        }
        put_v(line, &n, w, st, rec);
    } else if (rec->kind == EPSNET_REC_TRIANGLE) {
        line[n++] = 'f';
        for (int k = 0; k < 3; k++) {
            line[n++] = ' ';
            if (!st->corners) {
                n += format_u64(line + n, rec->v[k] + 1);
                continue;
            }
            const uint64_t *c = st->corner[rec->v[k]];
            n += format_u64(line + n, c[0] + 1);
            if (st->uv[0] >= 0 || st->n[0] >= 0)
                line[n++] = '/';
            if (st->uv[0] >= 0)
                n += format_u64(line + n, c[1] + 1);
            if (st->n[0] >= 0) {
                line[n++] = '/';
                n += format_u64(line + n, c[2] + 1);
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
    .close_writer = obj_close_writer,
    .holds_attr = obj_holds_attr,
    .holds_names = obj_holds_names,
};
