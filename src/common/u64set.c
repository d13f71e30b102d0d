#include "common/u64set.h"

#include "common/alloc.h"
#include "common/hash64.h"

#define EMPTY UINT64_MAX

struct en_u64set {
    uint64_t *keys;
    size_t mask;      /* capacity - 1, capacity a power of two */
    size_t count;
    size_t allocated; /* slots in keys, kept by en_u64set_clear */
};

static int rehash(en_u64set *s, size_t cap)
{
    uint64_t *keys = en_malloc(cap * sizeof *keys);
    if (!keys)
        return -1;
    for (size_t i = 0; i < cap; i++)
        keys[i] = EMPTY;
    if (s->keys) {
        for (size_t i = 0; i <= s->mask; i++) {
            uint64_t k = s->keys[i];
            if (k == EMPTY)
                continue;
            size_t j = en_hash_slot(k, cap - 1);
            while (keys[j] != EMPTY)
                j = (j + 1) & (cap - 1);
            keys[j] = k;
        }
    }
    en_free(s->keys);
    s->keys = keys;
    s->mask = cap - 1;
    s->allocated = cap;
    return 0;
}

en_u64set *en_u64set_new(void)
{
    en_u64set *s = en_calloc(1, sizeof *s);
    if (s && rehash(s, 64)) {
        en_free(s);
        return NULL;
    }
    return s;
}

void en_u64set_free(en_u64set **ps)
{
    if (!ps || !*ps)
        return;
    en_free((*ps)->keys);
    en_free(*ps);
    *ps = NULL;
}

int en_u64set_add(en_u64set *s, uint64_t key)
{
    if ((s->count + 1) * 4 > (s->mask + 1) * 3 && rehash(s, (s->mask + 1) * 2))
        return -1;
    size_t j = en_hash_slot(key, s->mask);
    while (s->keys[j] != EMPTY) {
        if (s->keys[j] == key)
            return 0;
        j = (j + 1) & s->mask;
    }
    s->keys[j] = key;
    s->count++;
    return 1;
}

int en_u64set_clear(en_u64set *s, size_t n)
{
    size_t cap = 64;
    while ((n + 1) * 4 > cap * 3) {
        if (cap > SIZE_MAX / 2 / sizeof *s->keys)
            return -1;
        cap *= 2;
    }
    s->count = 0;
    if (cap > s->allocated) {
        en_free(s->keys);
        s->keys = NULL;
        s->mask = s->allocated = 0;
        return rehash(s, cap);
    }
    for (size_t i = 0; i < cap; i++)
        s->keys[i] = EMPTY;
    s->mask = cap - 1;
    return 0;
}

int en_u64set_has(const en_u64set *s, uint64_t key)
{
    size_t j = en_hash_slot(key, s->mask);
    while (s->keys[j] != EMPTY) {
        if (s->keys[j] == key)
            return 1;
        j = (j + 1) & s->mask;
    }
    return 0;
}

int en_u64set_remove(en_u64set *s, uint64_t key)
{
    size_t j = en_hash_slot(key, s->mask);
    while (s->keys[j] != EMPTY) {
        if (s->keys[j] == key)
            break;
        j = (j + 1) & s->mask;
    }
    if (s->keys[j] == EMPTY)
        return 0;
    /* Backward-shift deletion keeps probe chains intact without tombstones. */
    size_t hole = j;
    for (;;) {
        j = (j + 1) & s->mask;
        uint64_t k = s->keys[j];
        if (k == EMPTY)
            break;
        size_t home = en_hash_slot(k, s->mask);
        if (en_hash_can_fill(home, hole, j, s->mask)) {
            s->keys[hole] = k;
            hole = j;
        }
    }
    s->keys[hole] = EMPTY;
    s->count--;
    return 1;
}

size_t en_u64set_count(const en_u64set *s)
{
    return s->count;
}

size_t en_u64set_bytes(const en_u64set *s)
{
    return s->allocated * sizeof(uint64_t);
}
