/*
 * PLY reader and writer (src/io/fmt_ply.c).
 *
 * The reference mesh: a tetrahedron and, beside it, a quad that the reader
 * must split into two triangles by a fan from its first corner.
 *
 *        3                     7 ------ 6
 *        |\                    |      / |
 *        | \                   |    /   |
 *        |  2                  |  /     |
 *        | / \                 |/       |
 *        0 --- 1               4 ------ 5
 *
 *   tetrahedron faces: (0 2 1) (0 1 3) (0 3 2) (1 2 3)
 *   quad (4 5 6 7)  -> (4 5 6) (4 6 7)
 *
 * Coordinates are not round numbers (0.1, 1e-3, ...) so that every path has
 * to carry float32 bits exactly.
 */
#include <dirent.h>
#include <stdint.h>

#include "common/pool.h"
#include "io/format.h"
#include "testlib.h"

#define NV 8
static const float ref_xyz[NV][3] = {
    { 0.1f, 0.2f, 0.3f },   { 1.5f, -0.25f, 0.001f }, { 0.7f, 1.1f, -3.75f }, { 1e-3f, 2.0f, 1e6f },
    { 2.0f, 0.0f, 0.0f },   { 3.0f, 0.1f, 0.0f },     { 3.0f, 1.0f, 0.2f },   { 2.0f, 1.0f, 0.3f },
};
#define NPOLY 5
static const int ref_poly_n[NPOLY] = { 3, 3, 3, 3, 4 };
static const uint32_t ref_poly[NPOLY][4] = {
    { 0, 2, 1, 0 }, { 0, 1, 3, 0 }, { 0, 3, 2, 0 }, { 1, 2, 3, 0 }, { 4, 5, 6, 7 },
};
#define NT 6
static const uint64_t ref_tri[NT][3] = {
    { 0, 2, 1 }, { 0, 1, 3 }, { 0, 3, 2 }, { 1, 2, 3 }, { 4, 5, 6 }, { 4, 6, 7 },
};

/* ---- a tiny PLY encoder for inputs (independent of the code under test) ---- */

typedef struct bytes {
    uint8_t *d;
    size_t n, cap;
} bytes;

static void b_put(bytes *b, const void *p, size_t n)
{
    if (b->n + n > b->cap) {
        b->cap = (b->n + n) * 2 + 256;
        b->d = realloc(b->d, b->cap);
    }
    memcpy(b->d + b->n, p, n);
    b->n += n;
}

static void b_str(bytes *b, const char *s)
{
    b_put(b, s, strlen(s));
}

static int host_is_be(void)
{
    const uint16_t one = 1;
    return *(const uint8_t *)&one == 0;
}

/* Put the n-byte value v in the file's byte order. */
static void b_num(bytes *b, const void *v, size_t n, int be)
{
    uint8_t tmp[8];
    memcpy(tmp, v, n);
    if (be != host_is_be())
        for (size_t i = 0; i < n / 2; i++) {
            uint8_t t = tmp[i];
            tmp[i] = tmp[n - 1 - i];
            tmp[n - 1 - i] = t;
        }
    b_put(b, tmp, n);
}

/* Encode an integer as one of the PLY integer types. */
static void b_int(bytes *b, const char *type, int64_t v, int be)
{
    if (!strcmp(type, "uchar") || !strcmp(type, "char") || !strcmp(type, "uint8") || !strcmp(type, "int8")) {
        int8_t x = (int8_t)v;
        b_num(b, &x, 1, be);
    } else if (!strcmp(type, "ushort") || !strcmp(type, "short") || !strcmp(type, "uint16") ||
               !strcmp(type, "int16")) {
        int16_t x = (int16_t)v;
        b_num(b, &x, 2, be);
    } else {
        int32_t x = (int32_t)v;
        b_num(b, &x, 4, be);
    }
}

enum { ASCII, LE, BE };
static const char *enc_name[] = { "ascii", "binary_little_endian", "binary_big_endian" };

typedef struct layout {
    int with_extras;          /* normals, colours and extra elements */
    const char *count_type;   /* face list types */
    const char *index_type;
} layout;

/* The reference mesh as PLY in encoding enc. */
static bytes make_ply(int enc, const layout *l)
{
    bytes b = { 0 };
    char line[256];
    snprintf(line, sizeof line, "ply\nformat %s 1.0\ncomment test mesh\n", enc_name[enc]);
    b_str(&b, line);
    if (l->with_extras)
        b_str(&b, "obj_info scanner 7\nelement camera 1\nproperty float view_px\nproperty uchar flag\n");
    snprintf(line, sizeof line, "element vertex %d\n", NV);
    b_str(&b, line);
    if (l->with_extras)
        b_str(&b, "property double confidence\nproperty float x\nproperty uchar red\nproperty uchar green\n"
                  "property uchar blue\nproperty float y\nproperty float nx\nproperty float ny\n"
                  "property float nz\nproperty float z\nproperty short intensity\n");
    else
        b_str(&b, "property float x\nproperty float y\nproperty float z\n");
    if (l->with_extras)
        b_str(&b, "element edge 2\nproperty int vertex1\nproperty list uchar int tags\nproperty int vertex2\n");
    snprintf(line, sizeof line, "element face %d\n", NPOLY);
    b_str(&b, line);
    if (l->with_extras)
        b_str(&b, "property uchar flags\n");
    snprintf(line, sizeof line, "property list %s %s vertex_indices\n", l->count_type, l->index_type);
    b_str(&b, line);
    if (l->with_extras)
        b_str(&b, "property list uchar float weights\nelement material 1\nproperty uchar ambient_red\n");
    b_str(&b, "end_header\n");

    if (l->with_extras) {
        if (enc == ASCII) {
            b_str(&b, "0.5 7\n");
        } else {
            float f = 0.5f;
            b_num(&b, &f, 4, enc == BE);
            b_int(&b, "uchar", 7, 0);
        }
    }
    for (int i = 0; i < NV; i++) {
        const float *p = ref_xyz[i];
        if (enc == ASCII) {
            if (l->with_extras)
                snprintf(line, sizeof line, "0.25 %.9g 255 128 0 %.9g 0 0 1 %.9g -12\n", (double)p[0],
                         (double)p[1], (double)p[2]);
            else
                snprintf(line, sizeof line, "%.9g %.9g %.9g\n", (double)p[0], (double)p[1], (double)p[2]);
            b_str(&b, line);
            continue;
        }
        double conf = 0.25;
        float n[3] = { 0, 0, 1 };
        if (l->with_extras)
            b_num(&b, &conf, 8, enc == BE);
        b_num(&b, &p[0], 4, enc == BE);
        if (l->with_extras)
            b_put(&b, "\xff\x80\x00", 3);
        b_num(&b, &p[1], 4, enc == BE);
        if (l->with_extras)
            for (int k = 0; k < 3; k++)
                b_num(&b, &n[k], 4, enc == BE);
        b_num(&b, &p[2], 4, enc == BE);
        if (l->with_extras)
            b_int(&b, "short", -12, enc == BE);
    }
    if (l->with_extras) {
        for (int e = 0; e < 2; e++) {
            if (enc == ASCII) {
                b_str(&b, e ? "1 0 2\n" : "0 2 5 6 1\n");
                continue;
            }
            b_int(&b, "int", e, enc == BE);
            b_int(&b, "uchar", e ? 0 : 2, 0);
            for (int k = 0; k < (e ? 0 : 2); k++)
                b_int(&b, "int", 5 + k, enc == BE);
            b_int(&b, "int", e + 1, enc == BE);
        }
    }
    for (int f = 0; f < NPOLY; f++) {
        if (enc == ASCII) {
            int n = 0;
            if (l->with_extras)
                n += snprintf(line + n, sizeof line - (size_t)n, "9 ");
            n += snprintf(line + n, sizeof line - (size_t)n, "%d", ref_poly_n[f]);
            for (int k = 0; k < ref_poly_n[f]; k++)
                n += snprintf(line + n, sizeof line - (size_t)n, " %u", ref_poly[f][k]);
            if (l->with_extras)
                n += snprintf(line + n, sizeof line - (size_t)n, " 2 0.5 0.75");
            snprintf(line + n, sizeof line - (size_t)n, "\n");
            b_str(&b, line);
            continue;
        }
        if (l->with_extras)
            b_int(&b, "uchar", 9, 0);
        b_int(&b, l->count_type, ref_poly_n[f], enc == BE);
        for (int k = 0; k < ref_poly_n[f]; k++)
            b_int(&b, l->index_type, ref_poly[f][k], enc == BE);
        if (l->with_extras) {
            float t[2] = { 0.5f, 0.75f };
            b_int(&b, "uchar", 2, 0);
            b_num(&b, &t[0], 4, enc == BE);
            b_num(&b, &t[1], 4, enc == BE);
        }
    }
    if (l->with_extras)
        b_str(&b, enc == ASCII ? "3\n" : "\x03");
    return b;
}

static void check_reference(const tl_mesh *m)
{
    CHECK_EQ_U64(m->nv, NV);
    CHECK_EQ_U64(m->nt, NT);
    CHECK_EQ_U64(m->nfin, 0);
    if (m->nv != NV || m->nt != NT)
        return;
    for (int i = 0; i < NV; i++)
        for (int k = 0; k < 3; k++)
            CHECK(m->xyz[3 * i + k] == (double)ref_xyz[i][k]);
    for (int t = 0; t < NT; t++)
        for (int k = 0; k < 3; k++)
            CHECK_EQ_U64(m->tri[3 * t + k], ref_tri[t][k]);
}

static const char *write_bytes(const char *name, bytes *b)
{
    const char *p = tl_write(name, b->d, b->n);
    free(b->d);
    b->d = NULL;
    return p;
}

/* ---- reading ---- */

TEST(ascii_le_and_be_give_the_reference_records)
{
    static const char *names[] = { "ref_ascii.ply", "ref_le.ply", "ref_be.ply" };
    static const char *enc_info[] = { "ascii", "binary_le", "binary_be" };
    layout l = { 0, "uchar", "int" };
    for (int enc = ASCII; enc <= BE; enc++) {
        bytes b = make_ply(enc, &l);
        const char *p = write_bytes(names[enc], &b);
        tl_mesh m;
        epsnet_error err;
        int rc = tl_read_mesh(p, &m, &err);
        CHECK_EQ_INT(rc, 0);
        if (rc)
            fprintf(stderr, "  %s\n", epsnet_error_message(&err));
        check_reference(&m);
        CHECK(strcmp(m.info.format, "ply") == 0);
        CHECK(strcmp(m.info.encoding, enc_info[enc]) == 0);
        CHECK_EQ_U64(m.info.nverts, NV);
        CHECK_EQ_U64(m.info.nfaces, EPSNET_COUNT_UNKNOWN);
        CHECK_EQ_INT(m.info.coord_type, EPSNET_COORD_FLOAT32);
        tl_mesh_free(&m);
    }
}

TEST(extra_properties_and_elements_are_skipped)
{
    static const char *names[] = { "extra_ascii.ply", "extra_le.ply", "extra_be.ply" };
    layout l = { 1, "uchar", "int" };
    for (int enc = ASCII; enc <= BE; enc++) {
        bytes b = make_ply(enc, &l);
        const char *p = write_bytes(names[enc], &b);
        tl_mesh m;
        epsnet_error err;
        int rc = tl_read_mesh(p, &m, &err);
        CHECK_EQ_INT(rc, 0);
        if (rc)
            fprintf(stderr, "  %s\n", epsnet_error_message(&err));
        check_reference(&m);
        tl_mesh_free(&m);
    }
}

/* What the reader tells about a file: its dropped text and count, known
 * from the header (docs/architecture.md §5). */
static const char *dropped_of(const char *path, uint64_t *n, char *buf, size_t cap)
{
    epsnet_reader *r = NULL;
    epsnet_error err;
    *n = 99;
    if (epsnet_reader_open(&r, path, NULL, &err))
        return "(open failed)";
    const char *what = epsnet_reader_dropped(r, n);
    snprintf(buf, cap, "%s", what ? what : "(null)");
    epsnet_reader_close(&r);
    return buf;
}

/* Every vertex scalar beyond x, y, z comes with its vertex, with its name
 * and type, bit for bit, in every encoding (epsnet.h §2). */
TEST(vertex_properties_are_carried_as_attributes)
{
    static const char *names[] = { "confidence", "red", "green", "blue", "nx", "ny", "nz", "intensity" };
    static const epsnet_attr_type types[] = { EPSNET_ATTR_FLOAT64, EPSNET_ATTR_UINT8, EPSNET_ATTR_UINT8,
                                              EPSNET_ATTR_UINT8, EPSNET_ATTR_FLOAT32, EPSNET_ATTR_FLOAT32,
                                              EPSNET_ATTR_FLOAT32, EPSNET_ATTR_INT16 };
    for (int enc = ASCII; enc <= BE; enc++) {
        layout l = { 1, "uchar", "int" };
        bytes b = make_ply(enc, &l);
        const char *p = write_bytes("attrs.ply", &b);
        epsnet_reader *r = NULL;
        epsnet_error err;
        CHECK_EQ_INT(epsnet_reader_open(&r, p, NULL, &err), 0);
        if (!r)
            continue;
        const epsnet_attr_layout *al = &epsnet_reader_info(r)->vertex_attrs;
        CHECK_EQ_U64(al->count, 8);
        CHECK_EQ_U64(al->size, 8 + 3 + 12 + 2);
        for (uint32_t i = 0; i < al->count && i < 8; i++) {
            CHECK(strcmp(al->attr[i].name, names[i]) == 0);
            CHECK_EQ_INT(al->attr[i].type, types[i]);
        }
        epsnet_record rec;
        uint64_t nv = 0;
        while (epsnet_reader_next(r, &rec, &err) == 1) {
            if (rec.kind != EPSNET_REC_VERTEX) {
                CHECK(rec.attr == NULL);
                continue;
            }
            nv++;
            CHECK(rec.attr != NULL);
            if (!rec.attr)
                break;
            double conf;
            float nz;
            int16_t inten;
            memcpy(&conf, rec.attr + al->attr[0].offset, 8);
            memcpy(&nz, rec.attr + al->attr[6].offset, 4);
            memcpy(&inten, rec.attr + al->attr[7].offset, 2);
            CHECK(conf == 0.25);
            CHECK(nz == 1.0f);
            CHECK_EQ_INT(inten, -12);
            CHECK_EQ_INT(rec.attr[al->attr[1].offset], 255);
            CHECK_EQ_INT(rec.attr[al->attr[2].offset], 128);
            CHECK_EQ_INT(rec.attr[al->attr[3].offset], 0);
        }
        CHECK_EQ_U64(nv, NV);
        epsnet_reader_close(&r);
    }
}

/* More vertex properties than a record carries, or a name no layout takes:
 * the first EPSNET_ATTR_MAX are carried, the rest named as dropped; never
 * an error, never a crash. */
TEST(attributes_past_the_limit_are_named_as_dropped)
{
    char text[16384];
    size_t n = (size_t)snprintf(text, sizeof text, "ply\nformat ascii 1.0\nelement vertex 2\n"
                                                   "property float x\nproperty float y\nproperty float z\n");
    for (int i = 0; i < EPSNET_ATTR_MAX + 3; i++)
        n += (size_t)snprintf(text + n, sizeof text - n, "property uchar a%d\n", i);
    n += (size_t)snprintf(text + n, sizeof text - n, "property short %s\nproperty list uchar int tags\n",
                          "a_name_far_longer_than_the_forty_seven_bytes_a_layout_takes");
    n += (size_t)snprintf(text + n, sizeof text - n,
                          "element face 1\nproperty list uchar int vertex_indices\nend_header\n");
    for (int v = 0; v < 2; v++) {
        n += (size_t)snprintf(text + n, sizeof text - n, "%d 0 0", v);
        for (int i = 0; i < EPSNET_ATTR_MAX + 3; i++)
            n += (size_t)snprintf(text + n, sizeof text - n, " %d", (i + v) % 256);
        n += (size_t)snprintf(text + n, sizeof text - n, " -7 2 1 2\n");
    }
    snprintf(text + n, sizeof text - n, "3 0 1 1\n");
    bytes b = { 0 };
    b_str(&b, text);
    const char *p = write_bytes("many_attrs.ply", &b);
    epsnet_reader *r = NULL;
    epsnet_error err;
    CHECK_EQ_INT(epsnet_reader_open(&r, p, NULL, &err), 0);
    if (!r)
        return;
    const epsnet_attr_layout *l = &epsnet_reader_info(r)->vertex_attrs;
    CHECK_EQ_U64(l->count, EPSNET_ATTR_MAX);
    CHECK_EQ_U64(l->size, EPSNET_ATTR_MAX);
    epsnet_record rec;
    uint64_t nv = 0;
    while (epsnet_reader_next(r, &rec, &err) == 1)
        if (rec.kind == EPSNET_REC_VERTEX) {
            for (uint32_t i = 0; i < l->count; i++)
                CHECK_EQ_INT(rec.attr[i], (int)((i + nv) % 256));
            nv++;
        }
    CHECK_EQ_U64(nv, 2);
    uint64_t nd = 0;
    const char *what = epsnet_reader_dropped(r, &nd);
    CHECK(what && strstr(what, "vertex property a32, vertex property a33, vertex property a34, vertex property "
                               "a_name_far_longer") != NULL);
    CHECK(what && strstr(what, "vertex property tags") != NULL);
    CHECK_EQ_U64(nd, 5);
    epsnet_reader_close(&r);
}

TEST(unused_elements_and_properties_are_named_as_dropped)
{
    /* vertex scalars are carried as attributes (epsnet.h §2), not dropped */
    static const char *want =
        "element camera (1), element edge (2), face property flags, face property weights, "
        "element material (1)";
    for (int enc = ASCII; enc <= BE; enc++) {
        layout l = { 1, "uchar", "int" };
        bytes b = make_ply(enc, &l);
        const char *p = write_bytes("dropped.ply", &b);
        char buf[1024];
        uint64_t n;
        const char *what = dropped_of(p, &n, buf, sizeof buf);
        CHECK(strcmp(what, want) == 0);
        CHECK_EQ_U64(n, 5);
        if (strcmp(what, want) != 0)
            fprintf(stderr, "  got: %s\n", what);
        l.with_extras = 0;
        b = make_ply(enc, &l);
        p = write_bytes("nothing_dropped.ply", &b);
        CHECK(strcmp(dropped_of(p, &n, buf, sizeof buf), "(null)") == 0);
        CHECK_EQ_U64(n, 0);
    }
    /* an element without records holds nothing to drop */
    const char *p = tl_write_str("empty_extra.ply",
                                 "ply\nformat ascii 1.0\nelement camera 0\nproperty float view_px\n"
                                 "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                                 "element tristrips 1\nproperty int tag\nproperty list int int vertex_indices\n"
                                 "end_header\n0 0 0\n5 1 0\n");
    char buf[256];
    uint64_t n;
    CHECK(strcmp(dropped_of(p, &n, buf, sizeof buf), "tristrips property tag") == 0);
    CHECK_EQ_U64(n, 1);
}

TEST(every_list_type_pair_reads_the_same_faces)
{
    static const char *pairs[][2] = {
        { "uchar", "int" }, { "ushort", "uint" }, { "int", "int" }, { "uint8", "uint16" },
        { "char", "short" }, { "int32", "uint32" }, { "uchar", "uchar" },
    };
    for (size_t i = 0; i < sizeof pairs / sizeof pairs[0]; i++)
        for (int enc = ASCII; enc <= BE; enc++) {
            layout l = { 0, pairs[i][0], pairs[i][1] };
            bytes b = make_ply(enc, &l);
            char name[64];
            snprintf(name, sizeof name, "types_%zu_%d.ply", i, enc);
            const char *p = write_bytes(name, &b);
            tl_mesh m;
            epsnet_error err;
            CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
            check_reference(&m);
            tl_mesh_free(&m);
        }
}

TEST(double_coordinates_set_float64_and_stay_exact)
{
    bytes b = { 0 };
    b_str(&b, "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty double x\n"
              "property double y\nproperty double z\nelement face 1\n"
              "property list uchar uint vertex_index\nend_header\n");
    const double v[9] = { 0.1, 0.2, 0.3, 1.0 / 3, -2e300, 5e-310, 7, 8, 9 };
    for (int i = 0; i < 9; i++)
        b_num(&b, &v[i], 8, 1);
    b_int(&b, "uchar", 3, 1);
    for (int k = 0; k < 3; k++)
        b_int(&b, "uint", 2 - k, 1);
    const char *p = write_bytes("double.ply", &b);
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
    CHECK_EQ_INT(m.info.coord_type, EPSNET_COORD_FLOAT64);
    CHECK_EQ_U64(m.nv, 3);
    CHECK_EQ_U64(m.nt, 1);
    if (m.nv == 3)
        CHECK(memcmp(m.xyz, v, sizeof v) == 0);
    if (m.nt == 1) {
        CHECK_EQ_U64(m.tri[0], 2);
        CHECK_EQ_U64(m.tri[1], 1);
        CHECK_EQ_U64(m.tri[2], 0);
    }
    tl_mesh_free(&m);
}

/*   Polygons with 0, 1 and 2 corners carry no triangle: skipped, not fatal.
 *   A pentagon fans into (0 1 2) (0 2 3) (0 3 4). */
TEST(short_polygons_are_skipped_and_pentagons_fanned)
{
    const char *p = tl_write_str("short.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
                                 "property float z\nelement face 4\nproperty list uchar int vertex_indices\n"
                                 "end_header\n0 0 0\n1 0 0\n1 1 0\n0.5 2 0\n0 1 0\n0\n1 3\n2 0 1\n5 0 1 2 3 4\n");
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
    CHECK_EQ_U64(m.nv, 5);
    CHECK_EQ_U64(m.nt, 3);
    const uint64_t want[9] = { 0, 1, 2, 0, 2, 3, 0, 3, 4 };
    if (m.nt == 3)
        CHECK(memcmp(m.tri, want, sizeof want) == 0);
    tl_mesh_free(&m);
    /* skipped, but named (docs/architecture.md §5) */
    epsnet_reader *r = NULL;
    CHECK_EQ_INT(epsnet_reader_open(&r, p, NULL, &err), 0);
    epsnet_record rec;
    while (r && epsnet_reader_next(r, &rec, &err) > 0)
        ;
    uint64_t n = 0;
    const char *what = r ? epsnet_reader_dropped(r, &n) : NULL;
    CHECK(what && strcmp(what, "faces with fewer than 3 corners (3)") == 0);
    CHECK_EQ_U64(n, 1);
    epsnet_reader_close(&r);
}

/* A polygon of 300000 corners (1.2 MB of indices, more than the reader's
 * window) still fans into 299998 triangles (0 k k+1), here over 3 vertices
 * whose indices cycle 0 1 2 0 1 2 ... */
TEST(polygon_longer_than_the_read_window_is_fanned)
{
    const int corners = 300000;
    bytes b = { 0 };
    b_str(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              "property float z\nelement face 1\nproperty list int int vertex_indices\nend_header\n");
    for (int i = 0; i < 9; i++) {
        float f = (float)i;
        b_num(&b, &f, 4, 0);
    }
    b_int(&b, "int", corners, 0);
    for (int k = 0; k < corners; k++)
        b_int(&b, "int", k % 3, 0);
    const char *p = write_bytes("long_polygon.ply", &b);
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
    CHECK_EQ_U64(m.nt, (uint64_t)corners - 2);
    int bad = 0;
    for (uint64_t t = 0; t < m.nt; t++)
        bad += m.tri[3 * t] != 0 || m.tri[3 * t + 1] != (t + 1) % 3 || m.tri[3 * t + 2] != (t + 2) % 3;
    CHECK_EQ_INT(bad, 0);
    tl_mesh_free(&m);
}

TEST(empty_mesh_and_point_cloud_are_valid)
{
    const char *p = tl_write_str("empty.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 0\n"
                                              "property float x\nproperty float y\nproperty float z\n"
                                              "element face 0\nproperty list uchar int vertex_indices\n"
                                              "end_header\n");
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
    CHECK_EQ_U64(m.nv, 0);
    CHECK_EQ_U64(m.nt, 0);
    CHECK_EQ_U64(m.info.nfaces, 0);
    tl_mesh_free(&m);
    p = tl_write_str("points.ply", "ply\r\nformat ascii 1.0\r\nelement vertex 2\r\nproperty float x\r\n"
                                   "property float y\r\nproperty float z\r\nend_header\r\n1 2 3\r\n4 5 6\r\n\r\n");
    CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
    CHECK_EQ_U64(m.nv, 2);
    CHECK_EQ_U64(m.nt, 0);
    if (m.nv == 2)
        CHECK(m.xyz[5] == 6.0);
    tl_mesh_free(&m);
}

TEST(content_probe_finds_ply_without_the_extension)
{
    layout l = { 0, "uchar", "int" };
    bytes b = make_ply(LE, &l);
    const char *p = write_bytes("mesh.data", &b);
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
    check_reference(&m);
    tl_mesh_free(&m);
}

/* ---- bad input: one error with file, position and reason ---- */

static void expect_error(const char *name, const void *data, size_t n, int code, const char *where,
                         const char *reason)
{
    const char *p = tl_write(name, data, n);
    tl_mesh m;
    epsnet_error err;
    memset(&err, 0, sizeof err);
    int rc = tl_read_mesh(p, &m, &err);
    tl_mesh_free(&m);
    CHECK_EQ_INT(rc, code);
    const char *msg = epsnet_error_message(&err);
    CHECK_STR_CONTAINS(msg, p);
    CHECK_STR_CONTAINS(msg, where);
    CHECK_STR_CONTAINS(msg, reason);
}

static void expect_error_str(const char *name, const char *text, int code, const char *where,
                             const char *reason)
{
    expect_error(name, text, strlen(text), code, where, reason);
}

#define HDR_ASCII                                                                                  \
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n" \
    "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
/* HDR_ASCII is 9 lines: the first vertex is on line 10, the face on line 13. */

TEST(truncated_binary_names_the_byte_offset)
{
    layout l = { 0, "uchar", "int" };
    bytes b = make_ply(LE, &l);
    size_t header = (size_t)(strstr((char *)b.d, "end_header\n") - (char *)b.d) + 11;
    /* cut in the middle of vertex 6 (0-based 5): it starts at header + 60 */
    char where[64];
    snprintf(where, sizeof where, ": byte %zu:", header + 60);
    expect_error("trunc_v.ply", b.d, header + 60 + 7, EPSNET_EFORMAT, where, "truncated");
    /* cut inside the indices of the quad, after 4 faces of 13 bytes: the
     * error points at the start of the face that is incomplete */
    size_t faces = header + 12 * NV;
    snprintf(where, sizeof where, ": byte %zu:", faces + 4 * 13);
    expect_error("trunc_f.ply", b.d, faces + 4 * 13 + 1 + 4 * 2 + 3, EPSNET_EFORMAT, where,
                 "face 5 of 5 is incomplete");
    free(b.d);
}

TEST(truncated_ascii_names_the_last_line)
{
    expect_error_str("trunc.ply", HDR_ASCII "0 0 0\n1 0 0\n0 1 0\n", EPSNET_EFORMAT, ":12:",
                     "face 1 of 1 is missing");
    expect_error_str("trunc_v.ply", HDR_ASCII "0 0 0\n1 0 0\n", EPSNET_EFORMAT, ":11:",
                     "vertex 3 of 3 is missing");
}

TEST(vertex_count_lying_up_or_down_is_an_error)
{
    /* up: the face line is read as a fourth vertex and has a value too many */
    expect_error_str("lie_up.ply",
                     "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                     "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
                     EPSNET_EFORMAT, ":13:", "extra value '2'");
    /* down: the third vertex is read as a face and '0.5' is no count */
    expect_error_str("lie_down.ply",
                     "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                     "0 0 0\n1 0 0\n0.5 1 0\n3 0 1 2\n",
                     EPSNET_EFORMAT, ":12:", "'0.5' is not a valid uchar list count");
    /* down, and the records happen to parse: the surplus is trailing data */
    expect_error_str("lie_down2.ply",
                     "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                     "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 2 1 0\n",
                     EPSNET_EFORMAT, ":14:", "trailing data");
    /* binary, count lying down: the leftover bytes are trailing data */
    layout l = { 0, "uchar", "int" };
    bytes b = make_ply(LE, &l);
    char *five = strstr((char *)b.d, "element face 5");
    five[13] = '4';
    size_t header = (size_t)(strstr((char *)b.d, "end_header\n") - (char *)b.d) + 11;
    char where[64];
    snprintf(where, sizeof where, ": byte %zu:", header + 12 * NV + 4 * 13);
    expect_error("lie_bin.ply", b.d, b.n, EPSNET_EFORMAT, where, "trailing data");
    free(b.d);
}

TEST(bad_indices_are_rejected_with_their_position)
{
    expect_error_str("range.ply", HDR_ASCII "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", EPSNET_EFORMAT, ":13:",
                     "references vertex 4 but only 3 vertices precede it");
    expect_error_str("neg.ply", HDR_ASCII "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", EPSNET_EFORMAT, ":13:",
                     "negative vertex index -1");
    layout l = { 0, "uchar", "int" };
    bytes b = make_ply(BE, &l);
    size_t header = (size_t)(strstr((char *)b.d, "end_header\n") - (char *)b.d) + 11;
    size_t third_index_of_face2 = header + 12 * NV + 13 + 1 + 8;
    b.d[third_index_of_face2 + 3] = 8;   /* big-endian int 3 -> 8 */
    char where[64];
    snprintf(where, sizeof where, ": byte %zu:", third_index_of_face2);
    expect_error("range_be.ply", b.d, b.n, EPSNET_EFORMAT, where, "vertex index 8 is out of range");
    memset(b.d + third_index_of_face2, 0xff, 4);
    expect_error("neg_be.ply", b.d, b.n, EPSNET_EFORMAT, where, "negative vertex index -1");
    free(b.d);
}

TEST(non_finite_and_garbage_values_are_rejected)
{
    expect_error_str("nan.ply", HDR_ASCII "0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n", EPSNET_EFORMAT, ":11:",
                     "non-finite");
    expect_error_str("inf.ply", HDR_ASCII "0 0 0\n1 0 1e999\n0 1 0\n3 0 1 2\n", EPSNET_EFORMAT, ":11:",
                     "non-finite");
    expect_error_str("garbage.ply", HDR_ASCII "0 0 0\n1 abc 0\n0 1 0\n3 0 1 2\n", EPSNET_EFORMAT, ":11:",
                     "'abc' is not a valid float for 'y'");
    expect_error_str("missing.ply", HDR_ASCII "0 0 0\n1 0\n0 1 0\n3 0 1 2\n", EPSNET_EFORMAT, ":11:",
                     "missing value for 'z'");
    layout l = { 0, "uchar", "int" };
    bytes b = make_ply(LE, &l);
    size_t header = (size_t)(strstr((char *)b.d, "end_header\n") - (char *)b.d) + 11;
    memcpy(b.d + header + 12 * 2 + 4, "\x00\x00\xc0\x7f", 4);   /* y of vertex 3 = NaN */
    char where[64];
    snprintf(where, sizeof where, ": byte %zu:", header + 12 * 2);
    expect_error("nan_le.ply", b.d, b.n, EPSNET_EFORMAT, where, "vertex 3 has a non-finite coordinate");
    free(b.d);
}

TEST(absurd_counts_fail_before_reading_data)
{
    expect_error_str("huge.ply",
                     "ply\nformat binary_little_endian 1.0\nelement vertex 1099511627776\nproperty float x\n"
                     "property float y\nproperty float z\nend_header\n",
                     EPSNET_ELIMIT, ":3:", "vertex count 1099511627776 exceeds the limit");
    expect_error_str("hugelist.ply",
                     "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list int int vertex_indices\nend_header\n"
                     "0 0 0\n1 0 0\n0 1 0\n200000000 0 1 2\n",
                     EPSNET_EFORMAT, ":13:", "list count 200000000 is out of range");
    bytes b = { 0 };
    b_str(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              "property float z\nelement face 1\nproperty list int int vertex_indices\nend_header\n");
    size_t header = b.n;
    float zero = 0;
    for (int i = 0; i < 9; i++)
        b_num(&b, &zero, 4, 0);
    b_int(&b, "int", 200000000, 0);
    char where[64];
    snprintf(where, sizeof where, ": byte %zu:", header + 36);
    expect_error("hugelist_le.ply", b.d, b.n, EPSNET_EFORMAT, where, "list count 200000000 is out of range");
    free(b.d);
}

TEST(header_errors_name_their_line)
{
    expect_error_str("face_first.ply",
                     "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
                     "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
                     "3 0 1 2\n0 0 0\n1 0 0\n0 1 0\n",
                     EPSNET_EFORMAT, ":5:", "'face' comes before element 'vertex'");
    expect_error_str("format.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n", EPSNET_EFORMAT, ":2:",
                     "unknown PLY format 'binary_middle_endian'");
    expect_error_str("no_z.ply",
                     "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
                     EPSNET_EFORMAT, ":6:", "lacks property 'z'");
    expect_error_str("type.ply",
                     "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n", EPSNET_EFORMAT,
                     ":4:", "unknown property type 'float128'");
    expect_error_str("no_end.ply", "ply\nformat ascii 1.0\nelement vertex 0\n", EPSNET_EFORMAT, ":3:",
                     "no 'end_header'");
    /* a misspelt element: its line is skipped (below), so its property
     * belongs to no element */
    expect_error_str("keyword.ply", "ply\nformat ascii 1.0\nelemnt vertex 1\nproperty float x\nend_header\n",
                     EPSNET_EFORMAT, ":4:", "before any element");
}

/* Some exporters write free text into the header ("Created by ..."): the
 * line is skipped and named, the mesh read as if it were not there. */
TEST(unknown_header_line_is_skipped_and_named)
{
    const char *p = tl_write_str("created_by.ply",
                                 "ply\nformat ascii 1.0\nCreated by SomeScanner 2.1\nelement vertex 3\n"
                                 "property float x\nproperty float y\nproperty float z\n"
                                 "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                                 "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
    CHECK_EQ_U64(m.nv, 3);
    CHECK_EQ_U64(m.nt, 1);
    tl_mesh_free(&m);
    uint64_t n = 0;
    char buf[256];
    CHECK(strcmp(dropped_of(p, &n, buf, sizeof buf), "header line 'Created' (1)") == 0);
    CHECK_EQ_U64(n, 1);
}

/* ---- writing ---- */

static int count_dir_entries(void)
{
    DIR *d = opendir(tl_tmpdir());
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, ".."))
            n++;
    closedir(d);
    return n;
}

/*
 * A streaming input: triangles interleaved with vertices, and FINALIZE
 * records, as the generator and the simplifier produce them.
 *
 *   v0 v1 v2 T(0 1 2) F0 v3 T(1 3 2) F1 v4 T(2 3 4) F2 F3 F4
 */
static const double stream_xyz[5][3] = {
    { 0.1, 0.2, 0.3 }, { 1.0 / 3, 2.5, -1e-7 }, { 7e20, -0.0, 1.25 }, { 2, 3, 4 }, { -5, 6.000001, 0.7 },
};
static const uint64_t stream_tri[3][3] = { { 0, 1, 2 }, { 1, 3, 2 }, { 2, 3, 4 } };

static int write_stream(const char *path, const epsnet_writer_settings *ws, const epsnet_mesh_info *info,
                        epsnet_error *err)
{
    epsnet_writer *w = NULL;
    int rc = epsnet_writer_open(&w, path, ws, info, err);
    if (rc)
        return rc;
    static const char plan[] = "vvvtfvtfvtfff";
    int v = 0, t = 0, f = 0;
    for (const char *c = plan; *c && rc == 0; c++) {
        epsnet_record rec;
        memset(&rec, 0, sizeof rec);
        if (*c == 'v') {
            rec.kind = EPSNET_REC_VERTEX;
            memcpy(rec.xyz, stream_xyz[v++], sizeof rec.xyz);
        } else if (*c == 't') {
            rec.kind = EPSNET_REC_TRIANGLE;
            memcpy(rec.v, stream_tri[t++], sizeof rec.v);
        } else {
            rec.kind = EPSNET_REC_FINALIZE;
            rec.v[0] = (uint64_t)f++;
        }
        rc = epsnet_writer_put(w, &rec, err);
    }
    if (rc == 0)
        return epsnet_writer_commit(&w, err);
    epsnet_writer_abort(&w);
    return rc;
}

/* ---- triangle strips (element tristrips) ---- */

/*
 *   1 --- 3 --- 5 --- 7
 *   | \   | \   | \   |
 *   |   \ |   \ |   \ |
 *   0 --- 2 --- 4 --- 6
 *
 * Record 1 holds the strip 0 1 2 3 4 5, a -1, then the strip 4 5 6 7 (with
 * no -1 after it); record 2 the strip 6 7 4 (one triangle). Triangle i of a
 * strip is (v[i] v[i+1] v[i+2]) for even i and (v[i+1] v[i] v[i+2]) for odd
 * i, counted from the strip's start, so all face -z like (0 1 2):
 */
#define STRIP_NV 8
static const int64_t strip_rec1[] = { 0, 1, 2, 3, 4, 5, -1, 4, 5, 6, 7 };
static const int64_t strip_rec2[] = { 6, 7, 4, -1 };
#define STRIP_NT 7
static const uint64_t strip_tri[STRIP_NT][3] = {
    { 0, 1, 2 }, { 2, 1, 3 }, { 2, 3, 4 }, { 4, 3, 5 }, { 4, 5, 6 }, { 6, 5, 7 }, { 6, 7, 4 },
};

/* The strip mesh as PLY: strips when face is 0, else its triangle list. */
static bytes make_strip_ply(int enc, const char *count_type, const char *index_type, int face)
{
    bytes b = { 0 };
    char line[256];
    snprintf(line, sizeof line,
             "ply\nformat %s 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
             "element %s %d\nproperty list %s %s vertex_indices\nend_header\n",
             enc_name[enc], STRIP_NV, face ? "face" : "tristrips", face ? STRIP_NT : 2, count_type, index_type);
    b_str(&b, line);
    for (int i = 0; i < STRIP_NV; i++) {
        float xyz[3] = { (float)(i / 2) + 0.1f, (float)(i % 2), 0.5f };
        if (enc == ASCII) {
            snprintf(line, sizeof line, "%.9g %.9g %.9g\n", (double)xyz[0], (double)xyz[1], (double)xyz[2]);
            b_str(&b, line);
        } else {
            for (int k = 0; k < 3; k++)
                b_num(&b, &xyz[k], 4, enc == BE);
        }
    }
    const int64_t *rec[2] = { strip_rec1, strip_rec2 };
    const size_t len[2] = { sizeof strip_rec1 / sizeof *strip_rec1, sizeof strip_rec2 / sizeof *strip_rec2 };
    for (int f = 0; f < (face ? STRIP_NT : 2); f++) {
        size_t n = face ? 3 : len[f];
        int64_t v[16];
        for (size_t k = 0; k < n; k++)
            v[k] = face ? (int64_t)strip_tri[f][k] : rec[f][k];
        if (enc == ASCII) {
            int at = snprintf(line, sizeof line, "%zu", n);
            for (size_t k = 0; k < n; k++)
                at += snprintf(line + at, sizeof line - (size_t)at, " %lld",
                               v[k] < 0 && index_type[0] == 'u' ? 4294967295LL : (long long)v[k]);
            snprintf(line + at, sizeof line - (size_t)at, "\n");
            b_str(&b, line);
            continue;
        }
        b_int(&b, count_type, (int64_t)n, enc == BE);
        for (size_t k = 0; k < n; k++)
            b_int(&b, index_type, v[k], enc == BE);
    }
    return b;
}

TEST(tristrips_give_the_triangles_of_their_triangle_list_twin)
{
    static const char *types[][2] = { { "int", "int" }, { "uchar", "int" }, { "uint", "int" }, { "uchar", "uint" } };
    for (size_t t = 0; t < sizeof types / sizeof types[0]; t++)
        for (int enc = ASCII; enc <= BE; enc++) {
            char name[64];
            snprintf(name, sizeof name, "strips_%zu_%d.ply", t, enc);
            bytes b = make_strip_ply(enc, types[t][0], types[t][1], 0);
            const char *strips = write_bytes(name, &b);
            snprintf(name, sizeof name, "twin_%zu_%d.ply", t, enc);
            b = make_strip_ply(enc, types[t][0], types[t][1], 1);
            const char *twin = write_bytes(name, &b);
            tl_mesh m, w;
            epsnet_error err;
            int rc = tl_read_mesh(strips, &m, &err);
            CHECK_EQ_INT(rc, 0);
            if (rc)
                fprintf(stderr, "  %s\n", epsnet_error_message(&err));
            CHECK_EQ_INT(tl_read_mesh(twin, &w, &err), 0);
            CHECK_EQ_U64(m.nv, STRIP_NV);
            CHECK_EQ_U64(m.nt, STRIP_NT);
            CHECK_EQ_U64(w.nt, STRIP_NT);
            CHECK_EQ_U64(m.info.nfaces, EPSNET_COUNT_UNKNOWN);
            if (m.nt == STRIP_NT && w.nt == STRIP_NT) {
                CHECK(memcmp(m.tri, strip_tri, sizeof strip_tri) == 0);
                CHECK(memcmp(m.tri, w.tri, sizeof strip_tri) == 0);
            }
            if (m.nv == STRIP_NV && w.nv == STRIP_NV)
                CHECK(memcmp(m.xyz, w.xyz, 3 * STRIP_NV * sizeof *m.xyz) == 0);
            tl_mesh_free(&m);
            tl_mesh_free(&w);
        }
}

/*   The strip 0 1 2 2 3 4 turns with a repeated index: its triangles are
 *   (0 1 2), [2 1 2], [2 2 3], (3 2 4) at i = 0..3. The two that repeat an
 *   index encode no surface and are skipped, but odd i = 3 still swaps. A
 *   strip shorter than 3 and empty strips (-1 -1) give nothing. */
TEST(strip_turns_are_skipped_and_keep_the_parity)
{
    const char *p = tl_write_str("turns.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
                                 "property float z\nelement tristrips 1\nproperty list int int vertex_indices\n"
                                 "end_header\n0 0 0\n1 0 0\n1 1 0\n0.5 2 0\n0 1 0\n"
                                 "12 0 1 2 2 3 4 -1 -1 0 1 -1 -1\n");
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
    CHECK_EQ_U64(m.nt, 2);
    const uint64_t want[6] = { 0, 1, 2, 3, 2, 4 };
    if (m.nt == 2)
        CHECK(memcmp(m.tri, want, sizeof want) == 0);
    tl_mesh_free(&m);
}

/* One strip of 200000 indices zigzagging between two rows of 100000
 * vertices: longer than the read window (in ascii, a 1.3 MB line) and than
 * one fill()'s batch of triangles, so the list is read in pieces. Triangle
 * i is (i i+1 i+2) in strip order, swapped for odd i. */
TEST(strip_longer_than_the_read_window_is_read_in_pieces)
{
    const int row = 100000, n = 2 * row;
    static const char *names[] = { "long_strip_ascii.ply", "long_strip_le.ply", "long_strip_be.ply" };
    for (int enc = ASCII; enc <= BE; enc++) {
        bytes b = { 0 };
        char line[256];
        snprintf(line, sizeof line,
                 "ply\nformat %s 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
                 "property float z\nelement tristrips 1\nproperty int tag\nproperty list int int vertex_indices\n"
                 "property uchar after\nend_header\n",
                 enc_name[enc], n);
        b_str(&b, line);
        for (int i = 0; i < n; i++) {
            float xyz[3] = { (float)(i % row), (float)(i / row), 0 };
            if (enc == ASCII) {
                snprintf(line, sizeof line, "%d %d 0\n", i % row, i / row);
                b_str(&b, line);
                continue;
            }
            for (int k = 0; k < 3; k++)
                b_num(&b, &xyz[k], 4, enc == BE);
        }
        if (enc == ASCII) {
            snprintf(line, sizeof line, "\n  7\t%d", n);
            b_str(&b, line);
            for (int k = 0; k < n; k++) {
                snprintf(line, sizeof line, " %d", (k % 2) * row + k / 2);
                b_str(&b, line);
            }
            b_str(&b, " 1\r\n\n");
        } else {
            b_int(&b, "int", 7, enc == BE);
            b_int(&b, "int", n, enc == BE);
            for (int k = 0; k < n; k++)
                b_int(&b, "int", (k % 2) * row + k / 2, enc == BE);
            b_int(&b, "uchar", 1, 0);
        }
        const char *p = write_bytes(names[enc], &b);
        tl_mesh m;
        epsnet_error err;
        int rc = tl_read_mesh(p, &m, &err);
        CHECK_EQ_INT(rc, 0);
        if (rc)
            fprintf(stderr, "  %s\n", epsnet_error_message(&err));
        CHECK_EQ_U64(m.nt, (uint64_t)n - 2);
        int bad = 0;
        for (uint64_t t = 0; t < m.nt; t++) {
            uint64_t v[3] = { t, t + 1, t + 2 };
            if (t & 1) {
                v[0] = t + 1;
                v[1] = t;
            }
            for (int k = 0; k < 3; k++)
                bad += m.tri[3 * t + k] != (v[k] % 2) * (uint64_t)row + v[k] / 2;
        }
        CHECK_EQ_INT(bad, 0);
        tl_mesh_free(&m);
    }
}

#define HDR_STRIPS                                                                                 \
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n" \
    "element tristrips 1\nproperty list int int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
/* HDR_STRIPS is 12 lines: the strip is on line 13. */

TEST(bad_strip_indices_are_rejected_with_their_position)
{
    expect_error_str("strip_range.ply", HDR_STRIPS "5 0 1 2 -1 3\n", EPSNET_EFORMAT, ":13:",
                     "tristrips 1: vertex index 3 is out of range (3 vertices)");
    expect_error_str("strip_neg.ply", HDR_STRIPS "3 0 -2 1\n", EPSNET_EFORMAT, ":13:",
                     "tristrips 1: negative vertex index -2");
    expect_error_str("strip_short.ply", HDR_STRIPS "4 0 1 2\n", EPSNET_EFORMAT, ":13:",
                     "missing value for 'vertex_indices'");
    expect_error_str("strip_extra.ply", HDR_STRIPS "\n3 0 1 2 9\n", EPSNET_EFORMAT, ":14:",
                     "tristrips 1: unexpected extra value '9'");
    expect_error_str("strip_missing.ply", HDR_STRIPS "\n", EPSNET_EFORMAT, ":13:",
                     "truncated file: tristrips 1 of 1 is missing");
    expect_error_str("strip_lie.ply", HDR_STRIPS "3 0 1 2\n3 0 1 2\n", EPSNET_EFORMAT, ":14:",
                     "trailing data");
    char longval[512];
    snprintf(longval, sizeof longval, "%s3 0 1 %0200d\n", HDR_STRIPS, 2);
    expect_error_str("strip_long_value.ply", longval, EPSNET_EFORMAT, ":13:", "a value longer than 127 bytes");
    expect_error("strip_nul.ply", HDR_STRIPS "3 0 1 \0002\n", sizeof HDR_STRIPS + 8, EPSNET_EFORMAT, ":13:",
                 "NUL byte");
    /* binary big-endian: the error names the byte of the bad index */
    bytes b = make_strip_ply(BE, "int", "int", 0);
    size_t header = (size_t)(strstr((char *)b.d, "end_header\n") - (char *)b.d) + 11;
    size_t fifth = header + 12 * STRIP_NV + 4 + 4 * 4;
    b.d[fifth + 3] = 9;  /* 4 -> 9 */
    char where[64];
    snprintf(where, sizeof where, ": byte %zu:", fifth);
    expect_error("strip_range_be.ply", b.d, b.n, EPSNET_EFORMAT, where, "vertex index 9 is out of range");
    b.d[fifth + 3] = 4;
    expect_error("strip_trunc_be.ply", b.d, b.n - 5, EPSNET_EFORMAT, "byte", "tristrips 2 of 2 is incomplete");
    free(b.d);
}

static void check_stream(const char *path, int coord64)
{
    tl_mesh m;
    epsnet_error err;
    int rc = tl_read_mesh(path, &m, &err);
    CHECK_EQ_INT(rc, 0);
    if (rc)
        fprintf(stderr, "  %s\n", epsnet_error_message(&err));
    CHECK_EQ_U64(m.nv, 5);
    CHECK_EQ_U64(m.nt, 3);
    CHECK_EQ_U64(m.nfin, 0);
    CHECK_EQ_INT(m.info.coord_type, coord64 ? EPSNET_COORD_FLOAT64 : EPSNET_COORD_FLOAT32);
    if (m.nv == 5)
        for (int i = 0; i < 5; i++)
            for (int k = 0; k < 3; k++) {
                double want = coord64 ? stream_xyz[i][k] : (double)(float)stream_xyz[i][k];
                CHECK(memcmp(&m.xyz[3 * i + k], &want, sizeof want) == 0);
            }
    if (m.nt == 3)
        CHECK(memcmp(m.tri, stream_tri, sizeof stream_tri) == 0);
    tl_mesh_free(&m);
}

TEST(streaming_input_round_trips_in_every_writer_mode)
{
    static const char *names[] = { "rt.ply", "rt.ply.zst" };
    for (int zst = 0; zst < 2; zst++)
        for (int ascii = 0; ascii < 2; ascii++)
            for (int coord64 = 0; coord64 < 2; coord64++)
                for (int known = 0; known < 2; known++) {
                    epsnet_writer_settings ws;
                    epsnet_writer_default_settings(&ws);
                    ws.ascii = ascii;
                    ws.coord_type = coord64;
                    epsnet_mesh_info info;
                    memset(&info, 0, sizeof info);
                    info.nverts = known ? 5 : EPSNET_COUNT_UNKNOWN;
                    info.nfaces = known ? 3 : EPSNET_COUNT_UNKNOWN;
                    info.sorted_axis = -1;
                    const char *p = tl_path(names[zst]);
                    epsnet_error err;
                    int rc = write_stream(p, &ws, &info, &err);
                    CHECK_EQ_INT(rc, 0);
                    if (rc)
                        fprintf(stderr, "  zst=%d ascii=%d coord64=%d known=%d: %s\n", zst, ascii, coord64,
                                known, epsnet_error_message(&err));
                    check_stream(p, coord64);
                    remove(p);
                }
}

TEST(reference_mesh_round_trips_through_the_writer)
{
    layout l = { 1, "ushort", "uint" };
    bytes b = make_ply(BE, &l);
    const char *in = write_bytes("rt_in.ply", &b);
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(in, &m, &err), 0);
    for (int ascii = 0; ascii < 2; ascii++) {
        epsnet_writer_settings ws;
        epsnet_writer_default_settings(&ws);
        ws.ascii = ascii;
        const char *out = tl_path(ascii ? "rt_out_a.ply" : "rt_out_b.ply");
        CHECK_EQ_INT(tl_write_mesh(out, &m, &ws, &err), 0);
        tl_mesh back;
        CHECK_EQ_INT(tl_read_mesh(out, &back, &err), 0);
        check_reference(&back);
        CHECK(strcmp(back.info.encoding, ascii ? "ascii" : "binary_le") == 0);
        tl_mesh_free(&back);
    }
    tl_mesh_free(&m);
}

TEST(binary_output_is_standard_little_endian_ply)
{
    /*   0 --- 1      one triangle, float coordinates, known counts
     *    \   /
     *      2                                                          */
    tl_mesh m;
    memset(&m, 0, sizeof m);
    double xyz[9] = { 0, 0, 0, 1, 0, 0, 0.5, -1, 0 };
    uint64_t tri[3] = { 0, 2, 1 };
    m.xyz = xyz;
    m.tri = tri;
    m.nv = 3;
    m.nt = 1;
    m.info.coord_type = EPSNET_COORD_FLOAT32;
    const char *out = tl_path("std.ply");
    epsnet_error err;
    CHECK_EQ_INT(tl_write_mesh(out, &m, NULL, &err), 0);
    FILE *f = fopen(out, "rb");
    char buf[2048];
    size_t n = f ? fread(buf, 1, sizeof buf - 1, f) : 0;
    if (f)
        fclose(f);
    buf[n] = '\0';
    CHECK(strncmp(buf, "ply\nformat binary_little_endian 1.0\n", 36) == 0);
    CHECK_STR_CONTAINS(buf, "\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                            "element face 1\nproperty list uchar int vertex_indices\n");
    char *end = strstr(buf, "end_header\n");
    CHECK(end != NULL);
    if (end) {
        size_t body = (size_t)(end + 11 - buf);
        CHECK_EQ_U64(n, body + 36 + 13);
        const uint8_t face[13] = { 3, 0, 0, 0, 0, 2, 0, 0, 0, 1, 0, 0, 0 };
        CHECK(n >= body + 49 && memcmp(buf + body + 36, face, 13) == 0);
        float y2 = -1;
        uint8_t le[4];
        memcpy(le, &y2, 4);
        if (host_is_be())
            for (int i = 0; i < 2; i++) {
                uint8_t t = le[i];
                le[i] = le[3 - i];
                le[3 - i] = t;
            }
        CHECK(n >= body + 36 && memcmp(buf + body + 28, le, 4) == 0);
    }
}

TEST(failed_conversion_leaves_no_output)
{
    const char *in = tl_write_str("bad_in.ply", HDR_ASCII "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
    int before = count_dir_entries();
    static const char *outs[] = { "never.ply", "never.ply.zst" };
    for (int i = 0; i < 2; i++) {
        epsnet_reader *r = NULL;
        epsnet_writer *w = NULL;
        epsnet_error err;
        int rc = epsnet_reader_open(&r, in, NULL, &err);
        CHECK_EQ_INT(rc, 0);
        const char *out = tl_path(outs[i]);
        if (rc == 0)
            rc = epsnet_writer_open(&w, out, NULL, epsnet_reader_info(r), &err);
        CHECK_EQ_INT(rc, 0);
        epsnet_record rec;
        while (rc == 0 && (rc = epsnet_reader_next(r, &rec, &err)) > 0)
            rc = epsnet_writer_put(w, &rec, &err);
        CHECK_EQ_INT(rc, EPSNET_EFORMAT);
        CHECK_STR_CONTAINS(epsnet_error_message(&err), ":13:");
        epsnet_writer_abort(&w);
        epsnet_reader_close(&r);
        CHECK(w == NULL);
        CHECK(!tl_exists(out));
        CHECK_EQ_INT(count_dir_entries(), before);
    }
}

TEST(writer_rejects_vertices_beyond_the_announced_count)
{
    /* Faces go straight to the file once the announced vertices are in; a
     * later vertex would corrupt it, so it is refused and nothing remains. */
    const char *out = tl_path("announced.ply");
    epsnet_mesh_info info;
    memset(&info, 0, sizeof info);
    info.nverts = 3;
    info.nfaces = EPSNET_COUNT_UNKNOWN;
    epsnet_writer *w = NULL;
    epsnet_error err;
    CHECK_EQ_INT(epsnet_writer_open(&w, out, NULL, &info, &err), 0);
    epsnet_record rec = { .kind = EPSNET_REC_VERTEX, .xyz = { 1, 2, 3 } };
    for (int i = 0; i < 3; i++)
        CHECK_EQ_INT(epsnet_writer_put(w, &rec, &err), 0);
    epsnet_record tri = { .kind = EPSNET_REC_TRIANGLE, .v = { 0, 1, 2 } };
    CHECK_EQ_INT(epsnet_writer_put(w, &tri, &err), 0);
    CHECK_EQ_INT(epsnet_writer_put(w, &rec, &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "vertex 4 arrives after the 3 vertices announced");
    epsnet_writer_abort(&w);
    CHECK(!tl_exists(out));
}

TEST(zst_output_with_wrong_announced_counts_fails_cleanly)
{
    epsnet_writer_settings ws;
    epsnet_writer_default_settings(&ws);
    epsnet_mesh_info info;
    memset(&info, 0, sizeof info);
    info.nverts = 6;
    info.nfaces = 3;
    const char *p = tl_path("lying.ply.zst");
    epsnet_error err;
    CHECK_EQ_INT(write_stream(p, &ws, &info, &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "announced 6 vertices and 3 triangles but got 5 and 3");
    CHECK(!tl_exists(p));
}

/* ---- records decoded ahead on the pool (fmt_ply.c, "Decoding ahead") ---- */

/* What a reader gave: its records with their attribute bytes, and how it
 * ended. */
typedef struct read_out {
    epsnet_record *r;
    uint8_t *a;
    size_t n, cap, asz;
    int rc;
    char msg[600];
} read_out;

static void out_add(read_out *o, const epsnet_record *rec)
{
    if (o->n == o->cap) {
        o->cap = o->cap ? 2 * o->cap : 4096;
        o->r = realloc(o->r, o->cap * sizeof *o->r);
        o->a = realloc(o->a, o->cap * (o->asz ? o->asz : 1));
    }
    o->r[o->n] = *rec;
    o->r[o->n].attr = NULL;
    if (o->asz && rec->kind == EPSNET_REC_VERTEX)
        memcpy(o->a + o->n * o->asz, rec->attr, o->asz);
    o->n++;
}

/* Read the file at path one record at a time (ahead 0: no pool), or with
 * runs decoded ahead on a pool of two workers, in batches (the records in
 * place; ahead 1) or one at a time (through the queue; ahead 2), within a
 * reader's budget of mem bytes (0: none). */
static void read_all(const char *path, int ahead, uint64_t mem, read_out *o)
{
    memset(o, 0, sizeof *o);
    epsnet_error err;
    memset(&err, 0, sizeof err);
    epsnet_reader *r = NULL;
    en_pool *pool = NULL;
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    rs.mem_limit = mem;
    o->rc = epsnet_reader_open(&r, path, &rs, &err);
    if (o->rc == 0) {
        o->asz = epsnet_reader_info(r)->vertex_attrs.size;
        if (ahead) {
            CHECK_EQ_INT(en_pool_new(&pool, 2), 0);
            CHECK_EQ_INT(en_reader_use_pool(r, pool), 0);
        }
        if (ahead == 1) {
            const epsnet_record *recs;
            size_t n;
            while ((o->rc = en_reader_next_batch(r, &recs, &n, &err)) > 0)
                for (size_t i = 0; i < n; i++)
                    out_add(o, &recs[i]);
        } else {
            epsnet_record rec;
            while ((o->rc = epsnet_reader_next(r, &rec, &err)) > 0)
                out_add(o, &rec);
        }
        if (ahead)
            (void)en_reader_use_pool(r, NULL);
    }
    snprintf(o->msg, sizeof o->msg, "%s", o->rc ? epsnet_error_message(&err) : "");
    epsnet_reader_close(&r);
    en_pool_free(&pool);
}

/* The records of x and y that differ (kind, corners, coordinates, bytes). */
static size_t records_differ(const read_out *x, const read_out *y)
{
    size_t differ = x->n != y->n;
    for (size_t i = 0; i < x->n && i < y->n; i++) {
        const epsnet_record *a = &x->r[i], *b = &y->r[i];
        differ += a->kind != b->kind || memcmp(a->v, b->v, sizeof a->v) || memcmp(a->xyz, b->xyz, sizeof a->xyz) ||
                  (x->asz && a->kind == EPSNET_REC_VERTEX && memcmp(x->a + i * x->asz, y->a + i * x->asz, x->asz));
    }
    return differ;
}

/* Both ways give the same records, bytes and end (want_rc, and a message
 * with want_msg in it). @return the records. */
static size_t same_both_ways(const char *name, const bytes *b, int want_rc, const char *want_msg)
{
    const char *path = tl_write(name, b->d, b->n);
    read_out one, ahead, more[2];
    read_all(path, 0, 0, &one);
    read_all(path, 1, 0, &ahead);
    read_all(path, 1, (uint64_t)1 << 20, &more[0]); /* a run or two in flight */
    read_all(path, 2, 0, &more[1]);
    for (int k = 0; k < 2; k++) {
        CHECK_EQ_INT(more[k].rc, one.rc);
        CHECK(strcmp(more[k].msg, one.msg) == 0);
        CHECK_EQ_U64(records_differ(&more[k], &one), 0);
        free(more[k].r);
        free(more[k].a);
    }
    CHECK_EQ_INT(one.rc, want_rc);
    if (one.rc != want_rc)
        fprintf(stderr, "  %s: %s\n", name, one.msg);
    CHECK_EQ_INT(ahead.rc, one.rc);
    CHECK(strcmp(ahead.msg, one.msg) == 0);
    if (want_msg)
        CHECK_STR_CONTAINS(one.msg, want_msg);
    CHECK_EQ_U64(ahead.n, one.n);
    CHECK_EQ_U64(records_differ(&ahead, &one), 0);
    if (strcmp(ahead.msg, one.msg) != 0)
        fprintf(stderr, "  %s:\n    one by one: %s\n    ahead:      %s\n", name, one.msg, ahead.msg);
    size_t n = one.n;
    free(one.r);
    free(one.a);
    free(ahead.r);
    free(ahead.a);
    return n;
}

/* A W x H grid in binary order be: vertices x, y, z and an attribute
 * (quality); an element of its own between them and the faces, which
 * have a flags byte before the list and a float after it; mostly
 * triangles, every 7th cell a quad, one face of two corners, and with
 * long_at > 0 that face instead a fan of long_n corners (an int count). */
static bytes grid_ply(int be, int w, int h, size_t long_at, int64_t long_n)
{
    bytes b = { 0 };
    char line[512];
    size_t nf = 0;
    for (int j = 0; j + 1 < h; j++)
        for (int i = 0; i + 1 < w; i++)
            nf += (j * w + i) % 7 ? 2 : 1;
    nf++; /* the short (or long) face */
    snprintf(line, sizeof line,
             "ply\nformat %s 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
             "property float quality\nelement edge 2\nproperty int a\nproperty int b\nelement face %zu\n"
             "property uchar flags\nproperty list %s int vertex_indices\nproperty float area\nend_header\n",
             be ? "binary_big_endian" : "binary_little_endian", w * h, nf, long_at ? "int" : "uchar");
    b_str(&b, line);
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            float v[4] = { (float)i * 0.5f, (float)j * 0.25f, (float)((i * 7 + j * 3) % 11) * 0.125f,
                           (float)(i + j) };
            for (int k = 0; k < 4; k++)
                b_num(&b, &v[k], 4, be);
        }
    for (int e = 0; e < 2; e++) {
        b_int(&b, "int", e, be);
        b_int(&b, "int", e + 1, be);
    }
    const char *ct = long_at ? "int" : "uchar";
    float area = 0.5f;
    size_t f = 0;
    for (int j = 0; j + 1 < h; j++)
        for (int i = 0; i + 1 < w; i++) {
            int64_t a = j * w + i, c[4] = { a, a + 1, a + w + 1, a + w };
            if (f++ == (long_at ? long_at / 2 : 1000)) {
                b_int(&b, "uchar", 0, be);
                b_int(&b, ct, long_at ? long_n : 2, be);
                for (int64_t k = 0; k < (long_at ? long_n : 2); k++)
                    b_int(&b, "int", (a + k) % (w * h), be);
                b_num(&b, &area, 4, be);
            }
            int quad = (j * w + i) % 7 == 0;
            for (int t = 0; t < (quad ? 1 : 2); t++) {
                b_int(&b, "uchar", 1, be);
                b_int(&b, ct, quad ? 4 : 3, be);
                for (int k = 0; k < (quad ? 4 : 3); k++)
                    b_int(&b, "int", quad ? c[k] : c[t ? (k ? k + 1 : 0) : k], be);
                b_num(&b, &area, 4, be);
            }
        }
    return b;
}

/* Where the faces start in a grid_ply file. */
static size_t grid_faces_at(const bytes *b, int w, int h)
{
    size_t header = (size_t)(strstr((char *)b->d, "end_header\n") - (char *)b->d) + 11;
    return header + (size_t)w * (size_t)h * 16 + 16;
}

/* A binary file read with runs decoded ahead on the pool gives the records,
 * attributes, errors and positions of the one-thread walkers, wherever a
 * run starts or stops: the reference meshes, a grid of many runs, and that
 * grid damaged in its vertices and faces, cut short, and with a polygon
 * longer than the read window or a list count out of range. */
TEST(runs_decoded_ahead_give_the_walkers_records_and_errors)
{
    static const char *types[][2] = { { "uchar", "int" }, { "ushort", "uint" }, { "int", "short" } };
    for (int enc = LE; enc <= BE; enc++)
        for (int extras = 0; extras <= 1; extras++)
            for (size_t t = 0; t < 3; t++) {
                layout l = { extras, types[t][0], types[t][1] };
                bytes b = make_ply(enc, &l);
                CHECK_EQ_U64(same_both_ways("ahead_ref.ply", &b, 0, NULL), NV + NT);
                free(b.d);
            }
    const int w = 300, h = 200;
    for (int be = 0; be <= 1; be++) {
        bytes b = grid_ply(be, w, h, 0, 0);
        size_t n = same_both_ways("ahead_grid.ply", &b, 0, NULL);
        CHECK(n > 100000);
        size_t faces = grid_faces_at(&b, w, h);
        /* a NaN in the middle of the vertices (vertex 40,001's y) */
        uint8_t keep[4];
        size_t at = faces - 16 - (size_t)(w * h - 40000) * 16 + 4;
        memcpy(keep, b.d + at, 4);
        memcpy(b.d + at, be ? "\x7f\xc0\x00\x00" : "\x00\x00\xc0\x7f", 4);
        CHECK_EQ_U64(same_both_ways("ahead_nan.ply", &b, EPSNET_EFORMAT, "vertex 40001 has a non-finite"), 40000);
        memcpy(b.d + at, keep, 4);
        /* the first corner of cell 40,000's first face (of 59,501) out of
         * range, then negative (the cell's records: one quad of 22 bytes
         * in 7 cells, the others two triangles of 18, and the short face
         * of 14 at cell 1000) */
        at = faces;
        for (int j = 0, c = 0; j + 1 < h && c < 40000; j++)
            for (int i = 0; i + 1 < w && c < 40000; i++, c++)
                at += (c == 1000 ? 14 : 0) + ((j * w + i) % 7 == 0 ? 22 : 36);
        size_t corner = at + 2;
        memcpy(keep, b.d + corner, 4);
        bytes v = { 0 };
        b_int(&v, "int", w * h, be);
        b_int(&v, "int", -5, be);
        memcpy(b.d + corner, v.d, 4);
        same_both_ways("ahead_range.ply", &b, EPSNET_EFORMAT, "vertex index 60000 is out of range");
        memcpy(b.d + corner, v.d + 4, 4);
        same_both_ways("ahead_neg.ply", &b, EPSNET_EFORMAT, "negative vertex index -5");
        memcpy(b.d + corner, keep, 4);
        free(v.d);
        /* cut short in the vertices, in the faces; trailing bytes */
        size_t whole = b.n;
        b.n = faces / 2 + 5;
        same_both_ways("ahead_cut_v.ply", &b, EPSNET_EFORMAT, "truncated file: vertex");
        b.n = faces + (whole - faces) / 3 + 7;
        same_both_ways("ahead_cut_f.ply", &b, EPSNET_EFORMAT, "truncated file: face");
        b.n = whole;
        b_str(&b, "junk");
        same_both_ways("ahead_junk.ply", &b, EPSNET_EFORMAT, "trailing data");
        free(b.d);
        /* a polygon longer than a read window among the runs, then a list
         * count out of range */
        b = grid_ply(be, w, h, 60000, 140000);
        CHECK(same_both_ways("ahead_long.ply", &b, 0, NULL) > 240000);
        free(b.d);
        b = grid_ply(be, w, h, 60000, (int64_t)1 << 21);
        same_both_ways("ahead_count.ply", &b, EPSNET_EFORMAT, "list count 2097152 is out of range");
        free(b.d);
    }
}

int main(void)
{
    RUN(ascii_le_and_be_give_the_reference_records);
    RUN(extra_properties_and_elements_are_skipped);
    RUN(vertex_properties_are_carried_as_attributes);
    RUN(attributes_past_the_limit_are_named_as_dropped);
    RUN(unused_elements_and_properties_are_named_as_dropped);
    RUN(every_list_type_pair_reads_the_same_faces);
    RUN(double_coordinates_set_float64_and_stay_exact);
    RUN(short_polygons_are_skipped_and_pentagons_fanned);
    RUN(polygon_longer_than_the_read_window_is_fanned);
    RUN(empty_mesh_and_point_cloud_are_valid);
    RUN(content_probe_finds_ply_without_the_extension);
    RUN(truncated_binary_names_the_byte_offset);
    RUN(truncated_ascii_names_the_last_line);
    RUN(vertex_count_lying_up_or_down_is_an_error);
    RUN(bad_indices_are_rejected_with_their_position);
    RUN(non_finite_and_garbage_values_are_rejected);
    RUN(absurd_counts_fail_before_reading_data);
    RUN(header_errors_name_their_line);
    RUN(unknown_header_line_is_skipped_and_named);
    RUN(tristrips_give_the_triangles_of_their_triangle_list_twin);
    RUN(strip_turns_are_skipped_and_keep_the_parity);
    RUN(strip_longer_than_the_read_window_is_read_in_pieces);
    RUN(bad_strip_indices_are_rejected_with_their_position);
    RUN(streaming_input_round_trips_in_every_writer_mode);
    RUN(reference_mesh_round_trips_through_the_writer);
    RUN(binary_output_is_standard_little_endian_ply);
    RUN(failed_conversion_leaves_no_output);
    RUN(writer_rejects_vertices_beyond_the_announced_count);
    RUN(zst_output_with_wrong_announced_counts_fails_cleanly);
    RUN(runs_decoded_ahead_give_the_walkers_records_and_errors);
    int rc = tl_finish();
    tl_cleanup();
    return rc;
}
