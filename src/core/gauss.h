/*
 * The Gaussian sphere G (paper §3.3, docs/method.md §2) in its own frame.
 *
 * The paper's sphere — an octahedron whose triangles are split into four L
 * times, projected onto the unit sphere — is the radial projection of the
 * flat triangular grid of frequency N = 2^L on the octahedron
 * |x| + |y| + |z| = N. Its vertices are the integer points on that surface
 * (4N^2 + 2 of them), its triangles the 8N^2 grid triangles, and its edges
 * are great arcs, the projections of the straight grid edges. Nothing is ever
 * normalised: every test is the sign of a determinant or dot product, which
 * positive scaling does not change, so G's vertices stay exact small integers.
 * Any frequency N >= 1 is allowed (N = 2^L gives the paper's levels; other N
 * give the finer "4n^2 + 2" control of --frequency, docs/method.md §2).
 *
 * Ids. Vertex ids run over the layers z = N, N-1, ..., -N; within a layer,
 * the ring |x| + |y| = N - |z| is walked counter-clockwise (seen from +z)
 * starting at (r, 0). Triangle ids are octant * N^2 + the index in the
 * octant's face, octant = (x<0) | (y<0) << 1 | (z<0) << 2. Both maps are O(1).
 * A triangle's three vertex ids are counter-clockwise seen from outside
 * (det(v0, v1, v2) > 0).
 *
 * Rotation. G is rotated by R; a face normal n enters G's frame as
 * n_G = R^T n, computed by gauss_to_frame() with one fixed formula. That
 * rounded vector is the normal every exact predicate sees, so face
 * association and sampling are exact with respect to it and identical on
 * every platform.
 *
 * Ties are broken by the symbolic perturbation of predicates.h, so every
 * non-zero normal lies in exactly one triangle, and on a convex mesh every
 * Gaussian vertex is enclosed by exactly one vertex polygon.
 *
 * No function here allocates; the sphere is a handful of numbers.
 */
#ifndef EN_CORE_GAUSS_H
#define EN_CORE_GAUSS_H

#include <stddef.h>
#include <stdint.h>

/* Largest frequency: 8 N^2 triangle ids must fit in 32 bits. */
#define GAUSS_MAX_FREQUENCY 16384u
/* Largest paper level, N = 2^L. */
#define GAUSS_MAX_LEVEL 14

/* A rotation of G; rt = R^T, so rt[r] is the r-th column of R. */
typedef struct gauss_rotation {
    double rt[3][3];
} gauss_rotation;

/* Immutable after gauss_init(): threads may share one read-only. */
typedef struct gauss_sphere {
    uint32_t n;        /* frequency N */
    uint32_t nverts;   /* 4 N^2 + 2 */
    uint32_t ntris;    /* 8 N^2 */
    gauss_rotation rot;
} gauss_sphere;

/* ---- rotations ---- */

void gauss_rotation_identity(gauss_rotation *r);

/*
 * The documented default: axis (0.2718281828, 0.5772156649, 0.7853981634)
 * (digits of e, the Euler–Mascheroni constant and pi/4), angle 41.4213562°
 * (digits of sqrt 2). Neither the axis nor the angle is related to the
 * coordinate axes or to the octahedron's symmetries, so the normals of
 * axis-aligned planes (±e_x, ±e_y, ±e_z) and of 45° planes do not fall on
 * Gaussian vertices or edges (test_gauss.c checks this for levels 0..8), and
 * CAD-like meshes get no ties at all.
 */
void gauss_rotation_default(gauss_rotation *r);

/* Rotation by deg degrees about axis (ax, ay, az) (right-hand rule).
 * @return 0, or EPSNET_EINVAL for a zero or non-finite axis or angle. */
int gauss_rotation_axis_angle(double ax, double ay, double az, double deg, gauss_rotation *r);

/* Rotation of the quaternion w + xi + yj + zk (normalised here).
 * @return 0, or EPSNET_EINVAL for a zero or non-finite quaternion. */
int gauss_rotation_quaternion(double w, double x, double y, double z, gauss_rotation *r);

/*
 * Uniformly random rotation from a seed: a splitmix64 stream gives three
 * uniform numbers u1, u2, u3 in [0, 1) (53 bits each), and Shoemake's method
 * (Graphics Gems III, "Uniform random rotations") maps them to a unit
 * quaternion uniformly distributed on S^3:
 *   (sqrt(1-u1) sin 2pi u2, sqrt(1-u1) cos 2pi u2, sqrt(u1) sin 2pi u3, sqrt(u1) cos 2pi u3).
 */
void gauss_rotation_from_seed(uint64_t seed, gauss_rotation *r);

/* Rotation of ε-net pass `pass` >= 2 (paper §5: each pass re-samples under a
 * new rotation), derived from the seed so that runs are repeatable. */
void gauss_pass_rotation(uint64_t seed, int pass, gauss_rotation *r);

/*
 * Parse a --rotation value: "identity", "default", "ax,ay,az,deg" (axis and
 * angle in degrees) or "q:w,x,y,z" (quaternion).
 * @return 0, or EPSNET_EINVAL (r unchanged).
 */
int gauss_rotation_parse(const char *text, gauss_rotation *r);

/* ---- the sphere ---- */

/* @return 0, or EPSNET_EINVAL unless 1 <= n <= GAUSS_MAX_FREQUENCY. */
int gauss_init(gauss_sphere *g, uint32_t n, const gauss_rotation *r);

/* Same for the paper's level L (N = 2^L, 0 <= L <= GAUSS_MAX_LEVEL). */
int gauss_init_level(gauss_sphere *g, int level, const gauss_rotation *r);

/* Lattice point (x, y, z), |x|+|y|+|z| = N -> vertex id (no check). */
uint32_t gauss_vertex_id(const gauss_sphere *g, int32_t x, int32_t y, int32_t z);

/* Vertex id -> lattice point. */
void gauss_vertex_coords(const gauss_sphere *g, uint32_t id, int32_t xyz[3]);

/* Same as doubles, the form the predicates take. */
void gauss_vertex_vector(const gauss_sphere *g, uint32_t id, double xyz[3]);

/* Triangle id -> its vertex ids, counter-clockwise seen from outside. */
void gauss_triangle_vertices(const gauss_sphere *g, uint32_t t, uint32_t v[3]);

/* ---- normals ---- */

/*
 * n_G = R^T n, then scaled by a power of two (exact) so that its largest
 * component has magnitude in [0.5, 1), and components below 2^-300 flushed
 * to zero. This fixed rounding meets the range precondition of predicates.h.
 * @return 1 for a usable normal, 0 for a zero normal (a zero-area face:
 * associated with nothing), EPSNET_EINVAL for a non-finite one.
 */
int gauss_to_frame(const gauss_sphere *g, const double n[3], double out[3]);

/*
 * The Gaussian triangle containing the frame normal n (from
 * gauss_to_frame()), ties broken symbolically, so exactly one triangle
 * answers for every n != 0. O(1): a floating-point guess verified with the
 * three exact edge tests, walking to a neighbour while one fails.
 * @return the triangle id (>= 0), EPSNET_EINVAL for n == 0 or non-finite,
 * or EPSNET_EINTERNAL if the walk did not end (a broken invariant; never
 * seen in the tests).
 */
int64_t gauss_locate(const gauss_sphere *g, const double n[3]);

/* Exact, tie-broken side of frame normal n against the arc from vertex a to
 * vertex b (a != b): +1 left (counter-clockwise side), -1 right. */
int gauss_edge_test(const gauss_sphere *g, uint32_t a, uint32_t b, const double n[3]);

/* 1 when n passes the three edge tests of triangle t (n is inside t). */
int gauss_triangle_contains(const gauss_sphere *g, uint32_t t, const double n[3]);

/* ---- vertex polygons (paper §4.1) ---- */

enum {
    GAUSS_HEMI_NONE = 0,       /* not in any open hemisphere (exact) */
    GAUSS_HEMI_CENTRE = 1,     /* in an open hemisphere; centre verified exactly */
    GAUSS_HEMI_UNVERIFIED = 2, /* no centre verified; see gauss_in_open_hemisphere */
};

/*
 * Do the normals (frame normals, none zero) lie in one open hemisphere?
 * Candidate centres, each accepted only when sign(c . n_i) > 0 holds
 * exactly for every i: the sum of the unit normals, a few perceptron
 * corrections of it, then (m <= 64) the sum of the unit extreme rays of the
 * dual cone {c : c . n_i >= 0}, which lies inside the cone however thin.
 * If none is accepted, the exact test "the origin is in the convex hull of
 * the normals" (Carathéodory: a pair, coplanar triple or quadruple
 * suffices) decides, for m <= 64.
 * @return GAUSS_HEMI_CENTRE with centre set; GAUSS_HEMI_NONE (proved: a
 * needle tip, docs/method.md §8); or GAUSS_HEMI_UNVERIFIED when a hemisphere exists
 * but no double-precision candidate separates the normals (the dual cone is
 * thinner than the rounding of its rays: a measure-zero configuration we
 * have not met in tests), or when m > 64 and the cheap candidates failed.
 * Callers treat UNVERIFIED like NONE (the vertex becomes a sample), which is
 * conservative and still deterministic.
 */
int gauss_in_open_hemisphere(const double (*normals)[3], size_t m, double centre[3]);

/* Exact: is the origin in the convex hull of the m vectors? 1 or 0.
 * O(m^4); meant for small m (used by gauss_in_open_hemisphere). */
int gauss_origin_in_hull(const double (*normals)[3], size_t m);

/*
 * Winding number of the closed spherical polygon normals[0..m-1] (great arcs
 * between consecutive normals, frame normals from gauss_to_frame()) about the
 * perturbed Gaussian vertex g'. centre must be a verified hemisphere centre
 * of the polygon (GAUSS_HEMI_CENTRE). The result is exact. It is 0 when g is
 * not in the open hemisphere of centre (then g is outside the polygon);
 * otherwise it is the planar winding number in the gnomonic projection,
 * computed with Sunday's crossing rule against the great circle through g'
 * and a fixed neighbour h' (signs only, no normalisation). Consecutive
 * normals that are parallel are a zero-length arc and are skipped.
 */
int gauss_winding(const gauss_sphere *g, const double (*normals)[3], size_t m, uint32_t gid,
                  const double centre[3]);

/* gauss_winding() about the Gaussian vertex at lattice point gp (the same
 * result; its id is computed only if a tie needs the perturbation). */
int gauss_winding_at(const gauss_sphere *g, const double (*normals)[3], size_t m, const int32_t gp[3],
                     const double centre[3]);

/*
 * The Gaussian vertices whose direction is within the angle
 * acos(cos_radius) of direction c (any length, G frame), as lattice points
 * (3 coordinates each; gauss_vertex_id() names one): a superset (the test
 * has a small relative slack). Writes up to cap points to xyz.
 * @return the number found (may exceed cap; then call again with more room).
 */
size_t gauss_vertices_near(const gauss_sphere *g, const double c[3], double cos_radius, int32_t (*xyz)[3],
                           size_t cap);

/* 1 when the m normals (none zero) lie in one closed octant (no coordinate
 * takes both signs). *signs gets the signs the normals take, for
 * gauss_vertices_enclosed(); centre the octant's sign vector, then a
 * verified hemisphere centre (its dot product with each normal is the
 * normal's 1-norm). gauss_in_open_hemisphere() finds a centre for every such polygon:
 * its first candidate, the sum of the unit normals, has a positive dot
 * product with each (no term is negative, and the term of the normal's
 * largest component, at least half its length, survives the candidate's
 * flush of tiny components). */
int gauss_in_one_octant(const double (*normals)[3], size_t m, double centre[3], int *signs);

/*
 * The Gaussian vertices the polygon normals[0..m-1] winds about (winding
 * number non-zero, as gauss_winding() counts it), found octant face by
 * octant face without a search of the sphere: a face's lattice points can be
 * enclosed only where their coordinates on the face lie within the range of
 * the normals' projections onto the face's plane, and the winding number is
 * counted on that plane (great arcs project to segments) in doubles, falling
 * back to gauss_winding_at() only where a crossing is too close to call.
 * A face is charted when every normal is well inside its half-space (s . n
 * >= |n|_1 / 64), as nearly every polygon's faces are; otherwise every
 * Gaussian vertex in the smallest cap around centre that holds the normals
 * is tested (gauss_vertices_near()), counted in the chart about centre the
 * same way. centre: a verified hemisphere centre of the polygon
 * (gauss_in_one_octant() or gauss_in_open_hemisphere()); signs from
 * gauss_in_one_octant(); chart is scratch for m points. Writes up to cap
 * points to xyz, each once. @return the number of enclosed vertices, or,
 * when above cap, a number of points to make room for and call again.
 */
size_t gauss_vertices_enclosed(const gauss_sphere *g, const double (*normals)[3], size_t m, int signs,
                               const double centre[3], double (*chart)[2], int32_t (*xyz)[3], size_t cap);

#endif /* EN_CORE_GAUSS_H */
