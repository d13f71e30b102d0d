/*
 * Glued membranes (core/membrane.h, docs/method.md §13): which faces of a
 * small mesh are a zero-volume double sheet the target stage may drop.
 */
#include "core/membrane.h"
#include "testlib.h"

/* A tetrahedron 0-3, outward faces, plus whatever faces a test adds. */
static const double P[6][3] = { { 0, 0, 0 }, { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 }, { 0.5, -0.5, 0.5 }, { 3, 3, 3 } };
static const uint32_t TET[4][3] = { { 0, 2, 1 }, { 0, 1, 3 }, { 0, 3, 2 }, { 1, 2, 3 } };

static int64_t membranes(const uint32_t (*extra)[3], int n, uint8_t *drop, const uint8_t *fflags, uint8_t need)
{
    en_slab s;
    en_slab_init(&s);
    for (int i = 0; i < 6; i++)
        en_slab_add_vertex(&s, (uint64_t)i, P[i], EN_V_OWNED | EN_V_TARGET);
    for (int i = 0; i < 4; i++)
        en_slab_add_face(&s, TET[i][0], TET[i][1], TET[i][2]);
    for (int i = 0; i < n; i++)
        en_slab_add_face(&s, extra[i][0], extra[i][1], extra[i][2]);
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    int64_t got = en_find_membranes(&s, fflags, need, drop);
    en_slab_free(&s);
    return got;
}

/* A fin on edge 0-1, apex 4, both sides: faces 4 and 5 go, the solid's stay. */
TEST(a_fin_glued_on_an_edge_is_a_membrane)
{
    const uint32_t fin[2][3] = { { 0, 1, 4 }, { 1, 0, 4 } };
    uint8_t drop[6];
    CHECK_EQ_INT((int)membranes(fin, 2, drop, NULL, 0), 2);
    const uint8_t want[6] = { 0, 0, 0, 0, 1, 1 };
    for (int f = 0; f < 6; f++)
        CHECK_EQ_INT(drop[f], want[f]);
}

/* A double triangle touching nothing else is a component: it stays. So
 * does a fin of one side only (not a double sheet), and a face that
 * doubles a face of the solid in reverse: dropping both would open it. */
TEST(floating_one_sided_and_surface_doubles_stay)
{
    const uint32_t floating[2][3] = { { 5, 4, 3 }, { 5, 3, 4 } };
    const uint32_t one_side[1][3] = { { 0, 1, 4 } };
    const uint32_t rev[1][3] = { { 3, 2, 1 } };
    uint8_t drop[6];
    CHECK_EQ_INT((int)membranes(floating, 2, drop, NULL, 0), 0);
    CHECK_EQ_INT((int)membranes(one_side, 1, drop, NULL, 0), 0);
    CHECK_EQ_INT((int)membranes(rev, 1, drop, NULL, 0), 0);
}

/* Four faces on 0-1-4, two each way: two pairs, all go. With one more
 * face one way, a pair is left over with it: dropping the pairs would
 * leave that face alone on edges 1-4 and 4-0, a one-sided fin with a
 * boundary, so they all stay. */
TEST(faces_pair_by_orientation_and_a_lone_face_keeps_its_sheet)
{
    const uint32_t fins[5][3] = { { 0, 1, 4 }, { 1, 4, 0 }, { 1, 0, 4 }, { 0, 4, 1 }, { 4, 0, 1 } };
    uint8_t drop[9];
    CHECK_EQ_INT((int)membranes(fins, 4, drop, NULL, 0), 4);
    for (int f = 0; f < 8; f++)
        CHECK_EQ_INT(drop[f], f >= 4);
    CHECK_EQ_INT((int)membranes(fins, 5, drop, NULL, 0), 0);
}

/* A slab drops a sheet only when it holds every face of it alone. */
TEST(a_sheet_with_a_face_the_caller_keeps_stays)
{
    const uint32_t fin[2][3] = { { 0, 1, 4 }, { 1, 0, 4 } };
    uint8_t drop[6];
    const uint8_t all[6] = { 1, 1, 1, 1, 1, 1 }, one[6] = { 1, 1, 1, 1, 1, 0 };
    CHECK_EQ_INT((int)membranes(fin, 2, drop, all, 1), 2);
    CHECK_EQ_INT((int)membranes(fin, 2, drop, one, 1), 0);
}

int main(void)
{
    RUN(a_fin_glued_on_an_edge_is_a_membrane);
    RUN(floating_one_sided_and_surface_doubles_stay);
    RUN(faces_pair_by_orientation_and_a_lone_face_keeps_its_sheet);
    RUN(a_sheet_with_a_face_the_caller_keeps_stays);
    return tl_finish();
}
