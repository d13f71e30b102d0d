#include "common/thread.h"

#include <errno.h>

#include "common/fault.h"

static en_fault en_thread_fault = EN_FAULT_INIT("EPSNET_FAIL_THREAD");

int en_thread_create(pthread_t *t, void *(*fn)(void *), void *arg)
{
    if (en_fault_hit(&en_thread_fault))
        return EAGAIN; /* what pthread_create says when threads run out */
    return pthread_create(t, NULL, fn, arg);
}
