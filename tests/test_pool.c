/*
 * The worker pool and its job rings (docs/architecture.md §10): jobs run on
 * any worker in any order, but each ring hands them back in its own
 * submission order with their own results, for any thread count, also when
 * several rings share one pool; in-flight jobs never exceed a ring's
 * capacity; an error rides in its job and surfaces in order; freeing a ring
 * with queued work finishes it cleanly; a serial ring's jobs run one at a
 * time, in order, beside other rings' jobs; a timed wait tells a job still
 * running from one done. The processors a run may use heed a cgroup's CPU
 * quota (read from a tree of files the test writes).
 * Also run under the thread sanitizer in CI (build-tsan).
 */
#include <stdatomic.h>
#include <sys/stat.h>

#include "common/pool.h"
#include "common/thread.h"
#include "testlib.h"

typedef struct work {
    uint64_t id;
    uint64_t input;
    uint64_t output;
    int fail;
} work;

static atomic_int running, max_running;

/* Unequal amounts of work so that jobs finish out of order. */
static int crunch(void *arg)
{
    work *w = arg;
    int now = atomic_fetch_add(&running, 1) + 1;
    int seen = atomic_load(&max_running);
    while (now > seen && !atomic_compare_exchange_weak(&max_running, &seen, now))
        ;
    uint64_t x = w->input;
    for (uint64_t i = 0; i < (w->id % 7) * 20000 + 1000; i++)
        x = x * 6364136223846793005ull + 1442695040888963407ull;
    w->output = x;
    atomic_fetch_sub(&running, 1);
    return w->fail ? EPSNET_EFORMAT : 0;
}

static uint64_t expected(const work *w)
{
    uint64_t x = w->input;
    for (uint64_t i = 0; i < (w->id % 7) * 20000 + 1000; i++)
        x = x * 6364136223846793005ull + 1442695040888963407ull;
    return x;
}

/* Run n jobs through a pool of t threads and capacity c; every retired job
 * must be the next in order with the right output. Returns a digest. */
static uint64_t run_jobs(int threads, size_t cap, uint64_t n, uint64_t fail_at, int *first_error_id)
{
    en_pool *pool = NULL;
    en_jobring *p = NULL;
    CHECK_EQ_INT(en_pool_new(&pool, threads), 0);
    CHECK_EQ_INT(en_jobring_new(&p, pool, cap), 0);
    work *jobs = calloc(n, sizeof *jobs);
    uint64_t next_retire = 0, digest = 0;
    *first_error_id = -1;
    atomic_store(&max_running, 0);
    for (uint64_t i = 0; i <= n; i++) {
        /* back-pressure: retire the oldest while the ring is full (and drain at the end) */
        while (en_jobring_full(p) || (i == n && en_jobring_in_flight(p))) {
            void *job;
            int result;
            CHECK_EQ_INT(en_jobring_retire(p, &job, &result), 1);
            work *w = job;
            CHECK_EQ_U64(w->id, next_retire);
            CHECK_EQ_U64(w->output, expected(w));
            if (result && *first_error_id < 0)
                *first_error_id = (int)w->id;
            CHECK_EQ_INT(result, w->fail ? EPSNET_EFORMAT : 0);
            digest = digest * 31 + w->output;
            next_retire++;
        }
        if (i == n)
            break;
        CHECK(en_jobring_in_flight(p) < cap + (cap == 0));
        jobs[i] = (work){ i, i * 977 + 1, 0, i == fail_at };
        CHECK_EQ_INT(en_jobring_submit(p, crunch, &jobs[i]), 0);
    }
    CHECK_EQ_U64(next_retire, n);
    void *job;
    int result;
    CHECK_EQ_INT(en_jobring_retire(p, &job, &result), 0);
    CHECK(en_pool_job_cpu_seconds(pool) > 0);
    en_jobring_free(&p, NULL);
    CHECK(p == NULL);
    en_pool_free(&pool);
    CHECK(pool == NULL);
    free(jobs);
    return digest;
}

TEST(jobs_retire_in_submission_order_for_any_thread_count)
{
    int err;
    uint64_t ref = run_jobs(0, 4, 300, UINT64_MAX, &err);
    CHECK_EQ_INT(err, -1);
    const int threads[] = { 1, 2, 3, 8 };
    for (int k = 0; k < 4; k++) {
        uint64_t d = run_jobs(threads[k], 8, 300, UINT64_MAX, &err);
        CHECK_EQ_U64(d, ref);
    }
}

TEST(jobs_in_flight_never_exceed_the_capacity)
{
    int err;
    run_jobs(8, 4, 200, UINT64_MAX, &err);
    CHECK(atomic_load(&max_running) <= 4);
    CHECK(atomic_load(&max_running) >= 1);
}

TEST(an_error_rides_in_its_job_and_surfaces_in_order)
{
    int err;
    run_jobs(3, 8, 100, 37, &err);
    CHECK_EQ_INT(err, 37);
    run_jobs(0, 8, 100, 0, &err);
    CHECK_EQ_INT(err, 0);
}

TEST(submitting_to_a_full_ring_is_refused_not_blocked)
{
    en_pool *pool = NULL;
    en_jobring *p = NULL;
    CHECK_EQ_INT(en_pool_new(&pool, 2), 0);
    CHECK_EQ_INT(en_jobring_new(&p, pool, 2), 0);
    work w[3] = { { 0, 1, 0, 0 }, { 1, 2, 0, 0 }, { 2, 3, 0, 0 } };
    CHECK_EQ_INT(en_jobring_submit(p, crunch, &w[0]), 0);
    CHECK_EQ_INT(en_jobring_submit(p, crunch, &w[1]), 0);
    CHECK(en_jobring_full(p));
    CHECK_EQ_INT(en_jobring_submit(p, crunch, &w[2]), EPSNET_EINTERNAL);
    en_jobring_free(&p, NULL); /* waits for both queued jobs */
    CHECK_EQ_U64(w[0].output, expected(&w[0]));
    CHECK_EQ_U64(w[1].output, expected(&w[1]));
    en_pool_free(&pool);
}

TEST(capacity_rounds_up_to_a_power_of_two)
{
    en_pool *pool = NULL;
    en_jobring *p = NULL;
    CHECK_EQ_INT(en_pool_new(&pool, 0), 0);
    CHECK_EQ_INT(en_jobring_new(&p, pool, 3), 0);
    work w[5];
    for (int i = 0; i < 4; i++) {
        w[i] = (work){ (uint64_t)i, (uint64_t)i, 0, 0 };
        CHECK_EQ_INT(en_jobring_submit(p, crunch, &w[i]), 0);
    }
    CHECK(en_jobring_full(p));
    en_jobring_free(&p, NULL);
    en_pool_free(&pool);
}

/*
 * Two producers on one pool, as two ε-net passes share the run's workers:
 * submissions interleave, each ring still retires its own jobs in its own
 * order with the right outputs.
 */
TEST(rings_sharing_a_pool_each_retire_in_their_own_order)
{
    const int threads[] = { 0, 1, 2, 5 };
    for (int k = 0; k < 4; k++) {
        en_pool *pool = NULL;
        en_jobring *ring[2] = { NULL, NULL };
        CHECK_EQ_INT(en_pool_new(&pool, threads[k]), 0);
        CHECK_EQ_INT(en_jobring_new(&ring[0], pool, 4), 0);
        CHECK_EQ_INT(en_jobring_new(&ring[1], pool, 2), 0);
        enum { N = 120 };
        work jobs[2][N];
        uint64_t next[2] = { 0, 0 };
        for (uint64_t i = 0; i <= N; i++) {
            for (int r = 0; r < 2; r++) {
                while (en_jobring_full(ring[r]) || (i == N && en_jobring_in_flight(ring[r]))) {
                    void *job;
                    int result;
                    CHECK_EQ_INT(en_jobring_retire(ring[r], &job, &result), 1);
                    work *w = job;
                    CHECK(w == &jobs[r][next[r]]);
                    CHECK_EQ_U64(w->output, expected(w));
                    CHECK_EQ_INT(result, 0);
                    next[r]++;
                }
                if (i == N)
                    continue;
                jobs[r][i] = (work){ i + (uint64_t)r * 3, i * 31 + (uint64_t)r, 0, 0 };
                CHECK_EQ_INT(en_jobring_submit(ring[r], crunch, &jobs[r][i]), 0);
            }
        }
        CHECK_EQ_U64(next[0], N);
        CHECK_EQ_U64(next[1], N);
        en_jobring_free(&ring[0], NULL);
        en_jobring_free(&ring[1], NULL);
        en_pool_free(&pool);
    }
}

/* A serial ring's jobs share plain state (as a pass's chunk jobs share its
 * chunker): each appends its id to a log without any lock, so overlap or
 * disorder shows as a wrong log (and as a race under the thread sanitizer). */
typedef struct serial_job {
    uint64_t id;
    uint64_t *log;
    size_t *nlog;
} serial_job;

static int append_id(void *arg)
{
    serial_job *j = arg;
    uint64_t x = j->id;
    for (uint64_t i = 0; i < (j->id % 5) * 10000; i++) /* unequal lengths */
        x = x * 6364136223846793005ull + 1;
    j->log[(*j->nlog)++] = j->id + (x & 0); /* x only keeps the loop */
    return 0;
}

/*
 * A serial, urgent ring beside an ordinary one on the same pool: the serial
 * ring's jobs run one at a time in submission order (the log), with several
 * in flight at once, while the other ring's jobs go on around them.
 */
TEST(a_serial_ring_runs_its_jobs_one_at_a_time_in_order)
{
    const int threads[] = { 0, 1, 2, 5 };
    for (int k = 0; k < 4; k++) {
        en_pool *pool = NULL;
        en_jobring *serial = NULL, *other = NULL;
        CHECK_EQ_INT(en_pool_new(&pool, threads[k]), 0);
        CHECK_EQ_INT(en_jobring_new(&serial, pool, 8), 0);
        CHECK_EQ_INT(en_jobring_new(&other, pool, 4), 0);
        en_jobring_set_order(serial, 1, 1);
        enum { N = 200 };
        static uint64_t log[N];
        size_t nlog = 0;
        serial_job sj[N];
        work ow[N];
        uint64_t retired = 0, oretired = 0;
        void *job;
        int result;
        for (uint64_t i = 0; i < N; i++) {
            if (en_jobring_full(serial)) {
                CHECK_EQ_INT(en_jobring_retire(serial, &job, &result), 1);
                CHECK(job == &sj[retired++]);
            }
            sj[i] = (serial_job){ i, log, &nlog };
            CHECK_EQ_INT(en_jobring_submit(serial, append_id, &sj[i]), 0);
            if (en_jobring_full(other)) {
                CHECK_EQ_INT(en_jobring_retire(other, &job, &result), 1);
                CHECK(job == &ow[oretired++]);
            }
            ow[i] = (work){ i, i * 7, 0, 0 };
            CHECK_EQ_INT(en_jobring_submit(other, crunch, &ow[i]), 0);
        }
        while (en_jobring_retire(serial, &job, &result))
            CHECK(job == &sj[retired++]);
        CHECK(!en_jobring_ready(serial));
        en_jobring_free(&other, NULL);
        CHECK_EQ_U64(nlog, N);
        for (uint64_t i = 0; i < N && i < nlog; i++)
            CHECK_EQ_U64(log[i], i);
        en_jobring_free(&serial, NULL);
        en_pool_free(&pool);
    }
}

static atomic_int gate;

/* Runs until the test opens the gate. */
static int wait_for_gate(void *arg)
{
    (void)arg;
    while (!atomic_load(&gate))
        ;
    return 0;
}

/* en_jobring_wait: a job still running is not ready when the time runs
 * out; once it is done, the wait says so and retire takes it; nothing in
 * flight, nothing to wait for; with no threads, a job submitted is done. */
TEST(a_timed_wait_tells_a_running_job_from_a_done_one)
{
    for (int threads = 0; threads <= 2; threads += 2) {
        en_pool *pool = NULL;
        en_jobring *r = NULL;
        CHECK_EQ_INT(en_pool_new(&pool, threads), 0);
        CHECK_EQ_INT(en_jobring_new(&r, pool, 2), 0);
        CHECK_EQ_INT(en_jobring_wait(r, 0.01), 0);
        atomic_store(&gate, threads == 0);
        CHECK_EQ_INT(en_jobring_submit(r, wait_for_gate, NULL), 0);
        if (threads)
            CHECK_EQ_INT(en_jobring_wait(r, 0.01), 0);
        atomic_store(&gate, 1);
        int done = 0;
        for (int tries = 0; tries < 1000 && !done; tries++)
            done = en_jobring_wait(r, 0.1);
        CHECK_EQ_INT(done, 1);
        void *job;
        int result = -1;
        CHECK_EQ_INT(en_jobring_retire(r, &job, &result), 1);
        CHECK_EQ_INT(result, 0);
        en_jobring_free(&r, NULL);
        en_pool_free(&pool);
    }
}

/* ---- a cgroup's CPU quota (common/thread.h: en_cgroup_cpus) ---- */

/* The private folder's root/rel, holding text, its folders made. */
static void put_file(const char *root, const char *rel, const char *text)
{
    char name[128];
    snprintf(name, sizeof name, "%s/%s", root, rel);
    for (char *p = name; (p = strchr(p, '/')); p++) {
        *p = '\0';
        mkdir(tl_path(name), 0700);
        *p = '/';
    }
    tl_write_str(name, text);
}

TEST(a_cgroup_quota_caps_the_processors_the_lowest_on_the_path_holding)
{
    /* v2: the process's cgroup and its parent, each may set cpu.max */
    const char *root = "cg2";
    put_file(root, "proc/self/cgroup", "0::/user.slice/job\n");
    put_file(root, "proc/self/mountinfo",
             "22 1 0:21 / /proc rw - proc proc rw\n29 23 0:26 / /sys/fs/cgroup rw,nosuid - cgroup2 cgroup2 rw\n");
    put_file(root, "sys/fs/cgroup/user.slice/job/cpu.max", "150000 100000\n");
    put_file(root, "sys/fs/cgroup/user.slice/cpu.max", "max 100000\n");
    CHECK_EQ_INT(en_cgroup_cpus(tl_path(root)), 2); /* 1.5 processors' time: two threads */
    put_file(root, "sys/fs/cgroup/user.slice/cpu.max", "100000 100000\n");
    CHECK_EQ_INT(en_cgroup_cpus(tl_path(root)), 1); /* the parent's is lower */
    put_file(root, "sys/fs/cgroup/user.slice/cpu.max", "max 100000\n");
    put_file(root, "sys/fs/cgroup/user.slice/job/cpu.max", "max 100000\n");
    CHECK_EQ_INT(en_cgroup_cpus(tl_path(root)), 0); /* no quota */
    /* v1 seen from a container: the mount's root is the process's own cgroup */
    root = "cg1";
    put_file(root, "proc/self/cgroup", "5:memory:/docker/abc\n4:cpu,cpuacct:/docker/abc\n0::/\n");
    put_file(root, "proc/self/mountinfo",
             "35 31 0:31 /docker/abc /sys/fs/cgroup/memory ro - cgroup cgroup rw,memory\n"
             "36 31 0:32 /docker/abc /sys/fs/cgroup/cpu,cpuacct ro - cgroup cgroup rw,cpu,cpuacct\n");
    put_file(root, "sys/fs/cgroup/cpu,cpuacct/cpu.cfs_quota_us", "250000\n");
    put_file(root, "sys/fs/cgroup/cpu,cpuacct/cpu.cfs_period_us", "100000\n");
    put_file(root, "sys/fs/cgroup/memory/cpu.cfs_quota_us", "100000\n"); /* not the cpu controller's */
    CHECK_EQ_INT(en_cgroup_cpus(tl_path(root)), 3);
    put_file(root, "sys/fs/cgroup/cpu,cpuacct/cpu.cfs_quota_us", "-1\n");
    CHECK_EQ_INT(en_cgroup_cpus(tl_path(root)), 0);
    /* nothing to read: no quota, and the processors are the affinity's */
    CHECK_EQ_INT(en_cgroup_cpus(tl_path("no-such-root")), 0);
    CHECK(en_cpus_usable() >= 1);
}

int main(void)
{
    RUN(jobs_retire_in_submission_order_for_any_thread_count);
    RUN(jobs_in_flight_never_exceed_the_capacity);
    RUN(an_error_rides_in_its_job_and_surfaces_in_order);
    RUN(submitting_to_a_full_ring_is_refused_not_blocked);
    RUN(capacity_rounds_up_to_a_power_of_two);
    RUN(rings_sharing_a_pool_each_retire_in_their_own_order);
    RUN(a_serial_ring_runs_its_jobs_one_at_a_time_in_order);
    RUN(a_timed_wait_tells_a_running_job_from_a_done_one);
    RUN(a_cgroup_quota_caps_the_processors_the_lowest_on_the_path_holding);
    tl_cleanup();
    return tl_finish();
}
