#ifndef _GNU_SOURCE
#define _GNU_SOURCE /* sched_getaffinity, CPU_COUNT */
#endif
#include "common/thread.h"

#include <errno.h>
#include <math.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/fault.h"

static en_fault en_thread_fault = EN_FAULT_INIT("EPSNET_FAIL_THREAD");

int en_thread_create(pthread_t *t, void *(*fn)(void *), void *arg)
{
    if (en_fault_hit(&en_thread_fault))
        return EAGAIN; /* what pthread_create says when threads run out */
    return pthread_create(t, NULL, fn, arg);
}

/* ---- the CPU quota of the process's cgroup ----
 * note: a container's --cpus, Kubernetes' CPU limit and systemd's
 * CPUQuota= give the process all of the host's processors in its affinity
 * but only a share of their time (cgroup v2 cpu.max, v1 cpu.cfs_quota_us
 * over cpu.cfs_period_us): as many workers as the host has processors
 * would take turns on a few processors' worth of time. The quota of the
 * process's cgroup and of every cgroup above it (the lowest holds), found
 * through /proc/self/cgroup and the mounts of /proc/self/mountinfo, as
 * language runtimes do for their own default thread counts. */

/* Read the first line of root + path into buf. @return 0, or -1. */
static int read_line(const char *root, const char *path, char *buf, size_t n)
{
    char full[4096];
    if ((size_t)snprintf(full, sizeof full, "%s%s", root, path) >= sizeof full)
        return -1;
    FILE *f = fopen(full, "r");
    if (!f)
        return -1;
    int ok = fgets(buf, (int)n, f) != NULL;
    fclose(f);
    if (ok)
        buf[strcspn(buf, "\n")] = '\0';
    return ok ? 0 : -1;
}

/* Processors' worth of time a quota gives: ceil(quota / period), 0 for
 * none (or what cannot be read). */
static int quota_cpus(double quota, double period)
{
    if (!(quota > 0) || !(period > 0))
        return 0;
    double c = ceil(quota / period);
    return c < 1 ? 1 : c > 1 << 20 ? 1 << 20 : (int)c;
}

/* The limit one cgroup directory sets (v2 or v1), 0 for none. */
static int dir_limit(const char *root, const char *dir, int v2)
{
    char path[4096], line[256];
    if (v2) {
        if ((size_t)snprintf(path, sizeof path, "%s/cpu.max", dir) >= sizeof path ||
            read_line(root, path, line, sizeof line))
            return 0;
        char quota[64];
        double period = 0;
        if (sscanf(line, "%63s %lf", quota, &period) != 2 || !strcmp(quota, "max"))
            return 0;
        return quota_cpus(strtod(quota, NULL), period);
    }
    double quota = 0, period = 0;
    if ((size_t)snprintf(path, sizeof path, "%s/cpu.cfs_quota_us", dir) >= sizeof path ||
        read_line(root, path, line, sizeof line))
        return 0;
    quota = strtod(line, NULL);
    if ((size_t)snprintf(path, sizeof path, "%s/cpu.cfs_period_us", dir) >= sizeof path ||
        read_line(root, path, line, sizeof line))
        return 0;
    period = strtod(line, NULL);
    return quota_cpus(quota, period);
}

/* Does a comma-separated option list hold opt? */
static int has_option(const char *list, const char *opt)
{
    size_t n = strlen(opt);
    for (const char *p = list; p && *p;) {
        const char *e = strchr(p, ',');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        if (len == n && !strncmp(p, opt, n))
            return 1;
        p = e ? e + 1 : NULL;
    }
    return 0;
}

/* The mount of the cgroup hierarchy (v2: the unified one; v1: the one
 * with the cpu controller), from a mountinfo line: its mount root and
 * mount point. @return 1 when the line is that mount. */
static int cgroup_mount(const char *line, int v2, char *mroot, char *mpoint, size_t n)
{
    char r[1024], m[1024], fstype[64], super[1024];
    const char *dash = strstr(line, " - ");
    if (!dash || sscanf(line, "%*s %*s %*s %1023s %1023s", r, m) != 2 ||
        sscanf(dash + 3, "%63s %*s %1023s", fstype, super) != 2)
        return 0;
    if (v2 ? strcmp(fstype, "cgroup2") != 0 : strcmp(fstype, "cgroup") != 0 || !has_option(super, "cpu"))
        return 0;
    snprintf(mroot, n, "%s", r);
    snprintf(mpoint, n, "%s", m);
    return 1;
}

int en_cgroup_cpus(const char *root)
{
    char path[1024], line[4096];
    int best = 0;
    if ((size_t)snprintf(path, sizeof path, "%s/proc/self/cgroup", root) >= sizeof path)
        return 0;
    FILE *cg = fopen(path, "r");
    if (!cg)
        return 0;
    while (fgets(line, sizeof line, cg)) {
        line[strcspn(line, "\n")] = '\0';
        /* "0::/path" (v2) or "N:cpu,cpuacct:/path" (v1) */
        char *c1 = strchr(line, ':'), *c2 = c1 ? strchr(c1 + 1, ':') : NULL;
        if (!c2)
            continue;
        *c1 = *c2 = '\0';
        const char *controllers = c1 + 1, *cgpath = c2 + 1;
        int v2 = *controllers == '\0' && !strcmp(line, "0");
        if (!v2 && !has_option(controllers, "cpu"))
            continue;
        char mi[1024], mroot[1024] = "", mpoint[1024] = "", l[4096];
        int found = 0;
        if ((size_t)snprintf(mi, sizeof mi, "%s/proc/self/mountinfo", root) >= sizeof mi)
            continue;
        FILE *m = fopen(mi, "r");
        while (m && !found && fgets(l, sizeof l, m))
            found = cgroup_mount(l, v2, mroot, mpoint, sizeof mroot);
        if (m)
            fclose(m);
        if (!found)
            continue;
        /* the path below the mount's root; one the mount does not show (a
         * container's view of its host's path) reads the mount point */
        size_t rl = strlen(mroot);
        const char *rel = cgpath;
        if (strcmp(mroot, "/") != 0) {
            if (!strncmp(cgpath, mroot, rl) && (cgpath[rl] == '/' || cgpath[rl] == '\0'))
                rel = cgpath + rl;
            else
                rel = "";
        }
        char dir[4096], probe[4096];
        if ((size_t)snprintf(dir, sizeof dir, "%s%s", mpoint, strcmp(rel, "/") ? rel : "") >= sizeof dir)
            continue;
        if ((size_t)snprintf(probe, sizeof probe, "%s%s", root, dir) >= sizeof probe)
            continue;
        if (access(probe, F_OK) != 0)
            snprintf(dir, sizeof dir, "%s", mpoint);
        /* this cgroup and every one above it, to the mount point */
        for (;;) {
            int lim = dir_limit(root, dir, v2);
            if (lim && (!best || lim < best))
                best = lim;
            size_t dl = strlen(dir), ml = strlen(mpoint);
            if (dl <= ml)
                break;
            char *slash = strrchr(dir, '/');
            if (!slash || (size_t)(slash - dir) < ml)
                break;
            *slash = '\0';
        }
    }
    fclose(cg);
    return best;
}

int en_cpus_usable(void)
{
    int n = 0;
#ifdef CPU_COUNT
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0)
        n = CPU_COUNT(&set);
#endif
    if (!n) {
        long k = sysconf(_SC_NPROCESSORS_ONLN);
        n = k > 0 ? (k > 1 << 20 ? 1 << 20 : (int)k) : 1;
    }
    int quota = en_cgroup_cpus("");
    return quota && quota < n ? quota : n;
}
