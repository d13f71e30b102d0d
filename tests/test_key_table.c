/*
 * The key table (common/key_table.h): exact answers through growth, and a
 * table emptied by en_key_reset forgets every key and, sized for what
 * comes, takes it without growing, in the slots it already had.
 */
#include <stdlib.h>
#include <string.h>

#include "common/key_table.h"
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

TEST(a_reset_table_forgets_its_keys_and_reuses_its_slots)
{
    en_key_table t;
    en_key_init(&t, 12);
    uint8_t key[12];
    for (int round = 0; round < 3; round++) {
        uint32_t n = round == 1 ? 100 : 3000; /* smaller, then larger again */
        CHECK_EQ_INT(en_key_reset(&t, n), 0);
        CHECK_EQ_U64(t.used, 0);
        const uint8_t *slots = t.slots;
        size_t cap = t.cap;
        CHECK(cap >= 2 * (size_t)n);
        for (uint32_t i = 0; i < n; i++) {
            uint64_t found = 0;
            int added = 0;
            key_of(i + (uint32_t)round, key); /* the last round's keys shifted by one */
            CHECK_EQ_INT(en_key_find(&t, key, i, &found, &added), 0);
            CHECK_EQ_INT(added, 1);
        }
        CHECK(t.slots == slots); /* sized for n: no growth */
        CHECK_EQ_U64(t.cap, cap);
        uint64_t found = 0;
        int added = 0;
        key_of(0, key);
        uint64_t absent = UINT64_MAX;
        CHECK_EQ_INT(en_key_find(&t, key, absent, &found, &added), 0);
        CHECK_EQ_INT(added, 0);
        CHECK_EQ_U64(found, round == 0 ? 0 : UINT64_MAX); /* key 0 only in round 0 */
    }
    size_t bytes = t.bytes;
    CHECK_EQ_INT(en_key_reset(&t, 10), 0); /* smaller: the same slots */
    CHECK_EQ_U64(t.bytes, bytes);
    en_key_free(&t);
}

int main(void)
{
    RUN(every_key_keeps_its_first_value_through_growth);
    RUN(a_reset_table_forgets_its_keys_and_reuses_its_slots);
    return tl_finish();
}
