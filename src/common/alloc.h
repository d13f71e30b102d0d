/*
 * All library allocations go through these wrappers so that fault injection
 * (EPSNET_FAIL_ALLOC=N, see alloc.c) can make any one of them fail and prove
 * that every cleanup path works (after dav1d's alloc_fail).
 */
#ifndef EN_COMMON_ALLOC_H
#define EN_COMMON_ALLOC_H

#include <stddef.h>

void *en_malloc(size_t n);
void *en_calloc(size_t count, size_t size);
void *en_realloc(void *p, size_t n);
void en_free(void *p);
char *en_strdup(const char *s);

/*
 * Grow *buf (holding *cap elements of elem bytes) to at least need elements,
 * doubling. @return 0, or -1 on overflow or allocation failure (then *buf is
 * unchanged).
 */
int en_grow_slow(void **buf, size_t *cap, size_t need, size_t elem);

/* note: inline for the common case (room left): the chunker and the reader
 * call it once per record on the calling thread, where a call each was a
 * measurable share of the serial time (docs/architecture.md §10). */
static inline int en_grow(void **buf, size_t *cap, size_t need, size_t elem)
{
    return need <= *cap ? 0 : en_grow_slow(buf, cap, need, elem);
}

#endif /* EN_COMMON_ALLOC_H */
