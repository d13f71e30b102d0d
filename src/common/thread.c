#include "common/thread.h"

#include <errno.h>
#include <stdatomic.h>
#include <stdlib.h>

/* note: process-wide and read once, like EPSNET_FAIL_ALLOC (alloc.c). */
static atomic_long en_thread_count;
static atomic_long en_thread_fail_at = -2;

static int should_fail(void)
{
    long at = atomic_load_explicit(&en_thread_fail_at, memory_order_relaxed);
    if (at == -2) {
        const char *e = getenv("EPSNET_FAIL_THREAD");
        at = e && *e ? atol(e) : -1;
        atomic_store(&en_thread_fail_at, at);
    }
    if (at < 0)
        return 0;
    return atomic_fetch_add(&en_thread_count, 1) + 1 >= at;
}

int en_thread_create(pthread_t *t, void *(*fn)(void *), void *arg)
{
    if (should_fail())
        return EAGAIN; /* what pthread_create says when threads run out */
    return pthread_create(t, NULL, fn, arg);
}
