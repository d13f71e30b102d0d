/*
 * The collapse core on meshes small enough to follow by hand: which target a
 * vertex goes to, what becomes of its faces, and which refusal stops it.
 */
#include "core/attr_quadric.h"
#include "core/collapse.h"
#include "testlib.h"

typedef struct run {
    en_slab s;
    en_quadric q[8];
    double ref[3 * 8];
    uint8_t removable[8], falive[8], valive[8];
    uint32_t tri[3 * 8];
    en_collapse_counts cc;
} run;

static void build(run *r, const double (*p)[3], int nv, const uint32_t (*f)[3], int nt)
{
    en_slab_init(&r->s);
    for (int i = 0; i < nv; i++)
        en_slab_add_vertex(&r->s, (uint64_t)i, p[i], EN_V_OWNED | EN_V_TARGET);
    for (int i = 0; i < nt; i++)
        en_slab_add_face(&r->s, f[i][0], f[i][1], f[i][2]);
    CHECK_EQ_INT(en_slab_build_stars(&r->s), 0);
    en_quadrics_from_faces(&r->s, r->q, r->ref);
    memset(r->removable, 0, sizeof r->removable);
}

static int collapse(run *r, double max_dev)
{
    en_collapse_settings cs = { .max_normal_dev_deg = max_dev };
    return en_collapse_slab(&r->s, r->removable, r->q, r->ref, &cs, r->falive, r->valive, r->tri, &r->cc, NULL);
}

/*
 *        3 ---- 2
 *       / \    / \        a flat hexagon, faces f_i = (0, i+1, i+2)
 *      4 -- 0 ---- 1      counter-clockwise, wrapping 6 -> 1; only the
 *       \  / \   /        centre 0 may go. Every pair costs exactly 0 on
 *        5 ---- 6         the plane, so the tie goes to the smallest id, 1.
 */
TEST(flat_fan_centre_goes_to_smallest_neighbour_and_its_faces_follow)
{
    const double h = 0.8660254037844386;
    const double p[7][3] = { { 0, 0, 0 },   { 1, 0, 0 },  { 0.5, h, 0 }, { -0.5, h, 0 },
                             { -1, 0, 0 },  { -0.5, -h, 0 }, { 0.5, -h, 0 } };
    const uint32_t f[6][3] = { { 0, 1, 2 }, { 0, 2, 3 }, { 0, 3, 4 }, { 0, 4, 5 }, { 0, 5, 6 }, { 0, 6, 1 } };
    run r;
    build(&r, p, 7, f, 6);
    r.removable[0] = 1;
    CHECK_EQ_INT(collapse(&r, 60), 0);
    CHECK_EQ_U64(r.cc.collapses, 1);
    CHECK_EQ_U64(r.cc.remaining, 0);
    CHECK_EQ_INT(r.valive[0], 0);
    for (int v = 1; v < 7; v++)
        CHECK_EQ_INT(r.valive[v], 1);
    /* the two faces on edge 0-1 go, the others are re-cornered from 0 to 1 */
    const uint8_t alive[6] = { 0, 1, 1, 1, 1, 0 };
    for (int i = 0; i < 6; i++) {
        CHECK_EQ_INT(r.falive[i], alive[i]);
        if (!alive[i])
            continue;
        CHECK_EQ_U64(r.tri[3 * i], 1);
        CHECK_EQ_U64(r.tri[3 * i + 1], f[i][1]);
        CHECK_EQ_U64(r.tri[3 * i + 2], f[i][2]);
    }
    en_slab_free(&r.s);
}

/*
 * A tetrahedron on the corner 0 of the unit axes. Collapsing 0 onto any
 * neighbour u passes the link condition (they share exactly the two others)
 * but turns the third face of 0 into the fourth face, reversed: a duplicate.
 * That face also turns by acos(1/sqrt 3) = 54.7 degrees from its input
 * normal, so a 50 degree bound refuses it first, for the normal.
 */
TEST(tetrahedron_corner_is_refused_as_duplicate_or_for_its_normal)
{
    const double p[4][3] = { { 0, 0, 0 }, { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 } };
    const uint32_t f[4][3] = { { 0, 2, 1 }, { 0, 1, 3 }, { 0, 3, 2 }, { 1, 2, 3 } };
    const struct {
        double bound;
        int kind;
    } cases[2] = { { 60, 3 }, { 50, 1 } }; /* bit of EN_REFUSE_DUPLICATE, EN_REFUSE_NORMAL */
    for (int c = 0; c < 2; c++) {
        run r;
        build(&r, p, 4, f, 4);
        r.removable[0] = 1;
        CHECK_EQ_INT(collapse(&r, cases[c].bound), 0);
        CHECK_EQ_U64(r.cc.collapses, 0);
        CHECK_EQ_U64(r.cc.remaining, 1);
        for (int k = 0; k < EN_REFUSE_KINDS; k++)
            CHECK_EQ_U64(r.cc.refused[k], k == cases[c].kind);
        for (int i = 0; i < 4; i++) {
            CHECK_EQ_INT(r.falive[i], 1);
            CHECK_EQ_INT(r.valive[i], 1);
            for (int k = 0; k < 3; k++)
                CHECK_EQ_U64(r.tri[3 * i + k], f[i][k]);
        }
        en_slab_free(&r.s);
    }
}

/* A G x G grid of unit squares, two faces each, heights z(i, j); every
 * inner vertex removable with the tier given by tier(i, j). */
#define G 6
typedef struct grid {
    en_slab s;
    en_quadric q[G * G];
    double ref[3 * 2 * (G - 1) * (G - 1)];
    uint8_t removable[G * G], falive[2 * (G - 1) * (G - 1)], valive[G * G];
    uint32_t tri[3 * 2 * (G - 1) * (G - 1)];
    en_collapse_counts cc;
} grid;

static void build_grid(grid *g, double bump, int tier2_from)
{
    en_slab_init(&g->s);
    for (int j = 0; j < G; j++)
        for (int i = 0; i < G; i++) {
            double p[3] = { i, j, bump * (double)((i * 7 + j * 3) % 5) };
            en_slab_add_vertex(&g->s, (uint64_t)(j * G + i), p, EN_V_OWNED | EN_V_TARGET);
        }
    for (int j = 0; j + 1 < G; j++)
        for (int i = 0; i + 1 < G; i++) {
            uint32_t a = (uint32_t)(j * G + i), b = a + 1, c = a + G + 1, d = a + G;
            en_slab_add_face(&g->s, a, b, c);
            en_slab_add_face(&g->s, a, c, d);
        }
    CHECK_EQ_INT(en_slab_build_stars(&g->s), 0);
    en_quadrics_from_faces(&g->s, g->q, g->ref);
    memset(g->removable, 0, sizeof g->removable);
    for (int j = 1; j + 1 < G; j++)
        for (int i = 1; i + 1 < G; i++)
            g->removable[j * G + i] = (uint8_t)(j * G + i >= tier2_from ? 2 : 1);
}

static int collapse_grid(grid *g, const en_collapse_settings *cs)
{
    return en_collapse_slab(&g->s, g->removable, g->q, g->ref, cs, g->falive, g->valive, g->tri, &g->cc, NULL);
}

static uint64_t alive_faces(const grid *g)
{
    uint64_t n = 0;
    for (uint32_t f = 0; f < g->s.nt; f++)
        n += g->falive[f];
    return n;
}

/* A face target stops the collapses at the target, or one below it (an
 * inner collapse takes two faces); a vertex target exactly at it. */
TEST(face_and_vertex_targets_stop_the_collapses)
{
    for (uint64_t keep = 49; keep >= 35; keep -= 7) {
        grid g;
        build_grid(&g, 0, G * G);
        en_collapse_settings cs = { .max_normal_dev_deg = 60, .keep_faces = keep };
        CHECK_EQ_INT(collapse_grid(&g, &cs), 0);
        CHECK(g.cc.faces_left <= keep && g.cc.faces_left + 1 >= keep);
        CHECK_EQ_U64(alive_faces(&g), g.cc.faces_left);
        CHECK_EQ_U64(g.cc.collapses, (50 - g.cc.faces_left) / 2);
        en_slab_free(&g.s);
    }
    grid g;
    build_grid(&g, 0, G * G);
    en_collapse_settings cs = { .max_normal_dev_deg = 60, .keep_vertices = 30 };
    CHECK_EQ_INT(collapse_grid(&g, &cs), 0);
    CHECK_EQ_U64(g.cc.vertices_left, 30);
    CHECK_EQ_U64(g.cc.collapses, 6);
    en_slab_free(&g.s);
}

/* The second tier joins only when the first is spent and the target is
 * still unmet: every first-tier vertex is gone before one of the second. */
TEST(second_tier_goes_only_when_the_first_cannot_meet_the_target)
{
    grid g;
    build_grid(&g, 0, 3 * G); /* rows 1 and 2 first tier, rows 3 and 4 second */
    en_collapse_settings cs = { .max_normal_dev_deg = 60, .keep_faces = 40 };
    CHECK_EQ_INT(collapse_grid(&g, &cs), 0);
    CHECK_EQ_U64(g.cc.given_up, 0); /* 8 first-tier vertices cover 10 faces */
    en_slab_free(&g.s);

    build_grid(&g, 0, 3 * G);
    cs.keep_faces = 20;
    CHECK_EQ_INT(collapse_grid(&g, &cs), 0);
    CHECK(g.cc.given_up > 0);
    for (int v = G; v < 3 * G; v++)
        if (g.removable[v] == 1)
            CHECK_EQ_INT(g.valive[v], 0);
    CHECK(g.cc.faces_left <= 20);
    en_slab_free(&g.s);

    /* no face or vertex target: the second tier never joins */
    build_grid(&g, 0, 3 * G);
    en_collapse_settings none = { .max_normal_dev_deg = 60 };
    CHECK_EQ_INT(collapse_grid(&g, &none), 0);
    CHECK_EQ_U64(g.cc.given_up, 0);
    for (int v = 3 * G; v < G * G; v++)
        CHECK_EQ_INT(g.valive[v], 1);
    en_slab_free(&g.s);
}

/* An error bound: on a flat grid every collapse costs 0 and all go; on a
 * bumpy one a tiny bound stops them and says so, and a larger bound never
 * leaves more faces. */
TEST(error_bound_refuses_dear_collapses)
{
    grid g;
    build_grid(&g, 0, G * G);
    en_collapse_settings cs = { .max_normal_dev_deg = 90, .by_error = 1, .max_error = 0 };
    CHECK_EQ_INT(collapse_grid(&g, &cs), 0);
    CHECK_EQ_INT(g.cc.stopped_by_error, 0);
    CHECK_EQ_U64(g.cc.remaining, 0);
    en_slab_free(&g.s);

    uint64_t last = UINT64_MAX, first = 0;
    const double bounds[] = { 1e-9, 0.01, 0.05, 0.2, 10 };
    for (int b = 0; b < 5; b++) {
        build_grid(&g, 0.3, G * G);
        cs.max_error = bounds[b];
        CHECK_EQ_INT(collapse_grid(&g, &cs), 0);
        if (b == 0) /* only collapses inside flat patches, if any, pass */
            CHECK_EQ_INT(g.cc.stopped_by_error, 1);
        if (b == 4)
            CHECK(g.cc.faces_left < first);
        if (b == 0)
            first = g.cc.faces_left;
        CHECK(g.cc.faces_left <= last);
        last = g.cc.faces_left;
        en_slab_free(&g.s);
    }
}

/* Quadrics taken afresh: before any collapse they are the input's own, so
 * the run is the run without; later, every vertex's quadric is that of the
 * faces then alive, and the target is still met. */
TEST(quadrics_taken_afresh)
{
    grid a, b;
    build_grid(&a, 0.3, G * G);
    build_grid(&b, 0.3, G * G);
    en_collapse_settings cs = { .max_normal_dev_deg = 90, .keep_faces = 30 };
    CHECK_EQ_INT(collapse_grid(&a, &cs), 0);
    cs.refresh_faces = 50; /* all the grid's faces: at once */
    CHECK_EQ_INT(collapse_grid(&b, &cs), 0);
    CHECK_EQ_U64(a.cc.collapses, b.cc.collapses);
    CHECK(memcmp(a.tri, b.tri, sizeof a.tri) == 0 && memcmp(a.falive, b.falive, sizeof a.falive) == 0);
    en_slab_free(&b.s);

    build_grid(&b, 0.3, G * G);
    cs.refresh_faces = 40;
    CHECK_EQ_INT(collapse_grid(&b, &cs), 0);
    CHECK(b.cc.faces_left <= 30 && b.cc.faces_left + 1 >= 30);
    /* from 40 faces on, the quadrics hold the planes of the faces then
     * alive, not every input plane: some kept vertex's differs from the
     * run that only accumulated */
    int differs = 0;
    for (int v = 0; v < G * G; v++)
        differs |= b.valive[v] && a.valive[v] && memcmp(&b.q[v], &a.q[v], sizeof a.q[v]) != 0;
    CHECK(differs);
    en_slab_free(&a.s);
    en_slab_free(&b.s);
}

/*
 * A bumpy 9 x 9 grid cut open along column 4 (a UV seam: left records
 * 0..44, columns 0-4; right records 45..89, its own copies of column 4 and
 * columns 5-8). The outer boundary stays; everything else may go, to a
 * small face target. A seam pair moves along the seam, both copies onto
 * copies of one position, or stays: no face ever takes a record of the
 * other side, and the two copies of a position live or die together.
 */
#define SG 9
TEST(a_seam_pair_collapses_along_the_seam_together)
{
    enum { NV = 2 * SG * 5, NT = 2 * 2 * (SG - 1) * 4 };
    en_slab s;
    en_slab_init(&s);
    uint32_t side[2][SG][5];
    for (int h = 0; h < 2; h++)
        for (int r = 0; r < SG; r++)
            for (int c = 0; c < 5; c++) {
                int x = h ? c + 4 : c;
                double p[3] = { x, r, 0.3 * (double)((x * 7 + r * 3) % 5) };
                side[h][r][c] = (uint32_t)en_slab_add_vertex(&s, s.nv, p, EN_V_OWNED | EN_V_TARGET);
            }
    for (int h = 0; h < 2; h++)
        for (int r = 0; r + 1 < SG; r++)
            for (int c = 0; c + 1 < 5; c++) {
                uint32_t a = side[h][r][c], b = side[h][r][c + 1], d = side[h][r + 1][c], e = side[h][r + 1][c + 1];
                en_slab_add_face(&s, a, b, e);
                en_slab_add_face(&s, a, e, d);
            }
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    static en_quadric q[NV];
    static double ref[3 * NT];
    static uint8_t removable[NV], falive[NT], valive[NV];
    static uint32_t tri[3 * NT];
    en_quadrics_from_faces(&s, q, ref);
    int pairs = 0;
    for (uint32_t v = 0; v < s.nv; v++) {
        removable[v] = !(s.vflags[v] & EN_V_BOUNDARY);
        pairs += (s.vflags[v] & EN_V_SEAM) != 0;
    }
    CHECK_EQ_INT(pairs, 2 * (SG - 2));
    en_collapse_settings cs = { .max_normal_dev_deg = 90, .keep_faces = 40 };
    en_collapse_counts cc;
    CHECK_EQ_INT(en_collapse_slab(&s, removable, q, ref, &cs, falive, valive, tri, &cc, NULL), 0);
    CHECK(cc.faces_left <= 41);
    int seam_gone = 0, mixed = 0, apart = 0;
    for (int r = 1; r + 1 < SG; r++) {
        uint32_t a = side[0][r][4], b = side[1][r][0];
        apart += valive[a] != valive[b];
        seam_gone += !valive[a];
    }
    for (uint32_t f = 0; f < s.nt; f++) {
        if (!falive[f])
            continue;
        int h = tri[3 * f] >= (uint32_t)(SG * 5);
        for (int k = 1; k < 3; k++)
            mixed += (tri[3 * f + k] >= (uint32_t)(SG * 5)) != h;
    }
    CHECK_EQ_INT(apart, 0);
    CHECK_EQ_INT(mixed, 0);
    CHECK(seam_gone > 0);
    en_slab_free(&s);
}

/* The value a face's linear field takes at p: barycentric in its plane
 * (p's offset along the normal changes nothing). */
static double field_at(const double (*tp)[3], const double *ta, const double p[3])
{
    double e1[3], e2[3], d[3];
    for (int i = 0; i < 3; i++)
        e1[i] = tp[1][i] - tp[0][i], e2[i] = tp[2][i] - tp[0][i], d[i] = p[i] - tp[0][i];
    double a = 0, b = 0, c = 0, x = 0, y = 0;
    for (int i = 0; i < 3; i++)
        a += e1[i] * e1[i], b += e1[i] * e2[i], c += e2[i] * e2[i], x += d[i] * e1[i], y += d[i] * e2[i];
    double det = a * c - b * b, l1 = (x * c - y * b) / det, l2 = (a * y - b * x) / det;
    return ta[0] + l1 * (ta[1] - ta[0]) + l2 * (ta[2] - ta[0]);
}

/*
 * A face's attribute quadric (Hoppe 1999): its fold (in the plane
 * quadric) plus its attribute part, at any position p and values a, is the
 * face's area times the squared difference between its fields at p and a,
 * on the plane and off it; the part's trace term is the fold's trace.
 */
TEST(an_attribute_quadric_is_the_squared_field_error)
{
    const double p[3][3] = { { 0.3, -1.2, 2.0 }, { 2.1, 0.4, 1.1 }, { -0.7, 1.5, 0.2 } };
    const double val[3 * 2] = { 0.25, 0.9, 0.75, 0.1, 0.4, 0.6 }; /* two channels per vertex */
    const uint32_t t[3] = { 0, 1, 2 };
    en_quadric fold;
    double aq[2 + 4 * 2];
    en_attr_face_quadric(&p[0][0], val, 2, t, &fold, aq);
    double n[3];
    en_triangle_normal(&p[0][0], t, n);
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), area = 0.5 * len;
    CHECK(fabs(aq[0] - area) <= 1e-12 * area);
    CHECK(fabs(aq[1] - (fold.a2 + fold.b2 + fold.c2)) <= 1e-12 * aq[1]);
    const double cases[4][6] = { /* l1, l2, height, a0, a1 */
                                 { 0.2, 0.3, 0.0, 0.5, 0.5 },
                                 { -0.4, 1.1, 0.7, 0.0, 1.0 },
                                 { 0.0, 0.0, -2.0, 0.25, 0.9 },
                                 { 1.5, -0.2, 0.1, 3.0, -1.0 } };
    for (int k = 0; k < 4; k++) {
        double q[3], a[2] = { cases[k][3], cases[k][4] };
        for (int i = 0; i < 3; i++)
            q[i] = p[0][i] + cases[k][0] * (p[1][i] - p[0][i]) + cases[k][1] * (p[2][i] - p[0][i]) +
                   cases[k][2] * n[i] / len;
        double want = 0;
        for (int c = 0; c < 2; c++) {
            const double ta[3] = { val[c], val[2 + c], val[4 + c] };
            double d = field_at(p, ta, q) - a[c];
            want += area * d * d;
        }
        double got = en_quadric_eval(&fold, q) + en_aq_eval(aq, 2, q, a);
        CHECK(fabs(got - want) <= 1e-9 * (1 + want));
    }
}

/*
 * The flat hexagon of the first test, with one attribute: every geometric
 * cost is 0 there, so without a weight the centre goes to vertex 1 (the
 * tie). With values, it goes where its faces' fields at the target differ
 * least from the target's own value, as a brute-force sum over its faces
 * computes it (field_at); the values are chosen so that this is not 1.
 */
TEST(an_attribute_weight_sends_a_vertex_where_its_fields_agree)
{
    const double h = 0.8660254037844386;
    const double p[7][3] = { { 0, 0, 0 },   { 1, 0, 0 },  { 0.5, h, 0 }, { -0.5, h, 0 },
                             { -1, 0, 0 },  { -0.5, -h, 0 }, { 0.5, -h, 0 } };
    const uint32_t f[6][3] = { { 0, 1, 2 }, { 0, 2, 3 }, { 0, 3, 4 }, { 0, 4, 5 }, { 0, 5, 6 }, { 0, 6, 1 } };
    const double val[7] = { 0.1, 0.9, 0.8, 0.3, 0.15, 0.2, 0.7 };
    int best = -1;
    double best_cost = INFINITY;
    for (int u = 1; u < 7; u++) {
        double cost = 0;
        for (int i = 0; i < 6; i++) {
            const double tp[3][3] = { { p[f[i][0]][0], p[f[i][0]][1], p[f[i][0]][2] },
                                      { p[f[i][1]][0], p[f[i][1]][1], p[f[i][1]][2] },
                                      { p[f[i][2]][0], p[f[i][2]][1], p[f[i][2]][2] } };
            const double ta[3] = { val[f[i][0]], val[f[i][1]], val[f[i][2]] };
            double n[3];
            en_triangle_normal(&p[0][0], f[i], n);
            double d = field_at(tp, ta, p[u]) - val[u];
            cost += 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) * d * d;
        }
        if (cost < best_cost)
            best_cost = cost, best = u;
    }
    CHECK(best != 1);
    run r;
    build(&r, p, 7, f, 6);
    r.removable[0] = 1;
    double aq[7 * (2 + 4)];
    en_attr_quadrics_from_faces(&r.s, val, 1, r.q, aq);
    en_collapse_settings cs = { .max_normal_dev_deg = 60, .attr_channels = 1, .attr_value = val, .aq = aq };
    CHECK_EQ_INT(en_collapse_slab(&r.s, r.removable, r.q, r.ref, &cs, r.falive, r.valive, r.tri, &r.cc, NULL), 0);
    CHECK_EQ_U64(r.cc.collapses, 1);
    /* the faces left are re-cornered onto the brute force's choice */
    for (int i = 0; i < 6; i++)
        if (r.falive[i])
            CHECK(r.tri[3 * i] == (uint32_t)best || r.tri[3 * i + 1] == (uint32_t)best ||
                  r.tri[3 * i + 2] == (uint32_t)best);
    CHECK_EQ_INT(r.falive[0] + r.falive[1] + r.falive[2] + r.falive[3] + r.falive[4] + r.falive[5], 4);
    en_slab_free(&r.s);
}

int main(void)
{
    RUN(flat_fan_centre_goes_to_smallest_neighbour_and_its_faces_follow);
    RUN(tetrahedron_corner_is_refused_as_duplicate_or_for_its_normal);
    RUN(face_and_vertex_targets_stop_the_collapses);
    RUN(quadrics_taken_afresh);
    RUN(second_tier_goes_only_when_the_first_cannot_meet_the_target);
    RUN(error_bound_refuses_dear_collapses);
    RUN(a_seam_pair_collapses_along_the_seam_together);
    RUN(an_attribute_quadric_is_the_squared_field_error);
    RUN(an_attribute_weight_sends_a_vertex_where_its_fields_agree);
    return tl_finish();
}
