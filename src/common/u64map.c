#include "common/u64map.h"

#include <string.h>

#include "common/alloc.h"
#include "common/hash64.h"

#define EMPTY UINT64_MAX

static int rehash(en_u64map *m, size_t cap)
{
    uint64_t *keys = en_malloc(cap * sizeof *keys);
    uint32_t *vals = en_malloc(cap * sizeof *vals);
    if (!keys || !vals) {
        en_free(keys);
        en_free(vals);
        return -1;
    }
    memset(keys, 0xff, cap * sizeof *keys);
    if (m->keys) {
        for (size_t i = 0; i <= m->mask; i++) {
            if (m->keys[i] == EMPTY)
                continue;
            size_t j = en_hash_slot(m->keys[i], cap - 1);
            while (keys[j] != EMPTY)
                j = (j + 1) & (cap - 1);
            keys[j] = m->keys[i];
            vals[j] = m->vals[i];
        }
    }
    en_free(m->keys);
    en_free(m->vals);
    m->keys = keys;
    m->vals = vals;
    m->mask = cap - 1;
    return 0;
}

int en_u64map_init(en_u64map *m)
{
    memset(m, 0, sizeof *m);
    return rehash(m, 64);
}

void en_u64map_free(en_u64map *m)
{
    en_free(m->keys);
    en_free(m->vals);
    memset(m, 0, sizeof *m);
}

void en_u64map_clear(en_u64map *m)
{
    if (m->keys)
        memset(m->keys, 0xff, (m->mask + 1) * sizeof *m->keys);
    m->count = 0;
}

int en_u64map_put(en_u64map *m, uint64_t key, uint32_t val)
{
    if ((m->count + 1) * 4 > (m->mask + 1) * 3 && rehash(m, (m->mask + 1) * 2))
        return -1;
    size_t j = en_hash_slot(key, m->mask);
    while (m->keys[j] != EMPTY) {
        if (m->keys[j] == key) {
            m->vals[j] = val;
            return 0;
        }
        j = (j + 1) & m->mask;
    }
    m->keys[j] = key;
    m->vals[j] = val;
    m->count++;
    return 0;
}

int en_u64map_get(const en_u64map *m, uint64_t key, uint32_t *val)
{
    size_t j = en_hash_slot(key, m->mask);
    while (m->keys[j] != EMPTY) {
        if (m->keys[j] == key) {
            *val = m->vals[j];
            return 1;
        }
        j = (j + 1) & m->mask;
    }
    return 0;
}

int en_u64map_remove(en_u64map *m, uint64_t key)
{
    size_t j = en_hash_slot(key, m->mask);
    while (m->keys[j] != EMPTY && m->keys[j] != key)
        j = (j + 1) & m->mask;
    if (m->keys[j] == EMPTY)
        return 0;
    /* Backward-shift deletion keeps probe chains intact without tombstones. */
    size_t hole = j;
    for (;;) {
        j = (j + 1) & m->mask;
        uint64_t k = m->keys[j];
        if (k == EMPTY)
            break;
        size_t home = en_hash_slot(k, m->mask);
        if (en_hash_can_fill(home, hole, j, m->mask)) {
            m->keys[hole] = k;
            m->vals[hole] = m->vals[j];
            hole = j;
        }
    }
    m->keys[hole] = EMPTY;
    m->count--;
    return 1;
}

size_t en_u64map_bytes(const en_u64map *m)
{
    return (m->mask + 1) * (sizeof *m->keys + sizeof *m->vals);
}
