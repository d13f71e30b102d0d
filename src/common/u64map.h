/*
 * Open-addressing hash map from 64-bit keys (global vertex ids; UINT64_MAX is
 * reserved) to 32-bit values (local indices), used by the streaming pipeline
 * to find a vertex's record by its global id. Same probing and
 * tombstone-free deletion as u64set.
 */
#ifndef EN_COMMON_U64MAP_H
#define EN_COMMON_U64MAP_H

#include <stddef.h>
#include <stdint.h>

typedef struct en_u64map {
    uint64_t *keys;
    uint32_t *vals;
    size_t mask;      /* capacity - 1, capacity a power of two */
    size_t count;
} en_u64map;

/* @return 0 or -1 (out of memory). */
int en_u64map_init(en_u64map *m);
void en_u64map_free(en_u64map *m);
/* Empty the map, keeping its memory. */
void en_u64map_clear(en_u64map *m);
/* Insert or overwrite. @return 0 or -1 (out of memory; m unchanged). */
int en_u64map_put(en_u64map *m, uint64_t key, uint32_t val);
/* @return 1 with *val set, or 0 when absent. */
int en_u64map_get(const en_u64map *m, uint64_t key, uint32_t *val);
/* @return 1 removed, 0 absent. */
int en_u64map_remove(en_u64map *m, uint64_t key);
size_t en_u64map_bytes(const en_u64map *m);

#endif
