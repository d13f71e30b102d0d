/*
 * External merge sort (see extsort.h). Runs are kept in a stack with a
 * level each; whenever `fanin` runs of the same level sit on top, they are
 * merged into one run of the next level, so the number of open temporary
 * files stays at most fanin per level (a few dozen) whatever the input size,
 * and every item is rewritten O(log_fanin(runs)) times.
 */
#include "sort/extsort.h"

#include <string.h>

#include "common/alloc.h"
#include "common/error.h"
#include "common/pool.h"
#include "io/sink.h"

/* note: what one open run may cost while it is merged, used to size the
 * fan-in from the budget. Runs are plain spills now (only our read buffer
 * and the kernel's read-ahead), so this is a margin, kept from when each run
 * held a zstd decoder's window and input buffer. */
#define RUN_READ_COST ((uint64_t)1 << 20)
#define CURSOR_BYTES ((size_t)64 << 10)
#define MIN_FANIN 4
#define MAX_FANIN 128
#define RUN_PART_MIN ((size_t)1 << 16)

void en_mem_take(en_mem_account *m, uint64_t bytes)
{
    if (!m)
        return;
    m->used += bytes;
    if (m->used > m->peak)
        m->peak = m->used;
}

void en_mem_give(en_mem_account *m, uint64_t bytes)
{
    if (m)
        m->used -= bytes < m->used ? bytes : m->used;
}

typedef struct run {
    en_spill *sp;
    int level;
    uint64_t items;
} run;

/* A full buffer being sorted and written as a run on the pool's worker
 * (extsort.h: cfg.threads). Written by the worker until retired; read by
 * the caller's thread only after en_jobring_retire() hands it back. */
typedef struct run_job {
    en_extsort *es;
    uint64_t *buf;             /* the items; the job owns them until retired */
    size_t n;
    uint64_t *tmp;             /* its part of the radix sort's copy */
    size_t (*count)[256];      /* its radix histograms */
    en_spill *sp;              /* the run, rewound, or NULL on failure */
    epsnet_error err;
} run_job;

typedef struct cursor {
    en_spill *sp;              /* borrowed from its run */
    uint64_t *buf;
    size_t n, pos;             /* items in buf (0: spent), next item */
    uint64_t key;              /* key_words 1: the next item's key, masked */
} cursor;

struct en_extsort {
    en_extsort_config cfg;
    uint64_t mask0;            /* cfg.key_mask, or all bits */
    size_t item_bytes;
    uint64_t *buf, *scratch;   /* run buffer and the radix sort's second half */
    size_t (*count)[256];      /* radix histograms, 8 per key word */
    size_t cap, n;             /* items */
    uint64_t buf_bytes;        /* accounted */
    run *runs;
    size_t nruns, runs_cap;
    size_t fanin;
    uint64_t items;
    uint64_t runs_written;
    uint64_t temp_bytes;
    /* output */
    int finished;
    int in_memory;             /* everything fits: hand out buf directly */
    size_t out_pos;
    cursor *cur;               /* fanin cursors of the final merge */
    size_t *tree;              /* the final merge's loser tree (merge_begin) */
    size_t ncur;
    int failed;
    epsnet_error err;
    /* runs formed on workers (cfg.threads > 0): one full buffer at a time
     * in flight, cut in `parts` runs sorted side by side, each in its part
     * of scratch, while the caller fills buf; spare is the buffer the jobs
     * give back */
    en_pool *pool;
    en_jobring *ring;
    run_job job[EN_EXTSORT_MAX_PARTS];
    size_t parts, job_busy;    /* job_busy: jobs in flight, job[0..job_busy) */
    uint64_t *job_buf;         /* the buffer in flight */
    uint64_t *spare;
};

/* note: the widths in use get fixed-size copies, a few moves inlined,
 * rather than a call per item. */
static inline void copy_item(uint64_t *dst, const uint64_t *src, size_t words)
{
    switch (words) {
    case 2: memcpy(dst, src, 2 * sizeof *src); break;
    case 3: memcpy(dst, src, 3 * sizeof *src); break;
    case 4: memcpy(dst, src, 4 * sizeof *src); break;
    default: memcpy(dst, src, words * sizeof *src); break;
    }
}

static int key_less(const uint64_t *a, const uint64_t *b, size_t k, uint64_t mask0)
{
    if ((a[0] & mask0) != (b[0] & mask0))
        return (a[0] & mask0) < (b[0] & mask0);
    for (size_t i = 1; i < k; i++)
        if (a[i] != b[i])
            return a[i] < b[i];
    return 0;
}

/* LSD radix sort on the key bytes, least significant first; a byte position
 * where every item has the same value is skipped (high bytes of ids, and
 * the bits key_mask leaves out, which count as zero). */
static void radix_sort(uint64_t *items, uint64_t *tmp, size_t n, size_t words, size_t key_words, uint64_t mask0,
                       size_t (*count)[256])
{
    size_t nbytes = key_words * 8;
    if (n < 2)
        return;
    memset(count, 0, nbytes * sizeof *count);
    for (size_t i = 0; i < n; i++) {
        const uint64_t *it = items + i * words;
        for (size_t w = 0; w < key_words; w++) {
            uint64_t k = w ? it[w] : it[0] & mask0;
            for (size_t b = 0; b < 8; b++)
                count[(key_words - 1 - w) * 8 + b][(k >> (8 * b)) & 0xff]++;
        }
    }
    uint64_t *src = items, *dst = tmp;
    for (size_t pos = 0; pos < nbytes; pos++) {
        size_t *c = count[pos];
        int trivial = 0;
        for (int v = 0; v < 256; v++)
            if (c[v] == n)
                trivial = 1;
        if (trivial)
            continue;
        size_t sum = 0;
        for (int v = 0; v < 256; v++) {
            size_t k = c[v];
            c[v] = sum;
            sum += k;
        }
        size_t w = key_words - 1 - pos / 8, shift = 8 * (pos % 8);
        uint64_t m = w ? UINT64_MAX : mask0;
        /* note: fixed item widths get their own loops, so the copy is a
         * few moves rather than a loop over words */
        switch (words) {
#define MOVE_ITEMS(W)                                                                         \
    for (size_t i = 0; i < n; i++) {                                                          \
        const uint64_t *it = src + i * (W);                                                   \
        memcpy(dst + c[((it[w] & m) >> shift) & 0xff]++ * (W), it, (W) * sizeof *it);         \
    }                                                                                         \
    break;
        case 2: MOVE_ITEMS(2)
        case 3: MOVE_ITEMS(3)
        case 4: MOVE_ITEMS(4)
        default: MOVE_ITEMS(words)
#undef MOVE_ITEMS
        }
        uint64_t *t = src;
        src = dst;
        dst = t;
    }
    if (src != items)
        memcpy(items, src, n * words * sizeof *items);
}

int en_extsort_open(en_extsort **out, const en_extsort_config *cfg, epsnet_error *err)
{
    *out = NULL;
    if (cfg->item_words < 1 || cfg->item_words > EN_EXTSORT_MAX_WORDS || cfg->key_words < 1 || cfg->key_words > cfg->item_words)
        return en_error_set(err, EPSNET_EINTERNAL, cfg->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "external sort: bad item layout");
    en_extsort *es = en_calloc(1, sizeof *es);
    if (!es)
        return en_error_set(err, EPSNET_ENOMEM, cfg->owner, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    es->cfg = *cfg;
    es->mask0 = cfg->key_mask ? cfg->key_mask : UINT64_MAX;
    es->parts = cfg->threads < 1 ? 1 : cfg->threads > EN_EXTSORT_MAX_PARTS ? EN_EXTSORT_MAX_PARTS : (size_t)cfg->threads;
    es->count = en_calloc(es->parts * cfg->key_words * 8, sizeof *es->count);
    if (!es->count) {
        en_free(es);
        return en_error_set(err, EPSNET_ENOMEM, cfg->owner, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    es->item_bytes = cfg->item_words * sizeof(uint64_t);
    uint64_t fan = cfg->mem / RUN_READ_COST;
    es->fanin = fan < MIN_FANIN ? MIN_FANIN : fan > MAX_FANIN ? MAX_FANIN : (size_t)fan;
    /* Half of the budget for items, half for the radix sort's copy; a
     * third each when a worker sorts one buffer while the next fills. */
    uint64_t cap = cfg->mem / (cfg->threads > 0 ? 3 : 2) / es->item_bytes;
    if (cap < 1024)
        cap = 1024;
    if (cap > SIZE_MAX / es->item_bytes / 2)
        cap = SIZE_MAX / es->item_bytes / 2;
    es->cap = (size_t)cap;
    *out = es;
    return 0;
}

static int fail(en_extsort *es, int code, epsnet_error *err)
{
    if (!es->failed) {
        es->failed = 1;
        if (err)
            es->err = *err;
        es->err.code = code;
    }
    if (err)
        *err = es->err;
    return code;
}

static int nomem(en_extsort *es, epsnet_error *err)
{
    en_error_set(err, EPSNET_ENOMEM, es->cfg.owner, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    return fail(es, EPSNET_ENOMEM, err);
}

static int alloc_buffer(en_extsort *es, epsnet_error *err)
{
    es->buf = en_malloc(es->cap * es->item_bytes);
    es->scratch = en_malloc(es->cap * es->item_bytes);
    if (!es->buf || !es->scratch)
        return nomem(es, err);
    es->buf_bytes = 2 * (uint64_t)es->cap * es->item_bytes;
    en_mem_take(es->cfg.account, es->buf_bytes);
    return 0;
}

static void free_buffer(en_extsort *es)
{
    en_free(es->buf);
    en_free(es->scratch);
    en_free(es->spare);
    es->buf = es->scratch = es->spare = NULL;
    en_mem_give(es->cfg.account, es->buf_bytes);
    es->buf_bytes = 0;
}

static int push_run(en_extsort *es, en_spill *sp, int level, uint64_t items, epsnet_error *err)
{
    if (es->nruns == es->runs_cap && en_grow((void **)&es->runs, &es->runs_cap, es->nruns + 1, sizeof *es->runs)) {
        en_spill_close(&sp);
        return nomem(es, err);
    }
    es->runs[es->nruns++] = (run){ .sp = sp, .level = level, .items = items };
    es->runs_written++;
    return 0;
}

/* ---- merging ---- */

static int cursor_refill(en_extsort *es, cursor *c, epsnet_error *err)
{
    int64_t got = en_spill_read(c->sp, c->buf, CURSOR_BYTES / es->item_bytes * es->item_bytes, err);
    if (got < 0)
        return fail(es, (int)got, err);
    if ((size_t)got % es->item_bytes)
        return fail(es, en_error_set(err, EPSNET_EIO, es->cfg.owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                     "temporary file: a sort run ends inside an item"),
                    err);
    c->n = (size_t)got / es->item_bytes;
    c->pos = 0;
    return 0;
}

static const uint64_t *cursor_item(const en_extsort *es, const cursor *c)
{
    return c->buf + c->pos * es->cfg.item_words;
}

/* Cursor a leaves before cursor b: by key, then by run age (note: equal
 * keys leave in run order, which keeps the sort stable); a spent cursor
 * after every other. A strict total order, so the merge's output does not
 * depend on how the tree compares. */
static int run_less(const en_extsort *es, const cursor *cs, size_t a, size_t b)
{
    if (cs[a].n == 0 || cs[b].n == 0)
        return cs[b].n == 0 && (cs[a].n != 0 || a < b);
    if (es->cfg.key_words == 1)
        return cs[a].key != cs[b].key ? cs[a].key < cs[b].key : a < b;
    const uint64_t *x = cursor_item(es, &cs[a]), *y = cursor_item(es, &cs[b]);
    if (key_less(x, y, es->cfg.key_words, es->mask0))
        return 1;
    if (key_less(y, x, es->cfg.key_words, es->mask0))
        return 0;
    return a < b;
}

static void cursor_key(const en_extsort *es, cursor *c)
{
    if (c->n)
        c->key = c->buf[c->pos * es->cfg.item_words] & es->mask0;
}

/* Open cursors on runs [first, first+k) and build the tree.
 * note: a loser tree: node n of 1..k-1 keeps
 * the loser of the match between its children 2n and 2n+1, leaves k..2k-1
 * are the runs, tree[0] the winner. Taking the winner replays only its
 * path, one comparison per level, where a heap's sift-down made two. */
static int merge_begin(en_extsort *es, size_t first, size_t k, cursor **pcs, size_t **ptree, epsnet_error *err)
{
    cursor *cs = en_calloc(k, sizeof *cs);
    size_t *tree = en_calloc(k, sizeof *tree);
    size_t *win = en_calloc(2 * k, sizeof *win);
    if (!cs || !tree || !win) {
        en_free(cs);
        en_free(tree);
        en_free(win);
        return nomem(es, err);
    }
    *pcs = cs;
    *ptree = tree;
    en_mem_take(es->cfg.account, k * (CURSOR_BYTES + RUN_READ_COST));
    int rc = 0;
    for (size_t i = 0; i < k && rc == 0; i++) {
        cs[i].sp = es->runs[first + i].sp;
        cs[i].buf = en_malloc(CURSOR_BYTES);
        if (!cs[i].buf)
            rc = nomem(es, err);
        else if ((rc = en_spill_rewind(cs[i].sp, err)))
            fail(es, rc, err);
        else if ((rc = cursor_refill(es, &cs[i], err)) == 0)
            cursor_key(es, &cs[i]);
    }
    if (rc == 0) {
        for (size_t i = 0; i < k; i++)
            win[k + i] = i;
        for (size_t n = k; n-- > 1;) {
            size_t a = win[2 * n], b = win[2 * n + 1];
            int a_wins = run_less(es, cs, a, b);
            win[n] = a_wins ? a : b;
            tree[n] = a_wins ? b : a;
        }
        tree[0] = k > 1 ? win[1] : 0;
    }
    en_free(win);
    return rc;
}

static void merge_end(en_extsort *es, cursor **pcs, size_t **ptree, size_t k)
{
    cursor *cs = *pcs;
    for (size_t i = 0; cs && i < k; i++)
        en_free(cs[i].buf);
    if (cs)
        en_mem_give(es->cfg.account, k * (CURSOR_BYTES + RUN_READ_COST));
    en_free(cs);
    en_free(*ptree);
    *pcs = NULL;
    *ptree = NULL;
}

/* Take the smallest item of a merge of k cursors. @return 1, 0 when
 * empty, or < 0. */
static int merge_pop(en_extsort *es, cursor *cs, size_t *tree, size_t k, uint64_t *item, epsnet_error *err)
{
    size_t w = tree[0];
    cursor *c = &cs[w];
    if (c->n == 0)
        return 0;
    copy_item(item, cursor_item(es, c), es->cfg.item_words);
    if (++c->pos == c->n) {
        int rc = cursor_refill(es, c, err);
        if (rc)
            return rc;
    }
    cursor_key(es, c);
    for (size_t n = (w + k) / 2; n >= 1; n /= 2)
        if (run_less(es, cs, tree[n], w)) {
            size_t t = tree[n];
            tree[n] = w;
            w = t;
        }
    tree[0] = w;
    return 1;
}

static void close_runs(en_extsort *es, size_t first, size_t k)
{
    for (size_t i = first; i < first + k; i++) {
        es->temp_bytes += en_spill_disk_bytes(es->runs[i].sp);
        en_spill_close(&es->runs[i].sp);
    }
}

/* Merge the k runs on top of the stack into one run of the given level. */
static int merge_top(en_extsort *es, size_t k, int level, epsnet_error *err)
{
    size_t first = es->nruns - k;
    cursor *cs = NULL;
    size_t *tree = NULL;
    en_spill *out = NULL;
    uint64_t *wbuf = NULL;
    uint64_t items = 0;
    int rc = merge_begin(es, first, k, &cs, &tree, err);
    if (rc == 0 && (rc = en_spill_open_plain(&out, es->cfg.tmpdir, es->cfg.owner, err)))
        fail(es, rc, err);
    size_t wcap = CURSOR_BYTES / es->item_bytes, wn = 0;
    if (rc == 0 && !(wbuf = en_malloc(wcap * es->item_bytes)))
        rc = nomem(es, err);
    while (rc == 0) {
        int got = merge_pop(es, cs, tree, k, wbuf + wn * es->cfg.item_words, err);
        if (got < 0)
            rc = got;
        if (got > 0) {
            items++;
            wn++;
        }
        if (rc == 0 && wn && (wn == wcap || got == 0)) {
            if ((rc = en_spill_write(out, wbuf, wn * es->item_bytes, err)))
                fail(es, rc, err);
            wn = 0;
        }
        if (got == 0)
            break;
    }
    en_free(wbuf);
    merge_end(es, &cs, &tree, k);
    if (rc == 0 && (rc = en_spill_rewind(out, err)))
        fail(es, rc, err);
    if (rc) {
        en_spill_close(&out);
        return rc;
    }
    close_runs(es, first, k);
    es->nruns = first;
    return push_run(es, out, level, items, err);
}

/* Keep at most fanin runs per level (file comment). */
static int cascade(en_extsort *es, epsnet_error *err)
{
    for (;;) {
        if (es->nruns < es->fanin)
            return 0;
        int level = es->runs[es->nruns - 1].level;
        for (size_t i = es->nruns - es->fanin; i < es->nruns; i++)
            if (es->runs[i].level != level)
                return 0;
        int rc = merge_top(es, es->fanin, level + 1, err);
        if (rc)
            return rc;
    }
}

static int run_job_fn(void *arg)
{
    run_job *jb = arg;
    en_extsort *es = jb->es;
    radix_sort(jb->buf, jb->tmp, jb->n, es->cfg.item_words, es->cfg.key_words, es->mask0, jb->count);
    int rc = en_spill_open_plain(&jb->sp, es->cfg.tmpdir, es->cfg.owner, &jb->err);
    if (rc == 0)
        rc = en_spill_write(jb->sp, jb->buf, jb->n * es->item_bytes, &jb->err);
    if (rc == 0)
        rc = en_spill_rewind(jb->sp, &jb->err);
    if (rc)
        en_spill_close(&jb->sp);
    return rc;
}

/* Wait for the runs in flight and throw them away (a failure, the end). */
static void drop_runs(en_extsort *es)
{
    for (size_t i = 0; i < es->job_busy; i++) {
        void *job;
        int result;
        en_jobring_retire(es->ring, &job, &result);
        en_spill_close(&es->job[i].sp);
    }
    es->job_busy = 0;
}

/* Wait for the runs in flight, if any, and put them on the stack in the
 * order they were cut. */
static int retire_run(en_extsort *es, epsnet_error *err)
{
    size_t busy = es->job_busy, failed = busy;
    int rc = 0;
    for (size_t i = 0; i < busy; i++) {
        void *job;
        int result;
        en_jobring_retire(es->ring, &job, &result);
        if (result && failed == busy) {
            failed = i;
            rc = result;
        }
    }
    if (!busy)
        return 0;
    es->job_busy = 0;
    es->spare = es->job_buf;
    es->job_buf = NULL;
    if (rc) {
        if (err)
            *err = es->job[failed].err;
        rc = fail(es, rc, err);
    }
    for (size_t i = 0; i < busy; i++) {
        if (rc == 0)
            rc = push_run(es, es->job[i].sp, 0, es->job[i].n, err);
        else
            en_spill_close(&es->job[i].sp);
        es->job[i].sp = NULL;
    }
    return rc ? rc : cascade(es, err);
}

/* note: workers sort and write the full buffer while the caller fills the
 * spare: the input's parsing and the runs overlap. With several workers
 * the buffer is cut in as many runs, sorted side by side (a worker alone
 * sorting one left the caller waiting for it and the other cores idle: on
 * a shuffled 20M-face PLY the sort's pass 2 ran on one core for a second;
 * bench/RESULTS.md, session 31). Runs stay in the order they were cut, so
 * ties still leave by run age and the items come out the same for any
 * number of parts. */
static int spill_buffer_async(en_extsort *es, epsnet_error *err)
{
    int rc = retire_run(es, err);
    if (rc)
        return rc;
    if (!es->spare) {
        es->spare = en_malloc(es->cap * es->item_bytes);
        if (!es->spare)
            return nomem(es, err);
        es->buf_bytes += (uint64_t)es->cap * es->item_bytes;
        en_mem_take(es->cfg.account, (uint64_t)es->cap * es->item_bytes);
    }
    /* a part of at least RUN_PART_MIN items: under a small budget more
     * runs are more merge levels (its fan-in is small), which cost more
     * than the sorting saves (a 1 MB --mem ran 4 times slower) */
    size_t words = es->cfg.item_words, parts = es->n / RUN_PART_MIN < es->parts ? es->n / RUN_PART_MIN : es->parts;
    if (parts < 1)
        parts = 1;
    es->job_buf = es->buf;
    for (size_t i = 0; i < parts; i++) {
        size_t lo = es->n * i / parts, hi = es->n * (i + 1) / parts;
        es->job[i] = (run_job){ .es = es, .buf = es->buf + lo * words, .n = hi - lo,
                                .tmp = es->scratch + lo * words,
                                .count = es->count + i * es->cfg.key_words * 8 };
        if (en_jobring_submit(es->ring, run_job_fn, &es->job[i]))
            break;
        es->job_busy = i + 1;
    }
    if (es->job_busy < parts) { /* a caller bug: the ring is sized for the parts */
        drop_runs(es);
        es->job_buf = NULL; /* the buffer stays buf */
        en_error_set(err, EPSNET_EINTERNAL, es->cfg.owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                     "external sort: the worker refused a run");
        return fail(es, EPSNET_EINTERNAL, err);
    }
    es->buf = es->spare;
    es->spare = NULL;
    es->n = 0;
    return 0;
}

static int spill_buffer(en_extsort *es, epsnet_error *err)
{
    radix_sort(es->buf, es->scratch, es->n, es->cfg.item_words, es->cfg.key_words, es->mask0, es->count);
    en_spill *sp = NULL;
    int rc = en_spill_open_plain(&sp, es->cfg.tmpdir, es->cfg.owner, err);
    if (rc == 0)
        rc = en_spill_write(sp, es->buf, es->n * es->item_bytes, err);
    /* note: rewinding ends the zstd frame and frees the compressor at once,
     * so a pile of finished runs costs little memory. */
    if (rc == 0)
        rc = en_spill_rewind(sp, err);
    if (rc) {
        en_spill_close(&sp);
        return fail(es, rc, err);
    }
    uint64_t n = es->n;
    es->n = 0;
    if ((rc = push_run(es, sp, 0, n, err)))
        return rc;
    return cascade(es, err);
}

/* Room in the buffer for one item at least: the first buffer, or the full
 * one spilled as a run. */
static int make_room(en_extsort *es, epsnet_error *err)
{
    if (!es->buf && alloc_buffer(es, err))
        return es->err.code;
    if (es->n == es->cap) {
        /* note: a thread that cannot start leaves the runs to this one */
        if (es->cfg.threads > 0 && !es->pool && !es->ring && es->cfg.pool) {
            /* the run's pool: a ring of our own on it */
            if (en_jobring_new(&es->ring, es->cfg.pool, es->parts))
                return nomem(es, err);
        }
        if (es->cfg.threads > 0 && !es->pool && !es->cfg.pool) {
            int rc = en_pool_new(&es->pool, (int)es->parts);
            if (rc == 0 && en_jobring_new(&es->ring, es->pool, es->parts)) {
                en_pool_free(&es->pool);
                rc = EPSNET_ENOMEM;
            }
            if (rc == EPSNET_ENOMEM)
                return nomem(es, err);
            if (rc)
                es->cfg.threads = 0;
        }
        return es->ring ? spill_buffer_async(es, err) : spill_buffer(es, err);
    }
    return 0;
}

int en_extsort_add(en_extsort *es, const uint64_t *item, epsnet_error *err)
{
    if (es->failed)
        return fail(es, es->err.code, err);
    int rc = make_room(es, err);
    if (rc)
        return rc;
    copy_item(es->buf + es->n * es->cfg.item_words, item, es->cfg.item_words);
    es->n++;
    es->items++;
    return 0;
}

int en_extsort_add_many(en_extsort *es, const uint64_t *items, size_t n, epsnet_error *err)
{
    if (es->failed)
        return fail(es, es->err.code, err);
    size_t w = es->cfg.item_words;
    while (n > 0) {
        int rc = make_room(es, err);
        if (rc)
            return rc;
        size_t k = es->cap - es->n < n ? es->cap - es->n : n;
        memcpy(es->buf + es->n * w, items, k * w * sizeof *items);
        es->n += k;
        es->items += k;
        items += k * w;
        n -= k;
    }
    return 0;
}

int en_extsort_finish(en_extsort *es, epsnet_error *err)
{
    if (es->failed)
        return fail(es, es->err.code, err);
    es->finished = 1;
    int rc = retire_run(es, err);
    if (rc)
        return rc;
    if (es->nruns == 0) {
        /* note: all items fit: sort them in place and hand them out from
         * memory; the scratch half is no longer needed. */
        if (es->buf)
            radix_sort(es->buf, es->scratch, es->n, es->cfg.item_words, es->cfg.key_words, es->mask0, es->count);
        en_free(es->scratch);
        es->scratch = NULL;
        en_mem_give(es->cfg.account, es->buf_bytes / 2);
        es->buf_bytes -= es->buf_bytes / 2;
        es->in_memory = 1;
        return 0;
    }
    /* the last buffer as the others went, in parts on the workers: on the
     * calling thread it was a sixth of that thread's sort passes on a
     * shuffled 20M-face PLY (bench/RESULTS.md, session 39) */
    if (es->n)
        rc = es->ring ? spill_buffer_async(es, err) : spill_buffer(es, err);
    if (rc == 0 && es->ring)
        rc = retire_run(es, err);
    free_buffer(es);
    while (rc == 0 && es->nruns > es->fanin)
        rc = merge_top(es, es->fanin, es->runs[es->nruns - 1].level + 1, err);
    if (rc)
        return rc;
    es->ncur = es->nruns;
    return merge_begin(es, 0, es->nruns, &es->cur, &es->tree, err);
}

const uint64_t *en_extsort_peek(en_extsort *es, int *rc, epsnet_error *err)
{
    *rc = 0;
    if (es->failed) {
        *rc = fail(es, es->err.code, err);
        return NULL;
    }
    if (es->in_memory)
        return es->out_pos < es->n ? es->buf + es->out_pos * es->cfg.item_words : NULL;
    const cursor *c = &es->cur[es->tree[0]];
    return c->n ? cursor_item(es, c) : NULL;
}

int en_extsort_next(en_extsort *es, uint64_t *item, epsnet_error *err)
{
    if (es->failed)
        return fail(es, es->err.code, err);
    if (es->in_memory) {
        if (es->out_pos == es->n)
            return 0;
        copy_item(item, es->buf + es->out_pos++ * es->cfg.item_words, es->cfg.item_words);
        return 1;
    }
    return merge_pop(es, es->cur, es->tree, es->ncur, item, err);
}

uint64_t en_extsort_items(const en_extsort *es)
{
    return es->items;
}

uint64_t en_extsort_runs(const en_extsort *es)
{
    return es->runs_written;
}

uint64_t en_extsort_temp_bytes(const en_extsort *es)
{
    uint64_t t = es->temp_bytes;
    for (size_t i = 0; i < es->nruns; i++)
        t += en_spill_disk_bytes(es->runs[i].sp);
    return t;
}

void en_extsort_close(en_extsort **pes)
{
    en_extsort *es = pes ? *pes : NULL;
    if (!es)
        return;
    if (es->job_busy) {
        drop_runs(es);
        en_free(es->job_buf);
    }
    en_jobring_free(&es->ring, NULL);
    en_pool_free(&es->pool);
    merge_end(es, &es->cur, &es->tree, es->ncur);
    for (size_t i = 0; i < es->nruns; i++)
        en_spill_close(&es->runs[i].sp);
    en_free(es->runs);
    free_buffer(es);
    en_free(es->count);
    en_free(es);
    *pes = NULL;
}
