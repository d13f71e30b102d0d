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

/* The processors this process may run on (its CPU affinity: taskset, a
 * container's cpuset, Slurm's --cpus-per-task, mpirun's binding), or
 * those online where the system does not say, and no more than its
 * cgroup's CPU quota gives (en_cgroup_cpus); at least 1. The "all cores"
 * of threads = 0. */
int en_cpus_usable(void);

/* Processors' worth of time the CPU quota of this process's cgroup and
 * of those above it gives (cgroup v2 cpu.max, v1 cpu.cfs_quota_us over
 * cpu.cfs_period_us, rounded up; the lowest holds), or 0 for none. root
 * prefixes every file read ("" for the system's; the tests give a tree of
 * their own). */
int en_cgroup_cpus(const char *root);

#endif
