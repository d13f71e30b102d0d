/*
 * The Gaussian sphere (src/core/gauss.c): lattice structure, point location
 * with ties, and the winding numbers that decide samples (paper §3.4, §4.1).
 */
#include "core/gauss.h"
#include "core/predicates.h"
#include "testlib.h"

/* ---- deterministic random numbers ---- */

static uint64_t rng_state = 0x0ddba11c0ffee123ull;

static uint64_t rnd(void)
{
    uint64_t z = (rng_state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static double rnd_unit(void)
{
    return (double)(rnd() >> 11) * 0x1p-53 * 2.0 - 1.0;
}

static void rnd_direction(double v[3])
{
    double len;
    do {
        for (int k = 0; k < 3; k++)
            v[k] = rnd_unit();
        len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    } while (len < 0.1 || len > 1.0);
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* ---- structure ---- */

/*
 * Counts, ids, orientation and closedness of G for frequency n:
 * 4n^2+2 vertices with a bijective id map, 8n^2 positively oriented
 * triangles, every directed edge once and its reverse once (closed,
 * consistently oriented), V - E + F = 2.
 */
static void check_structure(uint32_t n)
{
    gauss_rotation rot;
    gauss_rotation_identity(&rot);
    gauss_sphere g;
    CHECK_EQ_INT(gauss_init(&g, n, &rot), 0);
    CHECK_EQ_INT(g.nverts, 4 * n * n + 2);
    CHECK_EQ_INT(g.ntris, 8 * n * n);

    uint32_t *seen = calloc(g.nverts, sizeof *seen);
    for (uint32_t id = 0; id < g.nverts; id++) {
        int32_t p[3];
        gauss_vertex_coords(&g, id, p);
        CHECK_EQ_INT(abs(p[0]) + abs(p[1]) + abs(p[2]), n);
        CHECK_EQ_INT(gauss_vertex_id(&g, p[0], p[1], p[2]), id);
    }
    uint64_t *edges = malloc(3 * (size_t)g.ntris * sizeof *edges);
    int bad_orientation = 0;
    for (uint32_t t = 0; t < g.ntris; t++) {
        uint32_t v[3];
        double p[3][3];
        gauss_triangle_vertices(&g, t, v);
        for (int k = 0; k < 3; k++) {
            CHECK(v[k] < g.nverts);
            seen[v[k]]++;
            gauss_vertex_vector(&g, v[k], p[k]);
            edges[3 * (size_t)t + k] = (uint64_t)v[k] << 32 | v[(k + 1) % 3];
        }
        if (en_orient3_sign(p[0], p[1], p[2]) != 1)
            bad_orientation++;
    }
    CHECK_EQ_INT(bad_orientation, 0);
    size_t ne = 3 * (size_t)g.ntris;
    qsort(edges, ne, sizeof *edges, cmp_u64);
    int duplicates = 0, unmatched = 0;
    for (size_t i = 0; i < ne; i++) {
        if (i > 0 && edges[i] == edges[i - 1])
            duplicates++;
        uint64_t rev = (edges[i] & 0xffffffffu) << 32 | edges[i] >> 32;
        if (!bsearch(&rev, edges, ne, sizeof *edges, cmp_u64))
            unmatched++;
    }
    CHECK_EQ_INT(duplicates, 0);
    CHECK_EQ_INT(unmatched, 0);
    int64_t euler = (int64_t)g.nverts - (int64_t)(ne / 2) + (int64_t)g.ntris;
    CHECK_EQ_INT(euler, 2);
    int unused = 0;
    for (uint32_t id = 0; id < g.nverts; id++)
        unused += seen[id] == 0;
    CHECK_EQ_INT(unused, 0);
    free(seen);
    free(edges);
}

TEST(sphere_has_4n2_plus_2_vertices_and_is_a_closed_oriented_triangulation)
{
    for (uint32_t n = 1; n <= 16; n++)
        check_structure(n);
    for (int level = 0; level <= 6; level++)
        check_structure(1u << level);
    /* the paper's level counts: 6, 18, 66, 258, 1026 */
    static const uint32_t counts[] = {6, 18, 66, 258, 1026};
    for (int level = 0; level < 5; level++) {
        gauss_rotation rot;
        gauss_rotation_identity(&rot);
        gauss_sphere g;
        CHECK_EQ_INT(gauss_init_level(&g, level, &rot), 0);
        CHECK_EQ_INT(g.nverts, counts[level]);
    }
    gauss_rotation rot;
    gauss_rotation_identity(&rot);
    gauss_sphere g;
    CHECK_EQ_INT(gauss_init(&g, 0, &rot), EPSNET_EINVAL);
    CHECK_EQ_INT(gauss_init(&g, GAUSS_MAX_FREQUENCY + 1, &rot), EPSNET_EINVAL);
    CHECK_EQ_INT(gauss_init_level(&g, GAUSS_MAX_LEVEL + 1, &rot), EPSNET_EINVAL);
    CHECK_EQ_INT(gauss_init_level(&g, GAUSS_MAX_LEVEL, &rot), 0);
    CHECK_EQ_INT(g.ntris, 8u * 16384u * 16384u);
    /* the largest sphere: ids round-trip and located triangles contain
     * their normals (no 32-bit overflow in the id arithmetic) */
    gauss_rotation_from_seed(3, &rot);
    gauss_init_level(&g, GAUSS_MAX_LEVEL, &rot);
    for (int i = 0; i < 2000; i++) {
        uint32_t id = (uint32_t)(rnd() % g.nverts);
        int32_t p[3];
        gauss_vertex_coords(&g, id, p);
        CHECK_EQ_INT(abs(p[0]) + abs(p[1]) + abs(p[2]), g.n);
        CHECK_EQ_INT(gauss_vertex_id(&g, p[0], p[1], p[2]), id);
        double n[3], nf[3];
        rnd_direction(n);
        gauss_to_frame(&g, n, nf);
        int64_t t = gauss_locate(&g, nf);
        CHECK(t >= 0 && t < (int64_t)g.ntris);
        CHECK(t >= 0 && gauss_triangle_contains(&g, (uint32_t)t, nf));
    }
}

/* ---- location ---- */

/* Exactly one triangle passes its three edge tests, and gauss_locate finds
 * it. Brute force over all triangles (test only). */
static void check_unique_location(const gauss_sphere *g, const double nf[3])
{
    int64_t found = -1;
    int hits = 0;
    for (uint32_t t = 0; t < g->ntris; t++) {
        if (gauss_triangle_contains(g, t, nf)) {
            hits++;
            found = t;
        }
    }
    CHECK_EQ_INT(hits, 1);
    CHECK_EQ_INT(gauss_locate(g, nf), found);
}

TEST(every_random_normal_lies_in_exactly_one_triangle)
{
    for (int level = 0; level <= 4; level++) {
        for (int r = 0; r < 3; r++) {
            gauss_rotation rot;
            gauss_rotation_from_seed((uint64_t)r * 7 + 1, &rot);
            gauss_sphere g;
            gauss_init_level(&g, level, &rot);
            for (int i = 0; i < 200; i++) {
                double n[3], nf[3];
                rnd_direction(n);
                CHECK_EQ_INT(gauss_to_frame(&g, n, nf), 1);
                check_unique_location(&g, nf);
            }
        }
    }
}

/*
 * With the identity rotation, normals exactly on G's vertices and edges:
 *
 *        v                a normal on the vertex v is touched by all
 *      / | \              triangles around v, one on the edge u-v by the
 *     /  |  \             two beside it; the perturbation of the lower id
 *    / A | B \            decides, and exactly one triangle answers.
 *   u----+----w
 */
TEST(normals_on_gaussian_vertices_and_edges_have_exactly_one_triangle)
{
    uint32_t freqs[] = {1, 2, 3, 4, 8};
    for (size_t f = 0; f < sizeof freqs / sizeof *freqs; f++) {
        gauss_rotation rot;
        gauss_rotation_identity(&rot);
        gauss_sphere g;
        gauss_init(&g, freqs[f], &rot);
        for (uint32_t id = 0; id < g.nverts; id++) {
            double v[3], nf[3];
            gauss_vertex_vector(&g, id, v);
            CHECK_EQ_INT(gauss_to_frame(&g, v, nf), 1);
            check_unique_location(&g, nf);
        }
        for (uint32_t t = 0; t < g.ntris; t++) {
            uint32_t v[3];
            gauss_triangle_vertices(&g, t, v);
            double a[3], b[3];
            gauss_vertex_vector(&g, v[0], a);
            gauss_vertex_vector(&g, v[1], b);
            /* points of the arc v0-v1: a + b and 2a + b, 3a + 5b */
            double mid[3][3];
            for (int k = 0; k < 3; k++) {
                mid[0][k] = a[k] + b[k];
                mid[1][k] = 2 * a[k] + b[k];
                mid[2][k] = 3 * a[k] + 5 * b[k];
            }
            for (int m = 0; m < 3; m++) {
                double nf[3];
                CHECK_EQ_INT(en_orient3_sign(a, b, mid[m]), 0); /* truly on the arc */
                gauss_to_frame(&g, mid[m], nf);
                check_unique_location(&g, nf);
            }
        }
    }
}

TEST(locate_is_exact_for_normals_that_nearly_touch_edges)
{
    /* one ulp either side of a G edge, at a high level, under rotation */
    for (int level = 0; level <= 6; level += 2) {
        gauss_rotation rot;
        gauss_rotation_from_seed(99 + (uint64_t)level, &rot);
        gauss_sphere g;
        gauss_init_level(&g, level, &rot);
        for (int i = 0; i < 300; i++) {
            uint32_t t = (uint32_t)(rnd() % g.ntris), v[3];
            gauss_triangle_vertices(&g, t, v);
            double a[3], b[3], nf[3];
            gauss_vertex_vector(&g, v[0], a);
            gauss_vertex_vector(&g, v[1], b);
            double w = (double)(rnd() % 1000 + 1) / 1001.0;
            for (int k = 0; k < 3; k++)
                nf[k] = (w * a[k] + (1 - w) * b[k]) / g.n;
            int k = (int)(rnd() % 3);
            if (nf[k] != 0.0)
                nf[k] = nextafter(nf[k], (rnd() & 1) ? 1.0 : -1.0);
            if (level <= 4) {
                check_unique_location(&g, nf);
            } else {
                int64_t got = gauss_locate(&g, nf);
                CHECK(got >= 0);
                CHECK(got >= 0 && gauss_triangle_contains(&g, (uint32_t)got, nf));
            }
        }
    }
    gauss_rotation rot;
    gauss_rotation_identity(&rot);
    gauss_sphere g;
    gauss_init(&g, 4, &rot);
    double zero[3] = {0, 0, 0}, out[3];
    CHECK_EQ_INT(gauss_locate(&g, zero), EPSNET_EINVAL);
    CHECK_EQ_INT(gauss_to_frame(&g, zero, out), 0);
    double inf[3] = {INFINITY, 0, 1}, nan3[3] = {NAN, 1, 0};
    CHECK_EQ_INT(gauss_to_frame(&g, inf, out), EPSNET_EINVAL);
    CHECK_EQ_INT(gauss_to_frame(&g, nan3, out), EPSNET_EINVAL);
    CHECK_EQ_INT(gauss_locate(&g, inf), EPSNET_EINVAL);
    CHECK_EQ_INT(gauss_locate(&g, nan3), EPSNET_EINVAL);
    /* tiny and huge normals are scaled exactly, tiny components flushed */
    double tiny[3] = {0x1p-600, 0x1p-601, 0x1p-1074}, big[3] = {0x1p1000, -0x1p999, 1.0};
    double sub[3] = {0x3p-1074, 0x1p-1074, 0.0};
    CHECK_EQ_INT(gauss_to_frame(&g, tiny, out), 1);
    CHECK(out[0] == 0.5 && out[1] == 0.25 && out[2] == 0.0);
    CHECK_EQ_INT(gauss_to_frame(&g, sub, out), 1);
    CHECK(out[0] == 0.75 && out[1] == 0.25 && out[2] == 0.0);
    CHECK_EQ_INT(gauss_to_frame(&g, big, out), 1);
    CHECK(out[0] == 0.5 && out[1] == -0.25 && out[2] == 0.0);
}

TEST(default_rotation_keeps_axis_and_diagonal_normals_off_gaussian_edges)
{
    /* CAD meshes are full of normals like these; under the default R none
     * may need the tie-break (gauss.h). A normal on a vertex or an edge of G
     * makes an unperturbed edge determinant of its own triangle zero. */
    gauss_rotation rot;
    gauss_rotation_default(&rot);
    int ties = 0;
    for (int level = 0; level <= 8; level++) {
        gauss_sphere g;
        gauss_init_level(&g, level, &rot);
        for (int x = -1; x <= 1; x++)
            for (int y = -1; y <= 1; y++)
                for (int z = -1; z <= 1; z++) {
                    double n[3] = {x, y, z}, nf[3];
                    if (gauss_to_frame(&g, n, nf) != 1)
                        continue;
                    int64_t t = gauss_locate(&g, nf);
                    CHECK(t >= 0);
                    uint32_t v[3];
                    gauss_triangle_vertices(&g, (uint32_t)t, v);
                    for (int k = 0; k < 3; k++) {
                        double a[3], b[3];
                        gauss_vertex_vector(&g, v[k], a);
                        gauss_vertex_vector(&g, v[(k + 1) % 3], b);
                        ties += en_orient3_sign(a, b, nf) == 0;
                    }
                }
    }
    CHECK_EQ_INT(ties, 0);
}

TEST(rotations_parse_and_reject_bad_values)
{
    gauss_rotation r, ref;
    CHECK_EQ_INT(gauss_rotation_parse("identity", &r), 0);
    gauss_rotation_identity(&ref);
    CHECK(memcmp(&r, &ref, sizeof r) == 0);
    CHECK_EQ_INT(gauss_rotation_parse("0,0,1,90", &r), 0);
    /* 90 degrees about z maps e_x to e_y: n_G = R^T n sends e_y to e_x */
    double ey[3] = {0, 1, 0};
    double out[3];
    for (int k = 0; k < 3; k++)
        out[k] = r.rt[k][0] * ey[0] + r.rt[k][1] * ey[1] + r.rt[k][2] * ey[2];
    CHECK(fabs(out[0] - 1) < 1e-15 && fabs(out[1]) < 1e-15 && fabs(out[2]) < 1e-15);
    CHECK_EQ_INT(gauss_rotation_parse("q:1,0,0,0", &r), 0);
    CHECK(memcmp(&r, &ref, sizeof r) == 0);
    CHECK_EQ_INT(gauss_rotation_parse("q:0,0,0,0", &r), EPSNET_EINVAL);
    CHECK_EQ_INT(gauss_rotation_parse("0,0,0,30", &r), EPSNET_EINVAL);
    CHECK_EQ_INT(gauss_rotation_parse("1,2,3", &r), EPSNET_EINVAL);
    CHECK_EQ_INT(gauss_rotation_parse("1,2,3,4,5", &r), EPSNET_EINVAL);
    CHECK_EQ_INT(gauss_rotation_parse("1,2,nan,4", &r), EPSNET_EINVAL);
    CHECK_EQ_INT(gauss_rotation_parse("", &r), EPSNET_EINVAL);
    /* seeded rotations are orthonormal and differ per seed */
    gauss_rotation a, b;
    gauss_rotation_from_seed(1, &a);
    gauss_rotation_from_seed(2, &b);
    CHECK(memcmp(&a, &b, sizeof a) != 0);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double d = 0;
            for (int k = 0; k < 3; k++)
                d += a.rt[i][k] * a.rt[j][k];
            CHECK(fabs(d - (i == j)) < 1e-14);
        }
}

/* ---- winding numbers ---- */

typedef struct poly_mesh {
    int nv, nf;
    double xyz[64][3];
    int tri[128][3];
} poly_mesh;

/* Vertex polygons of a closed, outward-oriented triangle mesh: for vertex v
 * the faces in counter-clockwise order seen from outside (face (v,a,b) is
 * followed by the face (v,b,c)). @return the number of faces around v. */
static int vertex_fan(const poly_mesh *m, int v, int fan[64])
{
    int first = -1, count = 0;
    for (int f = 0; f < m->nf && first < 0; f++)
        for (int k = 0; k < 3; k++)
            if (m->tri[f][k] == v)
                first = f;
    int f = first;
    do {
        fan[count++] = f;
        int k = m->tri[f][0] == v ? 0 : m->tri[f][1] == v ? 1 : 2;
        int b = m->tri[f][(k + 2) % 3];
        int next = -1;
        for (int h = 0; h < m->nf && next < 0; h++)
            for (int j = 0; j < 3; j++)
                if (m->tri[h][j] == v && m->tri[h][(j + 1) % 3] == b)
                    next = h;
        f = next;
    } while (f != first && f >= 0 && count < 64);
    return count;
}

static void face_normal(const poly_mesh *m, int f, double n[3])
{
    const double *a = m->xyz[m->tri[f][0]], *b = m->xyz[m->tri[f][1]], *c = m->xyz[m->tri[f][2]];
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    n[0] = u[1] * w[2] - u[2] * w[1];
    n[1] = u[2] * w[0] - u[0] * w[2];
    n[2] = u[0] * w[1] - u[1] * w[0];
}

/*
 * The paper's §3.4 invariant at its core: on a closed convex mesh the vertex
 * polygons tile the Gaussian sphere, so every (perturbed) Gaussian vertex
 * has winding 1 in exactly one polygon and 0 in all others.
 */
static void check_convex_tiling(const poly_mesh *m, const gauss_sphere *g)
{
    double nf[128][3];
    for (int f = 0; f < m->nf; f++) {
        double n[3];
        face_normal(m, f, n);
        CHECK_EQ_INT(gauss_to_frame(g, n, nf[f]), 1);
    }
    static double poly[64][64][3];
    static double centre[64][3];
    int len[64];
    for (int v = 0; v < m->nv; v++) {
        int fan[64];
        len[v] = vertex_fan(m, v, fan);
        for (int k = 0; k < len[v]; k++)
            memcpy(poly[v][k], nf[fan[k]], sizeof poly[v][k]);
        CHECK_EQ_INT(gauss_in_open_hemisphere((const double(*)[3])poly[v], (size_t)len[v],
                                              centre[v]),
                     GAUSS_HEMI_CENTRE);
    }
    int bad_sum = 0, bad_value = 0;
    for (uint32_t gid = 0; gid < g->nverts; gid++) {
        int sum = 0;
        for (int v = 0; v < m->nv; v++) {
            int w = gauss_winding(g, (const double(*)[3])poly[v], (size_t)len[v], gid, centre[v]);
            sum += w;
            bad_value += w != 0 && w != 1;
        }
        bad_sum += sum != 1;
    }
    CHECK_EQ_INT(bad_sum, 0);
    CHECK_EQ_INT(bad_value, 0);
}

/*
 *      +-------+         cube [-1,1]^3, each square split into two
 *     /|      /|         triangles (so a polygon may repeat a normal).
 *    +-------+ |         Under the identity rotation its six face normals
 *    | +-----|-+         are exactly the level-0 Gaussian vertices ±e, and
 *    |/      |/          at every level lie on G's vertices and edges: the
 *    +-------+           tie-break alone assigns each g to one corner.
 */
static void make_cube(poly_mesh *m)
{
    memset(m, 0, sizeof *m);
    m->nv = 8;
    for (int i = 0; i < 8; i++) {
        m->xyz[i][0] = (i & 1) ? 1 : -1;
        m->xyz[i][1] = (i & 2) ? 1 : -1;
        m->xyz[i][2] = (i & 4) ? 1 : -1;
    }
    /* quads counter-clockwise seen from outside */
    static const int quads[6][4] = {
        {0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5},
    };
    for (int q = 0; q < 6; q++) {
        const int *v = quads[q];
        int a[3] = {v[0], v[1], v[2]}, b[3] = {v[0], v[2], v[3]};
        memcpy(m->tri[m->nf++], a, sizeof a);
        memcpy(m->tri[m->nf++], b, sizeof b);
    }
}

/* The octahedron ±e: face normals (±1,±1,±1), a Gaussian vertex at N = 3. */
static void make_octahedron(poly_mesh *m)
{
    memset(m, 0, sizeof *m);
    m->nv = 6;
    for (int i = 0; i < 6; i++)
        m->xyz[i][i / 2] = (i & 1) ? -1 : 1;
    for (int o = 0; o < 8; o++) {
        int x = (o & 1) ? 1 : 0, y = (o & 2) ? 3 : 2, z = (o & 4) ? 5 : 4;
        int neg = ((o & 1) != 0) + ((o & 2) != 0) + ((o & 4) != 0);
        int t[3] = {x, y, z};
        if (neg & 1) {
            t[1] = z;
            t[2] = y;
        }
        memcpy(m->tri[m->nf++], t, sizeof t);
    }
}

/* Convex hull of n random points on the unit sphere, by brute force over
 * all triples (the points are in general position with overwhelming
 * probability; a near-tie is rejected and redrawn). */
static void make_random_hull(poly_mesh *m, int n)
{
    for (;;) {
        memset(m, 0, sizeof *m);
        m->nv = n;
        for (int i = 0; i < n; i++) {
            double *p = m->xyz[i];
            rnd_direction(p);
            double len = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
            for (int k = 0; k < 3; k++)
                p[k] /= len;
        }
        int ok = 1;
        for (int i = 0; i < n && ok; i++)
            for (int j = i + 1; j < n && ok; j++)
                for (int k = j + 1; k < n && ok; k++) {
                    int t[3] = {i, j, k};
                    memcpy(m->tri[m->nf], t, sizeof t);
                    double nrm[3];
                    face_normal(m, m->nf, nrm);
                    int pos = 0, neg = 0;
                    for (int l = 0; l < n; l++) {
                        if (l == i || l == j || l == k)
                            continue;
                        double d = 0;
                        for (int c = 0; c < 3; c++)
                            d += nrm[c] * (m->xyz[l][c] - m->xyz[i][c]);
                        if (fabs(d) < 1e-9)
                            ok = 0;
                        pos += d > 0;
                        neg += d < 0;
                    }
                    if (!ok || (pos && neg))
                        continue;
                    if (pos) { /* others in front: flip to face outward */
                        m->tri[m->nf][1] = k;
                        m->tri[m->nf][2] = j;
                    }
                    if (m->nf < 127)
                        m->nf++;
                    else
                        ok = 0;
                }
        if (ok && m->nf == 2 * n - 4)
            return;
    }
}

TEST(convex_mesh_vertex_polygons_cover_every_gaussian_vertex_exactly_once)
{
    poly_mesh cube, octa, hull;
    make_cube(&cube);
    make_octahedron(&octa);
    make_random_hull(&hull, 24);
    uint32_t freqs[] = {1, 2, 3, 4, 8, 16}; /* levels 0..4, and N = 3 */
    for (size_t f = 0; f < sizeof freqs / sizeof *freqs; f++) {
        for (int r = 0; r <= 20; r++) {
            gauss_rotation rot;
            if (r == 0)
                gauss_rotation_identity(&rot);
            else
                gauss_rotation_from_seed(1000 + (uint64_t)r, &rot);
            gauss_sphere g;
            gauss_init(&g, freqs[f], &rot);
            check_convex_tiling(&cube, &g);
            check_convex_tiling(&octa, &g);
            check_convex_tiling(&hull, &g);
        }
    }
}

/*
 * Saddle (z = x^2 - y^2) and monkey saddle (z = Re (x + iy)^3) around a
 * vertex at the origin, ring heights alternating +h / -h:
 *
 *          p1 (-h)                p2(+) p1(-)
 *          /  \                  p3(-)  .  p0(+)
 *   p2(+h) -- o -- p0(+h)           p4(+) p5(-)
 *          \  /
 *          p3 (-h)
 *
 * Walking the faces counter-clockwise, the normals turn clockwise once
 * (saddle) or twice (monkey saddle) around +z: winding -1 and -2 about the
 * Gaussian vertex (0, 0, N) under the identity rotation.
 */
static int fan_winding(int ring, int alternate, uint32_t n)
{
    gauss_rotation rot;
    gauss_rotation_identity(&rot);
    gauss_sphere g;
    gauss_init(&g, n, &rot);
    double p[12][3], nf[12][3], centre[3];
    for (int k = 0; k < ring; k++) {
        double ang = 2 * 3.14159265358979323846 * k / ring;
        p[k][0] = cos(ang);
        p[k][1] = sin(ang);
        p[k][2] = alternate && (k & 1) ? 0.3 : -0.3;
    }
    for (int k = 0; k < ring; k++) {
        const double *a = p[k], *b = p[(k + 1) % ring];
        double nrm[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                         a[0] * b[1] - a[1] * b[0]};
        gauss_to_frame(&g, nrm, nf[k]);
    }
    if (gauss_in_open_hemisphere((const double(*)[3])nf, (size_t)ring, centre) !=
        GAUSS_HEMI_CENTRE)
        return 99;
    return gauss_winding(&g, (const double(*)[3])nf, (size_t)ring,
                         gauss_vertex_id(&g, 0, 0, (int32_t)n), centre);
}

TEST(saddle_winds_minus_one_and_monkey_saddle_minus_two)
{
    for (uint32_t n = 1; n <= 4; n++) {
        CHECK_EQ_INT(fan_winding(4, 1, n), -1);
        CHECK_EQ_INT(fan_winding(6, 1, n), -2);
        /* the tip of a convex cone (ring below the apex) winds +1 */
        CHECK_EQ_INT(fan_winding(6, 0, n), 1);
        CHECK_EQ_INT(fan_winding(4, 0, n), 1);
    }
}

/*
 * Needle tips: normals that no open hemisphere holds.
 *   fin:   a zero-thickness blade tip; faces (v,p,q) and (v,q,p) have
 *          opposite normals.
 *   star:  three fins meeting at 120 degrees: coplanar normals around 0.
 *   tetra: a tip whose four faces point to the corners of a tetrahedron.
 */
TEST(needle_tip_normals_are_not_in_an_open_hemisphere)
{
    double c[3];
    double fin[2][3] = {{0, -1, 0}, {0, 1, 0}};
    CHECK_EQ_INT(gauss_in_open_hemisphere(fin, 2, c), GAUSS_HEMI_NONE);
    double star[3][3] = {{1, 0, 0}, {-0.5, 0.8660254037844386, 0}, {-0.5, -0.8660254037844386, 0}};
    CHECK_EQ_INT(gauss_origin_in_hull(star, 3), 1);
    CHECK_EQ_INT(gauss_in_open_hemisphere(star, 3, c), GAUSS_HEMI_NONE);
    double tetra[4][3] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
    CHECK_EQ_INT(gauss_in_open_hemisphere(tetra, 4, c), GAUSS_HEMI_NONE);
    /* a sharp but honest cone tip stays in a hemisphere */
    double cone[4][3] = {{1, 0, 0.01}, {0, 1, 0.01}, {-1, 0, 0.01}, {0, -1, 0.01}};
    CHECK_EQ_INT(gauss_in_open_hemisphere(cone, 4, c), GAUSS_HEMI_CENTRE);
    for (int i = 0; i < 4; i++)
        CHECK_EQ_INT(en_dot3_sign(c, cone[i]), 1);
    /* a knife edge: two normals 2^-40 short of opposite (the dual cone is a
     * wedge without extreme rays); the sum of units cancels, yet a centre
     * exists and must be found */
    double knife[3][3] = {{1, 0, 0}, {-1, 0x1p-40, 0}, {1, 0, 0}};
    CHECK_EQ_INT(gauss_in_open_hemisphere(knife, 3, c), GAUSS_HEMI_CENTRE);
    for (int i = 0; i < 3; i++)
        CHECK_EQ_INT(en_dot3_sign(c, knife[i]), 1);
    double knife3d[4][3] = {{1, 0, 0.25}, {-1, 0x1p-40, 0}, {1, 0x1p-41, -0.25}, {-1, 0x1p-40, 0x1p-45}};
    int h = gauss_in_open_hemisphere(knife3d, 4, c);
    CHECK_EQ_INT(gauss_origin_in_hull(knife3d, 4), 0);
    CHECK_EQ_INT(h, GAUSS_HEMI_CENTRE);
    for (int i = 0; i < 4 && h == GAUSS_HEMI_CENTRE; i++)
        CHECK_EQ_INT(en_dot3_sign(c, knife3d[i]), 1);
    /* a flat polygon (all normals ±0 apart) is in a hemisphere too */
    double flat[3][3] = {{0, 0, 1}, {0, 0, 2}, {0, 0, 1}};
    CHECK_EQ_INT(gauss_in_open_hemisphere(flat, 3, c), GAUSS_HEMI_CENTRE);
}

TEST(hemisphere_test_agrees_with_exact_hull_test_on_random_sets)
{
    int none = 0, centre = 0;
    for (int it = 0; it < 3000; it++) {
        size_t m = 3 + rnd() % 6;
        double nv[8][3], c[3];
        /* directions around a random axis with a random spread */
        double axis[3];
        rnd_direction(axis);
        double spread = 0.2 + 2.0 * (double)(rnd() % 1000) / 1000.0;
        for (size_t i = 0; i < m; i++) {
            double d[3];
            rnd_direction(d);
            for (int k = 0; k < 3; k++)
                nv[i][k] = axis[k] + spread * d[k];
        }
        int h = gauss_in_open_hemisphere(nv, m, c);
        int in_hull = gauss_origin_in_hull(nv, m);
        CHECK(h != GAUSS_HEMI_UNVERIFIED);
        CHECK_EQ_INT(h == GAUSS_HEMI_NONE, in_hull);
        none += h == GAUSS_HEMI_NONE;
        centre += h == GAUSS_HEMI_CENTRE;
    }
    CHECK(none > 300 && centre > 300);
}

TEST(vertices_near_returns_every_vertex_in_the_cap)
{
    for (int level = 0; level <= 5; level++) {
        gauss_rotation rot;
        gauss_rotation_identity(&rot);
        gauss_sphere g;
        gauss_init_level(&g, level, &rot);
        static int32_t xyz[20000][3];
        static uint32_t out[20000];
        for (int it = 0; it < 50; it++) {
            double c[3];
            rnd_direction(c);
            double cr = cos((double)(rnd() % 1800) / 1000.0);
            size_t got = gauss_vertices_near(&g, c, cr, xyz, 20000);
            CHECK(got <= 20000);
            for (size_t i = 0; i < got && i < 20000; i++)
                out[i] = gauss_vertex_id(&g, xyz[i][0], xyz[i][1], xyz[i][2]);
            int missing = 0;
            size_t inside = 0;
            double len = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
            for (uint32_t id = 0; id < g.nverts; id++) {
                double p[3];
                gauss_vertex_vector(&g, id, p);
                double pl = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
                double cosang = (p[0] * c[0] + p[1] * c[1] + p[2] * c[2]) / (pl * len);
                if (cosang < cr)
                    continue;
                inside++;
                int present = 0;
                for (size_t i = 0; i < got && !present; i++)
                    present = out[i] == id;
                missing += !present;
            }
            CHECK_EQ_INT(missing, 0);
            /* a superset, but not much of one: the slack is 1e-9 */
            CHECK(got <= inside + 2);
        }
    }
}

/* A polygon around a random axis: most corners random, some on lattice
 * directions or on the great arc between two lattice points (ties the
 * chart cannot call), with a random spread. */
static size_t rnd_polygon(const gauss_sphere *g, double nv[][3], int with_ties)
{
    size_t m = 3 + rnd() % 6;
    double axis[3];
    rnd_direction(axis);
    /* up to a few dozen Gaussian vertices across, at any frequency */
    double spread = (0.02 + (double)(rnd() % 1000) / 1000.0) * (g->n < 16 ? 1.0 : 16.0 / g->n);
    for (size_t i = 0; i < m; i++) {
        double d[3];
        rnd_direction(d);
        for (int k = 0; k < 3; k++)
            nv[i][k] = axis[k] + spread * d[k];
        if (with_ties && rnd() % 3 == 0) {
            /* snap to the lattice point nearest N n / |n|_1, or the mid
             * point of it and a neighbour */
            double l1 = fabs(nv[i][0]) + fabs(nv[i][1]) + fabs(nv[i][2]);
            int32_t p[3];
            for (int k = 0; k < 2; k++)
                p[k] = (int32_t)lround(nv[i][k] * g->n / l1);
            int32_t rest = (int32_t)g->n - abs(p[0]) - abs(p[1]);
            if (rest < 0)
                continue;
            p[2] = nv[i][2] < 0 ? -rest : rest;
            for (int k = 0; k < 3; k++)
                nv[i][k] = p[k];
            if (rnd() % 2 && p[0] != 0) {
                int32_t q[3] = {p[0] > 0 ? p[0] - 1 : p[0] + 1, p[1] >= 0 ? p[1] + 1 : p[1] - 1, p[2]};
                for (int k = 0; k < 3; k++)
                    nv[i][k] = p[k] + q[k];
            }
        }
    }
    return m;
}

TEST(enclosed_vertices_from_charts_are_exactly_those_the_winding_counts)
{
    static int32_t xyz[20000][3];
    static uint32_t ref[20000];
    double chart[8][2];
    long tested = 0, found = 0;
    for (int level = 0; level <= 14; level++) {
        gauss_rotation rot;
        if (level % 2)
            gauss_rotation_identity(&rot);
        else
            gauss_rotation_default(&rot);
        gauss_sphere g;
        gauss_init_level(&g, level, &rot);
        for (int it = 0; it < 400; it++) {
            double nv[8][3], centre[3];
            size_t m = rnd_polygon(&g, nv, it % 2);
            if (gauss_in_open_hemisphere((const double(*)[3])nv, m, centre) != GAUSS_HEMI_CENTRE)
                continue;
            double oct[3];
            int signs;
            if (gauss_in_one_octant((const double(*)[3])nv, m, oct, &signs))
                for (size_t i = 0; i < m; i++)
                    CHECK(oct[0] * nv[i][0] + oct[1] * nv[i][1] + oct[2] * nv[i][2] > 0);
            tested++;
            /* the reference: every vertex in the polygon's cap, exactly wound */
            double cl = sqrt(centre[0] * centre[0] + centre[1] * centre[1] + centre[2] * centre[2]), cr = 1.0;
            for (size_t i = 0; i < m; i++) {
                double nl = sqrt(nv[i][0] * nv[i][0] + nv[i][1] * nv[i][1] + nv[i][2] * nv[i][2]);
                double c = (nv[i][0] * centre[0] + nv[i][1] * centre[1] + nv[i][2] * centre[2]) / (nl * cl);
                cr = c < cr ? c : cr;
            }
            size_t nn = gauss_vertices_near(&g, centre, cr, xyz, 20000), nref = 0;
            CHECK(nn <= 20000);
            for (size_t i = 0; i < nn && i < 20000; i++)
                if (gauss_winding_at(&g, (const double(*)[3])nv, m, xyz[i], centre) != 0)
                    ref[nref++] = gauss_vertex_id(&g, xyz[i][0], xyz[i][1], xyz[i][2]);
            size_t got = gauss_vertices_enclosed(&g, (const double(*)[3])nv, m, signs, centre, chart, xyz, 20000);
            CHECK(got <= 20000);
            found += (long)got;
            CHECK_EQ_INT((int)got, (int)nref);
            for (size_t i = 0; i < got && i < 20000; i++) {
                uint32_t id = gauss_vertex_id(&g, xyz[i][0], xyz[i][1], xyz[i][2]);
                int present = 0;
                for (size_t j = 0; j < nref && !present; j++)
                    present = ref[j] == id;
                CHECK(present);
                for (size_t j = 0; j < i; j++) /* listed once */
                    CHECK(!(xyz[j][0] == xyz[i][0] && xyz[j][1] == xyz[i][1] && xyz[j][2] == xyz[i][2]));
            }
        }
    }
    CHECK(tested > 4000);
    CHECK(found > 1000);
}

int main(void)
{
    RUN(sphere_has_4n2_plus_2_vertices_and_is_a_closed_oriented_triangulation);
    RUN(every_random_normal_lies_in_exactly_one_triangle);
    RUN(normals_on_gaussian_vertices_and_edges_have_exactly_one_triangle);
    RUN(locate_is_exact_for_normals_that_nearly_touch_edges);
    RUN(default_rotation_keeps_axis_and_diagonal_normals_off_gaussian_edges);
    RUN(rotations_parse_and_reject_bad_values);
    RUN(convex_mesh_vertex_polygons_cover_every_gaussian_vertex_exactly_once);
    RUN(saddle_winds_minus_one_and_monkey_saddle_minus_two);
    RUN(needle_tip_normals_are_not_in_an_open_hemisphere);
    RUN(hemisphere_test_agrees_with_exact_hull_test_on_random_sets);
    RUN(vertices_near_returns_every_vertex_in_the_cap);
    RUN(enclosed_vertices_from_charts_are_exactly_those_the_winding_counts);
    return tl_finish();
}
