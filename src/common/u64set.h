/*
 * Open-addressing hash set of 64-bit keys (UINT64_MAX is reserved), used for
 * the live-vertex set of streams and for index maps. Memory is reported so
 * callers can hold it to a budget.
 */
#ifndef EN_COMMON_U64SET_H
#define EN_COMMON_U64SET_H

#include <stddef.h>
#include <stdint.h>

typedef struct en_u64set en_u64set;

en_u64set *en_u64set_new(void);
void en_u64set_free(en_u64set **s);
/* @return 1 inserted, 0 already present, -1 out of memory. */
int en_u64set_add(en_u64set *s, uint64_t key);
/* Empty s for up to n keys without growing, in the slots it already has
 * when they are enough (a set reused call after call allocates nothing
 * once warm). @return 0 or -1 out of memory (s is then empty). */
int en_u64set_clear(en_u64set *s, size_t n);
int en_u64set_has(const en_u64set *s, uint64_t key);
/* @return 1 removed, 0 absent. */
int en_u64set_remove(en_u64set *s, uint64_t key);
size_t en_u64set_count(const en_u64set *s);
size_t en_u64set_bytes(const en_u64set *s);

#endif
