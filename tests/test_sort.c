/*
 * epsnet_sort_file() (docs/architecture.md §13): any mesh becomes a spatially sorted,
 * finalized streaming mesh with exactly the same triangles (as triples of
 * coordinates, orientation included), whatever the memory budget, in the
 * same bytes every time. The output is checked by an independent validator
 * written here, not by the library's own reader checks alone.
 */
#include "sort/extsort.h"
#include "sort/sort.h"
#include "testlib.h"

/* ---- helpers ---- */


/* threads < 0: the default. */
static int sort_threads(const char *in, const char *out, uint64_t mem, int threads, int axis, epsnet_sort_stats *st,
                        epsnet_error *err)
{
    epsnet_sort_settings s;
    epsnet_sort_default_settings(&s);
    s.mem = mem;
    if (threads >= 0)
        s.threads = threads;
    s.axis = axis;
    s.tmpdir = tl_tmpdir();
    return epsnet_sort_file(in, out, &s, st, err);
}

static int sort_with(const char *in, const char *out, uint64_t mem, int axis, epsnet_sort_stats *st,
                     epsnet_error *err)
{
    return sort_threads(in, out, mem, -1, axis, st, err);
}

/* A triangle as its corners' coordinates, rotated so that the smallest
 * corner comes first: the same triangle with the same orientation gives
 * the same 9 numbers, a flipped one does not. */
typedef struct coord_tri {
    double c[9];
} coord_tri;

static int cmp_corner(const double *a, const double *b)
{
    for (int k = 0; k < 3; k++)
        if (a[k] != b[k])
            return a[k] < b[k] ? -1 : 1;
    return 0;
}

static int cmp_tri(const void *pa, const void *pb)
{
    const coord_tri *a = pa, *b = pb;
    for (int i = 0; i < 3; i++) {
        int c = cmp_corner(a->c + 3 * i, b->c + 3 * i);
        if (c)
            return c;
    }
    return 0;
}

static coord_tri *coord_tris(const tl_mesh *m)
{
    coord_tri *t = malloc((m->nt ? m->nt : 1) * sizeof *t);
    for (uint64_t f = 0; f < m->nt; f++) {
        int first = 0;
        for (int k = 1; k < 3; k++)
            if (cmp_corner(m->xyz + 3 * m->tri[3 * f + k], m->xyz + 3 * m->tri[3 * f + first]) < 0)
                first = k;
        for (int k = 0; k < 3; k++)
            memcpy(t[f].c + 3 * k, m->xyz + 3 * m->tri[3 * f + (first + k) % 3], 3 * sizeof(double));
    }
    qsort(t, m->nt, sizeof *t, cmp_tri);
    return t;
}

static int same_triangles(const tl_mesh *a, const tl_mesh *b)
{
    if (a->nt != b->nt)
        return 0;
    coord_tri *ta = coord_tris(a), *tb = coord_tris(b);
    int same = a->nt == 0 || memcmp(ta, tb, a->nt * sizeof *ta) == 0;
    free(ta);
    free(tb);
    return same;
}

/*
 * Independent validator of a sorted, finalized streaming mesh (docs/architecture.md §6):
 * vertices non-decreasing along axis; each triangle right after its last
 * vertex (its newest corner is the newest vertex); every vertex used, and
 * finalized exactly once, right after its last triangle (only other
 * finalizations in between). @return NULL when valid, else what is wrong.
 */
static const char *validate_sorted_stream(const char *path, int axis)
{
    static char why[200];
    epsnet_reader *r = NULL;
    epsnet_error err;
    if (epsnet_reader_open(&r, path, NULL, &err))
        return "cannot open";
    size_t cap = 1024;
    uint64_t *last_use = malloc(cap * sizeof *last_use);
    char *fin = calloc(cap, 1);
    uint64_t nv = 0, nt = 0;
    double prev = -INFINITY;
    int vertex_since_tri = 0;
    const char *bad = NULL;
    epsnet_record rec;
    int rc;
    while (!bad && (rc = epsnet_reader_next(r, &rec, &err)) > 0) {
        if (rec.kind == EPSNET_REC_VERTEX) {
            if (rec.xyz[axis] < prev)
                bad = "vertices go back along the axis";
            prev = rec.xyz[axis];
            if (nv == cap) {
                cap *= 2;
                last_use = realloc(last_use, cap * sizeof *last_use);
                fin = realloc(fin, cap);
            }
            last_use[nv] = UINT64_MAX;
            fin[nv] = 0;
            nv++;
            vertex_since_tri = 1;
        } else if (rec.kind == EPSNET_REC_TRIANGLE) {
            uint64_t hi = rec.v[0];
            for (int k = 0; k < 3; k++) {
                if (rec.v[k] >= nv || fin[rec.v[k]])
                    bad = "a triangle uses a missing or finalized vertex";
                else
                    last_use[rec.v[k]] = nt;
                if (rec.v[k] > hi)
                    hi = rec.v[k];
            }
            if (hi != nv - 1) {
                snprintf(why, sizeof why, "triangle %llu does not follow its last vertex", (unsigned long long)nt);
                bad = why;
            }
            nt++;
            vertex_since_tri = 0;
        } else {
            uint64_t v = rec.v[0];
            if (v >= nv || fin[v])
                bad = "finalizes a missing or finalized vertex";
            else if (last_use[v] == UINT64_MAX)
                bad = "finalizes a vertex no triangle used";
            else if (last_use[v] != nt - 1 || vertex_since_tri)
                bad = "a vertex is finalized late";
            else
                fin[v] = 1;
        }
    }
    if (!bad && rc < 0)
        bad = "read error";
    for (uint64_t v = 0; !bad && v < nv; v++)
        if (!fin[v])
            bad = "a vertex is never finalized";
    epsnet_reader_close(&r);
    free(last_use);
    free(fin);
    return bad;
}

static int same_bytes(const char *p, const char *q)
{
    FILE *a = fopen(p, "rb"), *b = fopen(q, "rb");
    int same = a && b;
    while (same) {
        int x = fgetc(a), y = fgetc(b);
        same = x == y;
        if (x == EOF)
            break;
    }
    if (a)
        fclose(a);
    if (b)
        fclose(b);
    return same;
}

static void check_sort_of(const char *in, const char *name, uint64_t expect_unreferenced)
{
    char out[64];
    snprintf(out, sizeof out, "%s.smz", name);
    epsnet_sort_stats st;
    epsnet_error err;
    /* note: at 512K the in-core threshold is 32K vertices: every mesh here
     * but fandisk and rocker-arm goes through the external join */
    int rc = sort_with(in, tl_path(out), (uint64_t)512 << 10, -1, &st, &err);
    CHECK_EQ_INT(rc, 0);
    if (rc) {
        fprintf(stderr, "  %s: %s\n", name, epsnet_error_message(&err));
        return;
    }
    printf("  %-28s V %llu F %llu dropped %llu axis %c runs %llu temp %.1f MB width %llu\n", name,
           (unsigned long long)st.vertices, (unsigned long long)st.faces, (unsigned long long)st.unreferenced,
           "xyz"[st.axis], (unsigned long long)st.runs, (double)st.temp_bytes / 1e6,
           (unsigned long long)st.max_width);
    CHECK(st.runs > 1);
    CHECK_EQ_U64(st.unreferenced, expect_unreferenced);
    const char *bad = validate_sorted_stream(tl_path(out), st.axis);
    if (bad)
        fprintf(stderr, "  %s: %s\n", name, bad);
    CHECK(bad == NULL);
    tl_mesh a, b;
    CHECK_EQ_INT(tl_read_mesh(in, &a, &err), 0);
    CHECK_EQ_INT(tl_read_mesh(tl_path(out), &b, &err), 0);
    CHECK_EQ_U64(b.nv, a.nv - expect_unreferenced);
    CHECK_EQ_U64(st.vertices, a.nv);
    CHECK_EQ_U64(st.faces, a.nt);
    CHECK(same_triangles(&a, &b));
    CHECK_EQ_INT(b.info.sorted_axis, st.axis);
    tl_mesh_free(&a);
    tl_mesh_free(&b);
    /* a budget where ranks and last uses are looked up in memory instead of
     * joined externally: the same bytes */
    char out2[80];
    snprintf(out2, sizeof out2, "%s.big.smz", name);
    epsnet_sort_stats st2;
    CHECK_EQ_INT(sort_with(in, tl_path(out2), (uint64_t)256 << 20, -1, &st2, &err), 0);
    CHECK(st2.runs < st.runs);
    CHECK(same_bytes(tl_path(out), tl_path(out2)));
    remove(tl_path(out));
    remove(tl_path(out2));
}

/* ---- tests ---- */

/*
 * The whole output of a tiny mesh, exactly (x right, y up):
 *
 *   y
 *   1       v3-------v4          v2 = (5,5) is used by no triangle
 *          / \  t0  /
 *         / t1\    /            t0 = (v0, v4, v3)
 *   0   v1-----v0                t1 = (v1, v0, v3)
 *       0   1   2   3   x
 *
 * The bbox is 5 x 5 (v2 counts): a tie, so the earlier axis, x, wins.
 * Sorted along x: v1 v3 v0 v4 (ids 0 1 2 3); v2 is dropped. t1's last
 * corner is v0 (id 2), t0's is v4 (id 3). v1 is last used by t1.
 */
TEST(tiny_mesh_sorts_to_the_exact_expected_stream)
{
    const char *in = tl_write_str("tiny.obj", "v 2 0 0\nv 0 0 0\nv 5 5 0\nv 1 1 0\nv 3 1 0\n"
                                              "f 1 5 4\nf 2 1 4\n");
    epsnet_sort_stats st;
    epsnet_error err;
    CHECK_EQ_INT(sort_with(in, tl_path("tiny.smz"), 1 << 20, -1, &st, &err), 0);
    CHECK_EQ_INT(st.axis, 0);
    CHECK_EQ_U64(st.vertices, 5);
    CHECK_EQ_U64(st.faces, 2);
    CHECK_EQ_U64(st.unreferenced, 1);
    CHECK_EQ_U64(st.max_width, 3);
    static const struct { epsnet_record_kind kind; double x, y; uint64_t a, b, c; } want[] = {
        { EPSNET_REC_VERTEX, 0, 0, 0, 0, 0 },
        { EPSNET_REC_VERTEX, 1, 1, 0, 0, 0 },
        { EPSNET_REC_VERTEX, 2, 0, 0, 0, 0 },
        { EPSNET_REC_TRIANGLE, 0, 0, 0, 2, 1 },
        { EPSNET_REC_FINALIZE, 0, 0, 0, 0, 0 },
        { EPSNET_REC_VERTEX, 3, 1, 0, 0, 0 },
        { EPSNET_REC_TRIANGLE, 0, 0, 2, 3, 1 },
        { EPSNET_REC_FINALIZE, 0, 0, 2, 0, 0 },
        { EPSNET_REC_FINALIZE, 0, 0, 3, 0, 0 },
        { EPSNET_REC_FINALIZE, 0, 0, 1, 0, 0 },
    };
    epsnet_reader *r = NULL;
    CHECK_EQ_INT(epsnet_reader_open(&r, tl_path("tiny.smz"), NULL, &err), 0);
    epsnet_record rec;
    size_t i = 0;
    while (r && epsnet_reader_next(r, &rec, &err) > 0) {
        if (i < sizeof want / sizeof *want) {
            CHECK_EQ_INT(rec.kind, want[i].kind);
            if (rec.kind == EPSNET_REC_VERTEX) {
                CHECK(rec.xyz[0] == want[i].x && rec.xyz[1] == want[i].y && rec.xyz[2] == 0);
            } else if (rec.kind == EPSNET_REC_TRIANGLE) {
                CHECK_EQ_U64(rec.v[0], want[i].a);
                CHECK_EQ_U64(rec.v[1], want[i].b);
                CHECK_EQ_U64(rec.v[2], want[i].c);
            } else {
                CHECK_EQ_U64(rec.v[0], want[i].a);
            }
        }
        i++;
    }
    CHECK_EQ_U64(i, sizeof want / sizeof *want);
    CHECK_EQ_INT(epsnet_reader_info(r)->sorted_axis, 0);
    epsnet_reader_close(&r);
}

/* Equal coordinates keep their input order; an explicit axis is obeyed. */
TEST(ties_keep_input_order_and_axis_is_obeyed)
{
    /* three vertices at y = 0 in input order 2, 0, 1 of x; sorted along y
     * they stay 0 1 2 as given. */
    const char *in = tl_write_str("ties.obj", "v 2 0 0\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 4\nf 2 3 4\n");
    epsnet_sort_stats st;
    epsnet_error err;
    CHECK_EQ_INT(sort_with(in, tl_path("ties.smz"), 1 << 20, 1, &st, &err), 0);
    CHECK_EQ_INT(st.axis, 1);
    tl_mesh m;
    CHECK_EQ_INT(tl_read_mesh(tl_path("ties.smz"), &m, &err), 0);
    CHECK_EQ_U64(m.nv, 4);
    if (m.nv == 4) {
        CHECK(m.xyz[0] == 2 && m.xyz[3] == 0 && m.xyz[6] == 1 && m.xyz[10] == 1);
    }
    tl_mesh_free(&m);
    double lo[3] = { 0, 0, 0 }, hi[3] = { 1, 2, 2 };
    CHECK_EQ_INT(en_sort_longest_axis(lo, hi), 1);
    hi[2] = 2.5;
    CHECK_EQ_INT(en_sort_longest_axis(lo, hi), 2);
}

TEST(generated_shapes_keep_every_triangle_with_many_runs)
{
    static const char *const shapes[] = { "sphere", "torus", "bumpy", "terrain", "cad", "dimple" };
    for (size_t i = 0; i < sizeof shapes / sizeof *shapes; i++) {
        char name[64];
        snprintf(name, sizeof name, "shuffled_%s.ply", shapes[i]);
        epsnet_error err;
        CHECK_EQ_INT(tl_gen_file(tl_path(name), shapes[i], 80000, NAN, 1, 1, &err), 0);
        check_sort_of(tl_path(name), name, 0);
        remove(tl_path(name));
    }
}

/* From ../shared/data/README.md: the bunny has 1113 unused vertices. */
TEST(shared_meshes_keep_every_triangle)
{
    static const struct { const char *file; uint64_t unused; } meshes[] = {
        { "bun_zipper.ply.zst", 1113 },
        { "armadillo_decim100k.obj.zst", 0 },
        { "dragon_vrip_res2.ply.zst", 43 },
        { "fandisk.obj.zst", 0 },
        { "rocker-arm.obj.zst", 0 },
    };
    const char *dir = tl_shared_data();
    if (!dir) {
        printf("  (../shared/data not found: skipped)\n");
        return;
    }
    for (size_t i = 0; i < sizeof meshes / sizeof *meshes; i++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, meshes[i].file);
        if (!tl_exists(path)) {
            printf("  (%s missing: skipped)\n", meshes[i].file);
            continue;
        }
        check_sort_of(path, meshes[i].file, meshes[i].unused);
    }
}

/* Same input and options, same bytes; and the budget changes only how the
 * work is cut into runs, never the output. */
TEST(output_bytes_do_not_depend_on_the_budget)
{
    epsnet_error err;
    const char *in = tl_path("det.ply");
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 50000, NAN, 1, 1, &err), 0);
    epsnet_sort_stats a, b, c;
    /* 256K: external join (25K vertices is over the in-core threshold) */
    CHECK_EQ_INT(sort_with(in, tl_path("det1.smz"), 256 << 10, -1, &a, &err), 0);
    CHECK_EQ_INT(sort_with(in, tl_path("det2.smz"), 256 << 10, -1, &b, &err), 0);
    CHECK_EQ_INT(sort_with(in, tl_path("det3.smz"), (uint64_t)256 << 20, -1, &c, &err), 0);
    CHECK(a.runs > 1);
    CHECK_EQ_U64(c.runs, 0);
    CHECK(same_bytes(tl_path("det1.smz"), tl_path("det2.smz")));
    CHECK(same_bytes(tl_path("det1.smz"), tl_path("det3.smz")));
}

/* The in-memory path (the mesh and its arrays fit in half of the budget:
 * no temporary bytes at all) gives the external passes' bytes for any
 * thread count, and so does a read that outgrows it midway (an OBJ: no
 * counts announced) and moves what it has read to the spills; the
 * external passes too, whether their runs
 * are formed on a worker (threads > 1) or inline. */
TEST(in_memory_sort_gives_the_same_bytes_for_any_thread_count)
{
    epsnet_error err;
    const char *in = tl_path("whole.ply");
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 40000, NAN, 4, 1, &err), 0);
    /* 20K vertices and 40K faces need about 2.8M in memory: 4M is midway
     * short of that (twice it), 256M is plenty, 256K is the external path */
    static const struct { uint64_t mem; int threads; int whole; } runs[] = {
        { 256 << 10, 1, 0 }, { (uint64_t)256 << 20, 1, 1 }, { (uint64_t)256 << 20, 2, 1 },
        { (uint64_t)256 << 20, 3, 1 }, { 4 << 20, 2, 0 }, { 4 << 20, 1, 0 }, { 256 << 10, 2, 0 },
    };
    for (size_t i = 0; i < sizeof runs / sizeof *runs; i++) {
        epsnet_sort_stats st;
        CHECK_EQ_INT(sort_threads(in, tl_path(i ? "whole_b.smz" : "whole_a.smz"), runs[i].mem, runs[i].threads, -1,
                                  &st, &err),
                     0);
        CHECK_EQ_INT(st.temp_bytes == 0, runs[i].whole);
        if (i)
            CHECK(same_bytes(tl_path("whole_a.smz"), tl_path("whole_b.smz")));
    }
    /* an OBJ announces no counts: at 4M its read outgrows memory midway */
    const char *obj = tl_path("whole.obj");
    CHECK_EQ_INT(tl_gen_file(obj, "bumpy", 40000, NAN, 4, 1, &err), 0);
    epsnet_sort_stats st;
    CHECK_EQ_INT(sort_with(obj, tl_path("whole_c.smz"), (uint64_t)256 << 20, -1, &st, &err), 0);
    CHECK_EQ_U64(st.temp_bytes, 0);
    CHECK_EQ_INT(sort_with(obj, tl_path("whole_d.smz"), 4 << 20, -1, &st, &err), 0);
    CHECK(st.temp_bytes > 0);
    CHECK(same_bytes(tl_path("whole_c.smz"), tl_path("whole_d.smz")));
}

/* A 200 x 100 grid along x with a quality per vertex, a vertex no face
 * uses after every 37th, and a fan of 400 faces around a hub past the
 * grid's end, the last corner of all of them; digits: how the coordinates
 * are printed (6: floats, 17: doubles). */
static const char *fan_grid_ply(const char *name, int digits, uint64_t *unused)
{
    enum { W = 200, H = 100, FAN = 400 };
    const char *path = tl_path(name);
    FILE *f = fopen(path, "w");
    uint32_t *id = malloc(W * H * sizeof *id);
    uint64_t nv = 0, extra = 0;
    for (int k = 0; k < W * H; k++)
        extra += k % 37 == 36;
    fprintf(f, "ply\nformat ascii 1.0\nelement vertex %llu\nproperty double x\nproperty double y\n"
               "property double z\nproperty float quality\nelement face %d\n"
               "property list uchar int vertex_indices\nend_header\n",
            (unsigned long long)(W * H + extra + FAN + 1), 2 * (W - 1) * (H - 1) + FAN);
    for (int k = 0; k < W * H; k++) {
        double x = k % W + 1e-7 * (k % 7), y = 0.5 * (k / W), z = 0.01 * ((k * 7919) % 13);
        fprintf(f, "%.*g %.*g %.*g %d\n", digits, x, digits, y, digits, z, k % 251);
        id[k] = (uint32_t)nv++;
        if (k % 37 == 36) /* used by no face */
            fprintf(f, "%.*g %.*g 3 %d\n", digits, x + 0.25, digits, y + 0.25, k % 5), nv++;
    }
    for (int i = 0; i < FAN; i++) {
        double a = 6.283185307179586 * i / FAN;
        fprintf(f, "%.*g %.*g %.*g %d\n", digits, 230 + 20 * cos(a), digits, 25 + 20 * sin(a), digits, -1.0, i);
    }
    fprintf(f, "300 25 -1 7\n"); /* the hub: the largest x, so every fan face's last corner */
    for (int y = 0; y + 1 < H; y++)
        for (int x = 0; x + 1 < W; x++) {
            uint32_t a = id[y * W + x], b = id[y * W + x + 1], c = id[(y + 1) * W + x], d = id[(y + 1) * W + x + 1];
            fprintf(f, "3 %u %u %u\n3 %u %u %u\n", a, b, d, a, d, c);
        }
    for (int i = 0; i < FAN; i++)
        fprintf(f, "3 %llu %llu %llu\n", (unsigned long long)(nv + FAN), (unsigned long long)(nv + i),
                (unsigned long long)(nv + (i + 1) % FAN));
    fclose(f);
    free(id);
    *unused = extra;
    return path;
}

/* Pass 6 in blocks on the workers (the whole path, and the external one
 * with the last uses in memory) gives the live map's records (the external
 * path without them): the same bytes, the same unused vertices left out
 * and the same width, for any thread count, with attributes, with vertices
 * no face uses, with float and double coordinates, and with a group of
 * 400 faces sharing their last corner. */
TEST(pass_6_in_blocks_gives_the_live_maps_stream)
{
    static const struct { uint64_t mem; int threads; } runs[] = {
        { 256 << 10, 1 },         /* external, last uses in a sorter: the live map */
        { (uint64_t)256 << 20, 1 }, { (uint64_t)256 << 20, 2 }, { (uint64_t)256 << 20, 3 }, /* whole */
        { 4 << 20, 1 }, { 4 << 20, 2 }, { 4 << 20, 3 }, /* external, last uses in memory */
    };
    static const int digits[2] = { 6, 17 };
    for (int d = 0; d < 2; d++) {
        uint64_t unused = 0;
        char in[512]; /* tl_path's buffers rotate */
        snprintf(in, sizeof in, "%s", fan_grid_ply(d ? "fan17.ply" : "fan6.ply", digits[d], &unused));
        epsnet_sort_stats first = { 0 };
        for (size_t i = 0; i < sizeof runs / sizeof *runs; i++) {
            epsnet_sort_stats st;
            epsnet_error err;
            CHECK_EQ_INT(sort_threads(in, tl_path(i ? "fan_b.smz" : "fan_a.smz"), runs[i].mem, runs[i].threads, 0, &st,
                                      &err),
                         0);
            CHECK_EQ_U64(st.unreferenced, unused);
            CHECK_EQ_INT(st.temp_bytes == 0, runs[i].mem > (4 << 20));
            if (i == 0) {
                first = st;
                continue;
            }
            CHECK_EQ_U64(st.max_width, first.max_width);
            CHECK(same_bytes(tl_path("fan_a.smz"), tl_path("fan_b.smz")));
        }
        CHECK(first.max_width > 400); /* the fan's ring is live until the hub */
    }
}

typedef struct record_list {
    epsnet_record *r;
    size_t n, cap;
} record_list;

static int collect_records(void *opaque, const epsnet_record *recs, size_t n, epsnet_error *err)
{
    (void)err;
    record_list *l = opaque;
    for (size_t i = 0; i < n; i++) {
        if (l->n == l->cap) {
            l->cap = l->cap ? 2 * l->cap : 1024;
            l->r = realloc(l->r, l->cap * sizeof *l->r);
        }
        l->r[l->n++] = recs[i];
    }
    return 0;
}

static int collect_record(void *opaque, epsnet_record **recs, size_t *cap, size_t n, epsnet_error *err)
{
    (void)cap;
    return collect_records(opaque, *recs, n, err);
}

static int collect_one(void *opaque, const epsnet_record *rec, epsnet_error *err)
{
    return collect_records(opaque, rec, 1, err);
}

/* The sort as a stage (en_sort_emit) hands over exactly the records that
 * its .smz gives back: an OBJ read as float32 (its first 64K look like
 * floats) with a longer coordinate later gets that coordinate as float32. */
TEST(emitted_records_are_those_of_the_sorted_file)
{
    const char *obj = tl_path("late.obj");
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(obj, "bumpy", 20000, NAN, 3, 1, &err), 0);
    size_t n;
    char *text = (char *)tl_read_file(obj, &n);
    CHECK(text != NULL && n > 300000);
    char *v = strstr(text + 200000, "\nv ");
    CHECK(v != NULL);
    FILE *f = fopen(obj, "wb");
    fwrite(text, 1, (size_t)(v - text), f);
    fputs("\nv 0.1000000000000000055511151231257827 0.2 0.3", f);
    char *eol = strchr(v + 1, '\n');
    fwrite(eol, 1, n - (size_t)(eol - text), f);
    fclose(f);
    free(text);
    const char *smz = tl_path("late.smz");
    CHECK_EQ_INT(sort_with(obj, smz, (uint64_t)64 << 20, -1, NULL, &err), 0);
    record_list got = { 0 };
    en_sort *s = NULL;
    CHECK_EQ_INT(en_sort_open(&s, obj, smz, NULL, 1, NULL, NULL, &err), 0);
    CHECK_EQ_INT(en_sort_emit(s, collect_record, &got, &err), 0);
    en_sort_close(&s, NULL);
    epsnet_reader *r = NULL;
    CHECK_EQ_INT(epsnet_reader_open(&r, smz, NULL, &err), 0);
    epsnet_record rec;
    size_t i = 0, differ = 0;
    int rc;
    while ((rc = epsnet_reader_next(r, &rec, &err)) == 1 && i < got.n) {
        const epsnet_record *g = &got.r[i++];
        if (g->kind != rec.kind || (rec.kind == EPSNET_REC_VERTEX && memcmp(g->xyz, rec.xyz, sizeof rec.xyz)) ||
            (rec.kind != EPSNET_REC_VERTEX && g->v[0] != rec.v[0]) ||
            (rec.kind == EPSNET_REC_TRIANGLE && (g->v[1] != rec.v[1] || g->v[2] != rec.v[2])))
            differ++;
    }
    CHECK_EQ_INT(rc, 0);
    CHECK_EQ_U64(i, got.n);
    CHECK_EQ_U64(differ, 0);
    epsnet_reader_close(&r);
    free(got.r);
}

/* ---- windows of the sorted stream (en_sort_window) ---- */

static uint32_t test_stretches(uint64_t total, uint64_t *lo, uint64_t *hi)
{
    lo[0] = total / 10, hi[0] = total / 10 + total / 8;
    lo[1] = total / 2 - 1000, hi[1] = total / 2 + 1000;
    lo[2] = total / 2 + 900, hi[2] = total / 2 + 1500; /* overlaps the one before: merged */
    lo[3] = total - 3000, hi[3] = total + 50;        /* past the end: clamped */
    return 4;
}

static int window_records(en_sort *s, uint64_t lo, uint64_t hi, record_list *l, uint64_t *pushed, uint64_t *cut,
                          epsnet_error *err)
{
    en_stage into = { collect_one, NULL, l };
    return en_sort_window(s, lo, hi, 7, &into, pushed, cut, err);
}

/* A window is a stream of its own: its vertices numbered from base in
 * order, each face after its corners, each vertex finalized once, after
 * its last face. */
static int window_is_a_stream(const record_list *l, uint64_t pushed)
{
    uint8_t *state = calloc(pushed + 1, 1); /* 1 seen, 2 finalized */
    uint64_t next = 7;
    int ok = state != NULL;
    for (size_t i = 0; ok && i < l->n; i++) {
        const epsnet_record *r = &l->r[i];
        if (r->kind == EPSNET_REC_VERTEX) {
            ok = next < 7 + pushed;
            if (ok)
                state[next++ - 7] = 1;
        } else {
            for (int k = 0; ok && k < (r->kind == EPSNET_REC_TRIANGLE ? 3 : 1); k++)
                ok = r->v[k] >= 7 && r->v[k] < next && state[r->v[k] - 7] == 1;
            if (ok && r->kind == EPSNET_REC_FINALIZE)
                state[r->v[0] - 7] = 2;
        }
    }
    for (uint64_t v = 0; ok && v < pushed; v++)
        ok = state[v] == 2;
    free(state);
    return ok && next == 7 + pushed;
}

/* A size's pricing windows (docs/architecture.md §7) from an external
 * sort: the stretches it was asked to keep give, window for window, the
 * records of the whole path's arrays (stream order, the same numbering,
 * the same cut counts), with or without the in-core ranks; a window
 * outside them is refused, not guessed; and pass 6 afterwards still gives
 * the sorted stream. */
TEST(windows_from_kept_stretches_are_those_of_the_arrays)
{
    epsnet_error err;
    const char *in = tl_path("win.ply");
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 40000, NAN, 4, 1, &err), 0);
    static const uint64_t mems[3] = { (uint64_t)256 << 20, 4 << 20, 256 << 10 }; /* whole, in-core ranks, external */
    en_sort *s[3] = { NULL };
    record_list emitted[3] = { { 0 } };
    uint64_t total = 0;
    for (int i = 0; i < 3; i++) {
        epsnet_sort_settings set;
        epsnet_sort_default_settings(&set);
        set.mem = mems[i];
        set.tmpdir = tl_tmpdir();
        CHECK_EQ_INT(en_sort_open(&s[i], in, tl_path("win.smz"), &set, 0, test_stretches, NULL, &err), 0);
        uint64_t ranks = 0;
        CHECK(en_sort_windowed(s[i], &ranks));
        CHECK(ranks > 10000);
        total = ranks;
    }
    const uint64_t win[][2] = {
        { total / 10, total / 10 + 500 }, { total / 10 + 100, total / 10 + total / 8 },
        { total / 2 - 1000, total / 2 + 1500 }, { total - 3000, total },
    };
    for (size_t w = 0; w < sizeof win / sizeof *win; w++) {
        record_list got[3] = { { 0 } };
        uint64_t pushed[3] = { 0 }, cut[3] = { 0 };
        for (int i = 0; i < 3; i++) {
            CHECK_EQ_INT(window_records(s[i], win[w][0], win[w][1], &got[i], &pushed[i], &cut[i], &err), 0);
            uint64_t counted = 0, counted_cut = 0;
            CHECK_EQ_INT(en_sort_window(s[i], win[w][0], win[w][1], 0, NULL, &counted, &counted_cut, &err), 0);
            CHECK_EQ_U64(counted, pushed[i]);
            CHECK_EQ_U64(counted_cut, cut[i]);
            /* the count alone, as the windows' placing asks it (twice: the
             * second from what the first kept) */
            for (int again = 0; again < 2; again++) {
                counted = 0;
                CHECK_EQ_INT(en_sort_window(s[i], win[w][0], win[w][1], 0, NULL, &counted, NULL, &err), 0);
                CHECK_EQ_U64(counted, pushed[i]);
            }
        }
        CHECK(pushed[0] > 0 && cut[0] > 0 && got[0].n > pushed[0]);
        CHECK(window_is_a_stream(&got[0], pushed[0]));
        for (int i = 1; i < 3; i++) {
            CHECK_EQ_U64(pushed[i], pushed[0]);
            CHECK_EQ_U64(cut[i], cut[0]);
            CHECK_EQ_U64(got[i].n, got[0].n);
            size_t differ = 0;
            for (size_t k = 0; k < got[0].n && k < got[i].n; k++) {
                const epsnet_record *a = &got[0].r[k], *b = &got[i].r[k];
                differ += a->kind != b->kind || memcmp(a->v, b->v, sizeof a->v) ||
                          (a->kind == EPSNET_REC_VERTEX && memcmp(a->xyz, b->xyz, sizeof a->xyz));
            }
            CHECK_EQ_U64(differ, 0);
        }
        for (int i = 0; i < 3; i++)
            free(got[i].r);
    }
    /* outside every stretch: the arrays have it, the external sorts refuse it */
    uint64_t pushed = 0;
    CHECK_EQ_INT(en_sort_window(s[0], 0, 100, 0, NULL, &pushed, NULL, &err), 0);
    CHECK(pushed > 0);
    for (int i = 1; i < 3; i++)
        CHECK_EQ_INT(en_sort_window(s[i], 0, 100, 0, NULL, &pushed, NULL, &err), EPSNET_EFORMAT);
    for (int i = 0; i < 3; i++) {
        CHECK_EQ_INT(en_sort_emit(s[i], collect_record, &emitted[i], &err), 0);
        en_sort_close(&s[i], NULL);
    }
    for (int i = 1; i < 3; i++) {
        CHECK_EQ_U64(emitted[i].n, emitted[0].n);
        size_t differ = 0;
        for (size_t k = 0; k < emitted[0].n && k < emitted[i].n; k++)
            differ += emitted[0].r[k].kind != emitted[i].r[k].kind ||
                      memcmp(emitted[0].r[k].v, emitted[i].r[k].v, sizeof emitted[0].r[k].v);
        CHECK_EQ_U64(differ, 0);
    }
    for (int i = 0; i < 3; i++)
        free(emitted[i].r);
}

/* docs/architecture.md §12: a stream that never finalizes hits the memory budget with a
 * clear error, not an out-of-memory kill. */
TEST(never_finalizing_stream_hits_the_budget)
{
    epsnet_error err;
    const char *in = tl_path("nofin.sma");
    FILE *f = fopen(in, "w");
    for (int i = 0; i < 200000; i++)
        fprintf(f, "v %d %d 0\n", i % 500, i / 500);
    for (int i = 1; i + 2 <= 200000; i += 3)
        fprintf(f, "f %d %d %d\n", i, i + 1, i + 2);
    fclose(f);
    epsnet_sort_stats st;
    int rc = sort_with(in, tl_path("nofin.smz"), 1 << 20, -1, &st, &err);
    CHECK_EQ_INT(rc, EPSNET_ELIMIT);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "memory budget");
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "finalize");
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "nofin.sma");
    CHECK(!tl_exists(tl_path("nofin.smz")));
}

/* The output's live set must fit the budget too: a CAD part sorted along z
 * keeps about 1600 vertices live at 60K faces, over half of 256K. */
TEST(an_output_wider_than_the_budget_is_a_clear_error)
{
    epsnet_error err;
    const char *in = tl_path("wide.ply");
    CHECK_EQ_INT(tl_gen_file(in, "cad", 60000, NAN, 1, 1, &err), 0);
    epsnet_sort_stats st;
    CHECK_EQ_INT(sort_with(in, tl_path("wide.smz"), 256 << 10, -1, &st, &err), EPSNET_ELIMIT);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "vertices live at once");
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "raise --mem");
    CHECK(!tl_exists(tl_path("wide.smz")));
}

TEST(empty_mesh_sorts_to_an_empty_stream)
{
    const char *in = tl_write_str("empty.obj", "# nothing\n");
    epsnet_sort_stats st;
    epsnet_error err;
    CHECK_EQ_INT(sort_with(in, tl_path("empty.smz"), 1 << 20, -1, &st, &err), 0);
    CHECK_EQ_U64(st.vertices, 0);
    CHECK_EQ_U64(st.faces, 0);
    tl_mesh m;
    CHECK_EQ_INT(tl_read_mesh(tl_path("empty.smz"), &m, &err), 0);
    CHECK_EQ_U64(m.nv, 0);
    CHECK_EQ_U64(m.nt, 0);
    tl_mesh_free(&m);
}

/* Degenerate and duplicate faces are legal input (docs/architecture.md §5): kept as they
 * are, and a vertex repeated in one face is finalized once. */
TEST(degenerate_and_duplicate_faces_are_kept)
{
    const char *in = tl_write_str("degen.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 2 0\n"
                                               "f 1 2 3\nf 1 2 3\nf 4 4 2\nf 3 3 3\n");
    epsnet_sort_stats st;
    epsnet_error err;
    CHECK_EQ_INT(sort_with(in, tl_path("degen.sma"), 1 << 20, -1, &st, &err), 0);
    const char *bad = validate_sorted_stream(tl_path("degen.sma"), st.axis);
    CHECK(bad == NULL);
    tl_mesh a, b;
    CHECK_EQ_INT(tl_read_mesh(in, &a, &err), 0);
    CHECK_EQ_INT(tl_read_mesh(tl_path("degen.sma"), &b, &err), 0);
    CHECK_EQ_U64(b.nt, 4);
    CHECK(same_triangles(&a, &b));
    tl_mesh_free(&a);
    tl_mesh_free(&b);
}

/* Temporary runs are anonymous: nothing is left in --tmpdir, on success or
 * failure. */
TEST(no_temporary_files_are_left)
{
    epsnet_error err;
    const char *in = tl_path("tmpcheck.ply");
    CHECK_EQ_INT(tl_gen_file(in, "sphere", 20000, NAN, 1, 1, &err), 0);
    char dir[512];
    snprintf(dir, sizeof dir, "%s/runs", tl_tmpdir());
    mkdir(dir, 0700);
    epsnet_sort_settings s;
    epsnet_sort_default_settings(&s);
    s.mem = 1 << 20;
    s.tmpdir = dir;
    epsnet_sort_stats st;
    CHECK_EQ_INT(epsnet_sort_file(in, tl_path("tmpcheck.smz"), &s, &st, &err), 0);
    CHECK(st.runs > 1 && st.temp_bytes > 0);
    CHECK_EQ_INT(epsnet_sort_file(in, "/nonexistent-dir/x.smz", &s, &st, &err), EPSNET_EIO);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "test -z \"$(ls -A '%s')\"", dir);
    CHECK_EQ_INT(system(cmd), 0);
}

/* Items (key | payload << 32, index): only the low 32 bits are key, so
 * items with equal keys leave in the order they were added, whatever their
 * payload, through many runs and their merges (a small budget: merges
 * in levels), with runs formed inline and on a worker; and under a budget
 * whose buffers hold several parts of RUN_PART_MIN items, with a full
 * buffer cut in two or three runs sorted side by side (threads 2, 3),
 * whose runs then outnumber the one-worker sort's. */
TEST(extsort_key_mask_keeps_equal_keys_in_added_order)
{
    epsnet_error err;
    static const struct { uint64_t mem, n; int threads; } runs[] = {
        { 64 << 10, 50000, 0 }, { 64 << 10, 50000, 1 },
        { 12 << 20, 600000, 1 }, { 12 << 20, 600000, 2 }, { 12 << 20, 600000, 3 },
    };
    uint64_t runs_one = 0;
    for (size_t r = 0; r < sizeof runs / sizeof *runs; r++) {
        int threads = runs[r].threads;
        en_extsort_config c = { .item_words = 2, .key_words = 1, .key_mask = UINT32_MAX, .mem = runs[r].mem,
                                .tmpdir = tl_tmpdir(), .owner = "mask", .threads = threads };
        en_extsort *es = NULL;
        CHECK_EQ_INT(en_extsort_open(&es, &c, &err), 0);
        const uint64_t n = runs[r].n;
        for (uint64_t i = 0; i < n; i++) {
            uint64_t payload = (i * 2654435761u) & 0xffff; /* unordered high bits */
            uint64_t item[2] = { (i * 7919 % 97) | payload << 32, i };
            CHECK_EQ_INT(en_extsort_add(es, item, &err), 0);
        }
        CHECK_EQ_INT(en_extsort_finish(es, &err), 0);
        CHECK(en_extsort_runs(es) > 1);
        if (threads == 1)
            runs_one = en_extsort_runs(es); /* the big budget's comes last */
        if (threads > 1)
            CHECK(en_extsort_runs(es) > runs_one);
        uint64_t item[2], prev_key = 0, prev_i = 0, got = 0;
        int ok = 1;
        while (en_extsort_next(es, item, &err) > 0) {
            uint64_t key = item[0] & UINT32_MAX;
            ok &= key == item[1] * 7919 % 97 && item[0] >> 32 == ((item[1] * 2654435761u) & 0xffff);
            if (got)
                ok &= key > prev_key || (key == prev_key && item[1] > prev_i);
            prev_key = key;
            prev_i = item[1];
            got++;
        }
        CHECK(ok);
        CHECK_EQ_U64(got, n);
        en_extsort_close(&es);
    }
}

int main(void)
{
    RUN(tiny_mesh_sorts_to_the_exact_expected_stream);
    RUN(ties_keep_input_order_and_axis_is_obeyed);
    RUN(generated_shapes_keep_every_triangle_with_many_runs);
    RUN(shared_meshes_keep_every_triangle);
    RUN(output_bytes_do_not_depend_on_the_budget);
    RUN(in_memory_sort_gives_the_same_bytes_for_any_thread_count);
    RUN(pass_6_in_blocks_gives_the_live_maps_stream);
    RUN(emitted_records_are_those_of_the_sorted_file);
    RUN(windows_from_kept_stretches_are_those_of_the_arrays);
    RUN(never_finalizing_stream_hits_the_budget);
    RUN(an_output_wider_than_the_budget_is_a_clear_error);
    RUN(empty_mesh_sorts_to_an_empty_stream);
    RUN(degenerate_and_duplicate_faces_are_kept);
    RUN(no_temporary_files_are_left);
    RUN(extsort_key_mask_keeps_equal_keys_in_added_order);
    tl_cleanup();
    return tl_finish();
}
