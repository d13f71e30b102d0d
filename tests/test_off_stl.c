/*
 * OFF and STL readers (src/io/fmt_off.c, src/io/fmt_stl.c).
 *
 * OFF uses the reference mesh of test_ply.c: a tetrahedron and a quad that
 * is fanned from its first corner.
 *
 *        3                     7 ------ 6
 *        |\                    |      / |
 *        | \                   |    /   |
 *        |  2                  |  /     |
 *        | / \                 |/       |
 *        0 --- 1               4 ------ 5
 *
 * STL uses a unit cube: 12 facets, 36 corners, which must weld into exactly
 * 8 vertices. Corner c has coordinates (c & 1, c >> 1 & 1, c >> 2 & 1).
 *
 *        6 ------- 7
 *       /|        /|
 *      4 ------- 5 |        z
 *      | 2 ------|-3        | y
 *      |/        |/         |/
 *      0 ------- 1          +--- x
 */
#include <zstd.h>

#include "testlib.h"

/* ---- OFF ---- */

#define NV 8
#define NT 6
static const double off_xyz[NV][3] = {
    { 0.1, 0.2, 0.3 }, { 1.5, -0.25, 0.001 }, { 0.7, 1.1, -3.75 }, { 1e-3, 2.0, 1e6 },
    { 2.0, 0.0, 0.0 }, { 3.0, 0.1, 0.0 },     { 3.0, 1.0, 0.2 },   { 2.0, 1.0, 0.3 },
};
static const uint64_t off_tri[NT][3] = {
    { 0, 2, 1 }, { 0, 1, 3 }, { 0, 3, 2 }, { 1, 2, 3 }, { 4, 5, 6 }, { 4, 6, 7 },
};

static const char off_plain[] =
    "OFF\n"
    "# a tetrahedron and a quad\n"
    "8 5 0\n"
    "0.1 0.2 0.3\n1.5 -0.25 0.001\n0.7 1.1 -3.75\n0.001 2 1e6\n"
    "\n"
    "2 0 0\n3 0.1 0\n3 1 0.2  # comment after a vertex\n2 1 0.3\n"
    "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n4 4 5 6 7\n";

/* Colours per vertex (4 values) and per face (3 values), counts on the
 * keyword line, CRLF line ends. */
static const char off_colour[] =
    "COFF 8 5 12\r\n"
    "0.1 0.2 0.3 255 0 0 255\r\n1.5 -0.25 0.001 0 255 0 255\r\n0.7 1.1 -3.75 0 0 255 255\r\n"
    "0.001 2 1e6 1 1 1 1\r\n2 0 0 0.5 0.5 0.5 1\r\n3 0.1 0 0 0 0 0\r\n3 1 0.2 1 0 0 1\r\n2 1 0.3 0 1 0 1\r\n"
    "3 0 2 1 255 0 0\r\n3 0 1 3 0 255 0\r\n3 0 3 2 0 0 255\r\n3 1 2 3 9 9 9\r\n4 4 5 6 7 1 2 3\r\n";

/* Normals (3) then texture coordinates (2) in the STNOFF order. */
static const char off_stn[] =
    "STNOFF\n8 5 0\n"
    "0.1 0.2 0.3 0 0 1 0.5 0.5\n1.5 -0.25 0.001 0 0 1 0 0\n0.7 1.1 -3.75 0 0 1 1 1\n"
    "0.001 2 1e6 0 0 1 0 1\n2 0 0 0 0 1 1 0\n3 0.1 0 0 0 1 0 0\n3 1 0.2 0 0 1 0 0\n2 1 0.3 0 0 1 0 0\n"
    "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n4 4 5 6 7\n";

/* Every coordinate text above is a float printed at its own precision, so
 * the streams are FLOAT32 and each text reads as its float (the rule of
 * src/io/text_scan.h): 0.1 reads as 0.1f, not as the double 0.1. */
static void check_off_reference(const tl_mesh *m)
{
    CHECK_EQ_INT(m->info.coord_type, EPSNET_COORD_FLOAT32);
    CHECK_EQ_U64(m->nv, NV);
    CHECK_EQ_U64(m->nt, NT);
    if (m->nv != NV || m->nt != NT)
        return;
    for (int i = 0; i < NV; i++)
        for (int k = 0; k < 3; k++)
            CHECK(m->xyz[3 * i + k] == (double)(float)off_xyz[i][k]);
    for (int t = 0; t < NT; t++)
        for (int k = 0; k < 3; k++)
            CHECK_EQ_U64(m->tri[3 * t + k], off_tri[t][k]);
}

TEST(off_variants_give_the_reference_records)
{
    static const char *const texts[] = { off_plain, off_colour, off_stn };
    static const char *const names[] = { "plain.off", "colour.off", "stn.off" };
    for (int i = 0; i < 3; i++) {
        const char *p = tl_write_str(names[i], texts[i]);
        tl_mesh m;
        epsnet_error err;
        int rc = tl_read_mesh(p, &m, &err);
        CHECK_EQ_INT(rc, 0);
        if (rc)
            fprintf(stderr, "  %s\n", epsnet_error_message(&err));
        check_off_reference(&m);
        CHECK(strcmp(m.info.format, "off") == 0);
        CHECK_EQ_U64(m.info.nverts, NV);
        tl_mesh_free(&m);
    }
}

TEST(off_short_polygons_are_skipped)
{
    const char *p = tl_write_str("short.off", "OFF\n3 3 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n0\n3 0 1 2\n");
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
    CHECK_EQ_U64(m.nv, 3);
    CHECK_EQ_U64(m.nt, 1);
    tl_mesh_free(&m);
}

static void expect_error(const char *name, const void *data, size_t n, const epsnet_reader_settings *rs,
                         int code, const char *where, const char *reason)
{
    const char *p = tl_write(name, data, n);
    epsnet_reader *r = NULL;
    epsnet_error err;
    memset(&err, 0, sizeof err);
    int rc = epsnet_reader_open(&r, p, rs, &err);
    epsnet_record rec;
    while (rc == 0 && (rc = epsnet_reader_next(r, &rec, &err)) > 0)
        rc = 0;
    epsnet_reader_close(&r);
    CHECK_EQ_INT(rc, code);
    const char *msg = epsnet_error_message(&err);
    CHECK_STR_CONTAINS(msg, p);
    CHECK_STR_CONTAINS(msg, where);
    CHECK_STR_CONTAINS(msg, reason);
}

static void expect_error_str(const char *name, const char *text, int code, const char *where,
                             const char *reason)
{
    expect_error(name, text, strlen(text), NULL, code, where, reason);
}

TEST(off_bad_input_names_the_line)
{
    expect_error_str("trunc.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n", EPSNET_EFORMAT, ":5:",
                     "face 1 of 1 is missing");
    /* up: the face line is taken as vertex 4 with a colour, then no face is left */
    expect_error_str("lie_up.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", EPSNET_EFORMAT, ":6:",
                     "face 1 of 1 is missing");
    expect_error_str("lie_down.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 2 1 0\n", EPSNET_EFORMAT,
                     ":7:", "trailing data");
    expect_error_str("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", EPSNET_EFORMAT, ":6:",
                     "references vertex 4 but only 3 vertices precede it");
    expect_error_str("neg.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -2 1\n", EPSNET_EFORMAT, ":6:",
                     "negative vertex index -2");
    expect_error_str("nan.off", "OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", EPSNET_EFORMAT, ":4:",
                     "non-finite");
    expect_error_str("garbage.off", "OFF\n3 1 0\n0 0 0\n1 0 x7\n0 1 0\n3 0 1 2\n", EPSNET_EFORMAT, ":4:",
                     "'x7' is not a number");
    expect_error_str("few.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", EPSNET_EFORMAT, ":6:",
                     "expected 4 indices, found 3");
    expect_error_str("huge.off", "OFF\n1099511627776 1 0\n", EPSNET_ELIMIT, ":2:",
                     "vertex count 1099511627776 exceeds the limit");
    expect_error_str("hugepoly.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n200000000 0 1 2\n", EPSNET_EFORMAT,
                     ":6:", "200000000 corners is more than");
    expect_error_str("binary.off", "OFF BINARY\n", EPSNET_EUNSUPPORTED, ":1:", "binary OFF");
    expect_error_str("4d.off", "4OFF\n1 0 0\n0 0 0 1\n", EPSNET_EUNSUPPORTED, ":1:", "4D");
    expect_error_str("notoff.off", "# comment\nPLY\n", EPSNET_EFORMAT, ":2:", "not an OFF file");
    expect_error_str("nocounts.off", "OFF\n# only a comment\n", EPSNET_EFORMAT, ":2:", "no counts line");
}

/*
 * Coordinate type (src/io/text_scan.h): a triangle whose corners are written
 * once as float texts and once with 17 digits.
 *
 *   2
 *   | \
 *   0--1
 */
static const double off_precise[3][3] = {
    { 0.1, 0.2, 0.3 }, { 1.0 / 3.0, 2.0 / 3.0, 1e-7 }, { -2.5e10 / 7.0, 1.1, 123456.789 },
};

/* The triangle above as OFF, each coordinate printed as (type)value with
 * number_format ("%.9g" of the float, "%.17g" of the double). */
static const char *off_triangle_file(const char *name, const char *number_format, int as_float)
{
    char text[1024];
    size_t n = (size_t)snprintf(text, sizeof text, "OFF\n3 1 0\n");
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) {
            double v = as_float ? (double)(float)off_precise[i][k] : off_precise[i][k];
            n += (size_t)snprintf(text + n, sizeof text - n, number_format, v);
            n += (size_t)snprintf(text + n, sizeof text - n, k == 2 ? "\n" : " ");
        }
    snprintf(text + n, sizeof text - n, "3 0 1 2\n");
    return tl_write_str(name, text);
}

TEST(off_float_texts_make_a_float32_stream_of_exact_floats)
{
    /* %.9g has more digits than the shortest text of a float: still a float text */
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(off_triangle_file("float.off", "%.9g", 1), &m, &err), 0);
    CHECK_EQ_INT(m.info.coord_type, EPSNET_COORD_FLOAT32);
    CHECK_EQ_U64(m.nv, 3);
    for (uint64_t i = 0; i < m.nv && i < 3; i++)
        for (int k = 0; k < 3; k++)
            CHECK(m.xyz[3 * i + k] == (double)(float)off_precise[i][k]);
    tl_mesh_free(&m);
}

TEST(off_seventeen_digit_texts_make_a_float64_stream_of_exact_doubles)
{
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(off_triangle_file("double.off", "%.17g", 0), &m, &err), 0);
    CHECK_EQ_INT(m.info.coord_type, EPSNET_COORD_FLOAT64);
    CHECK_EQ_U64(m.nv, 3);
    for (uint64_t i = 0; i < m.nv && i < 3; i++)
        for (int k = 0; k < 3; k++)
            CHECK(m.xyz[3 * i + k] == off_precise[i][k]);
    tl_mesh_free(&m);
}

/* One precise coordinate among float texts is enough for FLOAT64. Face
 * lines are not coordinates: "1 0 0.30000000000000004" is a one-corner
 * polygon (skipped) whose third token is no float text. */
TEST(off_coordinate_type_looks_at_vertex_lines_only)
{
    static const char precise[] = "OFF\n3 1 0\n0 0 0\n1 0 0.30000000000000004\n0 1 0\n3 0 1 2\n";
    static const char face_line[] = "OFF\n3 2 0\n0.1 0 0\n1 0 0\n0 1 0\n3 0 1 2\n1 0 0.30000000000000004\n";
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(tl_write_str("one.off", precise), &m, &err), 0);
    CHECK_EQ_INT(m.info.coord_type, EPSNET_COORD_FLOAT64);
    CHECK(m.nv == 3 && m.xyz[5] == 0.30000000000000004);
    tl_mesh_free(&m);
    CHECK_EQ_INT(tl_read_mesh(tl_write_str("face_line.off", face_line), &m, &err), 0);
    CHECK_EQ_INT(m.info.coord_type, EPSNET_COORD_FLOAT32);
    CHECK(m.nv == 3 && m.xyz[0] == (double)0.1f);
    tl_mesh_free(&m);
}

/* ---- STL ---- */

#define CUBE_FACETS 12
/* Outward, counter-clockwise facets as corner numbers. */
static const int cube_facet[CUBE_FACETS][3] = {
    { 0, 2, 3 }, { 0, 3, 1 }, { 4, 5, 7 }, { 4, 7, 6 }, { 0, 1, 5 }, { 0, 5, 4 },
    { 2, 6, 7 }, { 2, 7, 3 }, { 0, 4, 6 }, { 0, 6, 2 }, { 1, 3, 7 }, { 1, 7, 5 },
};
/* Vertex index of each corner: the order in which the facets above first
 * mention them (0 2 3 1 4 5 7 6). */
static const uint64_t cube_index[8] = { 0, 3, 1, 2, 4, 5, 7, 6 };

/* Coordinate k of corner c; facets from the sixth on write zeros as -0.0,
 * which must weld with +0.0. */
static float cube_coord(int facet, int c, int k)
{
    float v = (float)((c >> k) & 1);
    return facet >= 5 && v == 0.0f ? -0.0f : v;
}

static char *cube_ascii(void)
{
    static char text[8192];
    size_t n = 0;
    n += (size_t)snprintf(text + n, sizeof text - n, "solid cube\n");
    for (int f = 0; f < CUBE_FACETS; f++) {
        n += (size_t)snprintf(text + n, sizeof text - n, "  facet normal 0 0 0\n    outer loop\n");
        for (int k = 0; k < 3; k++) {
            int c = cube_facet[f][k];
            n += (size_t)snprintf(text + n, sizeof text - n, "      vertex %g %g %g\n",
                                  (double)cube_coord(f, c, 0), (double)cube_coord(f, c, 1),
                                  (double)cube_coord(f, c, 2));
        }
        n += (size_t)snprintf(text + n, sizeof text - n, "    endloop\n  endfacet\n");
    }
    snprintf(text + n, sizeof text - n, "endsolid cube\n");
    return text;
}

static void put_le32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void put_le_float(uint8_t *p, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put_le32(p, u);
}

/* Binary cube whose 80-byte header starts with "solid", as many exporters
 * write it. Returns the size. */
static size_t cube_binary(uint8_t *out, uint32_t announced)
{
    memset(out, 0, 84);
    memcpy(out, "solid cube exported by a CAD tool", 33);
    put_le32(out + 80, announced);
    for (int f = 0; f < CUBE_FACETS; f++) {
        uint8_t *rec = out + 84 + 50 * f;
        memset(rec, 0, 50);
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++)
                put_le_float(rec + 12 + 12 * k + 4 * a, cube_coord(f, cube_facet[f][k], a));
    }
    return 84 + 50 * CUBE_FACETS;
}

static void check_cube(const tl_mesh *m)
{
    CHECK_EQ_U64(m->nv, 8);
    CHECK_EQ_U64(m->nt, CUBE_FACETS);
    CHECK_EQ_INT(m->info.coord_type, EPSNET_COORD_FLOAT32);
    if (m->nv != 8 || m->nt != CUBE_FACETS)
        return;
    for (int c = 0; c < 8; c++)
        for (int k = 0; k < 3; k++) {
            double want = (c >> k) & 1;
            /* first seen in facets 0..4, which use +0.0 */
            CHECK(memcmp(&m->xyz[3 * cube_index[c] + k], &want, sizeof want) == 0);
        }
    for (int f = 0; f < CUBE_FACETS; f++)
        for (int k = 0; k < 3; k++)
            CHECK_EQ_U64(m->tri[3 * f + k], cube_index[cube_facet[f][k]]);
}

TEST(ascii_stl_cube_welds_into_8_vertices)
{
    const char *p = tl_write_str("cube.stl", cube_ascii());
    tl_mesh m;
    epsnet_error err;
    int rc = tl_read_mesh(p, &m, &err);
    CHECK_EQ_INT(rc, 0);
    if (rc)
        fprintf(stderr, "  %s\n", epsnet_error_message(&err));
    check_cube(&m);
    CHECK(strcmp(m.info.encoding, "ascii") == 0);
    tl_mesh_free(&m);
}

TEST(binary_stl_starting_with_solid_is_read_as_binary)
{
    uint8_t buf[84 + 50 * CUBE_FACETS];
    size_t n = cube_binary(buf, CUBE_FACETS);
    const char *p = tl_write("cube_bin.stl", buf, n);
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
    check_cube(&m);
    CHECK(strcmp(m.info.encoding, "binary_le") == 0);
    CHECK_EQ_U64(m.info.nfaces, CUBE_FACETS);
    tl_mesh_free(&m);

    /* Through zstd the file size says nothing: the content must decide. */
    uint8_t z[4096];
    size_t zn = ZSTD_compress(z, sizeof z, buf, n, 3);
    CHECK(!ZSTD_isError(zn));
    p = tl_write("cube_bin.stl.zst", z, zn);
    CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
    check_cube(&m);
    tl_mesh_free(&m);
}

TEST(degenerate_facets_pass_through)
{
    /*  one facet whose three corners are the same point */
    const char *p = tl_write_str("degenerate.stl",
                                 "solid d\nfacet normal 0 0 0\nouter loop\nvertex 1 2 3\nvertex 1 2 3\n"
                                 "vertex 1 2 3\nendloop\nendfacet\nendsolid d\n");
    tl_mesh m;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(p, &m, &err), 0);
    CHECK_EQ_U64(m.nv, 1);
    CHECK_EQ_U64(m.nt, 1);
    if (m.nt == 1)
        CHECK(m.tri[0] == 0 && m.tri[1] == 0 && m.tri[2] == 0);
    tl_mesh_free(&m);
}

TEST(stl_bad_input_is_reported_with_its_position)
{
    uint8_t buf[84 + 50 * CUBE_FACETS];
    size_t n = cube_binary(buf, CUBE_FACETS + 1);
    expect_error("lying.stl", buf, n, NULL, EPSNET_EFORMAT, ": byte 80:",
                 "announces 13 triangles (734 bytes) but the file has 684 bytes");
    n = cube_binary(buf, CUBE_FACETS);
    put_le_float(buf + 84 + 50 * 3 + 12 + 4, __builtin_nanf(""));
    expect_error("nan.stl", buf, n, NULL, EPSNET_EFORMAT, ": byte 234:", "non-finite");

    /* truncated ascii: cut after the second vertex of the fourth facet */
    char *text = cube_ascii();
    char *cut = text;
    for (int lines = 0; lines < 1 + 3 * 7 + 4; lines++)
        cut = strchr(cut, '\n') + 1;
    expect_error("trunc.stl", text, (size_t)(cut - text), NULL, EPSNET_EFORMAT, ":26:",
                 "truncated file: facet 4 ends before 'vertex'");
    /* a file that stops after a whole facet still lacks its endsolid */
    cut = text;
    for (int lines = 0; lines < 1 + 7; lines++)
        cut = strchr(cut, '\n') + 1;
    expect_error("noend.stl", text, (size_t)(cut - text), NULL, EPSNET_EFORMAT, ":8:", "no 'endsolid'");

    expect_error_str("garbage.stl",
                     "solid g\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 zero 0\n",
                     EPSNET_EFORMAT, ":5:", "vertex value 'zero' is not a number");
    expect_error_str("keyword.stl", "solid g\nfacet normal 0 0 1\nouter loop\nvertx 0 0 0\n", EPSNET_EFORMAT,
                     ":4:", "expected 'vertex', found 'vertx'");
    expect_error_str("trailing.stl", "solid g\nendsolid g\nhello\n", EPSNET_EFORMAT, ":3:",
                     "trailing data after 'endsolid'");
    expect_error_str("short.stl", "sol", EPSNET_EFORMAT, ": byte 0:", "84-byte header");
}

TEST(welding_respects_the_memory_budget)
{
    uint8_t buf[84 + 50 * CUBE_FACETS];
    size_t n = cube_binary(buf, CUBE_FACETS);
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    rs.mem_limit = 1000;
    expect_error("budget.stl", buf, n, &rs, EPSNET_ELIMIT, ": byte 84:", "over the memory budget of 1000 bytes");
}

int main(void)
{
    RUN(off_variants_give_the_reference_records);
    RUN(off_short_polygons_are_skipped);
    RUN(off_bad_input_names_the_line);
    RUN(off_float_texts_make_a_float32_stream_of_exact_floats);
    RUN(off_seventeen_digit_texts_make_a_float64_stream_of_exact_doubles);
    RUN(off_coordinate_type_looks_at_vertex_lines_only);
    RUN(ascii_stl_cube_welds_into_8_vertices);
    RUN(binary_stl_starting_with_solid_is_read_as_binary);
    RUN(degenerate_facets_pass_through);
    RUN(stl_bad_input_is_reported_with_its_position);
    RUN(welding_respects_the_memory_budget);
    int rc = tl_finish();
    tl_cleanup();
    return rc;
}
