/*
 * Fault injection counters (after dav1d's alloc_fail), shared by
 * allocation (EPSNET_FAIL_ALLOC), thread creation (EPSNET_FAIL_THREAD) and
 * file writes (EPSNET_FAIL_WRITE, a full disk): the N-th event (1-based) and
 * every later one fail.
 * note: process-wide on purpose; the variable is read once; when it is
 * unset the cost is one predictable branch per event.
 */
#ifndef EN_COMMON_FAULT_H
#define EN_COMMON_FAULT_H

#include <stdatomic.h>
#include <stdlib.h>

typedef struct en_fault {
    atomic_long count;
    atomic_long fail_at;   /* -2 until read, -1 when off */
    const char *env;
} en_fault;

#define EN_FAULT_INIT(name) { 0, -2, name }

static inline int en_fault_hit(en_fault *f)
{
    long at = atomic_load_explicit(&f->fail_at, memory_order_relaxed);
    if (at == -2) {
        const char *e = getenv(f->env);
        at = e && *e ? atol(e) : -1;
        atomic_store(&f->fail_at, at);
    }
    if (at < 0)
        return 0;
    return atomic_fetch_add(&f->count, 1) + 1 >= at;
}

#endif
