/*
 * The streaming pipeline's guarantees (docs/architecture.md §11, issue 6): the samples equal
 * the one-slab in-core classification for any slab size; the output is the
 * same bytes for any thread count; it is a valid, sorted, finalized stream
 * with every sample kept; seams are simplified like the rest; the active set
 * grows with the stream's width, not its length; a worker's error surfaces
 * in slab order; the push/pull API gives what the file API gives.
 */
#include <dirent.h>
#include <math.h>
#include <sys/stat.h>
#include <unistd.h>

#include "api/run.h"
#include "common/pool.h"
#include "io/format.h"
#include "pipeline/chunker.h"
#include "sample_util.h"

static uint64_t *sorted_sample_gids(const char *shape, uint64_t faces, uint64_t *n)
{
    en_slab s;
    gauss_sphere g;
    gauss_rotation rot;
    gauss_rotation_identity(&rot);
    gauss_init(&g, 8, &rot);
    *n = 0;
    if (gen_slab(shape, faces, NAN, 7, 0, &s))
        return NULL;
    classified c;
    uint64_t *gids = malloc(sizeof *gids * (s.nv + 1));
    if (classify_all(&g, &s, &c) == 0)
        for (uint32_t v = 0; v < s.nv; v++)
            if (c.vclass[v] & EN_C_SAMPLE)
                gids[(*n)++] = s.gid[v];
    classified_free(&c);
    en_slab_free(&s);
    return gids; /* slab order is id order */
}

typedef struct gid_list {
    uint64_t *g;
    uint64_t n, cap;
} gid_list;

static int collect_gid(void *opaque, uint64_t gid, const double xyz[3], int32_t gvertex, epsnet_error *err)
{
    (void)xyz, (void)gvertex, (void)err;
    gid_list *l = opaque;
    if (l->n == l->cap) {
        l->cap = l->cap ? 2 * l->cap : 256;
        l->g = realloc(l->g, l->cap * sizeof *l->g);
    }
    l->g[l->n++] = gid;
    return 0;
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static epsnet_context *make_ctx(uint32_t slab, int threads, int passes)
{
    epsnet_settings set;
    epsnet_default_settings(&set);
    set.rotation_mode = EPSNET_ROTATION_IDENTITY;
    set.frequency = 8;
    set.slab_vertices = slab;
    set.threads = threads;
    set.passes = passes;
    epsnet_context *ctx = NULL;
    epsnet_error err;
    if (epsnet_context_new(&ctx, &set, &err))
        fprintf(stderr, "context: %s\n", epsnet_error_message(&err));
    return ctx;
}

/* Stream path through a SAMPLE-mode pipeline and return the sample ids. */
static int stream_samples(const char *path, uint32_t slab, int threads, gid_list *out)
{
    epsnet_context *ctx = make_ctx(slab, threads, 1);
    en_run run;
    epsnet_reader *r = NULL;
    epsnet_error err;
    epsnet_record rec;
    memset(out, 0, sizeof *out);
    int rc = en_run_open(&run, ctx, EN_SLAB_SAMPLE, path, NULL, NULL, NULL, 0, NULL, (en_stage){ 0 }, collect_gid, out,
                         &err);
    if (rc == 0)
        rc = epsnet_reader_open(&r, path, NULL, &err);
    while (rc == 0 && (rc = epsnet_reader_next(r, &rec, &err)) == 1)
        rc = en_run_put(&run, &rec, &err);
    if (rc == 0)
        rc = en_run_end(&run, &err);
    if (rc)
        fprintf(stderr, "stream_samples: %s\n", epsnet_error_message(&err));
    epsnet_reader_close(&r);
    en_run_close(&run);
    epsnet_context_free(&ctx);
    qsort(out->g, out->n, sizeof *out->g, cmp_u64);
    return rc;
}

/* Paper §4: a vertex's class depends on its star alone, and every slab owns
 * whole stars, so no slab size may change a single sample. */
TEST(samples_equal_one_slab_for_any_slab_size)
{
    static const struct {
        const char *shape;
        uint64_t faces;
    } cases[] = { { "bumpy", 20000 }, { "torus", 6000 }, { "terrain", 8000 }, { "cad", 8000 }, { "dimple", 6000 } };
    static const uint32_t slabs[] = { 1, 7, 100, 1000, UINT32_MAX };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        uint64_t nref;
        uint64_t *ref = sorted_sample_gids(cases[i].shape, cases[i].faces, &nref);
        CHECK(ref != NULL && nref > 20);
        const char *path = tl_path("samples.smz");
        epsnet_error err;
        CHECK_EQ_INT(tl_gen_file(path, cases[i].shape, cases[i].faces, NAN, 7, 0, &err), 0);
        for (size_t k = 0; k < sizeof slabs / sizeof *slabs; k++) {
            gid_list got;
            CHECK_EQ_INT(stream_samples(path, slabs[k], k % 2 ? 3 : 1, &got), 0);
            CHECK_EQ_U64(got.n, nref);
            int same = got.n == nref && memcmp(got.g, ref, nref * sizeof *ref) == 0;
            if (!same)
                fprintf(stderr, "  %s, slab %u: samples differ\n", cases[i].shape, slabs[k]);
            CHECK(same);
            free(got.g);
        }
        free(ref);
    }
}

static int simplify_file(const char *in, const char *out, uint32_t slab, int threads, int passes, epsnet_stats *st,
                         epsnet_error *err)
{
    epsnet_context *ctx = make_ctx(slab, threads, passes);
    int rc = epsnet_simplify_file(ctx, in, out, err);
    if (st)
        *st = *epsnet_context_stats(ctx);
    epsnet_context_free(&ctx);
    return rc;
}

/* The output file of the first of several runs, kept to compare the later
 * ones with. */
typedef struct output_bytes {
    unsigned char *b;
    size_t n;
} output_bytes;

/* Read the file at out: the first time keep it in *first, later check it
 * equals *first. @return 1 when it does (or is the first). */
static int same_as_first(output_bytes *first, const char *out)
{
    size_t n;
    unsigned char *b = tl_read_file(out, &n);
    CHECK(b != NULL && n > 100);
    if (!first->b) {
        first->b = b;
        first->n = n;
        return 1;
    }
    int same = b && n == first->n && memcmp(b, first->b, n) == 0;
    CHECK(same);
    free(b);
    return same;
}

/* docs/architecture.md §11: "same input and options give the same output bytes, for any
 * thread count" — slabs finish in any order on the workers. */
TEST(same_bytes_for_threads_1_2_3_8)
{
    char in[512], out[512]; /* tl_path's buffers rotate: keep copies */
    snprintf(in, sizeof in, "%s", tl_path("det.smz"));
    snprintf(out, sizeof out, "%s", tl_path("det_out.smz"));
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 30000, NAN, 3, 0, &err), 0);
    static const uint32_t slabs[] = { 50, 700 };
    static const int passes[] = { 1, 3 };
    for (int p = 0; p < 2; p++)
        for (int k = 0; k < 2; k++) {
            output_bytes first = { 0 };
            static const int threads[] = { 1, 2, 3, 8 };
            for (int t = 0; t < 4; t++) {
                CHECK_EQ_INT(simplify_file(in, out, slabs[k], threads[t], passes[p], NULL, &err), 0);
                if (!same_as_first(&first, out))
                    fprintf(stderr, "  slab %u, passes %d, %d threads: bytes differ\n", slabs[k], passes[p],
                            threads[t]);
            }
            free(first.b);
        }
}

/* docs/architecture.md §10: each pass's stitcher takes its slabs as pool
 * jobs, one at a time, and the caller hands their records on when it
 * retires them. Small slabs on shapes with features put most of the work in
 * seams, so takes overlap the slabs still running; the bytes must not move
 * with the thread count, for one pass and for chained passes (whose input is
 * the handed-on records). */
TEST(seam_jobs_give_the_same_bytes_for_any_thread_count)
{
    char in[512], out[512];
    static const char *shapes[] = { "cad", "torus" };
    static const uint32_t slabs[] = { 64, 300 };
    static const int threads[] = { 1, 2, 8 };
    epsnet_error err;
    for (int sh = 0; sh < 2; sh++) {
        snprintf(in, sizeof in, "%s", tl_path("seam_in.smz"));
        snprintf(out, sizeof out, "%s", tl_path("seam_out.smz"));
        CHECK_EQ_INT(tl_gen_file(in, shapes[sh], 20000, NAN, 5, 0, &err), 0);
        for (int k = 0; k < 2; k++)
            for (int passes = 1; passes <= 2; passes++) {
                output_bytes first = { 0 };
                for (int t = 0; t < 3; t++) {
                    epsnet_stats st;
                    CHECK_EQ_INT(simplify_file(in, out, slabs[k], threads[t], passes, &st, &err), 0);
                    CHECK(st.seam_collapses > 0);
                    if (!same_as_first(&first, out))
                        fprintf(stderr, "  %s, slab %u, passes %d, %d threads: bytes differ\n", shapes[sh],
                                slabs[k], passes, threads[t]);
                }
                free(first.b);
            }
    }
}

/* Copy the mesh at in to out (a .smz), giving every vertex attributes
 * that vary along the surface (docs/smz.md "Attributes": float and integer
 * values, predicted from a neighbour), and, after triangle bad_tri (0:
 * none), a triangle that uses vertex 0, finalized long before (a stream error the
 * reader front end finds while it pushes that block's records). */
static int copy_with_attrs(const char *in, const char *out, uint64_t bad_tri, epsnet_error *err)
{
    epsnet_reader *r = NULL;
    epsnet_writer *w = NULL;
    int rc = epsnet_reader_open(&r, in, NULL, err);
    epsnet_mesh_info info;
    if (rc == 0) {
        info = *epsnet_reader_info(r);
        memset(&info.vertex_attrs, 0, sizeof info.vertex_attrs);
        epsnet_attr_layout_add(&info.vertex_attrs, "confidence", EPSNET_ATTR_FLOAT32);
        epsnet_attr_layout_add(&info.vertex_attrs, "red", EPSNET_ATTR_UINT8);
        epsnet_attr_layout_add(&info.vertex_attrs, "weight", EPSNET_ATTR_FLOAT64);
        epsnet_attr_layout_add(&info.vertex_attrs, "label", EPSNET_ATTR_INT16);
        rc = epsnet_writer_open(&w, out, NULL, &info, err);
    }
    uint64_t nv = 0, nt = 0;
    epsnet_record rec;
    while (rc == 0 && (rc = epsnet_reader_next(r, &rec, err)) == 1) {
        uint8_t a[15];
        if (rec.kind == EPSNET_REC_VERTEX) {
            float c = (float)(rec.xyz[0] * 0.5 + rec.xyz[2]);
            uint8_t red = (uint8_t)(128 + 100 * rec.xyz[1]);
            double wt = rec.xyz[0] * rec.xyz[1] - (double)nv * 1e-7;
            int16_t label = (int16_t)(nv % 7 == 0 ? -(int)(nv % 1000) : (int)(nv / 50));
            memcpy(a, &c, 4);
            a[4] = red;
            memcpy(a + 5, &wt, 8);
            memcpy(a + 13, &label, 2);
            rec.attr = a;
            nv++;
        }
        rc = epsnet_writer_put(w, &rec, err);
        if (rc == 0 && rec.kind == EPSNET_REC_TRIANGLE && ++nt == bad_tri) {
            epsnet_record t = { .kind = EPSNET_REC_TRIANGLE, .v = { 0, nv - 1, nv - 2 } };
            rc = epsnet_writer_put(w, &t, err);
        }
    }
    if (rc == 0)
        rc = epsnet_writer_commit(&w, err);
    epsnet_writer_abort(&w);
    epsnet_reader_close(&r);
    return rc;
}

/* Simplify bad with 1, 2 and 8 threads: each must fail, all alike. */
static void fails_alike(const char *bad, const char *out, const char *kind)
{
    int first_rc = 0;
    char first_msg[1200] = "";
    for (int t = 0; t < 3; t++) {
        static const int threads[] = { 1, 2, 8 };
        epsnet_error e;
        memset(&e, 0, sizeof e);
        int rc = simplify_file(bad, out, 3000, threads[t], 1, NULL, &e);
        CHECK(rc < 0);
        if (t == 0) {
            first_rc = rc;
            snprintf(first_msg, sizeof first_msg, "%s", epsnet_error_message(&e));
            continue;
        }
        int same = rc == first_rc && strcmp(first_msg, epsnet_error_message(&e)) == 0;
        if (!same)
            fprintf(stderr, "  %s, %d threads: %d '%s' vs %d '%s'\n", kind, threads[t], rc,
                    epsnet_error_message(&e), first_rc, first_msg);
        CHECK(same);
    }
}

/* Damage the .smz at in three ways (late in a block's payload, a field of a
 * later block's header, the file cut short) and check each fails alike. */
static void damaged_fails_alike(const char *in, const char *what)
{
    char bad[512], out[512];
    snprintf(out, sizeof out, "%s", tl_path("blocks_out.smz"));
    size_t n;
    unsigned char *data = tl_read_file(in, &n);
    CHECK(data != NULL && n > 4096);
    if (!data)
        return;
    size_t tag = 0;
    for (size_t i = n / 2; i + 4 < n && !tag; i++)
        if (memcmp(data + i, "SMZB", 4) == 0)
            tag = i;
    CHECK(tag > 0);
    static const char *kinds[] = { "payload", "header", "cut" };
    for (int k = 0; k < 3; k++) {
        unsigned char *copy = malloc(n);
        CHECK(copy != NULL);
        if (!copy)
            break;
        memcpy(copy, data, n);
        size_t len = n;
        if (k == 0)
            copy[n * 3 / 4] ^= 0x5a;
        else if (k == 1)
            copy[tag + 8] ^= 0x01; /* a field under the header's CRC */
        else
            len = n * 2 / 3;
        snprintf(bad, sizeof bad, "%s", tl_write("blocks_bad.smz", copy, len));
        free(copy);
        char kind[200];
        snprintf(kind, sizeof kind, "%s, %s", what, kinds[k]);
        fails_alike(bad, out, kind);
    }
    free(data);
}

/* docs/architecture.md §10: with workers, .smz blocks are read ahead and
 * decoded on the pool, and every check still happens at the block's turn:
 * a damaged block, a damaged header or a cut file fails with the same code
 * and message for every thread count, version 2 with attributes too, and
 * so does a stream error the reader front end finds in a block read ahead
 * (its byte offset is where the one-thread reader stands); a sound file
 * gives the same bytes (same_bytes_for_threads_1_2_3_8 reads .smz too). */
TEST(damaged_smz_fails_alike_for_any_thread_count)
{
    char in[512], attrs[512], out[512];
    snprintf(in, sizeof in, "%s", tl_path("blocks.smz"));
    snprintf(attrs, sizeof attrs, "%s", tl_path("blocks_attrs.smz"));
    snprintf(out, sizeof out, "%s", tl_path("blocks_out.smz"));
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 120000, NAN, 3, 0, &err), 0); /* several blocks */
    damaged_fails_alike(in, "no attributes");
    CHECK_EQ_INT(copy_with_attrs(in, attrs, 0, &err), 0);
    damaged_fails_alike(attrs, "attributes");
    CHECK_EQ_INT(copy_with_attrs(in, attrs, 80000, &err), 0); /* of about 120000 */
    fails_alike(attrs, out, "a finalized vertex used late");
}

/* The records themselves: a reader given a pool (en_reader_use_pool) hands
 * out the records and attribute bytes of the one-thread reader, for 1, 2
 * and 8 workers, and its blocks did run on the workers. */
TEST(smz_records_alike_on_the_pool)
{
    char in[512], attrs[512];
    snprintf(in, sizeof in, "%s", tl_path("recs.smz"));
    snprintf(attrs, sizeof attrs, "%s", tl_path("recs_attrs.smz"));
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(in, "torus", 150000, NAN, 5, 0, &err), 0);
    CHECK_EQ_INT(copy_with_attrs(in, attrs, 0, &err), 0);
    const char *files[] = { in, attrs };
    for (int f = 0; f < 2; f++) {
        epsnet_reader *r = NULL;
        CHECK_EQ_INT(epsnet_reader_open(&r, files[f], NULL, &err), 0);
        if (!r)
            continue;
        size_t asz = epsnet_reader_info(r)->vertex_attrs.size, n = 0, cap = 1 << 16;
        CHECK(f == 0 || asz == 15);
        epsnet_record *recs = malloc(cap * sizeof *recs);
        uint8_t *abytes = malloc(cap * (asz + 1));
        epsnet_record rec;
        int rc;
        while (recs && abytes && (rc = epsnet_reader_next(r, &rec, &err)) == 1) {
            if (n == cap) {
                cap *= 2;
                recs = realloc(recs, cap * sizeof *recs);
                abytes = realloc(abytes, cap * (asz + 1));
                if (!recs || !abytes)
                    break;
            }
            if (rec.attr)
                memcpy(abytes + n * asz, rec.attr, asz);
            recs[n++] = rec;
        }
        epsnet_reader_close(&r);
        CHECK(recs && abytes && n > 70000 * 4); /* several blocks */
        static const int threads[] = { 1, 2, 8 };
        for (int t = 0; recs && abytes && t < 3; t++) {
            en_pool *pool = NULL;
            CHECK_EQ_INT(en_pool_new(&pool, threads[t] == 1 ? 0 : threads[t]), 0);
            CHECK_EQ_INT(epsnet_reader_open(&r, files[f], NULL, &err), 0);
            if (!pool || !r)
                break;
            CHECK_EQ_INT(en_reader_use_pool(r, pool), 0);
            size_t i = 0, bad = 0;
            while ((rc = epsnet_reader_next(r, &rec, &err)) == 1) {
                if (i >= n || rec.kind != recs[i].kind ||
                    memcmp(rec.v, recs[i].v, sizeof rec.v) != 0 ||
                    (rec.kind == EPSNET_REC_VERTEX && memcmp(rec.xyz, recs[i].xyz, sizeof rec.xyz) != 0) ||
                    (rec.attr == NULL) != (asz == 0 || rec.kind != EPSNET_REC_VERTEX) ||
                    (rec.attr && memcmp(rec.attr, abytes + i * asz, asz) != 0))
                    bad++;
                i++;
            }
            CHECK_EQ_INT(rc, 0);
            CHECK_EQ_U64(i, n);
            CHECK_EQ_U64(bad, 0);
            CHECK_EQ_INT(en_reader_use_pool(r, NULL), 0);
            if (threads[t] > 1)
                CHECK(en_pool_job_cpu_seconds(pool) > 0); /* the blocks were decoded by jobs */
            epsnet_reader_close(&r);
            en_pool_free(&pool);
        }
        free(recs);
        free(abytes);
    }
}

typedef struct stream_check {
    uint64_t nv, nt, nfin, late, unsorted;
    int closed_manifold;
    int64_t euler;
} stream_check;

static int cmp_edge(const void *a, const void *b)
{
    const uint64_t *x = a, *y = b;
    return x[0] != y[0] ? (x[0] > y[0]) - (x[0] < y[0]) : (x[1] > y[1]) - (x[1] < y[1]);
}

/* Read path record by record: vertices non-decreasing along z, every vertex
 * finalized right after its last triangle (no triangle in between), and
 * the surface's Euler characteristic and edge-manifoldness. */
static int check_stream(const char *path, stream_check *c, double **xyz_out)
{
    memset(c, 0, sizeof *c);
    epsnet_reader *r = NULL;
    epsnet_error err;
    if (epsnet_reader_open(&r, path, NULL, &err))
        return -1;
    size_t cap = 1024, tcap = 1024;
    double *xyz = malloc(cap * 3 * sizeof *xyz);
    uint64_t *tri = malloc(tcap * 3 * sizeof *tri);
    uint64_t *last_face = malloc(cap * sizeof *last_face);
    epsnet_record rec;
    int rc;
    while ((rc = epsnet_reader_next(r, &rec, &err)) == 1) {
        if (rec.kind == EPSNET_REC_VERTEX) {
            if (c->nv == cap) {
                cap *= 2;
                xyz = realloc(xyz, cap * 3 * sizeof *xyz);
                last_face = realloc(last_face, cap * sizeof *last_face);
            }
            if (c->nv && rec.xyz[2] < xyz[3 * (c->nv - 1) + 2])
                c->unsorted++;
            memcpy(xyz + 3 * c->nv, rec.xyz, sizeof rec.xyz);
            last_face[c->nv++] = UINT64_MAX;
        } else if (rec.kind == EPSNET_REC_TRIANGLE) {
            if (c->nt == tcap) {
                tcap *= 2;
                tri = realloc(tri, tcap * 3 * sizeof *tri);
            }
            memcpy(tri + 3 * c->nt, rec.v, sizeof rec.v);
            for (int k = 0; k < 3; k++)
                last_face[rec.v[k]] = c->nt;
            c->nt++;
        } else {
            c->nfin++;
            /* right after its last triangle: no triangle since that one */
            c->late += last_face[rec.v[0]] != c->nt - 1 && last_face[rec.v[0]] != UINT64_MAX ? 1 : 0;
        }
    }
    epsnet_reader_close(&r);
    uint64_t ne = 3 * c->nt;
    uint64_t *e = malloc(2 * sizeof *e * (ne + 1));
    for (uint64_t f = 0; f < c->nt; f++)
        for (int k = 0; k < 3; k++) {
            uint64_t a = tri[3 * f + k], b = tri[3 * f + (k + 1) % 3];
            e[2 * (3 * f + k)] = a < b ? a : b;
            e[2 * (3 * f + k) + 1] = a < b ? b : a;
        }
    qsort(e, ne, 2 * sizeof *e, cmp_edge);
    uint64_t edges = 0;
    c->closed_manifold = 1;
    for (uint64_t i = 0; i < ne;) {
        uint64_t j = i;
        while (j < ne && e[2 * j] == e[2 * i] && e[2 * j + 1] == e[2 * i + 1])
            j++;
        c->closed_manifold &= j - i == 2;
        edges++;
        i = j;
    }
    c->euler = (int64_t)c->nv - (int64_t)edges + (int64_t)c->nt;
    free(e);
    free(tri);
    free(last_face);
    if (xyz_out)
        *xyz_out = xyz;
    else
        free(xyz);
    return rc;
}

static int cmp_xyz(const void *a, const void *b)
{
    return memcmp(a, b, 3 * sizeof(double));
}

/* docs/architecture.md §9: a valid sorted stream; docs/method.md §11: samples survive, a
 * closed surface keeps its genus. Many small slabs put seams everywhere. */
TEST(output_is_a_valid_sorted_stream_keeping_samples_and_genus)
{
    static const struct {
        const char *shape;
        uint64_t faces;
        int64_t euler;
    } cases[] = { { "bumpy", 20000, 2 }, { "torus", 8000, 0 }, { "cad", 8000, 0 }, { "dimple", 8000, 2 } };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        const char *in = tl_path("valid_in.smz"), *out = tl_path("valid_out.smz");
        epsnet_error err;
        CHECK_EQ_INT(tl_gen_file(in, cases[i].shape, cases[i].faces, NAN, 7, 0, &err), 0);
        epsnet_stats st;
        CHECK_EQ_INT(simplify_file(in, out, 300, 2, 1, &st, &err), 0);
        stream_check c;
        double *xyz = NULL;
        CHECK_EQ_INT(check_stream(out, &c, &xyz), 0);
        CHECK(st.slabs > 3);
        CHECK(c.nt < cases[i].faces / 2);
        CHECK_EQ_U64(c.nv, st.output_vertices);
        CHECK_EQ_U64(c.nt, st.output_faces);
        CHECK_EQ_U64(c.nfin, c.nv);
        CHECK_EQ_U64(c.late, 0);
        CHECK_EQ_U64(c.unsorted, 0);
        CHECK(c.closed_manifold);
        CHECK_EQ_INT((int)c.euler, (int)cases[i].euler);
        /* every sample's coordinates are among the output's */
        en_slab s;
        gauss_sphere g;
        gauss_rotation rot;
        gauss_rotation_identity(&rot);
        gauss_init(&g, 8, &rot);
        CHECK_EQ_INT(gen_slab(cases[i].shape, cases[i].faces, NAN, 7, 0, &s), 0);
        classified cl;
        CHECK_EQ_INT(classify_all(&g, &s, &cl), 0);
        qsort(xyz, c.nv, 3 * sizeof *xyz, cmp_xyz);
        uint64_t missing = 0, samples = 0;
        for (uint32_t v = 0; v < s.nv; v++)
            if (cl.vclass[v] & EN_C_SAMPLE) {
                samples++;
                missing += !bsearch(s.pos + 3 * (size_t)v, xyz, c.nv, 3 * sizeof *xyz, cmp_xyz);
            }
        CHECK(samples > 0);
        CHECK_EQ_U64(missing, 0);
        classified_free(&cl);
        en_slab_free(&s);
        free(xyz);
    }
}

/* Issue 6: "no seam may stay unsimplified". The input non-samples within a
 * ring of a slab border must be left over no more often than the others,
 * and the result must match the one-slab run's size. */
TEST(seams_are_simplified_like_the_rest)
{
    const char *in = tl_path("seam_in.smz"), *out = tl_path("seam_out.smz");
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 60000, NAN, 5, 0, &err), 0);
    epsnet_stats one, many;
    CHECK_EQ_INT(simplify_file(in, out, UINT32_MAX, 1, 1, &one, &err), 0);
    CHECK_EQ_INT(simplify_file(in, out, 1500, 2, 1, &many, &err), 0);
    CHECK_EQ_U64(one.slabs, 1);
    CHECK_EQ_U64(one.band_nonsamples, 0);
    CHECK(many.slabs >= 15);
    CHECK(many.band_nonsamples > 5000);
    CHECK(many.inner_nonsamples > 5000);
    CHECK(many.seam_collapses > 1000);
    double band = (double)many.band_nonsamples_left / (double)many.band_nonsamples;
    double inner = (double)many.inner_nonsamples_left / (double)many.inner_nonsamples;
    double whole = (double)one.inner_nonsamples_left / (double)one.inner_nonsamples;
    fprintf(stderr, "  left over: band %.5f, inner %.5f, one slab %.5f; faces %llu vs %llu\n", band, inner, whole,
            (unsigned long long)many.output_faces, (unsigned long long)one.output_faces);
    CHECK(band <= inner + 0.002);
    CHECK(band <= whole + 0.002);
    CHECK_EQ_U64(many.samples, one.samples);
    CHECK(many.output_faces <= one.output_faces + one.output_faces / 100);
    CHECK(one.output_faces <= many.output_faces + many.output_faces / 100);
}

/* Paper Table 3: the active set follows the stream's width (about the
 * square root of the size for these sorted spheres), not its length. */
TEST(active_set_grows_with_width_not_length)
{
    const char *in = tl_path("active.smz"), *out = tl_path("active_out.smz");
    epsnet_error err;
    uint64_t active[2], faces[2] = { 20000, 160000 };
    for (int i = 0; i < 2; i++) {
        CHECK_EQ_INT(tl_gen_file(in, "bumpy", faces[i], NAN, 1, 0, &err), 0);
        epsnet_stats st;
        CHECK_EQ_INT(simplify_file(in, out, 1000, 2, 1, &st, &err), 0);
        active[i] = st.max_active;
        CHECK(active[i] > 0 && active[i] < st.faces);
    }
    fprintf(stderr, "  max active: %llu at 20k faces, %llu at 160k\n", (unsigned long long)active[0],
            (unsigned long long)active[1]);
    CHECK(active[1] < 4 * active[0]); /* 8x the faces; sqrt(8) = 2.8 */
}

/* Copy the stream at from to to (float64, finalization kept), with
 * coordinate axis[i] of vertex at[i] set to 1e200. */
static int copy_stream_with_huge(const char *from, const char *to, const uint64_t *at, const int *axis, int n)
{
    epsnet_error err;
    epsnet_reader *r = NULL;
    epsnet_writer *w = NULL;
    int rc = epsnet_reader_open(&r, from, NULL, &err);
    if (rc)
        return rc;
    epsnet_mesh_info info = *epsnet_reader_info(r);
    info.coord_type = EPSNET_COORD_FLOAT64;
    info.sorted_axis = -1;
    rc = epsnet_writer_open(&w, to, NULL, &info, &err);
    epsnet_record rec;
    uint64_t nv = 0;
    while (rc == 0 && (rc = epsnet_reader_next(r, &rec, &err)) == 1) {
        for (int i = 0; i < n && rec.kind == EPSNET_REC_VERTEX; i++)
            if (nv == at[i])
                rec.xyz[axis[i]] = 1e200;
        nv += rec.kind == EPSNET_REC_VERTEX;
        rc = epsnet_writer_put(w, &rec, &err);
    }
    if (rc == 0)
        rc = epsnet_writer_commit(&w, &err);
    epsnet_writer_abort(&w);
    epsnet_reader_close(&r);
    return rc;
}

/* A face whose normal overflows fails its slab's worker; whichever worker
 * finishes first, the first bad slab in stream order is reported, the run
 * stops cleanly and leaves no output. */
TEST(worker_error_surfaces_in_order)
{
    const char *good = tl_path("err_good.smz"), *bad = tl_path("err_bad.sma"), *out = tl_path("err_out.smz");
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(good, "bumpy", 20000, NAN, 1, 0, &err), 0);
    /* two far apart pairs of vertices in a row (they share faces): x and y
     * at 1e200 make those faces' cross products 1e400 */
    uint64_t third = 0;
    {
        tl_mesh m;
        CHECK_EQ_INT(tl_read_mesh(good, &m, &err), 0);
        third = m.nv / 3;
        tl_mesh_free(&m);
    }
    const uint64_t at[4] = { third, third + 1, 2 * third, 2 * third + 1 };
    const int axis[4] = { 0, 1, 0, 1 };
    CHECK_EQ_INT(copy_stream_with_huge(good, bad, at, axis, 4), 0);
    char first[1024] = "";
    static const int threads[] = { 1, 2, 8 };
    for (int t = 0; t < 3; t++) {
        epsnet_error e;
        int rc = simplify_file(bad, out, 64, threads[t], 1, NULL, &e);
        CHECK_EQ_INT(rc, EPSNET_EFORMAT);
        const char *msg = epsnet_error_message(&e);
        CHECK_STR_CONTAINS(msg, "err_bad.sma");
        CHECK_STR_CONTAINS(msg, "normal overflows");
        if (t == 0)
            snprintf(first, sizeof first, "%s", msg);
        else
            CHECK(strcmp(first, msg) == 0);
        CHECK(!tl_exists(out));
    }
}

static int count_entries(const char *dir)
{
    char cmd[600];
    snprintf(cmd, sizeof cmd, "ls -A '%s' | wc -l", dir);
    FILE *p = popen(cmd, "r");
    int n = -1;
    if (p) {
        if (fscanf(p, "%d", &n) != 1)
            n = -1;
        pclose(p);
    }
    return n;
}

/* Issue 5: an ordinary mesh (a shuffled PLY, no finalization) is sorted
 * into a stream first, so simplify gives what it gives on the sorted file,
 * in bounded memory, and leaves no temporary behind. */
TEST(unsorted_input_is_sorted_first)
{
    char dir[512], ply[600], smz[600], a[600], b[600];
    snprintf(dir, sizeof dir, "%s/unsorted", tl_tmpdir());
    CHECK_EQ_INT(mkdir(dir, 0700), 0);
    snprintf(ply, sizeof ply, "%s/in.ply", dir);
    snprintf(smz, sizeof smz, "%s/in.smz", dir);
    snprintf(a, sizeof a, "%s/a.smz", dir);
    snprintf(b, sizeof b, "%s/b.smz", dir);
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(ply, "bumpy", 20000, NAN, 9, 1, &err), 0);
    CHECK_EQ_INT(epsnet_sort_file(ply, smz, NULL, NULL, &err), 0);
    epsnet_stats sa, sb;
    CHECK_EQ_INT(simplify_file(ply, a, 400, 2, 1, &sa, &err), 0);
    CHECK_EQ_INT(simplify_file(smz, b, 400, 2, 1, &sb, &err), 0);
    CHECK(sa.seconds_sort > 0);
    CHECK(sb.seconds_sort == 0);
    CHECK(sa.slabs > 10);
    CHECK(tl_same_file(a, b));
    CHECK_EQ_INT(count_entries(dir), 4); /* in.ply, in.smz, a.smz, b.smz */
}

/* What a run's progress callback saw of its folders: the output's (dir)
 * and the temporaries' (runs). */
typedef struct folder_watch {
    const char *dir, *runs;
    int calls;
    int strangers;  /* most entries in dir beside the inputs, runs, a.smz (the run before's) and its temporary */
    int named_runs; /* most entries in runs */
    int open_runs;  /* most files this process had open in runs at once */
} folder_watch;

static int max_int(int a, int b)
{
    return a > b ? a : b;
}

static int watch_folders(void *opaque, uint64_t done, uint64_t total)
{
    (void)done;
    (void)total;
    folder_watch *w = opaque;
    w->calls++;
    int strangers = 0, named = 0, open_runs = 0;
    DIR *d = opendir(w->dir);
    for (struct dirent *e; d && (e = readdir(d));)
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..") && strcmp(e->d_name, "in.ply") &&
            strcmp(e->d_name, "in.smz") && strcmp(e->d_name, "b.smz") && strcmp(e->d_name, "a.smz") && strcmp(e->d_name, "runs") &&
            strncmp(e->d_name, ".a.smz.epsnet-", 14))
            strangers++;
    if (d)
        closedir(d);
    d = opendir(w->runs);
    for (struct dirent *e; d && (e = readdir(d));)
        named += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    if (d)
        closedir(d);
    d = opendir("/proc/self/fd");
    size_t n = strlen(w->runs);
    for (struct dirent *e; d && (e = readdir(d));) {
        char link[300], target[700];
        snprintf(link, sizeof link, "/proc/self/fd/%s", e->d_name);
        ssize_t k = readlink(link, target, sizeof target - 1);
        if (k > 0) {
            target[k] = '\0';
            open_runs += strncmp(target, w->runs, n) == 0 && target[n] == '/';
        }
    }
    if (d)
        closedir(d);
    w->strangers = max_int(w->strangers, strangers);
    w->named_runs = max_int(w->named_runs, named);
    w->open_runs = max_int(w->open_runs, open_runs);
    return 0;
}

/* docs/architecture.md §7: the sort's last pass feeds the first
 * chunker. No sorted copy is written anywhere: the only temporaries are the
 * sort's runs, anonymous files in --tmpdir (several at once when --mem is
 * small enough to spill); progress moves while the sort runs; and the
 * bytes are those of simplifying the sorted file, for 1 and 2 threads,
 * spilling or not. */
TEST(unsorted_input_feeds_the_pipeline_without_a_sorted_copy)
{
    char dir[512], runs[520], ply[600], smz[600], a[600], b[600];
    snprintf(dir, sizeof dir, "%s/nocopy", tl_tmpdir());
    snprintf(runs, sizeof runs, "%s/runs", dir);
    CHECK_EQ_INT(mkdir(dir, 0700), 0);
    CHECK_EQ_INT(mkdir(runs, 0700), 0);
    snprintf(ply, sizeof ply, "%s/in.ply", dir);
    snprintf(smz, sizeof smz, "%s/in.smz", dir);
    snprintf(a, sizeof a, "%s/a.smz", dir);
    snprintf(b, sizeof b, "%s/b.smz", dir);
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(ply, "bumpy", 20000, NAN, 5, 1, &err), 0);
    CHECK_EQ_INT(epsnet_sort_file(ply, smz, NULL, NULL, &err), 0);
    CHECK_EQ_INT(simplify_file(smz, b, 300, 1, 2, NULL, &err), 0);
    static const uint64_t mems[] = { 0, 4u << 20 }; /* the default, and one that spills */
    for (int m = 0; m < 2; m++)
        for (int threads = 1; threads <= 2; threads++) {
            folder_watch w = { .dir = dir, .runs = runs };
            epsnet_settings set;
            epsnet_default_settings(&set);
            set.rotation_mode = EPSNET_ROTATION_IDENTITY;
            set.frequency = 8;
            set.slab_vertices = 300;
            set.threads = threads;
            set.passes = 2;
            set.mem = mems[m];
            set.tmpdir = runs;
            set.progress = watch_folders;
            set.progress_opaque = &w;
            epsnet_context *ctx = NULL;
            CHECK_EQ_INT(epsnet_context_new(&ctx, &set, &err), 0);
            CHECK_EQ_INT(epsnet_simplify_file(ctx, ply, a, &err), 0);
            CHECK(epsnet_context_stats(ctx)->seconds_sort > 0);
            epsnet_context_free(&ctx);
            if (!tl_same_file(a, b))
                fprintf(stderr, "  mem %llu, %d threads: bytes differ\n", (unsigned long long)mems[m], threads);
            CHECK(tl_same_file(a, b));
            CHECK(w.calls > 0);
            CHECK_EQ_INT(w.strangers, 0);
            CHECK_EQ_INT(w.named_runs, 0);
            if (m == 1)
                CHECK(w.open_runs > 1);
            CHECK_EQ_INT(count_entries(runs), 0);
            CHECK_EQ_INT(count_entries(dir), 5); /* in.ply, in.smz, a.smz, b.smz, runs */
        }
}

/* One vertex at 1e200 keeps its faces' normals finite but overflows the
 * quadrics to NaN; the collapse queue once looped forever on NaN costs. */
TEST(huge_coordinates_end)
{
    char good[512], bad[512], out[512];
    snprintf(good, sizeof good, "%s", tl_path("huge_good.smz"));
    snprintf(bad, sizeof bad, "%s", tl_path("huge_bad.smz"));
    snprintf(out, sizeof out, "%s", tl_path("huge_out.smz"));
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(good, "sphere", 4000, NAN, 1, 0, &err), 0);
    const uint64_t at[1] = { 2000 }; /* about the middle of ~4000 faces' 2000 vertices */
    const int axis[1] = { 0 };
    CHECK_EQ_INT(copy_stream_with_huge(good, bad, at, axis, 1), 0);
    epsnet_stats st;
    CHECK_EQ_INT(simplify_file(bad, out, 200, 2, 1, &st, &err), 0);
    CHECK(st.output_faces > 0 && st.output_faces < st.faces);
}

/* A push/pull stream on ctx, the reader of in and a writer of the pulled
 * records to mine (a sorted stream along z, like the generated inputs). */
static void open_push_pull(epsnet_context *ctx, const char *in, const char *mine, epsnet_stream **s,
                           epsnet_reader **r, epsnet_writer **w)
{
    epsnet_error err;
    epsnet_mesh_info info;
    memset(&info, 0, sizeof info);
    info.nverts = info.nfaces = EPSNET_COUNT_UNKNOWN;
    info.streaming = 1;
    info.sorted_axis = 2;
    CHECK_EQ_INT(epsnet_stream_open(s, ctx, &err), 0);
    CHECK_EQ_INT(epsnet_reader_open(r, in, NULL, &err), 0);
    CHECK_EQ_INT(epsnet_writer_open(w, mine, NULL, &info, &err), 0);
}

/* The push/pull API (epsnet.h §8b) gives the records epsnet_simplify_file
 * writes, and rejects bad records with a clear error. */
TEST(push_pull_matches_file_api)
{
    const char *in = tl_path("pp_in.smz"), *out = tl_path("pp_out.sma"), *mine = tl_path("pp_mine.sma");
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(in, "torus", 12000, NAN, 1, 0, &err), 0);
    CHECK_EQ_INT(simplify_file(in, out, 500, 2, 2, NULL, &err), 0);

    epsnet_context *ctx = make_ctx(500, 2, 2);
    epsnet_stream *s = NULL;
    epsnet_reader *r = NULL;
    epsnet_writer *w = NULL;
    open_push_pull(ctx, in, mine, &s, &r, &w);
    epsnet_record rec, o;
    int rc;
    uint64_t pulled = 0;
    while ((rc = epsnet_reader_next(r, &rec, &err)) == 1) {
        CHECK_EQ_INT(epsnet_stream_push(s, &rec, &err), 0);
        while ((rc = epsnet_stream_pull(s, &o, &err)) == 1) {
            pulled++;
            CHECK_EQ_INT(epsnet_writer_put(w, &o, &err), 0);
        }
        CHECK_EQ_INT(rc, 0);
    }
    CHECK_EQ_INT(epsnet_stream_end(s, &err), 0);
    while ((rc = epsnet_stream_pull(s, &o, &err)) == 1) {
        pulled++;
        CHECK_EQ_INT(epsnet_writer_put(w, &o, &err), 0);
    }
    CHECK(pulled > 1000);
    CHECK_EQ_INT(epsnet_writer_commit(&w, &err), 0);
    epsnet_reader_close(&r);
    epsnet_stream_close(&s);
    CHECK(tl_same_file(out, mine));

    /* bad records: unknown vertex, then the error sticks */
    CHECK_EQ_INT(epsnet_stream_open(&s, ctx, &err), 0);
    memset(&rec, 0, sizeof rec);
    rec.kind = EPSNET_REC_VERTEX;
    CHECK_EQ_INT(epsnet_stream_push(s, &rec, &err), 0);
    rec.kind = EPSNET_REC_TRIANGLE;
    rec.v[0] = 0, rec.v[1] = 0, rec.v[2] = 5;
    CHECK_EQ_INT(epsnet_stream_push(s, &rec, &err), EPSNET_EFORMAT);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "unknown vertex 5");
    rec.kind = EPSNET_REC_VERTEX;
    CHECK_EQ_INT(epsnet_stream_push(s, &rec, &err), EPSNET_EFORMAT);
    epsnet_stream_close(&s);
    CHECK_EQ_INT(epsnet_stream_open(&s, ctx, &err), 0);
    rec.kind = EPSNET_REC_VERTEX;
    CHECK_EQ_INT(epsnet_stream_push(s, &rec, &err), 0);
    rec.kind = EPSNET_REC_FINALIZE;
    rec.v[0] = 0;
    CHECK_EQ_INT(epsnet_stream_push(s, &rec, &err), 0);
    CHECK_EQ_INT(epsnet_stream_push(s, &rec, &err), EPSNET_EFORMAT);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "finalized twice");
    epsnet_stream_close(&s);
    epsnet_context_free(&ctx);
}

/* Back-pressure (epsnet.h §8b): while output waits, push refuses with
 * EPSNET_EAGAIN and does not take the record; pushing it again after the
 * pull gives exactly the output of the file API. */
TEST(push_refuses_until_waiting_output_is_pulled)
{
    char in[512], out[512], mine[512];
    snprintf(in, sizeof in, "%s", tl_path("bp_in.smz"));
    snprintf(out, sizeof out, "%s", tl_path("bp_out.sma"));
    snprintf(mine, sizeof mine, "%s", tl_path("bp_mine.sma"));
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 20000, NAN, 1, 0, &err), 0);
    CHECK_EQ_INT(simplify_file(in, out, 300, 2, 1, NULL, &err), 0);
    epsnet_context *ctx = make_ctx(300, 2, 1);
    epsnet_stream *s = NULL;
    epsnet_reader *r = NULL;
    epsnet_writer *w = NULL;
    open_push_pull(ctx, in, mine, &s, &r, &w);
    epsnet_record rec, o;
    int rc, refusals = 0;
    while ((rc = epsnet_reader_next(r, &rec, &err)) == 1) {
        /* Pull only when refused: the refused record must be pushed again. */
        while ((rc = epsnet_stream_push(s, &rec, &err)) == EPSNET_EAGAIN) {
            refusals++;
            CHECK_STR_CONTAINS(epsnet_error_message(&err), "pull them");
            while ((rc = epsnet_stream_pull(s, &o, &err)) == 1)
                CHECK_EQ_INT(epsnet_writer_put(w, &o, &err), 0);
            CHECK_EQ_INT(rc, 0);
        }
        CHECK_EQ_INT(rc, 0);
    }
    CHECK_EQ_INT(epsnet_stream_end(s, &err), 0);
    while ((rc = epsnet_stream_pull(s, &o, &err)) == 1)
        CHECK_EQ_INT(epsnet_writer_put(w, &o, &err), 0);
    CHECK_EQ_INT(rc, 0);
    CHECK(refusals > 1); /* many slabs: output waited many times */
    CHECK_EQ_INT(epsnet_writer_commit(&w, &err), 0);
    epsnet_reader_close(&r);
    epsnet_stream_close(&s);
    epsnet_context_free(&ctx);
    CHECK(tl_same_file(out, mine));
}

/* --stats splits CPU time between the calling thread and the slab jobs
 * (epsnet_stats.cpu_main, cpu_workers): both are measured, at one thread
 * (jobs inline) and at two, and the JSON carries them. */
TEST(stats_split_cpu_between_main_and_workers)
{
    char in[512], out[512], json[512];
    snprintf(in, sizeof in, "%s", tl_path("cpu_in.smz"));
    snprintf(out, sizeof out, "%s", tl_path("cpu_out.smz"));
    snprintf(json, sizeof json, "%s", tl_path("cpu.json"));
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 60000, NAN, 1, 0, &err), 0);
    for (int threads = 1; threads <= 2; threads++) {
        epsnet_context *ctx = make_ctx(2000, threads, 1);
        CHECK_EQ_INT(epsnet_simplify_file(ctx, in, out, &err), 0);
        const epsnet_stats *st = epsnet_context_stats(ctx);
        CHECK(st->cpu_workers > 0);
        CHECK(st->cpu_main > 0);
        CHECK_EQ_INT(epsnet_stats_write_json(ctx, NULL, json, &err), 0);
        size_t n;
        char *text = (char *)tl_read_file(json, &n);
        CHECK(text != NULL);
        if (text)
            CHECK_STR_CONTAINS(text, "\"cpu\": {\"main\": ");
        free(text);
        epsnet_context_free(&ctx);
    }
}

/* What a run's progress callback saw of the bar. */
typedef struct bar_watch {
    int calls, backwards, finish_calls;
    double last, share;
    uint64_t other_totals; /* calls whose total was not the bar's */
    int cancel_in_finish;  /* answer "cancel" once the finish reports */
} bar_watch;

static int watch_bar(void *opaque, uint64_t done, uint64_t total)
{
    bar_watch *b = opaque;
    double f = total ? (double)done / (double)total : 0;
    b->calls++;
    b->other_totals += total != 1000000u;
    b->backwards += f < b->last;
    b->finish_calls += f > b->share + 1e-9 && f < 1;
    b->last = f;
    return b->cancel_in_finish && b->finish_calls > 0;
}

/* docs/architecture.md §7: a streamed target's one-slab finish comes after
 * the last record and takes a third of the run or more; the bar keeps the
 * last part for it and moves while it runs, never backwards, from the
 * sorted stream and from a file that is sorted first. The callback changes
 * nothing in the output. */
TEST(a_streamed_targets_finish_moves_the_progress_bar)
{
    char smz[512], ply[512], a[512], b[512];
    snprintf(smz, sizeof smz, "%s", tl_path("bar_in.smz"));
    snprintf(ply, sizeof ply, "%s", tl_path("bar_in.ply"));
    snprintf(a, sizeof a, "%s", tl_path("bar_a.smz"));
    snprintf(b, sizeof b, "%s", tl_path("bar_b.smz"));
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(smz, "bumpy", 100000, NAN, 3, 0, &err), 0);
    CHECK_EQ_INT(tl_gen_file(ply, "bumpy", 100000, NAN, 3, 1, &err), 0);
    const char *inputs[] = { smz, ply };
    for (int k = 0; k < 2; k++) {
        for (int watched = 0; watched < 2; watched++) {
            bar_watch w = { .share = 0.55 };
            epsnet_settings set;
            epsnet_default_settings(&set);
            set.threads = 2;
            set.slab_vertices = 4096;
            set.target_ratio = 0.1;
            if (watched) {
                set.progress = watch_bar;
                set.progress_opaque = &w;
            }
            epsnet_context *ctx = NULL;
            CHECK_EQ_INT(epsnet_context_new(&ctx, &set, &err), 0);
            CHECK_EQ_INT(epsnet_simplify_file(ctx, inputs[k], watched ? a : b, &err), 0);
            CHECK_EQ_INT((int)epsnet_context_stats(ctx)->passes, 2); /* thin, then the finish */
            epsnet_context_free(&ctx);
            if (!watched)
                continue;
            CHECK(w.calls > 0);
            CHECK_EQ_INT((int)w.other_totals, 0);
            CHECK_EQ_INT(w.backwards, 0);
            CHECK(w.finish_calls > 0);
            CHECK(w.last <= 1);
        }
        CHECK(tl_same_file(a, b));
    }
    /* cancelled while the finish runs: EPSNET_EINTR, and no output */
    bar_watch w = { .share = 0.55, .cancel_in_finish = 1 };
    epsnet_settings set;
    epsnet_default_settings(&set);
    set.threads = 2;
    set.slab_vertices = 4096;
    set.target_ratio = 0.1;
    set.progress = watch_bar;
    set.progress_opaque = &w;
    char c[512];
    snprintf(c, sizeof c, "%s", tl_path("bar_c.smz"));
    epsnet_context *ctx = NULL;
    CHECK_EQ_INT(epsnet_context_new(&ctx, &set, &err), 0);
    CHECK_EQ_INT(epsnet_simplify_file(ctx, smz, c, &err), EPSNET_EINTR);
    epsnet_context_free(&ctx);
    CHECK_EQ_INT(w.finish_calls, 1);
    CHECK(access(c, F_OK) != 0);
}

/* The same bar through rounds on slabs (a budget whose one slab the
 * thinned mesh is over): the stage's part moves in every round, by an
 * estimate of the rounds to come, never backwards, and a cancel in a round
 * stops the run with no output. */
TEST(the_progress_bar_moves_through_a_target_stages_rounds)
{
    char smz[512], out[512];
    snprintf(smz, sizeof smz, "%s", tl_path("rounds_in.smz"));
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(smz, "bumpy", 200000, NAN, 3, 0, &err), 0);
    for (int cancel = 0; cancel < 2; cancel++) {
        snprintf(out, sizeof out, "%s", tl_path(cancel ? "rounds_cancelled.smz" : "rounds_out.smz"));
        bar_watch w = { .share = 0.55, .cancel_in_finish = cancel };
        epsnet_settings set;
        epsnet_default_settings(&set);
        set.threads = 2;
        set.slab_vertices = 1024;
        /* note: at 2M the rounds' held state went over the budget once
         * their ceilings stopped taking everything (the one round before
         * took the mesh to 2,462 faces for a target of 3,996) */
        set.mem = 3u << 20;
        set.target_ratio = 0.02;
        set.progress = watch_bar;
        set.progress_opaque = &w;
        epsnet_context *ctx = NULL;
        CHECK_EQ_INT(epsnet_context_new(&ctx, &set, &err), 0);
        int rc = epsnet_simplify_file(ctx, smz, out, &err);
        const epsnet_stats *st = epsnet_context_stats(ctx);
        uint32_t rounds = st->target_rounds;
        uint64_t faces = st->output_faces, want = st->target_faces;
        epsnet_context_free(&ctx);
        if (cancel) {
            CHECK_EQ_INT(rc, EPSNET_EINTR);
            CHECK_EQ_INT(w.finish_calls, 1);
            CHECK(access(out, F_OK) != 0);
            continue;
        }
        CHECK_EQ_INT(rc, 0);
        CHECK(rounds >= 1);
        CHECK(faces <= want && faces + 1 >= want);
        CHECK_EQ_INT(w.backwards, 0);
        CHECK((uint32_t)w.finish_calls >= rounds + 1); /* each round and the last report at least once */
        CHECK(w.last > 0.9 && w.last <= 1);
    }
}

/* A seam pair's copies go to one slab: a copy finalized while its twin is
 * live waits, and waiting neither makes a slab of ghosts nor cuts more
 * often (chunker.h, live_at). Copy 0 is done with at once, copy 1 only at
 * the end of a long strip. */
/* Count a cut slab, note which slab owns each copy, and free it. */
static void tally(en_slab_work *w, uint32_t *slabs, int *empty, int64_t owner[2])
{
    (*slabs)++;
    *empty |= w->nowned == 0;
    for (uint32_t l = 0; l < w->nowned; l++)
        if (w->s.gid[l] < 2)
            owner[w->s.gid[l]] = w->index;
    en_slab_work_free(w);
    en_free(w);
}

/* The next slab the chunker cuts at the stream's end, or NULL. */
static en_slab_work *finish_next(en_chunker *c)
{
    en_slab_work *w = NULL;
    epsnet_error err;
    CHECK_EQ_INT(en_chunker_finish(c, &w, &err), 0);
    return w;
}

static int chunk_put(en_chunker *c, const epsnet_record *r, uint32_t *slabs, int *empty, int64_t owner[2])
{
    en_slab_work *w = NULL;
    epsnet_error err;
    int rc = en_chunker_put(c, r, &w, &err);
    if (rc == 0 && w)
        tally(w, slabs, empty, owner);
    return rc;
}

static void copies_wait_for_one_slab(uint32_t slab)
{
    enum { STRIP = 200 };
    en_chunker c;
    CHECK_EQ_INT(en_chunker_init(&c, slab, 0, "test"), 0);
    c.attr_size = 4;
    c.copies = 1;
    uint32_t slabs = 0;
    int empty = 0;
    int64_t owner[2] = { -1, -2 };
    uint8_t attr[4] = { 0 };
    epsnet_record r;
    memset(&r, 0, sizeof r);
    r.kind = EPSNET_REC_VERTEX;
    r.attr = attr;
    /* gid 0 and 1: the copies, at one position; gid 2 .. STRIP + 1: a strip */
    for (uint64_t g = 0; g < STRIP + 2; g++) {
        attr[0] = (uint8_t)g;
        r.xyz[0] = g < 2 ? 0.5 : (double)g;
        r.xyz[1] = g < 2 ? 0.0 : (double)(g & 1);
        CHECK_EQ_INT(chunk_put(&c, &r, &slabs, &empty, owner), 0);
    }
    epsnet_record t = { .kind = EPSNET_REC_TRIANGLE, .v = { 0, 2, 3 } };
    CHECK_EQ_INT(chunk_put(&c, &t, &slabs, &empty, owner), 0);
    epsnet_record f = { .kind = EPSNET_REC_FINALIZE, .v = { 0 } };
    CHECK_EQ_INT(chunk_put(&c, &f, &slabs, &empty, owner), 0);
    for (uint64_t k = 2; k + 2 < STRIP + 2; k++) {
        t.v[0] = k, t.v[1] = k + 1, t.v[2] = k + 2;
        CHECK_EQ_INT(chunk_put(&c, &t, &slabs, &empty, owner), 0);
        f.v[0] = k;
        CHECK_EQ_INT(chunk_put(&c, &f, &slabs, &empty, owner), 0);
    }
    t.v[0] = 1, t.v[1] = STRIP, t.v[2] = STRIP + 1;
    CHECK_EQ_INT(chunk_put(&c, &t, &slabs, &empty, owner), 0);
    uint64_t last[3] = { 1, STRIP, STRIP + 1 };
    for (int k = 0; k < 3; k++) {
        f.v[0] = last[k];
        CHECK_EQ_INT(chunk_put(&c, &f, &slabs, &empty, owner), 0);
    }
    en_slab_work *w;
    while ((w = finish_next(&c)) != NULL)
        tally(w, &slabs, &empty, owner); /* frees w */
    CHECK(owner[0] >= 0);
    CHECK_EQ_INT((int)owner[0], (int)owner[1]); /* one slab holds both copies */
    CHECK(!empty);
    CHECK(slabs <= (STRIP + 2 + slab - 1) / slab + 1);
    CHECK(c.deferred > 0);
    en_chunker_free(&c);
}

TEST(a_seam_pairs_copies_wait_for_one_slab)
{
    copies_wait_for_one_slab(8);
    copies_wait_for_one_slab(1); /* every cut would otherwise find the copy alone */
}

/* A slab's share counted in vertices (pass_plan.h: share_of_vertices): a
 * rippled tube streamed ring by ring through the chunker, each slab a few
 * rings between two frozen ones. Kept to half of what it can reach, a slab
 * takes exactly half of its inner vertices on faces, since each collapse
 * takes one; the same share in faces on inner vertices stops it earlier,
 * because a collapse beside a frozen ring also removes faces that count
 * leaves out (what held the slabs of a priced thinning far below its
 * ceiling while their seams went on to it, docs/architecture.md §7). */
enum { TUBE_AROUND = 32, TUBE_ALONG = 40, TUBE_SLAB = 10 * TUBE_AROUND };

static void tube_vertex(uint64_t g, double xyz[3])
{
    double x = (double)(g / TUBE_AROUND) * 0.2, t = 2 * M_PI * (double)(g % TUBE_AROUND) / TUBE_AROUND;
    double r = 1 + 0.1 * sin(1.3 * x) * sin(3 * t);
    xyz[0] = x, xyz[1] = r * cos(t), xyz[2] = r * sin(t);
}

/* The tube's slabs under one plan: what they did, summed. */
typedef struct tube_run {
    const en_pass_plan *t;
    const gauss_sphere *g;
    uint64_t collapses, reach;
} tube_run;

/* Run a slab the chunker cut from the tube under plan t, if both its ends
 * are frozen: its collapses, and its owned vertices on faces whose
 * neighbours are all owned here (what its own collapses can reach). */
static void tube_take(tube_run *tr, en_slab_work *w)
{
    if (w->index > 0 && !w->last) {
        w->g = tr->g;
        w->mode = EN_SLAB_SIMPLIFY;
        w->max_normal_dev = 60;
        w->plan = tr->t;
        CHECK_EQ_INT(en_slab_work_run(w), 0);
        tr->collapses += w->collapses;
        uint8_t *frozen = calloc((size_t)w->s.nv + 1, 1);
        for (uint32_t f = 0; f < w->s.nt; f++) {
            const uint32_t *v = w->s.tri + 3 * (size_t)f;
            if (v[0] >= w->nowned || v[1] >= w->nowned || v[2] >= w->nowned)
                frozen[v[0]] = frozen[v[1]] = frozen[v[2]] = 1;
        }
        for (uint32_t v = 0; v < w->nowned; v++)
            tr->reach += !frozen[v] && en_slab_degree(&w->s, v) > 0;
        free(frozen);
    }
    en_slab_work_free(w);
    en_free(w);
}

static void tube_put(en_chunker *c, tube_run *tr, const epsnet_record *r)
{
    en_slab_work *w = NULL;
    epsnet_error err;
    CHECK_EQ_INT(en_chunker_put(c, r, &w, &err), 0);
    if (w)
        tube_take(tr, w);
}

static void run_tube_slabs(tube_run *tr)
{
    en_chunker c;
    CHECK_EQ_INT(en_chunker_init(&c, TUBE_SLAB, 0, "tube"), 0);
    tr->collapses = tr->reach = 0;
    for (uint64_t k = 0; k <= TUBE_ALONG; k++) {
        for (uint64_t a = 0; k < TUBE_ALONG && a < TUBE_AROUND; a++) {
            epsnet_record r = { .kind = EPSNET_REC_VERTEX };
            tube_vertex(k * TUBE_AROUND + a, r.xyz);
            tube_put(&c, tr, &r);
        }
        for (uint64_t a = 0; k > 0 && k < TUBE_ALONG && a < TUBE_AROUND; a++) {
            uint64_t p0 = (k - 1) * TUBE_AROUND + a, p1 = (k - 1) * TUBE_AROUND + (a + 1) % TUBE_AROUND;
            epsnet_record f1 = { .kind = EPSNET_REC_TRIANGLE, .v = { p0, p1 + TUBE_AROUND, p0 + TUBE_AROUND } };
            epsnet_record f2 = { .kind = EPSNET_REC_TRIANGLE, .v = { p0, p1, p1 + TUBE_AROUND } };
            tube_put(&c, tr, &f1);
            tube_put(&c, tr, &f2);
        }
        for (uint64_t a = 0; k > 0 && a < TUBE_AROUND; a++) {
            epsnet_record f = { .kind = EPSNET_REC_FINALIZE, .v = { (k - 1) * TUBE_AROUND + a } };
            tube_put(&c, tr, &f);
        }
    }
    en_slab_work *w;
    while ((w = finish_next(&c)) != NULL)
        tube_take(tr, w);
    en_chunker_free(&c);
}

TEST(a_slabs_share_of_vertices_is_what_its_collapses_take)
{
    gauss_sphere g;
    gauss_rotation rot;
    gauss_rotation_identity(&rot);
    CHECK_EQ_INT(gauss_init(&g, 2, &rot), 0);
    en_pass_plan t = { .skeleton = EN_SKELETON_SPHERE, .keep_share = 0.5, .max_error = -1, .seams = EN_SEAMS_LEVEL };
    tube_run faces = { &t, &g, 0, 0 }, vertices = { &t, &g, 0, 0 };
    run_tube_slabs(&faces);
    t.share_of_vertices = 1;
    run_tube_slabs(&vertices);
    CHECK_EQ_INT((int)vertices.reach, (int)faces.reach);
    CHECK(vertices.reach >= 2 * 8 * TUBE_AROUND); /* at least two slabs with both ends frozen */
    /* half of each slab's reach, rounded down per slab */
    CHECK(vertices.collapses <= vertices.reach / 2 && vertices.collapses + 8 >= vertices.reach / 2);
    CHECK(faces.collapses < vertices.collapses);
}

/* A slab with hold_all owns what the slab before's ghosts left of
 * slab_vertices, so that it holds about that many however wide the stream,
 * and owns a quarter of it at least; without, it owns slab_vertices
 * (chunker.h). A
 * strip of `around` vertices a row, rows finalized one after the other:
 * its slabs' ghosts are about the row before and the row after. */
typedef struct cut_sizes {
    uint32_t n, owned[64], all[64];
} cut_sizes;

static void cut_size(cut_sizes *z, en_slab_work *w)
{
    if (z->n < 64) {
        z->owned[z->n] = w->nowned;
        z->all[z->n] = w->s.nv;
    }
    z->n++;
    en_slab_work_free(w);
    en_free(w);
}

static void cut_strip(uint32_t around, uint32_t rows, uint32_t slab, int hold_all, cut_sizes *z)
{
    en_chunker c;
    CHECK_EQ_INT(en_chunker_init(&c, slab, hold_all, "strip"), 0);
    memset(z, 0, sizeof *z);
    epsnet_error err;
    en_slab_work *w = NULL;
    for (uint64_t k = 0; k <= rows; k++) {
        for (uint64_t a = 0; k < rows && a < around; a++) {
            epsnet_record r = { .kind = EPSNET_REC_VERTEX, .xyz = { (double)a, (double)k, 0 } };
            CHECK_EQ_INT(en_chunker_put(&c, &r, &w, &err), 0);
        }
        for (uint64_t a = 0; k > 0 && k < rows && a + 1 < around; a++) {
            uint64_t p = (k - 1) * around + a, q = p + around;
            epsnet_record f1 = { .kind = EPSNET_REC_TRIANGLE, .v = { p, p + 1, q } };
            epsnet_record f2 = { .kind = EPSNET_REC_TRIANGLE, .v = { p + 1, q + 1, q } };
            CHECK_EQ_INT(en_chunker_put(&c, &f1, &w, &err), 0);
            CHECK(w == NULL);
            CHECK_EQ_INT(en_chunker_put(&c, &f2, &w, &err), 0);
            CHECK(w == NULL);
        }
        for (uint64_t a = 0; k > 0 && a < around; a++) {
            epsnet_record f = { .kind = EPSNET_REC_FINALIZE, .v = { (k - 1) * around + a } };
            CHECK_EQ_INT(en_chunker_put(&c, &f, &w, &err), 0);
            if (w)
                cut_size(z, w);
        }
    }
    while ((w = finish_next(&c)) != NULL)
        cut_size(z, w);
    en_chunker_free(&c);
}

TEST(a_slab_given_holds_owns_what_its_ghosts_leave)
{
    cut_sizes z;
    /* without: every slab but the last owns slab_vertices */
    cut_strip(50, 60, 400, 0, &z);
    CHECK(z.n >= 5 && z.n <= 64);
    for (uint32_t k = 0; k + 1 < z.n; k++)
        CHECK_EQ_INT((int)z.owned[k], 400);
    CHECK(z.all[2] >= 500); /* two rows of ghosts besides */
    /* with: the first owns slab_vertices, each after it what the one
     * before's ghosts left of slab_vertices, and holds about that in all */
    cut_strip(50, 60, 400, 1, &z);
    CHECK(z.n >= 5 && z.n <= 64);
    CHECK_EQ_INT((int)z.owned[0], 400);
    uint32_t total = 0;
    for (uint32_t k = 0; k < z.n; k++) {
        total += z.owned[k];
        if (k > 0 && k + 1 < z.n) {
            CHECK_EQ_INT((int)z.owned[k], (int)(400 - (z.all[k - 1] - z.owned[k - 1])));
            CHECK(z.all[k] <= 400 + 50); /* the width moves by a row at most */
        }
    }
    CHECK_EQ_INT((int)total, 50 * 60);
    /* a strip wider than a quarter of slab_vertices: slabs own the quarter where
     * the ghosts leave less */
    cut_strip(200, 25, 400, 1, &z);
    CHECK(z.n >= 5 && z.n <= 64);
    uint32_t floors = 0;
    for (uint32_t k = 1; k + 1 < z.n; k++) {
        uint32_t ghosts = z.all[k - 1] - z.owned[k - 1];
        CHECK_EQ_INT((int)z.owned[k], ghosts < 300 ? (int)(400 - ghosts) : 100);
        floors += z.owned[k] == 100;
    }
    CHECK(floors >= 3);
}

int main(void)
{
    RUN(samples_equal_one_slab_for_any_slab_size);
    RUN(a_seam_pairs_copies_wait_for_one_slab);
    RUN(a_slabs_share_of_vertices_is_what_its_collapses_take);
    RUN(a_slab_given_holds_owns_what_its_ghosts_leave);
    RUN(same_bytes_for_threads_1_2_3_8);
    RUN(seam_jobs_give_the_same_bytes_for_any_thread_count);
    RUN(damaged_smz_fails_alike_for_any_thread_count);
    RUN(smz_records_alike_on_the_pool);
    RUN(output_is_a_valid_sorted_stream_keeping_samples_and_genus);
    RUN(seams_are_simplified_like_the_rest);
    RUN(active_set_grows_with_width_not_length);
    RUN(worker_error_surfaces_in_order);
    RUN(unsorted_input_is_sorted_first);
    RUN(unsorted_input_feeds_the_pipeline_without_a_sorted_copy);
    RUN(huge_coordinates_end);
    RUN(push_pull_matches_file_api);
    RUN(push_refuses_until_waiting_output_is_pulled);
    RUN(stats_split_cpu_between_main_and_workers);
    RUN(a_streamed_targets_finish_moves_the_progress_bar);
    RUN(the_progress_bar_moves_through_a_target_stages_rounds);
    tl_cleanup();
    return tl_finish();
}
