#include "common/alloc.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "common/fault.h"

/* EPSNET_FAIL_ALLOC=N makes the N-th allocation (1-based) and every later
 * one fail, so a test can walk every failure point of a whole run
 * (tests/test_fault_injection.py). */
static en_fault en_alloc_fault = EN_FAULT_INIT("EPSNET_FAIL_ALLOC");

static int en_alloc_should_fail(void)
{
    return en_fault_hit(&en_alloc_fault);
}

void *en_malloc(size_t n)
{
    return en_alloc_should_fail() ? NULL : malloc(n ? n : 1);
}

void *en_calloc(size_t count, size_t size)
{
    return en_alloc_should_fail() ? NULL : calloc(count ? count : 1, size ? size : 1);
}

void *en_realloc(void *p, size_t n)
{
    return en_alloc_should_fail() ? NULL : realloc(p, n ? n : 1);
}

void en_free(void *p)
{
    free(p);
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
