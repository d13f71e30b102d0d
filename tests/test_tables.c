/*
 * The key table (common/key_table.h): exact answers through growth, its
 * slots zeroed by hand; and the u64set's clear (common/u64set.h), which the
 * seams' search reuses.
 */
#include <stdlib.h>
#include <string.h>

#include "common/key_table.h"
#include "common/u64set.h"
#include "testlib.h"

static void key_of(uint32_t i, uint8_t key[12])
{
    /* keys that share most bytes, as coordinates' bits do */
    uint32_t w[3] = { i / 7, 0x3ff00000u, i * 2654435761u };
    memcpy(key, w, sizeof w);
}

TEST(every_key_keeps_its_first_value_through_growth)
{
    enum { N = 50000 };
    en_key_table t;
    en_key_init(&t, 12);
    uint8_t key[12];
    for (uint32_t i = 0; i < N; i++) {
        uint64_t found = 0;
        int added = 0;
        key_of(i, key);
        CHECK_EQ_INT(en_key_find(&t, key, i, &found, &added), 0);
        CHECK_EQ_INT(added, 1);
        CHECK_EQ_U64(found, i);
    }
    CHECK_EQ_U64(t.used, N);
    for (uint32_t i = 0; i < N; i += 13) {
        uint64_t found = 0;
        int added = 1;
        key_of(i, key);
        CHECK_EQ_INT(en_key_find(&t, key, 7, &found, &added), 0);
        CHECK_EQ_INT(added, 0);
        CHECK_EQ_U64(found, i);
    }
    en_key_free(&t);
}

/* A cleared set forgets every key and, sized for what comes, takes it
 * without growing (the seams' search reuses one from slab to slab). */
TEST(a_cleared_set_forgets_its_keys_and_takes_n_without_growing)
{
    en_u64set *s = en_u64set_new();
    CHECK(s != NULL);
    for (int round = 0; round < 3; round++) {
        uint64_t n = round == 1 ? 100 : 3000; /* smaller, then larger again */
        CHECK_EQ_INT(en_u64set_clear(s, n), 0);
        CHECK_EQ_U64(en_u64set_count(s), 0);
        size_t bytes = en_u64set_bytes(s);
        for (uint64_t i = 0; i < n; i++)
            CHECK_EQ_INT(en_u64set_add(s, (i + (uint64_t)round) * 0x9e3779b97f4a7c15ull), 1);
        CHECK_EQ_U64(en_u64set_bytes(s), bytes); /* sized for n: no growth */
        CHECK_EQ_INT(en_u64set_has(s, 0), round == 0); /* key 0 only in round 0 */
        CHECK_EQ_INT(en_u64set_add(s, (uint64_t)round * 0x9e3779b97f4a7c15ull), 0);
    }
    en_u64set_free(&s);
}

int main(void)
{
    RUN(every_key_keeps_its_first_value_through_growth);
    RUN(a_cleared_set_forgets_its_keys_and_takes_n_without_growing);
    return tl_finish();
}
