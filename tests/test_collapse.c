/*
 * The collapse core on meshes small enough to follow by hand: which target a
 * vertex goes to, what becomes of its faces, and which refusal stops it.
 */
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
    return en_collapse_slab(&r->s, r->removable, r->q, r->ref, &cs, r->falive, r->valive, r->tri, &r->cc);
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

int main(void)
{
    RUN(flat_fan_centre_goes_to_smallest_neighbour_and_its_faces_follow);
    RUN(tetrahedron_corner_is_refused_as_duplicate_or_for_its_normal);
    return tl_finish();
}
