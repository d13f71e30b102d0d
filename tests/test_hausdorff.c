/*
 * The Metro-style error (src/metrics): the exact point-to-triangle routine
 * against brute force, the hierarchy against a linear scan, and the measure
 * on pairs whose answer is known in closed form: parallel squares, a shifted
 * square, concentric spheres, a tilted plane, zero-area triangles in either
 * mesh, identical meshes. The numbers must not depend on the thread count.
 */
#include <stdint.h>
#include <sys/wait.h>

#include "metrics/bvh.h"
#include "metrics/hausdorff.h"
#include "testlib.h"

#define DEG (180.0 / 3.14159265358979323846)

/* ---- small meshes built by hand ---- */

typedef struct hand_mesh {
    double xyz[3 * 32];
    uint32_t tri[3 * 32];
    uint32_t nv, nt;
} hand_mesh;

static uint32_t hm_vertex(hand_mesh *m, double x, double y, double z)
{
    m->xyz[3 * m->nv] = x;
    m->xyz[3 * m->nv + 1] = y;
    m->xyz[3 * m->nv + 2] = z;
    return m->nv++;
}

static void hm_face(hand_mesh *m, uint32_t a, uint32_t b, uint32_t c)
{
    m->tri[3 * m->nt] = a;
    m->tri[3 * m->nt + 1] = b;
    m->tri[3 * m->nt + 2] = c;
    m->nt++;
}

/*
 * The square [x0, x0+1] x [0, 1] at height z, normal +z:
 *
 *     3 ---- 2
 *     |  \   |     other_diagonal: 0-2 instead of 1-3
 *     |   \  |
 *     0 ---- 1
 */
static void hm_square(hand_mesh *m, double x0, double z, int other_diagonal)
{
    uint32_t v0 = hm_vertex(m, x0, 0, z), v1 = hm_vertex(m, x0 + 1, 0, z);
    uint32_t v2 = hm_vertex(m, x0 + 1, 1, z), v3 = hm_vertex(m, x0, 1, z);
    if (other_diagonal) {
        hm_face(m, v0, v1, v2);
        hm_face(m, v0, v2, v3);
    } else {
        hm_face(m, v0, v1, v3);
        hm_face(m, v1, v2, v3);
    }
}

static en_hd_mesh hm_view(const hand_mesh *m)
{
    en_hd_mesh v = { m->xyz, m->nv, m->tri, m->nt };
    return v;
}

static epsnet_hausdorff_settings dense(uint32_t per_face)
{
    epsnet_hausdorff_settings s;
    epsnet_hausdorff_default_settings(&s);
    s.samples_per_face = per_face;
    return s;
}

static int near(double got, double want, double tol)
{
    if (fabs(got - want) <= tol)
        return 1;
    fprintf(stderr, "  got %.17g, want %.17g +- %g\n", got, want, tol);
    return 0;
}

/* ---- generated meshes ---- */

typedef struct owned_mesh {
    double *xyz;
    uint32_t *tri;
    uint32_t nv, nt;
} owned_mesh;

static void om_free(owned_mesh *m)
{
    free(m->xyz);
    free(m->tri);
    memset(m, 0, sizeof *m);
}

static en_hd_mesh om_view(const owned_mesh *m)
{
    en_hd_mesh v = { m->xyz, m->nv, m->tri, m->nt };
    return v;
}

/* Generate a shape into a PLY file, read it back; returns the path. */
static const char *gen_file(const char *name, const char *shape, uint64_t faces, uint64_t seed)
{
    epsnet_error err;
    const char *path = tl_path(name);
    if (tl_gen_file(path, shape, faces, NAN, seed, 0, &err)) {
        fprintf(stderr, "gen %s: %s\n", shape, epsnet_error_message(&err));
        exit(2);
    }
    return path;
}

static owned_mesh gen_mesh(const char *shape, uint64_t faces, uint64_t seed)
{
    char name[64];
    snprintf(name, sizeof name, "%s-%llu-%llu.ply", shape, (unsigned long long)faces,
             (unsigned long long)seed);
    tl_mesh t;
    epsnet_error err;
    if (tl_read_mesh(gen_file(name, shape, faces, seed), &t, &err)) {
        fprintf(stderr, "read %s: %s\n", name, epsnet_error_message(&err));
        exit(2);
    }
    owned_mesh m = { malloc(3 * t.nv * sizeof(double)), malloc(3 * t.nt * sizeof(uint32_t)),
                     (uint32_t)t.nv, (uint32_t)t.nt };
    memcpy(m.xyz, t.xyz, 3 * t.nv * sizeof(double));
    for (uint64_t i = 0; i < 3 * t.nt; i++)
        m.tri[i] = (uint32_t)t.tri[i];
    tl_mesh_free(&t);
    return m;
}

/* ---- the point-to-triangle routine ---- */

static uint64_t rng_state = 12345;

static double urand(double lo, double hi)
{
    rng_state = rng_state * 6364136223846793005ULL + 1442695040888963407ULL;
    return lo + (hi - lo) * (double)(rng_state >> 11) * 0x1p-53;
}

static double d2(const double a[3], const double b[3])
{
    double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return x * x + y * y + z * z;
}

/* Nearest of a barycentric grid of (n+1)(n+2)/2 points on the triangle. */
static double brute_triangle(const double p[3], const double a[3], const double b[3], const double c[3], int n)
{
    double best = INFINITY;
    for (int i = 0; i <= n; i++)
        for (int j = 0; i + j <= n; j++) {
            double s = (double)i / n, t = (double)j / n, x[3];
            for (int k = 0; k < 3; k++)
                x[k] = a[k] + s * (b[k] - a[k]) + t * (c[k] - a[k]);
            double d = d2(p, x);
            best = d < best ? d : best;
        }
    return best;
}

/*
 * Random triangles, proper and degenerate (collinear with the third corner
 * inside or outside the segment, two corners coincident, all three
 * coincident, a sliver): the exact distance is never above the nearest grid
 * point, and never below it by more than the grid's spacing; the returned
 * point is where the returned distance says.
 */
TEST(closest_point_agrees_with_dense_sampling)
{
    const int grid = 200;
    int bad_low = 0, bad_high = 0, bad_point = 0;
    for (int iter = 0; iter < 400; iter++) {
        double a[3], b[3], c[3], p[3], q[3];
        for (int k = 0; k < 3; k++) {
            a[k] = urand(-1, 1);
            b[k] = urand(-1, 1);
            c[k] = urand(-1, 1);
            p[k] = urand(-2, 2);
        }
        switch (iter % 6) {
        case 1: for (int k = 0; k < 3; k++) c[k] = a[k] + 0.3 * (b[k] - a[k]); break;
        case 2: for (int k = 0; k < 3; k++) c[k] = a[k] + 1.7 * (b[k] - a[k]); break;
        case 3: memcpy(b, a, sizeof a); break;
        case 4: memcpy(b, a, sizeof a); memcpy(c, a, sizeof a); break;
        case 5: for (int k = 0; k < 3; k++) c[k] = 0.5 * (a[k] + b[k]) + (k == 0 ? 1e-7 : 0); break;
        default: break;
        }
        double got = en_closest_on_triangle(p, a, b, c, q);
        double brute = brute_triangle(p, a, b, c, grid);
        double lmax = sqrt(fmax(d2(a, b), fmax(d2(b, c), d2(c, a))));
        if (sqrt(got) > sqrt(brute) + 1e-12)
            bad_high++;
        if (sqrt(brute) > sqrt(got) + lmax / grid + 1e-12)
            bad_low++;
        if (d2(p, q) != got || sqrt(brute_triangle(q, a, b, c, grid)) > lmax / grid + 1e-12)
            bad_point++;
    }
    CHECK_EQ_INT(bad_high, 0);
    CHECK_EQ_INT(bad_low, 0);
    CHECK_EQ_INT(bad_point, 0);
}

/*
 * A zero-area triangle is exactly its segment or point. p sits right above
 * the middle of the collinear triangle (0,0,0) (1,0,0) (3,0,0) and beyond
 * its far end; a plane-projection routine would say 0 for the first.
 */
TEST(zero_area_triangles_are_segments_and_points)
{
    double a[3] = { 0, 0, 0 }, b[3] = { 1, 0, 0 }, c[3] = { 3, 0, 0 }, q[3];
    double above[3] = { 2, 0, 0.5 }, beyond[3] = { 4, 3, 0 };
    CHECK(en_tri_is_degenerate(a, b, c));
    CHECK(near(en_closest_on_triangle(above, a, b, c, q), 0.25, 0));
    CHECK(near(q[0], 2, 0) && q[1] == 0 && q[2] == 0);
    CHECK(near(en_closest_on_triangle(beyond, a, b, c, q), 10, 1e-15));
    double pt[3] = { 1, 2, 3 }, far[3] = { 1, 2, 5 };
    CHECK(near(en_closest_on_triangle(far, pt, pt, pt, q), 4, 0));
    double proper_c[3] = { 0, 1, 0 };
    CHECK(!en_tri_is_degenerate(a, b, proper_c));
}

/* ---- the hierarchy ---- */

/* A soup of small random triangles, some of them degenerate; every query of
 * the hierarchy finds the same squared distance as a scan of all of them. */
TEST(bvh_nearest_equals_linear_scan)
{
    enum { NT = 3000 };
    double *xyz = malloc(9 * NT * sizeof *xyz);
    uint32_t *tri = malloc(3 * NT * sizeof *tri);
    for (uint32_t t = 0; t < NT; t++) {
        double base[3] = { urand(0, 1), urand(0, 1), urand(0, 0.2) };
        for (int c = 0; c < 3; c++) {
            for (int k = 0; k < 3; k++)
                xyz[9 * t + 3 * c + k] = base[k] + urand(-0.03, 0.03);
            tri[3 * t + c] = 3 * t + c;
        }
        if (t % 50 == 0)
            memcpy(xyz + 9 * t + 6, xyz + 9 * t + 3, 3 * sizeof *xyz);
    }
    en_bvh bvh;
    CHECK_EQ_INT(en_bvh_build(&bvh, xyz, tri, NT), 0);
    int mismatches = 0, bad_face = 0;
    uint32_t hint = UINT32_MAX;
    for (int i = 0; i < 2000; i++) {
        double p[3] = { urand(-0.2, 1.2), urand(-0.2, 1.2), urand(-0.3, 0.5) }, q[3];
        double best = INFINITY;
        for (uint32_t t = 0; t < NT; t++) {
            double d = en_closest_on_triangle(p, xyz + 9 * t, xyz + 9 * t + 3, xyz + 9 * t + 6, q);
            best = d < best ? d : best;
        }
        double up[3] = { 0, 0, 1 };
        en_bvh_hit hit;
        CHECK_EQ_INT(en_bvh_nearest(&bvh, p, hint, i % 2 ? up : NULL, 0, &hit), 0);
        hint = i % 3 ? hit.slot : UINT32_MAX;
        mismatches += hit.d2 != best;
        double face_d2 = en_closest_on_triangle(p, xyz + 9 * hit.face, xyz + 9 * hit.face + 3,
                                                xyz + 9 * hit.face + 6, q);
        bad_face += face_d2 != best;
    }
    CHECK_EQ_INT(mismatches, 0);
    CHECK_EQ_INT(bad_face, 0);
    en_bvh_free(&bvh);
    free(xyz);
    free(tri);
}

/*
 * A roof: two faces meet at the ridge y = 0, z = 1, sloping down to either
 * side. A point right above the ridge is equally near both; the normal rule
 * takes the face whose normal agrees with the preferred direction.
 *
 *        0,1 ridge
 *       /    \
 *   face 0  face 1
 */
TEST(ridge_tie_takes_the_face_that_agrees)
{
    hand_mesh m = { 0 };
    uint32_t r0 = hm_vertex(&m, 0, 0, 1), r1 = hm_vertex(&m, 1, 0, 1);
    uint32_t l0 = hm_vertex(&m, 0, -1, 0), l1 = hm_vertex(&m, 1, -1, 0);
    uint32_t g0 = hm_vertex(&m, 0, 1, 0), g1 = hm_vertex(&m, 1, 1, 0);
    hm_face(&m, l0, l1, r1); /* rises toward +y: normal (0, -1, 1)/sqrt2 */
    hm_face(&m, l0, r1, r0);
    hm_face(&m, r0, r1, g1); /* falls toward +y: normal (0, 1, 1)/sqrt2 */
    hm_face(&m, r0, g1, g0);
    en_bvh bvh;
    CHECK_EQ_INT(en_bvh_build(&bvh, m.xyz, m.tri, m.nt), 0);
    double p[3] = { 0.5, 0, 2 };
    double toward_minus_y[3] = { 0, -0.6, 0.8 }, toward_plus_y[3] = { 0, 0.6, 0.8 };
    en_bvh_hit hit;
    en_bvh_nearest(&bvh, p, UINT32_MAX, toward_minus_y, 1e-10, &hit);
    CHECK(near(hit.d2, 1, 0));
    CHECK(hit.face == 0 || hit.face == 1);
    CHECK(near(hit.face_dot, (0.6 + 0.8) / sqrt(2.0), 1e-15));
    en_bvh_nearest(&bvh, p, UINT32_MAX, toward_plus_y, 1e-10, &hit);
    CHECK(hit.face == 2 || hit.face == 3);
    en_bvh_free(&bvh);
}

/* ---- the measure, known answers ---- */

/* Two unit squares d apart, triangulated along different diagonals: every
 * sample is exactly d away both ways, and the normals agree. */
TEST(parallel_squares_are_d_apart_everywhere)
{
    const double d = 0.375;
    hand_mesh a = { 0 }, b = { 0 };
    hm_square(&a, 0, 0, 0);
    hm_square(&b, 0, d, 1);
    en_hd_mesh va = hm_view(&a), vb = hm_view(&b);
    epsnet_hausdorff_settings s = dense(10);
    epsnet_hausdorff_result r;
    CHECK_EQ_INT(en_hausdorff(&va, &vb, &s, &r), 0);
    const epsnet_hausdorff_side *side[2] = { &r.a_to_b, &r.b_to_a };
    for (int i = 0; i < 2; i++) {
        CHECK(near(side[i]->max, d, 1e-15));
        CHECK(near(side[i]->mean, d, 1e-15));
        CHECK(near(side[i]->rms, d, 1e-15));
        CHECK(near(side[i]->normal_max, 0, 1e-12));
        CHECK(near(side[i]->area, 1, 1e-15));
        CHECK(side[i]->normal_samples >= 20);
        /* 4 vertices, 5 edges of spacing-limited points, about 20 face points */
        CHECK(side[i]->samples >= 24);
    }
    CHECK(near(r.hausdorff, d, 1e-15));
    CHECK(near(r.diagonal, sqrt(2.0), 1e-15));
    CHECK_EQ_U64(r.a_faces, 2);
    CHECK_EQ_U64(r.a_zero_area_faces, 0);
}

/* The same parallel squares scaled to the largest coordinates the files
 * API accepts (1e75: the zero-area test squares squared lengths) and down
 * to 1e-60: still proper triangles, still exactly d apart. */
TEST(parallel_squares_at_extreme_scales)
{
    const double scales[] = { 1e75, 1e-60 };
    for (int i = 0; i < 2; i++) {
        hand_mesh a = { 0 }, b = { 0 };
        hm_square(&a, 0, 0, 0);
        hm_square(&b, 0, 0.375, 1);
        for (uint32_t v = 0; v < 4; v++)
            for (int k = 0; k < 3; k++) {
                a.xyz[3 * v + k] *= scales[i];
                b.xyz[3 * v + k] *= scales[i];
            }
        en_hd_mesh va = hm_view(&a), vb = hm_view(&b);
        epsnet_hausdorff_settings s = dense(10);
        epsnet_hausdorff_result r;
        CHECK_EQ_INT(en_hausdorff(&va, &vb, &s, &r), 0);
        CHECK_EQ_U64(r.a_zero_area_faces, 0);
        CHECK(near(r.a_to_b.max / scales[i], 0.375, 1e-15));
        CHECK(near(r.b_to_a.mean / scales[i], 0.375, 1e-15));
        CHECK(near(r.a_to_b.normal_max, 0, 1e-12));
    }
}

/*
 * The unit square against itself shifted by s along x:
 *
 *     A: [0,1] x [0,1]      B: [s,1+s] x [0,1]
 *
 * A point of A at x < s is s - x from B, the rest is on B. So max = s,
 * mean = integral of (s - x) over x in [0, s] = s^2/2, rms = sqrt(s^3/3),
 * the same both ways. The estimate's error: one jittered point per cell of
 * diameter ~1/sqrt(k) with k = 50000 points per face, on a 1-Lipschitz
 * function, has a standard deviation below 2e-5; 1e-4 is over 5 of them
 * (and the run is deterministic: this is a bound, not a flake margin).
 */
TEST(shifted_square_has_closed_form_errors)
{
    const double shift = 0.25;
    hand_mesh a = { 0 }, b = { 0 };
    hm_square(&a, 0, 0, 0);
    hm_square(&b, shift, 0, 0);
    en_hd_mesh va = hm_view(&a), vb = hm_view(&b);
    epsnet_hausdorff_settings s = dense(50000);
    epsnet_hausdorff_result r;
    CHECK_EQ_INT(en_hausdorff(&va, &vb, &s, &r), 0);
    const epsnet_hausdorff_side *side[2] = { &r.a_to_b, &r.b_to_a };
    for (int i = 0; i < 2; i++) {
        CHECK(near(side[i]->max, shift, 1e-15));
        CHECK(near(side[i]->mean, shift * shift / 2, 1e-4));
        CHECK(near(side[i]->rms, sqrt(shift * shift * shift / 3), 1e-4));
        CHECK(near(side[i]->normal_max, 0, 1e-12));
    }
    CHECK(near(r.hausdorff, shift, 1e-15));
}

/* A tent over the unit square: B's apex is the one point at the worst
 * distance, and max_at names it. */
TEST(the_worst_distance_is_found_where_it_is)
{
    const double h = 0.125;
    hand_mesh a = { 0 }, b = { 0 };
    hm_square(&a, 0, 0, 0);
    uint32_t c[4] = { hm_vertex(&b, 0, 0, 0), hm_vertex(&b, 1, 0, 0), hm_vertex(&b, 1, 1, 0), hm_vertex(&b, 0, 1, 0) };
    uint32_t apex = hm_vertex(&b, 0.5, 0.5, h);
    for (int k = 0; k < 4; k++)
        hm_face(&b, c[k], c[(k + 1) % 4], apex);
    en_hd_mesh va = hm_view(&a), vb = hm_view(&b);
    epsnet_hausdorff_settings s = dense(100);
    epsnet_hausdorff_result r;
    CHECK_EQ_INT(en_hausdorff(&va, &vb, &s, &r), 0);
    CHECK(near(r.b_to_a.max, h, 1e-15));
    CHECK(r.b_to_a.max_at[0] == 0.5 && r.b_to_a.max_at[1] == 0.5 && r.b_to_a.max_at[2] == h);
    /* from A the worst is under the apex, on B's faces: within the square */
    CHECK(r.a_to_b.max_at[2] == 0);
    CHECK(r.a_to_b.max_at[0] >= 0 && r.a_to_b.max_at[0] <= 1 && r.a_to_b.max_at[1] >= 0 && r.a_to_b.max_at[1] <= 1);
}

/*
 * Concentric spheres: the generator's sphere (a convex polyhedron) and the
 * same scaled by 1.1. With R_in the smallest distance from the centre to a
 * face plane and R_out the largest vertex radius, every point of either
 * surface lies between them (times 1.1 for B), so every distance, both
 * ways, is in [1.1 R_in - R_out, 1.1 R_out - R_in]: 0.1 up to faceting.
 */
TEST(concentric_spheres_are_a_tenth_apart_up_to_faceting)
{
    owned_mesh a = gen_mesh("sphere", 20000, 1);
    owned_mesh b = { malloc(3 * a.nv * sizeof(double)), malloc(3 * a.nt * sizeof(uint32_t)), a.nv, a.nt };
    memcpy(b.tri, a.tri, 3 * a.nt * sizeof(uint32_t));
    double r_out = 0, r_in = INFINITY;
    for (uint32_t v = 0; v < a.nv; v++) {
        for (int k = 0; k < 3; k++)
            b.xyz[3 * v + k] = 1.1 * a.xyz[3 * v + k];
        r_out = fmax(r_out, sqrt(d2(a.xyz + 3 * v, (double[3]){ 0, 0, 0 })));
    }
    for (uint32_t t = 0; t < a.nt; t++) {
        const double *p0 = a.xyz + 3 * a.tri[3 * t], *p1 = a.xyz + 3 * a.tri[3 * t + 1];
        const double *p2 = a.xyz + 3 * a.tri[3 * t + 2];
        double u[3], w[3], n[3];
        for (int k = 0; k < 3; k++) {
            u[k] = p1[k] - p0[k];
            w[k] = p2[k] - p0[k];
        }
        n[0] = u[1] * w[2] - u[2] * w[1];
        n[1] = u[2] * w[0] - u[0] * w[2];
        n[2] = u[0] * w[1] - u[1] * w[0];
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len > 0)
            r_in = fmin(r_in, fabs(n[0] * p0[0] + n[1] * p0[1] + n[2] * p0[2]) / len);
    }
    double lo = 1.1 * r_in - r_out - 1e-12, hi = 1.1 * r_out - r_in + 1e-12;
    CHECK(hi - lo < 0.002); /* the bracket is tight enough to mean something */
    en_hd_mesh va = om_view(&a), vb = om_view(&b);
    epsnet_hausdorff_settings s = dense(10);
    epsnet_hausdorff_result r;
    CHECK_EQ_INT(en_hausdorff(&va, &vb, &s, &r), 0);
    const epsnet_hausdorff_side *side[2] = { &r.a_to_b, &r.b_to_a };
    for (int i = 0; i < 2; i++) {
        CHECK(side[i]->max >= lo && side[i]->max <= hi);
        CHECK(side[i]->mean >= lo && side[i]->mean <= hi);
        CHECK(side[i]->rms >= lo && side[i]->rms <= hi);
    }
    CHECK(near(r.hausdorff, 0.1, hi - 0.1));
    CHECK(near(r.diagonal, 2 * sqrt(3.0), 0.01));
    om_free(&a);
    om_free(&b);
}

/*
 * A plane against a plane tilted by 20 degrees about the x axis (lifted
 * above it so they do not cross): every face point, either way, sees the
 * other plane's normal at 20 degrees.
 */
TEST(tilted_plane_normal_deviation_is_the_tilt)
{
    const double tilt = 20 / DEG;
    hand_mesh a = { 0 }, b = { 0 };
    hm_square(&a, 0, 0, 0);
    uint32_t v0 = hm_vertex(&b, 0, 0, 1), v1 = hm_vertex(&b, 1, 0, 1);
    uint32_t v2 = hm_vertex(&b, 1, cos(tilt), 1 + sin(tilt)), v3 = hm_vertex(&b, 0, cos(tilt), 1 + sin(tilt));
    hm_face(&b, v0, v1, v2);
    hm_face(&b, v0, v2, v3);
    en_hd_mesh va = hm_view(&a), vb = hm_view(&b);
    epsnet_hausdorff_settings s = dense(100);
    epsnet_hausdorff_result r;
    CHECK_EQ_INT(en_hausdorff(&va, &vb, &s, &r), 0);
    CHECK(near(r.a_to_b.normal_max, 20, 1e-9));
    CHECK(near(r.a_to_b.normal_mean, 20, 1e-9));
    CHECK(near(r.b_to_a.normal_max, 20, 1e-9));
    CHECK(near(r.b_to_a.normal_mean, 20, 1e-9));
    CHECK(r.a_to_b.normal_samples >= 200 && r.b_to_a.normal_samples >= 200);
    /* B's top edge is 1 + sin(20°) above A's far edge y = cos(20°) */
    CHECK(near(r.b_to_a.max, 1 + sin(tilt), 1e-15));
}

/* Mean over the unit square at height h of sqrt((y-1/2)^2 + h^2):
 * 2 * integral_0^(1/2) sqrt(u^2 + h^2) du in closed form. */
static double mean_distance_to_midline(double h)
{
    double u = 0.5, r = sqrt(u * u + h * h);
    return 2 * (u * r / 2 + h * h / 2 * log((u + r) / h));
}

/*
 * B = the unit square at z = 0 plus a collinear triangle along y = 1/2 at
 * z = 1/2 (a segment from x = 0 to 1); A = the unit square at z = 1:
 *
 *     z=1   A ==========
 *     z=.5      ----- (B's segment, seen end-on: the line y = 1/2)
 *     z=0   B ==========
 *
 * A point of A is sqrt((y-1/2)^2 + 1/4) from the segment, nearer than B's
 * square: the segment counts, as a segment (neither "distance 0 to all" nor
 * ignored). B's square is 1 from A, its segment 1/2 (no area, so the mean
 * is the square's).
 */
TEST(collinear_triangle_in_b_is_its_segment)
{
    hand_mesh a = { 0 }, b = { 0 };
    hm_square(&a, 0, 1, 0);
    hm_square(&b, 0, 0, 0);
    uint32_t s0 = hm_vertex(&b, 0, 0.5, 0.5), s1 = hm_vertex(&b, 0.5, 0.5, 0.5);
    uint32_t s2 = hm_vertex(&b, 1, 0.5, 0.5);
    hm_face(&b, s0, s2, s1);
    en_hd_mesh va = hm_view(&a), vb = hm_view(&b);
    epsnet_hausdorff_settings s = dense(50000);
    epsnet_hausdorff_result r;
    CHECK_EQ_INT(en_hausdorff(&va, &vb, &s, &r), 0);
    CHECK(near(r.a_to_b.max, sqrt(0.5), 1e-15));
    CHECK(near(r.a_to_b.mean, mean_distance_to_midline(0.5), 1e-4));
    /* the nearest feature is a segment: no normal to compare with */
    CHECK_EQ_U64(r.a_to_b.normal_samples, 0);
    CHECK(near(r.b_to_a.max, 1, 1e-15));
    CHECK(near(r.b_to_a.mean, 1, 1e-15));
    CHECK_EQ_U64(r.b_zero_area_faces, 1);
    CHECK(near(r.b_to_a.area, 1, 1e-15));
}

/*
 * B = the unit square at z = 0 plus a triangle whose corners coincide at
 * c = (1/2, 1/2, 4/5), once as one index repeated and once as three
 * vertices with equal coordinates; A = the unit square at z = 1. A point of
 * A is |p - c| from B, 0.2 at the middle and sqrt(0.54) at the corners;
 * the mean is checked against a midpoint-rule integral on a 1000^2 grid.
 */
TEST(coincident_triangle_in_b_is_its_point)
{
    double brute = 0;
    for (int i = 0; i < 1000; i++)
        for (int j = 0; j < 1000; j++) {
            double x = (i + 0.5) / 1000 - 0.5, y = (j + 0.5) / 1000 - 0.5;
            brute += sqrt(x * x + y * y + 0.04);
        }
    brute /= 1e6;
    for (int repeated = 0; repeated < 2; repeated++) {
        hand_mesh a = { 0 }, b = { 0 };
        hm_square(&a, 0, 1, 0);
        hm_square(&b, 0, 0, 0);
        uint32_t c0 = hm_vertex(&b, 0.5, 0.5, 0.8);
        if (repeated) {
            hm_face(&b, c0, c0, c0);
        } else {
            uint32_t c1 = hm_vertex(&b, 0.5, 0.5, 0.8), c2 = hm_vertex(&b, 0.5, 0.5, 0.8);
            hm_face(&b, c0, c1, c2);
        }
        en_hd_mesh va = hm_view(&a), vb = hm_view(&b);
        epsnet_hausdorff_settings s = dense(50000);
        epsnet_hausdorff_result r;
        CHECK_EQ_INT(en_hausdorff(&va, &vb, &s, &r), 0);
        CHECK(near(r.a_to_b.max, sqrt(0.54), 1e-15));
        CHECK(near(r.a_to_b.mean, brute, 1e-4));
        CHECK(near(r.b_to_a.max, 1, 1e-15));
        CHECK(near(r.b_to_a.mean, 1, 1e-15));
        CHECK_EQ_U64(r.b_zero_area_faces, 1);
    }
}

/*
 * A = the unit square at z = 0 plus a collinear triangle (a segment along
 * y = 1/2) hanging at z = -2; B = the unit square at z = 1. The segment is
 * sampled along its edges, so A -> B reaches 3; it has no area, so the
 * mean stays the square's 1.
 */
TEST(zero_area_triangle_in_a_is_sampled_as_its_edges)
{
    hand_mesh a = { 0 }, b = { 0 };
    hm_square(&a, 0, 0, 0);
    uint32_t s0 = hm_vertex(&a, 0, 0.5, -2), s1 = hm_vertex(&a, 0.5, 0.5, -2), s2 = hm_vertex(&a, 1, 0.5, -2);
    hm_face(&a, s0, s1, s2);
    hm_square(&b, 0, 1, 1);
    en_hd_mesh va = hm_view(&a), vb = hm_view(&b);
    epsnet_hausdorff_settings s = dense(10);
    epsnet_hausdorff_result r;
    CHECK_EQ_INT(en_hausdorff(&va, &vb, &s, &r), 0);
    CHECK(near(r.a_to_b.max, 3, 1e-15));
    CHECK(near(r.a_to_b.mean, 1, 1e-15));
    CHECK(near(r.b_to_a.max, 1, 1e-15));
    CHECK_EQ_U64(r.a_zero_area_faces, 1);
    CHECK(near(r.a_to_b.area, 1, 1e-15));
    CHECK(near(r.diagonal, sqrt(1 + 1 + 4.0), 1e-15));
}

/* A mesh against itself: every sample lies on the other surface (up to the
 * rounding of a point computed inside a triangle) and meets its own face's
 * normal. */
TEST(identical_meshes_measure_zero)
{
    owned_mesh a = gen_mesh("bumpy", 5000, 1);
    en_hd_mesh va = om_view(&a);
    epsnet_hausdorff_settings s = dense(10);
    epsnet_hausdorff_result r;
    CHECK_EQ_INT(en_hausdorff(&va, &va, &s, &r), 0);
    CHECK(r.hausdorff <= 1e-14 * r.diagonal);
    CHECK(r.a_to_b.mean <= 1e-15 * r.diagonal);
    CHECK(r.a_to_b.normal_max == 0 && r.b_to_a.normal_max == 0);
    CHECK_EQ_U64(r.a_to_b.normal_samples, r.b_to_a.normal_samples);
    CHECK(r.a_to_b.samples > 10 * (uint64_t)a.nt);
    om_free(&a);
}

/* Different surfaces, many chunks: every thread count gives the same bits,
 * and so does a second run. A different seed moves the jitter, so the mean
 * changes (slightly). */
TEST(thread_count_does_not_change_a_bit)
{
    owned_mesh a = gen_mesh("bumpy", 6000, 1), b = gen_mesh("bumpy", 6000, 2);
    en_hd_mesh va = om_view(&a), vb = om_view(&b);
    epsnet_hausdorff_result ref, r;
    epsnet_hausdorff_settings s = dense(10);
    s.threads = 1;
    CHECK_EQ_INT(en_hausdorff(&va, &vb, &s, &ref), 0);
    CHECK(ref.a_to_b.max > 0 && ref.a_to_b.mean > 0);
    int threads[] = { 1, 2, 3, 8 };
    for (int i = 0; i < 4; i++) {
        s.threads = threads[i];
        CHECK_EQ_INT(en_hausdorff(&va, &vb, &s, &r), 0);
        CHECK(memcmp(&r, &ref, sizeof r) == 0);
    }
    s.seed = 2;
    CHECK_EQ_INT(en_hausdorff(&va, &vb, &s, &r), 0);
    CHECK(r.a_to_b.mean != ref.a_to_b.mean);
    CHECK(near(r.a_to_b.mean, ref.a_to_b.mean, 0.01 * ref.a_to_b.mean));
    om_free(&a);
    om_free(&b);
}

TEST(bad_settings_and_one_empty_mesh_are_refused)
{
    hand_mesh a = { 0 }, empty = { 0 };
    hm_square(&a, 0, 0, 0);
    hm_vertex(&empty, 0, 0, 0);
    en_hd_mesh va = hm_view(&a), ve = hm_view(&empty);
    epsnet_hausdorff_settings s = dense(0);
    epsnet_hausdorff_result r;
    CHECK_EQ_INT(en_hausdorff(&va, &va, &s, &r), EPSNET_EINVAL);
    s = dense(100001);
    CHECK_EQ_INT(en_hausdorff(&va, &va, &s, &r), EPSNET_EINVAL);
    s = dense(10);
    CHECK_EQ_INT(en_hausdorff(&va, &ve, &s, &r), EPSNET_EINVAL);
    CHECK_EQ_INT(en_hausdorff(&ve, &va, &s, &r), EPSNET_EINVAL);
    CHECK_EQ_INT(en_hausdorff(&ve, &ve, &s, &r), 0);
    CHECK(r.hausdorff == 0 && r.a_to_b.samples == 0);
}

/* ---- the public API on files ---- */

/*
 * OBJ quad (two triangles after triangulation) against an OFF quad half a
 * unit above; one-line errors for a missing file and for a face-less mesh.
 */
TEST(files_are_read_through_the_public_reader)
{
    const char *a = tl_write_str("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    const char *b = tl_write_str("quad.off", "OFF\n4 1 0\n0 0 0.5\n1 0 0.5\n1 1 0.5\n0 1 0.5\n4 0 1 2 3\n");
    const char *pts = tl_write_str("points.off", "OFF\n2 0 0\n0 0 0\n1 1 1\n");
    epsnet_hausdorff_result r;
    epsnet_error err;
    CHECK_EQ_INT(epsnet_hausdorff_files(a, b, NULL, &r, &err), 0);
    CHECK_EQ_U64(r.a_faces, 2);
    CHECK_EQ_U64(r.b_faces, 2);
    CHECK_EQ_U64(r.a_vertices, 4);
    CHECK(near(r.hausdorff, 0.5, 1e-15));
    CHECK(near(r.a_to_b.mean, 0.5, 1e-15));

    const char *json = tl_path("r.json");
    CHECK_EQ_INT(epsnet_hausdorff_write_json(&r, a, "b \"quoted\"", json, &err), 0);
    FILE *f = fopen(json, "rb");
    char text[4096] = { 0 };
    if (f) {
        size_t n = fread(text, 1, sizeof text - 1, f);
        text[n] = '\0';
        fclose(f);
    }
    CHECK_STR_CONTAINS(text, "\"hausdorff\": 0.5,");
    CHECK_STR_CONTAINS(text, "\"hausdorff_relative\": 0.353553391,");
    CHECK_STR_CONTAINS(text, "\"path\": \"b \\\"quoted\\\"\"");
    CHECK_STR_CONTAINS(text, "\"a_to_b\": {\"max\": 0.5,");

    CHECK_EQ_INT(epsnet_hausdorff_files(a, pts, NULL, &r, &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "points.off");
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "no faces");
    CHECK(epsnet_hausdorff_files(tl_path("missing.ply"), b, NULL, &r, &err) < 0);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "missing.ply");
    const char *huge = tl_write_str("huge.obj", "v 0 0 0\nv 1e200 0 0\nv 0 1 0\nf 1 2 3\n");
    CHECK_EQ_INT(epsnet_hausdorff_files(huge, b, NULL, &r, &err), EPSNET_EUNSUPPORTED);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "huge.obj");
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "vertex 2");
}

/* The command line: a table on stdout, exit codes by failure class. */
TEST(command_line_prints_the_table_and_exit_codes)
{
    const char *bin = getenv("EPSNET_BIN");
    if (!bin || !tl_exists(bin)) {
        printf("  (EPSNET_BIN not set: command line not tested)\n");
        return;
    }
    const char *a = tl_write_str("cli_a.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    const char *b = tl_write_str("cli_b.obj", "v 0 0 2\nv 1 0 2\nv 1 1 2\nv 0 1 2\nf 1 2 3 4\n");
    const char *out = tl_path("cli.txt");
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "'%s' hausdorff '%s' '%s' -j 2 --samples-per-face 5 > '%s' 2>&1", bin, a, b, out);
    CHECK_EQ_INT(system(cmd), 0);
    FILE *f = fopen(out, "rb");
    char text[4096] = { 0 };
    if (f) {
        size_t n = fread(text, 1, sizeof text - 1, f);
        text[n] = '\0';
        fclose(f);
    }
    CHECK_STR_CONTAINS(text, "A -> B     2 ");
    CHECK_STR_CONTAINS(text, "symmetric  2 ");
    snprintf(cmd, sizeof cmd, "'%s' hausdorff '%s' > /dev/null 2>&1", bin, a);
    int rc = system(cmd);
    CHECK(WIFEXITED(rc) && WEXITSTATUS(rc) == 1);
    snprintf(cmd, sizeof cmd, "'%s' hausdorff '%s' '%s' > /dev/null 2>&1", bin, a, tl_path("nope.ply"));
    rc = system(cmd);
    CHECK(WIFEXITED(rc) && WEXITSTATUS(rc) == 3);
}

int main(void)
{
    RUN(closest_point_agrees_with_dense_sampling);
    RUN(zero_area_triangles_are_segments_and_points);
    RUN(bvh_nearest_equals_linear_scan);
    RUN(ridge_tie_takes_the_face_that_agrees);
    RUN(parallel_squares_are_d_apart_everywhere);
    RUN(parallel_squares_at_extreme_scales);
    RUN(shifted_square_has_closed_form_errors);
    RUN(the_worst_distance_is_found_where_it_is);
    RUN(concentric_spheres_are_a_tenth_apart_up_to_faceting);
    RUN(tilted_plane_normal_deviation_is_the_tilt);
    RUN(collinear_triangle_in_b_is_its_segment);
    RUN(coincident_triangle_in_b_is_its_point);
    RUN(zero_area_triangle_in_a_is_sampled_as_its_edges);
    RUN(identical_meshes_measure_zero);
    RUN(thread_count_does_not_change_a_bit);
    RUN(bad_settings_and_one_empty_mesh_are_refused);
    RUN(files_are_read_through_the_public_reader);
    RUN(command_line_prints_the_table_and_exit_codes);
    tl_cleanup();
    return tl_finish();
}
