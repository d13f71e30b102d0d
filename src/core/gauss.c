/*
 * The Gaussian sphere as an integer lattice on the octahedron |x|+|y|+|z| = N
 * (paper §3.3, docs/method.md §2; layout and id scheme in gauss.h).
 */
#include "core/gauss.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/predicates.h"
#include "epsnet/epsnet.h"

#define GAUSS_PI 3.14159265358979323846

/* Components of a frame normal below this are flushed (gauss.h). */
#define GAUSS_FLUSH 0x1p-300

/* A walk longer than this means a broken invariant, not a hard input: the
 * floating-point guess is at most one or two triangles off. */
#define GAUSS_MAX_WALK 64

/* Carathéodory fallback of gauss_in_open_hemisphere is O(m^4). */
#define GAUSS_HULL_MAX 64
#define GAUSS_PERCEPTRON_ROUNDS 16

/* ---- rotations ---- */

void gauss_rotation_identity(gauss_rotation *r)
{
    memset(r, 0, sizeof *r);
    r->rt[0][0] = r->rt[1][1] = r->rt[2][2] = 1.0;
}

static int all_finite(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

int gauss_rotation_quaternion(double w, double x, double y, double z, gauss_rotation *r)
{
    double q[4] = {w, x, y, z};
    if (!all_finite(q, 4))
        return EPSNET_EINVAL;
    double len = sqrt(w * w + x * x + y * y + z * z);
    if (!(len > 0.0) || !isfinite(len))
        return EPSNET_EINVAL;
    w /= len;
    x /= len;
    y /= len;
    z /= len;
    double m[3][3] = {
        {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
        {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
        {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)},
    };
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            r->rt[i][j] = m[j][i];
    return 0;
}

int gauss_rotation_axis_angle(double ax, double ay, double az, double deg, gauss_rotation *r)
{
    double v[4] = {ax, ay, az, deg};
    if (!all_finite(v, 4))
        return EPSNET_EINVAL;
    double len = sqrt(ax * ax + ay * ay + az * az);
    if (!(len > 0.0) || !isfinite(len))
        return EPSNET_EINVAL;
    double half = deg * (GAUSS_PI / 360.0);
    double s = sin(half) / len;
    return gauss_rotation_quaternion(cos(half), ax * s, ay * s, az * s, r);
}

void gauss_rotation_default(gauss_rotation *r)
{
    (void)gauss_rotation_axis_angle(0.2718281828, 0.5772156649, 0.7853981634, 41.4213562, r);
}

static uint64_t splitmix64(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static double uniform01(uint64_t *state)
{
    return (double)(splitmix64(state) >> 11) * 0x1p-53;
}

void gauss_rotation_from_seed(uint64_t seed, gauss_rotation *r)
{
    uint64_t state = seed;
    double u1 = uniform01(&state), u2 = uniform01(&state), u3 = uniform01(&state);
    double a = sqrt(1.0 - u1), b = sqrt(u1);
    double t2 = 2.0 * GAUSS_PI * u2, t3 = 2.0 * GAUSS_PI * u3;
    /* |q| = 1 up to rounding, never 0, so this cannot fail. */
    (void)gauss_rotation_quaternion(b * cos(t3), a * sin(t2), a * cos(t2), b * sin(t3), r);
}

/* note: a rotation draws three consecutive splitmix64 outputs, so seeds one
 * increment apart would share two of them; hashing the pass into the seed
 * first keeps pass rotations unrelated to each other and to the --seed
 * rotation of pass 1. */
void gauss_pass_rotation(uint64_t seed, int pass, gauss_rotation *r)
{
    uint64_t state = seed + 0x9e3779b97f4a7c15ull * (uint64_t)pass;
    gauss_rotation_from_seed(splitmix64(&state), r);
}

/* Parse exactly four comma-separated finite numbers. */
static int parse_four(const char *s, double v[4])
{
    for (int i = 0; i < 4; i++) {
        char *end;
        v[i] = strtod(s, &end);
        if (end == s || !isfinite(v[i]))
            return EPSNET_EINVAL;
        s = end;
        while (*s == ' ')
            s++;
        if (i < 3) {
            if (*s != ',')
                return EPSNET_EINVAL;
            s++;
        }
    }
    return *s ? EPSNET_EINVAL : 0;
}

int gauss_rotation_parse(const char *text, gauss_rotation *r)
{
    if (!text)
        return EPSNET_EINVAL;
    if (!strcmp(text, "identity")) {
        gauss_rotation_identity(r);
        return 0;
    }
    if (!strcmp(text, "default")) {
        gauss_rotation_default(r);
        return 0;
    }
    double v[4];
    gauss_rotation tmp;
    int rc;
    if (!strncmp(text, "q:", 2)) {
        if (parse_four(text + 2, v))
            return EPSNET_EINVAL;
        rc = gauss_rotation_quaternion(v[0], v[1], v[2], v[3], &tmp);
    } else {
        if (parse_four(text, v))
            return EPSNET_EINVAL;
        rc = gauss_rotation_axis_angle(v[0], v[1], v[2], v[3], &tmp);
    }
    if (rc == 0)
        *r = tmp;
    return rc;
}

/* ---- the lattice and its ids ---- */

int gauss_init(gauss_sphere *g, uint32_t n, const gauss_rotation *r)
{
    if (n < 1 || n > GAUSS_MAX_FREQUENCY || !r)
        return EPSNET_EINVAL;
    g->n = n;
    g->nverts = 4 * n * n + 2;
    g->ntris = 8 * n * n;
    g->rot = *r;
    return 0;
}

int gauss_init_level(gauss_sphere *g, int level, const gauss_rotation *r)
{
    if (level < 0 || level > GAUSS_MAX_LEVEL)
        return EPSNET_EINVAL;
    return gauss_init(g, 1u << level, r);
}

/* Number of vertices in the layers before layer t (z = N - t), 0 <= t <= 2N+1. */
static uint32_t layer_start(uint32_t n, uint32_t t)
{
    if (t <= n)
        return t == 0 ? 0 : 2 * t * (t - 1) + 1;
    /* the layers from t down are the mirror image of layers 0 .. 2N - t */
    return 4 * n * n + 2 - layer_start(n, 2 * n + 1 - t);
}

/* Layer of an id in the upper half (layers 0..N). */
static uint32_t upper_layer(uint32_t n, uint32_t id)
{
    if (id == 0)
        return 0;
    uint32_t t = (uint32_t)((1.0 + sqrt(2.0 * id - 1.0)) * 0.5);
    while (t > 0 && layer_start(n, t) > id)
        t--;
    while (t < n && layer_start(n, t + 1) <= id)
        t++;
    return t;
}

uint32_t gauss_vertex_id(const gauss_sphere *g, int32_t x, int32_t y, int32_t z)
{
    uint32_t n = g->n;
    uint32_t t = (uint32_t)((int32_t)n - z);
    uint32_t r = n - (uint32_t)abs(z);
    uint32_t base = layer_start(n, t);
    if (r == 0)
        return base;
    uint32_t q, s;
    if (x > 0 && y >= 0) {
        q = 0;
        s = (uint32_t)y;
    } else if (x <= 0 && y > 0) {
        q = 1;
        s = (uint32_t)-x;
    } else if (x < 0 && y <= 0) {
        q = 2;
        s = (uint32_t)-y;
    } else {
        q = 3;
        s = (uint32_t)x;
    }
    return base + q * r + s;
}

void gauss_vertex_coords(const gauss_sphere *g, uint32_t id, int32_t xyz[3])
{
    uint32_t n = g->n;
    uint32_t t;
    if (id < layer_start(n, n + 1))
        t = upper_layer(n, id);
    else
        t = 2 * n - upper_layer(n, g->nverts - 1 - id);
    int32_t z = (int32_t)n - (int32_t)t;
    int32_t r = (int32_t)n - abs(z);
    int32_t pos = (int32_t)(id - layer_start(n, t));
    int32_t x = 0, y = 0;
    if (r > 0) {
        int32_t q = pos / r, s = pos % r;
        switch (q) {
        case 0: x = r - s; y = s; break;
        case 1: x = -s; y = r - s; break;
        case 2: x = -r + s; y = -s; break;
        default: x = s; y = -r + s; break;
        }
    }
    xyz[0] = x;
    xyz[1] = y;
    xyz[2] = z;
}

void gauss_vertex_vector(const gauss_sphere *g, uint32_t id, double xyz[3])
{
    int32_t p[3];
    gauss_vertex_coords(g, id, p);
    for (int c = 0; c < 3; c++)
        xyz[c] = (double)p[c];
}

/*
 * A face's triangles in face coordinates (a, b) = (|x|, |y|): the strip
 * between rows b = j and j + 1 holds "up" triangles (a,j) (a+1,j) (a,j+1)
 * at even and "down" triangles (a+1,j) (a+1,j+1) (a,j+1) at odd positions
 * 2a and 2a + 1. Strip j starts at N^2 - (N - j)^2.
 */
typedef struct gauss_cell {
    uint32_t octant; /* bit c set: coordinate c negative */
    uint32_t a, b;   /* face coordinates of the cell */
    uint32_t down;   /* 0 up, 1 down */
} gauss_cell;

static uint32_t cell_id(uint32_t n, const gauss_cell *c)
{
    return c->octant * n * n + (2 * n * c->b - c->b * c->b) + 2 * c->a + c->down;
}

static gauss_cell cell_of_id(uint32_t n, uint32_t t)
{
    gauss_cell c;
    uint32_t nn = n * n;
    c.octant = t / nn;
    uint32_t local = t % nn;
    uint32_t rem = nn - local;
    uint32_t s = (uint32_t)sqrt((double)rem);
    while (s * s < rem)
        s++;
    while (s > 0 && (s - 1) * (s - 1) >= rem)
        s--;
    c.b = n - s;
    uint32_t within = local - (2 * n * c.b - c.b * c.b);
    c.a = within / 2;
    c.down = within & 1;
    return c;
}

/* Lattice points of a cell, counter-clockwise seen from outside. */
static void cell_points(uint32_t n, const gauss_cell *c, int32_t p[3][3])
{
    static const uint32_t up[3][2] = {{0, 0}, {1, 0}, {0, 1}};
    static const uint32_t down[3][2] = {{1, 0}, {1, 1}, {0, 1}};
    const uint32_t(*d)[2] = c->down ? down : up;
    for (int k = 0; k < 3; k++) {
        int32_t a = (int32_t)(c->a + d[k][0]), b = (int32_t)(c->b + d[k][1]);
        int32_t q[3] = {a, b, (int32_t)n - a - b};
        for (int ax = 0; ax < 3; ax++)
            p[k][ax] = (c->octant >> ax) & 1 ? -q[ax] : q[ax];
    }
    /* each mirror reverses the orientation of the face */
    uint32_t o = c->octant;
    if (((o & 1) ^ ((o >> 1) & 1) ^ ((o >> 2) & 1)) != 0) {
        for (int ax = 0; ax < 3; ax++) {
            int32_t tmp = p[1][ax];
            p[1][ax] = p[2][ax];
            p[2][ax] = tmp;
        }
    }
}

void gauss_triangle_vertices(const gauss_sphere *g, uint32_t t, uint32_t v[3])
{
    gauss_cell c = cell_of_id(g->n, t);
    int32_t p[3][3];
    cell_points(g->n, &c, p);
    for (int k = 0; k < 3; k++)
        v[k] = gauss_vertex_id(g, p[k][0], p[k][1], p[k][2]);
}

/* The cell whose three lattice points sum to s (3 x its centroid, which is
 * inside a face, so no component of s is 0). */
static gauss_cell cell_of_centroid(const int32_t s[3])
{
    gauss_cell c;
    c.octant = (s[0] < 0) | (s[1] < 0) << 1 | (s[2] < 0) << 2;
    uint32_t a3 = (uint32_t)abs(s[0]), b3 = (uint32_t)abs(s[1]);
    c.a = a3 / 3;
    c.b = b3 / 3;
    c.down = (a3 % 3) == 2;
    return c;
}

/* ---- normals and point location ---- */

/* note: scalar locals rather than a small array, so the compiler keeps them
 * in registers (an array round-trip through the stack cost half the time of
 * face association in bench/gauss_locate_bench.c). */
int gauss_to_frame(const gauss_sphere *g, const double n[3], double out[3])
{
    const double(*rt)[3] = g->rot.rt;
    double x = n[0], y = n[1], z = n[2];
    double v0 = rt[0][0] * x + rt[0][1] * y + rt[0][2] * z;
    double v1 = rt[1][0] * x + rt[1][1] * y + rt[1][2] * z;
    double v2 = rt[2][0] * x + rt[2][1] * y + rt[2][2] * z;
    double a0 = fabs(v0), a1 = fabs(v1), a2 = fabs(v2);
    double m = a0 > a1 ? a0 : a1;
    m = m > a2 ? m : a2;
    if (!(a0 <= DBL_MAX && a1 <= DBL_MAX && a2 <= DBL_MAX)) {
        out[0] = out[1] = out[2] = 0.0;
        return EPSNET_EINVAL;
    }
    if (m == 0.0) {
        out[0] = out[1] = out[2] = 0.0;
        return 0;
    }
    /* m = f 2^e with f in [0.5, 1): multiply by 2^-e, exact for every
     * component that survives the flush */
    uint64_t bits;
    memcpy(&bits, &m, sizeof bits);
    int biased = (int)((bits >> 52) & 0x7ff);
    if (biased >= 1 && biased <= 2044) {
        uint64_t sbits = (uint64_t)(2045 - biased) << 52;
        double scale;
        memcpy(&scale, &sbits, sizeof scale);
        v0 *= scale;
        v1 *= scale;
        v2 *= scale;
    } else {
        int e;
        (void)frexp(m, &e);
        v0 = ldexp(v0, -e);
        v1 = ldexp(v1, -e);
        v2 = ldexp(v2, -e);
    }
    out[0] = fabs(v0) < GAUSS_FLUSH ? 0.0 : v0;
    out[1] = fabs(v1) < GAUSS_FLUSH ? 0.0 : v1;
    out[2] = fabs(v2) < GAUSS_FLUSH ? 0.0 : v2;
    return 1;
}

static void lattice_to_double(const int32_t p[3], double v[3])
{
    v[0] = (double)p[0];
    v[1] = (double)p[1];
    v[2] = (double)p[2];
}

/*
 * Unperturbed sign of det(ga, gb, n) = n . (ga x gb) when a plain double
 * evaluation decides it, else 0. ga x gb is exact: integers below 2N^2.
 */
static int edge_sign_fast(const double ga[3], const double gb[3], const double n[3])
{
    double e0 = ga[1] * gb[2] - ga[2] * gb[1];
    double e1 = ga[2] * gb[0] - ga[0] * gb[2];
    double e2 = ga[0] * gb[1] - ga[1] * gb[0];
    double p0 = e0 * n[0], p1 = e1 * n[1], p2 = e2 * n[2];
    double dot = p0 + p1 + p2;
    /* products (1 eps) and two sums (2 eps), slack for the permanent */
    double bound = 0x1p-50 * (fabs(p0) + fabs(p1) + fabs(p2));
    if (dot > bound)
        return 1;
    if (-dot > bound)
        return -1;
    return 0;
}

int gauss_edge_test(const gauss_sphere *g, uint32_t a, uint32_t b, const double n[3])
{
    double ga[3], gb[3];
    gauss_vertex_vector(g, a, ga);
    gauss_vertex_vector(g, b, gb);
    int s = edge_sign_fast(ga, gb, n);
    return s ? s : en_sos_edge(ga, a, gb, b, n);
}

int gauss_triangle_contains(const gauss_sphere *g, uint32_t t, const double n[3])
{
    uint32_t v[3];
    gauss_triangle_vertices(g, t, v);
    for (int k = 0; k < 3; k++)
        if (gauss_edge_test(g, v[k], v[(k + 1) % 3], n) < 0)
            return 0;
    return 1;
}

/* Floating-point guess of the cell holding n: octant from signs, then the
 * grid cell of the point N n / |n|_1 on the face. */
static gauss_cell guess_cell(uint32_t n, const double v[3])
{
    gauss_cell c;
    c.octant = (v[0] < 0) | (v[1] < 0) << 1 | (v[2] < 0) << 2;
    double ax = fabs(v[0]), ay = fabs(v[1]);
    double scale = (double)n / (ax + ay + fabs(v[2]));
    double fa = ax * scale, fb = ay * scale;
    uint32_t last = n - 1;
    uint32_t a = fa >= (double)last ? last : (uint32_t)fa;
    uint32_t b = fb >= (double)last ? last : (uint32_t)fb;
    if (a + b > last)
        b = last - a;
    c.a = a;
    c.b = b;
    c.down = (a + b < last) && (fa - a) + (fb - b) > 1.0;
    return c;
}

/* The cell across the edge p[e] -> p[e+1] of a cell with points p. */
static gauss_cell cell_across(uint32_t n, const int32_t p[3][3], int e)
{
    const int32_t *u = p[e], *w = p[(e + 1) % 3], *o = p[(e + 2) % 3];
    int32_t q[3];
    uint32_t l1 = 0;
    for (int ax = 0; ax < 3; ax++) {
        q[ax] = u[ax] + w[ax] - o[ax];
        l1 += (uint32_t)abs(q[ax]);
    }
    if (l1 != n) {
        /* the edge lies on an octahedron edge (a coordinate plane): the
         * neighbour is the mirror image of this cell across that plane */
        for (int ax = 0; ax < 3; ax++) {
            q[ax] = o[ax];
            if (u[ax] == 0 && w[ax] == 0)
                q[ax] = -o[ax];
        }
    }
    int32_t s[3];
    for (int ax = 0; ax < 3; ax++)
        s[ax] = u[ax] + w[ax] + q[ax];
    return cell_of_centroid(s);
}

/* Exact, tie-broken walk from cell c (gauss.h: gauss_locate). */
static int64_t walk(const gauss_sphere *g, gauss_cell c, const double n[3])
{
    for (int step = 0; step < GAUSS_MAX_WALK; step++) {
        int32_t p[3][3];
        cell_points(g->n, &c, p);
        double v[3][3];
        uint32_t id[3];
        for (int k = 0; k < 3; k++) {
            lattice_to_double(p[k], v[k]);
            id[k] = gauss_vertex_id(g, p[k][0], p[k][1], p[k][2]);
        }
        int failed = -1;
        for (int e = 0; e < 3 && failed < 0; e++) {
            int k = (e + 1) % 3;
            int s = edge_sign_fast(v[e], v[k], n);
            if (!s)
                s = en_sos_edge(v[e], id[e], v[k], id[k], n);
            if (s < 0)
                failed = e;
        }
        if (failed < 0)
            return cell_id(g->n, &c);
        c = cell_across(g->n, p, failed);
    }
    return EPSNET_EINTERNAL;
}

/*
 * Fast path of gauss_locate. Mirroring n into the positive octant maps G to
 * itself, and there the edge determinants of the cell (a, b) reduce to
 * barycentric tests on the point P = N |n| / |n|_1 of the face, e.g.
 * det(q0, q1, |n|) = N |n_y| - b |n|_1 for the up cell's edge (a,b)->(a+1,b).
 * Computing P costs at most 4 roundings relative (5.2 eps N absolute with the
 * subtraction of the cell corner), the third test adds two of them, so a
 * margin of 16 eps N proves all three unperturbed signs strictly positive;
 * the perturbation cannot change a non-zero sign. Otherwise returns -1.
 */
static int64_t locate_interior(uint32_t n, const double v[3])
{
    double ax = fabs(v[0]), ay = fabs(v[1]), az = fabs(v[2]);
    double scale = (double)n / (ax + ay + az);
    double fa = ax * scale, fb = ay * scale;
    double margin = (double)n * (16.0 * 0x1p-53);
    if (!(fa < (double)n && fb < (double)n))
        return -1;
    uint32_t a = (uint32_t)fa, b = (uint32_t)fb;
    double ra = fa - (double)a, rb = fb - (double)b;
    gauss_cell c;
    c.octant = (v[0] < 0) | (v[1] < 0) << 1 | (v[2] < 0) << 2;
    c.a = a;
    c.b = b;
    /* note: & rather than &&, so that the up/down choice (a coin toss for
     * random normals) is computed without a mispredicted branch */
    int up = (ra > margin) & (rb > margin) & (1.0 - ra - rb > margin) & (a + b < n);
    int down = (ra + rb - 1.0 > margin) & (1.0 - ra > margin) & (1.0 - rb > margin) &
               (a + b + 1 < n);
    if (!(up | down))
        return -1;
    c.down = (uint32_t)down;
    return cell_id(n, &c);
}

int64_t gauss_locate(const gauss_sphere *g, const double n[3])
{
    if (n[0] == 0.0 && n[1] == 0.0 && n[2] == 0.0)
        return EPSNET_EINVAL;
    int64_t t = locate_interior(g->n, n);
    if (t >= 0)
        return t;
    if (!all_finite(n, 3))
        return EPSNET_EINVAL;
    return walk(g, guess_cell(g->n, n), n);
}

/* ---- vertex polygons ---- */

static double norm3(const double v[3])
{
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

static void add_unit(double c[3], const double v[3])
{
    double len = norm3(v);
    if (len > 0.0 && isfinite(len))
        for (int k = 0; k < 3; k++)
            c[k] += v[k] / len;
}

/* First index whose exact dot with c is not positive, or m. */
static size_t first_violation(const double (*nv)[3], size_t m, const double c[3])
{
    for (size_t i = 0; i < m; i++)
        if (en_dot3_sign(c, nv[i]) <= 0)
            return i;
    return m;
}

static int coplanar_triple_surrounds_origin(const double a[3], const double b[3],
                                            const double c[3])
{
    /* a, b, c and 0 are coplanar with plane normal p; (x x y)_k = lambda p_k,
     * so on an axis k with p_k != 0 the three minors carry the signs of the
     * lambdas, and 0 = alpha a + beta b + gamma c with positive weights
     * exactly when the three agree. */
    for (int k = 0; k < 3; k++) {
        int s1 = en_cross_sign(a, b, k), s2 = en_cross_sign(b, c, k), s3 = en_cross_sign(c, a, k);
        if (s1 || s2 || s3)
            return s1 != 0 && s1 == s2 && s2 == s3;
    }
    return 0;
}

int gauss_origin_in_hull(const double (*nv)[3], size_t m)
{
    for (size_t i = 0; i < m; i++)
        if (nv[i][0] == 0.0 && nv[i][1] == 0.0 && nv[i][2] == 0.0)
            return 1;
    for (size_t i = 0; i < m; i++)
        for (size_t j = i + 1; j < m; j++)
            if (!en_cross_sign(nv[i], nv[j], 0) && !en_cross_sign(nv[i], nv[j], 1) &&
                !en_cross_sign(nv[i], nv[j], 2) && en_dot3_sign(nv[i], nv[j]) < 0)
                return 1;
    for (size_t i = 0; i < m; i++)
        for (size_t j = i + 1; j < m; j++)
            for (size_t k = j + 1; k < m; k++)
                if (en_orient3_sign(nv[i], nv[j], nv[k]) == 0 &&
                    coplanar_triple_surrounds_origin(nv[i], nv[j], nv[k]))
                    return 1;
    /* det(b,c,d) a - det(a,c,d) b + det(a,b,d) c - det(a,b,c) d = 0 spans the
     * dependencies of four vectors of rank 3; equal signs put 0 inside. */
    for (size_t i = 0; i < m; i++)
        for (size_t j = i + 1; j < m; j++)
            for (size_t k = j + 1; k < m; k++) {
                int d4 = en_orient3_sign(nv[i], nv[j], nv[k]);
                if (!d4)
                    continue;
                for (size_t l = k + 1; l < m; l++) {
                    int d1 = en_orient3_sign(nv[j], nv[k], nv[l]);
                    if (d1 != -d4)
                        continue;
                    if (en_orient3_sign(nv[i], nv[k], nv[l]) == -d1 &&
                        en_orient3_sign(nv[i], nv[j], nv[l]) == d1)
                        return 1;
                }
            }
    return 0;
}

/* Add r / |r| to c when no unit normal u_k contradicts r beyond a small
 * tolerance (r lies in the dual cone, up to rounding). */
static void add_if_in_dual_cone(const double (*u)[3], size_t m, const double r[3], double c[3])
{
    double len = norm3(r);
    if (!(len > 1e-300))
        return;
    for (size_t k = 0; k < m; k++)
        if (r[0] * u[k][0] + r[1] * u[k][1] + r[2] * u[k][2] < -1e-12 * len)
            return;
    for (int k = 0; k < 3; k++)
        c[k] += r[k] / len;
}

static void cross3(const double a[3], const double b[3], double r[3])
{
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}

/*
 * A centre candidate from the dual cone D = {c : c . n_i >= 0}, whose
 * interior is exactly the set of valid centres. Its extreme rays are among
 * +-(u_i x u_j) (unit normals u); when D is not pointed (all normals in one
 * plane: a wedge), its boundary rays are the in-plane perpendiculars
 * (u_i x u_j) x u_i and u_j x (u_i x u_j). The sum of all such rays lying
 * in D is interior to D whenever D has an interior, however thin it is.
 * O(m^3), only after the cheap candidates failed; m <= GAUSS_HULL_MAX.
 */
static void dual_cone_candidate(const double (*nv)[3], size_t m, double c[3])
{
    double u[GAUSS_HULL_MAX][3];
    for (size_t i = 0; i < m; i++) {
        u[i][0] = u[i][1] = u[i][2] = 0.0;
        add_unit(u[i], nv[i]);
    }
    c[0] = c[1] = c[2] = 0.0;
    for (size_t i = 0; i < m; i++) {
        for (size_t j = i + 1; j < m; j++) {
            double r[3], rneg[3], wi[3], wj[3];
            cross3(u[i], u[j], r);
            rneg[0] = -r[0];
            rneg[1] = -r[1];
            rneg[2] = -r[2];
            cross3(r, u[i], wi);
            cross3(u[j], r, wj);
            add_if_in_dual_cone((const double(*)[3])u, m, r, c);
            add_if_in_dual_cone((const double(*)[3])u, m, rneg, c);
            add_if_in_dual_cone((const double(*)[3])u, m, wi, c);
            add_if_in_dual_cone((const double(*)[3])u, m, wj, c);
        }
    }
}

/* Accept c when every normal is strictly on its side, exactly. */
static int try_centre(const double (*nv)[3], size_t m, double c[3], double centre[3])
{
    /* keep the candidate inside the predicates' range precondition */
    for (int k = 0; k < 3; k++)
        if (fabs(c[k]) < 0x1p-200)
            c[k] = 0.0;
    if (first_violation(nv, m, c) != m)
        return 0;
    memcpy(centre, c, 3 * sizeof *c);
    return 1;
}

int gauss_in_open_hemisphere(const double (*nv)[3], size_t m, double centre[3])
{
    if (m == 0)
        return GAUSS_HEMI_NONE;
    double c[3] = {0.0, 0.0, 0.0};
    for (size_t i = 0; i < m; i++)
        add_unit(c, nv[i]);
    for (int round = 0; round <= GAUSS_PERCEPTRON_ROUNDS; round++) {
        if (try_centre(nv, m, c, centre))
            return GAUSS_HEMI_CENTRE;
        add_unit(c, nv[first_violation(nv, m, c)]);
    }
    if (m > GAUSS_HULL_MAX)
        return GAUSS_HEMI_UNVERIFIED;
    double d[3];
    dual_cone_candidate(nv, m, d);
    if (try_centre(nv, m, d, centre))
        return GAUSS_HEMI_CENTRE;
    if (gauss_origin_in_hull(nv, m))
        return GAUSS_HEMI_NONE;
    return GAUSS_HEMI_UNVERIFIED;
}

/* A fixed lattice neighbour of g: one unit moved from the first non-zero
 * coordinate to the next one, keeping |h|_1 = N; never parallel to g. */
static void neighbour_point(const int32_t gp[3], int32_t hp[3])
{
    int a = gp[0] ? 0 : gp[1] ? 1 : 2;
    int b = (a + 1) % 3;
    hp[0] = gp[0];
    hp[1] = gp[1];
    hp[2] = gp[2];
    hp[a] -= gp[a] > 0 ? 1 : -1;
    hp[b] += gp[b] >= 0 ? 1 : -1;
}

int gauss_winding_at(const gauss_sphere *g, const double (*nv)[3], size_t m, const int32_t gp[3],
                     const double centre[3])
{
    if (m < 2)
        return 0;
    int32_t hp[3];
    neighbour_point(gp, hp);
    double gv[3], hv[3];
    lattice_to_double(gp, gv);
    lattice_to_double(hp, hv);
    if (en_dot3_sign(centre, gv) <= 0)
        return 0;
    /* note: det(g, h, n) = n . (g x h), with g x h exact (integers), so
     * each edge test is a dot product; only when its filter is undecided
     * does the perturbation need the two ids, found then (they cost as
     * much as the tests: bench/RESULTS.md, session 13) */
    double w[3] = { gv[1] * hv[2] - gv[2] * hv[1], gv[2] * hv[0] - gv[0] * hv[2], gv[0] * hv[1] - gv[1] * hv[0] };
    uint32_t gid = UINT32_MAX, hid = UINT32_MAX;
    int winding = 0, side_a = 0;
    for (size_t k = 0; k <= m; k++) {
        const double *b = nv[k == 0 ? m - 1 : k - 1];
        int side_b = en_dot3_sign_filtered(w, b);
        if (side_b == 0) {
            if (gid == UINT32_MAX) {
                gid = gauss_vertex_id(g, gp[0], gp[1], gp[2]);
                hid = gauss_vertex_id(g, hp[0], hp[1], hp[2]);
            }
            side_b = en_sos_edge_cross_undecided(gv, gid, hv, hid, w, b);
        }
        if (k > 0 && side_a != side_b) {
            const double *a = nv[k == 1 ? m - 1 : k - 2];
            int left = en_sos_point(a, b, gv);
            if (side_a < 0 && left > 0)
                winding++;
            else if (side_a > 0 && left < 0)
                winding--;
        }
        side_a = side_b;
    }
    return winding;
}

int gauss_winding(const gauss_sphere *g, const double (*nv)[3], size_t m, uint32_t gid,
                  const double centre[3])
{
    int32_t gp[3];
    gauss_vertex_coords(g, gid, gp);
    return gauss_winding_at(g, nv, m, gp, centre);
}

size_t gauss_vertices_near(const gauss_sphere *g, const double c[3], double cos_radius, int32_t (*xyz)[3],
                           size_t cap)
{
    double len = norm3(c);
    if (!(len > 0.0) || !isfinite(len) || isnan(cos_radius))
        return 0;
    double u[3] = {c[0] / len, c[1] / len, c[2] / len};
    double cr = fmin(cos_radius, 1.0) - 1e-9;
    if (cr < -1.0)
        cr = -1.0;
    int32_t n = (int32_t)g->n;
    /* a direction within chord r of u, scaled to a lattice point p with
     * N / sqrt 3 <= |p| <= N, lies within N r of |p| u: a box per axis */
    double chord = sqrt(fmax(0.0, 2.0 - 2.0 * cr)) + 1e-9;
    /* note: a tighter box from the same test. A point p that passes has
     * d = p / |p| with d.u >= cr - 1e-9 sqrt 3 (|p| >= N / sqrt 3), so
     * |d - u| <= wide; its 1-norm, N / |p|, is within sqrt 3 wide of u's,
     * which bounds |p| far closer than [N / sqrt 3, N] does (a lattice
     * unit of margin on each side covers the rounding). The points tested
     * are still a superset of those kept, in the same order, so the list
     * is the same; at frequency 32 the search costs a third fewer
     * instructions (bench/RESULTS.md). */
    double wide = sqrt(fmax(0.0, 2.0 - 2.0 * cr + 4e-9)) + 1e-9;
    double l1 = fabs(u[0]) + fabs(u[1]) + fabs(u[2]);
    double n1_lo = fmax(1.0, l1 - sqrt(3.0) * wide), n1_hi = fmin(sqrt(3.0), l1 + sqrt(3.0) * wide);
    double pmin = n / n1_hi, pmax = n / n1_lo;
    int32_t lo[3], hi[3];
    for (int k = 0; k < 3; k++) {
        double e1 = u[k] * n / sqrt(3.0), e2 = u[k] * n;
        double l = fmin(e1, e2) - n * chord, h = fmax(e1, e2) + n * chord;
        double a = u[k] - wide, b = u[k] + wide;
        l = fmax(l, fmin(pmin * a, pmax * a) - 1.0);
        h = fmin(h, fmax(pmin * b, pmax * b) + 1.0);
        lo[k] = l <= -n ? -n : (int32_t)floor(l);
        hi[k] = h >= n ? n : (int32_t)ceil(h);
    }
    size_t count = 0;
    for (int32_t x = lo[0]; x <= hi[0]; x++) {
        int32_t rem = n - abs(x);
        int32_t ylo = lo[1] > -rem ? lo[1] : -rem, yhi = hi[1] < rem ? hi[1] : rem;
        for (int32_t y = ylo; y <= yhi; y++) {
            int32_t zabs = rem - abs(y);
            for (int side = 0; side < (zabs ? 2 : 1); side++) {
                int32_t z = side ? -zabs : zabs;
                if (z < lo[2] || z > hi[2])
                    continue;
                double p[3] = {x, y, z};
                double dot = p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
                if (dot < cr * norm3(p) - 1e-9 * n)
                    continue;
                if (count < cap)
                    xyz[count][0] = x, xyz[count][1] = y, xyz[count][2] = z;
                count++;
            }
        }
    }
    return count;
}

/* Bit k of *pos (*neg): some normal has component k > 0 (< 0). */
static void sign_bits(const double (*nv)[3], size_t m, int *pos, int *neg)
{
    *pos = *neg = 0;
    for (size_t i = 0; i < m; i++)
        for (int k = 0; k < 3; k++) {
            *pos |= (nv[i][k] > 0) << k;
            *neg |= (nv[i][k] < 0) << k;
        }
}

int gauss_in_one_octant(const double (*nv)[3], size_t m, double centre[3], int *signs)
{
    int pos, neg;
    sign_bits(nv, m, &pos, &neg);
    *signs = pos | neg << 3;
    for (int k = 0; k < 3; k++)
        centre[k] = neg >> k & 1 ? -1.0 : 1.0;
    return !(pos & neg);
}

/* note: a face's points map to its plane's chart by (x, y, z) -> (|x|, |y|),
 * affine on the face, and a normal n maps by its central projection onto the
 * plane s . p = N, (s_x n_x, s_y n_y) N / (s . n). Great arcs become
 * segments, so the planar winding number about a point of the face is the
 * spherical one up to the chart's orientation. With r = |n|_1 / (s . n),
 * s . n is rounded by at most 2u r of itself (u = 2^-53), so a chart
 * coordinate, at most N r, is within N r (2r + 3) u of the exact projection;
 * err (below) is four times the largest such bound, and at least CHART_ERR.
 * A vertex that close to the ray's height, or a side test that close to
 * zero, sends the point to gauss_winding_at(), which also breaks ties by the
 * perturbation. */
#define CHART_ERR 1e-9

/* The winding number about (qx, qy) of the polygon chart[0..m-1], each
 * coordinate of which, like q's, is within err of its exact chart (up to
 * the chart's orientation); where that is too close to call, gauss_winding_at()
 * about gp with the hemisphere centre centre. */
static int planar_winding(const gauss_sphere *g, const double (*nv)[3], const double (*chart)[2], size_t m,
                          double err, double qx, double qy, const int32_t gp[3], const double centre[3])
{
    int winding = 0;
    for (size_t i = 0; i < m; i++) {
        const double *a = chart[i], *b = chart[i + 1 == m ? 0 : i + 1];
        double ay = a[1] - qy, by = b[1] - qy;
        if (fabs(ay) <= 2 * err || fabs(by) <= 2 * err)
            return gauss_winding_at(g, nv, m, gp, centre);
        if ((ay < 0) == (by < 0))
            continue;
        /* the side of q from the segment a -> b; each difference is within
         * 2 err, each product within 2 err (|x| + |y|) + 4 err^2, and the
         * rounding is the last term */
        double ex = b[0] - a[0], ey = b[1] - a[1], ax = a[0] - qx;
        double side = ax * ey - ay * ex;
        double bound = 4 * err * (fabs(ax) + fabs(ay) + fabs(ex) + fabs(ey)) + 16 * err * err +
                       1e-12 * (fabs(ax * ey) + fabs(ay * ex));
        if (fabs(side) <= bound)
            return gauss_winding_at(g, nv, m, gp, centre);
        if (ay < 0 && side > 0) /* upwards, q on its left */
            winding++;
        else if (ay > 0 && side < 0) /* downwards, q on its right */
            winding--;
    }
    return winding;
}

/* The enclosed lattice points of the face with signs s (bit k set: s_k =
 * -1), appended to xyz from count on; points with a zero coordinate on an
 * axis in skip (where the neighbouring face lists them) are left out. 0, or
 * -1 when a normal is not well inside s's half-space (r above CHART_RMAX,
 * where the chart would send most points to the exact test). */
#define CHART_RMAX 64.0
static int enclosed_on_face(const gauss_sphere *g, const double (*nv)[3], size_t m, double (*chart)[2], int signs,
                            int skip, int32_t (*xyz)[3], size_t cap, size_t *count)
{
    double s[3] = {signs & 1 ? -1.0 : 1.0, signs & 2 ? -1.0 : 1.0, signs & 4 ? -1.0 : 1.0};
    double n = (double)g->n, lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double rmax = 1.0;
    for (size_t i = 0; i < m; i++) {
        double a[3] = {s[0] * nv[i][0], s[1] * nv[i][1], s[2] * nv[i][2]};
        double dot = a[0] + a[1] + a[2], inv = 1.0 / dot, r = (fabs(a[0]) + fabs(a[1]) + fabs(a[2])) * inv;
        if (!(dot > 0 && r <= CHART_RMAX))
            return -1;
        rmax = r > rmax ? r : rmax;
        double scale = n * inv;
        for (int k = 0; k < 3; k++) {
            double c = a[k] * scale;
            lo[k] = c < lo[k] ? c : lo[k];
            hi[k] = c > hi[k] ? c : hi[k];
            if (k < 2)
                chart[i][k] = c;
        }
    }
    /* q in the polygon's hull is a non-negative combination of the normals,
     * so each of its face coordinates N s_k q_k / (s . q) is a weighted mean
     * of the normals' (weights s . n_i > 0): the box holds it */
    double err = 4 * n * rmax * (2 * rmax + 3) * 0x1p-53;
    err = err > CHART_ERR ? err : CHART_ERR;
    int32_t ilo[3], ihi[3];
    for (int k = 0; k < 3; k++) {
        /* clamped to [-1, N + 1] first, so the conversions are exact; a cast
         * and a step stand for ceil() and floor(), a call each here */
        double l = lo[k] - 2 * err, h = hi[k] + 2 * err;
        l = l < -1 ? -1 : l > n + 1 ? n + 1 : l;
        h = h < -1 ? -1 : h > n + 1 ? n + 1 : h;
        int32_t il = (int32_t)l, ih = (int32_t)h; /* towards zero */
        il += (double)il < l;
        ih -= (double)ih > h;
        ilo[k] = il < 0 ? 0 : il;
        ihi[k] = ih > (int32_t)g->n ? (int32_t)g->n : ih;
        if (skip >> k & 1 && ilo[k] == 0)
            ilo[k] = 1;
    }
    for (int32_t x = ilo[0]; x <= ihi[0]; x++)
        for (int32_t y = ilo[1]; y <= ihi[1]; y++) {
            int32_t z = (int32_t)g->n - x - y;
            if (z < ilo[2] || z > ihi[2])
                continue;
            int32_t q[3] = {signs & 1 ? -x : x, signs & 2 ? -y : y, signs & 4 ? -z : z};
            if (planar_winding(g, nv, (const double(*)[2])chart, m, err, x, y, q, s) == 0)
                continue;
            if (*count < cap)
                memcpy(xyz[*count], q, sizeof q);
            (*count)++;
        }
    return 0;
}

/* The chart about a hemisphere centre c: p -> (u . p, v . p) / (c . p) for
 * any u, v completing c to a basis (a central projection onto the plane
 * c . p = 1 in other coordinates, so arcs still become segments). Into
 * xy, and into *err a bound on its rounding: each dot product is within 3u
 * of the sum of its terms' sizes (A for u and v, C for c), so a coordinate X
 * is within 4u (A / d + |X| (C / d + 1)), d = c . p. 0, or -1 when p is
 * not well inside the hemisphere (C / d above CHART_RMAX). */
static int cap_chart(const double uvc[3][3], const double p[3], double xy[2], double *err)
{
    double dot[3], size[3];
    for (int r = 0; r < 3; r++) {
        dot[r] = uvc[r][0] * p[0] + uvc[r][1] * p[1] + uvc[r][2] * p[2];
        size[r] = fabs(uvc[r][0] * p[0]) + fabs(uvc[r][1] * p[1]) + fabs(uvc[r][2] * p[2]);
    }
    double d = dot[2];
    if (!(d > 0 && size[2] <= CHART_RMAX * d))
        return -1;
    xy[0] = dot[0] / d;
    xy[1] = dot[1] / d;
    *err = 4 * 0x1p-53 * ((size[0] + size[1]) / d + (fabs(xy[0]) + fabs(xy[1])) * (size[2] / d + 1));
    return 0;
}

/* The Gaussian vertices in the smallest cap around centre that holds every
 * normal (the polygon lies in the spherical hull of its vertices, inside that
 * cap) that the polygon winds about, counted in the chart about centre. */
static size_t enclosed_in_cap(const gauss_sphere *g, const double (*nv)[3], size_t m, const double c[3],
                              double (*chart)[2], int32_t (*xyz)[3], size_t cap)
{
    double cl = norm3(c), cos_r = 1.0;
    for (size_t i = 0; i < m; i++) {
        double cosine = (nv[i][0] * c[0] + nv[i][1] * c[1] + nv[i][2] * c[2]) / (norm3(nv[i]) * cl);
        cos_r = cosine < cos_r ? cosine : cos_r;
    }
    size_t nn = gauss_vertices_near(g, c, cos_r, xyz, cap);
    if (nn > cap)
        return nn;
    /* u: c x the axis c is least along; v: c x u */
    int k = fabs(c[0]) <= fabs(c[1]) && fabs(c[0]) <= fabs(c[2]) ? 0 : fabs(c[1]) <= fabs(c[2]) ? 1 : 2;
    double e[3] = {k == 0, k == 1, k == 2}, uvc[3][3];
    cross3(c, e, uvc[0]);
    cross3(c, uvc[0], uvc[1]);
    memcpy(uvc[2], c, sizeof uvc[2]);
    double err = 0;
    int charted = 1;
    for (size_t i = 0; i < m && charted; i++) {
        double ei;
        charted = cap_chart((const double(*)[3])uvc, nv[i], chart[i], &ei) == 0;
        err = ei > err ? ei : err;
    }
    size_t kept = 0;
    for (size_t i = 0; i < nn; i++) {
        double p[3], q[2], eq;
        lattice_to_double(xyz[i], p);
        int w;
        if (!charted || cap_chart((const double(*)[3])uvc, p, q, &eq) < 0)
            w = gauss_winding_at(g, nv, m, xyz[i], c);
        else
            w = planar_winding(g, nv, (const double(*)[2])chart, m, eq > err ? eq : err, q[0], q[1], xyz[i], c);
        if (w != 0)
            memmove(xyz[kept++], xyz[i], sizeof *xyz);
    }
    return kept;
}

size_t gauss_vertices_enclosed(const gauss_sphere *g, const double (*nv)[3], size_t m, int signs_taken,
                               const double centre[3], double (*chart)[2], int32_t (*xyz)[3], size_t cap)
{
    int pos = signs_taken & 7, neg = signs_taken >> 3;
    /* the hull stays on the side every normal is on, for each axis where
     * they agree; the axes where they differ ("open") leave both faces */
    int open = pos & neg, fixed = neg & ~open;
    size_t count = 0;
    for (int signs = 0; signs < 8; signs++) {
        if ((signs & ~open) != fixed)
            continue;
        /* a point on a plane between two open faces is listed once, by the
         * face on that axis's positive side */
        if (enclosed_on_face(g, nv, m, chart, signs, signs & open, xyz, cap, &count) < 0)
            return enclosed_in_cap(g, nv, m, centre, chart, xyz, cap);
    }
    return count;
}
