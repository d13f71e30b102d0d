/*
 * SMA and SMB streaming meshes (src/io/fmt_sma.c, src/io/fmt_smb.c): exact
 * record sequences with finalization, the three SMB byte-order cases, round
 * trips through both formats and zstd, and hostile or truncated input.
 */
#include <zstd.h>

#include "testlib.h"

enum { MAX_RECORDS = 512 };

typedef struct records {
    epsnet_record rec[MAX_RECORDS];
    int n;
    epsnet_mesh_info info;
} records;

static int read_records(const char *path, records *out, epsnet_error *err)
{
    memset(out, 0, sizeof *out);
    epsnet_reader *r = NULL;
    int rc = epsnet_reader_open(&r, path, NULL, err);
    if (rc)
        return rc;
    out->info = *epsnet_reader_info(r);
    epsnet_record rec;
    while ((rc = epsnet_reader_next(r, &rec, err)) > 0 && out->n < MAX_RECORDS)
        out->rec[out->n++] = rec;
    epsnet_reader_close(&r);
    return rc < 0 ? rc : 0;
}

/* Write records with the given announced counts (EPSNET_COUNT_UNKNOWN ok). */
static int write_records(const char *path, const epsnet_record *rec, int n, uint64_t nverts,
                         uint64_t nfaces, epsnet_error *err)
{
    epsnet_mesh_info info;
    memset(&info, 0, sizeof info);
    info.nverts = nverts;
    info.nfaces = nfaces;
    info.coord_type = EPSNET_COORD_FLOAT32;
    info.sorted_axis = -1;
    epsnet_writer *w = NULL;
    int rc = epsnet_writer_open(&w, path, NULL, &info, err);
    for (int i = 0; i < n && rc == 0; i++)
        rc = epsnet_writer_put(w, &rec[i], err);
    if (rc == 0)
        return epsnet_writer_commit(&w, err);
    epsnet_writer_abort(&w);
    return rc;
}

#define V(x, y, z) { .kind = EPSNET_REC_VERTEX, .xyz = { x, y, z } }
#define T(a, b, c) { .kind = EPSNET_REC_TRIANGLE, .v = { a, b, c } }
#define F(a) { .kind = EPSNET_REC_FINALIZE, .v = { a } }

/* Exact equality of two record sequences; prints the first difference. */
static int same_records(const epsnet_record *a, int na, const epsnet_record *b, int nb)
{
    if (na != nb) {
        fprintf(stderr, "  %d records, expected %d\n", na, nb);
        return 0;
    }
    for (int i = 0; i < na; i++) {
        int same = a[i].kind == b[i].kind;
        if (same && a[i].kind == EPSNET_REC_VERTEX)
            same = memcmp(a[i].xyz, b[i].xyz, sizeof a[i].xyz) == 0;
        else if (same && a[i].kind == EPSNET_REC_TRIANGLE)
            same = memcmp(a[i].v, b[i].v, sizeof a[i].v) == 0;
        else if (same)
            same = a[i].v[0] == b[i].v[0];
        if (!same) {
            fprintf(stderr, "  record %d differs: kind %d v %llu %llu %llu, expected kind %d v %llu %llu %llu\n",
                    i, a[i].kind, (unsigned long long)a[i].v[0], (unsigned long long)a[i].v[1],
                    (unsigned long long)a[i].v[2], b[i].kind, (unsigned long long)b[i].v[0],
                    (unsigned long long)b[i].v[1], (unsigned long long)b[i].v[2]);
            return 0;
        }
    }
    return 1;
}

static void check_error(int rc, const epsnet_error *err, int code, const char *where, const char *reason)
{
    CHECK_EQ_INT(rc, code);
    const char *msg = epsnet_error_message(err);
    CHECK_STR_CONTAINS(msg, where);
    CHECK_STR_CONTAINS(msg, reason);
}

/*
 *   2 ------ 3
 *   |  \     |     triangles 0-1-2 and 1-3-2; 3 and 2 are finalized by the
 *   |    \   |     negative corners of the second one, 0 and 1 by x lines
 *   0 ------ 1
 */
static const epsnet_record square_with_x[] = {
    V(0, 0, 0), V(1, 0, 0), V(0, 1, 0), T(0, 1, 2), V(1, 1, 0), T(1, 3, 2), F(3), F(2), F(0), F(1),
};

static const char square_sma[] =
    "# nverts 4\n"
    "# nfaces 2\n"
    "# bb_min 0 0 0\n"
    "# bb_max 1 1 0\n"
    "# any other comment\n"
    "v 0 0 0\n"
    "v 1 0 0\n"
    "v 0 1 0\n"
    "f 1 2 3\n"
    "v 1 1 0\n"
    "f 2 -1 -2\n"
    "# comments may come between records\n"
    "x 1\n"
    "x -3\n";

TEST(sma_negative_indices_and_x_lines_give_the_exact_record_sequence)
{
    const char *path = tl_write_str("square.sma", square_sma);
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK(same_records(m.rec, m.n, square_with_x, 10));
    CHECK_STR_CONTAINS(m.info.format, "sma");
    CHECK_EQ_INT(m.info.streaming, 1);
    CHECK_EQ_U64(m.info.nverts, 4);
    CHECK_EQ_U64(m.info.nfaces, 2);
    CHECK_EQ_INT(m.info.has_bbox, 1);
    CHECK(m.info.bbox_max[0] == 1 && m.info.bbox_max[1] == 1 && m.info.bbox_max[2] == 0);
}

TEST(sma_corner_repeated_negatively_is_finalized_once)
{
    /* a degenerate triangle naming vertex 3 twice, both times finalizing */
    const char *path = tl_write_str("twice.sma", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 -1 -1\n");
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    static const epsnet_record want[] = { V(0, 0, 0), V(1, 0, 0), V(0, 1, 0), T(0, 2, 2), F(2) };
    CHECK(same_records(m.rec, m.n, want, 5));
}

TEST(sma_triangle_after_finalization_is_an_error_naming_the_line)
{
    const char *path = tl_write_str("late.sma", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -1\nf 1 2 3\n");
    records m;
    epsnet_error err;
    int rc = read_records(path, &m, &err);
    char where[600];
    snprintf(where, sizeof where, "%s:5: ", path);
    check_error(rc, &err, EPSNET_EFORMAT, where, "finalized");
    static const epsnet_record before[] = { V(0, 0, 0), V(1, 0, 0), V(0, 1, 0), T(0, 1, 2), F(2) };
    CHECK(same_records(m.rec, m.n, before, 5));
}

static void check_sma_rejected(const char *name, const char *text, int line, const char *reason)
{
    const char *path = tl_write_str(name, text);
    records m;
    epsnet_error err;
    int rc = read_records(path, &m, &err);
    char where[600];
    snprintf(where, sizeof where, "%s:%d: ", path, line);
    check_error(rc, &err, EPSNET_EFORMAT, where, reason);
}

TEST(sma_bad_input_is_rejected_with_its_line)
{
    check_sma_rejected("x_twice.sma", "v 0 0 0\nx 1\nx -1\n", 3, "finalized twice");
    check_sma_rejected("x_zero.sma", "v 0 0 0\nx 0\n", 2, "index 0");
    check_sma_rejected("f_back.sma", "v 0 0 0\nv 1 0 0\nf 1 2 -3\n", 3, "before the first vertex");
    check_sma_rejected("f_quad.sma", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 1\n", 4, "after 3 indices");
    check_sma_rejected("f_word.sma", "v 0 0 0\nf 1 a 1\n", 2, "'a' is not an integer");
    check_sma_rejected("v_nan.sma", "v 0 nan 0\n", 1, "non-finite");
    check_sma_rejected("stmt.sma", "v 0 0 0\nq 1 2\n", 2, "unknown SMA statement 'q'");
    check_sma_rejected("short.sma", "# nverts 3\n# nfaces 1\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", 5,
                       "announces 1 triangles but the file has 0");
}

/* ---- SMB written by hand ---- */

typedef struct smb_bytes {
    uint8_t b[8192];
    size_t n;
    int big;                /* byte order of the data */
} smb_bytes;

static void put8(smb_bytes *s, uint8_t v)
{
    s->b[s->n++] = v;
}

static void put32(smb_bytes *s, uint32_t v)
{
    for (int k = 0; k < 4; k++)
        put8(s, (uint8_t)(v >> (s->big ? 24 - 8 * k : 8 * k)));
}

static void putf(smb_bytes *s, float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    put32(s, u);
}

/* One SMB record as the test spells it: a vertex or three raw corners. */
typedef struct smb_item {
    int is_vertex;
    float xyz[3];
    int32_t idx[3];
} smb_item;

#define SV(x, y, z) { 1, { x, y, z }, { 0, 0, 0 } }
#define ST(a, b, c) { 0, { 0, 0, 0 }, { a, b, c } }

static void smb_encode(smb_bytes *s, int flag, int big, const char *comment, int32_t nverts,
                       int32_t nfaces, const float *bbox, const smb_item *items, int n)
{
    s->n = 0;
    s->big = big;
    put8(s, 0);
    put8(s, (uint8_t)flag);
    put8(s, 0);
    put8(s, 0);
    put32(s, comment ? 1 : 0);
    if (comment) {
        put32(s, (uint32_t)strlen(comment));
        for (const char *c = comment; *c; c++)
            put8(s, (uint8_t)*c);
    }
    put32(s, (uint32_t)nverts);
    put32(s, (uint32_t)nfaces);
    put8(s, bbox ? 1 : 0);
    for (int k = 0; bbox && k < 6; k++)
        putf(s, bbox[k]);
    for (int first = 0; first < n; first += 32) {
        int count = n - first < 32 ? n - first : 32;
        uint32_t mask = 0;
        for (int i = 0; i < count; i++)
            mask |= (uint32_t)items[first + i].is_vertex << i;
        put32(s, mask);
        for (int i = 0; i < count; i++)
            for (int k = 0; k < 3; k++) {
                if (items[first + i].is_vertex)
                    putf(s, items[first + i].xyz[k]);
                else
                    put32(s, (uint32_t)items[first + i].idx[k]);
            }
    }
}

/* The square without its x lines: SMB has only negative corners. */
static const smb_item square_items[] = {
    SV(0, 0, 0), SV(1, 0, 0), SV(0, 1, 0), ST(1, 2, 3), SV(1, 1, 0), ST(2, -1, -2),
};
static const epsnet_record square_records[] = {
    V(0, 0, 0), V(1, 0, 0), V(0, 1, 0), T(0, 1, 2), V(1, 1, 0), T(1, 3, 2), F(3), F(2),
};
static const float square_bbox[6] = { 0, 0, 0, 1, 1, 0 };

static void check_square_smb(const char *name, int flag, int big, const char *encoding)
{
    smb_bytes s;
    smb_encode(&s, flag, big, "drawn by hand", 4, 2, square_bbox, square_items, 6);
    const char *path = tl_write(name, s.b, s.n);
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK(same_records(m.rec, m.n, square_records, 8));
    CHECK_STR_CONTAINS(m.info.encoding, encoding);
    CHECK_EQ_U64(m.info.nverts, 4);
    CHECK_EQ_U64(m.info.nfaces, 2);
    CHECK_EQ_INT(m.info.has_bbox, 1);
    CHECK(m.info.bbox_max[0] == 1 && m.info.bbox_max[1] == 1);
    CHECK_EQ_INT(m.info.coord_type, EPSNET_COORD_FLOAT32);
}

TEST(smb_little_endian_decodes_to_the_expected_records)
{
    check_square_smb("le.smb", 0, 0, "binary_le");
}

TEST(smb_big_endian_flag_with_little_endian_data_is_read_as_little_endian)
{
    check_square_smb("quirk.smb", 1, 0, "binary_le");
}

TEST(smb_genuine_big_endian_decodes_to_the_same_records)
{
    check_square_smb("be.smb", 1, 1, "binary_be");
}

/* Without comments the header reads plausibly both ways; inside zstd the
 * file size cannot help either, so the first block decides. */
TEST(smb_quirk_is_recognised_from_the_first_block_inside_zstd)
{
    smb_bytes s;
    smb_encode(&s, 1, 0, NULL, 4, 2, NULL, square_items, 6);
    static uint8_t packed[8192];
    size_t n = ZSTD_compress(packed, sizeof packed, s.b, s.n, 3);
    CHECK(!ZSTD_isError(n));
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(tl_write("quirk.smb.zst", packed, n), &m, &err), 0);
    CHECK(same_records(m.rec, m.n, square_records, 8));
    CHECK_STR_CONTAINS(m.info.encoding, "binary_le");
    CHECK_EQ_INT(m.info.compressed, 1);
}

/*
 *   1---3---5---7 ...     a strip of quads along x, two triangles each, every
 *   | \ | \ | \ |         vertex finalized by a negative corner right after
 *   0---2---4---6 ...     its last triangle
 */
static int strip_records(epsnet_record *rec, int columns)
{
    int n = 0;
    for (int i = 0; i < columns; i++) {
        uint64_t b = 2 * (uint64_t)i, t = b + 1;
        rec[n++] = (epsnet_record)V(0.5 * i, 0, 0.25 * (i % 3));
        rec[n++] = (epsnet_record)V(0.5 * i, 1, 0.25 * (i % 3));
        if (i == 0)
            continue;
        rec[n++] = (epsnet_record)T(b - 2, b, b - 1);
        rec[n++] = (epsnet_record)F(b - 2);
        rec[n++] = (epsnet_record)T(b - 1, b, t);
        rec[n++] = (epsnet_record)F(b - 1);
        if (i == columns - 1) {
            rec[n++] = (epsnet_record)F(b);
            rec[n++] = (epsnet_record)F(t);
        }
    }
    return n;
}

TEST(smb_without_counts_reads_to_the_end_across_blocks)
{
    /* 30 vertices then 28 triangles of the strip, no finalization: two blocks */
    smb_item items[58];
    epsnet_record want[58];
    int n = 0;
    for (int i = 0; i < 30; i++) {
        items[n] = (smb_item)SV((float)(i / 2), (float)(i % 2), 0);
        want[n++] = (epsnet_record)V((double)(i / 2), (double)(i % 2), 0);
    }
    for (int i = 0; i < 28; i++) {
        items[n] = (smb_item)ST(i + 1, i + 2, i + 3);
        want[n++] = (epsnet_record)T((uint64_t)i, (uint64_t)i + 1, (uint64_t)i + 2);
    }
    smb_bytes s;
    smb_encode(&s, 0, 0, NULL, -1, -1, NULL, items, n);
    const char *path = tl_write("nocount.smb", s.b, s.n);
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK(same_records(m.rec, m.n, want, n));
    CHECK_EQ_U64(m.info.nverts, EPSNET_COUNT_UNKNOWN);
    CHECK_EQ_INT(m.info.has_bbox, 0);
}

TEST(smb_full_last_block_may_be_followed_by_an_empty_block_word)
{
    smb_item items[32];
    for (int i = 0; i < 32; i++)
        items[i] = (smb_item)SV((float)i, 0, 0);
    smb_bytes s;
    smb_encode(&s, 0, 0, NULL, 32, 0, NULL, items, 32);
    put32(&s, 0);
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(tl_write("fullblock.smb", s.b, s.n), &m, &err), 0);
    CHECK_EQ_INT(m.n, 32);
    put32(&s, 0);
    int rc = read_records(tl_write("trailing.smb", s.b, s.n), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "byte 405:", "data after the last announced record");
}

TEST(round_trip_sma_smb_sma_preserves_records_and_finalization)
{
    static epsnet_record strip[200];
    int n = strip_records(strip, 25);
    uint64_t nv = 50, nt = 48;
    epsnet_error err;
    records a, b, c;
    const char *sma1 = tl_path("strip1.sma"), *smb = tl_path("strip.smb"), *sma2 = tl_path("strip2.sma");
    CHECK_EQ_INT(write_records(sma1, strip, n, nv, nt, &err), 0);
    CHECK_EQ_INT(read_records(sma1, &a, &err), 0);
    CHECK(same_records(a.rec, a.n, strip, n));
    CHECK_EQ_INT(write_records(smb, a.rec, a.n, a.info.nverts, a.info.nfaces, &err), 0);
    CHECK_EQ_INT(read_records(smb, &b, &err), 0);
    CHECK(same_records(b.rec, b.n, strip, n));
    CHECK_EQ_U64(b.info.nverts, nv);
    CHECK_EQ_U64(b.info.nfaces, nt);
    CHECK_EQ_INT(write_records(sma2, b.rec, b.n, b.info.nverts, b.info.nfaces, &err), 0);
    CHECK_EQ_INT(read_records(sma2, &c, &err), 0);
    CHECK(same_records(c.rec, c.n, strip, n));
}

TEST(finalization_smb_cannot_express_is_dropped_and_sma_keeps_it)
{
    epsnet_error err;
    records m;
    /* SMA keeps the x lines */
    CHECK_EQ_INT(write_records(tl_path("sq.sma"), square_with_x, 10, 4, 2, &err), 0);
    CHECK_EQ_INT(read_records(tl_path("sq.sma"), &m, &err), 0);
    CHECK(same_records(m.rec, m.n, square_with_x, 10));
    /* SMB keeps the finalizations that follow a triangle, drops the rest */
    CHECK_EQ_INT(write_records(tl_path("sq.smb"), square_with_x, 10, 4, 2, &err), 0);
    CHECK_EQ_INT(read_records(tl_path("sq.smb"), &m, &err), 0);
    CHECK(same_records(m.rec, m.n, square_records, 8));
}

TEST(sma_writer_uses_negative_corners_only_in_reader_order)
{
    /* The reader gives back the finalizations of a triangle in corner order
     * (1 3 2 here). F(2) is corner 2 and folds in; F(3), corner 1, would then
     * come back before it, so it must stay an x line. */
    static const epsnet_record rec[] = {
        V(0, 0, 0), V(1, 0, 0), V(0, 1, 0), T(0, 1, 2), V(1, 1, 0), T(1, 3, 2), F(2), F(3),
    };
    epsnet_error err;
    records m;
    const char *path = tl_path("order.sma");
    CHECK_EQ_INT(write_records(path, rec, 8, EPSNET_COUNT_UNKNOWN, EPSNET_COUNT_UNKNOWN, &err), 0);
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK(same_records(m.rec, m.n, rec, 8));
    CHECK_EQ_U64(m.info.nverts, 4);     /* counts patched in on a plain file */
    CHECK_EQ_U64(m.info.nfaces, 2);
    FILE *f = fopen(path, "rb");
    char text[512] = { 0 };
    size_t len = f ? fread(text, 1, sizeof text - 1, f) : 0;
    if (f)
        fclose(f);
    text[len] = '\0';
    CHECK_STR_CONTAINS(text, "v 1 1 0\nf 2 4 -2\nx 4\n");
}

TEST(compressed_smb_round_trips_with_and_without_counts)
{
    static epsnet_record strip[200];
    int n = strip_records(strip, 20);
    epsnet_error err;
    records m;
    const char *known = tl_path("strip.smb.zst"), *unknown = tl_path("strip_nocount.smb.zst");
    CHECK_EQ_INT(write_records(known, strip, n, 40, 38, &err), 0);
    CHECK_EQ_INT(read_records(known, &m, &err), 0);
    CHECK(same_records(m.rec, m.n, strip, n));
    CHECK_EQ_INT(m.info.compressed, 1);
    CHECK_EQ_U64(m.info.nverts, 40);
    CHECK_EQ_INT(write_records(unknown, strip, n, EPSNET_COUNT_UNKNOWN, EPSNET_COUNT_UNKNOWN, &err), 0);
    CHECK_EQ_INT(read_records(unknown, &m, &err), 0);
    CHECK(same_records(m.rec, m.n, strip, n));
    CHECK_EQ_U64(m.info.nverts, EPSNET_COUNT_UNKNOWN);
    /* a compressed output cannot be patched, so a wrong announcement fails */
    int rc = write_records(tl_path("lie.smb.zst"), strip, n, 41, 38, &err);
    CHECK_EQ_INT(rc, EPSNET_EINVAL);
    CHECK(!tl_exists(tl_path("lie.smb.zst")));
}

/* ---- hostile SMB ---- */

TEST(truncated_smb_names_the_byte_offset)
{
    smb_bytes s;
    smb_encode(&s, 0, 0, NULL, 4, 2, NULL, square_items, 6);
    /* header 17 bytes, block word at 17, record i at 21 + 12 i */
    records m;
    epsnet_error err;
    int rc = read_records(tl_write("cut_mid.smb", s.b, 21 + 12 * 4 + 5), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "cut_mid.smb: byte 69:", "vertex record is cut short");
    CHECK(same_records(m.rec, m.n, square_records, 4));
    rc = read_records(tl_write("cut_edge.smb", s.b, 21 + 12 * 4), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "cut_edge.smb: byte 69:", "3 of the 4 announced vertices");
    /* the same cut in a big-endian-flagged file of little-endian data: the
     * first block still tells the order, so the message is the truncation */
    smb_encode(&s, 1, 0, NULL, 4, 2, NULL, square_items, 6);
    rc = read_records(tl_write("cut_quirk.smb", s.b, 21 + 12 * 4 + 5), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "cut_quirk.smb: byte 69:", "vertex record is cut short");
    CHECK(same_records(m.rec, m.n, square_records, 4));
    rc = read_records(tl_write("cut_head.smb", s.b, 10), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "cut_head.smb: byte 10:", "header ends early");
}

TEST(absurd_smb_comment_count_is_rejected)
{
    smb_bytes s;
    smb_encode(&s, 0, 0, NULL, 4, 2, NULL, square_items, 6);
    memcpy(s.b + 4, "\xff\xff\xff\x7f", 4);
    records m;
    epsnet_error err;
    int rc = read_records(tl_write("comments.smb", s.b, s.n), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "comments.smb: byte 4:", "comment count 2147483647 is absurd");
    /* one comment claiming 2 MiB */
    smb_encode(&s, 0, 0, "x", 4, 2, NULL, square_items, 6);
    memcpy(s.b + 8, "\x00\x00\x20\x00", 4);
    rc = read_records(tl_write("comment_len.smb", s.b, s.n), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "comment_len.smb: byte 8:", "comment 1 has length 2097152");
}

TEST(smb_bad_corners_and_headers_are_rejected)
{
    smb_bytes s;
    records m;
    epsnet_error err;
    static const smb_item zero[] = { SV(0, 0, 0), SV(1, 0, 0), SV(0, 1, 0), ST(1, 0, 3) };
    smb_encode(&s, 0, 0, NULL, 3, 1, NULL, zero, 4);
    int rc = read_records(tl_write("zero.smb", s.b, s.n), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "zero.smb: byte 57:", "corner index 0");
    static const smb_item late[] = { SV(0, 0, 0), SV(1, 0, 0), SV(0, 1, 0), ST(1, 2, -1), ST(1, 2, 3) };
    smb_encode(&s, 0, 0, NULL, 3, 2, NULL, late, 5);
    rc = read_records(tl_write("late.smb", s.b, s.n), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "late.smb: byte 69:", "finalized");
    smb_encode(&s, 0, 0, NULL, 3, 1, NULL, zero, 4);
    s.b[0] = 2;
    rc = read_records(tl_write("version.smb", s.b, s.n), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "version.smb: byte 0:", "version byte is 2");
    static const smb_item nan_item[] = { SV(0, NAN, 0) };
    smb_encode(&s, 0, 0, NULL, 1, 0, NULL, nan_item, 1);
    rc = read_records(tl_write("nan.smb", s.b, s.n), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "nan.smb: byte 21:", "non-finite");
}

static int read_with_max_count(const char *path, uint64_t max_count, epsnet_error *err)
{
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    rs.max_count = max_count;
    epsnet_reader *r = NULL;
    int rc = epsnet_reader_open(&r, path, &rs, err);
    epsnet_reader_close(&r);
    return rc;
}

TEST(header_counts_over_the_reader_limit_are_refused_before_reading)
{
    smb_bytes s;
    smb_encode(&s, 0, 0, NULL, 4, 2, NULL, square_items, 6);
    epsnet_error err;
    int rc = read_with_max_count(tl_write("limit.smb", s.b, s.n), 3, &err);
    check_error(rc, &err, EPSNET_ELIMIT, "limit.smb", "vertex count 4 exceeds the limit of 3");
    CHECK_EQ_INT(read_with_max_count(tl_path("limit.smb"), 4, &err), 0);
    rc = read_with_max_count(tl_write_str("limit.sma", square_sma), 1, &err);
    check_error(rc, &err, EPSNET_ELIMIT, "limit.sma:1:", "vertex count 4 exceeds the limit of 1");
}

TEST(smb_writer_refuses_coordinates_beyond_float32)
{
    static const epsnet_record rec[] = { V(0, 1e300, 0) };
    epsnet_error err;
    int rc = write_records(tl_path("huge.smb"), rec, 1, 1, 0, &err);
    check_error(rc, &err, EPSNET_EUNSUPPORTED, "huge.smb", "does not fit in SMB's float32");
    CHECK(!tl_exists(tl_path("huge.smb")));
}

TEST(empty_streams_are_valid)
{
    smb_bytes s;
    smb_encode(&s, 0, 0, NULL, 0, 0, NULL, NULL, 0);
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(tl_write("empty.smb", s.b, s.n), &m, &err), 0);
    CHECK_EQ_INT(m.n, 0);
    CHECK_EQ_INT(read_records(tl_write_str("empty.sma", ""), &m, &err), 0);
    CHECK_EQ_INT(m.n, 0);
    CHECK_EQ_INT(write_records(tl_path("empty_w.smb"), NULL, 0, 0, 0, &err), 0);
    CHECK_EQ_INT(read_records(tl_path("empty_w.smb"), &m, &err), 0);
    CHECK_EQ_INT(m.n, 0);
}

/* The authors' writer writes the header with the first record, so its empty
 * mesh is the version byte and the empty block word of the final flush. */
TEST(smb_authors_empty_mesh_of_five_zero_bytes_is_valid)
{
    static const uint8_t empty[5] = { 0, 0, 0, 0, 0 };
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(tl_write("authors_empty.smb", empty, sizeof empty), &m, &err), 0);
    CHECK_EQ_INT(m.n, 0);
    CHECK_EQ_U64(m.info.nverts, 0);
    CHECK_EQ_U64(m.info.nfaces, 0);
    uint8_t packed[64];
    size_t n = ZSTD_compress(packed, sizeof packed, empty, sizeof empty, 3);
    CHECK(!ZSTD_isError(n));
    CHECK_EQ_INT(read_records(tl_write("authors_empty.smb.zst", packed, n), &m, &err), 0);
    CHECK_EQ_INT(m.n, 0);
    /* a non-empty block word, or a cut header, is still no valid file */
    static const uint8_t mask[5] = { 0, 1, 0, 0, 0 };
    int rc = read_records(tl_write("five_bytes.smb", mask, sizeof mask), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "five_bytes.smb: byte", "truncated file");
    rc = read_records(tl_write("four_bytes.smb", empty, 4), &m, &err);
    check_error(rc, &err, EPSNET_EFORMAT, "four_bytes.smb: byte", "truncated file");
}

int main(void)
{
    RUN(sma_negative_indices_and_x_lines_give_the_exact_record_sequence);
    RUN(sma_corner_repeated_negatively_is_finalized_once);
    RUN(sma_triangle_after_finalization_is_an_error_naming_the_line);
    RUN(sma_bad_input_is_rejected_with_its_line);
    RUN(smb_little_endian_decodes_to_the_expected_records);
    RUN(smb_big_endian_flag_with_little_endian_data_is_read_as_little_endian);
    RUN(smb_genuine_big_endian_decodes_to_the_same_records);
    RUN(smb_quirk_is_recognised_from_the_first_block_inside_zstd);
    RUN(smb_without_counts_reads_to_the_end_across_blocks);
    RUN(smb_full_last_block_may_be_followed_by_an_empty_block_word);
    RUN(round_trip_sma_smb_sma_preserves_records_and_finalization);
    RUN(finalization_smb_cannot_express_is_dropped_and_sma_keeps_it);
    RUN(sma_writer_uses_negative_corners_only_in_reader_order);
    RUN(compressed_smb_round_trips_with_and_without_counts);
    RUN(truncated_smb_names_the_byte_offset);
    RUN(absurd_smb_comment_count_is_rejected);
    RUN(smb_bad_corners_and_headers_are_rejected);
    RUN(header_counts_over_the_reader_limit_are_refused_before_reading);
    RUN(smb_writer_refuses_coordinates_beyond_float32);
    RUN(empty_streams_are_valid);
    RUN(smb_authors_empty_mesh_of_five_zero_bytes_is_valid);
    int rc = tl_finish();
    tl_cleanup();
    return rc;
}
