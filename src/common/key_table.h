/*
 * An exact map from fixed-size byte keys to 64-bit values, open
 * addressing, grown at half full: the writers' weld tables (an OBJ's `v`,
 * `vt` and `vn` lines, a PLY's vertices under face values;
 * docs/architecture.md §13).
 */
#ifndef EN_COMMON_KEY_TABLE_H
#define EN_COMMON_KEY_TABLE_H

#include <stddef.h>
#include <stdint.h>

typedef struct en_key_table {
    uint8_t *slots;                  /* per slot: uint64 value + 1 (0: free), then the key */
    size_t cap, used, key_size, slot_size;
} en_key_table;

/* An empty table of keys of key_size bytes (no memory until the first key). */
void en_key_init(en_key_table *t, size_t key_size);
void en_key_free(en_key_table *t);
/* The value of key, or its new value when absent (*added = 1); value
 * UINT64_MAX leaves an absent key out. @return 0 or -1 out of memory. */
int en_key_find(en_key_table *t, const uint8_t *key, uint64_t value, uint64_t *found, int *added);
/* Overwrite the value of a key that is present. */
void en_key_set(en_key_table *t, const uint8_t *key, uint64_t value);

#endif
