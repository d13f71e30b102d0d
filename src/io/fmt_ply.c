/*
 * PLY reader and writer (docs/architecture.md §13: ascii, binary little-
 * and big-endian, extra properties skipped, polygons triangulated; and PLY
 * `tristrips`, read as triangles). What is skipped is named through
 * epsnet_reader_dropped() (docs/architecture.md §5). A face's integer
 * properties (material_index and the like) travel as its corners'
 * attributes, which makes the reader hold the vertex block (see
 * ply_reader.labels).
 *
 * Reading: the header becomes a list of elements with their properties; the
 * body is then walked element by element. The encoding is chosen once, when
 * the header is read: ascii records go through a line tokenizer, binary ones
 * through a table of per-type decoders for the file's byte order (after
 * rply's driver tables), so no value ever tests the encoding.
 *
 * Writing: PLY needs every vertex before every face and both counts in the
 * header, while a streaming input interleaves them and may not know its
 * counts. The writer therefore reserves a fixed-size header, writes vertices
 * straight to the output, spills faces to a temporary file and appends them
 * at the end, then patches the header with the real counts. Outputs that
 * cannot be rewritten (.zst, stdout) spill the vertices too, unless the
 * counts were announced. A face's values (epsnet_attr.of_face: a label the
 * reader took from a face element, an OBJ material) go back on the face
 * element, and the records of one position that differ only in them are
 * welded into one vertex, so that a material boundary is not written as a
 * cut (put_faced_vertex()). The names such labels stand for (OBJ materials
 * and groups) ride in header comments (ply_names), which makes the header
 * the last thing written.
 */
#include <inttypes.h>
#include <limits.h>
#include <stdarg.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "common/key_table.h"
#include "common/pool.h"
#include "io/format.h"
#include "io/text_scan.h"

#define PLY_NAME_MAX 64
#define PLY_HEADER_LINE_MAX 65536
#define PLY_MAX_ELEMENTS 256
#define PLY_MAX_PROPERTIES 1024       /* per element */
#define PLY_MAX_LIST ((int64_t)1 << 20)
#define PLY_BATCH 1024                /* records decoded per fill() */
#define PLY_CHUNK ((size_t)1 << 19)   /* bytes asked of the source at once */

/* ------------------------------------------------------------------------
 * Types and their binary decoders
 * ------------------------------------------------------------------------ */

typedef enum ply_type {
    PLY_NONE = 0,
    PLY_INT8, PLY_UINT8, PLY_INT16, PLY_UINT16,
    PLY_INT32, PLY_UINT32, PLY_FLOAT32, PLY_FLOAT64,
    PLY_NTYPES
} ply_type;

static const struct {
    const char *name, *alias;
} ply_type_names[PLY_NTYPES] = {
    [PLY_INT8] = { "char", "int8" },     [PLY_UINT8] = { "uchar", "uint8" },
    [PLY_INT16] = { "short", "int16" },  [PLY_UINT16] = { "ushort", "uint16" },
    [PLY_INT32] = { "int", "int32" },    [PLY_UINT32] = { "uint", "uint32" },
    [PLY_FLOAT32] = { "float", "float32" }, [PLY_FLOAT64] = { "double", "float64" },
};

static const size_t ply_type_size[PLY_NTYPES] = {
    [PLY_INT8] = 1, [PLY_UINT8] = 1, [PLY_INT16] = 2, [PLY_UINT16] = 2,
    [PLY_INT32] = 4, [PLY_UINT32] = 4, [PLY_FLOAT32] = 4, [PLY_FLOAT64] = 8,
};

static const int64_t ply_int_min[PLY_NTYPES] = {
    [PLY_INT8] = INT8_MIN, [PLY_INT16] = INT16_MIN, [PLY_INT32] = INT32_MIN,
};
static const int64_t ply_int_max[PLY_NTYPES] = {
    [PLY_INT8] = INT8_MAX, [PLY_UINT8] = UINT8_MAX, [PLY_INT16] = INT16_MAX,
    [PLY_UINT16] = UINT16_MAX, [PLY_INT32] = INT32_MAX, [PLY_UINT32] = UINT32_MAX,
};

static int ply_type_is_int(ply_type t)
{
    return t >= PLY_INT8 && t <= PLY_UINT32;
}

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
#define PLY_HOST_BE 1
#else
#define PLY_HOST_BE 0
#endif

static uint16_t swap16(uint16_t v) { return __builtin_bswap16(v); }
static uint32_t swap32(uint32_t v) { return __builtin_bswap32(v); }
static uint64_t swap64(uint64_t v) { return __builtin_bswap64(v); }
static uint16_t keep16(uint16_t v) { return v; }
static uint32_t keep32(uint32_t v) { return v; }
static uint64_t keep64(uint64_t v) { return v; }

/* One set of decoders per byte order: FIXn turns file order into host
 * order. Integers decode to int64_t (counts, indices), anything to double
 * (coordinates). */
#define PLY_DECODERS(E, FIX16, FIX32, FIX64)                                                   \
    static int64_t int_i8_##E(const uint8_t *p) { return (int8_t)p[0]; }                      \
    static int64_t int_u8_##E(const uint8_t *p) { return p[0]; }                              \
    static int64_t int_i16_##E(const uint8_t *p)                                              \
    {                                                                                         \
        uint16_t u;                                                                           \
        memcpy(&u, p, 2);                                                                     \
        return (int16_t)FIX16(u);                                                             \
    }                                                                                         \
    static int64_t int_u16_##E(const uint8_t *p)                                              \
    {                                                                                         \
        uint16_t u;                                                                           \
        memcpy(&u, p, 2);                                                                     \
        return FIX16(u);                                                                      \
    }                                                                                         \
    static int64_t int_i32_##E(const uint8_t *p)                                              \
    {                                                                                         \
        uint32_t u;                                                                           \
        memcpy(&u, p, 4);                                                                     \
        return (int32_t)FIX32(u);                                                             \
    }                                                                                         \
    static int64_t int_u32_##E(const uint8_t *p)                                              \
    {                                                                                         \
        uint32_t u;                                                                           \
        memcpy(&u, p, 4);                                                                     \
        return FIX32(u);                                                                      \
    }                                                                                         \
    static double real_i8_##E(const uint8_t *p) { return (double)int_i8_##E(p); }             \
    static double real_u8_##E(const uint8_t *p) { return (double)int_u8_##E(p); }             \
    static double real_i16_##E(const uint8_t *p) { return (double)int_i16_##E(p); }           \
    static double real_u16_##E(const uint8_t *p) { return (double)int_u16_##E(p); }           \
    static double real_i32_##E(const uint8_t *p) { return (double)int_i32_##E(p); }           \
    static double real_u32_##E(const uint8_t *p) { return (double)int_u32_##E(p); }           \
    static double real_f32_##E(const uint8_t *p)                                              \
    {                                                                                         \
        uint32_t u;                                                                           \
        float f;                                                                              \
        memcpy(&u, p, 4);                                                                     \
        u = FIX32(u);                                                                         \
        memcpy(&f, &u, 4);                                                                    \
        return f;                                                                             \
    }                                                                                         \
    static double real_f64_##E(const uint8_t *p)                                              \
    {                                                                                         \
        uint64_t u;                                                                           \
        double d;                                                                             \
        memcpy(&u, p, 8);                                                                     \
        u = FIX64(u);                                                                         \
        memcpy(&d, &u, 8);                                                                    \
        return d;                                                                             \
    }                                                                                         \
    static const ply_codec ply_codec_##E = {                                                  \
        .get_int = { NULL, int_i8_##E, int_u8_##E, int_i16_##E, int_u16_##E, int_i32_##E,     \
                     int_u32_##E, NULL, NULL },                                               \
        .get_real = { NULL, real_i8_##E, real_u8_##E, real_i16_##E, real_u16_##E,             \
                      real_i32_##E, real_u32_##E, real_f32_##E, real_f64_##E },               \
    };

typedef struct ply_codec {
    int64_t (*get_int[PLY_NTYPES])(const uint8_t *p);   /* NULL for float types */
    double (*get_real[PLY_NTYPES])(const uint8_t *p);
} ply_codec;

#if PLY_HOST_BE
PLY_DECODERS(le, swap16, swap32, swap64)
PLY_DECODERS(be, keep16, keep32, keep64)
#else
PLY_DECODERS(le, keep16, keep32, keep64)
PLY_DECODERS(be, swap16, swap32, swap64)
#endif

/* ------------------------------------------------------------------------
 * Header model
 * ------------------------------------------------------------------------ */

typedef enum ply_role {
    ROLE_SKIP = -1,
    ROLE_X = 0, ROLE_Y = 1, ROLE_Z = 2,
    ROLE_INDICES = 3,
    ROLE_ATTR = 4,          /* a vertex attribute the records carry (epsnet.h §2) */
    ROLE_LABEL = 5,         /* a face's integer property its corners carry (see face_labels) */
    ROLE_TEXCOORD = 6,      /* a face's list of u, v per corner (see face_texcoords) */
} ply_role;

typedef struct ply_property {
    char name[PLY_NAME_MAX];
    ply_type type;          /* scalar type, or the item type of a list */
    ply_type count_type;    /* PLY_NONE for scalars */
    ply_role role;
    uint32_t attr_offset;   /* ROLE_ATTR, ROLE_LABEL: where its bytes go in the vertex's packed bytes */
} ply_property;

/* ELEM_STRIPS: the Stanford tools' `tristrips` element (see strip_index()). */
typedef enum ply_kind { ELEM_OTHER, ELEM_VERTEX, ELEM_FACE, ELEM_STRIPS } ply_kind;

typedef struct ply_element {
    char name[PLY_NAME_MAX];
    uint64_t count;
    ply_kind kind;
    uint64_t header_line;
    ply_property *props;
    size_t nprops, cap;
    size_t fixed_size;      /* bytes per binary record when no property is a list, else 0 */
} ply_element;

typedef enum ply_encoding { ENC_ASCII, ENC_LE, ENC_BE } ply_encoding;

/* Where a strip list stands: the two indices before the next one, and the
 * position in the strip since the last restart (its parity gives the
 * orientation). Binary strip lists can be as long as the mesh (Stanford
 * files hold every strip in one record), so a list is read in pieces across
 * fill() calls and this state survives between them. */
typedef struct ply_strip {
    uint64_t a, b;
    uint64_t n;             /* indices since the last restart */
    int64_t left;           /* items of the current list still to read, -1 outside a list */
    size_t prop;            /* next property of the current record */
    int in_line;            /* ascii: the record's line has begun */
} ply_strip;

/*
 * The names a face label stands for (epsnet.h epsnet_face_names): [0] the
 * materials of material_index with their `mtllib` text, [1] the groups of
 * group_index (en_face_label_attr). PLY has no place for them, so the
 * writer puts them in header comments, one a value in order, which this
 * reader takes back:
 *     comment epsnet mtllib LIBRARY
 *     comment epsnet material_index 0 NAME
 * A list out of order, or names whose property is not a face's ushort,
 * are named as dropped (header_names).
 */
typedef struct ply_names {
    epsnet_face_names tab;
    char **names;
    size_t cap;
    char *library;
    int out_of_order;
    int64_t at;                  /* its value's offset in ply_reader.attr once taken, else -1 */
} ply_names;

typedef struct ply_reader ply_reader;

/* Reads up to n records of element e: ascii or binary, chosen once. */
typedef int (*ply_records_fn)(epsnet_reader *r, ply_reader *p, ply_element *e, uint64_t n);

struct ply_reader {
    uint8_t attr[EPSNET_ATTR_MAX * 8]; /* one vertex's packed attribute bytes */
    int swap;                    /* binary file order differs from the host's */
    ply_element *elems;
    size_t nelems, cap;
    ply_encoding encoding;
    const ply_codec *codec;      /* binary only */
    ply_records_fn read_records;
    size_t elem;                 /* element being read */
    uint64_t record;             /* records of it read so far */
    uint64_t short_polygons;     /* faces with fewer than 3 corners, skipped */
    ply_strip strip;             /* tristrips only */
    uint64_t strip_turns;        /* strip triangles that repeat an index, skipped */

    /* Face labels (docs/architecture.md §13): the face element's integer
     * properties (material_index and the like) travel as attributes of its
     * corners, after the vertex's own (vsize bytes, then lsize of labels).
     * A PLY lists every vertex before any face, so the vertex block is held
     * (within settings.mem_limit) and a record is pushed for each distinct
     * (vertex, labels) that a face names, as the OBJ reader does for its
     * corners: a vertex whose faces have two materials is two records. */
    int labels;
    uint32_t vsize, lsize;
    uint64_t nheld;              /* vertices read and held */
    double *held_xyz;            /* 3 per held vertex */
    uint8_t *held_attr;          /* vsize per held vertex */
    uint32_t *first;             /* per held vertex: its newest record + 1; 0: none */
    uint32_t *next;              /* per record: the older record of its vertex + 1 */
    uint8_t *rec_label;          /* per record: its lsize label bytes */
    size_t xyz_cap, attr_cap, first_cap, next_cap, label_cap;
    uint64_t *corners;           /* the face being read: its vertex indices */
    size_t ncorners, corners_cap;
    /* A face's texture coordinates (face_texcoords): where texture_u and
     * texture_v go in the label bytes (-1: none), and the face being read's
     * u, v values, in its corners' order. */
    int64_t uv_at;
    float *fuv;
    size_t nfuv, fuv_cap;
    size_t held_bytes;           /* of the tables above, held to settings.mem_limit */
    uint8_t out[EPSNET_ATTR_MAX * 8]; /* a record's packed bytes */
    ply_names names[2];          /* [0] material_index, [1] group_index (header_comment) */
    int started;                 /* the first fill() has looked at the attributes kept */

    /* Decoding ahead on the pool (ply_use_pool; see "Decoding ahead"):
     * ring NULL when not. */
    struct en_jobring *ring;
    struct ply_job *jobs;        /* njobs slots, at most njobs - 1 in flight: the current one stays */
    size_t njobs;
    uint64_t submitted;          /* jobs ever submitted */
    struct ply_job *cur;         /* the job whose records are handed out, NULL: none */
    uint32_t cur_pos;            /* its records handed out */
    uint64_t ahead_vertices;     /* vertex records cut and not yet handed out */
    size_t ahead_bytes;          /* the slots' buffers (ahead_room) */
    int ahead_stop;              /* something the walkers must see (a long list, the end): no more cuts */
};

/* ------------------------------------------------------------------------
 * Small helpers shared by the reader paths
 * ------------------------------------------------------------------------ */

/* Take over an error that a source call wrote into err. */
static int adopt_error(epsnet_reader *r, const epsnet_error *e)
{
    if (!r->failed) {
        r->failed = 1;
        r->err = *e;
    }
    return r->err.code;
}

static int source_failure(epsnet_reader *r)
{
    epsnet_error e;
    en_source_error(r->src, &e);
    return adopt_error(r, &e);
}

/* Pointer to n readable bytes at the source's cursor, or NULL at the end. */
static inline const uint8_t *need(en_source *s, size_t n)
{
    if ((size_t)(s->end - s->cur) >= n)
        return s->cur;
    return en_source_fill(s, n) >= n ? s->cur : NULL;
}

static int truncated_binary(epsnet_reader *r, const ply_element *e, uint64_t record)
{
    if (r->src->failed)
        return source_failure(r);
    return en_reader_fail_at(r, EPSNET_EFORMAT, en_source_offset(r->src),
                             "truncated file: %s %" PRIu64 " of %" PRIu64 " is incomplete",
                             e->name, record + 1, e->count);
}

/* Next whitespace-separated token of *cursor, NUL-terminated in place. */
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

static int parse_u64(const char *s, uint64_t *out)
{
    if (*s < '0' || *s > '9')
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

/* Integer token within the range of type t. */
static int parse_int_as(const char *s, ply_type t, int64_t *out)
{
    int neg = *s == '-';
    if (*s == '-' || *s == '+')
        s++;
    uint64_t u;
    if (parse_u64(s, &u) || u > (uint64_t)INT64_MAX)
        return -1;
    int64_t v = neg ? -(int64_t)u : (int64_t)u;
    if (v < ply_int_min[t] || v > ply_int_max[t])
        return -1;
    *out = v;
    return 0;
}

/* Number token of type t (integers must be integers in range). */
static int parse_real_as(const char *s, ply_type t, double *out)
{
    if (ply_type_is_int(t)) {
        int64_t v;
        if (parse_int_as(s, t, &v))
            return -1;
        *out = (double)v;
        return 0;
    }
    char *end;
    double v = t == PLY_FLOAT32 ? (double)strtof(s, &end) : strtod(s, &end);
    if (end == s || *end)
        return -1;
    *out = v;
    return 0;
}

/* ------------------------------------------------------------------------
 * Header
 * ------------------------------------------------------------------------ */

static ply_type type_by_name(const char *s)
{
    for (int t = PLY_INT8; t < PLY_NTYPES; t++)
        if (strcmp(s, ply_type_names[t].name) == 0 || strcmp(s, ply_type_names[t].alias) == 0)
            return (ply_type)t;
    return PLY_NONE;
}

static int copy_name(epsnet_reader *r, char *dst, const char *src, const char *what)
{
    size_t n = strlen(src);
    if (n >= PLY_NAME_MAX)
        return en_reader_fail(r, EPSNET_EFORMAT, "%s name longer than %d bytes", what, PLY_NAME_MAX - 1);
    memcpy(dst, src, n + 1);
    return 0;
}

static int header_element(epsnet_reader *r, ply_reader *p, char *rest)
{
    char *name = next_token(&rest);
    char *count = next_token(&rest);
    if (!name || !count || next_token(&rest))
        return en_reader_fail(r, EPSNET_EFORMAT, "expected 'element NAME COUNT'");
    if (p->nelems == PLY_MAX_ELEMENTS)
        return en_reader_fail(r, EPSNET_ELIMIT, "more than %d elements", PLY_MAX_ELEMENTS);
    uint64_t n;
    if (parse_u64(count, &n))
        return en_reader_fail(r, EPSNET_EFORMAT, "element '%s' has an invalid count '%s'", name, count);
    ply_kind kind = strcmp(name, "vertex") == 0 ? ELEM_VERTEX
                    : strcmp(name, "face") == 0 ? ELEM_FACE
                    : strcmp(name, "tristrips") == 0 ? ELEM_STRIPS : ELEM_OTHER;
    int rc = en_reader_check_count(r, n, kind == ELEM_VERTEX ? "vertex count"
                                         : kind == ELEM_FACE ? "face count"
                                         : kind == ELEM_STRIPS ? "strip count" : "element count");
    if (rc)
        return rc;
    for (size_t i = 0; i < p->nelems; i++) {
        const ply_element *o = &p->elems[i];
        if (kind != ELEM_OTHER && o->kind == kind)
            return en_reader_fail(r, EPSNET_EFORMAT, "second '%s' element", name);
        if (kind == ELEM_VERTEX && (o->kind == ELEM_FACE || o->kind == ELEM_STRIPS) && o->count > 0)
            return en_reader_fail(r, EPSNET_EFORMAT,
                                  "element '%s' comes before element 'vertex' (line %" PRIu64
                                  "): faces need their vertices first",
                                  o->name, o->header_line);
    }
    if (p->nelems == p->cap &&
        en_grow((void **)&p->elems, &p->cap, p->nelems + 1, sizeof *p->elems))
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    ply_element *e = &p->elems[p->nelems];
    memset(e, 0, sizeof *e);
    if ((rc = copy_name(r, e->name, name, "element")))
        return rc;
    e->count = n;
    e->kind = kind;
    e->header_line = r->src->lineno;
    p->nelems++;
    return 0;
}

static ply_role role_of(const ply_element *e, const char *name, int is_list)
{
    if (e->kind == ELEM_VERTEX && !is_list) {
        if (strcmp(name, "x") == 0)
            return ROLE_X;
        if (strcmp(name, "y") == 0)
            return ROLE_Y;
        if (strcmp(name, "z") == 0)
            return ROLE_Z;
    }
    if ((e->kind == ELEM_FACE || e->kind == ELEM_STRIPS) && is_list &&
        (strcmp(name, "vertex_indices") == 0 || strcmp(name, "vertex_index") == 0))
        return ROLE_INDICES;
    return ROLE_SKIP;
}

static int header_property(epsnet_reader *r, ply_reader *p, char *rest)
{
    if (p->nelems == 0)
        return en_reader_fail(r, EPSNET_EFORMAT, "property before any element");
    ply_element *e = &p->elems[p->nelems - 1];
    ply_property prop = { .count_type = PLY_NONE };
    char *tok = next_token(&rest);
    char *name;
    if (tok && strcmp(tok, "list") == 0) {
        char *ct = next_token(&rest), *it = next_token(&rest);
        name = next_token(&rest);
        if (!name || next_token(&rest))
            return en_reader_fail(r, EPSNET_EFORMAT, "expected 'property list COUNTTYPE ITEMTYPE NAME'");
        prop.count_type = type_by_name(ct);
        prop.type = type_by_name(it);
        if (!prop.count_type || !prop.type)
            return en_reader_fail(r, EPSNET_EFORMAT, "unknown property type '%s'", prop.count_type ? it : ct);
        if (!ply_type_is_int(prop.count_type))
            return en_reader_fail(r, EPSNET_EFORMAT, "list '%s' has a non-integer count type '%s'", name, ct);
    } else {
        name = next_token(&rest);
        if (!tok || !name || next_token(&rest))
            return en_reader_fail(r, EPSNET_EFORMAT, "expected 'property TYPE NAME'");
        prop.type = type_by_name(tok);
        if (!prop.type)
            return en_reader_fail(r, EPSNET_EFORMAT, "unknown property type '%s'", tok);
    }
    int rc = copy_name(r, prop.name, name, "property");
    if (rc)
        return rc;
    prop.role = role_of(e, name, prop.count_type != PLY_NONE);
    if (e->kind == ELEM_VERTEX && prop.count_type != PLY_NONE &&
        (strcmp(name, "x") == 0 || strcmp(name, "y") == 0 || strcmp(name, "z") == 0))
        return en_reader_fail(r, EPSNET_EFORMAT, "vertex coordinate '%s' is declared as a list", name);
    if ((e->kind == ELEM_FACE || e->kind == ELEM_STRIPS) && prop.count_type == PLY_NONE &&
        (strcmp(name, "vertex_indices") == 0 || strcmp(name, "vertex_index") == 0))
        return en_reader_fail(r, EPSNET_EFORMAT, "%s property '%s' is not a list", e->name, name);
    if (prop.role == ROLE_INDICES && !ply_type_is_int(prop.type))
        return en_reader_fail(r, EPSNET_EUNSUPPORTED, "%s indices of type '%s' are not integers", e->name,
                              ply_type_names[prop.type].name);
    for (size_t i = 0; i < e->nprops; i++) {
        if (strcmp(e->props[i].name, prop.name) == 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "element '%s' declares property '%s' twice",
                                  e->name, prop.name);
        if (prop.role == ROLE_INDICES && e->props[i].role == ROLE_INDICES)
            return en_reader_fail(r, EPSNET_EFORMAT, "%s element has both vertex_indices and vertex_index",
                                  e->name);
    }
    if (e->nprops == PLY_MAX_PROPERTIES)
        return en_reader_fail(r, EPSNET_ELIMIT, "element '%s' has more than %d properties", e->name,
                              PLY_MAX_PROPERTIES);
    if (e->nprops == e->cap && en_grow((void **)&e->props, &e->cap, e->nprops + 1, sizeof *e->props))
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    e->props[e->nprops++] = prop;
    return 0;
}

static int header_format(epsnet_reader *r, ply_reader *p, char *rest, int *seen)
{
    char *enc = next_token(&rest), *ver = next_token(&rest);
    if (*seen)
        return en_reader_fail(r, EPSNET_EFORMAT, "second 'format' line");
    if (!enc || !ver || next_token(&rest))
        return en_reader_fail(r, EPSNET_EFORMAT, "expected 'format ENCODING 1.0'");
    if (strcmp(enc, "ascii") == 0)
        p->encoding = ENC_ASCII;
    else if (strcmp(enc, "binary_little_endian") == 0)
        p->encoding = ENC_LE;
    else if (strcmp(enc, "binary_big_endian") == 0)
        p->encoding = ENC_BE;
    else
        return en_reader_fail(r, EPSNET_EFORMAT,
                              "unknown PLY format '%s' (expected ascii, binary_little_endian or "
                              "binary_big_endian)", enc);
    if (strcmp(ver, "1.0") != 0 && strcmp(ver, "1") != 0)
        return en_reader_fail(r, EPSNET_EUNSUPPORTED, "unsupported PLY version '%s'", ver);
    *seen = 1;
    return 0;
}

/* The face element's integer scalars become labels its corners carry
 * (material_index, MeshLab's texnumber, a part or segment id, a face
 * colour). Floating-point face properties (normals, quality) stay dropped
 * and named: as labels they would make nearly every vertex a seam. So do
 * `flags` (an editor's selection and visit bits, not a property of the
 * surface) and a name the vertex element has already. */
static int face_labels(epsnet_reader *r, ply_reader *p, ply_element *face)
{
    p->vsize = r->file_attrs.size;
    for (size_t k = 0; k < face->nprops; k++) {
        ply_property *pr = &face->props[k];
        if (pr->role != ROLE_SKIP || pr->count_type != PLY_NONE || !ply_type_is_int(pr->type) ||
            strcmp(pr->name, "flags") == 0 || epsnet_attr_layout_find(&r->file_attrs, pr->name) >= 0)
            continue;
        int rc = en_reader_add_attr_of(r, pr->name, (epsnet_attr_type)pr->type, 1);
        if (rc < 0)
            return rc;
        if (rc == 1) {
            pr->role = ROLE_LABEL;
            pr->attr_offset = r->file_attrs.attr[r->file_attrs.count - 1].offset;
            p->labels = 1;
        }
    }
    p->lsize = r->file_attrs.size - p->vsize;
    return 0;
}

/* A face list of texture coordinates, u and v for each corner in turn
 * (`property list uchar float texcoord`: MeshLab's and Agisoft Metashape's
 * textured PLY). They travel as texture_u and texture_v of the face's
 * corners, as an OBJ's vt do: one record per distinct (vertex, labels,
 * u, v), so a UV seam is a seam (docs/architecture.md §13). A vertex
 * element with texture coordinates of its own keeps those, and the list
 * is named as dropped. */
static int face_texcoords(epsnet_reader *r, ply_reader *p, ply_element *face)
{
    static const char *const uv[2] = { "texture_u", "texture_v" };
    p->uv_at = -1;
    ply_property *tc = NULL;
    for (size_t k = 0; k < face->nprops; k++) {
        ply_property *pr = &face->props[k];
        if (pr->role == ROLE_SKIP && pr->count_type != PLY_NONE && strcmp(pr->name, "texcoord") == 0 &&
            (pr->type == PLY_FLOAT32 || pr->type == PLY_FLOAT64))
            tc = pr;
    }
    if (!tc || epsnet_attr_layout_find(&r->file_attrs, uv[0]) >= 0 ||
        epsnet_attr_layout_find(&r->file_attrs, uv[1]) >= 0 || r->file_attrs.count + 2 > EPSNET_ATTR_MAX)
        return 0; /* the list stays dropped (named) */
    for (int k = 0; k < 2; k++) {
        int rc = en_reader_add_attr(r, uv[k], EPSNET_ATTR_FLOAT32);
        if (rc < 0)
            return rc;
        if (rc != 1)
            return en_reader_fail(r, EPSNET_EINTERNAL, "cannot carry '%s'", uv[k]);
    }
    tc->role = ROLE_TEXCOORD;
    p->uv_at = r->file_attrs.attr[r->file_attrs.count - 2].offset;
    p->labels = 1;
    return 0;
}

/* Checks that need the whole header, then what the body walk precomputes. */
static int header_finish(epsnet_reader *r, ply_reader *p)
{
    ply_element *vertex = NULL, *faces[2] = { NULL, NULL };
    for (size_t i = 0; i < p->nelems; i++) {
        ply_element *e = &p->elems[i];
        e->fixed_size = 0;
        int has_list = 0;
        size_t size = 0;
        for (size_t k = 0; k < e->nprops; k++) {
            if (e->props[k].count_type != PLY_NONE)
                has_list = 1;
            else
                size += ply_type_size[e->props[k].type];
        }
        if (!has_list)
            e->fixed_size = size;
        if (e->kind == ELEM_VERTEX)
            vertex = e;
        if (e->kind == ELEM_FACE)
            faces[0] = e;
        if (e->kind == ELEM_STRIPS)
            faces[1] = e;
    }
    r->info.coord_type = EPSNET_COORD_FLOAT32;
    if (vertex) {
        int have[3] = { 0, 0, 0 };
        for (size_t k = 0; k < vertex->nprops; k++) {
            const ply_property *pr = &vertex->props[k];
            if (pr->role >= ROLE_X && pr->role <= ROLE_Z) {
                have[pr->role] = 1;
                /* note: 32-bit integers do not fit a float32, so they are
                 * carried as float64 to keep every coordinate exact (docs/method.md §11). */
                if (pr->type == PLY_FLOAT64 || pr->type == PLY_INT32 || pr->type == PLY_UINT32)
                    r->info.coord_type = EPSNET_COORD_FLOAT64;
            }
        }
        if (!have[0] || !have[1] || !have[2])
            return en_reader_fail(r, EPSNET_EFORMAT, "element 'vertex' lacks property '%s'",
                                  !have[0] ? "x" : !have[1] ? "y" : "z");
        /* note: every scalar vertex property beyond x, y, z travels with
         * its vertex, bit for bit (epsnet.h §2); the PLY type numbers are
         * epsnet_attr_type's. Lists stay dropped (named by note_dropped). */
        for (size_t k = 0; k < vertex->nprops; k++) {
            ply_property *pr = &vertex->props[k];
            if (pr->role != ROLE_SKIP || pr->count_type != PLY_NONE)
                continue;
            int rc = en_reader_add_attr(r, pr->name, (epsnet_attr_type)pr->type);
            if (rc < 0)
                return rc;
            if (rc == 1) {
                pr->role = ROLE_ATTR;
                pr->attr_offset = r->file_attrs.attr[r->file_attrs.count - 1].offset;
            }
        }
    }
    p->uv_at = -1;
    if (vertex && faces[0]) {
        int rc = face_labels(r, p, faces[0]);
        if (rc == 0)
            rc = face_texcoords(r, p, faces[0]);
        if (rc)
            return rc;
        p->lsize = r->file_attrs.size - p->vsize;
    }
    r->info.nfaces = 0;
    for (int f = 0; f < 2; f++) {
        const ply_element *face = faces[f];
        if (!face)
            continue;
        int has_indices = 0;
        for (size_t k = 0; k < face->nprops; k++)
            has_indices |= face->props[k].role == ROLE_INDICES;
        if (!has_indices)
            return en_reader_fail(r, EPSNET_EFORMAT, "element '%s' has no 'vertex_indices' list", face->name);
        if (!vertex && face->count > 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "%s but no 'vertex' element",
                                  f ? "triangle strips" : "faces");
        if (face->count > 0)
            r->info.nfaces = EPSNET_COUNT_UNKNOWN;
    }
    r->info.nverts = vertex ? vertex->count : 0;
    r->info.encoding = p->encoding == ENC_ASCII ? "ascii" : p->encoding == ENC_LE ? "binary_le" : "binary_be";
    return 0;
}

/* docs/architecture.md §5: every element and property the records do not carry is named
 * (vertex lists, face properties, other elements; vertex scalars travel as
 * attributes). Elements without records hold nothing. */
static void note_dropped(epsnet_reader *r, const ply_reader *p)
{
    char name[EN_DROP_NAME];
    for (size_t i = 0; i < p->nelems; i++) {
        const ply_element *e = &p->elems[i];
        if (e->count == 0)
            continue;
        if (e->kind == ELEM_OTHER) {
            snprintf(name, sizeof name, "element %s", e->name);
            en_reader_drop(r, name, e->count, 1);
            continue;
        }
        for (size_t k = 0; k < e->nprops; k++)
            if (e->props[k].role == ROLE_SKIP) {
                snprintf(name, sizeof name, "%s property %s", e->name, e->props[k].name);
                en_reader_drop(r, name, 0, 0);
            }
    }
}


/* note: some exporters write free text into the header ("Created by ..."),
 * which the format does not allow; robust readers skip such a line, and so
 * does this one, naming it (docs/architecture.md §5). */
static int skip_header_line(epsnet_reader *r, const char *kw)
{
    char name[EN_DROP_NAME];
    snprintf(name, sizeof name, "header line '%.64s'", kw);
    en_reader_drop(r, name, 1, 1);
    return 0;
}

/* A copy of the n bytes of text at *to. */
static int copy_text(epsnet_reader *r, char **to, const char *text, size_t n)
{
    char *c = en_malloc(n + 1);
    if (!c)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    memcpy(c, text, n);
    c[n] = '\0';
    *to = c;
    return 0;
}

/* A header comment: the names of a face label (ply_names), or free text. */
static int header_comment(epsnet_reader *r, ply_reader *p, char *rest)
{
    char *tag = next_token(&rest);
    size_t n;
    if (tag && strcmp(tag, "TextureFile") == 0) {
        /* MeshLab's and Metashape's texture image: its texcoord are read
         * (face_texcoords), the image's name has no place to go */
        const char *file = en_text_trim(rest, &n);
        char name[EN_DROP_NAME];
        snprintf(name, sizeof name, "texture file %.*s (comment TextureFile)", n > 96 ? 96 : (int)n, file);
        en_reader_drop(r, name, 0, 0);
        return 0;
    }
    char *what = tag ? next_token(&rest) : NULL;
    if (!what || strcmp(tag, "epsnet") != 0)
        return 0;
    if (strcmp(what, "mtllib") == 0) {
        en_free(p->names[0].library);
        p->names[0].library = NULL;
        const char *lib = en_text_trim(rest, &n);
        return copy_text(r, &p->names[0].library, lib, n);
    }
    for (int k = 0; k < 2; k++) {
        if (strcmp(what, en_face_label_attr[k]) != 0)
            continue;
        ply_names *l = &p->names[k];
        char *num = next_token(&rest), *end = NULL;
        unsigned long i = num && *num >= '0' && *num <= '9' ? strtoul(num, &end, 10) : ULONG_MAX;
        if (l->out_of_order || !end || *end || i != l->tab.count || i >= EPSNET_FACE_NAMES_MAX) {
            l->out_of_order = 1;
            return 0;
        }
        if (en_grow((void **)&l->names, &l->cap, (size_t)l->tab.count + 1, sizeof *l->names))
            return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
        const char *text = en_text_trim(rest, &n);
        int rc = copy_text(r, &l->names[l->tab.count], text, n);
        if (rc)
            return rc;
        l->tab.names = (const char *const *)l->names;
        l->tab.count++;
    }
    return 0;
}

/* The names the comments gave, as info.materials and info.groups when
 * their property is a face's ushort label (the writer's own, and the
 * OBJ writer's: usemtl and g), else named as dropped. */
static void header_names(epsnet_reader *r, ply_reader *p)
{
    const ply_element *face = NULL;
    for (size_t i = 0; i < p->nelems; i++)
        if (p->elems[i].kind == ELEM_FACE)
            face = &p->elems[i];
    for (int k = 0; k < 2; k++) {
        ply_names *l = &p->names[k];
        l->at = -1;
        if (!l->tab.count && !l->library && !l->out_of_order)
            continue;
        for (size_t j = 0; face && j < face->nprops; j++) {
            const ply_property *pr = &face->props[j];
            if (strcmp(pr->name, en_face_label_attr[k]) == 0 && pr->role == ROLE_LABEL && pr->type == PLY_UINT16)
                l->at = pr->attr_offset;
        }
        char name[EN_DROP_NAME];
        if (l->at < 0 || l->out_of_order) {
            snprintf(name, sizeof name, "header comments naming %s (%s)", en_face_label_attr[k],
                     l->out_of_order ? "not numbered 0, 1, 2, ... in order" : "no face property ushort of that name");
            en_reader_drop(r, name, 0, 0);
            l->at = -1;
            continue;
        }
        l->tab.library = k == 0 ? l->library : NULL;
        *(k ? &r->info.groups : &r->info.materials) = &l->tab;
    }
}

/* A face's labels name a name the comments gave (epsnet.h: names[i]
 * exists before any record with index i). */
static int check_label_names(epsnet_reader *r, const ply_reader *p, uint64_t record)
{
    for (int k = 0; k < 2; k++) {
        if (p->names[k].at < 0)
            continue;
        uint16_t m;
        memcpy(&m, p->attr + p->names[k].at, sizeof m);
        if (m >= p->names[k].tab.count)
            return en_reader_fail(r, EPSNET_EFORMAT,
                                  "face %" PRIu64 ": %s %u has no name (the header's comments name %u)", record + 1,
                                  en_face_label_attr[k], m, p->names[k].tab.count);
    }
    return 0;
}

static int read_header(epsnet_reader *r, ply_reader *p)
{
    char *line;
    size_t len;
    epsnet_error e;
    int seen_format = 0;
    for (uint64_t n = 0;; n++) {
        int rc = en_source_line(r->src, &line, &len, PLY_HEADER_LINE_MAX, &e);
        if (rc < 0)
            return adopt_error(r, &e);
        if (rc == 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "truncated header: no 'end_header' line");
        char *rest = line;
        char *kw = next_token(&rest);
        if (n == 0) {
            if (!kw || strcmp(kw, "ply") != 0 || next_token(&rest))
                return en_reader_fail(r, EPSNET_EFORMAT, "not a PLY file: the first line is not 'ply'");
            continue;
        }
        if (!kw)
            continue;
        if (strcmp(kw, "obj_info") == 0)
            continue;
        if (strcmp(kw, "comment") == 0) {
            if ((rc = header_comment(r, p, rest)))
                return rc;
            continue;
        }
        if (strcmp(kw, "end_header") == 0)
            break;
        if (strcmp(kw, "format") == 0)
            rc = header_format(r, p, rest, &seen_format);
        else if (strcmp(kw, "element") != 0 && strcmp(kw, "property") != 0)
            rc = skip_header_line(r, kw);
        else if (!seen_format)
            rc = en_reader_fail(r, EPSNET_EFORMAT, "'%s' before the 'format' line", kw);
        else if (strcmp(kw, "element") == 0)
            rc = header_element(r, p, rest);
        else
            rc = header_property(r, p, rest);
        if (rc)
            return rc;
    }
    if (!seen_format)
        return en_reader_fail(r, EPSNET_EFORMAT, "header has no 'format' line");
    int rc = header_finish(r, p);
    if (rc == 0) {
        note_dropped(r, p);
        header_names(r, p);
    }
    return rc;
}

/* ------------------------------------------------------------------------
 * Faces: fan triangulation shared by both encodings
 * ------------------------------------------------------------------------ */

typedef struct ply_fan {
    uint64_t first, prev;
    int64_t seen;
    ply_reader *labelled;        /* non-NULL: collect the corners (labelled_face) */
} ply_fan;

static int collect_corner(epsnet_reader *r, ply_reader *p, uint64_t v);

/* Feed one corner; emits (first, prev, v) once three corners are known. */
static inline int fan_corner(epsnet_reader *r, ply_fan *f, uint64_t v)
{
    if (f->labelled)
        return collect_corner(r, f->labelled, v);
    int rc = 0;
    if (f->seen == 0)
        f->first = v;
    else if (f->seen >= 2)
        rc = en_reader_push_triangle(r, f->first, f->prev, v);
    f->prev = v;
    f->seen++;
    return rc;
}

/* ------------------------------------------------------------------------
 * Face labels (see ply_reader.labels): the held vertex block and the
 * records of (vertex, labels)
 * ------------------------------------------------------------------------ */

/* Grow a held table to need elements, keeping all of them within the
 * reader's memory budget (they live until the end of the file). */
static int held_grow(epsnet_reader *r, ply_reader *p, void **buf, size_t *cap, size_t need, size_t elem)
{
    size_t bytes = 0;
    int rc = en_reader_grow_held(r, &p->held_bytes, buf, cap, need, elem, &bytes);
    if (rc == EPSNET_ELIMIT)
        return en_reader_fail(r, EPSNET_ELIMIT,
                              "a PLY with face properties is held in memory until its faces are read: %" PRIu64
                              " vertices and %" PRIu64 " corner records need %zu bytes, over the memory budget of %"
                              PRIu64 " bytes", p->nheld, r->nverts, bytes, r->settings.mem_limit);
    return rc;
}

/* A vertex of the file, held until the faces name it. */
static int hold_vertex(epsnet_reader *r, ply_reader *p, const double xyz[3], const uint8_t *attr)
{
    uint64_t n = p->nheld + 1;
    int rc = held_grow(r, p, (void **)&p->held_xyz, &p->xyz_cap, n, 3 * sizeof(double));
    if (rc == 0 && p->vsize)
        rc = held_grow(r, p, (void **)&p->held_attr, &p->attr_cap, n, p->vsize);
    if (rc == 0)
        rc = held_grow(r, p, (void **)&p->first, &p->first_cap, n, sizeof(uint32_t));
    if (rc)
        return rc;
    memcpy(p->held_xyz + 3 * p->nheld, xyz, 3 * sizeof(double));
    if (p->vsize)
        memcpy(p->held_attr + p->nheld * p->vsize, attr, p->vsize);
    p->first[p->nheld] = 0;
    p->nheld = n;
    return 0;
}

static int collect_corner(epsnet_reader *r, ply_reader *p, uint64_t v)
{
    if (en_grow((void **)&p->corners, &p->corners_cap, p->ncorners + 1, sizeof *p->corners))
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    p->corners[p->ncorners++] = v;
    return 0;
}

/* The record of held vertex v with the current face's labels
 * (p->attr + vsize): found among v's records, or pushed now. */
static int labelled_record(epsnet_reader *r, ply_reader *p, uint64_t v, uint64_t *id)
{
    const uint8_t *label = p->attr + p->vsize;
    for (uint32_t k = p->first[v]; k; k = p->next[k - 1])
        if (memcmp(p->rec_label + (size_t)(k - 1) * p->lsize, label, p->lsize) == 0) {
            *id = k - 1;
            return 0;
        }
    uint64_t n = r->nverts;
    if (n >= UINT32_MAX - 1)
        return en_reader_fail(r, EPSNET_ELIMIT, "more than %u corner records", UINT32_MAX - 2);
    int rc = held_grow(r, p, (void **)&p->next, &p->next_cap, n + 1, sizeof(uint32_t));
    if (rc == 0)
        rc = held_grow(r, p, (void **)&p->rec_label, &p->label_cap, n + 1, p->lsize);
    if (rc)
        return rc;
    if (p->vsize)
        memcpy(p->out, p->held_attr + v * p->vsize, p->vsize);
    memcpy(p->out + p->vsize, label, p->lsize);
    const double *xyz = p->held_xyz + 3 * v;
    if ((rc = en_reader_push_vertex_attr(r, xyz[0], xyz[1], xyz[2], p->out)))
        return rc;
    memcpy(p->rec_label + n * p->lsize, label, p->lsize);
    p->next[n] = p->first[v];
    p->first[v] = (uint32_t)(n + 1);
    *id = n;
    return 0;
}

/* A face of a labelled file, once its whole record is read (a label may
 * come after the index list): its corners become records, then triangles. */
static int labelled_face(epsnet_reader *r, ply_reader *p, uint64_t record)
{
    size_t n = p->ncorners, nuv = p->nfuv;
    p->ncorners = p->nfuv = 0;
    if (n < 3)
        return 0;
    if (check_label_names(r, p, record))
        return r->err.code;
    if (p->uv_at >= 0 && nuv != 2 * n)
        return en_reader_fail(r, EPSNET_EFORMAT, "face %" PRIu64 ": texcoord has %zu values for %zu corners "
                              "(u and v for each)", record + 1, nuv, n);
    ply_fan fan = { 0, 0, 0, NULL };
    for (size_t i = 0; i < n; i++) {
        uint64_t v = p->corners[i], id = 0;
        if (v >= p->nheld)
            return en_reader_fail(r, EPSNET_EFORMAT, "face %" PRIu64 ": vertex index %" PRIu64 " is out of range",
                                  record + 1, v);
        if (p->uv_at >= 0)
            memcpy(p->attr + p->uv_at, p->fuv + 2 * i, 2 * sizeof *p->fuv);
        int rc = labelled_record(r, p, v, &id);
        if (rc == 0)
            rc = fan_corner(r, &fan, id);
        if (rc)
            return rc;
    }
    return 0;
}

/* ------------------------------------------------------------------------
 * Triangle strips shared by both encodings
 * ------------------------------------------------------------------------ */

/* Triangles a binary strip list may push in one fill(): a long list is
 * read in pieces, so the record queue stays small whatever the strip. */
#define PLY_STRIP_BATCH 8192

static int is_strip_restart(ply_type t, int64_t v)
{
    /* note: -1 ends a strip; a list of an unsigned type can only hold -1 as
     * its all-ones pattern, which a writer that casts -1 produces. */
    return v == -1 || (ply_int_min[t] == 0 && v == ply_int_max[t]);
}

/*
 * One index of a `tristrips` list, the strips of the Stanford tools: a list
 * holds strips separated by -1. Counting from a strip's start, triangle i
 * over its indices v[] is (v[i], v[i+1], v[i+2]) for even i and
 * (v[i+1], v[i], v[i+2]) for odd i, so every triangle has the orientation
 * of the first; this is how the Stanford tools unpack strips into faces.
 * at is the index's byte offset, or EPSNET_POS_NONE in an ascii file.
 *
 * note: a strip triangle that repeats an index is how a strip turns or
 * jumps (a swap) and encodes no surface: it is skipped (strip_turns), but it
 * still counts for the parity of the triangles after it. A face element's
 * triangle with a repeated corner is different: the file declares it a face,
 * so it is passed on like any other (docs/architecture.md §5: degenerate faces are legal
 * input, handled and reported downstream). Triangles with distinct indices
 * are passed on whatever their area, like faces.
 */
static int strip_index(epsnet_reader *r, ply_reader *p, const ply_property *pr, int64_t v, uint64_t at)
{
    ply_strip *st = &p->strip;
    if (is_strip_restart(pr->type, v)) {
        st->n = 0;
        return 0;
    }
    if (v < 0 || (uint64_t)v >= r->nverts) {
        static const char neg[] = "tristrips %" PRIu64 ": negative vertex index %" PRId64
                                  " (only -1, which ends a strip, is allowed)";
        static const char big[] = "tristrips %" PRIu64 ": vertex index %" PRId64
                                  " is out of range (%" PRIu64 " vertices)";
        if (at == EPSNET_POS_NONE)
            return v < 0 ? en_reader_fail(r, EPSNET_EFORMAT, neg, p->record + 1, v)
                         : en_reader_fail(r, EPSNET_EFORMAT, big, p->record + 1, v, r->nverts);
        return v < 0 ? en_reader_fail_at(r, EPSNET_EFORMAT, at, neg, p->record + 1, v)
                     : en_reader_fail_at(r, EPSNET_EFORMAT, at, big, p->record + 1, v, r->nverts);
    }
    const uint64_t a = st->a, b = st->b, c = (uint64_t)v;
    int rc = 0;
    if (st->n >= 2) {
        if (a == b || b == c || a == c)
            p->strip_turns++;
        else if (st->n & 1)
            rc = en_reader_push_triangle(r, b, a, c);
        else
            rc = en_reader_push_triangle(r, a, b, c);
    }
    st->a = b;
    st->b = c;
    st->n++;
    return rc;
}

/* ------------------------------------------------------------------------
 * ASCII body: one record per line, as in Turk's original ply.c
 * ------------------------------------------------------------------------ */

static int ascii_record_line(epsnet_reader *r, const ply_element *e, uint64_t record, char **line)
{
    size_t len;
    epsnet_error err;
    for (;;) {
        int rc = en_source_line(r->src, line, &len, (size_t)1 << 20, &err);
        if (rc < 0)
            return adopt_error(r, &err);
        if (rc == 0)
            return en_reader_fail(r, EPSNET_EFORMAT,
                                  "truncated file: %s %" PRIu64 " of %" PRIu64 " is missing",
                                  e->name, record + 1, e->count);
        char *s = *line;
        while (*s == ' ' || *s == '\t' || *s == '\r')
            s++;
        if (*s)
            return 0;
    }
}

static int ascii_bad_value(epsnet_reader *r, const ply_element *e, uint64_t record,
                           const ply_property *pr, const char *tok)
{
    if (!tok)
        return en_reader_fail(r, EPSNET_EFORMAT, "%s %" PRIu64 ": missing value for '%s'",
                              e->name, record + 1, pr->name);
    return en_reader_fail(r, EPSNET_EFORMAT, "%s %" PRIu64 ": '%s' is not a valid %s for '%s'",
                          e->name, record + 1, tok, ply_type_names[pr->type].name, pr->name);
}

/* One value of the face's texcoord list (face_texcoords). */
static int face_uv(epsnet_reader *r, ply_reader *p, double v)
{
    if (en_grow((void **)&p->fuv, &p->fuv_cap, p->nfuv + 1, sizeof *p->fuv))
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    p->fuv[p->nfuv++] = (float)v;
    return 0;
}

static int ascii_list(epsnet_reader *r, ply_reader *p, const ply_element *e, uint64_t record,
                      const ply_property *pr, char **cursor)
{
    char *tok = next_token(cursor);
    int64_t count;
    if (!tok)
        return en_reader_fail(r, EPSNET_EFORMAT, "%s %" PRIu64 ": missing list count for '%s'",
                              e->name, record + 1, pr->name);
    if (parse_int_as(tok, pr->count_type, &count))
        return en_reader_fail(r, EPSNET_EFORMAT, "%s %" PRIu64 ": '%s' is not a valid %s list count",
                              e->name, record + 1, tok, ply_type_names[pr->count_type].name);
    if (count < 0 || count > PLY_MAX_LIST)
        return en_reader_fail(r, EPSNET_EFORMAT, "%s %" PRIu64 ": list count %" PRId64 " is out of range "
                              "(0..%" PRId64 ")", e->name, record + 1, count, PLY_MAX_LIST);
    ply_fan fan = { 0, 0, 0, p->labels ? p : NULL };
    for (int64_t i = 0; i < count; i++) {
        tok = next_token(cursor);
        if (pr->role != ROLE_INDICES) {
            double value;
            if (!tok || parse_real_as(tok, pr->type, &value))
                return ascii_bad_value(r, e, record, pr, tok);
            if (pr->role == ROLE_TEXCOORD && face_uv(r, p, value))
                return r->err.code;
            continue;
        }
        int64_t v;
        if (!tok || parse_int_as(tok, pr->type, &v))
            return ascii_bad_value(r, e, record, pr, tok);
        if (v < 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "face %" PRIu64 ": negative vertex index %" PRId64,
                                  record + 1, v);
        int rc = fan_corner(r, &fan, (uint64_t)v);
        if (rc)
            return rc;
    }
    if (pr->role == ROLE_INDICES && count < 3)
        p->short_polygons++;
    return 0;
}

/*
 * Strip records in ascii, resumable like binary_strips(): a Stanford file
 * holds every strip in one record, one line that can be far longer than a
 * line buffer, so its tokens are read straight from the source window and
 * the line is never held whole. Lines are counted here as en_source_line()
 * counts them, so errors name the record's line.
 */
static int line_blank(int c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

/* Next byte of the window without taking it; -1 at the end of input, -2
 * on a read error (recorded in r). */
static int peek_byte(epsnet_reader *r)
{
    en_source *s = r->src;
    if (s->cur == s->end && en_source_fill(s, 1) == 0)
        return s->failed ? (source_failure(r), -2) : -1;
    return *s->cur;
}

/* Next token of the current line into buf: 1, 0 at the end of the line
 * (the newline is not taken), or a negative code. */
static int stream_token(epsnet_reader *r, const ply_reader *p, const ply_element *e, char *buf, size_t cap)
{
    en_source *s = r->src;
    int c;
    while ((c = peek_byte(r)) >= 0 && line_blank(c))
        s->cur++;
    if (c == -2)
        return r->err.code;
    if (c < 0 || c == '\n')
        return 0;
    size_t n = 0;
    while ((c = peek_byte(r)) >= 0 && c != '\n' && !line_blank(c)) {
        if (c == 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "NUL byte in a text line");
        if (n == cap - 1)
            return en_reader_fail(r, EPSNET_EFORMAT, "%s %" PRIu64 ": a value longer than %zu bytes", e->name,
                                  p->record + 1, cap - 1);
        buf[n++] = (char)c;
        s->cur++;
    }
    if (c == -2)
        return r->err.code;
    buf[n] = '\0';
    return 1;
}

static int ascii_strips(epsnet_reader *r, ply_reader *p, ply_element *e, uint64_t n)
{
    en_source *s = r->src;
    ply_strip *st = &p->strip;
    const uint64_t start = r->ntris;
    char tok[128];
    int rc, c;
    for (; n; n--, p->record++, st->prop = 0, st->in_line = 0) {
        if (!st->in_line) {
            /* blank lines between records are skipped, as ascii_record_line() does */
            for (;;) {
                while ((c = peek_byte(r)) >= 0 && line_blank(c))
                    s->cur++;
                if (c == -2)
                    return r->err.code;
                if (c < 0)
                    return en_reader_fail(r, EPSNET_EFORMAT, "truncated file: %s %" PRIu64 " of %" PRIu64
                                          " is missing", e->name, p->record + 1, e->count);
                s->lineno++;
                if (c != '\n')
                    break;
                s->cur++;
            }
            st->in_line = 1;
        }
        for (; st->prop < e->nprops; st->prop++) {
            const ply_property *pr = &e->props[st->prop];
            if (pr->count_type == PLY_NONE || st->left < 0) {
                if ((rc = stream_token(r, p, e, tok, sizeof tok)) < 0)
                    return rc;
                const char *t = rc ? tok : NULL;
                if (pr->count_type == PLY_NONE) {
                    double ignored;
                    if (!t || parse_real_as(t, pr->type, &ignored))
                        return ascii_bad_value(r, e, p->record, pr, t);
                    continue;
                }
                int64_t count;
                if (!t)
                    return en_reader_fail(r, EPSNET_EFORMAT, "%s %" PRIu64 ": missing list count for '%s'",
                                          e->name, p->record + 1, pr->name);
                if (parse_int_as(t, pr->count_type, &count) || count < 0 ||
                    (pr->role != ROLE_INDICES && count > PLY_MAX_LIST))
                    return en_reader_fail(r, EPSNET_EFORMAT, "%s %" PRIu64 ": '%s' is not a valid %s list count",
                                          e->name, p->record + 1, t, ply_type_names[pr->count_type].name);
                st->left = count;
                st->n = 0;
            }
            for (; st->left > 0; st->left--) {
                if (r->ntris - start >= PLY_STRIP_BATCH)
                    return 0;
                if ((rc = stream_token(r, p, e, tok, sizeof tok)) < 0)
                    return rc;
                const char *t = rc ? tok : NULL;
                if (pr->role != ROLE_INDICES) {
                    double ignored;
                    if (!t || parse_real_as(t, pr->type, &ignored))
                        return ascii_bad_value(r, e, p->record, pr, t);
                    continue;
                }
                int64_t v;
                if (!t || parse_int_as(t, pr->type, &v))
                    return ascii_bad_value(r, e, p->record, pr, t);
                if ((rc = strip_index(r, p, pr, v, EPSNET_POS_NONE)))
                    return rc;
            }
            st->left = -1;
        }
        if ((rc = stream_token(r, p, e, tok, sizeof tok)) < 0)
            return rc;
        if (rc)
            return en_reader_fail(r, EPSNET_EFORMAT, "%s %" PRIu64 ": unexpected extra value '%s'",
                                  e->name, p->record + 1, tok);
        if (peek_byte(r) == '\n')
            r->src->cur++;
    }
    return 0;
}

/* An attribute's value from its (already validated) token, in host order.
 * note: float32 goes through strtof, not a double, so the bits are the
 * nearest float to the text, as a float reader would give them. */
static void ascii_attr(uint8_t *dst, ply_type t, const char *tok, double v)
{
    switch (t) {
    case PLY_INT8: { int8_t x = (int8_t)v; memcpy(dst, &x, 1); break; }
    case PLY_UINT8: { uint8_t x = (uint8_t)v; memcpy(dst, &x, 1); break; }
    case PLY_INT16: { int16_t x = (int16_t)v; memcpy(dst, &x, 2); break; }
    case PLY_UINT16: { uint16_t x = (uint16_t)v; memcpy(dst, &x, 2); break; }
    case PLY_INT32: { int32_t x = (int32_t)v; memcpy(dst, &x, 4); break; }
    case PLY_UINT32: { uint32_t x = (uint32_t)v; memcpy(dst, &x, 4); break; }
    case PLY_FLOAT32: { float x = strtof(tok, NULL); memcpy(dst, &x, 4); break; }
    case PLY_FLOAT64: { double x = strtod(tok, NULL); memcpy(dst, &x, 8); break; }
    default: break;
    }
}

/* An attribute's file bytes in host order. */
static void binary_attr(uint8_t *dst, const uint8_t *src, size_t size, int swap)
{
    if (!swap) {
        memcpy(dst, src, size);
        return;
    }
    for (size_t i = 0; i < size; i++)
        dst[i] = src[size - 1 - i];
}

static int vertex_checked(epsnet_reader *r, ply_reader *p, uint64_t offset, const double xyz[3]);

static int ascii_records(epsnet_reader *r, ply_reader *p, ply_element *e, uint64_t n)
{
    if (e->kind == ELEM_STRIPS)
        return ascii_strips(r, p, e, n);
    for (uint64_t i = 0; i < n; i++, p->record++) {
        char *line;
        int rc = ascii_record_line(r, e, p->record, &line);
        if (rc)
            return rc;
        double xyz[3] = { 0, 0, 0 };
        for (size_t k = 0; k < e->nprops; k++) {
            const ply_property *pr = &e->props[k];
            if (pr->count_type != PLY_NONE) {
                if ((rc = ascii_list(r, p, e, p->record, pr, &line)))
                    return rc;
                continue;
            }
            char *tok = next_token(&line);
            double v;
            if (!tok || parse_real_as(tok, pr->type, &v))
                return ascii_bad_value(r, e, p->record, pr, tok);
            if (pr->role >= ROLE_X && pr->role <= ROLE_Z)
                xyz[pr->role] = v;
            else if (pr->role == ROLE_ATTR || pr->role == ROLE_LABEL)
                ascii_attr(p->attr + pr->attr_offset, pr->type, tok, v);
        }
        char *extra = next_token(&line);
        if (extra)
            return en_reader_fail(r, EPSNET_EFORMAT, "%s %" PRIu64 ": unexpected extra value '%s'",
                                  e->name, p->record + 1, extra);
        if (e->kind == ELEM_VERTEX)
            rc = p->labels ? vertex_checked(r, p, EPSNET_POS_NONE, xyz)
                           : en_reader_push_vertex_attr(r, xyz[0], xyz[1], xyz[2], p->attr);
        else if (e->kind == ELEM_FACE && p->labels)
            rc = labelled_face(r, p, p->record);
        if (rc)
            return rc;
    }
    return 0;
}

/* ------------------------------------------------------------------------
 * Binary body: decoders from the codec table, straight out of the window
 * ------------------------------------------------------------------------ */

/* A vertex with its attributes in p->attr: pushed, or held when the faces
 * carry labels. offset: its byte offset, EPSNET_POS_NONE in ascii. */
static int vertex_checked(epsnet_reader *r, ply_reader *p, uint64_t offset, const double xyz[3])
{
    uint64_t number = (p->labels ? p->nheld : r->nverts) + 1;
    if (!isfinite(xyz[0]) || !isfinite(xyz[1]) || !isfinite(xyz[2])) {
        if (offset == EPSNET_POS_NONE)
            return en_reader_fail(r, EPSNET_EFORMAT, "vertex %" PRIu64 " has a non-finite coordinate (%g %g %g)",
                                  number, xyz[0], xyz[1], xyz[2]);
        return en_reader_fail_at(r, EPSNET_EFORMAT, offset,
                                 "vertex %" PRIu64 " has a non-finite coordinate (%g %g %g)",
                                 number, xyz[0], xyz[1], xyz[2]);
    }
    if (p->labels)
        return hold_vertex(r, p, xyz, p->attr);
    return en_reader_push_vertex_attr(r, xyz[0], xyz[1], xyz[2], p->attr);
}

/* Where a fixed-size vertex record's coordinates and attributes are, and
 * their decoders. */
typedef struct vertex_layout {
    size_t offset[3];
    double (*get[3])(const uint8_t *);
    struct { size_t from, to, size; } attrs[EPSNET_ATTR_MAX];
    size_t na;
} vertex_layout;

static void vertex_layout_of(const ply_element *e, const ply_codec *codec, vertex_layout *l)
{
    memset(l, 0, sizeof *l);
    size_t at = 0;
    for (size_t k = 0; k < e->nprops; k++) {
        const ply_property *pr = &e->props[k];
        if (pr->role >= ROLE_X && pr->role <= ROLE_Z) {
            l->offset[pr->role] = at;
            l->get[pr->role] = codec->get_real[pr->type];
        } else if (pr->role == ROLE_ATTR && l->na < EPSNET_ATTR_MAX) {
            l->attrs[l->na].from = at;
            l->attrs[l->na].to = pr->attr_offset;
            l->attrs[l->na++].size = ply_type_size[pr->type];
        }
        at += ply_type_size[pr->type];
    }
}

/* Vertices whose records have a fixed size: the common scanner layout. */
static int binary_fixed_vertices(epsnet_reader *r, ply_reader *p, ply_element *e, uint64_t n)
{
    en_source *s = r->src;
    const size_t size = e->fixed_size;
    vertex_layout l;
    vertex_layout_of(e, p->codec, &l);
    while (n) {
        size_t want = n < PLY_CHUNK / size ? (size_t)n : PLY_CHUNK / size;
        if (want == 0)
            want = 1;
        const uint8_t *base = need(s, size * want);
        size_t k = want;
        if (!base) {
            k = (size_t)(s->end - s->cur) / size;
            if (k == 0)
                return truncated_binary(r, e, p->record);
            base = s->cur;
        }
        for (size_t i = 0; i < k; i++) {
            const uint8_t *rec = base + i * size;
            double xyz[3] = { l.get[0](rec + l.offset[0]), l.get[1](rec + l.offset[1]), l.get[2](rec + l.offset[2]) };
            for (size_t a = 0; a < l.na; a++)
                binary_attr(p->attr + l.attrs[a].to, rec + l.attrs[a].from, l.attrs[a].size, p->swap);
            s->cur = rec;
            int rc = vertex_checked(r, p, en_source_offset(s), xyz);
            if (rc)
                return rc;
        }
        s->cur = base + k * size;
        p->record += k;
        n -= k;
    }
    return 0;
}

/* Records of an element we do not use and whose size is fixed. */
static int binary_skip_fixed(epsnet_reader *r, ply_reader *p, ply_element *e, uint64_t n)
{
    en_source *s = r->src;
    while (n) {
        size_t want = n < PLY_CHUNK / e->fixed_size ? (size_t)n : PLY_CHUNK / e->fixed_size;
        if (want == 0)
            want = 1;
        size_t avail = (size_t)(s->end - s->cur);
        if (avail < e->fixed_size * want)
            avail = en_source_fill(s, e->fixed_size * want);
        size_t k = avail / e->fixed_size;
        if (k > want)
            k = want;
        if (k == 0)
            return truncated_binary(r, e, p->record);
        s->cur += k * e->fixed_size;
        p->record += k;
        n -= k;
    }
    return 0;
}

/* Items of a list, in pieces that fit the source window. */
static int binary_list_items(epsnet_reader *r, ply_reader *p, const ply_element *e,
                             const ply_property *pr, int64_t count, ply_fan *fan)
{
    en_source *s = r->src;
    const size_t isize = ply_type_size[pr->type];
    int64_t (*get)(const uint8_t *) = p->codec->get_int[pr->type];
    const uint64_t nverts = p->labels ? p->nheld : r->nverts;
    while (count > 0) {
        size_t k = count < (int64_t)(PLY_CHUNK / isize) ? (size_t)count : PLY_CHUNK / isize;
        const uint8_t *q = need(s, k * isize);
        if (!q)
            return truncated_binary(r, e, p->record);
        for (size_t i = 0; i < k && pr->role == ROLE_TEXCOORD; i++)
            if (face_uv(r, p, p->codec->get_real[pr->type](q + i * isize)))
                return r->err.code;
        if (pr->role == ROLE_INDICES) {
            for (size_t i = 0; i < k; i++) {
                int64_t v = get(q + i * isize);
                if (v < 0 || (uint64_t)v >= nverts)
                    return en_reader_fail_at(r, EPSNET_EFORMAT, en_source_offset(s) + i * isize,
                                             v < 0 ? "face %" PRIu64 ": negative vertex index %" PRId64
                                                   : "face %" PRIu64 ": vertex index %" PRId64
                                                     " is out of range",
                                             p->record + 1, v);
                int rc = fan_corner(r, fan, (uint64_t)v);
                if (rc)
                    return rc;
            }
        }
        s->cur += k * isize;
        count -= (int64_t)k;
    }
    return 0;
}

/* Any record, property by property (lists make the size vary). */
static int binary_record(epsnet_reader *r, ply_reader *p, ply_element *e)
{
    en_source *s = r->src;
    uint64_t start = en_source_offset(s);
    double xyz[3] = { 0, 0, 0 };
    for (size_t k = 0; k < e->nprops; k++) {
        const ply_property *pr = &e->props[k];
        if (pr->count_type == PLY_NONE) {
            size_t size = ply_type_size[pr->type];
            const uint8_t *q = need(s, size);
            if (!q)
                return truncated_binary(r, e, p->record);
            if (pr->role >= ROLE_X && pr->role <= ROLE_Z)
                xyz[pr->role] = p->codec->get_real[pr->type](q);
            else if (pr->role == ROLE_ATTR || pr->role == ROLE_LABEL)
                binary_attr(p->attr + pr->attr_offset, q, size, p->swap);
            s->cur += size;
            continue;
        }
        size_t csize = ply_type_size[pr->count_type];
        const uint8_t *q = need(s, csize);
        if (!q)
            return truncated_binary(r, e, p->record);
        int64_t count = p->codec->get_int[pr->count_type](q);
        if (count < 0 || count > PLY_MAX_LIST)
            return en_reader_fail_at(r, EPSNET_EFORMAT, en_source_offset(s),
                                     "%s %" PRIu64 ": list count %" PRId64 " is out of range (0..%" PRId64 ")",
                                     e->name, p->record + 1, count, PLY_MAX_LIST);
        s->cur += csize;
        ply_fan fan = { 0, 0, 0, p->labels ? p : NULL };
        int rc = binary_list_items(r, p, e, pr, count, &fan);
        if (rc)
            return rc;
        if (pr->role == ROLE_INDICES && count < 3)
            p->short_polygons++;
    }
    if (e->kind == ELEM_VERTEX)
        return vertex_checked(r, p, start, xyz);
    if (e->kind == ELEM_FACE && p->labels)
        return labelled_face(r, p, p->record);
    return 0;
}

/* A face element of one list (has_one_list), its records read whole: the
 * list, the fixed bytes before and after it, its count's and items' sizes
 * and decoders, and the longest list a read window holds (longer ones go
 * to the general walker, binary_record). */
typedef struct face_shape {
    const ply_property *list;
    size_t before, after, csize, isize;
    int64_t (*get_count)(const uint8_t *);
    int64_t (*get_index)(const uint8_t *);
    int64_t window_items;
} face_shape;

static void face_shape_of(const ply_element *e, const ply_codec *codec, face_shape *f)
{
    memset(f, 0, sizeof *f);
    for (size_t k = 0; k < e->nprops; k++) {
        if (e->props[k].count_type != PLY_NONE)
            f->list = &e->props[k];
        else
            *(f->list ? &f->after : &f->before) += ply_type_size[e->props[k].type];
    }
    f->csize = ply_type_size[f->list->count_type];
    f->isize = ply_type_size[f->list->type];
    f->get_count = codec->get_int[f->list->count_type];
    f->get_index = codec->get_int[f->list->type];
    f->window_items = (int64_t)((PLY_CHUNK - f->before - f->csize - f->after) / f->isize);
}

/*
 * Faces whose only list is the index list, between fixed-size properties:
 * every face writer we know of. The whole record is checked out of the
 * window at once; fan triangulation and range checks as in binary_record().
 */
static int binary_simple_faces(epsnet_reader *r, ply_reader *p, ply_element *e, uint64_t n)
{
    en_source *s = r->src;
    face_shape f;
    face_shape_of(e, p->codec, &f);
    const size_t before = f.before, after = f.after, csize = f.csize, isize = f.isize;
    for (uint64_t i = 0; i < n; i++, p->record++) {
        const uint8_t *q = need(s, before + csize);
        if (!q)
            return truncated_binary(r, e, p->record);
        int64_t count = f.get_count(q + before);
        if (count < 0 || count > f.window_items) {
            /* absurd, or too long for one window: the general walker
             * reports or handles it */
            int rc = binary_record(r, p, e);
            if (rc)
                return rc;
            continue;
        }
        size_t size = before + csize + (size_t)count * isize + after;
        if (!(q = need(s, size)))
            return truncated_binary(r, e, p->record);
        const uint8_t *items = q + before + csize;
        ply_fan fan = { 0, 0, 0, NULL };
        for (int64_t k = 0; k < count; k++) {
            int64_t v = f.get_index(items + k * (int64_t)isize);
            if (v < 0 || (uint64_t)v >= r->nverts)
                return en_reader_fail_at(r, EPSNET_EFORMAT,
                                         en_source_offset(s) + before + csize + (uint64_t)k * isize,
                                         v < 0 ? "face %" PRIu64 ": negative vertex index %" PRId64
                                               : "face %" PRIu64 ": vertex index %" PRId64 " is out of range",
                                         p->record + 1, v);
            int rc = fan_corner(r, &fan, (uint64_t)v);
            if (rc)
                return rc;
        }
        if (count < 3)
            p->short_polygons++;
        s->cur += size;
    }
    return 0;
}

/*
 * Strip records, resumable: a list is read in window-sized pieces and the
 * walk returns once PLY_STRIP_BATCH triangles are queued, to carry on from
 * p->strip at the next call. Other properties are skipped.
 */
static int binary_strips(epsnet_reader *r, ply_reader *p, ply_element *e, uint64_t n)
{
    en_source *s = r->src;
    ply_strip *st = &p->strip;
    const uint64_t start = r->ntris;
    for (; n; n--, p->record++, st->prop = 0) {
        for (; st->prop < e->nprops; st->prop++) {
            const ply_property *pr = &e->props[st->prop];
            const size_t isize = ply_type_size[pr->type];
            if (pr->count_type == PLY_NONE) {
                if (!need(s, isize))
                    return truncated_binary(r, e, p->record);
                s->cur += isize;
                continue;
            }
            if (st->left < 0) {
                const size_t csize = ply_type_size[pr->count_type];
                const uint8_t *q = need(s, csize);
                if (!q)
                    return truncated_binary(r, e, p->record);
                int64_t count = p->codec->get_int[pr->count_type](q);
                /* note: the index list has no length limit but its type's:
                 * it streams, and a lying count ends as a truncated file. */
                if (count < 0 || (pr->role != ROLE_INDICES && count > PLY_MAX_LIST))
                    return en_reader_fail_at(r, EPSNET_EFORMAT, en_source_offset(s),
                                             "%s %" PRIu64 ": list count %" PRId64 " is out of range",
                                             e->name, p->record + 1, count);
                s->cur += csize;
                st->left = count;
                st->n = 0;
            }
            int64_t (*get)(const uint8_t *) = p->codec->get_int[pr->type];
            while (st->left > 0) {
                size_t k = st->left < (int64_t)(PLY_CHUNK / isize) ? (size_t)st->left : PLY_CHUNK / isize;
                const uint8_t *q = need(s, k * isize);
                if (!q)
                    return truncated_binary(r, e, p->record);
                if (pr->role == ROLE_INDICES) {
                    const uint64_t at = en_source_offset(s);
                    for (size_t i = 0; i < k; i++) {
                        int rc = strip_index(r, p, pr, get(q + i * isize), at + i * isize);
                        if (rc)
                            return rc;
                        if (r->ntris - start >= PLY_STRIP_BATCH && i + 1 < (size_t)st->left) {
                            s->cur += (i + 1) * isize;
                            st->left -= (int64_t)(i + 1);
                            return 0;
                        }
                    }
                }
                s->cur += k * isize;
                st->left -= (int64_t)k;
            }
            st->left = -1;
        }
    }
    return 0;
}

static int has_one_list(const ply_element *e)
{
    size_t lists = 0;
    for (size_t k = 0; k < e->nprops; k++)
        lists += e->props[k].count_type != PLY_NONE;
    return lists == 1;
}

static int binary_records(epsnet_reader *r, ply_reader *p, ply_element *e, uint64_t n)
{
    if (e->fixed_size && e->kind == ELEM_VERTEX)
        return binary_fixed_vertices(r, p, e, n);
    if (e->fixed_size && e->kind == ELEM_OTHER)
        return binary_skip_fixed(r, p, e, n);
    if (e->kind == ELEM_STRIPS)
        return binary_strips(r, p, e, n);
    if (e->kind == ELEM_FACE && has_one_list(e) && !p->labels)
        return binary_simple_faces(r, p, e, n);
    for (uint64_t i = 0; i < n; i++) {
        int rc = binary_record(r, p, e);
        if (rc)
            return rc;
        p->record++;
    }
    return 0;
}

/* ------------------------------------------------------------------------
 * End of data
 * ------------------------------------------------------------------------ */

static int is_blank(uint8_t c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}

/* note: whitespace after the last element is tolerated (some writers end
 * binary files with a newline); anything else means the counts lied. */
static int check_trailing(epsnet_reader *r, const ply_reader *p)
{
    en_source *s = r->src;
    if (p->encoding == ENC_ASCII) {
        char *line;
        size_t len;
        epsnet_error e;
        for (;;) {
            int rc = en_source_line(s, &line, &len, (size_t)1 << 20, &e);
            if (rc < 0)
                return adopt_error(r, &e);
            if (rc == 0)
                return 0;
            for (size_t i = 0; i < len; i++)
                if (!is_blank((uint8_t)line[i]))
                    return en_reader_fail(r, EPSNET_EFORMAT,
                                          "trailing data after the last element (do the header counts lie?)");
        }
    }
    for (;;) {
        size_t avail = en_source_fill(s, PLY_CHUNK);
        if (avail == 0)
            return s->failed ? source_failure(r) : 0;
        for (size_t i = 0; i < avail; i++)
            if (!is_blank(s->cur[i]))
                return en_reader_fail_at(r, EPSNET_EFORMAT, en_source_offset(s) + i,
                                         "trailing data after the last element (do the header counts lie?)");
        s->cur += avail;
    }
}

/* ------------------------------------------------------------------------
 * Decoding ahead on the pool (ply_use_pool)
 *
 * A binary file's vertex records of a fixed size and its faces of one index
 * list are cut by the caller's thread into runs of whole records, copied
 * out of the source window, and decoded into records on the workers
 * (docs/architecture.md §10): on the caller's thread that parsing was most
 * of the sort's first pass of a shuffled 20M-face PLY, the second core 40%
 * idle (bench/RESULTS.md, session 39). Runs are handed out in the order cut. A
 * worker checks what the one-thread walkers check (finite coordinates,
 * indices in range) and stops at the first failure, which the caller
 * raises once the records before it are out, with the walkers' message and
 * offset. Anything else (another element, a list too long for a window, the
 * end of the data, no memory) stops the cutting where it stands, and the
 * walkers go on from there once the runs in flight are out: they meet it
 * as they always did.
 * ------------------------------------------------------------------------ */

#define AHEAD_RECORDS 16384           /* records a run makes, at most (one polygon may make more) */

typedef struct ply_job {
    /* The caller's, written before submit: */
    const ply_element *e;
    const ply_codec *codec;
    int swap;
    uint32_t asz;                     /* a vertex's packed attribute bytes (file_attrs) */
    uint64_t first;                   /* the element's index of the run's first record */
    uint64_t nrecords;                /* records of the element in buf */
    uint64_t offset;                  /* of buf[0] in the file */
    uint64_t nverts;                  /* vertices before the run */
    uint8_t *buf;
    size_t cap;
    epsnet_record *recs;              /* sized by the caller, filled by the worker */
    size_t recs_cap;
    uint8_t *attrs;
    size_t attrs_cap;
    /* The worker's, read after retire: */
    size_t nrecs;
    uint64_t short_polygons;
    int bad;                          /* after nrecs records: why, at bad_offset */
    uint64_t bad_offset;
    char why[160];
} ply_job;

/* Whether e's records may be decoded ahead: the vertices of a fixed size
 * whose attributes fill the packed bytes (so that no byte is a record's
 * left over, as in binary_fixed_vertices), and the faces of one integer
 * index list (binary_simple_faces); never with face labels. */
static int ahead_takes(const epsnet_reader *r, const ply_reader *p, const ply_element *e)
{
    if (p->encoding == ENC_ASCII || p->labels)
        return 0;
    if (e->kind == ELEM_VERTEX && e->fixed_size) {
        size_t bytes = 0, n = 0;
        for (size_t k = 0; k < e->nprops; k++)
            if (e->props[k].role == ROLE_ATTR) {
                bytes += ply_type_size[e->props[k].type];
                n++;
            }
        return n <= EPSNET_ATTR_MAX && bytes == r->file_attrs.size;
    }
    if (e->kind != ELEM_FACE || e->fixed_size || !has_one_list(e))
        return 0;
    face_shape f;
    face_shape_of(e, p->codec, &f);
    return f.list->role == ROLE_INDICES && f.get_index && f.get_count;
}

static void run_failed(ply_job *j, uint64_t offset, const char *fmt, ...) EN_PRINTF(3, 4);
static void run_failed(ply_job *j, uint64_t offset, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(j->why, sizeof j->why, fmt, ap);
    va_end(ap);
    j->bad = 1;
    j->bad_offset = offset;
}

static void decode_vertices(ply_job *j)
{
    const size_t size = j->e->fixed_size;
    vertex_layout l;
    vertex_layout_of(j->e, j->codec, &l);
    for (size_t i = 0; i < j->nrecords; i++) {
        const uint8_t *rec = j->buf + i * size;
        double xyz[3] = { l.get[0](rec + l.offset[0]), l.get[1](rec + l.offset[1]), l.get[2](rec + l.offset[2]) };
        if (!isfinite(xyz[0]) || !isfinite(xyz[1]) || !isfinite(xyz[2])) {
            run_failed(j, j->offset + i * size, "vertex %" PRIu64 " has a non-finite coordinate (%g %g %g)",
                       j->nverts + i + 1, xyz[0], xyz[1], xyz[2]);
            return;
        }
        uint8_t *a = j->asz ? j->attrs + i * j->asz : NULL;
        for (size_t k = 0; k < l.na; k++)
            binary_attr(a + l.attrs[k].to, rec + l.attrs[k].from, l.attrs[k].size, j->swap);
        j->recs[j->nrecs++] = (epsnet_record){ .kind = EPSNET_REC_VERTEX, .xyz = { xyz[0], xyz[1], xyz[2] }, .attr = a };
    }
}

static void decode_faces(ply_job *j)
{
    face_shape f;
    face_shape_of(j->e, j->codec, &f);
    const size_t before = f.before, after = f.after, csize = f.csize, isize = f.isize;
    size_t pos = 0;
    for (uint64_t i = 0; i < j->nrecords; i++) {
        const uint8_t *q = j->buf + pos;
        int64_t count = f.get_count(q + before);
        const uint8_t *items = q + before + csize;
        uint64_t first = 0, prev = 0;
        for (int64_t k = 0; k < count; k++) {
            int64_t v = f.get_index(items + k * (int64_t)isize);
            if (v < 0 || (uint64_t)v >= j->nverts) {
                run_failed(j, j->offset + pos + before + csize + (uint64_t)k * isize,
                           v < 0 ? "face %" PRIu64 ": negative vertex index %" PRId64
                                 : "face %" PRIu64 ": vertex index %" PRId64 " is out of range",
                           j->first + i + 1, v);
                return;
            }
            /* a fan, as fan_corner makes it */
            if (k == 0)
                first = (uint64_t)v;
            else if (k >= 2)
                j->recs[j->nrecs++] =
                    (epsnet_record){ .kind = EPSNET_REC_TRIANGLE, .v = { first, prev, (uint64_t)v } };
            prev = (uint64_t)v;
        }
        j->short_polygons += count < 3;
        pos += before + csize + (size_t)count * isize + after;
    }
}

static int decode_run(void *job)
{
    ply_job *j = job;
    if (j->e->kind == ELEM_VERTEX)
        decode_vertices(j);
    else
        decode_faces(j);
    return 0;
}

static size_t job_bytes(const ply_job *j)
{
    return j->cap + j->recs_cap * sizeof *j->recs + j->attrs_cap;
}

/* Whether the slots may grow by `more` bytes: the runs in flight hold at
 * most a quarter of the reader's budget (docs/architecture.md §12), one
 * run whatever it needs. Over it the cutting waits for runs to be handed
 * out. */
static int ahead_room(const epsnet_reader *r, const ply_reader *p, size_t more)
{
    uint64_t limit = r->settings.mem_limit;
    return !limit || en_jobring_in_flight(p->ring) == 0 || p->ahead_bytes + more <= limit / 4;
}

/* Cut the next run of e, from the record p->record on, out of the source
 * window into a free slot, and submit it. @return 1, or 0 when nothing was
 * cut: it waits for room (ahead_room), or the walkers take it from here
 * (ahead_stop). */
static int cut_run(epsnet_reader *r, ply_reader *p, const ply_element *e)
{
    en_source *s = r->src;
    ply_job *j = &p->jobs[p->submitted % p->njobs];
    size_t avail = en_source_fill(s, PLY_CHUNK);
    uint64_t left = e->count - p->record;
    size_t bytes = 0, nrec = 0, nout = 0;
    if (s->failed)
        avail = 0;
    if (e->kind == ELEM_VERTEX) {
        nrec = avail / e->fixed_size;
        nrec = nrec < left ? nrec : (size_t)left;
        nrec = nrec < AHEAD_RECORDS ? nrec : AHEAD_RECORDS;
        bytes = nrec * e->fixed_size;
        nout = nrec;
    } else {
        face_shape f;
        face_shape_of(e, p->codec, &f);
        while (nrec < left && nout < AHEAD_RECORDS && bytes + f.before + f.csize <= avail) {
            int64_t count = f.get_count(s->cur + bytes + f.before);
            if (count < 0 || count > f.window_items) {
                p->ahead_stop = 1; /* as binary_simple_faces: the general walker's */
                break;
            }
            size_t size = f.before + f.csize + (size_t)count * f.isize + f.after;
            if (bytes + size > avail)
                break;
            bytes += size;
            nrec++;
            nout += count > 2 ? (size_t)count - 2 : 0;
        }
    }
    size_t asz = e->kind == ELEM_VERTEX ? r->file_attrs.size : 0, before = job_bytes(j);
    size_t need = bytes + (nout ? nout : 1) * sizeof *j->recs + nrec * asz;
    if (nrec && need > before && !ahead_room(r, p, need - before))
        return 0;
    int grown = nrec && !en_grow((void **)&j->buf, &j->cap, bytes, 1) &&
                !en_grow((void **)&j->recs, &j->recs_cap, nout ? nout : 1, sizeof *j->recs) &&
                !(asz && en_grow((void **)&j->attrs, &j->attrs_cap, nrec * asz, 1));
    p->ahead_bytes += job_bytes(j) - before;
    if (!grown) {
        p->ahead_stop = 1;
        return 0;
    }
    memcpy(j->buf, s->cur, bytes);
    j->e = e;
    j->codec = p->codec;
    j->swap = p->swap;
    j->asz = r->file_attrs.size;
    j->first = p->record;
    j->nrecords = nrec;
    j->offset = en_source_offset(s);
    j->nverts = r->nverts + p->ahead_vertices;
    j->nrecs = 0;
    j->short_polygons = 0;
    j->bad = 0;
    if (en_jobring_submit(p->ring, decode_run, j)) {
        p->ahead_stop = 1; /* cannot happen: the ring had room */
        return 0;
    }
    s->cur += bytes;
    p->record += nrec;
    if (e->kind == ELEM_VERTEX)
        p->ahead_vertices += nrec;
    p->submitted++;
    return 1;
}

/* Cut runs while the ring has room, the current run's slot left alone. */
static void cut_ahead(epsnet_reader *r, ply_reader *p)
{
    while (!p->ahead_stop && !en_jobring_full(p->ring) && en_jobring_in_flight(p->ring) + 1 < p->njobs) {
        while (p->elem < p->nelems && (p->record == p->elems[p->elem].count || p->elems[p->elem].nprops == 0)) {
            p->elem++;
            p->record = 0;
        }
        if (p->elem == p->nelems || !ahead_takes(r, p, &p->elems[p->elem]) ||
            !cut_run(r, p, &p->elems[p->elem]))
            return;
    }
}

/* The current run, or the next one decoded. @return 1 with p->cur set, 0
 * when none is in flight (the walkers' turn), or the failure a run met
 * once its records are out. */
static int current_run(epsnet_reader *r, ply_reader *p)
{
    for (;;) {
        ply_job *j = p->cur;
        if (j && p->cur_pos < j->nrecs)
            return 1;
        if (j && j->bad) {
            j->bad = 0;
            return en_reader_fail_at(r, EPSNET_EFORMAT, j->bad_offset, "%s", j->why);
        }
        p->cur = NULL;
        cut_ahead(r, p);
        void *job;
        int result;
        if (!en_jobring_retire(p->ring, &job, &result))
            return 0;
        p->cur = job;
        p->cur_pos = 0;
        p->short_polygons += p->cur->short_polygons;
        cut_ahead(r, p); /* the next ones decode while this one is handed out */
    }
}

/* ply_fill's part with runs ahead: up to PLY_BATCH records of the current
 * run into the queue. @return 1, 0 with no run (the walkers'), or an error. */
static int fill_ahead(epsnet_reader *r, ply_reader *p)
{
    int rc = current_run(r, p);
    if (rc <= 0)
        return rc;
    ply_job *j = p->cur;
    size_t end = j->nrecs - p->cur_pos < PLY_BATCH ? j->nrecs : p->cur_pos + PLY_BATCH;
    for (; p->cur_pos < end; p->cur_pos++) {
        const epsnet_record *rec = &j->recs[p->cur_pos];
        if (rec->kind == EPSNET_REC_VERTEX) {
            rc = en_reader_push_vertex_attr(r, rec->xyz[0], rec->xyz[1], rec->xyz[2], rec->attr);
            p->ahead_vertices--;
        } else {
            rc = en_reader_push_triangle(r, rec->v[0], rec->v[1], rec->v[2]);
        }
        if (rc)
            return rc;
    }
    return 1;
}

/* The current run's records, handed out in place (en_format.next_in_place):
 * checked by the worker, only counted here (a PLY has no live set). */
static int ply_next_in_place(epsnet_reader *r, const epsnet_record **recs, size_t *n)
{
    ply_reader *p = r->state;
    *n = 0;
    if (!p->ring)
        return 1; /* the queue's */
    int rc = current_run(r, p);
    if (rc <= 0)
        return rc < 0 ? rc : 1; /* none in flight: the walkers, through the queue */
    ply_job *j = p->cur;
    *recs = j->recs + p->cur_pos;
    *n = j->nrecs - p->cur_pos;
    p->cur_pos = (uint32_t)j->nrecs;
    if (j->e->kind == ELEM_VERTEX) {
        en_reader_count_checked(r, *n, 0);
        p->ahead_vertices -= *n;
    } else {
        en_reader_count_checked(r, 0, *n);
    }
    return 1;
}

static void ahead_free(ply_reader *p)
{
    en_jobring_free(&p->ring, NULL); /* waits for the runs in flight */
    for (size_t i = 0; i < p->njobs; i++) {
        en_free(p->jobs[i].buf);
        en_free(p->jobs[i].recs);
        en_free(p->jobs[i].attrs);
    }
    en_free(p->jobs);
    p->jobs = NULL;
    p->njobs = 0;
    p->cur = NULL;
    p->ahead_bytes = 0;
}

/*
 * From now on decode runs on pool (NULL, or a pool without workers: on the
 * caller's thread, as before); the file's bytes are read ahead there too
 * (en_source_use_pool). Stopping waits for the runs in flight; call it
 * between batches, with the runs handed out.
 */
static int ply_use_pool(epsnet_reader *r, en_pool *pool)
{
    ply_reader *p = r->state;
    if (!pool || en_pool_threads(pool) == 0) {
        int lost = p->ring && (en_jobring_in_flight(p->ring) || (p->cur && p->cur_pos < p->cur->nrecs));
        ahead_free(p);
        if (lost && !r->failed) /* decoded ahead and now dropped: this reader cannot go on */
            en_reader_fail(r, EPSNET_EINTERNAL, "records decoded ahead were dropped (a bug)");
        return en_source_use_pool(r->src, pool);
    }
    int rc = en_source_use_pool(r->src, pool);
    if (p->ring || p->encoding == ENC_ASCII || p->labels)
        return rc;
    /* one run in flight a worker, as a .smz's blocks */
    size_t cap = (size_t)en_pool_threads(pool);
    if (en_jobring_new(&p->ring, pool, cap))
        return EPSNET_ENOMEM;
    p->njobs = cap + 1;
    if (!(p->jobs = en_calloc(p->njobs, sizeof *p->jobs))) {
        p->njobs = 0;
        ahead_free(p);
        return EPSNET_ENOMEM;
    }
    return rc;
}

/* ------------------------------------------------------------------------
 * Reader driver
 * ------------------------------------------------------------------------ */

static void ply_reader_free(ply_reader *p)
{
    if (!p)
        return;
    for (size_t i = 0; i < p->nelems; i++)
        en_free(p->elems[i].props);
    en_free(p->elems);
    en_free(p->held_xyz);
    en_free(p->held_attr);
    en_free(p->first);
    en_free(p->next);
    en_free(p->rec_label);
    en_free(p->corners);
    en_free(p->fuv);
    for (int k = 0; k < 2; k++) {
        for (uint32_t i = 0; i < p->names[k].tab.count; i++)
            en_free(p->names[k].names[i]);
        en_free(p->names[k].names);
        en_free(p->names[k].library);
    }
    en_free(p);
}

static int ply_open_reader(epsnet_reader *r)
{
    ply_reader *p = en_calloc(1, sizeof *p);
    if (!p)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    r->state = p;
    r->text = 1;
    p->strip.left = -1;
    int rc = read_header(r, p);
    if (rc)
        return rc;
    if (p->encoding == ENC_ASCII) {
        p->read_records = ascii_records;
    } else {
        p->codec = p->encoding == ENC_LE ? &ply_codec_le : &ply_codec_be;
        p->swap = (p->encoding == ENC_BE) != PLY_HOST_BE;
        p->read_records = binary_records;
        r->text = 0;
    }
    return 0;
}

static int ply_fill(epsnet_reader *r)
{
    ply_reader *p = r->state;
    if (!p->started) {
        /* names whose label the output does not keep go with it (named
         * there: en_reader_keep_attrs) */
        p->started = 1;
        for (int k = 0; k < 2; k++)
            if (p->names[k].at >= 0 && epsnet_attr_layout_find(&r->info.vertex_attrs, en_face_label_attr[k]) < 0) {
                p->names[k].at = -1;
                *(k ? &r->info.groups : &r->info.materials) = NULL;
            }
    }
    if (p->ring) {
        int rc = fill_ahead(r, p);
        if (rc)
            return rc;
    }
    const uint64_t pushed = r->nverts + r->ntris;
    while (p->elem < p->nelems) {
        ply_element *e = &p->elems[p->elem];
        if (p->record == e->count || e->nprops == 0) {
            p->elem++;
            p->record = 0;
            continue;
        }
        if (p->ring && !p->ahead_stop && ahead_takes(r, p, e)) {
            /* runs ahead from here (none is in flight: fill_ahead above) */
            int rc = fill_ahead(r, p);
            if (rc)
                return rc; /* else nothing was cut (ahead_stop): the walkers go on */
        }
        uint64_t left = e->count - p->record;
        int rc = p->read_records(r, p, e, left < PLY_BATCH ? left : PLY_BATCH);
        if (rc)
            return rc;
        if (r->nverts + r->ntris != pushed)
            return 1;
    }
    /* note: a face of 0, 1 or 2 corners has no triangle to carry; it is
     * legal and skipped, but not without a word (docs/architecture.md §5) */
    if (p->short_polygons)
        en_reader_drop(r, "faces with fewer than 3 corners", p->short_polygons, 1);
    /* note: a held vertex that no face names never becomes a record */
    uint64_t unused = 0;
    for (uint64_t v = 0; v < p->nheld; v++)
        unused += p->first[v] == 0;
    if (unused)
        en_reader_drop(r, "vertices no face uses", unused, 1);
    int rc = check_trailing(r, p);
    return rc ? rc : 0;
}

static void ply_close_reader(epsnet_reader *r)
{
    if (r->state)
        ahead_free(r->state); /* waits for the runs in flight */
    ply_reader_free(r->state);
    r->state = NULL;
}

static int ply_probe(const uint8_t *head, size_t n)
{
    if (n >= 4 && memcmp(head, "ply\n", 4) == 0)
        return 100;
    if (n >= 5 && memcmp(head, "ply\r\n", 5) == 0)
        return 100;
    return 0;
}

/* ------------------------------------------------------------------------
 * Writer
 * ------------------------------------------------------------------------ */

/* The largest header written: fixed lines and one line per attribute. */
#define PLY_WRITE_HEADER_MAX (1024 + EPSNET_ATTR_MAX * (EPSNET_ATTR_NAME_MAX + 24))
/* Faces are written as "3 a b c": uchar count, then int (or uint) indices. */
#define PLY_FACE_BYTES 13
/* Largest vertex index an int32 list can hold; above it the header says uint. */
#define PLY_INT_INDEX_MAX ((uint64_t)INT32_MAX)

typedef enum ply_write_mode {
    /* Header reserved at offset 0 and rewritten at the end (plain files). */
    WRITE_PATCH,
    /* Counts announced and output not rewritable: final header first, the
     * counts are checked at the end. */
    WRITE_ANNOUNCED,
    /* Nothing known and output not rewritable: everything spilled. */
    WRITE_SPILL_ALL,
} ply_write_mode;

typedef struct ply_writer {
    const epsnet_attr_layout *attrs; /* the writer's w->attrs */
    ply_write_mode mode;
    int ascii;
    int coord64;
    size_t header_size;      /* WRITE_PATCH: bytes reserved at offset 0 */
    int uint_index;          /* WRITE_ANNOUNCED: index type fixed up front */
    int faces_direct;        /* faces go to the sink: every vertex is already there */
    int faces_decided;       /* the first triangle chose direct or spill */
    en_spill *verts;         /* WRITE_SPILL_ALL only */
    en_spill *faces;
    uint64_t max_index;
    /* Face values (epsnet_attr.of_face): the layout's attributes of each
     * element, by index; the faces' bytes of them. A vertex record welds
     * into the vertex of an earlier one at its position with the same own
     * bytes (weld: xyz bits and own bytes -> vertex) unless that vertex
     * has a record with the same face bytes already (used: vertex and
     * face bytes), which is a distinct vertex at the same place. Per
     * record: its vertex, and its face bytes for the faces naming it. */
    int faced;
    /* The names of en_face_label_attr[k] to write (ply_names): where a record's
     * value is, and a copy of the names taken while records are put, the
     * only time the table is sure to live (epsnet.h epsnet_mesh_info). */
    int names[2];
    uint32_t name_at[2];
    en_face_names_copy name_copy[2];
    uint32_t nown, nface, face_size;
    uint32_t own[EPSNET_ATTR_MAX], face[EPSNET_ATTR_MAX];
    en_key_table weld, used;
    uint64_t nout;           /* vertices written (welded) */
    uint64_t *rec_vertex;
    uint8_t *rec_face;
    size_t rec_vertex_cap, rec_face_cap;
    uint8_t *key;            /* scratch: one weld key, then one used key */
} ply_writer;

static void store_le32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

static void store_le64(uint8_t *p, uint64_t v)
{
    store_le32(p, (uint32_t)v);
    store_le32(p + 4, (uint32_t)(v >> 32));
}

/* The `property` lines of the layout's attributes at[0 .. n) after the len
 * bytes of buf. @return the new length, or 0 if they do not fit. */
static size_t put_properties(char *buf, size_t cap, size_t len, const ply_writer *p, const uint32_t *at, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++) {
        const epsnet_attr *a = &p->attrs->attr[at[i]];
        int k = snprintf(buf + len, cap - len, "property %s %s\n", epsnet_attr_type_name(a->type), a->name);
        if (k < 0 || (size_t)k >= cap - len)
            return 0;
        len += (size_t)k;
    }
    return len;
}

/* Header text into buf; pad_to > 0 adds a comment line that brings the
 * header to exactly pad_to bytes. @return the length, or 0 if it does not
 * fit. */
static size_t build_header(char *buf, size_t cap, const ply_writer *p, uint64_t nv, uint64_t nf,
                           int uint_index, size_t pad_to, size_t *names_at)
{
    const char *coord = p->coord64 ? "double" : "float";
    int n = snprintf(buf, cap, "ply\nformat %s 1.0\ncomment written by epsnet %s\n",
                     p->ascii ? "ascii" : "binary_little_endian", EPSNET_VERSION_STRING);
    if (n < 0 || (size_t)n >= cap)
        return 0;
    size_t len = (size_t)n;
    if (names_at)
        *names_at = len;
    n = snprintf(buf + len, cap - len,
                 "element vertex %" PRIu64 "\nproperty %s x\nproperty %s y\nproperty %s z\n", nv, coord, coord,
                 coord);
    if (n < 0 || (size_t)n >= cap - len)
        return 0;
    len += (size_t)n;
    /* every attribute with its own name and type (epsnet.h §2), a face's
     * values on the face element */
    if (!(len = put_properties(buf, cap, len, p, p->own, p->nown)))
        return 0;
    n = snprintf(buf + len, cap - len, "element face %" PRIu64 "\nproperty list uchar %s vertex_indices\n", nf,
                 uint_index ? "uint" : "int");
    if (n < 0 || (size_t)n >= cap - len)
        return 0;
    len += (size_t)n;
    if (!(len = put_properties(buf, cap, len, p, p->face, p->nface)))
        return 0;
    static const char end[] = "end_header\n";
    if (pad_to) {
        static const char pad[] = "comment";
        if (len + sizeof pad + 1 + sizeof end - 1 > pad_to || pad_to > cap)
            return 0;
        size_t fill = pad_to - len - (sizeof end - 1);
        memcpy(buf + len, pad, sizeof pad - 1);
        memset(buf + len + sizeof pad - 1, ' ', fill - sizeof pad);
        buf[len + fill - 1] = '\n';
        len += fill;
    }
    if (len + sizeof end > cap)
        return 0;
    memcpy(buf + len, end, sizeof end);
    return len + sizeof end - 1;
}

/* Text of one attribute value (host-order bytes at src) into buf (at
 * least 32 bytes): integers in decimal, floats in the shortest text that
 * reads back to the same bits. @return the length. */
static size_t format_attr(char *buf, const uint8_t *src, epsnet_attr_type t)
{
    int n = 0;
    switch (t) {
    case EPSNET_ATTR_INT8: { int8_t x; memcpy(&x, src, 1); n = snprintf(buf, 32, "%d", x); break; }
    case EPSNET_ATTR_UINT8: { uint8_t x; memcpy(&x, src, 1); n = snprintf(buf, 32, "%u", x); break; }
    case EPSNET_ATTR_INT16: { int16_t x; memcpy(&x, src, 2); n = snprintf(buf, 32, "%d", x); break; }
    case EPSNET_ATTR_UINT16: { uint16_t x; memcpy(&x, src, 2); n = snprintf(buf, 32, "%u", x); break; }
    case EPSNET_ATTR_INT32: { int32_t x; memcpy(&x, src, 4); n = snprintf(buf, 32, "%" PRId32, x); break; }
    case EPSNET_ATTR_UINT32: { uint32_t x; memcpy(&x, src, 4); n = snprintf(buf, 32, "%" PRIu32, x); break; }
    case EPSNET_ATTR_FLOAT32: {
        float x;
        memcpy(&x, src, 4);
        n = en_format_coord(buf, x, EPSNET_COORD_FLOAT32);
        break;
    }
    case EPSNET_ATTR_FLOAT64: {
        double x;
        memcpy(&x, src, 8);
        n = en_format_coord(buf, x, EPSNET_COORD_FLOAT64);
        break;
    }
    }
    return n > 0 ? (size_t)n : 0;
}

static int emit_vertex(epsnet_writer *w, const ply_writer *p, const double xyz[3], const uint8_t *attr)
{
    const epsnet_attr_layout *l = p->attrs;
    if (p->ascii) {
        char line[112 + EPSNET_ATTR_MAX * 34];
        size_t len = 0;
        for (int k = 0; k < 3; k++) {
            len += (size_t)en_format_coord(line + len, xyz[k], w->coord_type);
            line[len++] = k < 2 || p->nown ? ' ' : '\n';
        }
        for (uint32_t i = 0; i < p->nown; i++) {
            const epsnet_attr *a = &l->attr[p->own[i]];
            len += format_attr(line + len, attr + a->offset, a->type);
            line[len++] = i + 1 < p->nown ? ' ' : '\n';
        }
        return en_writer_bytes(w, line, len);
    }
    uint8_t rec[24 + EPSNET_ATTR_MAX * 8];
    size_t len;
    if (p->coord64) {
        for (int k = 0; k < 3; k++) {
            uint64_t u;
            memcpy(&u, &xyz[k], 8);
            store_le64(rec + 8 * k, u);
        }
        len = 24;
    } else {
        for (int k = 0; k < 3; k++) {
            float f = (float)xyz[k];
            uint32_t u;
            memcpy(&u, &f, 4);
            store_le32(rec + 4 * k, u);
        }
        len = 12;
    }
    /* the body is little-endian: each value's host bytes, reversed on a
     * big-endian host */
    for (uint32_t i = 0; i < p->nown; i++) {
        const epsnet_attr *a = &l->attr[p->own[i]];
        size_t size = epsnet_attr_type_size(a->type);
        binary_attr(rec + len, attr + a->offset, size, PLY_HOST_BE);
        len += size;
    }
    return en_writer_bytes(w, rec, len);
}

/* A face: its corners, then its values (p->face_size bytes packed in the
 * order of p->face, when the layout has any). */
static int emit_face(epsnet_writer *w, const ply_writer *p, const uint32_t v[3], const uint8_t *values)
{
    const epsnet_attr_layout *l = p->attrs;
    if (p->ascii) {
        char line[40 + EPSNET_ATTR_MAX * 34];
        int n = snprintf(line, sizeof line, "3 %" PRIu32 " %" PRIu32 " %" PRIu32, v[0], v[1], v[2]);
        size_t len = n > 0 ? (size_t)n : 0;
        for (uint32_t i = 0, at = 0; i < p->nface; i++) {
            const epsnet_attr *a = &l->attr[p->face[i]];
            line[len++] = ' ';
            len += format_attr(line + len, values + at, a->type);
            at += (uint32_t)epsnet_attr_type_size(a->type);
        }
        line[len++] = '\n';
        return en_writer_bytes(w, line, len);
    }
    uint8_t rec[PLY_FACE_BYTES + EPSNET_ATTR_MAX * 8];
    rec[0] = 3;
    for (int k = 0; k < 3; k++)
        store_le32(rec + 1 + 4 * k, v[k]);
    size_t len = PLY_FACE_BYTES;
    for (uint32_t i = 0; i < p->nface; i++) {
        size_t size = epsnet_attr_type_size(l->attr[p->face[i]].type);
        binary_attr(rec + len, values + (len - PLY_FACE_BYTES), size, PLY_HOST_BE);
        len += size;
    }
    return en_writer_bytes(w, rec, len);
}

/* Are label k's names written (put_names)? When its property is a face's
 * ushort, which is what the reader takes names for (header_names). */
static int ply_holds_names(const epsnet_attr_layout *l, int k)
{
    int i = epsnet_attr_layout_find(l, en_face_label_attr[k]);
    return i >= 0 && l->attr[i].of_face && l->attr[i].type == EPSNET_ATTR_UINT16;
}

static int ply_open_writer(epsnet_writer *w)
{
    ply_writer *p = en_calloc(1, sizeof *p);
    if (!p)
        return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory");
    w->state = p;
    p->attrs = &w->attrs;
    p->ascii = w->settings.ascii != 0;
    p->coord64 = w->coord_type == EPSNET_COORD_FLOAT64;
    uint32_t own_size = 0;
    for (uint32_t i = 0; i < p->attrs->count; i++) {
        const epsnet_attr *a = &p->attrs->attr[i];
        if (a->of_face) {
            p->face[p->nface++] = i;
            p->face_size += (uint32_t)epsnet_attr_type_size(a->type);
        } else {
            p->own[p->nown++] = i;
            own_size += (uint32_t)epsnet_attr_type_size(a->type);
        }
    }
    p->faced = p->nface > 0;
    if (p->faced) {
        en_key_init(&p->weld, 24 + own_size);
        en_key_init(&p->used, 8 + p->face_size);
        if (!(p->key = en_malloc(24 + own_size + 8 + p->face_size)))
            return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "out of memory");
    }
    /* note: a reader fills its names as it reads (epsnet.h), so they are
     * known at the end only, and their lines have no bound: the header is
     * written last, after the vertices are spilled too. */
    for (int k = 0; k < 2; k++) {
        p->names[k] = ply_holds_names(p->attrs, k) && (k ? w->info.groups : w->info.materials) != NULL;
        if (p->names[k])
            p->name_at[k] = p->attrs->attr[epsnet_attr_layout_find(p->attrs, en_face_label_attr[k])].offset;
    }
    char hdr[PLY_WRITE_HEADER_MAX];
    if (p->names[0] || p->names[1]) {
        p->mode = WRITE_SPILL_ALL;
        return 0;
    }
    if (en_sink_can_patch(w->sink)) {
        p->mode = WRITE_PATCH;
        /* note: room for the widest counts and "uint", so the final header
         * always fits the reserved bytes. */
        p->header_size = build_header(hdr, sizeof hdr, p, UINT64_MAX, UINT64_MAX, 1, 0, NULL) + 16;
        size_t n = build_header(hdr, sizeof hdr, p, 0, 0, 0, p->header_size, NULL);
        return en_writer_bytes(w, hdr, n);
    }
    /* (welded, the vertices are fewer than announced) */
    if (w->info.nverts != EPSNET_COUNT_UNKNOWN && w->info.nfaces != EPSNET_COUNT_UNKNOWN && !p->faced) {
        p->mode = WRITE_ANNOUNCED;
        if (w->info.nverts > (uint64_t)UINT32_MAX + 1)
            return en_error_set(&w->err, EPSNET_EUNSUPPORTED, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "PLY output cannot index %" PRIu64 " vertices (at most 2^32)",
                                w->info.nverts);
        p->uint_index = w->info.nverts > PLY_INT_INDEX_MAX + 1;
        size_t n = build_header(hdr, sizeof hdr, p, w->info.nverts, w->info.nfaces, p->uint_index, 0, NULL);
        return en_writer_bytes(w, hdr, n);
    }
    p->mode = WRITE_SPILL_ALL;
    return 0;
}

/* A vertex of the output: written, or spilled until the header can be. */
static int out_vertex(epsnet_writer *w, ply_writer *p, const double xyz[3], const uint8_t *attr)
{
    if (p->mode != WRITE_SPILL_ALL)
        return emit_vertex(w, p, xyz, attr);
    int rc = en_writer_open_spill(w, &p->verts);
    if (rc)
        return rc;
    if (p->coord64)
        rc = en_spill_write(p->verts, xyz, 3 * sizeof(double), &w->err);
    else {
        float f[3] = { (float)xyz[0], (float)xyz[1], (float)xyz[2] };
        rc = en_spill_write(p->verts, f, sizeof f, &w->err);
    }
    if (rc == 0 && p->attrs->size)
        rc = en_spill_write(p->verts, attr, p->attrs->size, &w->err);
    return rc;
}

static int writer_nomem(epsnet_writer *w)
{
    return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
}

/* A vertex record of a layout with face values: its vertex unless it welds
 * into an earlier one (see ply_writer.faced); its face bytes are kept for
 * the faces that name it. */
static int put_faced_vertex(epsnet_writer *w, ply_writer *p, const double xyz[3], const uint8_t *attr)
{
    uint64_t r = w->nverts - 1; /* this record */
    if (en_grow((void **)&p->rec_vertex, &p->rec_vertex_cap, r + 1, sizeof *p->rec_vertex) ||
        en_grow((void **)&p->rec_face, &p->rec_face_cap, (r + 1) * p->face_size, 1))
        return writer_nomem(w);
    const epsnet_attr_layout *l = p->attrs;
    uint8_t *key = p->key, *face = p->rec_face + r * p->face_size;
    size_t n = 24;
    memcpy(key, xyz, 24);
    for (uint32_t i = 0; i < p->nown; i++) {
        size_t size = epsnet_attr_type_size(l->attr[p->own[i]].type);
        memcpy(key + n, attr + l->attr[p->own[i]].offset, size);
        n += size;
    }
    for (uint32_t i = 0, at = 0; i < p->nface; i++) {
        size_t size = epsnet_attr_type_size(l->attr[p->face[i]].type);
        memcpy(face + at, attr + l->attr[p->face[i]].offset, size);
        at += (uint32_t)size;
    }
    uint8_t *ukey = key + n;
    uint64_t vertex, ignored;
    int added, fresh;
    if (en_key_find(&p->weld, key, p->nout, &vertex, &added))
        return writer_nomem(w);
    memcpy(ukey, &vertex, 8);
    memcpy(ukey + 8, face, p->face_size);
    if (en_key_find(&p->used, ukey, 0, &ignored, &fresh))
        return writer_nomem(w);
    if (!added && !fresh) {
        /* that vertex has a record with these face values: a distinct
         * vertex at the same place */
        vertex = p->nout;
        en_key_set(&p->weld, key, vertex);
        memcpy(ukey, &vertex, 8);
        if (en_key_find(&p->used, ukey, 0, &ignored, &fresh))
            return writer_nomem(w);
        added = 1;
    }
    p->rec_vertex[r] = vertex;
    if (!added)
        return 0;
    p->nout++;
    return out_vertex(w, p, xyz, attr);
}

/* A vertex's labels: their names copied (ply_writer.name_copy) once the
 * copy lacks them. */
static int copy_names(epsnet_writer *w, ply_writer *p, const uint8_t *attr)
{
    for (int k = 0; k < 2; k++) {
        if (!p->names[k])
            continue;
        uint16_t m;
        memcpy(&m, attr + p->name_at[k], sizeof m);
        en_face_names_copy *c = &p->name_copy[k];
        if (c->of && m < c->names.count)
            continue;
        const epsnet_face_names *t = k ? w->info.groups : w->info.materials;
        if (m >= t->count)
            return en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "%s %u of vertex %" PRIu64 " names nothing (%u names known)", en_face_label_attr[k], m,
                                w->nverts, t->count);
        en_face_names_copy_free(c);
        if (en_face_names_copy_of(c, t))
            return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "out of memory");
    }
    return 0;
}

static int put_vertex(epsnet_writer *w, ply_writer *p, const double xyz[3], const uint8_t *attr)
{
    int rc = copy_names(w, p, attr);
    if (rc)
        return rc;
    if (p->faces_direct)
        return en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "vertex %" PRIu64 " arrives after the %" PRIu64 " vertices announced",
                            w->nverts, w->info.nverts);
    return p->faced ? put_faced_vertex(w, p, xyz, attr) : out_vertex(w, p, xyz, attr);
}

static int put_triangle(epsnet_writer *w, ply_writer *p, const uint64_t v[3])
{
    uint32_t idx[3];
    const uint8_t *values = NULL;
    for (int k = 0; k < 3; k++) {
        uint64_t o = p->faced ? p->rec_vertex[v[k]] : v[k]; /* (writer.c checked v[k] came) */
        if (o > UINT32_MAX)
            return en_error_set(&w->err, EPSNET_EUNSUPPORTED, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "PLY output cannot index vertex %" PRIu64 " (at most 2^32 vertices)", o + 1);
        if (o > p->max_index)
            p->max_index = o;
        idx[k] = (uint32_t)o;
    }
    if (p->faced) /* the face's values are its corners' (the first's, should they differ) */
        values = p->rec_face + v[0] * p->face_size;
    if (!p->faces_decided) {
        /* note: faces can skip the spill file only when no vertex can follow
         * them, which the caller guarantees by announcing the vertex count. */
        p->faces_decided = 1;
        p->faces_direct = p->mode != WRITE_SPILL_ALL && w->info.nverts == w->nverts;
    }
    if (p->faces_direct)
        return emit_face(w, p, idx, values);
    int rc = en_writer_open_spill(w, &p->faces);
    if (rc == 0)
        rc = en_spill_write(p->faces, idx, sizeof idx, &w->err);
    if (rc == 0 && p->face_size)
        rc = en_spill_write(p->faces, values, p->face_size, &w->err);
    return rc;
}

static int ply_put(epsnet_writer *w, const epsnet_record *rec)
{
    ply_writer *p = w->state;
    if (rec->kind == EPSNET_REC_VERTEX)
        return put_vertex(w, p, rec->xyz, rec->attr);
    if (rec->kind == EPSNET_REC_TRIANGLE)
        return put_triangle(w, p, rec->v);
    return 0;
}

/* Replay a spill file through emit_vertex/emit_face. */
static int replay(epsnet_writer *w, ply_writer *p, en_spill *sp, int vertices)
{
    if (!sp)
        return 0;
    int rc = en_spill_rewind(sp, &w->err);
    if (rc)
        return rc;
    const size_t rec = vertices ? (p->coord64 ? 3 * sizeof(double) : 3 * sizeof(float)) + p->attrs->size
                                : 3 * sizeof(uint32_t) + p->face_size;
    union {
        double d[3 * 2048];
        uint8_t b[3 * 2048 * sizeof(double)];
    } buf;
    for (;;) {
        int64_t got = en_spill_read(sp, &buf, (sizeof buf / rec) * rec, &w->err);
        if (got < 0)
            return (int)got;
        if (got == 0)
            return 0;
        if ((size_t)got % rec)
            return en_error_set(&w->err, EPSNET_EIO, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "temporary file ended in the middle of a record");
        size_t n = (size_t)got / rec;
        for (size_t i = 0; i < n; i++) {
            if (vertices) {
                const uint8_t *at = buf.b + i * rec;
                double xyz[3];
                for (int k = 0; k < 3; k++) {
                    if (p->coord64) {
                        memcpy(&xyz[k], at + 8 * k, 8);
                    } else {
                        float f;
                        memcpy(&f, at + 4 * k, 4);
                        xyz[k] = f;
                    }
                }
                rc = emit_vertex(w, p, xyz, at + (p->coord64 ? 24 : 12));
            } else {
                uint32_t idx[3];
                memcpy(idx, buf.b + i * rec, sizeof idx);
                rc = emit_face(w, p, idx, buf.b + i * rec + sizeof idx);
            }
            if (rc)
                return rc;
        }
    }
}

/* The names of the face labels, as header comments (ply_names). */
static int put_names(epsnet_writer *w, const ply_writer *p)
{
    static const char head[] = "comment epsnet ";
    for (int k = 0; k < 2; k++) {
        const epsnet_face_names *t = p->name_copy[k].of;
        if (!t)
            continue;
        int rc;
        if (k == 0 && t->library &&
            ((rc = en_writer_bytes(w, head, sizeof head - 1)) || (rc = en_writer_bytes(w, "mtllib ", 7)) ||
             (rc = en_writer_bytes(w, t->library, strlen(t->library))) || (rc = en_writer_bytes(w, "\n", 1))))
            return rc;
        for (uint32_t i = 0; i < t->count; i++) {
            char num[48];
            int n = snprintf(num, sizeof num, "%s %u%s", en_face_label_attr[k], i, *t->names[i] ? " " : "");
            if ((rc = en_writer_bytes(w, head, sizeof head - 1)) || (rc = en_writer_bytes(w, num, (size_t)n)) ||
                (rc = en_writer_bytes(w, t->names[i], strlen(t->names[i]))) || (rc = en_writer_bytes(w, "\n", 1)))
                return rc;
        }
    }
    return 0;
}

static int ply_finish(epsnet_writer *w)
{
    ply_writer *p = w->state;
    int uint_index = p->max_index > PLY_INT_INDEX_MAX;
    uint64_t nverts = p->faced ? p->nout : w->nverts; /* welded (see ply_writer.faced) */
    char hdr[PLY_WRITE_HEADER_MAX];
    int rc;
    switch (p->mode) {
    case WRITE_PATCH: {
        if ((rc = replay(w, p, p->faces, 0)))
            return rc;
        size_t n = build_header(hdr, sizeof hdr, p, nverts, w->ntris, uint_index, p->header_size, NULL);
        if (n != p->header_size)
            return en_error_set(&w->err, EPSNET_EINTERNAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "PLY header does not fit its reserved space");
        return en_sink_patch(w->sink, 0, hdr, n, &w->err);
    }
    case WRITE_ANNOUNCED:
        if (w->nverts != w->info.nverts || w->ntris != w->info.nfaces)
            return en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "announced %" PRIu64 " vertices and %" PRIu64 " triangles but got %" PRIu64
                                " and %" PRIu64 " (a PLY written to a pipe or .zst needs exact counts)",
                                w->info.nverts, w->info.nfaces, w->nverts, w->ntris);
        return replay(w, p, p->faces, 0);
    case WRITE_SPILL_ALL: {
        size_t at = 0, n = build_header(hdr, sizeof hdr, p, nverts, w->ntris, uint_index, 0, &at);
        if ((rc = en_writer_bytes(w, hdr, at)) || (rc = put_names(w, p)) ||
            (rc = en_writer_bytes(w, hdr + at, n - at)) || (rc = replay(w, p, p->verts, 1)))
            return rc;
        return replay(w, p, p->faces, 0);
    }
    }
    return EPSNET_EINTERNAL;
}

static void ply_close_writer(epsnet_writer *w)
{
    ply_writer *p = w->state;
    if (!p)
        return;
    en_spill_close(&p->verts);
    en_spill_close(&p->faces);
    en_key_free(&p->weld);
    en_key_free(&p->used);
    en_free(p->rec_vertex);
    en_free(p->rec_face);
    en_free(p->key);
    en_face_names_copy_free(&p->name_copy[0]);
    en_face_names_copy_free(&p->name_copy[1]);
    en_free(p);
    w->state = NULL;
}

const en_format en_format_ply = {
    .name = "ply",
    .extensions = "ply",
    .probe = ply_probe,
    .open_reader = ply_open_reader,
    .fill = ply_fill,
    .close_reader = ply_close_reader,
    .use_pool = ply_use_pool,
    .next_in_place = ply_next_in_place,
    .open_writer = ply_open_writer,
    .put = ply_put,
    .finish = ply_finish,
    .close_writer = ply_close_writer,
    .holds_attr = en_format_holds_every_attr,
    .holds_names = ply_holds_names,
};
