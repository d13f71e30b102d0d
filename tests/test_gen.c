/*
 * Synthetic mesh generator (src/gen): shapes are closed manifolds of the
 * designed genus, streams are sorted and finalized as docs/architecture.md §6 requires,
 * convex shapes are convex polyhedra on the coordinates as written, shuffled
 * output is the same surface, and memory does not grow with the face count.
 *
 * Records are collected through the internal emitter callback (the same
 * path epsnet_gen() takes into a writer), so these tests do not depend on a
 * file format; one test also goes through a real writer when the SMA
 * driver is available.
 */
#include <float.h>
#include <stdint.h>

#include "gen/gen_internal.h"
#include "testlib.h"

/* ---- collecting records ---- */

typedef struct rec_list {
    epsnet_record *rec;
    size_t n, cap;
} rec_list;

static int collect(void *ctx, const epsnet_record *rec, epsnet_error *err)
{
    (void)err;
    rec_list *l = ctx;
    if (l->n == l->cap) {
        l->cap = l->cap ? 2 * l->cap : 1024;
        l->rec = realloc(l->rec, l->cap * sizeof *l->rec);
        if (!l->rec) {
            perror("realloc");
            exit(2);
        }
    }
    l->rec[l->n++] = *rec;
    return 0;
}

static int count_only(void *ctx, const epsnet_record *rec, epsnet_error *err)
{
    (void)err;
    uint64_t *counts = ctx;
    counts[rec->kind]++;
    return 0;
}

typedef struct gen_mesh {
    rec_list list;
    float (*xyz)[3];
    uint64_t (*tri)[3];
    uint64_t nv, nt, nfin;
    epsnet_mesh_info info;
} gen_mesh;

/* tl_gen_settings, in this file's argument order. */
static epsnet_gen_settings settings(const char *shape, uint64_t faces, double param, int shuffle,
                                    uint64_t seed)
{
    return tl_gen_settings(shape, faces, param, seed, shuffle);
}

static int generate(const epsnet_gen_settings *s, gen_mesh *m)
{
    memset(m, 0, sizeof *m);
    epsnet_error err;
    int rc = epsnet_gen_info(s, &m->info, &err);
    if (rc == 0)
        rc = en_gen_run(s, collect, &m->list, NULL, &err);
    if (rc) {
        fprintf(stderr, "generate %s: %s\n", s->shape, epsnet_error_message(&err));
        return rc;
    }
    for (size_t i = 0; i < m->list.n; i++) {
        if (m->list.rec[i].kind == EPSNET_REC_VERTEX)
            m->nv++;
        else if (m->list.rec[i].kind == EPSNET_REC_TRIANGLE)
            m->nt++;
        else
            m->nfin++;
    }
    m->xyz = calloc(m->nv + 1, sizeof *m->xyz);
    m->tri = calloc(m->nt + 1, sizeof *m->tri);
    uint64_t iv = 0, it = 0;
    for (size_t i = 0; i < m->list.n; i++) {
        const epsnet_record *r = &m->list.rec[i];
        if (r->kind == EPSNET_REC_VERTEX) {
            for (int k = 0; k < 3; k++)
                m->xyz[iv][k] = (float)r->xyz[k];
            iv++;
        } else if (r->kind == EPSNET_REC_TRIANGLE) {
            memcpy(m->tri[it++], r->v, sizeof r->v);
        }
    }
    return 0;
}

static void gen_mesh_free(gen_mesh *m)
{
    free(m->list.rec);
    free(m->xyz);
    free(m->tri);
    memset(m, 0, sizeof *m);
}

/* ---- edges ---- */

typedef struct edge_use {
    uint64_t key;  /* min << 32 | max */
    uint64_t face;
    int forward;   /* 1 when the face walks min -> max */
} edge_use;

static int edge_cmp(const void *pa, const void *pb)
{
    const edge_use *a = pa, *b = pb;
    if (a->key != b->key)
        return a->key < b->key ? -1 : 1;
    return a->face < b->face ? -1 : a->face > b->face;
}

static edge_use *edge_uses(const gen_mesh *m)
{
    edge_use *e = malloc((3 * m->nt + 1) * sizeof *e);
    for (uint64_t f = 0; f < m->nt; f++)
        for (int k = 0; k < 3; k++) {
            uint64_t a = m->tri[f][k], b = m->tri[f][(k + 1) % 3];
            uint64_t lo = a < b ? a : b, hi = a < b ? b : a;
            e[3 * f + k] = (edge_use){lo << 32 | hi, f, a < b};
        }
    qsort(e, 3 * m->nt, sizeof *e, edge_cmp);
    return e;
}

typedef struct topo {
    uint64_t edges, boundary_edges, bad_edges, boundary_loops;
    int64_t euler;
} topo;

/* Closed where every edge has two faces walking it in opposite directions;
 * boundary edges have one; anything else is counted as bad. Boundary loops
 * are counted by following each boundary vertex's one outgoing edge. */
static topo topology(const gen_mesh *m)
{
    topo t = {0, 0, 0, 0, 0};
    edge_use *e = edge_uses(m);
    uint64_t *next = malloc((m->nv + 1) * sizeof *next);
    for (uint64_t v = 0; v < m->nv; v++)
        next[v] = UINT64_MAX;
    for (uint64_t i = 0; i < 3 * m->nt;) {
        uint64_t j = i;
        while (j < 3 * m->nt && e[j].key == e[i].key)
            j++;
        t.edges++;
        if (j - i == 2 && e[i].forward != e[i + 1].forward) {
            /* interior, consistently oriented */
        } else if (j - i == 1) {
            t.boundary_edges++;
            uint64_t lo = e[i].key >> 32, hi = e[i].key & 0xffffffffu;
            uint64_t from = e[i].forward ? lo : hi, to = e[i].forward ? hi : lo;
            if (next[from] != UINT64_MAX)
                t.bad_edges++;
            next[from] = to;
        } else {
            t.bad_edges++;
        }
        i = j;
    }
    for (uint64_t v = 0; v < m->nv; v++) {
        if (next[v] == UINT64_MAX)
            continue;
        t.boundary_loops++;
        uint64_t w = v;
        while (next[w] != UINT64_MAX) {
            uint64_t n = next[w];
            next[w] = UINT64_MAX;
            w = n;
        }
    }
    t.euler = (int64_t)m->nv - (int64_t)t.edges + (int64_t)m->nt;
    free(next);
    free(e);
    return t;
}

/* Edges whose far vertex lies above the plane of a face: 0 for a convex
 * polyhedron. Decided exactly on the float coordinates. */
static uint64_t reflex_edges(const gen_mesh *m)
{
    edge_use *e = edge_uses(m);
    uint64_t bad = 0;
    for (uint64_t i = 0; i + 1 < 3 * m->nt; i++) {
        if (e[i].key != e[i + 1].key)
            continue;
        for (int side = 0; side < 2; side++) {
            const uint64_t *f = m->tri[e[i + side].face], *g = m->tri[e[i + 1 - side].face];
            uint64_t far = g[0];
            for (int k = 0; k < 3; k++)
                if (g[k] != f[0] && g[k] != f[1] && g[k] != f[2])
                    far = g[k];
            if (en_gen_orient(m->xyz[f[0]], m->xyz[f[1]], m->xyz[f[2]], m->xyz[far]) > 0)
                bad++;
        }
        i++;
    }
    free(e);
    return bad;
}

static double tri_area2(const gen_mesh *m, uint64_t f, double n[3])
{
    const float *a = m->xyz[m->tri[f][0]], *b = m->xyz[m->tri[f][1]], *c = m->xyz[m->tri[f][2]];
    double u[3], v[3];
    for (int k = 0; k < 3; k++) {
        u[k] = (double)b[k] - a[k];
        v[k] = (double)c[k] - a[k];
    }
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
    return n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
}

static uint64_t tiny_faces(const gen_mesh *m)
{
    uint64_t bad = 0;
    for (uint64_t f = 0; f < m->nt; f++) {
        double n[3];
        if (!(tri_area2(m, f, n) > 1e-24))
            bad++;
    }
    return bad;
}

/* Six times the enclosed volume: positive when faces point outwards. */
static double signed_volume6(const gen_mesh *m)
{
    double vol = 0;
    for (uint64_t f = 0; f < m->nt; f++) {
        const float *a = m->xyz[m->tri[f][0]], *b = m->xyz[m->tri[f][1]], *c = m->xyz[m->tri[f][2]];
        vol += (double)a[0] * ((double)b[1] * c[2] - (double)b[2] * c[1]) -
               (double)a[1] * ((double)b[0] * c[2] - (double)b[2] * c[0]) +
               (double)a[2] * ((double)b[0] * c[1] - (double)b[1] * c[0]);
    }
    return vol;
}

/* ---- stream order (docs/architecture.md §6) ---- */

typedef struct order_report {
    uint64_t unsorted;        /* vertex below the previous one on the axis */
    uint64_t late_triangles;  /* triangle not right after its last vertex */
    uint64_t dead_refs;       /* reference to a finalized or unknown vertex */
    uint64_t late_finalize;   /* finalize not right after the vertex's last triangle */
    uint64_t finalize_errors; /* finalized twice, never, or with triangles to come */
} order_report;

static order_report stream_order(const gen_mesh *m, int axis)
{
    order_report o;
    memset(&o, 0, sizeof o);
    const rec_list *l = &m->list;
    /* position of each vertex's last triangle record */
    size_t *last_tri = calloc(m->nv + 1, sizeof *last_tri);
    uint8_t *state = calloc(m->nv + 1, 1); /* 1 live, 2 finalized */
    for (size_t i = 0; i < l->n; i++)
        if (l->rec[i].kind == EPSNET_REC_TRIANGLE)
            for (int k = 0; k < 3; k++)
                if (l->rec[i].v[k] < m->nv)
                    last_tri[l->rec[i].v[k]] = i;
    uint64_t nv = 0;
    double prev = -INFINITY;
    for (size_t i = 0; i < l->n; i++) {
        const epsnet_record *r = &l->rec[i];
        if (r->kind == EPSNET_REC_VERTEX) {
            if (r->xyz[axis] < prev)
                o.unsorted++;
            prev = r->xyz[axis];
            state[nv++] = 1;
        } else if (r->kind == EPSNET_REC_TRIANGLE) {
            uint64_t mx = 0;
            for (int k = 0; k < 3; k++) {
                if (r->v[k] >= nv || state[r->v[k]] != 1)
                    o.dead_refs++;
                if (r->v[k] > mx)
                    mx = r->v[k];
            }
            if (mx + 1 != nv)
                o.late_triangles++;
        } else {
            uint64_t v = r->v[0];
            if (v >= nv || state[v] != 1 || last_tri[v] > i) {
                o.finalize_errors++;
                continue;
            }
            state[v] = 2;
            for (size_t k = last_tri[v] + 1; k < i; k++)
                if (l->rec[k].kind != EPSNET_REC_FINALIZE) {
                    o.late_finalize++;
                    break;
                }
        }
    }
    for (uint64_t v = 0; v < nv; v++)
        if (state[v] != 2)
            o.finalize_errors++;
    free(last_tri);
    free(state);
    return o;
}

/* ---- shared checks ---- */

typedef struct expect {
    const char *shape;
    double param;
    int64_t euler;
    uint64_t boundary_loops;
    int convex;
} expect;

static void check_shape(const expect *x, uint64_t faces)
{
    epsnet_gen_settings s = settings(x->shape, faces, x->param, 0, 7);
    gen_mesh m;
    CHECK_EQ_INT(generate(&s, &m), 0);
    CHECK_EQ_U64(m.nv, m.info.nverts);
    CHECK_EQ_U64(m.nt, m.info.nfaces);
    CHECK_EQ_U64(m.nfin, m.nv);
    CHECK_EQ_INT(m.info.coord_type, EPSNET_COORD_FLOAT32);
    CHECK_EQ_INT(m.info.streaming, 1);
    if (faces >= 2000) {
        double rel = fabs((double)m.nt - (double)faces) / (double)faces;
        if (rel > 0.1)
            fprintf(stderr, "%s: %" PRIu64 " faces for %" PRIu64 " asked\n", x->shape, m.nt, faces);
        CHECK(rel <= 0.1);
    }
    topo t = topology(&m);
    CHECK_EQ_U64(t.bad_edges, 0);
    CHECK_EQ_INT(t.euler, x->euler);
    CHECK_EQ_U64(t.boundary_loops, x->boundary_loops);
    if (x->boundary_loops == 0) {
        CHECK_EQ_U64(t.boundary_edges, 0);
        CHECK(signed_volume6(&m) > 0);
    }
    CHECK_EQ_U64(tiny_faces(&m), 0);
    order_report o = stream_order(&m, m.info.sorted_axis);
    CHECK_EQ_U64(o.unsorted, 0);
    CHECK_EQ_U64(o.late_triangles, 0);
    CHECK_EQ_U64(o.dead_refs, 0);
    CHECK_EQ_U64(o.late_finalize, 0);
    CHECK_EQ_U64(o.finalize_errors, 0);
    if (x->convex)
        CHECK_EQ_U64(reflex_edges(&m), 0);
    gen_mesh_free(&m);
}

static const expect all_shapes[] = {
    {"sphere", NAN, 2, 0, 1},
    {"ellipsoid", NAN, 2, 0, 1},
    {"roundcube", NAN, 2, 0, 1},
    {"torus", NAN, 0, 0, 0},
    {"dimple", NAN, 2, 0, 0},
    {"bumpy", NAN, 2, 0, 0},
    {"terrain", NAN, 1, 1, 0},
    /* a through bore: genus 1 */
    {"cad", NAN, 0, 0, 0},
};

TEST(every_shape_is_a_sorted_finalized_manifold_of_its_genus)
{
    static const uint64_t sizes[] = {50, 2000, 30000};
    for (size_t i = 0; i < sizeof all_shapes / sizeof *all_shapes; i++)
        for (size_t k = 0; k < sizeof sizes / sizeof *sizes; k++)
            check_shape(&all_shapes[i], sizes[k]);
}

TEST(convex_shapes_have_only_convex_edges)
{
    static const double params[] = {0, 0.3, 0.7, 0.95, 1};
    static const uint64_t sizes[] = {100, 5000, 60000, 250000};
    for (size_t k = 0; k < sizeof sizes / sizeof *sizes; k++) {
        for (size_t p = 0; p < sizeof params / sizeof *params; p++) {
            expect x = {"roundcube", params[p], 2, 0, 1};
            check_shape(&x, sizes[k]);
        }
        expect sphere = {"sphere", NAN, 2, 0, 1}, ellipsoid = {"ellipsoid", NAN, 2, 0, 1};
        check_shape(&sphere, sizes[k]);
        check_shape(&ellipsoid, sizes[k]);
    }
}

TEST(reflex_edge_check_catches_a_dent)
{
    /* The check itself must be able to fail: push one vertex of a sphere
     * inwards and the edges around it turn reflex. */
    epsnet_gen_settings s = settings("sphere", 2000, NAN, 0, 1);
    gen_mesh m;
    CHECK_EQ_INT(generate(&s, &m), 0);
    CHECK_EQ_U64(reflex_edges(&m), 0);
    uint64_t v = m.nv / 2;
    for (int k = 0; k < 3; k++)
        m.xyz[v][k] *= 0.9f;
    CHECK(reflex_edges(&m) >= 6);
    gen_mesh_free(&m);
}

/* Each triangle as coordinates, rotated so its smallest corner comes first
 * (orientation kept), for comparing meshes whatever their vertex order. */
typedef struct coord_tri {
    float p[9];
} coord_tri;

static int coord_tri_cmp(const void *pa, const void *pb)
{
    return memcmp(pa, pb, sizeof(coord_tri));
}

static int corner_less(const float *a, const float *b)
{
    for (int k = 0; k < 3; k++)
        if (a[k] != b[k])
            return a[k] < b[k];
    return 0;
}

static coord_tri *coord_tris(const gen_mesh *m)
{
    coord_tri *t = calloc(m->nt + 1, sizeof *t);
    for (uint64_t f = 0; f < m->nt; f++) {
        int first = 0;
        for (int k = 1; k < 3; k++)
            if (corner_less(m->xyz[m->tri[f][k]], m->xyz[m->tri[f][first]]))
                first = k;
        for (int k = 0; k < 3; k++)
            memcpy(t[f].p + 3 * k, m->xyz[m->tri[f][(first + k) % 3]], 3 * sizeof(float));
    }
    qsort(t, m->nt, sizeof *t, coord_tri_cmp);
    return t;
}

TEST(shuffle_gives_the_same_triangles_in_another_order)
{
    for (size_t i = 0; i < sizeof all_shapes / sizeof *all_shapes; i++) {
        epsnet_gen_settings ss = settings(all_shapes[i].shape, 3000, NAN, 0, 5);
        epsnet_gen_settings sh = settings(all_shapes[i].shape, 3000, NAN, 1, 5);
        gen_mesh a, b;
        CHECK_EQ_INT(generate(&ss, &a), 0);
        CHECK_EQ_INT(generate(&sh, &b), 0);
        CHECK_EQ_INT(b.info.streaming, 0);
        CHECK_EQ_INT(b.info.sorted_axis, -1);
        CHECK_EQ_U64(b.nfin, 0);
        CHECK_EQ_U64(a.nv, b.nv);
        CHECK_EQ_U64(a.nt, b.nt);
        /* vertices first, then faces */
        size_t first_tri = 0;
        while (first_tri < b.list.n && b.list.rec[first_tri].kind == EPSNET_REC_VERTEX)
            first_tri++;
        CHECK_EQ_U64(first_tri, b.nv);
        coord_tri *ta = coord_tris(&a), *tb = coord_tris(&b);
        CHECK(a.nt == b.nt && memcmp(ta, tb, a.nt * sizeof *ta) == 0);
        /* and really shuffled: the vertex order differs from the sorted one */
        uint64_t same = 0;
        for (uint64_t v = 0; v < a.nv; v++)
            same += memcmp(a.xyz[v], b.xyz[v], sizeof a.xyz[v]) == 0;
        CHECK(same < a.nv / 10);
        free(ta);
        free(tb);
        gen_mesh_free(&a);
        gen_mesh_free(&b);
    }
}

static int same_records(const gen_mesh *a, const gen_mesh *b)
{
    return a->list.n == b->list.n &&
           memcmp(a->list.rec, b->list.rec, a->list.n * sizeof *a->list.rec) == 0;
}

TEST(same_seed_same_records_other_seed_other_bumps)
{
    for (int shuffle = 0; shuffle < 2; shuffle++) {
        epsnet_gen_settings s1 = settings("bumpy", 4000, NAN, shuffle, 11);
        epsnet_gen_settings s2 = settings("bumpy", 4000, NAN, shuffle, 12);
        gen_mesh a, b, c;
        CHECK_EQ_INT(generate(&s1, &a), 0);
        CHECK_EQ_INT(generate(&s1, &b), 0);
        CHECK_EQ_INT(generate(&s2, &c), 0);
        CHECK(same_records(&a, &b));
        CHECK(!same_records(&a, &c));
        gen_mesh_free(&a);
        gen_mesh_free(&b);
        gen_mesh_free(&c);
    }
    /* dimple and terrain use the seed too */
    const char *seeded[] = {"dimple", "terrain"};
    for (int i = 0; i < 2; i++) {
        epsnet_gen_settings s1 = settings(seeded[i], 4000, NAN, 0, 11);
        epsnet_gen_settings s2 = settings(seeded[i], 4000, NAN, 0, 12);
        gen_mesh a, c;
        CHECK_EQ_INT(generate(&s1, &a), 0);
        CHECK_EQ_INT(generate(&s2, &c), 0);
        CHECK(!same_records(&a, &c));
        gen_mesh_free(&a);
        gen_mesh_free(&c);
    }
}

TEST(a_few_exact_coordinates)
{
    /* The sphere's poles and the cube's corners are exact:
     *
     *        (0,0,1)                 (-1,1,1) +------+ (1,1,1)
     *          /\                             |      |
     *         /  \                            | top  |
     *        ...                   (-1,-1,1)  +------+ (1,-1,1)
     */
    gen_mesh m;
    epsnet_gen_settings s = settings("sphere", 1000, NAN, 0, 1);
    CHECK_EQ_INT(generate(&s, &m), 0);
    CHECK(m.xyz[0][0] == 0 && m.xyz[0][1] == 0 && m.xyz[0][2] == -1);
    CHECK(m.xyz[m.nv - 1][0] == 0 && m.xyz[m.nv - 1][1] == 0 && m.xyz[m.nv - 1][2] == 1);
    gen_mesh_free(&m);

    s = settings("roundcube", 1000, 1.0, 0, 1);
    CHECK_EQ_INT(generate(&s, &m), 0);
    int corners = 0;
    float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    for (uint64_t v = 0; v < m.nv; v++) {
        int on = 1;
        for (int k = 0; k < 3; k++) {
            on &= fabsf(m.xyz[v][k]) == 1.0f;
            lo[k] = fminf(lo[k], m.xyz[v][k]);
            hi[k] = fmaxf(hi[k], m.xyz[v][k]);
        }
        corners += on;
    }
    CHECK_EQ_INT(corners, 8);
    for (int k = 0; k < 3; k++)
        CHECK(lo[k] == -1.0f && hi[k] == 1.0f);
    gen_mesh_free(&m);
}

TEST(cad_is_a_shaft_with_a_bore_and_a_hexagonal_flange)
{
    /* Profile (r, z), revolved around z; the flange is a hexagon of apothem
     * 0.75, so its corners are at radius 0.75 / cos 30 = 0.866:
     *
     *  z=1    +--+            bore r=0.2, shaft r=0.3 / 0.4 / 0.45
     *         |  |__
     *  z=0.5  |     |
     *  z=-0.2 |     |______
     *         |  flange    |  hexagon
     *  z=-0.4 |   _________|
     *  z=-1   +__|
     */
    epsnet_gen_settings s = settings("cad", 20000, NAN, 0, 1);
    gen_mesh m;
    CHECK_EQ_INT(generate(&s, &m), 0);
    double rmin = INFINITY, rmax = 0;
    uint64_t at_max = 0, at_max_in_flange = 0;
    for (uint64_t v = 0; v < m.nv; v++) {
        double r = hypot(m.xyz[v][0], m.xyz[v][1]);
        rmin = fmin(rmin, r);
        rmax = fmax(rmax, r);
    }
    for (uint64_t v = 0; v < m.nv; v++) {
        double r = hypot(m.xyz[v][0], m.xyz[v][1]);
        if (r > rmax - 1e-6) {
            at_max++;
            at_max_in_flange += m.xyz[v][2] >= -0.4f && m.xyz[v][2] <= -0.2f;
        }
    }
    CHECK(fabs(rmin - 0.2) < 1e-6);
    CHECK(fabs(rmax - 0.75 / cos(M_PI / 6)) < 1e-6);
    /* six corner lines, at least the two crease rows on each */
    CHECK(at_max >= 12 && at_max % 6 == 0);
    CHECK_EQ_U64(at_max_in_flange, at_max);
    /* planar faces: the five annuli are exactly horizontal */
    uint64_t horizontal = 0;
    for (uint64_t f = 0; f < m.nt; f++) {
        double n[3];
        tri_area2(&m, f, n);
        horizontal += n[0] == 0 && n[1] == 0;
    }
    CHECK(horizontal > m.nt / 10);
    gen_mesh_free(&m);
}

TEST(memory_does_not_grow_with_the_face_count)
{
    /* 2M faces counted, not stored: the generator's own working memory must
     * follow the grid side (sqrt of the faces), not the face count. */
    const char *shapes[] = {"sphere", "roundcube", "bumpy", "torus", "cad", "terrain"};
    for (int i = 0; i < 6; i++) {
        epsnet_error err;
        en_gen_stats small, big;
        uint64_t counts_small[4] = {0}, counts_big[4] = {0};
        epsnet_gen_settings s = settings(shapes[i], 20000, NAN, 0, 1);
        CHECK_EQ_INT(en_gen_run(&s, count_only, counts_small, &small, &err), 0);
        s.faces = 2000000;
        CHECK_EQ_INT(en_gen_run(&s, count_only, counts_big, &big, &err), 0);
        epsnet_mesh_info info;
        CHECK_EQ_INT(epsnet_gen_info(&s, &info, &err), 0);
        CHECK_EQ_U64(counts_big[EPSNET_REC_TRIANGLE], info.nfaces);
        CHECK_EQ_U64(counts_big[EPSNET_REC_FINALIZE], info.nverts);
        /* 100x the faces: sqrt growth is ~10x, linear would be 100x */
        if (!(big.peak_bytes < 20 * small.peak_bytes && big.peak_bytes < (2u << 20)))
            fprintf(stderr, "%s: peak %" PRIu64 " bytes at 20k faces, %" PRIu64 " at 2M\n",
                    shapes[i], small.peak_bytes, big.peak_bytes);
        CHECK(big.peak_bytes < 20 * small.peak_bytes);
        CHECK(big.peak_bytes < (2u << 20));
        CHECK(big.peak_live < info.nverts / 50);
    }
}

TEST(bad_settings_are_rejected_with_a_reason)
{
    epsnet_error err;
    epsnet_mesh_info info;
    epsnet_gen_settings s = settings("teapot", 1000, NAN, 0, 1);
    CHECK_EQ_INT(epsnet_gen_info(&s, &info, &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(err.reason, "unknown shape 'teapot'");
    s = settings("sphere", 0, NAN, 0, 1);
    CHECK_EQ_INT(epsnet_gen_info(&s, &info, &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(err.reason, "--faces");
    s = settings("torus", 1000, 1.5, 0, 1);
    CHECK_EQ_INT(epsnet_gen_info(&s, &info, &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(err.reason, "torus --param");
    s = settings("roundcube", 1000, -0.1, 0, 1);
    CHECK_EQ_INT(epsnet_gen_info(&s, &info, &err), EPSNET_EINVAL);
    s = settings("bumpy", 1000, INFINITY, 0, 1);
    CHECK_EQ_INT(epsnet_gen_info(&s, &info, &err), EPSNET_EINVAL);
    s = settings("sphere", 1000, NAN, 0, 1);
    CHECK_EQ_INT(epsnet_gen(&s, NULL, &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(epsnet_gen_shapes(), "cad");
}

TEST(huge_requests_are_sized_without_generating)
{
    epsnet_error err;
    epsnet_mesh_info info;
    epsnet_gen_settings s = settings("bumpy", 1000000000, NAN, 0, 1);
    CHECK_EQ_INT(epsnet_gen_info(&s, &info, &err), 0);
    CHECK(fabs((double)info.nfaces - 1e9) < 1e8);
    CHECK_EQ_INT(info.sorted_axis, 2);
    s.shape = "terrain";
    CHECK_EQ_INT(epsnet_gen_info(&s, &info, &err), 0);
    CHECK(fabs((double)info.nfaces - 1e9) < 1e8);
    CHECK_EQ_INT(info.sorted_axis, 1);
}

/* ---- arithmetic helpers ---- */

TEST(sincos_of_turns_is_accurate_and_exact_at_quarters)
{
    double s, c;
    en_gen_sincos_turn(0, 8, &s, &c);
    CHECK(s == 0 && c == 1);
    en_gen_sincos_turn(2, 8, &s, &c);
    CHECK(s == 1 && c == 0);
    en_gen_sincos_turn(-1, 4, &s, &c);
    CHECK(s == -1 && c == 0);
    double worst = 0;
    for (int64_t n = -1000; n <= 1000; n++) {
        en_gen_sincos_turn(n, 997, &s, &c);
        double a = 2 * M_PI * (double)n / 997.0;
        worst = fmax(worst, fmax(fabs(s - sin(a)), fabs(c - cos(a))));
    }
    /* the reference angle itself is rounded: about 1e-15 at 2 pi */
    CHECK(worst < 2e-15);
    /* mirrored angles give the same magnitudes bit for bit */
    double s1, c1, s2, c2;
    en_gen_sincos_turn(7, 40, &s1, &c1);
    en_gen_sincos_turn(13, 40, &s2, &c2);
    CHECK(s1 == s2 && c1 == -c2);
}

TEST(orientation_is_exact_for_nearly_coplanar_points)
{
    /* d is one float step above or below the plane z = 0.5 through a, b, c */
    float a[3] = {0.1f, 0.1f, 0.5f}, b[3] = {0.3f, 0.1f, 0.5f}, c[3] = {0.1f, 0.7f, 0.5f};
    float up[3] = {0.2f, 0.2f, nextafterf(0.5f, 1)}, down[3] = {0.2f, 0.2f, nextafterf(0.5f, 0)};
    float on[3] = {0.9f, -0.3f, 0.5f};
    CHECK_EQ_INT(en_gen_orient(a, b, c, up), 1);
    CHECK_EQ_INT(en_gen_orient(a, b, c, down), -1);
    CHECK_EQ_INT(en_gen_orient(a, b, c, on), 0);
    CHECK_EQ_INT(en_gen_orient(a, c, b, up), -1);
    /* a tilted plane: points of the form p + t*(u) + s*(v) with exact
     * small-integer multiples stay coplanar */
    float p[3] = {0.25f, 0.5f, 0.75f};
    float q[3] = {0.375f, 0.5f, 0.8125f}, r[3] = {0.25f, 0.625f, 0.6875f};
    float s4[3] = {0.375f, 0.625f, 0.75f};
    CHECK_EQ_INT(en_gen_orient(p, q, r, s4), 0);
    s4[2] = nextafterf(0.75f, 1);
    CHECK(en_gen_orient(p, q, r, s4) != 0);

    /* a vertical rectangle whose top is at 1e-16, not 0: the differences
     * do not fit a double, the points are still exactly coplanar
     *
     *   (x1,y1,1e-16) +----+ (x2,y2,1e-16)
     *                 |    |
     *   (x1,y1,-h)    +----+ (x2,y2,-h)
     */
    float ra[3] = {1.0f, 0.7f, -0.0037433156f}, rb[3] = {0.99997669f, 0.70373988f, 1.110223e-16f};
    float rc[3] = {1.0f, 0.7f, 1.110223e-16f}, rd[3] = {0.99997669f, 0.70373988f, -0.0037433156f};
    CHECK_EQ_INT(en_gen_orient(ra, rb, rc, rd), 0);
    rd[0] = nextafterf(rd[0], 2);
    int outwards = en_gen_orient(ra, rb, rc, rd);
    rd[0] = nextafterf(nextafterf(rd[0], 0), 0);
    CHECK_EQ_INT(en_gen_orient(ra, rb, rc, rd), -outwards);
    CHECK(outwards != 0);
    /* extreme magnitudes */
    float ta[3] = {1e-38f, 0, 0}, tb[3] = {0, 1e30f, 0}, tc[3] = {0, 0, 1e-30f}, td[3] = {0, 0, 0};
    CHECK_EQ_INT(en_gen_orient(ta, tb, tc, td), -en_gen_orient(tb, ta, tc, td));
    CHECK(en_gen_orient(ta, tb, tc, td) != 0);
}

TEST(permutation_is_a_bijection)
{
    static const uint64_t sizes[] = {1, 2, 3, 17, 1000, 4097};
    for (size_t i = 0; i < sizeof sizes / sizeof *sizes; i++) {
        uint64_t n = sizes[i];
        en_gen_perm p;
        en_gen_perm_init(&p, n, 42);
        uint8_t *seen = calloc(n, 1);
        uint64_t dup = 0, inverse_bad = 0, fixed = 0;
        for (uint64_t x = 0; x < n; x++) {
            uint64_t y = en_gen_perm_fwd(&p, x);
            if (y >= n || seen[y])
                dup++;
            else
                seen[y] = 1;
            if (en_gen_perm_inv(&p, y) != x)
                inverse_bad++;
            fixed += y == x;
        }
        CHECK_EQ_U64(dup, 0);
        CHECK_EQ_U64(inverse_bad, 0);
        if (n >= 1000)
            CHECK(fixed < n / 50);
        free(seen);
    }
}

/* ---- through a real writer ---- */

TEST(writing_through_a_writer_gives_the_same_mesh)
{
    epsnet_gen_settings s = settings("torus", 3000, NAN, 0, 3);
    epsnet_mesh_info info;
    epsnet_error err;
    CHECK_EQ_INT(epsnet_gen_info(&s, &info, &err), 0);
    const char *path = tl_path("torus.sma");
    epsnet_writer *w = NULL;
    int rc = epsnet_writer_open(&w, path, NULL, &info, &err);
    if (rc == EPSNET_EUNSUPPORTED) {
        printf("note: no SMA writer yet, writer test not run\n");
        return;
    }
    CHECK_EQ_INT(rc, 0);
    if (rc == 0)
        rc = epsnet_gen(&s, w, &err);
    CHECK_EQ_INT(rc, 0);
    if (rc == 0)
        rc = epsnet_writer_commit(&w, &err);
    epsnet_writer_abort(&w);
    CHECK_EQ_INT(rc, 0);
    tl_mesh back;
    rc = tl_read_mesh(path, &back, &err);
    if (rc == EPSNET_EUNSUPPORTED) {
        printf("note: no SMA reader yet, read-back not run\n");
        tl_mesh_free(&back);
        return;
    }
    CHECK_EQ_INT(rc, 0);
    gen_mesh m;
    CHECK_EQ_INT(generate(&s, &m), 0);
    CHECK_EQ_U64(back.nv, m.nv);
    CHECK_EQ_U64(back.nt, m.nt);
    CHECK_EQ_U64(back.nfin, m.nv);
    int same = back.nv == m.nv && back.nt == m.nt;
    for (uint64_t v = 0; same && v < m.nv; v++)
        for (int k = 0; k < 3; k++)
            same &= (float)back.xyz[3 * v + k] == m.xyz[v][k];
    for (uint64_t f = 0; same && f < m.nt; f++)
        same &= memcmp(back.tri + 3 * f, m.tri[f], sizeof m.tri[f]) == 0;
    CHECK(same);
    tl_mesh_free(&back);
    gen_mesh_free(&m);
}

int main(void)
{
    RUN(sincos_of_turns_is_accurate_and_exact_at_quarters);
    RUN(orientation_is_exact_for_nearly_coplanar_points);
    RUN(permutation_is_a_bijection);
    RUN(every_shape_is_a_sorted_finalized_manifold_of_its_genus);
    RUN(convex_shapes_have_only_convex_edges);
    RUN(reflex_edge_check_catches_a_dent);
    RUN(shuffle_gives_the_same_triangles_in_another_order);
    RUN(same_seed_same_records_other_seed_other_bumps);
    RUN(a_few_exact_coordinates);
    RUN(cad_is_a_shaft_with_a_bore_and_a_hexagonal_flange);
    RUN(memory_does_not_grow_with_the_face_count);
    RUN(bad_settings_are_rejected_with_a_reason);
    RUN(huge_requests_are_sized_without_generating);
    RUN(writing_through_a_writer_gives_the_same_mesh);
    tl_cleanup();
    return tl_finish();
}
