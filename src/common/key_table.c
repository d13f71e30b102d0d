#include "common/key_table.h"

#include <string.h>

#include "common/alloc.h"
#include "common/hash64.h"

/* note: a word at a time, the rest a byte at a time: the keys are mostly
 * coordinates' bits (8 or 4 bytes each), and hashing them byte by byte was
 * most of a lookup's time where seams are looked for in every slab and
 * seam mesh (core/slab.c: any_shared_position; bench/RESULTS.md, session
 * 30). Any spread will do: no one walks the slots in order. */
static size_t key_hash(const uint8_t *k, size_t n)
{
    uint64_t h = n;
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        uint64_t w;
        memcpy(&w, k + i, 8);
        h = (h ^ w) * 0x9e3779b97f4a7c15ull;
        h ^= h >> 29;
    }
    for (; i < n; i++)
        h = (h ^ k[i]) * 0x100000001b3ull;
    return en_hash_slot(h, SIZE_MAX);
}

/* Zeroed slots, written before they are read.
 * note: not calloc: a large calloc is fresh pages that the first probe
 * maps to the shared zero page, and the first insert then copies it, each
 * copy flushing the page from every core's TLB (a table of the seams'
 * search did that in 2.5% of a size's samples; bench/RESULTS.md, session
 * 31). */
static uint8_t *zeroed_slots(size_t cap, size_t slot_size)
{
    if (cap > SIZE_MAX / slot_size)
        return NULL;
    uint8_t *slots = en_malloc(cap * slot_size);
    if (slots)
        memset(slots, 0, cap * slot_size);
    return slots;
}

static int key_grow(en_key_table *t)
{
    size_t cap = t->cap ? t->cap * 2 : 1024;
    uint8_t *slots = zeroed_slots(cap, t->slot_size);
    if (!slots)
        return -1;
    for (size_t i = 0; i < t->cap; i++) {
        const uint8_t *s = t->slots + i * t->slot_size;
        uint64_t v;
        memcpy(&v, s, 8);
        if (!v)
            continue;
        size_t j = key_hash(s + 8, t->key_size) & (cap - 1);
        while (memcpy(&v, slots + j * t->slot_size, 8), v)
            j = (j + 1) & (cap - 1);
        memcpy(slots + j * t->slot_size, s, t->slot_size);
    }
    en_free(t->slots);
    t->slots = slots;
    t->cap = cap;
    return 0;
}

int en_key_find(en_key_table *t, const uint8_t *key, uint64_t value, uint64_t *found, int *added)
{
    *added = 0;
    if ((t->used + 1) * 2 > t->cap && key_grow(t))
        return -1;
    size_t j = key_hash(key, t->key_size) & (t->cap - 1);
    for (;; j = (j + 1) & (t->cap - 1)) {
        uint8_t *s = t->slots + j * t->slot_size;
        uint64_t v;
        memcpy(&v, s, 8);
        if (!v)
            break;
        if (memcmp(s + 8, key, t->key_size) == 0) {
            *found = v - 1;
            return 0;
        }
    }
    *found = value;
    if (value == UINT64_MAX)
        return 0;
    uint8_t *s = t->slots + j * t->slot_size;
    uint64_t v = value + 1;
    memcpy(s, &v, 8);
    memcpy(s + 8, key, t->key_size);
    t->used++;
    *added = 1;
    return 0;
}

void en_key_set(en_key_table *t, const uint8_t *key, uint64_t value)
{
    size_t j = key_hash(key, t->key_size) & (t->cap - 1);
    for (;; j = (j + 1) & (t->cap - 1)) {
        uint8_t *s = t->slots + j * t->slot_size;
        if (memcmp(s + 8, key, t->key_size) == 0) {
            uint64_t v = value + 1;
            memcpy(s, &v, 8);
            return;
        }
    }
}

void en_key_init(en_key_table *t, size_t key_size)
{
    memset(t, 0, sizeof *t);
    t->key_size = key_size;
    t->slot_size = 8 + key_size;
}

void en_key_free(en_key_table *t)
{
    en_free(t->slots);
    memset(t, 0, sizeof *t);
}
