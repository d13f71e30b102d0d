#ifndef _GNU_SOURCE
#define _GNU_SOURCE /* sched_getaffinity, CPU_COUNT */
#endif
#include "common/thread.h"

#include <errno.h>
#include <sched.h>
#include <unistd.h>

#include "common/fault.h"

static en_fault en_thread_fault = EN_FAULT_INIT("EPSNET_FAIL_THREAD");

int en_thread_create(pthread_t *t, void *(*fn)(void *), void *arg)
{
    if (en_fault_hit(&en_thread_fault))
        return EAGAIN; /* what pthread_create says when threads run out */
    return pthread_create(t, NULL, fn, arg);
}

int en_cpus_usable(void)
{
#ifdef CPU_COUNT
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0)
        return CPU_COUNT(&set);
#endif
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (n > 1 << 20 ? 1 << 20 : (int)n) : 1;
}
