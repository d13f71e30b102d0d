/*
 * The seam rules (pipeline/seam.h, docs/architecture.md §8): which vertex
 * may be removed and which may receive a collapse, for every holder of part
 * of the mesh (a slab worker, the stitcher's seam mesh, a later stage).
 */
#include "pipeline/seam.h"
#include "testlib.h"

/* Only a vertex whose whole star is here, undecided, and neither a sample
 * nor locked may go. */
TEST(only_a_free_vertex_is_removable)
{
    CHECK(en_removable(EN_VK_FREE));
    CHECK(!en_removable(EN_VK_SAMPLE));
    CHECK(!en_removable(EN_VK_LOCKED));
    CHECK(!en_removable(EN_VK_OPEN));
    CHECK(!en_removable(EN_VK_SETTLED));
}

/* A collapse may land on samples and locked vertices (only v moves), but
 * never on a vertex with faces out of sight or already decided. */
TEST(a_target_needs_its_whole_star_and_no_decision)
{
    CHECK(en_receives(EN_VK_FREE));
    CHECK(en_receives(EN_VK_SAMPLE));
    CHECK(en_receives(EN_VK_LOCKED));
    CHECK(!en_receives(EN_VK_OPEN));
    CHECK(!en_receives(EN_VK_SETTLED));
}

/* The core takes the table as two per-vertex inputs: that is only right
 * while every entry is its row's test times its column's. */
TEST(the_table_is_a_row_test_times_a_column_test)
{
    for (int v = 0; v < EN_VK_COUNT; v++)
        for (int u = 0; u < EN_VK_COUNT; u++)
            CHECK_EQ_INT(en_can_collapse[v][u], en_removable((en_vertex_kind)v) && en_receives((en_vertex_kind)u));
}

/* Settled beats everything (it may be on its way out), then a star not all
 * here, then locked topology, then the sample class. */
TEST(kind_follows_what_the_holder_knows_in_order)
{
    CHECK_EQ_INT(en_vertex_kind_of(1, 1, 1, 1), EN_VK_SETTLED);
    CHECK_EQ_INT(en_vertex_kind_of(0, 0, 1, 1), EN_VK_OPEN);
    CHECK_EQ_INT(en_vertex_kind_of(1, 0, 1, 1), EN_VK_LOCKED);
    CHECK_EQ_INT(en_vertex_kind_of(1, 0, 0, 1), EN_VK_SAMPLE);
    CHECK_EQ_INT(en_vertex_kind_of(1, 0, 0, 0), EN_VK_FREE);
    CHECK(en_seam_locked(EN_V_BOUNDARY) && en_seam_locked(EN_V_NONMANIFOLD) && en_seam_locked(EN_V_ISOLATED));
    CHECK(!en_seam_locked(EN_V_OWNED | EN_V_TARGET));
}

int main(void)
{
    RUN(only_a_free_vertex_is_removable);
    RUN(a_target_needs_its_whole_star_and_no_decision);
    RUN(the_table_is_a_row_test_times_a_column_test);
    RUN(kind_follows_what_the_holder_knows_in_order);
    return tl_finish();
}
