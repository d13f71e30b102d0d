#include "render/vertex_table.h"

#include <string.h>

#include "common/alloc.h"

#define EMPTY_KEY UINT64_MAX

void en_vertex_table_init(en_vertex_table *t, int hashed, uint64_t max_bytes)
{
    memset(t, 0, sizeof *t);
    t->hashed = hashed;
    t->max_bytes = max_bytes;
}

void en_vertex_table_free(en_vertex_table *t)
{
    en_free(t->pos);
    en_free(t->key);
    memset(t, 0, sizeof *t);
}

uint64_t en_vertex_table_bytes(const en_vertex_table *t)
{
    return (uint64_t)t->cap * (3 * sizeof(double) + (t->hashed ? sizeof(uint64_t) : 0));
}

static size_t home_slot(uint64_t gid, size_t cap)
{
    /* note: Fibonacci hashing; streaming indices are consecutive, and the
     * multiply spreads them over the whole table. */
    return (size_t)((gid * 0x9e3779b97f4a7c15ull) >> 17) & (cap - 1);
}

static void hashed_insert(uint64_t *key, double *pos, size_t cap, uint64_t gid, const double xyz[3])
{
    size_t i = home_slot(gid, cap);
    while (key[i] != EMPTY_KEY)
        i = (i + 1) & (cap - 1);
    key[i] = gid;
    memcpy(pos + 3 * i, xyz, 3 * sizeof *pos);
}

static int hashed_grow(en_vertex_table *t)
{
    size_t cap = t->cap ? 2 * t->cap : 1024;
    uint64_t bytes = (uint64_t)cap * (3 * sizeof(double) + sizeof(uint64_t));
    if (t->max_bytes && bytes > t->max_bytes)
        return EN_VT_LIMIT;
    if (cap > SIZE_MAX / (3 * sizeof(double)))
        return EN_VT_NOMEM;
    uint64_t *key = en_malloc(cap * sizeof *key);
    double *pos = en_malloc(cap * 3 * sizeof *pos);
    if (!key || !pos) {
        en_free(key);
        en_free(pos);
        return EN_VT_NOMEM;
    }
    for (size_t i = 0; i < cap; i++)
        key[i] = EMPTY_KEY;
    for (size_t i = 0; i < t->cap; i++)
        if (t->key[i] != EMPTY_KEY)
            hashed_insert(key, pos, cap, t->key[i], t->pos + 3 * i);
    en_free(t->key);
    en_free(t->pos);
    t->key = key;
    t->pos = pos;
    t->cap = cap;
    return 0;
}

static int dense_grow(en_vertex_table *t)
{
    size_t cap = t->cap ? 2 * t->cap : 1024;
    if (t->max_bytes && (uint64_t)cap * 3 * sizeof(double) > t->max_bytes) {
        cap = (size_t)(t->max_bytes / (3 * sizeof(double)));
        if (cap <= t->count)
            return EN_VT_LIMIT;
    }
    if (cap > SIZE_MAX / (3 * sizeof(double)))
        return EN_VT_NOMEM;
    double *pos = en_realloc(t->pos, cap * 3 * sizeof *pos);
    if (!pos)
        return EN_VT_NOMEM;
    t->pos = pos;
    t->cap = cap;
    return 0;
}

int en_vertex_table_add(en_vertex_table *t, uint64_t gid, const double xyz[3])
{
    if (!t->hashed) {
        if (gid != t->count)
            return EN_VT_NOMEM; /* cannot happen: the reader numbers vertices in order */
        int rc = t->count == t->cap ? dense_grow(t) : 0;
        if (rc)
            return rc;
        memcpy(t->pos + 3 * t->count++, xyz, 3 * sizeof *t->pos);
        return 0;
    }
    if (gid == EMPTY_KEY)
        return EN_VT_LIMIT;
    /* note: at most half full, so probes stay short and always end. */
    if (2 * (t->count + 1) > t->cap) {
        int rc = hashed_grow(t);
        if (rc)
            return rc;
    }
    hashed_insert(t->key, t->pos, t->cap, gid, xyz);
    t->count++;
    return 0;
}

static size_t hashed_find(const en_vertex_table *t, uint64_t gid)
{
    if (!t->cap)
        return SIZE_MAX;
    for (size_t i = home_slot(gid, t->cap);; i = (i + 1) & (t->cap - 1)) {
        if (t->key[i] == gid)
            return i;
        if (t->key[i] == EMPTY_KEY)
            return SIZE_MAX;
    }
}

const double *en_vertex_table_get(const en_vertex_table *t, uint64_t gid)
{
    if (!t->hashed)
        return gid < t->count ? t->pos + 3 * gid : NULL;
    size_t i = hashed_find(t, gid);
    return i == SIZE_MAX ? NULL : t->pos + 3 * i;
}

void en_vertex_table_remove(en_vertex_table *t, uint64_t gid)
{
    if (!t->hashed)
        return;
    size_t hole = hashed_find(t, gid);
    if (hole == SIZE_MAX)
        return;
    /* Backward-shift deletion: move later members of the probe run into
     * the hole when their home slot does not lie strictly after it, so every
     * key stays reachable from its home without tombstones. */
    size_t mask = t->cap - 1;
    for (size_t i = (hole + 1) & mask; t->key[i] != EMPTY_KEY; i = (i + 1) & mask) {
        size_t home = home_slot(t->key[i], t->cap);
        if (((i - home) & mask) >= ((i - hole) & mask)) {
            t->key[hole] = t->key[i];
            memcpy(t->pos + 3 * hole, t->pos + 3 * i, 3 * sizeof *t->pos);
            hole = i;
        }
    }
    t->key[hole] = EMPTY_KEY;
    t->count--;
}
