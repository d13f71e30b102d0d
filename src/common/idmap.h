/*
 * Map from stream vertex ids to 32-bit values, for ids handed out in
 * increasing order (docs/architecture.md §8): the chunker's live vertices.
 *
 * note: in a stream most lookups are for recent ids, so the newest ids sit
 * in a direct-mapped ring (slot = id mod ring size): one array access, no
 * hashing, no probing. An id still present when a newer one needs its slot
 * (a vertex used again far later) moves to a hash map, which is asked only
 * when the ring misses. Any stream is served; a coherent one almost never
 * touches the hash.
 *
 * A ring may also start small and grow (en_idmap_init_growing): it doubles
 * instead of pushing a present id out, while it is smaller than its limit
 * and than four times the ids present, so it ends about as wide as the
 * stream's window of live ids, which no caller need know ahead.
 */
#ifndef EN_COMMON_IDMAP_H
#define EN_COMMON_IDMAP_H

#include <stddef.h>
#include <stdint.h>

#include "common/u64map.h"

typedef struct en_idmap {
    uint64_t *ring_key;   /* id in the slot, UINT64_MAX when empty */
    uint32_t *ring_val;
    size_t ring_mask;     /* ring size - 1, a power of two */
    size_t ring_max;      /* the ring may double up to this many slots */
    uint64_t next;        /* every id put so far is below it */
    en_u64map old;        /* ids pushed out of the ring while present */
    size_t count;         /* ids present */
} en_idmap;

/* ring: slots wanted (rounded up to a power of two, at least 64).
 * @return 0 or -1 (out of memory). */
int en_idmap_init(en_idmap *m, size_t ring);
/* A ring of 64 slots that grows up to ring_max (rounded up to a power of
 * two). @return 0 or -1 (out of memory). */
int en_idmap_init_growing(en_idmap *m, size_t ring_max);
void en_idmap_free(en_idmap *m);
/* Insert id, which must be >= every id put before (else -1, m unchanged).
 * @return 0 or -1 (out of memory; m unchanged). */
int en_idmap_put(en_idmap *m, uint64_t id, uint32_t val);
/* @return 1 with *val set, or 0 when absent.
 * note: inline for the ring hit, the common case: the reader front end
 * asks once per triangle corner on the calling thread (docs/architecture.md
 * §10), where a call each was a measurable share. */
static inline int en_idmap_get(const en_idmap *m, uint64_t id, uint32_t *val)
{
    size_t slot = (size_t)(id & m->ring_mask);
    if (m->ring_key[slot] == id) {
        *val = m->ring_val[slot];
        return 1;
    }
    return m->old.count ? en_u64map_get(&m->old, id, val) : 0;
}
/* @return 1 removed, 0 absent. */
int en_idmap_remove(en_idmap *m, uint64_t id);
size_t en_idmap_bytes(const en_idmap *m);

#endif
