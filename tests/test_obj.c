/*
 * OBJ reader and writer (src/io/fmt_obj.c): corner forms, relative indices,
 * polygons, interleaving, skipped statements, exact round trips and one-line
 * errors that name the file and the line.
 */
#include "testlib.h"

/* Every record of a file, in order. */
typedef struct records {
    epsnet_record rec[256];
    uint8_t attr[256][64];           /* rec[i].attr points here */
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
    size_t asz = out->info.vertex_attrs.size;
    while ((rc = epsnet_reader_next(r, &rec, err)) > 0 && out->n < 256) {
        if (rec.attr && asz <= sizeof out->attr[0]) {
            memcpy(out->attr[out->n], rec.attr, asz);
            rec.attr = out->attr[out->n];
        }
        out->rec[out->n++] = rec;
    }
    epsnet_reader_close(&r);
    return rc < 0 ? rc : 0;
}

static void check_tri(const epsnet_record *rec, uint64_t a, uint64_t b, uint64_t c)
{
    CHECK_EQ_INT(rec->kind, EPSNET_REC_TRIANGLE);
    CHECK_EQ_U64(rec->v[0], a);
    CHECK_EQ_U64(rec->v[1], b);
    CHECK_EQ_U64(rec->v[2], c);
}

static void check_vertex(const epsnet_record *rec, double x, double y, double z)
{
    CHECK_EQ_INT(rec->kind, EPSNET_REC_VERTEX);
    CHECK(rec->xyz[0] == x && rec->xyz[1] == y && rec->xyz[2] == z);
}

/* Read text that must fail; check the code and that the message is
 * "PATH:LINE: ..." containing reason. */
static void check_rejected(const char *name, const char *text, int code, int line, const char *reason)
{
    const char *path = tl_write_str(name, text);
    records m;
    epsnet_error err;
    memset(&err, 0, sizeof err);
    int rc = read_records(path, &m, &err);
    CHECK_EQ_INT(rc, code);
    char where[600];
    snprintf(where, sizeof where, "%s:%d: ", path, line);
    const char *msg = epsnet_error_message(&err);
    CHECK_STR_CONTAINS(msg, where);
    CHECK_STR_CONTAINS(msg, reason);
}

/*
 *   3 ----- 2
 *   |     / |      the same triangle 0-1-2 written with each corner form
 *   |   /   |
 *   0 ----- 1
 */
TEST(all_four_corner_forms_name_the_same_vertices)
{
    const char *path = tl_write_str("forms.obj",
                                    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                    "vt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\n"
                                    "f 1 2 3\n"
                                    "f 1/1 2/2 3/3\n"
                                    "f 1/1/1 2/2/1 3/3/1\n"
                                    "f 1//1 2//1 3//1\n");
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK_EQ_INT(m.n, 8);
    check_vertex(&m.rec[2], 1, 1, 0);
    for (int i = 4; i < 8; i++)
        check_tri(&m.rec[i], 0, 1, 2);
    CHECK_STR_CONTAINS(m.info.format, "obj");
    CHECK_EQ_INT(m.info.streaming, 0);
    CHECK_EQ_U64(m.info.nverts, EPSNET_COUNT_UNKNOWN);
}

TEST(negative_indices_count_back_from_the_newest_vertex)
{
    const char *path = tl_write_str("neg.obj",
                                    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                    "f -4 -3 -2\n"        /* 0 1 2 */
                                    "v 2 0 0\n"
                                    "f -1 -2/5 -3//2\n"); /* 4 3 2 */
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK_EQ_INT(m.n, 7);
    check_tri(&m.rec[4], 0, 1, 2);
    check_vertex(&m.rec[5], 2, 0, 0);
    check_tri(&m.rec[6], 4, 3, 2);
}

/*
 *        4
 *      /   \
 *    0       3      fan around corner 0: 0-1-2, 0-2-3, 0-3-4
 *     \     /
 *      1---2
 */
TEST(pentagon_fans_into_three_triangles)
{
    const char *path = tl_write_str("penta.obj",
                                    "v 0 1 0\nv 0.5 0 0\nv 1.5 0 0\nv 2 1 0\nv 1 2 0\n"
                                    "f 1 2 3 4 5\n");
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK_EQ_INT(m.n, 8);
    check_tri(&m.rec[5], 0, 1, 2);
    check_tri(&m.rec[6], 0, 2, 3);
    check_tri(&m.rec[7], 0, 3, 4);
}

TEST(faces_may_interleave_with_vertices)
{
    const char *path = tl_write_str("inter.obj",
                                    "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
                                    "v 1 1 0\nf 2 4 3\n");
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK_EQ_INT(m.n, 6);
    static const int kinds[] = { 1, 1, 1, 2, 1, 2 };
    for (int i = 0; i < 6; i++)
        CHECK_EQ_INT(m.rec[i].kind, kinds[i]);
    check_tri(&m.rec[3], 0, 1, 2);
    check_tri(&m.rec[5], 1, 3, 2);
}

TEST(other_statements_and_vertex_extras_are_skipped)
{
    const char *path = tl_write_str("skip.obj",
                                    "# exported by hand\n"
                                    "mtllib scene.mtl\n"
                                    "o thing\n"
                                    "g group one\n"
                                    "\n"
                                    "   \t\n"
                                    "s off\n"
                                    "usemtl red\n"
                                    "v 0 0 0 1.0\n"              /* w */
                                    "v 1 0 0 0.5 0.25 0.125\n"   /* colour */
                                    "  v 0 1 0\n"                /* leading blanks */
                                    "vt 0.5 0.5\nvn 0 0 1\nvp 0.1 0.2\n"
                                    "l 1 2\np 3\n"
                                    "curv 0 1 1 2\n"             /* unknown statement */
                                    "f 1 2 3\r\n"                /* CRLF */
                                    "# trailing comment\n");
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK_EQ_INT(m.n, 4);
    check_vertex(&m.rec[0], 0, 0, 0);
    check_vertex(&m.rec[1], 1, 0, 0);
    check_vertex(&m.rec[2], 0, 1, 0);
    check_tri(&m.rec[3], 0, 1, 2);
}

/* docs/architecture.md §5: every statement kind the records do not carry is named once,
 * in the order first met, with how many there were; comments and blank
 * lines are not statements. The text is complete at the end of the mesh. */
TEST(skipped_statements_are_named_with_their_counts)
{
    const char *path = tl_write_str("dropped.obj",
                                    "# comment\nmtllib scene.mtl\no thing\nusemtl red\nv 0 0 0 1.0\n"
                                    "v 1 0 0 0.5 0.25 0.125\nv 0 1 0 1 1 1\nvt 0 0\nvt 1 0\nvn 0 0 1\n"
                                    "f 1/1/1 2/2/1 3/1/1\nusemtl blue\n\n\001bad 1\n");
    epsnet_reader *r = NULL;
    epsnet_error err;
    CHECK_EQ_INT(epsnet_reader_open(&r, path, NULL, &err), 0);
    if (!r)
        return;
    uint64_t n = 99;
    epsnet_record rec;
    int rc;
    while ((rc = epsnet_reader_next(r, &rec, &err)) > 0)
        ;
    CHECK_EQ_INT(rc, 0);
    /* vt and vn are carried (the faces name them): not dropped */
    const char *what = epsnet_reader_dropped(r, &n);
    /* and so are the materials (a usemtl comes before the first face) */
    CHECK(what && strcmp(what, "o (1), vertex w (1), vertex colour (2), ?bad (1)") == 0);
    if (what && strcmp(what, "o (1), vertex w (1), vertex colour (2), ?bad (1)") != 0)
        fprintf(stderr, "  got: %s\n", what);
    CHECK_EQ_U64(n, 4);
    const epsnet_mesh_info *info = epsnet_reader_info(r);
    CHECK_EQ_U64(info->vertex_attrs.count, 6);
    CHECK(epsnet_attr_layout_find(&info->vertex_attrs, "material_index") == 5);
    CHECK(!info->groups);
    CHECK(info->materials && info->materials->count == 2 && strcmp(info->materials->names[0], "red") == 0 &&
          strcmp(info->materials->names[1], "blue") == 0 && info->materials->library &&
          strcmp(info->materials->library, "scene.mtl") == 0);
    epsnet_reader_close(&r);

    /* vt and vn that no face names are not carried, and so named; a g
     * before the first face is carried as the faces' group_index */
    path = tl_write_str("unused_vt.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\ng x\nf 1 2 3\n");
    CHECK_EQ_INT(epsnet_reader_open(&r, path, NULL, &err), 0);
    if (!r)
        return;
    CHECK_EQ_INT(epsnet_reader_info(r)->vertex_attrs.count, 1);
    CHECK(epsnet_attr_layout_find(&epsnet_reader_info(r)->vertex_attrs, "group_index") == 0);
    while ((rc = epsnet_reader_next(r, &rec, &err)) > 0)
        ;
    what = epsnet_reader_dropped(r, &n);
    CHECK(what && strcmp(what, "vt (2), vn (1)") == 0);
    info = epsnet_reader_info(r);
    CHECK(info->groups && info->groups->count == 1 && strcmp(info->groups->names[0], "x") == 0 && !info->materials);
    epsnet_reader_close(&r);

    path = tl_write_str("plain.obj", "# only geometry\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    CHECK_EQ_INT(epsnet_reader_open(&r, path, NULL, &err), 0);
    if (!r)
        return;
    while ((rc = epsnet_reader_next(r, &rec, &err)) > 0)
        ;
    CHECK(epsnet_reader_dropped(r, &n) == NULL);
    CHECK_EQ_U64(n, 0);
    epsnet_reader_close(&r);
}

TEST(backslash_continues_a_statement_and_lines_stay_counted)
{
    const char *path = tl_write_str("cont.obj",
                                    "v 0 0 \\\n0\nv 1 0 0\nv 0 1 0\n"
                                    "f 1 2 \\\n  3\n"
                                    "f 1 2 0\n");   /* line 7 */
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), EPSNET_EFORMAT);
    CHECK_EQ_INT(m.n, 4);
    check_vertex(&m.rec[0], 0, 0, 0);
    check_tri(&m.rec[3], 0, 1, 2);
    CHECK_EQ_U64(err.line, 7);
}

TEST(last_line_without_newline_is_read)
{
    const char *path = tl_write_str("nonl.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3");
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK_EQ_INT(m.n, 4);
    check_tri(&m.rec[3], 0, 1, 2);
}

TEST(empty_file_is_an_empty_mesh)
{
    const char *path = tl_write_str("empty.obj", "");
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK_EQ_INT(m.n, 0);
}

TEST(coordinate_type_follows_the_digits_written)
{
    records m;
    epsnet_error err;
    /* floats printed with %f (MeshLab) and shortest: float texts */
    const char *f32 = tl_write_str("f32.obj", "v 12.759519 -2.470218 19.806297\nv 1e-06 0.1 1234.567871\n");
    CHECK_EQ_INT(read_records(f32, &m, &err), 0);
    CHECK_EQ_INT(m.info.coord_type, EPSNET_COORD_FLOAT32);
    CHECK(m.rec[0].xyz[0] == (double)12.759519f);
    CHECK(m.rec[1].xyz[1] == (double)0.1f);
    CHECK(m.rec[1].xyz[2] == (double)1234.567871f);
    /* 17 digits of a double: more than any float printer writes */
    const char *f64 = tl_write_str("f64.obj", "v 1e-06 0.5 3\nv 0.08156099999999999 0 0\n");
    CHECK_EQ_INT(read_records(f64, &m, &err), 0);
    CHECK_EQ_INT(m.info.coord_type, EPSNET_COORD_FLOAT64);
    CHECK(m.rec[0].xyz[0] == 1e-06);
    CHECK(m.rec[1].xyz[0] == 0.08156099999999999);
}

TEST(precise_coordinate_after_the_look_ahead_keeps_its_double)
{
    size_t cap = 100000, n = 0;
    char *text = malloc(cap);
    while (n < 70000)
        n += (size_t)snprintf(text + n, cap - n, "v 0.25 %zu 0.1\n", n);
    snprintf(text + n, cap - n, "v 0.1234567890123 0 0\n");
    records m;
    epsnet_error err;
    epsnet_reader *r = NULL;
    CHECK_EQ_INT(epsnet_reader_open(&r, tl_write_str("late.obj", text), NULL, &err), 0);
    free(text);
    if (!r)
        return;
    CHECK_EQ_INT(epsnet_reader_info(r)->coord_type, EPSNET_COORD_FLOAT32);
    epsnet_record rec, first = { 0 };
    int rc, count = 0;
    while ((rc = epsnet_reader_next(r, &rec, &err)) > 0)
        if (count++ == 0)
            first = rec;
    CHECK_EQ_INT(rc, 0);
    CHECK(first.xyz[2] == (double)0.1f);
    CHECK(rec.xyz[0] == 0.1234567890123);
    epsnet_reader_close(&r);
    (void)m;
}

/* ---- writer ---- */

static int write_records(const char *path, const epsnet_record *rec, int n, int coord_type,
                         epsnet_error *err)
{
    epsnet_writer_settings ws;
    epsnet_writer_default_settings(&ws);
    ws.coord_type = coord_type;
    epsnet_writer *w = NULL;
    int rc = epsnet_writer_open(&w, path, &ws, NULL, err);
    for (int i = 0; i < n && rc == 0; i++)
        rc = epsnet_writer_put(w, &rec[i], err);
    if (rc == 0)
        return epsnet_writer_commit(&w, err);
    epsnet_writer_abort(&w);
    return rc;
}

TEST(writer_emits_v_and_one_based_f_lines_in_stream_order)
{
    epsnet_record rec[] = {
        { .kind = EPSNET_REC_VERTEX, .xyz = { 0, 0, 0 } },
        { .kind = EPSNET_REC_VERTEX, .xyz = { 1, 0, 0 } },
        { .kind = EPSNET_REC_VERTEX, .xyz = { 0.5, 1, -0.25 } },
        { .kind = EPSNET_REC_TRIANGLE, .v = { 0, 1, 2 } },
        { .kind = EPSNET_REC_FINALIZE, .v = { 0 } },
        { .kind = EPSNET_REC_VERTEX, .xyz = { 0.1f, 2, 3 } },
        { .kind = EPSNET_REC_TRIANGLE, .v = { 1, 3, 2 } },
    };
    const char *path = tl_path("written.obj");
    epsnet_error err;
    CHECK_EQ_INT(write_records(path, rec, 7, EPSNET_COORD_FLOAT32, &err), 0);
    char text[256] = { 0 };
    FILE *f = fopen(path, "rb");
    size_t n = f ? fread(text, 1, sizeof text - 1, f) : 0;
    if (f)
        fclose(f);
    text[n] = '\0';
    CHECK(strcmp(text, "v 0 0 0\nv 1 0 0\nv 0.5 1 -0.25\nf 1 2 3\nv 0.1 2 3\nf 2 4 3\n") == 0);
}

/* Deterministic pseudo-random doubles spread over many magnitudes. */
static double scrambled(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    double mant = (double)(*s >> 11) / 9007199254740992.0;
    int expo = (int)(*s % 40) - 20;
    return ldexp(mant - 0.5, expo);
}

static int same_bytes(const char *a, const char *b)
{
    FILE *fa = fopen(a, "rb"), *fb = fopen(b, "rb");
    int same = fa && fb;
    while (same) {
        int ca = fgetc(fa), cb = fgetc(fb);
        same = ca == cb;
        if (ca == EOF)
            break;
    }
    if (fa)
        fclose(fa);
    if (fb)
        fclose(fb);
    return same;
}

static void check_round_trip(int coord_type, const char *name)
{
    enum { NV = 60 };
    epsnet_record rec[NV + NV - 2];
    uint64_t seed = 12345;
    int n = 0;
    for (int i = 0; i < NV; i++) {
        rec[n] = (epsnet_record){ .kind = EPSNET_REC_VERTEX };
        for (int k = 0; k < 3; k++) {
            double d = scrambled(&seed);
            rec[n].xyz[k] = coord_type == EPSNET_COORD_FLOAT32 ? (double)(float)d : d;
        }
        n++;
        if (i >= 2)
            rec[n++] = (epsnet_record){ .kind = EPSNET_REC_TRIANGLE,
                                        .v = { (uint64_t)i - 2, (uint64_t)i - 1, (uint64_t)i } };
    }
    const char *path = tl_path(name);
    epsnet_error err;
    CHECK_EQ_INT(write_records(path, rec, n, coord_type, &err), 0);
    records m;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK_EQ_INT(m.n, n);
    CHECK_EQ_INT(m.info.coord_type, coord_type);
    int same = 1;
    for (int i = 0; i < n && i < m.n; i++) {
        same &= m.rec[i].kind == rec[i].kind;
        if (rec[i].kind == EPSNET_REC_TRIANGLE) {
            same &= memcmp(m.rec[i].v, rec[i].v, sizeof rec[i].v) == 0;
            continue;
        }
        same &= memcmp(m.rec[i].xyz, rec[i].xyz, sizeof rec[i].xyz) == 0;
    }
    CHECK(same);
    /* and the text is a fixed point: writing what was read gives the same bytes */
    char again[64];
    snprintf(again, sizeof again, "again_%s", name);
    const char *path2 = tl_path(again);
    CHECK_EQ_INT(write_records(path2, m.rec, m.n, coord_type, &err), 0);
    CHECK(same_bytes(path, path2));
}

TEST(float_coordinates_round_trip_bit_exact)
{
    check_round_trip(EPSNET_COORD_FLOAT32, "rt32.obj");
}

TEST(double_coordinates_round_trip_bit_exact)
{
    check_round_trip(EPSNET_COORD_FLOAT64, "rt64.obj");
}

TEST(compressed_obj_round_trips)
{
    epsnet_record rec[] = {
        { .kind = EPSNET_REC_VERTEX, .xyz = { 0, 0, 0 } },
        { .kind = EPSNET_REC_VERTEX, .xyz = { 1, 0, 0 } },
        { .kind = EPSNET_REC_VERTEX, .xyz = { 0, 1, 0 } },
        { .kind = EPSNET_REC_TRIANGLE, .v = { 2, 0, 1 } },
    };
    const char *path = tl_path("small.obj.zst");
    epsnet_error err;
    CHECK_EQ_INT(write_records(path, rec, 4, -1, &err), 0);
    records m;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK_EQ_INT(m.info.compressed, 1);
    CHECK_EQ_INT(m.n, 4);
    check_tri(&m.rec[3], 2, 0, 1);
}

TEST(float32_writer_refuses_coordinates_beyond_float_range)
{
    epsnet_record rec[] = { { .kind = EPSNET_REC_VERTEX, .xyz = { 0, 0, -1e39 } } };
    const char *path = tl_path("huge.obj");
    epsnet_error err;
    CHECK_EQ_INT(write_records(path, rec, 1, EPSNET_COORD_FLOAT32, &err), EPSNET_EUNSUPPORTED);
    CHECK_STR_CONTAINS(err.reason, "does not fit in float32");
    CHECK(!tl_exists(path));
    CHECK_EQ_INT(write_records(path, rec, 1, EPSNET_COORD_FLOAT64, &err), 0);
}

/* ---- texture coordinates and normals (docs/architecture.md §13) ---- */

static float attr_f32(const epsnet_record *rec, const epsnet_mesh_info *info, const char *name)
{
    int at = epsnet_attr_layout_find(&info->vertex_attrs, name);
    float f = -999;
    if (at >= 0 && rec->attr)
        memcpy(&f, rec->attr + info->vertex_attrs.attr[at].offset, 4);
    return f;
}

/*
 *   4 ----- 3     two triangles sharing the edge 1-3; the second gives
 *   |     / |     position 1 another vt (a UV seam through 1): position 1
 *   |   /   |     becomes two records at the same place, one per face
 *   1 ----- 2
 */
TEST(a_uv_seam_splits_its_position_into_one_record_per_corner_value)
{
    const char *path = tl_write_str("seam.obj",
                                    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0.5\nvn 0 0 1\n"
                                    "f 1/1/1 2/2/1 3/3/1\n"
                                    "f 1/5/1 3/3/-1 4/-2/1\n");
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    const epsnet_attr_layout *l = &m.info.vertex_attrs;
    CHECK_EQ_INT(l->count, 5);
    CHECK(epsnet_attr_layout_find(l, "texture_u") == 0 && epsnet_attr_layout_find(l, "texture_v") == 1);
    CHECK(epsnet_attr_layout_find(l, "nx") == 2 && epsnet_attr_layout_find(l, "nz") == 4);
    /* records in the order faces first name them: 1 2 3, f, 1' 4, f */
    CHECK_EQ_INT(m.n, 7);
    static const int kinds[] = { 1, 1, 1, 2, 1, 1, 2 };
    for (int i = 0; i < m.n && i < 7; i++)
        CHECK_EQ_INT(m.rec[i].kind, kinds[i]);
    check_vertex(&m.rec[0], 0, 0, 0);
    check_vertex(&m.rec[4], 0, 0, 0);
    check_vertex(&m.rec[5], 0, 1, 0);
    check_tri(&m.rec[3], 0, 1, 2);
    check_tri(&m.rec[6], 3, 2, 4);
    CHECK(attr_f32(&m.rec[0], &m.info, "texture_u") == 0 && attr_f32(&m.rec[4], &m.info, "texture_u") == 0.5f);
    CHECK(attr_f32(&m.rec[5], &m.info, "texture_v") == 1 && attr_f32(&m.rec[5], &m.info, "nz") == 1);
}

/* Exporters that write one vt per corner repeat equal values: a position
 * keeps one record wherever its vt and vn agree bit for bit, so no seam is
 * invented. A v no face names comes last, with zero vt and vn; `vt u`
 * means v = 0 and a w is named as dropped. */
TEST(equal_corner_values_share_a_record_and_lone_positions_come_last)
{
    const char *path = tl_write_str("dup.obj",
                                    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nv 1 1 0\n"
                                    "vt 0.25 0.5 0\nvt 1\nvt 0 1\nvt 0.25 0.5\nvt 1 0\n"
                                    "f 1/1 2/2 3/3\n"
                                    "f 2/5 5/3 3/3\n"
                                    "f 3/3 1/4 2/2\n");
    records m;
    epsnet_error err;
    epsnet_reader *r = NULL;
    CHECK_EQ_INT(read_records(path, &m, &err), 0);
    CHECK_EQ_INT(m.info.vertex_attrs.count, 2);
    /* 1 2 3 f 5 f f 4 */
    CHECK_EQ_INT(m.n, 8);
    check_tri(&m.rec[3], 0, 1, 2);
    check_tri(&m.rec[5], 1, 3, 2);
    check_tri(&m.rec[6], 2, 0, 1);
    check_vertex(&m.rec[7], 5, 5, 5);
    CHECK(attr_f32(&m.rec[1], &m.info, "texture_u") == 1 && attr_f32(&m.rec[1], &m.info, "texture_v") == 0);
    CHECK(attr_f32(&m.rec[7], &m.info, "texture_u") == 0);
    CHECK_EQ_INT(epsnet_reader_open(&r, path, NULL, &err), 0);
    if (!r)
        return;
    epsnet_record rec;
    while (epsnet_reader_next(r, &rec, &err) > 0)
        ;
    const char *what = epsnet_reader_dropped(r, NULL);
    CHECK(what && strcmp(what, "vt w (1)") == 0);
    epsnet_reader_close(&r);
}

TEST(corner_tables_are_held_to_the_memory_budget)
{
    char *text = malloc(64 << 10);
    size_t n = 0;
    for (int i = 0; i < 2000; i++)
        n += (size_t)sprintf(text + n, "v %d 0 0\n", i);
    n += (size_t)sprintf(text + n, "vt 0 0\nf 1/1 2/1 3/1\n");
    const char *path = tl_write("budget.obj", text, n);
    free(text);
    epsnet_reader_settings set;
    epsnet_reader_default_settings(&set);
    set.mem_limit = 32 << 10;
    epsnet_reader *r = NULL;
    epsnet_error err;
    memset(&err, 0, sizeof err);
    int rc = epsnet_reader_open(&r, path, &set, &err);
    epsnet_record rec;
    while (rc == 0 && (rc = epsnet_reader_next(r, &rec, &err)) > 0)
        ;
    CHECK_EQ_INT(rc, EPSNET_ELIMIT);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "over the memory budget");
    epsnet_reader_close(&r);
}

#define SQ_VT "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\n"

TEST(bad_texture_coordinate_and_normal_indices_are_rejected)
{
    check_rejected("vt_range.obj", SQ_VT "f 1/1/1 2/2/1 3/3/1\n", EPSNET_EFORMAT, 7,
                   "face 1: vt index 3, but only 2 vt precede it");
    check_rejected("vn_range.obj", SQ_VT "f 1/1/1 2/2/1 3/2/2\n", EPSNET_EFORMAT, 7,
                   "face 1: vn index 2, but only 1 vn precede it");
    check_rejected("vt_zero.obj", SQ_VT "f 1/1/1 2/0/1 3/2/1\n", EPSNET_EFORMAT, 7, "vt index 0");
    check_rejected("vn_rel.obj", SQ_VT "f 1/1/1 2/2/1 3/2/-2\n", EPSNET_EFORMAT, 7,
                   "relative vn index -2 reaches before the first vn");
    check_rejected("v_range.obj", SQ_VT "f 1/1/1 2/2/1 4/2/1\n", EPSNET_EFORMAT, 7,
                   "face 1: vertex index 4, but only 3 vertices precede it");
    check_rejected("vt_bad.obj", SQ_VT "f 1/1/1 2/x/1 3/2/1\n", EPSNET_EFORMAT, 7, "bad corner '2/x/1'");
    check_rejected("vt_many.obj", "v 0 0 0\nvt 1 2 3 4\nf 1/1 1/1 1/1\n", EPSNET_EFORMAT, 2,
                   "vt 1 has more than 3 values");
    check_rejected("vt_none.obj", "v 0 0 0\nvt 0 0\nvt\nf 1/1 1/1 1/1\n", EPSNET_EFORMAT, 3, "vt 2 has no values");
    check_rejected("vt_nan.obj", "v 0 0 0\nvt 0 zero\nf 1/1 1/1 1/1\n", EPSNET_EFORMAT, 2,
                   "vt 1: 'zero' is not a number");
    check_rejected("vn_two.obj", "v 0 0 0\nvn 0 1\nf 1//1 1//1 1//1\n", EPSNET_EFORMAT, 2,
                   "vn 1 has 2 values, expected 3");
    check_rejected("v_nan.obj", "v 0 0 0\nv 0 inf 0\nvt 0 0\nf 1/1 1/1 1/1\n", EPSNET_EFORMAT, 2,
                   "vertex 2 has a non-finite coordinate");
}

/* ---- bad input ---- */

#define TRI3 "v 0 0 0\nv 1 0 0\nv 0 1 0\n"

TEST(index_zero_is_rejected)
{
    check_rejected("zero.obj", TRI3 "f 1 0 3\n", EPSNET_EFORMAT, 4, "index 0");
}

TEST(index_out_of_range_is_rejected)
{
    check_rejected("range.obj", TRI3 "f 1 2 9\n", EPSNET_EFORMAT, 4, "vertex 9");
    check_rejected("range_neg.obj", TRI3 "f -1 -2 -4\n", EPSNET_EFORMAT, 4, "before the first vertex");
    check_rejected("huge.obj", TRI3 "f 1 2 99999999999999999999999\n", EPSNET_EFORMAT, 4, "bad corner");
}

TEST(index_before_its_vertex_is_rejected)
{
    check_rejected("early.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n", EPSNET_EFORMAT, 3,
                   "only 2 vertices precede it");
}

TEST(garbage_in_vertex_lines_is_rejected)
{
    check_rejected("gv1.obj", TRI3 "v 1 2 abc\n", EPSNET_EFORMAT, 4, "'abc' is not a number");
    check_rejected("gv2.obj", TRI3 "v 1 2 3x\n", EPSNET_EFORMAT, 4, "'3x' is not a number");
    check_rejected("gv3.obj", "v 1 2\n", EPSNET_EFORMAT, 1, "has 2 coordinates");
    check_rejected("gv4.obj", "v 1 2 3 4 5 6 7 8\n", EPSNET_EFORMAT, 1, "more than 7 values");
}

TEST(garbage_in_face_lines_is_rejected)
{
    check_rejected("gf1.obj", TRI3 "f 1 2 x\n", EPSNET_EFORMAT, 4, "bad corner 'x'");
    check_rejected("gf2.obj", TRI3 "f 1/a 2 3\n", EPSNET_EFORMAT, 4, "bad corner '1/a'");
    check_rejected("gf3.obj", TRI3 "f 1 2 3/\n", EPSNET_EFORMAT, 4, "bad corner '3/'");
    check_rejected("gf4.obj", TRI3 "f 1 2\n", EPSNET_EFORMAT, 4, "has 2 corners");
    check_rejected("gf5.obj", TRI3 "f 1 2 3,\n", EPSNET_EFORMAT, 4, "bad corner '3,'");
}

TEST(non_finite_coordinates_are_rejected)
{
    check_rejected("nan.obj", "v 0 0 0\nv nan 0 0\n", EPSNET_EFORMAT, 2, "non-finite");
    check_rejected("inf.obj", "v 0 -inf 0\n", EPSNET_EFORMAT, 1, "non-finite");
    check_rejected("ovf.obj", "v 0 1e999 0\n", EPSNET_EFORMAT, 1, "non-finite");
}

TEST(a_two_megabyte_line_is_rejected)
{
    size_t n = (size_t)2 << 20;
    char *text = malloc(n + 64);
    strcpy(text, TRI3 "f 1 2 3");
    size_t k = strlen(text);
    memset(text + k, ' ', n);
    strcpy(text + k + n, " \n");
    check_rejected("long.obj", text, EPSNET_EFORMAT, 4, "line longer than");
    free(text);
}

TEST(nul_byte_is_rejected)
{
    const char *path = tl_write("nul.obj", "v 0 0 0\nv 1\0 0 0\n", 17);
    records m;
    epsnet_error err;
    CHECK_EQ_INT(read_records(path, &m, &err), EPSNET_EFORMAT);
    CHECK_EQ_U64(err.line, 2);
}

int main(void)
{
    RUN(all_four_corner_forms_name_the_same_vertices);
    RUN(negative_indices_count_back_from_the_newest_vertex);
    RUN(pentagon_fans_into_three_triangles);
    RUN(faces_may_interleave_with_vertices);
    RUN(other_statements_and_vertex_extras_are_skipped);
    RUN(skipped_statements_are_named_with_their_counts);
    RUN(backslash_continues_a_statement_and_lines_stay_counted);
    RUN(last_line_without_newline_is_read);
    RUN(empty_file_is_an_empty_mesh);
    RUN(coordinate_type_follows_the_digits_written);
    RUN(precise_coordinate_after_the_look_ahead_keeps_its_double);
    RUN(writer_emits_v_and_one_based_f_lines_in_stream_order);
    RUN(float_coordinates_round_trip_bit_exact);
    RUN(double_coordinates_round_trip_bit_exact);
    RUN(compressed_obj_round_trips);
    RUN(float32_writer_refuses_coordinates_beyond_float_range);
    RUN(index_zero_is_rejected);
    RUN(index_out_of_range_is_rejected);
    RUN(index_before_its_vertex_is_rejected);
    RUN(garbage_in_vertex_lines_is_rejected);
    RUN(garbage_in_face_lines_is_rejected);
    RUN(non_finite_coordinates_are_rejected);
    RUN(a_two_megabyte_line_is_rejected);
    RUN(nul_byte_is_rejected);
    RUN(a_uv_seam_splits_its_position_into_one_record_per_corner_value);
    RUN(equal_corner_values_share_a_record_and_lone_positions_come_last);
    RUN(corner_tables_are_held_to_the_memory_budget);
    RUN(bad_texture_coordinate_and_normal_indices_are_rejected);
    int rc = tl_finish();
    tl_cleanup();
    return rc;
}
