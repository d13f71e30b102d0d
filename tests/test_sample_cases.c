/*
 * Tiny hand-made sampling cases (docs/method.md §8, paper §4.1): exact ties broken the
 * same everywhere, saddles with negative winding, and needle tips.
 */
#include "sample_util.h"

static void add(en_slab *s, double x, double y, double z)
{
    double p[3] = { x, y, z };
    en_slab_add_vertex(s, s->nv, p, EN_V_OWNED);
}

static void quad(en_slab *s, uint32_t a, uint32_t b, uint32_t c, uint32_t d)
{
    en_slab_add_face(s, a, b, c);
    en_slab_add_face(s, a, c, d);
}

/* Box from 8 corners given in the order
 *      7-----6
 *     /|    /|        bottom 0 1 2 3 (counter-clockwise seen from above),
 *    4-----5 |        top    4 5 6 7 above them
 *    | 3---|-2
 *    |/    |/
 *    0-----1
 * every square split into two triangles, outward orientation. */
static void box(en_slab *s, const double c[8][3])
{
    en_slab_init(s);
    for (int i = 0; i < 8; i++)
        add(s, c[i][0], c[i][1], c[i][2]);
    quad(s, 0, 3, 2, 1); /* bottom */
    quad(s, 4, 5, 6, 7); /* top */
    quad(s, 0, 1, 5, 4);
    quad(s, 1, 2, 6, 5);
    quad(s, 2, 3, 7, 6);
    quad(s, 3, 0, 4, 7);
    en_slab_build_stars(s);
}

/* How many vertex polygons enclose each Gaussian vertex, by brute force. */
static void coverage(const gauss_sphere *g, const en_slab *s, const classified *c, uint32_t *cover)
{
    memset(cover, 0, g->nverts * sizeof *cover);
    double normals[64][3];
    for (uint32_t v = 0; v < s->nv; v++) {
        uint32_t deg = en_slab_degree(s, v), m = 0;
        for (uint32_t i = 0; i < deg; i++)
            memcpy(normals[m++], c->fnormal + 3 * s->star[s->star_start[v] + i], sizeof normals[0]);
        double centre[3];
        if (gauss_in_open_hemisphere((const double(*)[3])normals, m, centre) != GAUSS_HEMI_CENTRE)
            continue;
        for (uint32_t id = 0; id < g->nverts; id++)
            if (gauss_winding(g, (const double(*)[3])normals, m, id, centre) != 0)
                cover[id]++;
    }
}

static void every_gvertex_covered_once(const en_slab *s, const char *what)
{
    gauss_rotation r;
    gauss_rotation_identity(&r);
    for (int level = 0; level <= 3; level++) {
        gauss_sphere g;
        gauss_init_level(&g, level, &r);
        classified c;
        classify_all(&g, s, &c);
        uint32_t *cover = malloc(g.nverts * sizeof *cover);
        coverage(&g, s, &c, cover);
        uint32_t once = 0;
        for (uint32_t id = 0; id < g.nverts; id++)
            once += cover[id] == 1;
        if (once != g.nverts)
            fprintf(stderr, "  %s level %d: %u of %u Gaussian vertices covered exactly once\n", what, level,
                    once, g.nverts);
        CHECK_EQ_INT(once, g.nverts);
        /* and the classifier agrees: a vertex is a sample iff it covers one */
        uint32_t samples = 0;
        for (uint32_t v = 0; v < s->nv; v++)
            samples += (c.vclass[v] & EN_C_SAMPLE) != 0;
        CHECK(samples >= 1 && samples <= s->nv);
        free(cover);
        classified_free(&c);
    }
}

/* Identity rotation: every face normal of the cube is exactly a Gaussian
 * vertex (±e_x, ±e_y, ±e_z) and every cube edge maps onto a Gaussian edge.
 * The symbolic tie-break must still give each Gaussian vertex to exactly one
 * corner. */
TEST(tie_normals_exactly_on_gaussian_vertices_of_a_cube)
{
    const double c[8][3] = { { -1, -1, -1 }, { 1, -1, -1 }, { 1, 1, -1 }, { -1, 1, -1 },
                             { -1, -1, 1 },  { 1, -1, 1 },  { 1, 1, 1 },  { -1, 1, 1 } };
    en_slab s;
    box(&s, c);
    every_gvertex_covered_once(&s, "cube");
    en_slab_free(&s);
}

/* A square prism turned 45 degrees, exact integer corners: its side normals
 * (±1,±1,0) lie exactly on Gaussian edges at level 0 and exactly on Gaussian
 * vertices from level 1 on. */
TEST(tie_normals_exactly_on_gaussian_edges_of_a_diamond_prism)
{
    const double c[8][3] = { { 1, 0, -1 }, { 0, 1, -1 }, { -1, 0, -1 }, { 0, -1, -1 },
                             { 1, 0, 1 },  { 0, 1, 1 },  { -1, 0, 1 },  { 0, -1, 1 } };
    en_slab s;
    box(&s, c);
    every_gvertex_covered_once(&s, "diamond prism");
    en_slab_free(&s);
}

/* Fan around vertex 0 at the origin with neighbours P_i, faces (0,P_i,P_i+1). */
static void fan(en_slab *s, const double (*p)[3], int n)
{
    en_slab_init(s);
    add(s, 0, 0, 0);
    for (int i = 0; i < n; i++)
        add(s, p[i][0], p[i][1], p[i][2]);
    for (int i = 0; i < n; i++)
        en_slab_add_face(s, 0, (uint32_t)(1 + i), (uint32_t)(1 + (i + 1) % n));
    en_slab_build_stars(s);
}

static int winding_about_up(const en_slab *s, const classified *c, const gauss_sphere *g)
{
    double normals[64][3], centre[3];
    uint32_t deg = en_slab_degree(s, 0);
    for (uint32_t i = 0; i < deg; i++)
        memcpy(normals[i], c->fnormal + 3 * s->star[s->star_start[0] + i], sizeof normals[0]);
    if (gauss_in_open_hemisphere((const double(*)[3])normals, deg, centre) != GAUSS_HEMI_CENTRE)
        return 99;
    return gauss_winding(g, (const double(*)[3])normals, deg, gauss_vertex_id(g, 0, 0, (int32_t)g->n), centre);
}

/*
 * Saddle z = x^2 - y^2 sampled at four neighbours, up, down, up, down:
 *
 *            (0,1,-1)
 *               |
 *   (-1,0,1) ---0--- (1,0,1)         face normals (-1,1,1) (1,1,1) (1,-1,1)
 *               |                    (-1,-1,1): going around +z clockwise,
 *            (0,-1,-1)               so the winding about +z is -1.
 */
TEST(saddle_winds_minus_one_and_is_a_sample)
{
    const double p[4][3] = { { 1, 0, 1 }, { 0, 1, -1 }, { -1, 0, 1 }, { 0, -1, -1 } };
    en_slab s;
    fan(&s, p, 4);
    gauss_rotation r;
    gauss_rotation_identity(&r);
    gauss_sphere g;
    gauss_init_level(&g, 0, &r);
    classified c;
    classify_all(&g, &s, &c);
    CHECK_EQ_INT(winding_about_up(&s, &c, &g), -1);
    CHECK(c.vclass[0] & EN_C_SAMPLE);
    CHECK(!(c.vclass[0] & EN_C_LOCKED));
    CHECK_EQ_INT(c.vgvertex[0], (int32_t)gauss_vertex_id(&g, 0, 0, 1));
    classified_free(&c);
    en_slab_free(&s);
}

/* Monkey saddle z = r^3 cos 3t: six neighbours alternating up and down; the
 * normals go twice around +z clockwise: winding -2. */
TEST(monkey_saddle_winds_minus_two)
{
    double p[6][3];
    for (int i = 0; i < 6; i++) {
        double t = M_PI / 3 * i;
        p[i][0] = cos(t);
        p[i][1] = sin(t);
        p[i][2] = i % 2 ? -1 : 1;
    }
    en_slab s;
    fan(&s, (const double(*)[3])p, 6);
    gauss_rotation r;
    gauss_rotation_identity(&r);
    gauss_sphere g;
    gauss_init_level(&g, 1, &r);
    classified c;
    classify_all(&g, &s, &c);
    CHECK_EQ_INT(winding_about_up(&s, &c, &g), -2);
    CHECK(c.vclass[0] & EN_C_SAMPLE);
    classified_free(&c);
    en_slab_free(&s);
}

/* A gentle cone tip: normals all near +z, inside one Gaussian triangle at
 * level 0 away from its corners -> not a candidate, not a sample. */
TEST(flat_cone_tip_inside_one_gaussian_triangle_is_not_a_sample)
{
    double p[8][3];
    for (int i = 0; i < 8; i++) {
        double t = M_PI / 4 * i;
        p[i][0] = cos(t);
        p[i][1] = sin(t);
        p[i][2] = -0.05;
    }
    en_slab s;
    fan(&s, (const double(*)[3])p, 8);
    gauss_rotation r;
    gauss_rotation_axis_angle(1, 1, 0, 30, &r); /* tilt so +z is well inside a triangle */
    gauss_sphere g;
    gauss_init_level(&g, 0, &r);
    classified c;
    classify_all(&g, &s, &c);
    CHECK(!(c.vclass[0] & EN_C_CANDIDATE));
    CHECK(!(c.vclass[0] & EN_C_SAMPLE));
    classified_free(&c);
    en_slab_free(&s);
}

/*
 * Needle tip: a fan that folds back over itself, so some faces face up and
 * some down:
 *        P1 (120 deg)
 *         \          faces (0,P0,P1), (0,P1,P2) turn counter-clockwise: +z;
 *   P3 --- 0 --- P0  (0,P2,P3) turns back clockwise from 240 to 180 deg: -z;
 *         /          (0,P3,P0) from 180 to 360 deg: +z.
 *        P2 (240 deg)
 * Normals +z and -z are in no open hemisphere: a sample (docs/method.md §8).
 */
TEST(needle_tip_is_a_sample)
{
    const double p[4][3] = { { 1, 0, 0 }, { -0.5, 0.8660254037844386, 0 }, { -0.5, -0.8660254037844386, 0 },
                             { -1, 0, 0 } };
    en_slab s;
    fan(&s, p, 4);
    gauss_rotation r;
    gauss_rotation_default(&r);
    gauss_sphere g;
    gauss_init_level(&g, 2, &r);
    classified c;
    classify_all(&g, &s, &c);
    CHECK(c.vclass[0] & EN_C_NEEDLE);
    CHECK(c.vclass[0] & EN_C_SAMPLE);
    CHECK_EQ_U64(c.counts.needles, 1);
    /* the rim vertices are boundary vertices: locked samples */
    for (uint32_t v = 1; v <= 4; v++)
        CHECK(c.vclass[v] & EN_C_LOCKED);
    classified_free(&c);
    en_slab_free(&s);
}

int main(void)
{
    RUN(tie_normals_exactly_on_gaussian_vertices_of_a_cube);
    RUN(tie_normals_exactly_on_gaussian_edges_of_a_diamond_prism);
    RUN(saddle_winds_minus_one_and_is_a_sample);
    RUN(monkey_saddle_winds_minus_two);
    RUN(flat_cone_tip_inside_one_gaussian_triangle_is_not_a_sample);
    RUN(needle_tip_is_a_sample);
    return tl_finish();
}
