/*
 * Thread creation with fault injection (issue 8, as alloc.h does for
 * memory): EPSNET_FAIL_THREAD=N makes the N-th thread creation (1-based)
 * and every later one fail, so tests can prove that a pool which cannot
 * start shuts down cleanly with a clear error.
 */
#ifndef EN_COMMON_THREAD_H
#define EN_COMMON_THREAD_H

#include <pthread.h>

/* pthread_create with default attributes. @return 0 or an errno value. */
int en_thread_create(pthread_t *t, void *(*fn)(void *), void *arg);

#endif
