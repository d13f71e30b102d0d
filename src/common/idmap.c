#include "common/idmap.h"

#include <string.h>

#include "common/alloc.h"

static size_t ring_slots(size_t ring)
{
    size_t n = 64;
    while (n < ring && n < ((size_t)1 << 30))
        n *= 2;
    return n;
}

int en_idmap_init(en_idmap *m, size_t ring)
{
    memset(m, 0, sizeof *m);
    size_t n = ring_slots(ring);
    m->ring_max = n;
    m->ring_key = en_malloc(n * sizeof *m->ring_key);
    m->ring_val = en_malloc(n * sizeof *m->ring_val);
    if (!m->ring_key || !m->ring_val || en_u64map_init(&m->old)) {
        en_free(m->ring_key);
        en_free(m->ring_val);
        memset(m, 0, sizeof *m);
        return -1;
    }
    memset(m->ring_key, 0xff, n * sizeof *m->ring_key);
    m->ring_mask = n - 1;
    return 0;
}

int en_idmap_init_growing(en_idmap *m, size_t ring_max)
{
    if (en_idmap_init(m, 64))
        return -1;
    m->ring_max = ring_slots(ring_max);
    return 0;
}

/* Double the ring. Every id in it is within one ring size of m->next (an
 * older one with its residue was pushed out), so the ids keep distinct
 * slots in a ring twice as large. @return 0 or -1 (out of memory; m
 * unchanged). */
static int grow_ring(en_idmap *m)
{
    size_t n = 2 * (m->ring_mask + 1);
    uint64_t *key = en_malloc(n * sizeof *key);
    uint32_t *val = en_malloc(n * sizeof *val);
    if (!key || !val) {
        en_free(key);
        en_free(val);
        return -1;
    }
    memset(key, 0xff, n * sizeof *key);
    for (size_t i = 0; i <= m->ring_mask; i++) {
        uint64_t id = m->ring_key[i];
        if (id == UINT64_MAX)
            continue;
        key[id & (n - 1)] = id;
        val[id & (n - 1)] = m->ring_val[i];
    }
    en_free(m->ring_key);
    en_free(m->ring_val);
    m->ring_key = key;
    m->ring_val = val;
    m->ring_mask = n - 1;
    return 0;
}

void en_idmap_free(en_idmap *m)
{
    en_free(m->ring_key);
    en_free(m->ring_val);
    en_u64map_free(&m->old);
    memset(m, 0, sizeof *m);
}

int en_idmap_put(en_idmap *m, uint64_t id, uint32_t val)
{
    if (id < m->next || id == UINT64_MAX)
        return -1;
    size_t slot = (size_t)(id & m->ring_mask);
    uint64_t held = m->ring_key[slot];
    size_t ring = m->ring_mask + 1;
    if (held != UINT64_MAX && ring < m->ring_max && ring < 4 * (m->count + 1) && grow_ring(m) == 0) {
        slot = (size_t)(id & m->ring_mask);
        held = m->ring_key[slot];
    }
    /* The slot's id is older than this one by a multiple of the ring size:
     * still present, it moves to the hash map. */
    if (held != UINT64_MAX && en_u64map_put(&m->old, held, m->ring_val[slot]))
        return -1;
    m->ring_key[slot] = id;
    m->ring_val[slot] = val;
    m->next = id + 1;
    m->count++;
    return 0;
}

int en_idmap_remove(en_idmap *m, uint64_t id)
{
    size_t slot = (size_t)(id & m->ring_mask);
    int gone = 0;
    if (m->ring_key[slot] == id) {
        m->ring_key[slot] = UINT64_MAX;
        gone = 1;
    } else if (m->old.count) {
        gone = en_u64map_remove(&m->old, id);
    }
    m->count -= (size_t)gone;
    return gone;
}

size_t en_idmap_bytes(const en_idmap *m)
{
    return (m->ring_mask + 1) * (sizeof *m->ring_key + sizeof *m->ring_val) + en_u64map_bytes(&m->old);
}
