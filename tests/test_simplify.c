/*
 * Shape approximation guarantees (docs/method.md §9, issue 4):
 * output vertices are input vertices bit for bit, every sample survives a
 * single pass, topology is kept, no face flips, non-manifold parts pass
 * through, and the non-samples left are counted exactly.
 */
#include "core/collapse.h"
#include "sample_util.h"

typedef struct topo {
    int64_t euler;
    uint64_t components, boundary_loops, boundary_edges, nonmanifold_edges, inconsistent_edges;
} topo;

static int cmp_u64x2(const void *a, const void *b)
{
    const uint64_t *x = a, *y = b;
    if (x[0] != y[0])
        return x[0] < y[0] ? -1 : 1;
    return (x[1] > y[1]) - (x[1] < y[1]);
}

static uint64_t find(uint64_t *p, uint64_t x)
{
    while (p[x] != x)
        x = p[x] = p[p[x]];
    return x;
}

/* V - E + F over referenced vertices; components by union-find over faces;
 * boundary loops by union-find over boundary edges. */
static topo topology(const tl_mesh *m)
{
    topo t = { 0 };
    uint64_t ne = m->nt * 3;
    uint64_t *e = malloc(ne * 3 * sizeof *e + 8); /* (min, max, directed a<b ? 1 : 0) */
    uint64_t *parent = malloc((m->nv + 1) * sizeof *parent), *bparent = malloc((m->nv + 1) * sizeof *bparent);
    char *used = calloc(m->nv + 1, 1), *onb = calloc(m->nv + 1, 1);
    for (uint64_t v = 0; v < m->nv; v++)
        parent[v] = bparent[v] = v;
    for (uint64_t f = 0; f < m->nt; f++)
        for (int k = 0; k < 3; k++) {
            uint64_t a = m->tri[3 * f + k], b = m->tri[3 * f + (k + 1) % 3];
            used[a] = 1;
            e[3 * (3 * f + k)] = a < b ? a : b;
            e[3 * (3 * f + k) + 1] = a < b ? b : a;
            e[3 * (3 * f + k) + 2] = a < b;
            parent[find(parent, a)] = find(parent, b);
        }
    /* sort by (min,max); direction rides along as a third word */
    uint64_t *pairs = malloc(ne * 2 * sizeof *pairs + 8);
    for (uint64_t i = 0; i < ne; i++) {
        pairs[2 * i] = e[3 * i] << 32 | e[3 * i + 1];
        pairs[2 * i + 1] = e[3 * i + 2];
    }
    qsort(pairs, ne, 2 * sizeof *pairs, cmp_u64x2);
    uint64_t nedges = 0;
    for (uint64_t i = 0; i < ne;) {
        uint64_t j = i, fwd = 0;
        while (j < ne && pairs[2 * j] == pairs[2 * i]) {
            fwd += pairs[2 * j + 1];
            j++;
        }
        uint64_t n = j - i, a = pairs[2 * i] >> 32, b = pairs[2 * i] & 0xffffffffu;
        nedges++;
        if (n == 1) {
            t.boundary_edges++;
            onb[a] = onb[b] = 1;
            bparent[find(bparent, a)] = find(bparent, b);
        } else if (n > 2) {
            t.nonmanifold_edges++;
        } else if (fwd != 1) {
            t.inconsistent_edges++;
        }
        i = j;
    }
    uint64_t nv = 0;
    for (uint64_t v = 0; v < m->nv; v++) {
        if (!used[v])
            continue;
        nv++;
        t.components += find(parent, v) == v;
        t.boundary_loops += onb[v] && find(bparent, v) == v;
    }
    t.euler = (int64_t)nv - (int64_t)nedges + (int64_t)m->nt;
    free(e);
    free(pairs);
    free(parent);
    free(bparent);
    free(used);
    free(onb);
    return t;
}

static int cmp_xyz(const void *a, const void *b)
{
    return memcmp(a, b, 3 * sizeof(double));
}

/* Is p (3 doubles) among the sorted points? */
static int has_point(const double *sorted, uint64_t n, const double *p)
{
    return bsearch(p, sorted, n, 3 * sizeof(double), cmp_xyz) != NULL;
}

static double *sorted_points(const tl_mesh *m)
{
    double *p = malloc(m->nv * 3 * sizeof *p + 8);
    memcpy(p, m->xyz, m->nv * 3 * sizeof *p);
    qsort(p, m->nv, 3 * sizeof *p, cmp_xyz);
    return p;
}

typedef struct run {
    tl_mesh in, out;
    epsnet_stats stats;
} run;

static int simplify(const char *in_path, const char *name, int level, int passes, run *r)
{
    epsnet_settings st;
    epsnet_default_settings(&st);
    st.level = level;
    st.passes = passes;
    epsnet_error err;
    epsnet_context *ctx = NULL;
    const char *out = tl_path(name);
    int rc = epsnet_context_new(&ctx, &st, &err);
    if (rc == 0)
        rc = epsnet_simplify_file(ctx, in_path, out, &err);
    if (rc == 0)
        r->stats = *epsnet_context_stats(ctx);
    epsnet_context_free(&ctx);
    if (rc == 0)
        rc = tl_read_mesh(in_path, &r->in, &err);
    if (rc == 0)
        rc = tl_read_mesh(out, &r->out, &err);
    if (rc)
        fprintf(stderr, "  simplify %s: %s\n", in_path, epsnet_error_message(&err));
    return rc;
}

static const char *generate(const char *shape, uint64_t faces, uint64_t seed)
{
    char name[128];
    snprintf(name, sizeof name, "%s_%llu.ply", shape, (unsigned long long)faces);
    const char *path = tl_path(name);
    epsnet_error err;
    return tl_gen_file(path, shape, faces, NAN, seed, 0, &err) ? NULL : path;
}

/* The guarantees common to every input. */
static void check_guarantees(const run *r, const char *what, int closed_manifold_input)
{
    double *in_pts = sorted_points(&r->in);
    uint64_t missing = 0;
    for (uint64_t v = 0; v < r->out.nv; v++)
        missing += !has_point(in_pts, r->in.nv, r->out.xyz + 3 * v);
    if (missing)
        fprintf(stderr, "  %s: %llu output vertices are not input vertices\n", what, (unsigned long long)missing);
    CHECK_EQ_U64(missing, 0);
    CHECK(r->out.nt < r->in.nt);
    CHECK_EQ_U64(r->out.nv, r->stats.output_vertices);
    CHECK_EQ_U64(r->out.nt, r->stats.output_faces);
    topo ti = topology(&r->in), to = topology(&r->out);
    CHECK_EQ_U64(to.inconsistent_edges, ti.inconsistent_edges);
    if (closed_manifold_input) {
        CHECK_EQ_INT(to.euler, ti.euler);
        CHECK_EQ_U64(to.components, ti.components);
        CHECK_EQ_U64(to.boundary_loops, ti.boundary_loops);
        CHECK_EQ_U64(to.boundary_edges, 0);
        CHECK_EQ_U64(to.nonmanifold_edges, 0);
    } else {
        CHECK_EQ_U64(to.boundary_loops, ti.boundary_loops);
        CHECK_EQ_U64(to.components, ti.components);
    }
    free(in_pts);
}

/* Samples of the input (one pass, the context's level and rotation). */
static void check_samples_survive(const char *in_path, const run *r, int level, const char *what)
{
    en_slab s;
    epsnet_reader *rd = NULL;
    epsnet_error err;
    en_slab_init(&s);
    CHECK_EQ_INT(epsnet_reader_open(&rd, in_path, NULL, &err), 0);
    CHECK_EQ_INT(en_slab_read_all(&s, rd, in_path, &err), 0);
    epsnet_reader_close(&rd);
    gauss_rotation rot;
    gauss_rotation_default(&rot);
    gauss_sphere g;
    gauss_init_level(&g, level, &rot);
    classified c;
    classify_all(&g, &s, &c);
    double *out_pts = sorted_points(&r->out);
    uint64_t samples = 0, lost = 0;
    for (uint32_t v = 0; v < s.nv; v++)
        if (c.vclass[v] & EN_C_SAMPLE) {
            samples++;
            lost += !has_point(out_pts, r->out.nv, s.pos + 3 * v);
        }
    if (lost)
        fprintf(stderr, "  %s: %llu of %llu samples lost\n", what, (unsigned long long)lost,
                (unsigned long long)samples);
    CHECK_EQ_U64(lost, 0);
    CHECK_EQ_U64(samples, r->stats.samples);
    /* Everything left is a sample or a counted non-sample. */
    CHECK_EQ_U64(r->out.nv, r->stats.samples + r->stats.remaining_nonsamples);
    free(out_pts);
    classified_free(&c);
    en_slab_free(&s);
}

/* No face flips: each output face's normal agrees with the input face whose
 * centroid is nearest its own centroid (brute force: meshes are small). */
static void check_no_flips(const run *r, const char *what)
{
    uint64_t flipped = 0;
    for (uint64_t f = 0; f < r->out.nt; f++) {
        const uint64_t *t = r->out.tri + 3 * f;
        double c[3], n[3];
        const double *a = r->out.xyz + 3 * t[0], *b = r->out.xyz + 3 * t[1], *d = r->out.xyz + 3 * t[2];
        for (int k = 0; k < 3; k++)
            c[k] = (a[k] + b[k] + d[k]) / 3;
        n[0] = (b[1] - a[1]) * (d[2] - a[2]) - (b[2] - a[2]) * (d[1] - a[1]);
        n[1] = (b[2] - a[2]) * (d[0] - a[0]) - (b[0] - a[0]) * (d[2] - a[2]);
        n[2] = (b[0] - a[0]) * (d[1] - a[1]) - (b[1] - a[1]) * (d[0] - a[0]);
        double best = 1e300, bn[3] = { 0, 0, 0 };
        for (uint64_t g = 0; g < r->in.nt; g++) {
            const uint64_t *u = r->in.tri + 3 * g;
            const double *p = r->in.xyz + 3 * u[0], *q = r->in.xyz + 3 * u[1], *s = r->in.xyz + 3 * u[2];
            double dd = 0;
            for (int k = 0; k < 3; k++) {
                double x = (p[k] + q[k] + s[k]) / 3 - c[k];
                dd += x * x;
            }
            if (dd < best) {
                best = dd;
                bn[0] = (q[1] - p[1]) * (s[2] - p[2]) - (q[2] - p[2]) * (s[1] - p[1]);
                bn[1] = (q[2] - p[2]) * (s[0] - p[0]) - (q[0] - p[0]) * (s[2] - p[2]);
                bn[2] = (q[0] - p[0]) * (s[1] - p[1]) - (q[1] - p[1]) * (s[0] - p[0]);
            }
        }
        flipped += n[0] * bn[0] + n[1] * bn[1] + n[2] * bn[2] < 0;
    }
    if (flipped)
        fprintf(stderr, "  %s: %llu of %llu faces flipped\n", what, (unsigned long long)flipped,
                (unsigned long long)r->out.nt);
    CHECK_EQ_U64(flipped, 0);
}

static void run_free(run *r)
{
    tl_mesh_free(&r->in);
    tl_mesh_free(&r->out);
}

TEST(generated_closed_shapes_keep_topology_samples_and_orientation)
{
    const char *shapes[] = { "sphere", "torus", "dimple", "bumpy", "cad", "roundcube" };
    for (size_t i = 0; i < sizeof shapes / sizeof *shapes; i++)
        for (int level = 2; level <= 3; level++) {
            const char *in = generate(shapes[i], 8000, 3);
            CHECK(in != NULL);
            if (!in)
                continue;
            run r = { 0 };
            char name[64];
            snprintf(name, sizeof name, "out_%s_%d.ply", shapes[i], level);
            if (simplify(in, name, level, 1, &r) == 0) {
                check_guarantees(&r, shapes[i], 1);
                check_samples_survive(in, &r, level, shapes[i]);
                check_no_flips(&r, shapes[i]);
                printf("  %-9s level %d: %llu -> %llu faces, %llu samples, %llu non-samples left\n", shapes[i],
                       level, (unsigned long long)r.in.nt, (unsigned long long)r.out.nt,
                       (unsigned long long)r.stats.samples, (unsigned long long)r.stats.remaining_nonsamples);
            } else {
                CHECK(!"simplify failed");
            }
            run_free(&r);
        }
}

TEST(open_terrain_keeps_its_boundary)
{
    const char *in = generate("terrain", 8000, 2);
    run r = { 0 };
    CHECK(in && simplify(in, "out_terrain.ply", 3, 1, &r) == 0);
    check_guarantees(&r, "terrain", 0);
    check_samples_survive(in, &r, 3, "terrain");
    topo ti = topology(&r.in), to = topology(&r.out);
    CHECK_EQ_U64(to.boundary_edges, ti.boundary_edges); /* boundary vertices are locked */
    run_free(&r);
}

/* ε-net passes remove more, never break topology, and stop when stable. */
TEST(more_passes_remove_more_and_keep_topology)
{
    const char *in = generate("bumpy", 8000, 4);
    run one = { 0 }, many = { 0 };
    CHECK(in && simplify(in, "p1.ply", 3, 1, &one) == 0 && simplify(in, "p5.ply", 3, 5, &many) == 0);
    CHECK(many.out.nv <= one.out.nv);
    CHECK(many.stats.passes >= 2 && many.stats.passes <= 5);
    check_guarantees(&many, "bumpy passes", 1);
    printf("  bumpy: 1 pass %llu vertices, %llu passes %llu vertices\n", (unsigned long long)one.out.nv,
           (unsigned long long)many.stats.passes, (unsigned long long)many.out.nv);
    run_free(&one);
    run_free(&many);
}

TEST(same_input_gives_same_bytes)
{
    const char *in = generate("bumpy", 8000, 5);
    run a = { 0 }, b = { 0 };
    CHECK(in && simplify(in, "same_a.ply", 3, 2, &a) == 0 && simplify(in, "same_b.ply", 3, 2, &b) == 0);
    FILE *fa = fopen(tl_path("same_a.ply"), "rb"), *fb = fopen(tl_path("same_b.ply"), "rb");
    int same = fa && fb;
    while (same) {
        int x = fgetc(fa), y = fgetc(fb);
        same = x == y;
        if (x == EOF || y == EOF)
            break;
    }
    CHECK(same);
    if (fa)
        fclose(fa);
    if (fb)
        fclose(fb);
    run_free(&a);
    run_free(&b);
}

/* Real meshes: closed ones keep topology; the non-manifold dragon passes its
 * non-manifold edges through untouched. */
TEST(shared_data_meshes)
{
    const char *dir = tl_shared_data();
    if (!dir) {
        printf("  SKIP: ../shared/data not found\n");
        return;
    }
    const struct {
        const char *file;
        int closed;
    } meshes[] = {
        { "fandisk.obj.zst", 1 },
        { "rocker-arm.obj.zst", 1 },
        { "armadillo_decim100k.obj.zst", 1 },
        { "bun_zipper.ply.zst", 0 },
        { "dragon_vrip_res2.ply.zst", 0 },
    };
    for (size_t i = 0; i < sizeof meshes / sizeof *meshes; i++) {
        char path[1024], name[128];
        snprintf(path, sizeof path, "%s/%s", dir, meshes[i].file);
        snprintf(name, sizeof name, "shared_%zu.ply", i);
        run r = { 0 };
        if (simplify(path, name, 3, 1, &r)) {
            CHECK(!"simplify failed");
            continue;
        }
        check_guarantees(&r, meshes[i].file, meshes[i].closed);
        check_samples_survive(path, &r, 3, meshes[i].file);
        topo ti = topology(&r.in), to = topology(&r.out);
        if (!meshes[i].closed)
            CHECK_EQ_U64(to.nonmanifold_edges, ti.nonmanifold_edges);
        printf("  %-28s %llu -> %llu faces, nm edges %llu -> %llu, %llu non-samples left\n", meshes[i].file,
               (unsigned long long)r.in.nt, (unsigned long long)r.out.nt, (unsigned long long)ti.nonmanifold_edges,
               (unsigned long long)to.nonmanifold_edges, (unsigned long long)r.stats.remaining_nonsamples);
        run_free(&r);
    }
}

/* The normal bound is against each face's *input* normal, so however many
 * collapses re-corner a face, it never ends up turned further than the
 * bound (a per-collapse bound lets turns add up into folds). */
TEST(no_face_turns_past_the_bound_from_its_input_normal)
{
    const double bounds[] = { 30.0, 60.0 };
    en_slab s;
    if (gen_slab("bumpy", 60000, NAN, 9, 0, &s)) {
        CHECK(!"generation failed");
        return;
    }
    gauss_rotation r;
    gauss_rotation_default(&r);
    gauss_sphere g;
    gauss_init_level(&g, 3, &r);
    classified c;
    classify_all(&g, &s, &c);
    uint8_t *removable = malloc(s.nv + 1), *fa = malloc(s.nt + 1), *va = malloc(s.nv + 1);
    uint32_t *tri = malloc(3 * sizeof *tri * (s.nt + 1));
    en_quadric *q = malloc(sizeof *q * (s.nv + 1));
    double *ref = malloc(3 * sizeof *ref * (s.nt + 1));
    for (uint32_t v = 0; v < s.nv; v++)
        removable[v] = !(c.vclass[v] & EN_C_SAMPLE) && !(s.vflags[v] & (EN_V_BOUNDARY | EN_V_NONMANIFOLD));
    for (size_t b = 0; b < 2; b++) {
        en_quadrics_from_faces(&s, q, ref);
        en_collapse_settings cs = { .max_normal_dev_deg = bounds[b] };
        en_collapse_counts cc;
        CHECK_EQ_INT(en_collapse_slab(&s, removable, q, ref, &cs, fa, va, tri, &cc, NULL), 0);
        CHECK(cc.collapses > s.nv / 2);
        double worst = 0;
        for (uint32_t f = 0; f < s.nt; f++) {
            if (!fa[f])
                continue;
            double n[3];
            en_triangle_normal(s.pos, tri + 3 * f, n);
            double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            const double *m = ref + 3 * f;
            double ang = acos(fmin(1.0, (n[0] * m[0] + n[1] * m[1] + n[2] * m[2]) / len)) * 180 / M_PI;
            if (ang > worst)
                worst = ang;
        }
        printf("  bound %.0f: %llu collapses, worst face turn %.2f degrees\n", bounds[b],
               (unsigned long long)cc.collapses, worst);
        CHECK(worst <= bounds[b] + 1e-9);
    }
    free(removable);
    free(fa);
    free(va);
    free(tri);
    free(q);
    free(ref);
    classified_free(&c);
    en_slab_free(&s);
}

int main(void)
{
    RUN(generated_closed_shapes_keep_topology_samples_and_orientation);
    RUN(no_face_turns_past_the_bound_from_its_input_normal);
    RUN(open_terrain_keeps_its_boundary);
    RUN(more_passes_remove_more_and_keep_topology);
    RUN(same_input_gives_same_bytes);
    RUN(shared_data_meshes);
    tl_cleanup();
    return tl_finish();
}
