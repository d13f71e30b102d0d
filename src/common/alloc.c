#ifndef _GNU_SOURCE
#define _GNU_SOURCE /* mremap */
#endif
#include "common/alloc.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#include "common/fault.h"

/* EPSNET_FAIL_ALLOC=N makes the N-th allocation (1-based) and every later
 * one fail, so a test can walk every failure point of a whole run
 * (tests/test_fault_injection.py). */
static en_fault en_alloc_fault = EN_FAULT_INIT("EPSNET_FAIL_ALLOC");

static int en_alloc_should_fail(void)
{
    return en_fault_hit(&en_alloc_fault);
}

/*
 * Blocks of EN_MAP_MIN bytes and more are mapped and unmapped here
 * (mmap, munmap), whatever the host process's malloc does with them.
 *
 * note: glibc maps a large block only while it is above a threshold that
 * rises to the largest block freed; after that, freed slab arrays stay in
 * its heaps, freed on another thread than the one that allocated them, and
 * a run's peak grows with its slab count. The CLI fixes the threshold for
 * its whole process (tools/epsnet.c); a library inside someone else's
 * process (the Python package) must not change that process's policy, so
 * it maps its own large blocks: the same behaviour, for its blocks only
 * (bench/RESULTS.md, session 17: the Python peak of `gen bumpy` 2M). Every
 * block starts with a header of EN_ALLOC_HEAD bytes: its size. Under the
 * address sanitizer every block comes from malloc, whose overflows it
 * checks.
 */
#define EN_MAP_MIN ((size_t)1 << 20)
#define EN_ALLOC_HEAD 16 /* keeps malloc's 16-byte alignment */
#if defined(__SANITIZE_ADDRESS__)
#define EN_MAP_BLOCKS 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define EN_MAP_BLOCKS 0
#endif
#endif
#ifndef EN_MAP_BLOCKS
#define EN_MAP_BLOCKS 1
#endif

/* A block's header: the caller's bytes. Whether it is mapped follows
 * from them (maps()): a resize across EN_MAP_MIN moves the block. */
typedef struct head {
    size_t size;
} head;

static int maps(size_t n)
{
    return EN_MAP_BLOCKS && n >= EN_MAP_MIN;
}

/* A block of n caller bytes (zeroed when zero is set), or NULL. */
static void *block(size_t n, int zero)
{
    if (n > SIZE_MAX - EN_ALLOC_HEAD)
        return NULL;
    head *h;
    if (maps(n)) {
        void *m = mmap(NULL, n + EN_ALLOC_HEAD, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (m == MAP_FAILED)
            return NULL;
        h = m; /* mapped pages are zero */
    } else if (!(h = zero ? calloc(1, n + EN_ALLOC_HEAD) : malloc(n + EN_ALLOC_HEAD))) {
        return NULL;
    }
    h->size = n;
    return (uint8_t *)h + EN_ALLOC_HEAD;
}

static head *head_of(void *p)
{
    return (head *)(void *)((uint8_t *)p - EN_ALLOC_HEAD);
}

void *en_malloc(size_t n)
{
    return en_alloc_should_fail() ? NULL : block(n ? n : 1, 0);
}

void *en_calloc(size_t count, size_t size)
{
    count = count ? count : 1;
    size = size ? size : 1;
    if (en_alloc_should_fail() || count > SIZE_MAX / size)
        return NULL;
    return block(count * size, 1);
}

void *en_realloc(void *p, size_t n)
{
    if (en_alloc_should_fail())
        return NULL;
    n = n ? n : 1;
    if (!p)
        return block(n, 0);
    if (n > SIZE_MAX - EN_ALLOC_HEAD)
        return NULL;
    head *h = head_of(p);
    if (!maps(h->size) && !maps(n)) {
        if (!(h = realloc(h, n + EN_ALLOC_HEAD)))
            return NULL;
        h->size = n;
        return (uint8_t *)h + EN_ALLOC_HEAD;
    }
#ifdef MREMAP_MAYMOVE
    if (maps(h->size) && maps(n)) {
        void *m = mremap(h, h->size + EN_ALLOC_HEAD, n + EN_ALLOC_HEAD, MREMAP_MAYMOVE);
        if (m == MAP_FAILED)
            return NULL;
        h = m;
        h->size = n;
        return (uint8_t *)h + EN_ALLOC_HEAD;
    }
#endif
    /* across the line between malloc and mmap: a new block and a copy */
    void *q = block(n, 0);
    if (!q)
        return NULL;
    memcpy(q, p, h->size < n ? h->size : n);
    en_free(p);
    return q;
}

void en_free(void *p)
{
    if (!p)
        return;
    head *h = head_of(p);
    if (maps(h->size))
        munmap(h, h->size + EN_ALLOC_HEAD);
    else
        free(h);
}

char *en_strdup(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = en_malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

int en_grow_slow(void **buf, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return 0;
    size_t n = *cap ? *cap : 16;
    while (n < need) {
        if (n > SIZE_MAX / 2)
            return -1;
        n *= 2;
    }
    if (elem && n > SIZE_MAX / elem)
        return -1;
    void *p = en_realloc(*buf, n * elem);
    if (!p)
        return -1;
    *buf = p;
    *cap = n;
    return 0;
}
