/*
 * The stream id map (common/idmap.h): recent ids in a ring, ids still
 * present when their slot is needed in a hash map; answers are those of a
 * plain map whatever the mix, and ids only grow.
 */
#include <stdlib.h>

#include "common/idmap.h"
#include "testlib.h"

/* A window of live ids slides along, with a few ids kept alive far longer
 * (a vertex used again much later): every answer matches a reference
 * array, including after the long-lived ids were pushed out of the ring. */
TEST(answers_match_a_plain_map_with_long_lived_ids)
{
    enum { N = 20000, WIDTH = 150 };
    en_idmap m;
    CHECK_EQ_INT(en_idmap_init(&m, 100), 0); /* rounds up to 128 slots: WIDTH overflows it */
    int *present = calloc(N, sizeof *present);
    size_t count = 0;
    for (uint64_t id = 0; id < N; id++) {
        CHECK_EQ_INT(en_idmap_put(&m, id, (uint32_t)(id * 7 + 1)), 0);
        present[id] = 1;
        count++;
        if (id >= WIDTH && (id - WIDTH) % 97 != 0) { /* every 97th id stays to the end */
            CHECK_EQ_INT(en_idmap_remove(&m, id - WIDTH), 1);
            present[id - WIDTH] = 0;
            count--;
        }
        if (id % 1000 == 999) {
            for (uint64_t q = 0; q <= id + 3; q++) {
                uint32_t v = 0;
                int got = en_idmap_get(&m, q, &v);
                CHECK_EQ_INT(got, q <= id && present[q]);
                if (got)
                    CHECK_EQ_U64(v, q * 7 + 1);
            }
            CHECK_EQ_U64(m.count, count);
        }
    }
    CHECK(m.old.count > 0); /* the long-lived ids did leave the ring */
    CHECK_EQ_INT(en_idmap_remove(&m, 97), 1);
    CHECK_EQ_INT(en_idmap_remove(&m, 97), 0);
    uint32_t v;
    CHECK_EQ_INT(en_idmap_get(&m, 97, &v), 0);
    free(present);
    en_idmap_free(&m);
}

/* A growing ring (en_idmap_init_growing) starts at 64 slots and doubles
 * to the window's width instead of pushing live ids to the hash: the same
 * answers as a plain map, the window's ids never leave the ring, and the
 * long-lived ones do once the ring is four times the ids present. */
TEST(a_growing_ring_widens_to_the_window)
{
    enum { N = 20000, WIDTH = 1000 };
    en_idmap m;
    CHECK_EQ_INT(en_idmap_init_growing(&m, 1 << 20), 0);
    CHECK_EQ_U64(m.ring_mask + 1, 64);
    int *present = calloc(N, sizeof *present);
    for (uint64_t id = 0; id < N; id++) {
        CHECK_EQ_INT(en_idmap_put(&m, id, (uint32_t)(id * 3 + 2)), 0);
        present[id] = 1;
        if (id >= WIDTH && (id - WIDTH) % 501 != 0) { /* every 501st id stays to the end */
            CHECK_EQ_INT(en_idmap_remove(&m, id - WIDTH), 1);
            present[id - WIDTH] = 0;
        }
        if (id == WIDTH)
            CHECK_EQ_U64(m.old.count, 0); /* grew rather than push the window out */
    }
    for (uint64_t q = 0; q < N + 2; q++) {
        uint32_t v = 0;
        int got = en_idmap_get(&m, q, &v);
        CHECK_EQ_INT(got, q < N && present[q]);
        if (got)
            CHECK_EQ_U64(v, q * 3 + 2);
    }
    CHECK(m.ring_mask + 1 >= WIDTH && m.ring_mask + 1 <= 8 * (WIDTH + N / 501 + 1)); /* doubled below 4x */
    CHECK(m.old.count > 0);
    free(present);
    en_idmap_free(&m);
}

/* Ids come in stream order: an id below one already put is refused and
 * changes nothing. */
TEST(an_id_older_than_the_last_put_is_refused)
{
    en_idmap m;
    CHECK_EQ_INT(en_idmap_init(&m, 64), 0);
    CHECK_EQ_INT(en_idmap_put(&m, 10, 1), 0);
    CHECK_EQ_INT(en_idmap_put(&m, 5, 2), -1);
    CHECK_EQ_INT(en_idmap_put(&m, 10, 3), -1);
    uint32_t v;
    CHECK_EQ_INT(en_idmap_get(&m, 10, &v), 1);
    CHECK_EQ_U64(v, 1);
    CHECK_EQ_INT(en_idmap_get(&m, 5, &v), 0);
    CHECK_EQ_U64(m.count, 1);
    en_idmap_free(&m);
}

int main(void)
{
    RUN(answers_match_a_plain_map_with_long_lived_ids);
    RUN(a_growing_ring_widens_to_the_window);
    RUN(an_id_older_than_the_last_put_is_refused);
    return tl_finish();
}
