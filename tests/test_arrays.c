/*
 * Meshes in arrays (epsnet.h §13): the reader over arrays gives the records
 * a PLY of the same content gives, so simplify, sample and measure on arrays
 * give what the file runs give, to the bit; bad values are named by their
 * row, as the caller indexes them. Public API only, plus the test harness.
 */
#include "testlib.h"

/* ---- a mesh with two attribute columns, as arrays and as a PLY ---- */

typedef struct arrays_mesh {
    float *xyz;
    int32_t *tri;
    uint32_t *id;         /* attribute "id": the vertex's input index */
    double *q;            /* attribute "q": a float64 that is not a coordinate */
    uint64_t nv, nt;
} arrays_mesh;

static void arrays_mesh_free(arrays_mesh *m)
{
    free(m->xyz);
    free(m->tri);
    free(m->id);
    free(m->q);
    memset(m, 0, sizeof *m);
}

static epsnet_attr_layout two_columns(void)
{
    epsnet_attr_layout l;
    memset(&l, 0, sizeof l);
    epsnet_attr_layout_add(&l, "id", EPSNET_ATTR_UINT32);
    epsnet_attr_layout_add(&l, "q", EPSNET_ATTR_FLOAT64);
    return l;
}

/* A shuffled bumpy sphere (float32, as a scanner's PLY), into arrays and
 * into path with the same two attributes. */
static int make_mesh(const char *path, uint64_t faces, arrays_mesh *m)
{
    epsnet_error err;
    tl_mesh t;
    memset(m, 0, sizeof *m);
    const char *raw = tl_path("raw.ply");
    if (tl_gen_file(raw, "bumpy", faces, NAN, 3, 1, &err) || tl_read_mesh(raw, &t, &err))
        return -1;
    m->nv = t.nv, m->nt = t.nt;
    m->xyz = malloc(3 * t.nv * sizeof *m->xyz);
    m->tri = malloc(3 * t.nt * sizeof *m->tri);
    m->id = malloc(t.nv * sizeof *m->id);
    m->q = malloc(t.nv * sizeof *m->q);
    for (uint64_t i = 0; i < 3 * t.nv; i++)
        m->xyz[i] = (float)t.xyz[i];
    for (uint64_t i = 0; i < 3 * t.nt; i++)
        m->tri[i] = (int32_t)t.tri[i];
    for (uint64_t v = 0; v < t.nv; v++) {
        m->id[v] = (uint32_t)v;
        m->q[v] = t.xyz[3 * v] * 1e-3 + 1.0 / 3.0;
    }
    epsnet_mesh_info info = t.info;
    info.nverts = t.nv;
    info.nfaces = t.nt;
    info.vertex_attrs = two_columns();
    epsnet_writer *w = NULL;
    int rc = epsnet_writer_open(&w, path, NULL, &info, &err);
    epsnet_record rec = { 0 };
    uint8_t bytes[12];
    rec.attr = bytes;
    for (uint64_t v = 0; rc == 0 && v < t.nv; v++) {
        rec.kind = EPSNET_REC_VERTEX;
        memcpy(rec.xyz, t.xyz + 3 * v, sizeof rec.xyz);
        memcpy(bytes, &m->id[v], 4);
        memcpy(bytes + 4, &m->q[v], 8);
        rc = epsnet_writer_put(w, &rec, &err);
    }
    rec.attr = NULL;
    for (uint64_t f = 0; rc == 0 && f < t.nt; f++) {
        rec.kind = EPSNET_REC_TRIANGLE;
        memcpy(rec.v, t.tri + 3 * f, sizeof rec.v);
        rc = epsnet_writer_put(w, &rec, &err);
    }
    rc = rc ? rc : epsnet_writer_commit(&w, &err);
    epsnet_writer_abort(&w);
    tl_mesh_free(&t);
    return rc;
}

static epsnet_arrays describe(const arrays_mesh *m, int with_attrs)
{
    epsnet_arrays a;
    epsnet_arrays_init(&a);
    a.nverts = m->nv;
    a.xyz = m->xyz;
    a.nfaces = m->nt;
    a.faces = m->tri;
    if (with_attrs) {
        a.attrs = two_columns();
        a.attr[0] = m->id;
        a.attr[1] = m->q;
    }
    return a;
}

/* The records of path with their attribute bytes, flattened: vertices
 * (xyz as doubles, then the bytes), faces. */
typedef struct file_out {
    double *xyz;
    uint64_t *tri;
    uint8_t *attr;
    uint64_t nv, nt;
    uint32_t asz;
} file_out;

static int read_out(const char *path, file_out *o)
{
    memset(o, 0, sizeof *o);
    epsnet_error err;
    epsnet_reader *r = NULL;
    int rc = epsnet_reader_open(&r, path, NULL, &err);
    if (rc)
        return rc;
    o->asz = epsnet_reader_info(r)->vertex_attrs.size;
    size_t vcap = 0, tcap = 0;
    epsnet_record rec;
    while ((rc = epsnet_reader_next(r, &rec, &err)) > 0) {
        if (rec.kind == EPSNET_REC_VERTEX) {
            if (o->nv == vcap) {
                vcap = vcap ? 2 * vcap : 256;
                o->xyz = realloc(o->xyz, 3 * vcap * sizeof *o->xyz);
                o->attr = realloc(o->attr, vcap * o->asz + 1);
            }
            memcpy(o->xyz + 3 * o->nv, rec.xyz, sizeof rec.xyz);
            if (o->asz)
                memcpy(o->attr + o->nv * o->asz, rec.attr, o->asz);
            o->nv++;
        } else if (rec.kind == EPSNET_REC_TRIANGLE) {
            if (o->nt == tcap) {
                tcap = tcap ? 2 * tcap : 256;
                o->tri = realloc(o->tri, 3 * tcap * sizeof *o->tri);
            }
            memcpy(o->tri + 3 * o->nt++, rec.v, sizeof rec.v);
        }
    }
    epsnet_reader_close(&r);
    return rc < 0 ? rc : 0;
}

static void file_out_free(file_out *o)
{
    free(o->xyz);
    free(o->tri);
    free(o->attr);
}

/* out equals the file's records: same vertices in the same order, bit for
 * bit with their attributes, same faces. @return 1 when equal. */
static int same_as_file(const epsnet_arrays_out *out, const file_out *f, int with_attrs)
{
    if (out->nverts != f->nv || out->nfaces != f->nt || out->coord_type != EPSNET_COORD_FLOAT32 ||
        out->index_bytes != 4)
        return 0;
    const float *x = out->xyz;
    const int32_t *t = out->faces;
    for (uint64_t i = 0; i < 3 * f->nv; i++)
        if ((double)x[i] != f->xyz[i])
            return 0;
    for (uint64_t i = 0; i < 3 * f->nt; i++)
        if ((uint64_t)t[i] != f->tri[i])
            return 0;
    if (!with_attrs)
        return out->attrs.count == 0;
    if (out->attrs.count != 2 || f->asz != 12)
        return 0;
    for (uint64_t v = 0; v < f->nv; v++)
        if (memcmp((const uint32_t *)out->attr[0] + v, f->attr + 12 * v, 4) ||
            memcmp((const double *)out->attr[1] + v, f->attr + 12 * v + 4, 8))
            return 0;
    return 1;
}

/* Simplify path as a file (one thread) and m as arrays (two threads) with
 * the same settings otherwise; both outputs must be the same. */
static void check_like_file(const char *path, const arrays_mesh *m, double ratio, uint32_t slab, int with_attrs)
{
    epsnet_settings s;
    epsnet_default_settings(&s);
    s.target_ratio = ratio;
    s.slab_vertices = slab;
    s.tmpdir = tl_tmpdir();
    s.threads = 1;
    epsnet_context *ctx = NULL;
    epsnet_error err;
    const char *out_path = tl_path("out.ply");
    CHECK_EQ_INT(epsnet_context_new(&ctx, &s, &err), 0);
    CHECK_EQ_INT(epsnet_simplify_file(ctx, path, out_path, &err), 0);
    uint64_t file_samples = epsnet_context_stats(ctx)->samples;
    epsnet_context_free(&ctx);
    file_out f;
    CHECK_EQ_INT(read_out(out_path, &f), 0);

    s.threads = 2;
    CHECK_EQ_INT(epsnet_context_new(&ctx, &s, &err), 0);
    epsnet_arrays in = describe(m, with_attrs);
    epsnet_arrays_out out;
    CHECK_EQ_INT(epsnet_simplify_arrays(ctx, &in, &out, &err), 0);
    CHECK(f.nv > 0 && f.nv < m->nv);
    CHECK(same_as_file(&out, &f, with_attrs));
    CHECK_EQ_U64(epsnet_context_stats(ctx)->samples, file_samples);
    CHECK_EQ_U64(epsnet_context_stats(ctx)->output_faces, f.nt);
    if (slab)
        CHECK(epsnet_context_stats(ctx)->slabs > 1); /* thinned on slabs, then the last round */
    epsnet_arrays_out_free(&out);
    CHECK(out.xyz == NULL && out.nverts == 0);
    epsnet_context_free(&ctx);
    file_out_free(&f);
}

TEST(arrays_simplify_to_the_file_runs_vertices_faces_and_attributes)
{
    arrays_mesh m;
    const char *path = tl_path("in.ply");
    CHECK_EQ_INT(make_mesh(path, 20000, &m), 0);
    check_like_file(path, &m, 0, 0, 1);     /* the ε-net method */
    check_like_file(path, &m, 0.1, 0, 1);   /* a target in one slab */
    check_like_file(path, &m, 0, 0, 0);     /* no attribute columns: the same mesh */
    arrays_mesh_free(&m);
}

TEST(arrays_over_many_slabs_go_through_the_streamed_target_like_the_file)
{
    arrays_mesh m;
    const char *path = tl_path("in.ply");
    CHECK_EQ_INT(make_mesh(path, 20000, &m), 0);
    /* 10,000 vertices on slabs of 1024: thinning, rounds, last round */
    check_like_file(path, &m, 0.1, 1024, 1);
    arrays_mesh_free(&m);
}

TEST(reader_over_arrays_gives_the_records_of_the_ply)
{
    arrays_mesh m;
    const char *path = tl_path("in.ply");
    CHECK_EQ_INT(make_mesh(path, 2000, &m), 0);
    epsnet_arrays in = describe(&m, 1);
    epsnet_reader *a = NULL, *p = NULL;
    epsnet_error err;
    CHECK_EQ_INT(epsnet_reader_open_arrays(&a, &in, NULL, &err), 0);
    CHECK_EQ_INT(epsnet_reader_open(&p, path, NULL, &err), 0);
    if (!a || !p)
        return;
    CHECK(strcmp(epsnet_reader_info(a)->format, "arrays") == 0);
    CHECK_EQ_U64(epsnet_reader_info(a)->nverts, m.nv);
    CHECK_EQ_U64(epsnet_reader_info(a)->vertex_attrs.size, 12);
    epsnet_record ra, rp;
    int ca, cp;
    uint64_t n = 0, differ = 0;
    while ((ca = epsnet_reader_next(a, &ra, &err)) == 1 && (cp = epsnet_reader_next(p, &rp, &err)) == 1) {
        n++;
        if (ra.kind != rp.kind)
            differ++;
        else if (ra.kind == EPSNET_REC_VERTEX)
            differ += memcmp(ra.xyz, rp.xyz, sizeof ra.xyz) != 0 || memcmp(ra.attr, rp.attr, 12) != 0;
        else
            differ += memcmp(ra.v, rp.v, sizeof ra.v) != 0;
    }
    CHECK_EQ_INT(ca, 0);
    CHECK_EQ_INT(epsnet_reader_next(p, &rp, &err), 0);
    CHECK_EQ_U64(n, m.nv + m.nt);
    CHECK_EQ_U64(differ, 0);
    CHECK_EQ_U64(epsnet_reader_bytes_read(a), epsnet_reader_file_size(a));
    CHECK_EQ_U64(epsnet_reader_file_size(a), m.nv * (12 + 12) + m.nt * 12);
    epsnet_reader_close(&a);
    epsnet_reader_close(&p);
    arrays_mesh_free(&m);
}

/* Simplify arrays that hold one bad value: the code, the row in the
 * message, an empty result. */
static void check_refused(const epsnet_arrays *in, int code, const char *says)
{
    epsnet_context *ctx = NULL;
    epsnet_error err;
    epsnet_settings s;
    epsnet_default_settings(&s);
    s.threads = 2;
    CHECK_EQ_INT(epsnet_context_new(&ctx, &s, &err), 0);
    epsnet_arrays_out out;
    CHECK_EQ_INT(epsnet_simplify_arrays(ctx, in, &out, &err), code);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), says);
    CHECK(out.xyz == NULL && out.faces == NULL && out.nverts == 0 && out.nfaces == 0);
    epsnet_context_free(&ctx);
}

/*
 *   3 ------ 2
 *   | \      |      a square of two faces; each case spoils one value
 *   |   \    |
 *   0 ------ 1
 */
TEST(bad_values_are_named_by_their_row)
{
    double xyz[12] = { 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0 };
    int64_t tri[6] = { 0, 1, 3, 1, 2, 3 };
    epsnet_arrays in;
    epsnet_arrays_init(&in);
    in.coord_type = EPSNET_COORD_FLOAT64;
    in.index_bytes = 8;
    in.nverts = 4, in.xyz = xyz, in.nfaces = 2, in.faces = tri;
    in.name = "square";
    xyz[7] = NAN;
    check_refused(&in, EPSNET_EFORMAT, "square: vertices[2] is not finite");
    xyz[7] = 1;
    tri[5] = -1;
    check_refused(&in, EPSNET_EFORMAT, "faces[1, 2] = -1 is not a vertex index (0 .. 3)");
    tri[5] = 4;
    check_refused(&in, EPSNET_EFORMAT, "faces[1, 2] = 4 is not a vertex index (0 .. 3)");
    tri[5] = 3;
    in.nverts = 0;
    check_refused(&in, EPSNET_EFORMAT, "faces[0, 0] = 0 names a vertex, but there are none");
    in.nverts = 4;
    in.index_bytes = 2;
    check_refused(&in, EPSNET_EINVAL, "4 or 8 bytes");
    in.index_bytes = 8;
    in.attrs.count = 1; /* a column named but given no values */
    in.attrs.size = 1;
    snprintf(in.attrs.attr[0].name, sizeof in.attrs.attr[0].name, "lock");
    in.attrs.attr[0].type = EPSNET_ATTR_UINT8;
    check_refused(&in, EPSNET_EINVAL, "attribute 'lock' has no values");
}

TEST(arrays_classification_is_the_sample_mesh_files)
{
    arrays_mesh m;
    const char *path = tl_path("in.ply"), *flags = tl_path("flags.ply");
    CHECK_EQ_INT(make_mesh(path, 6000, &m), 0);
    epsnet_context *ctx = NULL;
    epsnet_error err;
    CHECK_EQ_INT(epsnet_context_new(&ctx, NULL, &err), 0);
    CHECK_EQ_INT(epsnet_sample_file(ctx, path, flags, EPSNET_SAMPLES_MESH, 0, &err), 0);
    uint64_t samples = epsnet_context_stats(ctx)->samples;
    epsnet_arrays in = describe(&m, 0);
    uint8_t *is_sample = malloc(m.nv);
    int32_t *gv = malloc(m.nv * sizeof *gv);
    CHECK_EQ_INT(epsnet_sample_arrays(ctx, &in, is_sample, gv, &err), 0);
    CHECK_EQ_U64(epsnet_context_stats(ctx)->samples, samples);
    file_out f;
    CHECK_EQ_INT(read_out(flags, &f), 0);
    /* the flags file's vertex: x y z, uchar sample, int gvertex, uchar red green blue */
    uint64_t differ = 0, n = 0;
    CHECK_EQ_U64(f.nv, m.nv);
    CHECK_EQ_INT(f.asz, 8);
    for (uint64_t v = 0; f.asz == 8 && v < f.nv && v < m.nv; v++) {
        int32_t g;
        memcpy(&g, f.attr + 8 * v + 1, 4);
        differ += g != gv[v] || f.attr[8 * v] != is_sample[v];
        n += is_sample[v];
    }
    CHECK_EQ_U64(differ, 0);
    CHECK_EQ_U64(n, samples);
    CHECK(samples > 0 && samples < m.nv);
    file_out_free(&f);
    free(is_sample);
    free(gv);
    epsnet_context_free(&ctx);
    arrays_mesh_free(&m);
}

TEST(hausdorff_of_arrays_is_the_files)
{
    arrays_mesh m;
    const char *path = tl_path("in.ply"), *small = tl_path("small.ply");
    CHECK_EQ_INT(make_mesh(path, 4000, &m), 0);
    epsnet_settings s;
    epsnet_default_settings(&s);
    s.target_ratio = 0.2;
    epsnet_context *ctx = NULL;
    epsnet_error err;
    CHECK_EQ_INT(epsnet_context_new(&ctx, &s, &err), 0);
    epsnet_arrays in = describe(&m, 0);
    epsnet_arrays_out out;
    CHECK_EQ_INT(epsnet_simplify_arrays(ctx, &in, &out, &err), 0);
    CHECK_EQ_INT(epsnet_simplify_file(ctx, path, small, &err), 0);
    epsnet_arrays b;
    epsnet_arrays_init(&b);
    b.nverts = out.nverts, b.xyz = out.xyz, b.nfaces = out.nfaces, b.faces = out.faces;
    epsnet_hausdorff_settings hs;
    epsnet_hausdorff_default_settings(&hs);
    hs.threads = 2;
    epsnet_hausdorff_result ra, rf;
    CHECK_EQ_INT(epsnet_hausdorff_arrays(&in, &b, &hs, &ra, &err), 0);
    hs.threads = 1;
    CHECK_EQ_INT(epsnet_hausdorff_files(path, small, &hs, &rf, &err), 0);
    CHECK(ra.hausdorff > 0);
    CHECK(ra.hausdorff == rf.hausdorff && ra.a_to_b.mean == rf.a_to_b.mean && ra.b_to_a.rms == rf.b_to_a.rms);
    CHECK_EQ_U64(ra.b_faces, out.nfaces);
    epsnet_arrays_out_free(&out);
    epsnet_context_free(&ctx);
    arrays_mesh_free(&m);
}

static int cancel_at_half(void *opaque, uint64_t done, uint64_t total)
{
    int *calls = opaque;
    ++*calls;
    return total && done * 2 >= total;
}

TEST(a_cancelled_arrays_run_returns_eintr_and_nothing)
{
    arrays_mesh m;
    const char *path = tl_path("in.ply");
    CHECK_EQ_INT(make_mesh(path, 20000, &m), 0);
    int calls = 0;
    epsnet_settings s;
    epsnet_default_settings(&s);
    s.progress = cancel_at_half;
    s.progress_opaque = &calls;
    s.slab_vertices = 1024;
    s.target_ratio = 0.1;
    s.tmpdir = tl_tmpdir();
    epsnet_context *ctx = NULL;
    epsnet_error err;
    CHECK_EQ_INT(epsnet_context_new(&ctx, &s, &err), 0);
    epsnet_arrays in = describe(&m, 1);
    epsnet_arrays_out out;
    CHECK_EQ_INT(epsnet_simplify_arrays(ctx, &in, &out, &err), EPSNET_EINTR);
    CHECK(calls > 0);
    CHECK(out.xyz == NULL && out.attr[0] == NULL && out.nverts == 0);
    epsnet_context_free(&ctx);
    arrays_mesh_free(&m);
}

int main(void)
{
    RUN(reader_over_arrays_gives_the_records_of_the_ply);
    RUN(arrays_simplify_to_the_file_runs_vertices_faces_and_attributes);
    RUN(arrays_over_many_slabs_go_through_the_streamed_target_like_the_file);
    RUN(bad_values_are_named_by_their_row);
    RUN(arrays_classification_is_the_sample_mesh_files);
    RUN(hausdorff_of_arrays_is_the_files);
    RUN(a_cancelled_arrays_run_returns_eintr_and_nothing);
    tl_cleanup();
    return tl_finish();
}
