/*
 * The shapes, each a ring stack (gen_internal.h) with a position function.
 *
 * Rounded-square stack (sphere, ellipsoid, roundcube, dimple, bumpy). The
 * roundcube with parameter s is the Minkowski sum of the cube [-s,s]^3 and
 * a ball of radius 1-s (PAPER Fig. 3: s = 0 is the unit sphere, s = 1 the
 * cube [-1,1]^3). Each horizontal row is a rounded square: half-size c,
 * corner radius r, with n_side columns along each straight side and n_arc
 * on each corner arc, so flat and cylindrical parts get their own columns.
 * From the bottom pole up the rows are:
 *   pole, flat bottom (scaled copies of the rounded square (c_flat, r_flat)
 *   at z = -1), lower ball band (c = s, r = (1-s) cos lat), vertical band
 *   (z from -s to s), upper ball band, flat top, pole.
 * note: all rows of a flat face share z = +-1 exactly and all side columns
 * of a row share x (or y) exactly, so the flat parts stay exactly planar
 * after rounding to float. The other quads are planar before rounding;
 * their diagonal is chosen on the rounded coordinates (EN_DIAG_CONVEX) so
 * it folds outwards, and the edges between quads are convex by a margin of
 * order spacing^2, far above float rounding (tests/test_gen.c checks every
 * edge exactly; verified up to 8M faces).
 * The poles are fans of C triangles (C = 4 (n_side + n_arc) columns).
 *
 * The ellipsoid is the sphere scaled by (1, 0.75, 0.5). Dimple and bumpy
 * scale the sphere's x and y only, so rows keep one z each.
 *
 * Torus: major radius 1, minor radius = param, rows around the tube.
 * Terrain: height field over [-1,1]^2, rows along x at constant y (axis y).
 * Cad: a lathe-turned stepped shaft with a through bore and a hexagonal
 * flange: a surface of revolution of a closed profile (genus 1).
 */
#include <math.h>
#include <string.h>
#include <strings.h>

#include "common/error.h"
#include "gen/gen_internal.h"

static const char *const shape_names[] = {
    "sphere", "ellipsoid", "roundcube", "torus", "dimple", "bumpy", "terrain", "cad",
};

int en_gen_shape_by_name(const char *name)
{
    for (int i = 0; i < (int)(sizeof shape_names / sizeof *shape_names); i++)
        if (name && strcasecmp(name, shape_names[i]) == 0)
            return i;
    return -1;
}

static uint64_t count_at_least(double v, uint64_t lo)
{
    double r = round(v);
    if (!(r >= (double)lo))
        return lo;
    if (r > 1e12)
        return (uint64_t)1e12;
    return (uint64_t)r;
}

/* ---- rounded-square stack ---- */

static void stack_layout(en_gen_grid *g, double s, double h)
{
    double rho0 = 1.0 - s;
    g->s = s;
    g->rho0 = rho0;
    /* note: the rounded edges and corners carry all the curvature; spaced
     * like the flat parts, a small radius gets only a few columns and each
     * vertex's normal polygon then covers several Gaussian vertices. They
     * are refined as if the radius were up to 5x larger (at most 0.25). */
    double r_eff = rho0 >= 0.25 ? rho0 : (5 * rho0 < 0.25 ? 5 * rho0 : 0.25);
    g->n_arc = rho0 > 0 ? count_at_least(M_PI / 2 * r_eff / h, 2) : 0;
    g->n_lat = g->n_arc;
    g->n_side = s > 0 ? count_at_least(2 * s / h, 1) : 0;
    g->n_band = s > 0 ? count_at_least(2 * s / h, 1) : 0;
    g->n_flat = s > 0 ? count_at_least(s / h, 1) : 0;
    if (rho0 > 0 && s > 0) {
        double sl, cl;
        en_gen_sincos_turn((int64_t)g->n_lat - 1, 4 * (int64_t)g->n_lat, &sl, &cl);
        double r_last = rho0 * cl;
        g->r_flat = r_last < s / 2 ? r_last : s / 2;
        g->c_flat = s - g->r_flat;
    } else {
        g->r_flat = 0;
        g->c_flat = s;
    }
    /* note: on the cube the vertical band's last row is already the edge of
     * the flat face, so the flat rows start one step inside it. */
    uint64_t flat_rows = s > 0 ? (rho0 > 0 ? g->n_flat : g->n_flat - 1) : 0;
    uint64_t curved_rows = g->n_lat ? g->n_lat - 1 : 0;
    uint64_t loops = 2 * flat_rows + 2 * curved_rows + g->n_band + 1;
    g->ncols = 4 * (g->n_side + g->n_arc);
    g->nrows = loops + 2;
    g->pole_first = g->pole_last = 1;
    g->wrap_rows = 0;
    g->open_cols = 0;
    g->axis = 2;
}

typedef struct stack_row {
    int pole;
    double c, r, z;
} stack_row;

static stack_row stack_row_at(const en_gen_grid *g, uint64_t row)
{
    stack_row out = {0, 0, 0, 0};
    uint64_t flat_rows = g->s > 0 ? (g->rho0 > 0 ? g->n_flat : g->n_flat - 1) : 0;
    uint64_t curved_rows = g->n_lat ? g->n_lat - 1 : 0;
    uint64_t band_rows = g->n_band + 1;
    if (row == 0 || row == g->nrows - 1) {
        out.pole = 1;
        out.z = row == 0 ? -1.0 : 1.0;
        return out;
    }
    uint64_t i = row - 1;
    if (i < flat_rows) {
        out.c = g->c_flat * (double)(i + 1) / (double)g->n_flat;
        out.r = g->r_flat * (double)(i + 1) / (double)g->n_flat;
        out.z = -1.0;
        return out;
    }
    i -= flat_rows;
    if (i < curved_rows) {
        double sl, cl;
        en_gen_sincos_turn((int64_t)(g->n_lat - 1 - i), 4 * (int64_t)g->n_lat, &sl, &cl);
        out.c = g->s;
        out.r = g->rho0 * cl;
        out.z = -g->s - g->rho0 * sl;
        return out;
    }
    i -= curved_rows;
    if (i < band_rows) {
        out.c = g->s;
        out.r = g->rho0;
        /* note: symmetric form, so the middle row is exactly z = 0 */
        out.z = g->n_band ? g->s * (double)(2 * (int64_t)i - (int64_t)g->n_band) / (double)g->n_band
                          : 0.0;
        return out;
    }
    i -= band_rows;
    if (i < curved_rows) {
        double sl, cl;
        en_gen_sincos_turn((int64_t)(i + 1), 4 * (int64_t)g->n_lat, &sl, &cl);
        out.c = g->s;
        out.r = g->rho0 * cl;
        out.z = g->s + g->rho0 * sl;
        return out;
    }
    i -= curved_rows;
    out.c = g->c_flat * (double)(flat_rows - i) / (double)g->n_flat;
    out.r = g->r_flat * (double)(flat_rows - i) / (double)g->n_flat;
    out.z = 1.0;
    return out;
}

static void stack_point(const en_gen_grid *g, uint64_t row, uint64_t col, double p[3])
{
    stack_row sr = stack_row_at(g, row);
    p[2] = sr.z;
    if (sr.pole) {
        p[0] = p[1] = 0.0;
        return;
    }
    uint64_t per = g->n_side + g->n_arc;
    uint64_t quadrant = col / per, k = col % per;
    double x, y;
    if (k < g->n_side) {
        x = sr.c + sr.r;
        y = sr.c * (double)(2 * (int64_t)k - (int64_t)g->n_side) / (double)g->n_side;
    } else {
        double sp, cp;
        en_gen_sincos_turn((int64_t)(k - g->n_side), 4 * (int64_t)g->n_arc, &sp, &cp);
        x = sr.c + sr.r * cp;
        y = sr.c + sr.r * sp;
    }
    switch (quadrant) {
    case 0: p[0] = x; p[1] = y; break;
    case 1: p[0] = -y; p[1] = x; break;
    case 2: p[0] = -x; p[1] = -y; break;
    default: p[0] = y; p[1] = -x; break;
    }
}

/* ---- fractal value noise (bumpy, terrain) ---- */

static double lattice_value(uint64_t octave_key, int64_t x, int64_t y, int64_t z)
{
    uint64_t h = octave_key ^ ((uint64_t)x * 0x9e3779b97f4a7c15ull + (uint64_t)y * 0xc2b2ae3d27d4eb4full +
                               (uint64_t)z * 0x165667b19e3779f9ull);
    return (double)(en_gen_mix64(h) >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

static double fade(double t)
{
    return t * t * t * (t * (t * 6 - 15) + 10);
}

static int64_t floor_to_int(double x)
{
    int64_t i = (int64_t)x;
    return (double)i > x ? i - 1 : i;
}

/* Trilinear value noise with quintic fade; planar (z ignored) when flat. */
static double value_noise(uint64_t seed, int octave, double x, double y, double z, int flat)
{
    uint64_t key = en_gen_mix64(seed ^ ((uint64_t)octave << 56));
    int64_t ix = floor_to_int(x), iy = floor_to_int(y), iz = flat ? 0 : floor_to_int(z);
    double tx = fade(x - (double)ix), ty = fade(y - (double)iy), tz = flat ? 0 : fade(z - (double)iz);
    double acc[2] = {0, 0};
    for (int dz = 0; dz < (flat ? 1 : 2); dz++) {
        double v00 = lattice_value(key, ix, iy, iz + dz);
        double v10 = lattice_value(key, ix + 1, iy, iz + dz);
        double v01 = lattice_value(key, ix, iy + 1, iz + dz);
        double v11 = lattice_value(key, ix + 1, iy + 1, iz + dz);
        double a = v00 + tx * (v10 - v00);
        double b = v01 + tx * (v11 - v01);
        acc[dz] = a + ty * (b - a);
    }
    return acc[0] + tz * (acc[1] - acc[0]);
}

/* Sum of octaves with amplitude halving as frequency doubles, down to the
 * grid spacing: detail at every scale, like a scan. Range (-2, 2). */
static double fractal(const en_gen_grid *g, double x, double y, double z, int flat)
{
    double sum = 0, amp = 1, f = g->base_freq;
    for (int o = 0; o < g->octaves; o++) {
        sum += amp * value_noise(g->seed, o, x * f + 0.37 * o, y * f + 0.61 * o, z * f + 0.23 * o,
                                 flat);
        amp *= 0.5;
        f *= 2;
    }
    return sum;
}

static int octaves_for(double base_freq, double h)
{
    int k = 1;
    double f = base_freq;
    while (k < 30 && f * 2 <= 1.0 / (2 * h)) {
        f *= 2;
        k++;
    }
    return k;
}

/* ---- dents ---- */

static void place_dents(en_gen_grid *g)
{
    /* note: six dents at alternating latitudes +-25 degrees around the
     * equator, jittered by the seed; their caps do not overlap, so each one
     * is a separate concave region (PAPER Fig. 6, right). */
    uint64_t h = g->seed;
    g->ndents = EN_GEN_MAX_DENTS;
    g->dent_width = 0.5;
    for (int k = 0; k < g->ndents; k++) {
        h = en_gen_mix64(h + (uint64_t)k);
        int64_t jitter_lon = (int64_t)(h % 41) - 20;      /* +-20/720 turn */
        int64_t jitter_lat = (int64_t)((h >> 20) % 21) - 10;
        double so, co, sl, cl;
        en_gen_sincos_turn(120 * k + jitter_lon, 720, &so, &co);
        en_gen_sincos_turn((k & 1 ? -50 : 50) + jitter_lat, 720, &sl, &cl);
        g->dent[k][0] = cl * co;
        g->dent[k][1] = cl * so;
        g->dent[k][2] = sl;
    }
}

static double dent_depth_at(const en_gen_grid *g, const double p[3])
{
    double sum = 0;
    for (int k = 0; k < g->ndents; k++) {
        double dx = p[0] - g->dent[k][0], dy = p[1] - g->dent[k][1], dz = p[2] - g->dent[k][2];
        double t2 = (dx * dx + dy * dy + dz * dz) / (g->dent_width * g->dent_width);
        if (t2 < 1)
            sum += (1 - t2) * (1 - t2);
    }
    return g->param * sum;
}

/* ---- cad: stepped shaft ---- */

static void cad_profile(en_gen_grid *g)
{
    /* Profile corners (kind, radius or hexagon apothem, z), counter-clockwise
     * in the (r, z) half plane: bottom face outwards, outer surface upwards,
     * top face inwards, bore downwards. */
    static const struct {
        int kind;
        double r, z;
    } corners[EN_GEN_CAD_SEGMENTS] = {
        {0, 0.2, -1.0},  {0, 0.45, -1.0}, {0, 0.45, -0.4}, {1, 0.75, -0.4}, {1, 0.75, -0.2},
        {0, 0.4, -0.2},  {0, 0.4, 0.5},   {0, 0.3, 0.5},   {0, 0.3, 1.0},   {0, 0.2, 1.0},
    };
    for (int k = 0; k < EN_GEN_CAD_SEGMENTS; k++) {
        g->cad_kind[k] = corners[k].kind;
        g->cad_r[k] = corners[k].r;
        g->cad_z[k] = corners[k].z;
    }
}

static void cad_layout(en_gen_grid *g, double h)
{
    uint64_t first = 0;
    for (int k = 0; k < EN_GEN_CAD_SEGMENTS; k++) {
        int n = (k + 1) % EN_GEN_CAD_SEGMENTS;
        double dr = g->cad_r[n] - g->cad_r[k], dz = g->cad_z[n] - g->cad_z[k];
        double len = sqrt(dr * dr + dz * dz); /* note: not hypot(), whose last bit varies by libm */
        g->seg_rows[k] = count_at_least(len / h, 1);
        g->seg_first[k] = first;
        first += g->seg_rows[k];
    }
    g->seg_first[EN_GEN_CAD_SEGMENTS] = first;
    g->nrows = first;
    g->ncols = 6 * count_at_least(2 * M_PI * 0.6 / h / 6, 2);
    g->pole_first = g->pole_last = 0;
    g->wrap_rows = 1;
    g->open_cols = 0;
    g->axis = 2;
}

static double cad_radius(const en_gen_grid *g, int corner, uint64_t col)
{
    if (!g->cad_kind[corner])
        return g->cad_r[corner];
    /* hexagon with corners on the columns that are multiples of C/6:
     * polar equation of its sides, apothem / cos(angle from side middle) */
    int64_t m = (int64_t)g->ncols / 6;
    double s, c;
    en_gen_sincos_turn(2 * ((int64_t)col % m) - m, 12 * m, &s, &c);
    return g->cad_r[corner] / c;
}

static void cad_point(const en_gen_grid *g, uint64_t row, uint64_t col, double p[3])
{
    int k = 0;
    while (k + 1 < EN_GEN_CAD_SEGMENTS && row >= g->seg_first[k + 1])
        k++;
    int n = (k + 1) % EN_GEN_CAD_SEGMENTS;
    double t = (double)(row - g->seg_first[k]) / (double)g->seg_rows[k];
    double r0 = cad_radius(g, k, col), r1 = cad_radius(g, n, col);
    double rad = r0 + t * (r1 - r0);
    double s, c;
    en_gen_sincos_turn((int64_t)col, (int64_t)g->ncols, &s, &c);
    p[0] = rad * c;
    p[1] = rad * s;
    p[2] = g->cad_z[k] + t * (g->cad_z[n] - g->cad_z[k]);
}

/* ---- all shapes ---- */

static void count_elements(en_gen_grid *g);

static void layout(en_gen_grid *g, double h)
{
    switch (g->shape) {
    case EN_SHAPE_SPHERE:
    case EN_SHAPE_ELLIPSOID:
    case EN_SHAPE_DIMPLE:
    case EN_SHAPE_BUMPY:
        stack_layout(g, 0.0, h);
        g->diag = g->shape == EN_SHAPE_DIMPLE || g->shape == EN_SHAPE_BUMPY ? EN_DIAG_CHECKER
                                                                            : EN_DIAG_CONVEX;
        if (g->shape == EN_SHAPE_BUMPY) {
            g->base_freq = 2.0;
            g->octaves = octaves_for(g->base_freq, h);
        }
        break;
    case EN_SHAPE_ROUNDCUBE:
        stack_layout(g, g->param, h);
        g->diag = EN_DIAG_CONVEX;
        break;
    case EN_SHAPE_TORUS:
        g->nrows = count_at_least(2 * M_PI * g->param / h, 3);
        g->ncols = count_at_least(2 * M_PI / h, 3);
        g->pole_first = g->pole_last = 0;
        g->wrap_rows = 1;
        g->open_cols = 0;
        g->axis = 2;
        g->diag = EN_DIAG_CHECKER;
        break;
    case EN_SHAPE_TERRAIN:
        g->nrows = g->ncols = count_at_least(2 / h, 1) + 1;
        g->pole_first = g->pole_last = 0;
        g->wrap_rows = 0;
        g->open_cols = 1;
        g->axis = 1;
        g->diag = EN_DIAG_CHECKER;
        g->base_freq = 1.0;
        g->octaves = octaves_for(g->base_freq, h);
        break;
    case EN_SHAPE_CAD:
        cad_layout(g, h);
        g->diag = EN_DIAG_CHECKER;
        break;
    }
    count_elements(g);
}

static void count_elements(en_gen_grid *g)
{
    uint64_t loops = g->nrows - (uint64_t)g->pole_first - (uint64_t)g->pole_last;
    g->nverts = loops * g->ncols + (uint64_t)g->pole_first + (uint64_t)g->pole_last;
    uint64_t quads = g->open_cols ? g->ncols - 1 : g->ncols;
    uint64_t strips = g->wrap_rows ? g->nrows : g->nrows - 1;
    uint64_t fans = (uint64_t)g->pole_first + (uint64_t)g->pole_last;
    g->nfaces = (strips - fans) * 2 * quads + fans * g->ncols;
}

void en_gen_point(const en_gen_grid *g, uint64_t row, uint64_t col, double p[3])
{
    switch (g->shape) {
    case EN_SHAPE_SPHERE:
    case EN_SHAPE_ROUNDCUBE:
        stack_point(g, row, col, p);
        break;
    case EN_SHAPE_ELLIPSOID:
        stack_point(g, row, col, p);
        p[1] *= 0.75;
        p[2] *= 0.5;
        break;
    case EN_SHAPE_DIMPLE: {
        stack_point(g, row, col, p);
        double f = 1 - dent_depth_at(g, p);
        p[0] *= f;
        p[1] *= f;
        break;
    }
    case EN_SHAPE_BUMPY: {
        stack_point(g, row, col, p);
        double f = 1 + g->param * fractal(g, p[0], p[1], p[2], 0);
        p[0] *= f;
        p[1] *= f;
        break;
    }
    case EN_SHAPE_TORUS: {
        double sp, cp, st, ct;
        en_gen_sincos_turn((int64_t)row, (int64_t)g->nrows, &sp, &cp);
        en_gen_sincos_turn((int64_t)col, (int64_t)g->ncols, &st, &ct);
        double ring = 1 + g->param * cp;
        p[0] = ring * ct;
        p[1] = ring * st;
        p[2] = g->param * sp;
        break;
    }
    case EN_SHAPE_TERRAIN:
        p[0] = -1 + 2 * (double)col / (double)(g->ncols - 1);
        p[1] = -1 + 2 * (double)row / (double)(g->nrows - 1);
        p[2] = g->param * fractal(g, p[0], p[1], 0.0, 1);
        break;
    case EN_SHAPE_CAD:
        cad_point(g, row, col, p);
        break;
    }
}

void en_gen_point_f(const en_gen_grid *g, uint64_t row, uint64_t col, float out[3])
{
    double p[3];
    en_gen_point(g, row, col, p);
    out[0] = (float)p[0];
    out[1] = (float)p[1];
    out[2] = (float)p[2];
}

static int check_param(en_gen_grid *g, double param, epsnet_error *err)
{
    static const double defaults[] = {0, 0, 0.5, 0.4, 0.3, 0.05, 0.2, 0};
    double v = isnan(param) ? defaults[g->shape] : param;
    const char *bad = NULL;
    switch (g->shape) {
    case EN_SHAPE_ROUNDCUBE:
        if (!(v >= 0 && v <= 1))
            bad = "roundcube --param must be in [0, 1] (0 = sphere, 1 = cube)";
        break;
    case EN_SHAPE_TORUS:
        if (!(v > 0.01 && v < 0.99))
            bad = "torus --param (minor/major radius) must be in (0.01, 0.99)";
        break;
    case EN_SHAPE_DIMPLE:
        if (!(v >= 0 && v <= 0.6))
            bad = "dimple --param (dent depth) must be in [0, 0.6]";
        break;
    case EN_SHAPE_BUMPY:
        if (!(v >= 0 && v <= 0.4))
            bad = "bumpy --param (amplitude) must be in [0, 0.4]";
        break;
    case EN_SHAPE_TERRAIN:
        if (!(v >= 0 && v <= 10))
            bad = "terrain --param (relief) must be in [0, 10]";
        break;
    default:
        break;
    }
    if (bad)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "%s", bad);
    g->param = v;
    return 0;
}

/* Shapes without a pole fan or quadrant structure can take any column
 * count (cad: a multiple of 6), which brings small meshes much closer to
 * the requested face count than the spacing alone. */
static void refine_columns(en_gen_grid *g, uint64_t target)
{
    double t = (double)target;
    switch (g->shape) {
    case EN_SHAPE_TORUS:
        g->ncols = count_at_least(t / (2.0 * (double)g->nrows), 3);
        break;
    case EN_SHAPE_CAD:
        g->ncols = 6 * count_at_least(t / (12.0 * (double)g->nrows), 2);
        break;
    case EN_SHAPE_TERRAIN:
        g->ncols = 1 + count_at_least(t / (2.0 * (double)(g->nrows - 1)), 1);
        break;
    default:
        return;
    }
    count_elements(g);
}

/* Largest face count accepted: beyond it float32 cannot separate the
 * vertices anyway. */
#define EN_GEN_MAX_FACES 20000000000ull

int en_gen_grid_init(en_gen_grid *g, const epsnet_gen_settings *s, epsnet_error *err)
{
    memset(g, 0, sizeof *g);
    if (!s)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "generator settings are NULL");
    int id = en_gen_shape_by_name(s->shape);
    if (id < 0)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "unknown shape '%s' (shapes: %s)", s->shape ? s->shape : "(null)",
                            epsnet_gen_shapes());
    if (s->faces == 0 || s->faces > EN_GEN_MAX_FACES)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "--faces must be between 1 and %llu",
                            (unsigned long long)EN_GEN_MAX_FACES);
    g->shape = (en_gen_shape_id)id;
    g->seed = s->seed;
    int rc = check_param(g, s->param, err);
    if (rc)
        return rc;
    if (g->shape == EN_SHAPE_DIMPLE)
        place_dents(g);
    if (g->shape == EN_SHAPE_CAD)
        cad_profile(g);

    /* note: the face count falls as the spacing h grows; bisect on log h
     * and keep the spacing whose count is closest to the request. */
    double target = (double)s->faces;
    double lo = 1e-7, hi = 4.0, best_h = hi;
    double best_err = INFINITY;
    for (int it = 0; it < 100; it++) {
        double mid = sqrt(lo * hi);
        layout(g, mid);
        int more = (double)g->nfaces >= target;
        /* note: column refinement only near the right spacing, so it never
         * trades rows for columns far from square cells */
        if (fabs((double)g->nfaces - target) <= 0.25 * target)
            refine_columns(g, s->faces);
        double d = fabs((double)g->nfaces - target);
        if (d < best_err || (d == best_err && mid > best_h)) {
            best_err = d;
            best_h = mid;
        }
        if (more)
            lo = mid;
        else
            hi = mid;
    }
    layout(g, best_h);
    if (fabs((double)g->nfaces - target) <= 0.25 * target)
        refine_columns(g, s->faces);
    en_gen_atlas_init(g, s->charts);
    return 0;
}
