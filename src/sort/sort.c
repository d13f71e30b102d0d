/*
 * epsnet_sort_file(): the passes of sort.h, one function each, sharing a
 * sort_job that owns every temporary resource so that one cleanup path
 * frees them on success and on failure alike.
 */
#include "sort/sort.h"

#include <math.h>
#include <unistd.h>
#include <string.h>

#include "common/alloc.h"
#include "common/error.h"
#include "common/fault.h"
#include "common/hash64.h"
#include "common/pool.h"
#include "common/thread.h"
#include "common/util.h"
#include "io/format.h"
#include "io/sink.h"
#include "sort/emit_block.h"
#include "sort/extsort.h"

#define NONE UINT64_MAX
#define BATCH 4096               /* vertices per temporary-file read or write */
#define PREFETCH 16              /* items ahead whose random reads are started early */
#define RELABEL_AHEAD 2          /* pass 5 in core: batches relabelled ahead of the one added */
#define PROGRESS_EVERY 0xffff
#define PHASES 6
#define PHASE_UNITS 1000

/* EPSNET_FAIL_SORT_WIDE=N: the N-th face spilled in pass 1 and those after
 * it are written as if past 2^32 vertices (put_faces), so that the tests
 * see both layouts of the temporary faces and the switch between them */
static en_fault wide_fault = EN_FAULT_INIT("EPSNET_FAIL_SORT_WIDE");

void epsnet_sort_default_settings(epsnet_sort_settings *s)
{
    memset(s, 0, sizeof *s);
    s->axis = -1;
    s->mem = (uint64_t)512 << 20;
    s->tmpdir = NULL;
    s->format = NULL;
    s->progress = NULL;
    s->progress_opaque = NULL;
}

int en_sort_longest_axis(const double lo[3], const double hi[3])
{
    int best = 0;
    for (int k = 1; k < 3; k++)
        if (hi[k] - lo[k] > hi[best] - lo[best])
            best = k;
    return best;
}

/* ---- live vertices of the output: rank -> (new id, last use) ----
 * Open addressing with linear probing and backward-shift deletion, so the
 * table never fills with tombstones however long the stream. */

typedef struct live_slot {
    uint64_t rank;               /* NONE = empty */
    uint64_t id;                 /* index in the output */
    uint64_t last;               /* rank whose face group uses it last */
    uint64_t fin_face;           /* face of that group after which it is finalized */
} live_slot;

typedef struct live_map {
    live_slot *slots;
    size_t mask;
    size_t count;
} live_map;

static int live_resize(live_map *m, size_t cap)
{
    live_slot *s = en_malloc(cap * sizeof *s);
    if (!s)
        return -1;
    for (size_t i = 0; i < cap; i++)
        s[i].rank = NONE;
    for (size_t i = 0; m->slots && i <= m->mask; i++) {
        if (m->slots[i].rank == NONE)
            continue;
        size_t j = en_hash_slot(m->slots[i].rank, cap - 1);
        while (s[j].rank != NONE)
            j = (j + 1) & (cap - 1);
        s[j] = m->slots[i];
    }
    en_free(m->slots);
    m->slots = s;
    m->mask = cap - 1;
    return 0;
}

static live_slot *live_find(live_map *m, uint64_t rank)
{
    for (size_t i = en_hash_slot(rank, m->mask);; i = (i + 1) & m->mask) {
        if (m->slots[i].rank == rank)
            return &m->slots[i];
        if (m->slots[i].rank == NONE)
            return NULL;
    }
}

static int live_add(live_map *m, uint64_t rank, uint64_t id, uint64_t last)
{
    if (!m->slots && live_resize(m, 1024))
        return -1;
    if (2 * (m->count + 1) > m->mask + 1 && live_resize(m, 2 * (m->mask + 1)))
        return -1;
    size_t i = en_hash_slot(rank, m->mask);
    while (m->slots[i].rank != NONE)
        i = (i + 1) & m->mask;
    m->slots[i] = (live_slot){ .rank = rank, .id = id, .last = last, .fin_face = NONE };
    m->count++;
    return 0;
}

static void live_remove(live_map *m, live_slot *s)
{
    size_t i = (size_t)(s - m->slots);
    m->slots[i].rank = NONE;
    m->count--;
    for (size_t j = (i + 1) & m->mask; m->slots[j].rank != NONE; j = (j + 1) & m->mask) {
        size_t home = en_hash_slot(m->slots[j].rank, m->mask);
        if (en_hash_can_fill(home, i, j, m->mask)) {
            m->slots[i] = m->slots[j];
            m->slots[j].rank = NONE;
            i = j;
        }
    }
}

static uint64_t live_bytes(const live_map *m)
{
    return m->slots ? (uint64_t)(m->mask + 1) * sizeof *m->slots : 0;
}

/* ---- a sorter's final merge, a block ahead on a worker ----
 * note: the final merge of sorter F is most of what pass 6 does for the
 * sort itself (the rest is the consumer's: encoding the output), and that
 * of sorter V a third of pass 3 on the calling thread (session 37). A
 * worker merges the next block of items into one buffer while the calling
 * thread walks the other, so the merge overlaps the walk
 * (docs/architecture.md §10, §13). One fill is in flight at a time, on a
 * one-slot ring, so the sorter is only ever touched by one fill, and the
 * blocks, hence the items, come in the same order for any thread count. */
#define FEED_ITEMS 16384

typedef struct item_fill {
    /* Written by the calling thread before submit, read by the worker. */
    en_extsort *sorter;          /* touched only by the fill in flight */
    uint64_t *buf;               /* FEED_ITEMS items: the worker writes them while in flight */
    size_t words;
    /* Written by the worker, read by the calling thread after retire. */
    size_t n;                    /* items filled; fewer than FEED_ITEMS: the sorter is drained */
    epsnet_error err;
} item_fill;

/* Calling thread only. */
typedef struct item_feed {
    en_pool *pool;               /* ours (0 workers: inline) when the sort has none (sort_pool) */
    en_jobring *ring;            /* one slot */
    item_fill fill[2];
    int cur;                     /* the block being walked: fill[cur] */
    size_t pos;                  /* its next item */
    int busy;                    /* fill[1 - cur] is in flight */
    uint64_t bytes;              /* accounted */
} item_feed;

/* ---- stretches kept for windows ----
 * note: a size's pricing pass walks a few windows of the sorted stream
 * before pass 6 starts it (docs/architecture.md §7). In memory they are the
 * whole path's arrays; an external sort keeps, in temporary files, the
 * stretches of ranks the consumer names at open: pass 3 writes their
 * vertices, pass 5 every face with a corner among them (input order), so
 * a window inside one is pushed with the same records as the arrays would
 * give, without a seekable copy of the whole stream. The stretches are
 * under a fifth of the stream (api/windows.c: en_windows_stretches) and on
 * disk, so the sort's memory does not grow with them. */
typedef struct stretch {
    uint64_t lo, hi;             /* ranks [lo, hi) */
    en_spill *verts;             /* vertex records (vrec bytes) of ranks lo..hi-1, pass 3 */
    en_spill *faces;             /* faces with a corner in [lo, hi): 3 ranks, input order, pass 5 */
    uint64_t *used;              /* bit r - lo: a face uses rank r (stretch_used); NULL until asked */
} stretch;

/* ---- the job ---- */

struct en_sort {
    const char *in_path;
    const char *owner;           /* the output the sort serves: named in messages */
    epsnet_sort_settings set;
    char *tmpdir;
    en_mem_account mem;
    epsnet_sort_stats st;
    epsnet_reader *r;
    en_face_names_copy materials, groups; /* the reader's (read to its end), which the writer names */
    en_sort_emit_fn emit;        /* pass 6 hands each record to emit(emit_opaque) */
    void *emit_opaque;
    en_spill *vraw;              /* input vertices, input order */
    en_spill *vsorted;           /* vertices in rank order */
    en_spill *fraw;              /* input faces (old ids), input order */
    int in_core;                 /* rank_of/last_of arrays fit the budget */
    int narrow;                  /* ranks fit 32 bits: sorter F's items are 2 words, not 4 */
    int whole;                   /* everything is in memory (see whole_fits) */
    double *xyz;                 /* whole: input vertices, 3 each */
    uint32_t *tri;               /* whole: input faces, 3 old ids each */
    size_t xyz_n, xyz_cap;       /* vertices */
    size_t tri_n, tri_cap;       /* faces */
    double *sxyz;                /* whole: the vertices in rank order, 3 each */
    uint8_t *attr;               /* whole: input vertices' attribute bytes, asz each */
    uint8_t *sattr;              /* whole: the same in rank order */
    uint32_t *fend;              /* whole: rank -> end of its faces in fitems */
    uint64_t *fitems;            /* whole: faces by (last corner, input order): see whole_faces */
    uint64_t whole_bytes;        /* accounted */
    en_pool *pool;               /* ours when not shared (start_pool); NULL = this thread */
    en_pool *shared;             /* the run's pool when given (not ours to free) */
    en_jobring *ring;            /* the whole path's pieces, retired in order */
    size_t chunks;               /* pieces the whole path's loops are cut into */
    uint32_t *rank_of;           /* in core: old id -> rank */
    uint32_t *last_of;           /* in core: rank -> last use, UINT32_MAX none */
    uint64_t arrays_bytes;
    en_extsort *corners, *verts, *map, *joined, *faces, *lastuse;
    uint64_t runs, temp_bytes;   /* of the sorters already closed */
    double lo[3], hi[3];
    int axis;
    epsnet_coord_type ct;
    int phase;
    /* Vertex attributes travel with their vertex, bit for bit
     * (epsnet.h §2): in every vertex record of the spills (xyz, then asz
     * bytes: vrec bytes), in sorter V's items (aw words after the four) and
     * in the whole path's arrays. */
    epsnet_attr_layout attrs;
    size_t asz, aw, vrec;
    size_t cbytes;               /* a coordinate's bytes in the spills: 4 for a float32 input, else 8 */
    uint64_t fwide_from;         /* fraw: faces before this one hold 3 x 4 bytes, the rest 3 x 8 */
    int keep_attrs;              /* EN_SORT_KEEP_* | EN_SORT_DROP_NORMALS; 0: the consumer carries none */
    uint8_t *vbuf;               /* BATCH vertex records of vrec bytes */
    uint64_t *fbuf;              /* BATCH faces */
    uint64_t *group;             /* faces of one last corner: 5 words each */
    size_t group_cap;
    live_map live;
    item_feed feed;              /* pass 3: sorter V's items, pass 6: sorter F's, a block ahead */
    en_sort_stretches_fn stretches; /* what to keep for en_sort_window (NULL: nothing) */
    stretch keep[EN_SORT_MAX_STRETCHES];
    uint32_t nkeep;
    uint64_t keep_lo, keep_hi;   /* the span of every kept stretch */
    int kept;                    /* after pass 5: the stretches read back (stretch_window) */
    double t0;
};

typedef struct en_sort sort_job;

static int progress(sort_job *j, uint64_t done, uint64_t total, epsnet_error *err)
{
    if (!j->set.progress)
        return 0;
    uint64_t frac = total ? (done >= total ? PHASE_UNITS : done * PHASE_UNITS / total) : 0;
    if (j->set.progress(j->set.progress_opaque, (uint64_t)(j->phase - 1) * PHASE_UNITS + frac,
                        (uint64_t)PHASES * PHASE_UNITS))
        return en_error_set(err, EPSNET_EINTR, j->owner, EPSNET_POS_NONE, EPSNET_POS_NONE, "interrupted");
    return 0;
}

static int nomem(const sort_job *j, epsnet_error *err)
{
    return en_error_set(err, EPSNET_ENOMEM, j->owner, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
}

/* Threads asked for: as epsnet_settings.threads, 0 = all cores. */
static long sort_workers(const sort_job *j)
{
    if (j->shared) /* its threads; 0 runs jobs on this thread */
        return en_pool_threads(j->shared) > 1 ? en_pool_threads(j->shared) : 1;
    long n = j->set.threads > 0 ? j->set.threads : en_cpus_usable();
    return n > 64 ? 64 : n;
}

/* The workers the sort's jobs run on: the run's, else its own (start_pool),
 * else none (NULL). */
static en_pool *sort_pool(const sort_job *j)
{
    return j->shared ? j->shared : j->pool;
}

/* note: every sorter keys on its first word only. The sort is stable and
 * items arrive in input order (vertex id, face id), so ties keep input
 * order: the (coordinate, id) and (last corner, face) orders of sort.h
 * without comparing the second word. */
static int open_sorter(sort_job *j, en_extsort **es, size_t words, uint64_t key_mask, epsnet_error *err)
{
    en_extsort_config c = {
        .item_words = words, .key_words = 1, .key_mask = key_mask, .mem = j->set.mem / 4,
        .tmpdir = j->tmpdir, .owner = j->owner, .account = &j->mem,
        .threads = sort_workers(j) > 1 ? (int)sort_workers(j) : 0, /* runs cut side by side, one a worker */
        .pool = j->shared,
    };
    return en_extsort_open(es, &c, err);
}

static void close_sorter(sort_job *j, en_extsort **es)
{
    if (!*es)
        return;
    j->runs += en_extsort_runs(*es);
    j->temp_bytes += en_extsort_temp_bytes(*es);
    en_extsort_close(es);
}

/* A plain spill for the calling thread's writes, written behind on the
 * pool (en_spill_write_behind): the copies into the page cache were a
 * quarter of the calling thread's time in passes 1 to 5 of a shuffled
 * 20M-face PLY (1.6% of the run's samples, session 38). */
static int open_spill(sort_job *j, en_spill **sp, epsnet_error *err)
{
    int rc = en_spill_open_plain(sp, j->tmpdir, j->owner, err);
    if (rc == 0)
        (void)en_spill_write_behind(*sp, sort_pool(j)); /* ENOMEM: it writes here */
    return rc;
}

static void close_spill(sort_job *j, en_spill **sp)
{
    if (!*sp)
        return;
    j->temp_bytes += en_spill_disk_bytes(*sp);
    en_spill_close(sp);
}

/* Doubles as unsigned keys in the same order (-0 just below +0). */
static uint64_t order_key(double d)
{
    uint64_t u;
    memcpy(&u, &d, sizeof u);
    return u >> 63 ? ~u : u | (uint64_t)1 << 63;
}

static double order_value(uint64_t u)
{
    u = u >> 63 ? u & ~((uint64_t)1 << 63) : ~u;
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}

static uint64_t dbits(double d)
{
    uint64_t u;
    memcpy(&u, &d, sizeof u);
    return u;
}

/* Two floats in one word, as memcpy lays them (the first in the lower
 * address). */
static uint64_t fbits2(float x, float y)
{
    float f[2] = { x, y };
    uint64_t u;
    memcpy(&u, f, sizeof u);
    return u;
}

/* Sorter V's item: key, id, coordinates (two words, or one of two floats),
 * then the attribute words. */
static size_t vert_words(const sort_job *j)
{
    return j->cbytes == sizeof(float) ? 3 : 4;
}

static double bitsd(uint64_t u)
{
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}

/* ---- everything in memory ----
 *
 * note: when the input's vertices and faces and the arrays that sort them
 * fit in half of the budget (half, as for the in-core arrays of
 * choose_relabel: the rest is the reader's, the writer's and, in pass 6,
 * the consumer's), passes 1 to 5 need no temporary file and no compression
 * at all: the vertices are ranked by a radix sort of their keys, and the
 * faces put in (last corner, input order) by a radix sort on their last
 * corner, which is a rank. Both sorts are stable, so the output is the
 * external passes' to the byte. Past that size the read moves what it holds
 * to the spills and goes on with the external passes.
 */

/* Bytes the whole path may hold at once for nv vertices and nf faces, a
 * bound on both of its peaks: xyz and tri, the keys (16 bytes each) with
 * their radix copy or, later, the coordinates in rank order and rank_of;
 * then the coordinates, the faces' items and their radix copy (16 bytes
 * each), fend and last_of. Pass 6 holds less: the coordinates, the items,
 * and four arrays over the ranks. */
static uint64_t whole_bytes(uint64_t nv, uint64_t nf, uint64_t asz)
{
    /* attributes: the input's and, while they are gathered, the ranked copy */
    return (68 + 2 * asz) * nv + 36 * nf;
}

static int whole_fits(const sort_job *j, uint64_t nv, uint64_t nf)
{
    return nv < UINT32_MAX && nf < UINT32_MAX && whole_bytes(nv, nf, j->asz) <= j->set.mem / 2;
}

/* Vertex record i of vbuf: xyz, then its attribute bytes. */
static uint8_t *vrec_at(const sort_job *j, size_t i)
{
    return j->vbuf + i * j->vrec;
}

/* Its attribute bytes, after the coordinates. */
static uint8_t *vrec_attr(const sort_job *j, size_t i)
{
    return vrec_at(j, i) + 3 * j->cbytes;
}

/* note: a float32 input's coordinates are floats from pass 1 on (read_xyz),
 * so its records hold them as floats: the spills' vertices in half the
 * bytes, and the same values (docs/architecture.md §13). */
static void vrec_put(sort_job *j, size_t i, const double xyz[3], const uint8_t *attr)
{
    uint8_t *p = vrec_at(j, i);
    if (j->cbytes == sizeof(float)) {
        float f[3] = { (float)xyz[0], (float)xyz[1], (float)xyz[2] };
        memcpy(p, f, sizeof f);
    } else {
        memcpy(p, xyz, 3 * sizeof *xyz);
    }
    if (j->asz)
        memcpy(p + 3 * j->cbytes, attr, j->asz);
}

static void vrec_get(const sort_job *j, size_t i, double xyz[3])
{
    const uint8_t *p = vrec_at(j, i);
    if (j->cbytes == sizeof(float)) {
        float f[3];
        memcpy(f, p, sizeof f);
        for (int k = 0; k < 3; k++)
            xyz[k] = f[k];
    } else {
        memcpy(xyz, p, 3 * sizeof *xyz);
    }
}

/* Write n faces of fbuf (3 old ids each, all below UINT32_MAX unless
 * j->fwide_from was reached) to fraw: 3 x 4 bytes each before fwide_from,
 * packed in place. */
static int put_faces(sort_job *j, size_t n, epsnet_error *err)
{
    if (j->fwide_from != UINT64_MAX)
        return en_spill_write(j->fraw, j->fbuf, n * 3 * sizeof *j->fbuf, err);
    uint8_t *u = (uint8_t *)j->fbuf; /* (memcpy: the bytes change type in place) */
    for (size_t i = 0; i < 3 * n; i++) {
        uint64_t x; /* read before its bytes are written over: 4 i + 3 < 8 i for i > 0 */
        memcpy(&x, u + 8 * i, sizeof x);
        uint32_t y = (uint32_t)x;
        memcpy(u + 4 * i, &y, sizeof y);
    }
    return en_spill_write(j->fraw, u, n * 3 * sizeof(uint32_t), err);
}

/* No longer whole: what was read goes to the spills, in input order. */
static int whole_spill(sort_job *j, epsnet_error *err)
{
    int rc = 0;
    j->whole = 0;
    for (size_t v = 0; v < j->xyz_n && rc == 0;) {
        size_t n = j->xyz_n - v < BATCH ? j->xyz_n - v : BATCH;
        for (size_t i = 0; i < n; i++)
            vrec_put(j, i, j->xyz + 3 * (v + i), j->asz ? j->attr + (v + i) * j->asz : NULL);
        rc = en_spill_write(j->vraw, j->vbuf, n * j->vrec, err);
        v += n;
    }
    if (rc)
        return rc;
    for (size_t f = 0; f < j->tri_n && rc == 0;) {
        size_t n = j->tri_n - f < BATCH ? j->tri_n - f : BATCH;
        for (size_t i = 0; i < 3 * n; i++)
            j->fbuf[i] = j->tri[3 * f + i];
        rc = put_faces(j, n, err);
        f += n;
    }
    en_free(j->xyz);
    en_free(j->tri);
    en_free(j->attr);
    j->xyz = NULL;
    j->tri = NULL;
    j->attr = NULL;
    j->xyz_cap = j->tri_cap = j->xyz_n = j->tri_n = 0;
    en_mem_give(&j->mem, j->whole_bytes);
    j->whole_bytes = 0;
    return rc;
}

/* Room for at least one more vertex (vertices 1) or face (0): grow by half
 * within the budget. @return 0, or 1 when it does not fit (then the caller
 * spills). */
static int whole_grow(sort_job *j, int vertices)
{
    size_t n = vertices ? j->xyz_n : j->tri_n, cap = vertices ? j->xyz_cap : j->tri_cap;
    size_t want = cap < 4096 ? 4096 : cap + cap / 2;
    uint64_t nv = vertices ? want : j->xyz_cap, nf = vertices ? j->tri_cap : want;
    if (!whole_fits(j, nv, nf)) {
        /* the most that fits */
        uint64_t lo = n + 1, hi = want;
        if (!whole_fits(j, vertices ? lo : nv, vertices ? nf : lo))
            return 1;
        while (lo < hi) {
            uint64_t mid = lo + (hi - lo + 1) / 2;
            if (whole_fits(j, vertices ? mid : nv, vertices ? nf : mid))
                lo = mid;
            else
                hi = mid - 1;
        }
        want = (size_t)lo;
    }
    void *p = vertices ? en_realloc(j->xyz, want * 3 * sizeof *j->xyz) : en_realloc(j->tri, want * 3 * sizeof *j->tri);
    if (!p)
        return 1; /* note: the spills need far less memory: try them */
    if (vertices) {
        j->xyz = p;
        if (j->asz) {
            uint8_t *a = en_realloc(j->attr, want * j->asz);
            if (!a)
                return 1;
            j->attr = a;
        }
        j->xyz_cap = want;
    } else {
        j->tri = p;
        j->tri_cap = want;
    }
    uint64_t b = (uint64_t)j->xyz_cap * (3 * sizeof *j->xyz + j->asz) + (uint64_t)j->tri_cap * 3 * sizeof *j->tri;
    en_mem_give(&j->mem, j->whole_bytes);
    j->whole_bytes = b;
    en_mem_take(&j->mem, b);
    return 0;
}

/* @return 0 when kept, 1 when the path is no longer whole (the caller
 * spills the record), or < 0. */
static int whole_vertex(sort_job *j, const double p[3], const uint8_t *attr, epsnet_error *err)
{
    if (j->xyz_n == j->xyz_cap && whole_grow(j, 1)) {
        int rc = whole_spill(j, err);
        return rc ? rc : 1;
    }
    if (j->asz)
        memcpy(j->attr + j->xyz_n * j->asz, attr, j->asz);
    memcpy(j->xyz + 3 * j->xyz_n++, p, 3 * sizeof *p);
    return 0;
}

static int whole_face(sort_job *j, const uint64_t v[3], epsnet_error *err)
{
    if (v[0] >= UINT32_MAX || v[1] >= UINT32_MAX || v[2] >= UINT32_MAX ||
        (j->tri_n == j->tri_cap && whole_grow(j, 0))) {
        int rc = whole_spill(j, err);
        return rc ? rc : 1;
    }
    for (int s = 0; s < 3; s++)
        j->tri[3 * j->tri_n + (size_t)s] = (uint32_t)v[s];
    j->tri_n++;
    return 0;
}

static int internal(const sort_job *j, const char *what, epsnet_error *err);

/* The whole path's loops run as `chunks` pieces on the pool. Pieces are
 * cut by count only and write disjoint ranges (or disjoint entries), so
 * the result is the same for any number of threads. */
typedef struct whole_piece {
    sort_job *j;
    size_t lo, hi;               /* items [lo, hi) */
    int shift;                   /* radix: the byte counted or moved */
    size_t count[256];           /* radix: this piece's histogram, then its offsets */
    const uint64_t *src;         /* radix: 2 words per item, the key first */
    uint64_t *dst;
} whole_piece;

static int run_pieces(sort_job *j, whole_piece *pc, en_job_fn fn, epsnet_error *err)
{
    int first = 0;
    if (!j->pool) {
        for (size_t c = 0; c < j->chunks; c++)
            if ((first = fn(&pc[c])) != 0)
                break;
    } else {
        for (size_t c = 0; c < j->chunks; c++)
            if (en_jobring_submit(j->ring, fn, &pc[c]) && !first)
                first = EPSNET_EINTERNAL;
        void *job;
        int result;
        while (en_jobring_retire(j->ring, &job, &result))
            if (result && !first)
                first = result;
    }
    return first ? internal(j, "a piece of the in-memory sort failed", err) : 0;
}

static void cut_pieces(sort_job *j, whole_piece *pc, uint64_t n)
{
    for (size_t c = 0; c < j->chunks; c++) {
        pc[c].j = j;
        pc[c].lo = (size_t)(n * c / j->chunks);
        pc[c].hi = (size_t)(n * (c + 1) / j->chunks);
    }
}

/* The vertices' (key, input id) items. */
static int piece_keys(void *arg)
{
    whole_piece *p = arg;
    sort_job *j = p->j;
    uint64_t *k = p->dst;
    for (size_t i = p->lo; i < p->hi; i++) {
        k[2 * i] = order_key(j->xyz[3 * i + (size_t)j->axis]);
        k[2 * i + 1] = i;
    }
    return 0;
}

static int piece_count(void *arg)
{
    whole_piece *p = arg;
    memset(p->count, 0, sizeof p->count);
    for (size_t i = p->lo; i < p->hi; i++)
        p->count[(p->src[2 * i] >> p->shift) & 0xff]++;
    return 0;
}

static int piece_move(void *arg)
{
    whole_piece *p = arg;
    for (size_t i = p->lo; i < p->hi; i++) {
        size_t at = p->count[(p->src[2 * i] >> p->shift) & 0xff]++;
        p->dst[2 * at] = p->src[2 * i];
        p->dst[2 * at + 1] = p->src[2 * i + 1];
    }
    return 0;
}

/* note: the coordinates are gathered into rank order here, where the
 * loop's reads are independent and overlap, rather than read at random in
 * pass 6, one at a time behind the live map. */
static int piece_ranks(void *arg)
{
    whole_piece *p = arg;
    sort_job *j = p->j;
    for (size_t r = p->lo; r < p->hi; r++) {
        uint32_t id = (uint32_t)p->src[2 * r + 1];
        j->rank_of[id] = (uint32_t)r;
        memcpy(j->sxyz + 3 * r, j->xyz + 3 * (size_t)id, 3 * sizeof *j->xyz);
        if (j->asz)
            memcpy(j->sattr + r * j->asz, j->attr + (size_t)id * j->asz, j->asz);
    }
    return 0;
}

static int piece_faces(void *arg)
{
    whole_piece *p = arg;
    sort_job *j = p->j;
    for (size_t f = p->lo; f < p->hi; f++) {
        const uint32_t *t = j->tri + 3 * f;
        uint64_t a = j->rank_of[t[0]], b = j->rank_of[t[1]], c = j->rank_of[t[2]];
        uint64_t m = a > b ? a : b;
        m = m > c ? m : c;
        j->fitems[2 * f] = m | a << 32;
        j->fitems[2 * f + 1] = b | c << 32;
    }
    return 0;
}

static int whole_alloc(sort_job *j, void **p, uint64_t n, size_t elem, epsnet_error *err)
{
    *p = en_malloc(n ? (size_t)n * elem : 1);
    return *p ? 0 : nomem(j, err);
}

/* LSD radix sort of n items of 2 words by the bits keymask selects of
 * their first word, a byte at a time, in pieces: stable, and byte
 * positions where every key has the same value are skipped (the low bytes
 * of coordinates that came from float32 are all zero; the high bytes of
 * ranks). *a holds the items and gets the sorted ones; *b is the scratch
 * copy, which this frees. */
static int whole_radix(sort_job *j, whole_piece *pc, uint64_t **a, uint64_t **b, uint64_t n, uint64_t keymask,
                       epsnet_error *err)
{
    uint64_t diff = 0;
    for (uint64_t i = 0; i < n; i++)
        diff |= (*a)[2 * i] ^ (*a)[0];
    diff &= keymask;
    int rc = 0;
    cut_pieces(j, pc, n);
    for (int shift = 0; rc == 0 && shift < 64; shift += 8) {
        if (((diff >> shift) & 0xff) == 0)
            continue;
        for (size_t c = 0; c < j->chunks; c++) {
            pc[c].src = *a;
            pc[c].dst = *b;
            pc[c].shift = shift;
        }
        if ((rc = run_pieces(j, pc, piece_count, err)))
            break;
        size_t sum = 0;
        for (int d = 0; d < 256; d++)
            for (size_t c = 0; c < j->chunks; c++) {
                size_t k = pc[c].count[d];
                pc[c].count[d] = sum;
                sum += k;
            }
        if ((rc = run_pieces(j, pc, piece_move, err)))
            break;
        uint64_t *t = *a;
        *a = *b;
        *b = t;
    }
    en_free(*b);
    *b = NULL;
    return rc;
}

/* Passes 2 and 3 in memory: the vertices' (key, id) radix-sorted; equal
 * coordinates keep input order. */
static int whole_order(sort_job *j, epsnet_error *err)
{
    uint64_t nv = j->st.vertices;
    uint64_t *a = NULL, *b = NULL;
    whole_piece *pc = en_calloc(j->chunks, sizeof *pc);
    int rc = pc ? 0 : nomem(j, err);
    if (rc == 0 && (rc = whole_alloc(j, (void **)&a, 2 * nv, sizeof *a, err)) == 0)
        rc = whole_alloc(j, (void **)&b, 2 * nv, sizeof *b, err);
    uint64_t temp = 32 * nv;
    en_mem_take(&j->mem, temp);
    if (rc == 0) {
        cut_pieces(j, pc, nv);
        for (size_t c = 0; c < j->chunks; c++)
            pc[c].dst = a;
        rc = run_pieces(j, pc, piece_keys, err);
    }
    if (rc == 0)
        rc = whole_radix(j, pc, &a, &b, nv, UINT64_MAX, err);
    if (rc == 0)
        rc = progress(j, 1, 1, err);
    if (rc == 0 && (rc = whole_alloc(j, (void **)&j->sxyz, 3 * nv, sizeof *j->sxyz, err)) == 0)
        rc = whole_alloc(j, (void **)&j->rank_of, nv, sizeof *j->rank_of, err);
    if (rc == 0 && j->asz)
        rc = whole_alloc(j, (void **)&j->sattr, nv, j->asz, err);
    en_mem_take(&j->mem, (28 + j->asz) * nv);
    if (rc == 0) {
        cut_pieces(j, pc, nv);
        for (size_t c = 0; c < j->chunks; c++)
            pc[c].src = a;
        j->phase = 3;
        rc = run_pieces(j, pc, piece_ranks, err);
    }
    en_free(a);
    en_free(b);
    en_free(pc);
    en_free(j->xyz);
    en_free(j->attr);
    j->xyz = NULL;
    j->attr = NULL;
    en_mem_give(&j->mem, temp + (24 + j->asz) * nv);
    return rc;
}

/* Passes 4 and 5 in memory: each face becomes (last corner | its first
 * corner's rank << 32, second | third << 32), in pieces; a radix sort on
 * the last corner keeps input order among equals, which is pass 5's order.
 * fend[r] ends rank r's faces; last_of[r] is r's largest last corner. */
static int whole_faces(sort_job *j, epsnet_error *err)
{
    uint64_t nv = j->st.vertices, nf = j->st.faces;
    whole_piece *pc = en_calloc(j->chunks, sizeof *pc);
    uint64_t *b = NULL;
    int rc = pc ? 0 : nomem(j, err);
    if (rc == 0 && (rc = whole_alloc(j, (void **)&j->fitems, 2 * nf, sizeof *j->fitems, err)) == 0 &&
        (rc = whole_alloc(j, (void **)&j->fend, nv, sizeof *j->fend, err)) == 0)
        rc = whole_alloc(j, (void **)&j->last_of, nv, sizeof *j->last_of, err);
    en_mem_take(&j->mem, 16 * nf + 8 * nv);
    if (rc == 0) {
        cut_pieces(j, pc, nf);
        rc = run_pieces(j, pc, piece_faces, err);
    }
    /* the input ids are no longer needed: the faces hold ranks now */
    en_free(j->tri);
    en_free(j->rank_of);
    j->tri = NULL;
    j->rank_of = NULL;
    en_mem_give(&j->mem, 12 * nf + 4 * nv);
    if (rc == 0)
        rc = whole_alloc(j, (void **)&b, 2 * nf, sizeof *b, err);
    en_mem_take(&j->mem, 16 * nf);
    if (rc == 0)
        rc = whole_radix(j, pc, &j->fitems, &b, nf, UINT32_MAX, err);
    en_free(b);
    en_mem_give(&j->mem, 16 * nf);
    en_free(pc);
    if (rc || (rc = progress(j, 1, 2, err)))
        return rc;
    for (uint64_t v = 0; v < nv; v++)
        j->last_of[v] = UINT32_MAX;
    uint32_t prev = 0;
    for (uint64_t f = 0; f < nf; f++) {
        const uint64_t *it = j->fitems + 2 * f;
        uint32_t l = (uint32_t)it[0], r[3] = { (uint32_t)(it[0] >> 32), (uint32_t)it[1], (uint32_t)(it[1] >> 32) };
        for (; prev < l; prev++)
            j->fend[prev] = (uint32_t)f;
        for (int s = 0; s < 3; s++)
            if (j->last_of[r[s]] == UINT32_MAX || j->last_of[r[s]] < l)
                j->last_of[r[s]] = l;
    }
    for (; prev < nv; prev++)
        j->fend[prev] = (uint32_t)nf;
    return progress(j, 2, 2, err);
}

/* ---- stretches kept for windows (see stretch) ---- */

/* A face's last corner: the largest of its ranks; and its first. */
static uint64_t max3(const uint64_t c[3])
{
    uint64_t m = c[0] > c[1] ? c[0] : c[1];
    return m > c[2] ? m : c[2];
}

static uint64_t min3(const uint64_t c[3])
{
    uint64_t m = c[0] < c[1] ? c[0] : c[1];
    return m < c[2] ? m : c[2];
}

/* The consumer's stretches for the stream's ranks, clamped, sorted and
 * merged where they overlap or touch, each with its two files. */
static int open_stretches(sort_job *j, epsnet_error *err)
{
    if (!j->stretches)
        return 0;
    uint64_t lo[EN_SORT_MAX_STRETCHES], hi[EN_SORT_MAX_STRETCHES], nv = j->st.vertices;
    uint32_t n = j->stretches(nv, lo, hi);
    n = n < EN_SORT_MAX_STRETCHES ? n : EN_SORT_MAX_STRETCHES;
    for (uint32_t a = 0; a < n; a++) {
        hi[a] = hi[a] < nv ? hi[a] : nv;
        lo[a] = lo[a] < hi[a] ? lo[a] : hi[a];
        for (uint32_t b = a; b > 0 && lo[b - 1] > lo[b]; b--) { /* a handful: by insertion */
            uint64_t tl = lo[b], th = hi[b];
            lo[b] = lo[b - 1], hi[b] = hi[b - 1];
            lo[b - 1] = tl, hi[b - 1] = th;
        }
    }
    for (uint32_t a = 0; a < n; a++) {
        if (lo[a] == hi[a])
            continue;
        stretch *last = j->nkeep ? &j->keep[j->nkeep - 1] : NULL;
        if (last && lo[a] <= last->hi)
            last->hi = hi[a] > last->hi ? hi[a] : last->hi;
        else
            j->keep[j->nkeep++] = (stretch){ .lo = lo[a], .hi = hi[a] };
    }
    int rc = 0;
    for (uint32_t k = 0; k < j->nkeep && rc == 0; k++)
        if ((rc = open_spill(j, &j->keep[k].verts, err)) == 0)
            rc = open_spill(j, &j->keep[k].faces, err);
    if (j->nkeep) {
        j->keep_lo = j->keep[0].lo;
        j->keep_hi = j->keep[j->nkeep - 1].hi;
    }
    return rc;
}

static void close_stretches(sort_job *j)
{
    for (uint32_t k = 0; k < j->nkeep; k++) {
        close_spill(j, &j->keep[k].verts);
        close_spill(j, &j->keep[k].faces);
        en_free(j->keep[k].used);
        j->keep[k].used = NULL;
    }
    j->nkeep = 0;
    j->kept = 0;
}

/* Pass 3: the vertex records of ranks [first, first + n), in j->vbuf, that
 * a stretch holds. */
static int keep_vertices(sort_job *j, uint64_t first, size_t n, epsnet_error *err)
{
    uint64_t end = first + n;
    if (!j->nkeep || end <= j->keep_lo || first >= j->keep_hi)
        return 0;
    int rc = 0;
    for (uint32_t k = 0; k < j->nkeep && rc == 0; k++) {
        uint64_t a = first > j->keep[k].lo ? first : j->keep[k].lo;
        uint64_t b = end < j->keep[k].hi ? end : j->keep[k].hi;
        if (a < b)
            rc = en_spill_write(j->keep[k].verts, vrec_at(j, (size_t)(a - first)), (size_t)(b - a) * j->vrec, err);
    }
    return rc;
}

/* The stretches a face (its corners' ranks, the largest last) has a corner
 * in, as bits (keep_face writes it to each). */
_Static_assert(EN_SORT_MAX_STRETCHES <= 8, "a face's stretches are the bits of a byte");
static uint8_t face_stretches(const sort_job *j, const uint64_t r[3], uint64_t last)
{
    if (last < j->keep_lo || min3(r) >= j->keep_hi)
        return 0;
    uint8_t bits = 0;
    for (uint32_t k = 0; k < j->nkeep; k++)
        for (int c = 0; c < 3; c++)
            bits |= (uint8_t)((r[c] >= j->keep[k].lo && r[c] < j->keep[k].hi) << k);
    return bits;
}

/* Pass 5: a face (its corners' ranks) to every stretch of bits, those it
 * has a corner in (face_stretches). */
static int keep_face(sort_job *j, const uint64_t r[3], uint8_t bits, epsnet_error *err)
{
    int rc = 0;
    for (uint32_t k = 0; bits && k < j->nkeep && rc == 0; k++)
        if (bits >> k & 1)
            rc = en_spill_write(j->keep[k].faces, r, 3 * sizeof *r, err);
    return rc;
}

/* After pass 5: the stretches' files to be read (stretch_window). */
static int stretches_read_back(sort_job *j, epsnet_error *err)
{
    int rc = 0;
    for (uint32_t k = 0; k < j->nkeep && rc == 0; k++)
        if ((rc = en_spill_rewind(j->keep[k].verts, err)) == 0)
            rc = en_spill_rewind(j->keep[k].faces, err);
    j->kept = rc == 0 && j->nkeep > 0;
    return rc;
}

/* ---- windows of the sorted stream (en_sort_window) ----
 * note: a window is pushed as pass 6 would stream it: each used vertex in
 * rank order, after it the faces whose last corner it is, and each vertex's
 * finalization after the last of the window's faces that uses it. A
 * consumer that cuts slabs as vertices are finalized (the pricing chain)
 * then holds a few slabs of the window, not all of it: with every vertex
 * first and every finalization last it held the whole window, and the
 * pricing of a sorted 20M-face PLY peaked 50 MB over its thinning
 * (bench/RESULTS.md, session 27). The same records come from the whole
 * path's arrays and from a kept stretch. */
#define W_USED 1                 /* a face uses it: the stream has it */
#define W_CUT 2                  /* a face with a corner outside the window uses it */
#define W_DONE 4                 /* finalized */

typedef struct window_walk {
    uint64_t lo, hi, base;
    en_stage *into;              /* NULL: counts only */
    uint8_t *flags;              /* W_* by rank - lo */
    uint32_t *loc;               /* rank - lo -> its number in the window, UINT32_MAX not in it */
    uint32_t *last;              /* rank - lo -> the last corner - lo of its last window face; UINT32_MAX none */
    uint64_t used;
    /* a kept stretch's window faces, by last corner, 3 corners - lo each */
    uint32_t *start;             /* by last corner - lo: counts, then where each group ends */
    uint32_t *faces;
    size_t nfaces;
    uint64_t *bits;              /* stretch_used's, one a rank - lo */
} window_walk;

static int window_open(sort_job *j, window_walk *w, uint64_t lo, uint64_t hi, uint64_t base, en_stage *into,
                       epsnet_error *err)
{
    size_t n = (size_t)(hi - lo);
    *w = (window_walk){ .lo = lo, .hi = hi, .base = base, .into = into };
    w->flags = en_calloc(n ? n : 1, 1);
    w->loc = en_malloc((n ? n : 1) * sizeof *w->loc);
    w->last = en_malloc((n ? n : 1) * sizeof *w->last);
    if (!w->flags || !w->loc || !w->last)
        return nomem(j, err);
    for (size_t r = 0; r < n; r++)
        w->last[r] = UINT32_MAX;
    return 0;
}

static void window_close(window_walk *w)
{
    en_free(w->flags);
    en_free(w->loc);
    en_free(w->last);
    en_free(w->start);
    en_free(w->faces);
}

/* Are all of a face's corners in the window? */
static int window_has(const window_walk *w, const uint64_t *c)
{
    return c[0] >= w->lo && c[0] < w->hi && c[1] >= w->lo && c[1] < w->hi && c[2] >= w->lo && c[2] < w->hi;
}

/* A window face's last corner - lo. */
static uint32_t window_last(const window_walk *w, const uint64_t *c)
{
    return (uint32_t)(max3(c) - w->lo);
}

/* A face of the stream (its corners' ranks) with a corner in the window:
 * what it says of its corners. */
static void window_saw(window_walk *w, const uint64_t c[3])
{
    int all = window_has(w, c);
    uint32_t last = all ? window_last(w, c) : 0;
    for (int k = 0; k < 3; k++) {
        if (c[k] < w->lo || c[k] >= w->hi)
            continue;
        w->flags[c[k] - w->lo] |= all ? W_USED : W_USED | W_CUT;
        uint32_t *l = &w->last[c[k] - w->lo];
        if (all && (*l == UINT32_MAX || *l < last))
            *l = last;
    }
}

/* Vertex rank lo + r; xyz and attr its record. */
static int window_vertex(window_walk *w, size_t r, const double xyz[3], const uint8_t *attr, epsnet_error *err)
{
    w->loc[r] = UINT32_MAX;
    if (!(w->flags[r] & W_USED))
        return 0; /* no face uses it: the stream drops it */
    w->loc[r] = (uint32_t)w->used++;
    if (!w->into)
        return 0;
    epsnet_record v = { .kind = EPSNET_REC_VERTEX, .attr = attr };
    memcpy(v.xyz, xyz, sizeof v.xyz);
    int rc = en_stage_put(w->into, &v, err);
    if (rc || w->last[r] != UINT32_MAX)
        return rc;
    w->flags[r] |= W_DONE; /* none of the window's faces uses it */
    return en_stage_put(w->into, &(epsnet_record){ .kind = EPSNET_REC_FINALIZE, .v = { w->base + w->loc[r] } }, err);
}

static int window_face(window_walk *w, const uint32_t c[3], epsnet_error *err)
{
    epsnet_record f = { .kind = EPSNET_REC_TRIANGLE };
    for (int k = 0; k < 3; k++)
        f.v[k] = w->base + w->loc[c[k]];
    return w->into ? en_stage_put(w->into, &f, err) : 0;
}

/* After the faces of last corner lo + r: the finalizations of a face's
 * corners whose last window face that was. */
static int window_face_done(window_walk *w, size_t r, const uint32_t c[3], epsnet_error *err)
{
    int rc = 0;
    for (int k = 0; k < 3 && rc == 0; k++) {
        if (w->last[c[k]] != r || (w->flags[c[k]] & W_DONE))
            continue;
        w->flags[c[k]] |= W_DONE;
        if (w->into)
            rc = en_stage_put(w->into, &(epsnet_record){ .kind = EPSNET_REC_FINALIZE, .v = { w->base + w->loc[c[k]] } },
                              err);
    }
    return rc;
}

static void window_end(const window_walk *w, uint64_t *pushed, uint64_t *cut)
{
    for (uint64_t r = 0; cut && r < w->hi - w->lo; r++)
        *cut += (w->flags[r] & W_CUT) != 0;
    *pushed += w->used;
}

/* Read a kept stretch's faces from the start, calling fn on each; @return
 * 0 or a negative code. */
static int stretch_faces(sort_job *j, const stretch *s, void (*fn)(window_walk *, const uint64_t *), window_walk *w,
                         epsnet_error *err)
{
    int rc = en_spill_rewind(s->faces, err);
    while (rc == 0) {
        int64_t got = en_spill_read(s->faces, j->fbuf, BATCH * 3 * sizeof *j->fbuf, err);
        if (got <= 0)
            return (int)got;
        if (got % (int64_t)(3 * sizeof *j->fbuf))
            return internal(j, "a kept stretch's faces are cut short", err);
        for (size_t i = 0; i < (size_t)got / (3 * sizeof *j->fbuf); i++)
            fn(w, j->fbuf + 3 * i);
    }
    return rc;
}

/* First read: the corners' flags and last faces, and how many window
 * faces each last corner has. */
static void stretch_count(window_walk *w, const uint64_t *c)
{
    window_saw(w, c);
    if (window_has(w, c)) {
        w->start[window_last(w, c) + 1]++;
        w->nfaces++;
    }
}

/* Second read: each window face to its place, in file order (input
 * order: sorter F's order among equal last corners) within its group. */
static void stretch_place(window_walk *w, const uint64_t *c)
{
    if (!window_has(w, c))
        return;
    uint32_t *f = w->faces + 3 * (size_t)w->start[window_last(w, c)]++;
    for (int k = 0; k < 3; k++)
        f[k] = (uint32_t)(c[k] - w->lo);
}

static void stretch_mark_used(window_walk *w, const uint64_t *c)
{
    for (int k = 0; k < 3; k++)
        if (c[k] >= w->lo && c[k] < w->hi)
            w->bits[(c[k] - w->lo) >> 6] |= (uint64_t)1 << ((c[k] - w->lo) & 63);
}

/* The vertices of ranks [lo, hi) that a face uses, of stretch s: what a
 * window's walk pushes, its count alone (windows.c asks five of them for
 * each window). note: from a bit a rank, made by one read of the
 * stretch's faces and kept: each count read the whole file again, and
 * those reads were a third of the calling thread's pricing of a shuffled
 * 20M-face PLY (bench/RESULTS.md, session 39). */
static int stretch_used(sort_job *j, stretch *s, uint64_t lo, uint64_t hi, uint64_t *pushed, epsnet_error *err)
{
    if (!s->used) {
        size_t words = (size_t)((s->hi - s->lo + 63) / 64);
        window_walk w = { .lo = s->lo, .hi = s->hi };
        if (!(w.bits = en_calloc(words ? words : 1, sizeof *w.bits)))
            return nomem(j, err);
        int rc = stretch_faces(j, s, stretch_mark_used, &w, err);
        if (rc) {
            en_free(w.bits);
            return rc;
        }
        s->used = w.bits;
    }
    for (uint64_t r = lo; r < hi; r++)
        *pushed += s->used[(r - s->lo) >> 6] >> ((r - s->lo) & 63) & 1;
    return 0;
}

/* en_sort_window() from a kept stretch. A face with a corner in the
 * window is in the stretch's file, so "used" and "on a face left out" are
 * known from it alone; the window's faces are placed by last corner in a
 * second read of the file (12 bytes a face beside the pricing chain). */
static int stretch_window(sort_job *j, uint64_t lo, uint64_t hi, uint64_t base, en_stage *into, uint64_t *pushed,
                          uint64_t *cut, epsnet_error *err)
{
    stretch *s = NULL;
    for (uint32_t k = 0; k < j->nkeep; k++)
        if (lo >= j->keep[k].lo && hi <= j->keep[k].hi)
            s = &j->keep[k];
    if (!s || hi - lo >= UINT32_MAX)
        return en_error_set(err, EPSNET_EFORMAT, j->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "sort: ranks %llu to %llu were not kept for a window", (unsigned long long)lo,
                            (unsigned long long)hi);
    if (hi <= lo)
        return 0;
    if (!into && !cut)
        return stretch_used(j, s, lo, hi, pushed, err);
    size_t n = (size_t)(hi - lo);
    window_walk w;
    int rc = window_open(j, &w, lo, hi, base, into, err);
    if (rc == 0 && !(w.start = en_calloc(n + 1, sizeof *w.start)))
        rc = nomem(j, err);
    if (rc == 0)
        rc = stretch_faces(j, s, stretch_count, &w, err);
    if (rc == 0 && into) {
        for (size_t r = 0; r < n; r++)
            w.start[r + 1] += w.start[r];
        if (w.nfaces && !(w.faces = en_malloc(3 * w.nfaces * sizeof *w.faces)))
            rc = nomem(j, err);
        else
            rc = stretch_faces(j, s, stretch_place, &w, err); /* start[r]: the end of r's group */
    }
    if (rc == 0 && into)
        rc = en_spill_rewind(s->verts, err);
    size_t f = 0;
    for (uint64_t r = s->lo; r < hi && rc == 0;) {
        size_t want = hi - r < BATCH ? (size_t)(hi - r) : BATCH;
        if (!into) { /* counts: the flags say who is used */
            for (size_t b = 0; b < want; b++, r++)
                if (r >= lo)
                    w.used += (w.flags[r - lo] & W_USED) != 0;
            continue;
        }
        int64_t got = en_spill_read(s->verts, j->vbuf, want * j->vrec, err);
        if (got < 0) {
            rc = (int)got;
            break;
        }
        if (got != (int64_t)(want * j->vrec)) {
            rc = internal(j, "a kept stretch's vertices are cut short", err);
            break;
        }
        for (size_t b = 0; b < want && rc == 0; b++, r++) {
            if (r < lo)
                continue;
            double p[3];
            vrec_get(j, b, p);
            size_t l = (size_t)(r - lo), g = f;
            rc = window_vertex(&w, l, p, j->asz ? vrec_attr(j, b) : NULL, err);
            for (; f < w.start[l] && rc == 0; f++)
                rc = window_face(&w, w.faces + 3 * f, err);
            for (; g < w.start[l] && rc == 0; g++)
                rc = window_face_done(&w, l, w.faces + 3 * g, err);
        }
    }
    if (rc == 0)
        window_end(&w, pushed, cut);
    window_close(&w);
    return rc;
}

/* Item i of fitems (whole_faces: narrow, the first corner above the key). */
static void fitem_corners(const sort_job *j, uint32_t i, uint64_t c[3])
{
    const uint64_t *it = j->fitems + 2 * (size_t)i;
    c[0] = (uint32_t)(it[0] >> 32), c[1] = (uint32_t)it[1], c[2] = (uint32_t)(it[1] >> 32);
}

/* en_sort_window() from the whole path's arrays: the faces by last corner
 * (fitems, fend), and last_of for the faces after hi. */
static int whole_window(en_sort *j, uint64_t lo, uint64_t hi, uint64_t base, en_stage *into, uint64_t *pushed,
                        uint64_t *cut, epsnet_error *err)
{
    if (hi <= lo)
        return 0;
    window_walk w;
    int rc = window_open(j, &w, lo, hi, base, into, err);
    for (uint64_t r = lo; r < hi && rc == 0; r++) {
        if (j->last_of[r] >= hi && j->last_of[r] != UINT32_MAX)
            w.flags[r - lo] |= W_USED | W_CUT; /* a face after hi uses it */
        for (uint32_t i = r ? j->fend[r - 1] : 0; i < j->fend[r]; i++) {
            uint64_t c[3];
            fitem_corners(j, i, c);
            window_saw(&w, c);
        }
    }
    for (uint64_t r = lo; r < hi && rc == 0; r++) {
        size_t l = (size_t)(r - lo);
        rc = window_vertex(&w, l, j->sxyz + 3 * r, j->asz ? j->sattr + r * j->asz : NULL, err);
        for (int pass = 0; pass < 2; pass++)
            for (uint32_t i = r ? j->fend[r - 1] : 0; i < j->fend[r] && rc == 0; i++) {
                uint64_t c[3];
                fitem_corners(j, i, c);
                if (c[0] < lo || c[1] < lo || c[2] < lo)
                    continue; /* its last corner is r: the others are below hi */
                uint32_t t[3] = { (uint32_t)(c[0] - lo), (uint32_t)(c[1] - lo), (uint32_t)(c[2] - lo) };
                rc = pass == 0 ? window_face(&w, t, err) : window_face_done(&w, l, t, err);
            }
    }
    if (rc == 0)
        window_end(&w, pushed, cut);
    window_close(&w);
    return rc;
}

/* ---- pass 1: read ---- */

/* A vertex's coordinates as the stream will carry them: a float32 input's
 * rounded to float here, once, as its .smz would hold them, so that every
 * pass sorts and every record gives the values written (and the spills
 * hold them in 4 bytes: vrec_put). */
static int read_xyz(sort_job *j, const double in[3], double out[3], epsnet_error *err)
{
    for (int k = 0; k < 3; k++) {
        if (j->cbytes == sizeof(double)) {
            out[k] = in[k];
            continue;
        }
        float f = (float)in[k];
        if (isfinite(in[k]) && !isfinite(f))
            return en_error_set(err, EPSNET_EUNSUPPORTED, j->in_path ? j->in_path : j->owner, EPSNET_POS_NONE,
                                EPSNET_POS_NONE, "vertex %llu: coordinate %g does not fit in float32",
                                (unsigned long long)j->st.vertices, in[k]);
        out[k] = f;
    }
    return 0;
}

static int pass_read(sort_job *j, epsnet_error *err)
{
    int rc;
    for (int k = 0; k < 3; k++) {
        j->lo[k] = INFINITY;
        j->hi[k] = -INFINITY;
    }
    size_t nb = 0, nf = 0;
    uint64_t n = 0;
    const epsnet_record *batch;
    size_t count;
    /* note: straight from the reader's queue, not copied out record by
     * record (docs/architecture.md §10) */
    while ((rc = en_reader_next_batch(j->r, &batch, &count, err)) > 0) {
        for (size_t b = 0; b < count; b++) {
            const epsnet_record *rec = &batch[b];
            if ((++n & PROGRESS_EVERY) == 0 &&
                (rc = progress(j, epsnet_reader_bytes_read(j->r), epsnet_reader_file_size(j->r), err)))
                return rc;
            if (rec->kind == EPSNET_REC_VERTEX) {
                for (int k = 0; k < 3; k++) {
                    if (rec->xyz[k] < j->lo[k])
                        j->lo[k] = rec->xyz[k];
                    if (rec->xyz[k] > j->hi[k])
                        j->hi[k] = rec->xyz[k];
                }
                j->st.vertices++;
                double p[3];
                if ((rc = read_xyz(j, rec->xyz, p, err)))
                    return rc;
                if (j->whole) {
                    if ((rc = whole_vertex(j, p, rec->attr, err)) < 0)
                        return rc;
                    if (rc == 0)
                        continue;
                    nb = 0; /* no longer whole: the vertex goes to the spill */
                }
                vrec_put(j, nb, p, rec->attr);
                if (++nb == BATCH) {
                    if ((rc = en_spill_write(j->vraw, j->vbuf, nb * j->vrec, err)))
                        return rc;
                    nb = 0;
                }
            } else if (rec->kind == EPSNET_REC_TRIANGLE) {
                j->st.faces++;
                if (j->whole) {
                    if ((rc = whole_face(j, rec->v, err)) < 0)
                        return rc;
                    if (rc == 0)
                        continue;
                    nf = 0;
                }
                if (j->fwide_from == UINT64_MAX && (rec->v[0] >= UINT32_MAX || rec->v[1] >= UINT32_MAX ||
                                                    rec->v[2] >= UINT32_MAX || en_fault_hit(&wide_fault))) {
                    /* past 2^32 vertices: the faces before it stay 3 x 4 bytes */
                    if (nf && (rc = put_faces(j, nf, err)))
                        return rc;
                    nf = 0;
                    j->fwide_from = j->st.faces - 1;
                }
                memcpy(j->fbuf + 3 * nf, rec->v, sizeof rec->v);
                if (++nf == BATCH) {
                    if ((rc = put_faces(j, nf, err)))
                        return rc;
                    nf = 0;
                }
            }
        }
    }
    if (rc < 0)
        return rc;
    if (j->whole)
        return 0;
    if ((nb && (rc = en_spill_write(j->vraw, j->vbuf, nb * j->vrec, err))) ||
        (nf && (rc = put_faces(j, nf, err))) ||
        (rc = en_spill_rewind(j->fraw, err)))
        return rc;
    return en_spill_rewind(j->vraw, err);
}

/* Read exactly want faces, faces first.. of j->fraw, into buf (3 old ids
 * each): those before fwide_from were written in 3 x 4 bytes (put_faces). */
static int read_faces(const sort_job *j, uint64_t *buf, uint64_t first, size_t want, epsnet_error *err)
{
    uint64_t before = first < j->fwide_from ? j->fwide_from - first : 0;
    size_t narrow = before < want ? (size_t)before : want;
    uint8_t *b = (uint8_t *)buf;
    size_t nbytes = narrow * 3 * sizeof(uint32_t), wbytes = (want - narrow) * 3 * sizeof *buf;
    /* at face first's offset, not where the last read ended: pass 5 in
     * core reads batches on two workers side by side */
    uint64_t at = first < j->fwide_from ? first * 3 * sizeof(uint32_t)
                                        : j->fwide_from * 3 * sizeof(uint32_t) + (first - j->fwide_from) * 3 * sizeof *buf;
    int64_t got = nbytes ? en_spill_read_at(j->fraw, b, nbytes, at, err) : 0, wgot = 0;
    if (got >= 0 && wbytes)
        wgot = en_spill_read_at(j->fraw, buf + 3 * narrow, wbytes, at + nbytes, err);
    if (got < 0 || wgot < 0)
        return (int)(got < 0 ? got : wgot);
    if ((size_t)got != nbytes || (size_t)wgot != wbytes)
        return en_error_set(err, EPSNET_EINTERNAL, j->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "temporary face file is short");
    /* widened in place from the last: 8 i >= 4 i, and the ids above i are read */
    for (size_t i = 3 * narrow; i-- > 0;) {
        uint32_t y;
        memcpy(&y, b + 4 * i, sizeof y);
        uint64_t x = y;
        memcpy(b + 8 * i, &x, sizeof x);
    }
    return 0;
}

/* Read exactly want vertex records from sp into buf. */
static int read_vertices_into(sort_job *j, en_spill *sp, uint8_t *buf, size_t want, epsnet_error *err)
{
    int64_t got = en_spill_read(sp, buf, want * j->vrec, err);
    if (got < 0)
        return (int)got;
    if ((size_t)got != want * j->vrec)
        return en_error_set(err, EPSNET_EINTERNAL, j->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "temporary vertex file is short");
    return 0;
}

/* Read exactly want vertex records from sp into j->vbuf. */
static int read_vertices(sort_job *j, en_spill *sp, size_t want, epsnet_error *err)
{
    return read_vertices_into(j, sp, j->vbuf, want, err);
}

static int fill_job(void *arg)
{
    item_fill *f = arg;
    int rc = 0;
    f->n = 0;
    while (f->n < FEED_ITEMS && (rc = en_extsort_next(f->sorter, f->buf + f->n * f->words, &f->err)) > 0)
        f->n++;
    return rc < 0 ? rc : 0;
}

static int feed_submit(sort_job *j, item_feed *fd, int which, epsnet_error *err)
{
    if (en_jobring_submit(fd->ring, fill_job, &fd->fill[which]))
        return internal(j, "the worker refused a block of faces", err);
    fd->busy = 1;
    return 0;
}

/* A thread that cannot start leaves the merge to this one (fills then run
 * inline, through the same code). */
static int feed_open(sort_job *j, item_feed *fd, en_extsort *sorter, size_t words, epsnet_error *err)
{
    en_pool *pool = sort_pool(j);
    if (!pool) {
        int rc = en_pool_new(&fd->pool, sort_workers(j) > 1 ? 1 : 0);
        if (rc && rc != EPSNET_ENOMEM)
            rc = en_pool_new(&fd->pool, 0);
        if (rc)
            return nomem(j, err);
        pool = fd->pool;
    }
    if (en_jobring_new(&fd->ring, pool, 1))
        return nomem(j, err);
    for (int b = 0; b < 2; b++) {
        fd->fill[b] = (item_fill){ .sorter = sorter, .words = words };
        if (!(fd->fill[b].buf = en_malloc(FEED_ITEMS * words * sizeof(uint64_t))))
            return nomem(j, err);
    }
    fd->bytes = 2 * FEED_ITEMS * words * sizeof(uint64_t);
    en_mem_take(&j->mem, fd->bytes);
    fd->cur = 1; /* an empty block, whose successor is in flight */
    fd->pos = 0;
    return feed_submit(j, fd, 0, err);
}

/* Move to the block in flight, and start the next one after it unless the
 * sorter is drained. @return 1, 0 at the end, or < 0. */
static int feed_advance(sort_job *j, item_feed *fd, epsnet_error *err)
{
    if (!fd->busy)
        return 0;
    void *job;
    int rc;
    en_jobring_retire(fd->ring, &job, &rc);
    fd->busy = 0;
    fd->cur = 1 - fd->cur;
    fd->pos = 0;
    const item_fill *f = &fd->fill[fd->cur];
    if (rc) {
        if (err)
            *err = f->err;
        return rc;
    }
    if (f->n == FEED_ITEMS && (rc = feed_submit(j, fd, 1 - fd->cur, err)))
        return rc;
    return f->n > 0;
}

/* The next item of the feed's sorter, or NULL at the end or on failure (*rc < 0);
 * *rc is 1 when it moved to the next block. */
static const uint64_t *feed_peek(sort_job *j, item_feed *fd, int *rc, epsnet_error *err)
{
    *rc = 0;
    if (fd->pos == fd->fill[fd->cur].n && (*rc = feed_advance(j, fd, err)) <= 0)
        return NULL;
    const item_fill *f = &fd->fill[fd->cur];
    return f->buf + fd->pos * f->words;
}

static void feed_close(sort_job *j, item_feed *fd)
{
    if (fd->busy) {
        void *job;
        int rc;
        en_jobring_retire(fd->ring, &job, &rc);
        fd->busy = 0;
    }
    en_jobring_free(&fd->ring, NULL);
    en_pool_free(&fd->pool);
    for (int b = 0; b < 2; b++) {
        en_free(fd->fill[b].buf);
        fd->fill[b].buf = NULL;
    }
    en_mem_give(&j->mem, fd->bytes);
    fd->bytes = 0;
}

/* ---- pass 2: order the vertices along the axis ---- */

static int pass_order(sort_job *j, epsnet_error *err)
{
    int a = j->axis, o1 = (a + 1) % 3, o2 = (a + 2) % 3;
    uint64_t nv = j->st.vertices;
    /* note: a batch's items made here and added in one call: an add a
     * vertex was a fifth of this pass on the calling thread (bench/
     * RESULTS.md, session 39) */
    size_t words = vert_words(j) + j->aw;
    uint64_t *items = en_malloc(BATCH * words * sizeof *items);
    if (!items)
        return nomem(j, err);
    int rc = 0;
    for (uint64_t v = 0; v < nv && rc == 0;) {
        size_t n = nv - v < BATCH ? (size_t)(nv - v) : BATCH;
        if ((rc = read_vertices(j, j->vraw, n, err)))
            break;
        for (size_t i = 0; i < n; i++) {
            double p[3];
            vrec_get(j, i, p);
            uint64_t *item = items + i * words;
            item[0] = order_key(p[a]);
            item[1] = v + i;
            if (j->cbytes == sizeof(float)) {
                item[2] = fbits2((float)p[o1], (float)p[o2]); /* three words, not four */
            } else {
                item[2] = dbits(p[o1]);
                item[3] = dbits(p[o2]);
            }
            if (j->asz) {
                item[words - 1] = 0; /* the attributes' last word, whole */
                memcpy(item + vert_words(j), vrec_attr(j, i), j->asz);
            }
        }
        v += n;
        if ((rc = en_extsort_add_many(j->verts, items, n, err)) == 0)
            rc = progress(j, v, nv, err);
    }
    en_free(items);
    if (rc)
        return rc;
    close_spill(j, &j->vraw);
    return en_extsort_finish(j->verts, err);
}

/* ---- pass 3: ranks ---- */

/* rank_of[ids[i]] = first + i: random writes on a shuffled input, started
 * PREFETCH ahead so that their misses overlap (pass_faces_in_core). */
static void rank_batch(sort_job *j, const uint32_t *ids, size_t n, uint64_t first)
{
    for (size_t i = 0; i < n; i++) {
        if (i + PREFETCH < n)
            __builtin_prefetch(&j->rank_of[ids[i + PREFETCH]], 1);
        j->rank_of[ids[i]] = (uint32_t)(first + i);
    }
}

static int pass_rank(sort_job *j, epsnet_error *err)
{
    int a = j->axis, o1 = (a + 1) % 3, o2 = (a + 2) % 3;
    const uint64_t *item;
    uint32_t ids[BATCH];         /* in core: the batch's old ids, ranked at the flush */
    size_t nb = 0;
    uint64_t rank = 0;
    int rc = feed_open(j, &j->feed, j->verts, vert_words(j) + j->aw, err);
    while (rc == 0 && (item = feed_peek(j, &j->feed, &rc, err))) {
        rc = 0; /* 1: the peek moved to the next block */
        j->feed.pos++;
        double p[3];
        p[a] = order_value(item[0]);
        if (j->cbytes == sizeof(float)) {
            float f[2];
            memcpy(f, &item[2], sizeof f);
            p[o1] = f[0];
            p[o2] = f[1];
        } else {
            p[o1] = bitsd(item[2]);
            p[o2] = bitsd(item[3]);
        }
        vrec_put(j, nb, p, (const uint8_t *)(item + vert_words(j)));
        uint64_t m[2] = { item[1], rank++ };
        if (j->in_core)
            ids[nb] = (uint32_t)item[1];
        else if ((rc = en_extsort_add(j->map, m, err)))
            return rc;
        if (++nb == BATCH) {
            if (j->in_core)
                rank_batch(j, ids, nb, rank - nb);
            if ((rc = en_spill_write(j->vsorted, j->vbuf, nb * j->vrec, err)) ||
                (rc = keep_vertices(j, rank - nb, nb, err)) ||
                (rc = progress(j, rank, j->st.vertices, err)))
                return rc;
            nb = 0;
        }
    }
    feed_close(j, &j->feed); /* before the sorter: a fill in flight uses it */
    if (rc < 0)
        return rc;
    if (nb && j->in_core)
        rank_batch(j, ids, nb, rank - nb);
    if (nb && ((rc = en_spill_write(j->vsorted, j->vbuf, nb * j->vrec, err)) ||
               (rc = keep_vertices(j, rank - nb, nb, err))))
        return rc;
    close_sorter(j, &j->verts);
    if ((rc = en_spill_rewind(j->vsorted, err)))
        return rc;
    return en_extsort_finish(j->map, err);
}

/* ---- pass 4: corners get ranks ---- */

static int internal(const sort_job *j, const char *what, epsnet_error *err)
{
    return en_error_set(err, EPSNET_EINTERNAL, j->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "sort: %s", what);
}

static int pass_relabel(sort_job *j, epsnet_error *err)
{
    int rc;
    uint64_t nfaces = j->st.faces;
    for (uint64_t f = 0; f < nfaces;) {
        size_t n = nfaces - f < BATCH ? (size_t)(nfaces - f) : BATCH;
        if ((rc = read_faces(j, j->fbuf, f, n, err)))
            return rc;
        for (size_t i = 0; i < n; i++, f++)
            for (uint64_t s = 0; s < 3; s++) {
                uint64_t item[2] = { j->fbuf[3 * i + s], f << 2 | s };
                if ((rc = en_extsort_add(j->corners, item, err)))
                    return rc;
            }
    }
    close_spill(j, &j->fraw);
    if ((rc = en_extsort_finish(j->corners, err)))
        return rc;
    uint64_t c[2], m[2] = { NONE, NONE }, done = 0, total = 3 * j->st.faces;
    int have = 0;
    while ((rc = en_extsort_next(j->corners, c, err)) > 0) {
        while (!have || m[0] < c[0]) {
            if ((rc = en_extsort_next(j->map, m, err)) < 0)
                return rc;
            if (rc == 0)
                return internal(j, "a corner names a vertex without a rank", err);
            have = 1;
        }
        if (m[0] != c[0])
            return internal(j, "a corner names a vertex without a rank", err);
        uint64_t out[2] = { c[1], m[1] };
        if ((rc = en_extsort_add(j->joined, out, err)))
            return rc;
        if ((++done & PROGRESS_EVERY) == 0 && (rc = progress(j, done, total, err)))
            return rc;
    }
    if (rc < 0)
        return rc;
    close_sorter(j, &j->corners);
    close_sorter(j, &j->map);
    return en_extsort_finish(j->joined, err);
}

/* ---- pass 5: whole faces, and last uses ---- */

/* A face into sorter F (and the stretches kept for windows). */
static int add_face_item(sort_job *j, const uint64_t r[3], uint64_t last, epsnet_error *err)
{
    int rc = j->nkeep ? keep_face(j, r, face_stretches(j, r, last), err) : 0;
    if (rc)
        return rc;
    /* note: a face's id is not kept: it only breaks ties on the last
     * corner, which the stable sort does by itself (faces are added in
     * input order); with ranks below 2^32 the corners share words, and
     * the first corner rides in the key word above the key mask, as in
     * whole_faces. */
    uint64_t face[4] = { last, r[0], r[1], r[2] };
    if (j->narrow) {
        face[0] = last | r[0] << 32;
        face[1] = r[1] | r[2] << 32;
    }
    return en_extsort_add(j->faces, face, err);
}

/* A face into sorter F, and its last corner as a last use of each corner
 * into sorter LU (the external path; in core relabel_run keeps last_of). */
static int add_face(sort_job *j, const uint64_t r[3], epsnet_error *err)
{
    uint64_t last = max3(r);
    int rc = add_face_item(j, r, last, err);
    for (int s = 0; s < 3 && rc == 0; s++) {
        uint64_t use[2] = { r[s], last };
        rc = en_extsort_add(j->lastuse, use, err);
    }
    return rc;
}

/* Pass 5 in core, one batch of faces: read from the input order,
 * relabelled through rank_of, its last uses kept in last_of, its faces
 * made sorter F's items and each one's kept stretches found, on a worker
 * while the calling thread adds the batch before to sorter F
 * (pass_faces_in_core). The job touches only j->fraw, its own buffers and
 * last_of, which nothing else writes then, and reads rank_of and the
 * stretches' bounds. */
typedef struct relabel_job {
    sort_job *j;
    uint64_t *fb;                /* 3 n corners, then n items of 2 words: the worker writes them while in flight */
    uint8_t *kept;               /* with stretches kept: per face, bit k when it has a corner in stretch k (worker) */
    uint64_t first;              /* the first face's index */
    size_t n;
    epsnet_error err;            /* the worker's, read after retire */
} relabel_job;

static int relabel_run(void *arg)
{
    relabel_job *b = arg;
    sort_job *j = b->j;
    int rc = read_faces(j, b->fb, b->first, b->n, &b->err);
    if (rc)
        return rc;
    /* note: on a shuffled input rank_of is read at random, one cache miss
     * per corner; asking for it PREFETCH faces ahead lets the misses
     * overlap instead of following one another. */
    uint64_t *fb = b->fb;
    for (size_t i = 0; i < 3 * b->n; i++) {
        if (i + 3 * PREFETCH < 3 * b->n)
            __builtin_prefetch(&j->rank_of[fb[i + 3 * PREFETCH]]);
        fb[i] = j->rank_of[fb[i]];
    }
    /* note: the last uses too, here and not on the calling thread: a
     * largest last corner does not depend on the order faces come in (the
     * random writes were a fifth of pass 5 on the calling thread, session
     * 37), and two batches are in flight, so each is raised by an atomic
     * compare-and-swap (only where it grows); and sorter F's items, in
     * place (item i's two words are written after face i's three were
     * read, and below the faces read ahead: 2i + 1 < 3i from i = 1 on), so
     * that the calling thread adds the batch in one copy (add_face_item's
     * items) */
    uint32_t *last_of = j->last_of;
    for (size_t i = 0; i < b->n; i++) {
        if (i + PREFETCH < b->n)
            for (int s = 0; s < 3; s++)
                __builtin_prefetch(&last_of[fb[3 * (i + PREFETCH) + (size_t)s]], 1);
        uint64_t c[3] = { fb[3 * i], fb[3 * i + 1], fb[3 * i + 2] }, last = max3(c);
        for (int s = 0; s < 3; s++) {
            uint32_t *l = &last_of[c[s]], was = __atomic_load_n(l, __ATOMIC_RELAXED);
            while ((was == UINT32_MAX || was < last) &&
                   !__atomic_compare_exchange_n(l, &was, (uint32_t)last, 1, __ATOMIC_RELAXED, __ATOMIC_RELAXED))
                ;
        }
        if (b->kept)
            b->kept[i] = face_stretches(j, c, last);
        fb[2 * i] = last | c[0] << 32;
        fb[2 * i + 1] = c[1] | c[2] << 32;
    }
    return 0;
}

/* Start the next batch of faces into b: on ring's worker, or here when
 * there is none (then it is done on return). @return 0, or what the
 * batch met (in b->err). */
static int relabel_start(en_jobring *ring, relabel_job *b, uint64_t *next, uint64_t nf)
{
    b->n = nf - *next < BATCH ? (size_t)(nf - *next) : BATCH;
    b->first = *next;
    *next += b->n;
    if (ring && en_jobring_submit(ring, relabel_run, b) == 0)
        return 0;
    return relabel_run(b);
}

/* Start batches *started, ... up to batch upto in jobs[k % (RELABEL_AHEAD
 * + 1)], as far as ring has room. @return 0, or what a batch run here met
 * (*failed: that batch). */
static int relabel_ahead(en_jobring *ring, relabel_job *jobs, size_t *started, size_t upto, uint64_t *next,
                         uint64_t nf, const relabel_job **failed)
{
    while (*next < nf && *started <= upto && !(ring && en_jobring_full(ring))) {
        relabel_job *s = &jobs[(*started)++ % (RELABEL_AHEAD + 1)];
        int rc = relabel_start(ring, s, next, nf);
        if (rc) {
            *failed = s;
            return rc;
        }
    }
    return 0;
}

/* In core: the faces straight from the input order, relabelled through
 * rank_of; last uses go to last_of. note: the read, the relabelling and
 * the last uses of batches k + 1 and k + 2 (the random reads of rank_of
 * and writes of last_of: on a shuffled 20M-face PLY they were most of this
 * pass on the calling thread) run on the workers while this thread adds
 * batch k to sorter F (with one batch ahead, the pass kept two cores 56-71%
 * busy, session 38); the batches are added in order, so the sorter sees
 * the same items in the same order for any thread count. */
static int pass_faces_in_core(sort_job *j, epsnet_error *err)
{
    for (uint64_t v = 0; v < j->st.vertices; v++)
        j->last_of[v] = UINT32_MAX;
    relabel_job jobs[RELABEL_AHEAD + 1] = { { .j = j, .fb = j->fbuf } };
    en_jobring *ring = NULL;
    en_pool *pool = sort_pool(j);
    int rc = pool && en_jobring_new(&ring, pool, RELABEL_AHEAD) ? EPSNET_ENOMEM : 0;
    for (int k = 1; k <= RELABEL_AHEAD; k++) {
        jobs[k].j = j;
        if (rc == 0 && !(jobs[k].fb = en_malloc(BATCH * 3 * sizeof *jobs[k].fb)))
            rc = EPSNET_ENOMEM;
    }
    /* note: which stretches each face goes to, found by the workers: on the
     * calling thread that test of every face took three times the adds to
     * sorter F (bench/RESULTS.md, session 39) */
    for (int k = 0; k <= RELABEL_AHEAD && j->nkeep; k++)
        if (rc == 0 && !(jobs[k].kept = en_malloc(BATCH)))
            rc = EPSNET_ENOMEM;
    if (rc) {
        en_jobring_free(&ring, NULL);
        for (int k = 0; k <= RELABEL_AHEAD; k++) {
            if (k)
                en_free(jobs[k].fb);
            en_free(jobs[k].kept);
        }
        return nomem(j, err);
    }
    uint64_t nf = j->st.faces, next = 0, f = 0;
    /* batch k in jobs[k % (RELABEL_AHEAD + 1)]; while batch cur is added,
     * the RELABEL_AHEAD after it run (the ring retires in order) */
    size_t started = 0;
    const relabel_job *failed = NULL;
    rc = relabel_ahead(ring, jobs, &started, RELABEL_AHEAD - 1, &next, nf, &failed);
    for (size_t cur = 0; f < nf && rc == 0; cur++) {
        relabel_job *b = &jobs[cur % (RELABEL_AHEAD + 1)];
        void *job;
        if (ring && en_jobring_retire(ring, &job, &rc) == 1 && rc) {
            failed = b;
            break;
        }
        if ((rc = relabel_ahead(ring, jobs, &started, cur + RELABEL_AHEAD, &next, nf, &failed)) != 0)
            break;
        const uint64_t *it = b->fb; /* sorter F's items now (relabel_run) */
        for (size_t i = 0; i < b->n && rc == 0 && b->kept; i++) {
            if (!b->kept[i])
                continue;
            uint64_t r[3] = { it[2 * i] >> 32, it[2 * i + 1] & UINT32_MAX, it[2 * i + 1] >> 32 };
            rc = keep_face(j, r, b->kept[i], err);
        }
        if (rc == 0)
            rc = en_extsort_add_many(j->faces, it, b->n, err);
        f += b->n;
        if (rc == 0)
            rc = progress(j, f, nf, err);
    }
    en_jobring_free(&ring, NULL); /* waits for the batches still in flight */
    for (int k = 0; k <= RELABEL_AHEAD; k++) {
        if (k)
            en_free(jobs[k].fb);
        en_free(jobs[k].kept);
    }
    if (failed && err)
        *err = failed->err;
    if (rc)
        return rc;
    close_spill(j, &j->fraw);
    en_free(j->rank_of);
    j->rank_of = NULL;
    en_mem_give(&j->mem, j->st.vertices * sizeof(uint32_t));
    j->arrays_bytes -= j->st.vertices * sizeof(uint32_t);
    return en_extsort_finish(j->faces, err);
}

static int pass_faces(sort_job *j, epsnet_error *err)
{
    uint64_t c[3][2];
    int rc;
    for (uint64_t f = 0; f < j->st.faces; f++) {
        for (int s = 0; s < 3; s++) {
            rc = en_extsort_next(j->joined, c[s], err);
            if (rc < 0)
                return rc;
            if (rc == 0 || c[s][0] != (f << 2 | (uint64_t)s))
                return internal(j, "face corners out of step", err);
        }
        uint64_t r[3] = { c[0][1], c[1][1], c[2][1] };
        if ((rc = add_face(j, r, err)))
            return rc;
        if ((f & PROGRESS_EVERY) == 0 && (rc = progress(j, f, j->st.faces, err)))
            return rc;
    }
    close_sorter(j, &j->joined);
    if ((rc = en_extsort_finish(j->faces, err)))
        return rc;
    return en_extsort_finish(j->lastuse, err);
}

/* ---- pass 6: the output stream ---- */

static int over_budget(sort_job *j, epsnet_error *err)
{
    uint64_t bytes = live_bytes(&j->live) + (uint64_t)j->group_cap * 5 * sizeof(uint64_t);
    if (j->mem.used + bytes > j->mem.peak)
        j->mem.peak = j->mem.used + bytes;
    if (bytes <= j->set.mem / 2)
        return 0;
    return en_error_set(err, EPSNET_ELIMIT, j->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "the sorted stream keeps %llu vertices live at once (%llu bytes), over half of the "
                        "memory budget of %llu bytes; raise --mem",
                        (unsigned long long)j->live.count, (unsigned long long)bytes,
                        (unsigned long long)j->set.mem);
}

/* Largest "last corner" among the faces that use rank, or NONE. */
static int last_use_of(sort_job *j, uint64_t rank, uint64_t *last, epsnet_error *err)
{
    *last = NONE;
    if (j->in_core) {
        if (j->last_of[rank] != UINT32_MAX)
            *last = j->last_of[rank];
        return 0;
    }
    int rc;
    const uint64_t *u;
    while ((u = en_extsort_peek(j->lastuse, &rc, err)) && u[0] == rank) {
        if (*last == NONE || u[1] > *last)
            *last = u[1];
        uint64_t skip[2];
        if ((rc = en_extsort_next(j->lastuse, skip, err)) < 0)
            return rc;
    }
    if (rc < 0)
        return rc;
    if (u && u[0] < rank)
        return internal(j, "last uses out of order", err);
    return 0;
}

static int put_record(sort_job *j, epsnet_record_kind kind, uint64_t a, uint64_t b, uint64_t c,
                      epsnet_error *err)
{
    epsnet_record rec = { .kind = kind, .v = { a, b, c } }, *p = &rec;
    return j->emit(j->emit_opaque, &p, NULL, 1, err);
}

/* note: the records are those of the stream in the input's coordinate
 * type, as a .smz of it would give them back: a float32 input's values were
 * rounded (or refused) in pass 1 (read_xyz), so that a consumer fed
 * directly sees what it would read from the sorted file. */
static int emit_vertex(sort_job *j, const double xyz[3], const uint8_t *attr, epsnet_error *err)
{
    epsnet_record rec = { .kind = EPSNET_REC_VERTEX, .attr = j->asz ? attr : NULL };
    memcpy(rec.xyz, xyz, sizeof rec.xyz);
    epsnet_record *p = &rec;
    return j->emit(j->emit_opaque, &p, NULL, 1, err);
}

/* Write the faces whose last corner is rank, finalizing each vertex after
 * the last of them that uses it (if this is its last group). */
static int emit_group(sort_job *j, uint64_t rank, size_t n, epsnet_error *err)
{
    for (size_t i = n; i-- > 0;)
        for (int s = 0; s < 3; s++) {
            live_slot *v = live_find(&j->live, j->group[5 * i + 2 + (size_t)s]);
            if (!v)
                return internal(j, "a face uses a vertex that is not live", err);
            if (v->last == rank && v->fin_face == NONE)
                v->fin_face = i;
        }
    int rc;
    for (size_t i = 0; i < n; i++) {
        const uint64_t *f = j->group + 5 * i + 2;
        live_slot *v[3];
        for (int s = 0; s < 3; s++)
            v[s] = live_find(&j->live, f[s]);
        if ((rc = put_record(j, EPSNET_REC_TRIANGLE, v[0]->id, v[1]->id, v[2]->id, err)))
            return rc;
        for (int s = 0; s < 3; s++) {
            if ((s > 0 && f[s] == f[0]) || (s > 1 && f[s] == f[1]))
                continue;
            live_slot *x = live_find(&j->live, f[s]);
            if (x->fin_face != i)
                continue;
            if ((rc = put_record(j, EPSNET_REC_FINALIZE, x->id, 0, 0, err)))
                return rc;
            live_remove(&j->live, x);
        }
    }
    return 0;
}


/* ---- pass 6 in blocks of ranks (emit_block.h) ----
 * note: with the last uses in memory, each block of EMIT_RANKS ranks is built
 * into records by a job on any worker and handed on in rank order, so the
 * calling thread only reads the block's vertices and faces and passes the
 * records on (docs/architecture.md §13, "Pass 6 in blocks"). Blocks in
 * flight: two a worker, one without workers (then each runs inline). */
#define EMIT_BLOCKS_MAX 8
#define EMIT_RANKS 1024          /* a block's ranks: a multiple of 64 (en_rank_ids_fill) */

typedef struct emit_blocks {
    en_pool *own;                /* a pool of no threads when the sort has none */
    en_jobring *ring;
    en_emit_block b[EMIT_BLOCKS_MAX];
    uint8_t *vbuf[EMIT_BLOCKS_MAX]; /* external path: the block's vertex records */
    uint64_t *items[EMIT_BLOCKS_MAX]; /* external path: its faces, 2 words each */
    size_t items_cap[EMIT_BLOCKS_MAX];
    size_t n;                    /* blocks */
    size_t submitted, retired;
    en_rank_ids ids;
    int64_t live;                /* vertices handed on less those finalized */
    uint64_t held[EMIT_BLOCKS_MAX]; /* a block's records, table and faces, as last accounted */
    uint64_t bytes;              /* accounted in all */
} emit_blocks;

/* Account block i's bytes again: only once it is retired, when no job
 * writes it (its records grow on the worker). */
static void blocks_account(emit_blocks *e, sort_job *j, size_t i)
{
    uint64_t now = en_emit_block_bytes(&e->b[i]) + e->items_cap[i] * 2 * sizeof(uint64_t);
    if (now > e->held[i])
        en_mem_take(&j->mem, now - e->held[i]);
    else
        en_mem_give(&j->mem, e->held[i] - now);
    e->bytes += now - e->held[i];
    e->held[i] = now;
}

/* Hand on the oldest block's records. */
static int blocks_retire(sort_job *j, emit_blocks *e, int hand_on, epsnet_error *err)
{
    void *job;
    int rc;
    en_jobring_retire(e->ring, &job, &rc);
    en_emit_block *b = job;
    e->retired++;
    if (rc == EPSNET_ENOMEM)
        return nomem(j, err);
    if (rc)
        return internal(j, "a face of pass 6 is not in its block", err);
    if (!hand_on)
        return 0;
    if ((uint64_t)(e->live + b->live_peak) > j->st.max_width)
        j->st.max_width = (uint64_t)(e->live + b->live_peak);
    e->live += b->live_delta;
    blocks_account(e, j, (size_t)(b - e->b));
    /* the consumer may keep the array and leave another: a copy fewer */
    return b->nrecs ? j->emit(j->emit_opaque, &b->recs, &b->recs_cap, b->nrecs, err) : 0;
}

static void blocks_close(sort_job *j, emit_blocks *e)
{
    while (e->ring && e->retired < e->submitted)
        blocks_retire(j, e, 0, NULL);
    en_jobring_free(&e->ring, NULL);
    en_pool_free(&e->own);
    for (size_t i = 0; i < e->n; i++) {
        en_emit_block_free(&e->b[i]);
        en_free(e->vbuf[i]);
        en_free(e->items[i]);
    }
    en_rank_ids_free(&e->ids);
    en_mem_give(&j->mem, e->bytes);
}

static int blocks_open(sort_job *j, emit_blocks *e, int external, epsnet_error *err)
{
    memset(e, 0, sizeof *e);
    en_pool *pool = sort_pool(j);
    if (!pool && en_pool_new(&e->own, 0))
        return nomem(j, err);
    pool = pool ? pool : e->own;
    long w = en_pool_threads(pool);
    e->n = w < 1 ? 1 : 2 * (size_t)w > EMIT_BLOCKS_MAX ? EMIT_BLOCKS_MAX : 2 * (size_t)w;
    if (en_jobring_new(&e->ring, pool, e->n) || en_rank_ids_init(&e->ids, j->st.vertices))
        return nomem(j, err);
    for (size_t i = 0; i < e->n; i++) {
        e->b[i].last_of = j->last_of;
        e->b[i].ids = &e->ids;
        if (external && !(e->vbuf[i] = en_malloc(EMIT_RANKS * j->vrec)))
            return nomem(j, err);
    }
    e->bytes = en_rank_ids_bytes(j->st.vertices) + (external ? e->n * EMIT_RANKS * j->vrec : 0);
    en_mem_take(&j->mem, e->bytes);
    return 0;
}

/* The external path's faces of ranks below end, from sorter F, into the
 * block's own buffer. */
static int blocks_items(sort_job *j, emit_blocks *e, size_t i, uint64_t end, epsnet_error *err)
{
    en_emit_block *b = &e->b[i];
    size_t n = 0;
    const uint64_t *f;
    int rc;
    while ((f = feed_peek(j, &j->feed, &rc, err)) && (f[0] & UINT32_MAX) < end) {
        const item_fill *fill = &j->feed.fill[j->feed.cur];
        size_t k = 0, avail = fill->n - j->feed.pos;
        while (k < avail && (f[2 * k] & UINT32_MAX) < end)
            k++;
        if (en_grow((void **)&e->items[i], &e->items_cap[i], n + k, 2 * sizeof(uint64_t)))
            return nomem(j, err);
        memcpy(e->items[i] + 2 * n, f, k * 2 * sizeof *f);
        n += k;
        j->feed.pos += k;
    }
    if (rc < 0)
        return rc;
    b->items = e->items[i];
    b->nitems = n;
    return 0;
}

/*
 * Pass 6 when the last uses are in memory (last_of): the whole path's
 * arrays (vertices and faces by rank), or the external path's spill of
 * vertices in rank order and sorter F's merge. The records are those of
 * the live map's walk below (emit_group), in the same order.
 */
static int emit_blocks_run(sort_job *j, int external, epsnet_error *err)
{
    uint64_t nv = j->st.vertices;
    emit_blocks e;
    int rc = blocks_open(j, &e, external, err);
    if (rc == 0 && external)
        rc = feed_open(j, &j->feed, j->faces, j->narrow ? 2 : 4, err);
    for (uint64_t rank = 0; rc == 0 && rank < nv;) {
        size_t nb = nv - rank < EMIT_RANKS ? (size_t)(nv - rank) : EMIT_RANKS, i = e.submitted % e.n;
        if (e.submitted - e.retired == e.n && (rc = blocks_retire(j, &e, 1, err)))
            break;
        en_emit_block *b = &e.b[i];
        b->rank0 = rank;
        b->nranks = nb;
        j->st.unreferenced += en_rank_ids_fill(&e.ids, j->last_of, rank, nb);
        if (external) {
            if ((rc = read_vertices_into(j, j->vsorted, e.vbuf[i], nb, err)) ||
                (rc = blocks_items(j, &e, i, rank + nb, err)))
                break;
            b->xyz = e.vbuf[i];
            b->xyz_stride = j->vrec;
            b->xyz_float = j->cbytes == sizeof(float);
            b->attr = j->asz ? e.vbuf[i] + 3 * j->cbytes : NULL;
            b->attr_stride = j->vrec;
        } else {
            uint64_t start = rank ? j->fend[rank - 1] : 0, end = j->fend[rank + nb - 1];
            b->items = j->fitems + 2 * start;
            b->nitems = (size_t)(end - start);
            b->xyz = (const uint8_t *)(j->sxyz + 3 * rank);
            b->xyz_stride = 3 * sizeof(double);
            b->xyz_float = 0;
            b->attr = j->asz ? j->sattr + rank * j->asz : NULL;
            b->attr_stride = j->asz;
        }
        if (en_jobring_submit(e.ring, en_emit_block_run, b)) {
            rc = internal(j, "the worker refused a block of pass 6", err);
            break;
        }
        e.submitted++;
        rank += nb;
        rc = progress(j, rank, nv, err);
    }
    while (rc == 0 && e.retired < e.submitted)
        rc = blocks_retire(j, &e, 1, err);
    if (rc == 0 && e.live)
        rc = internal(j, "vertices left live at the end", err);
    blocks_close(j, &e);
    return rc;
}

/* Pass 6: in blocks when the last uses are in memory, else through the
 * live map, as wide as the stream, with sorter LU's last uses. */
static int pass_emit(sort_job *j, epsnet_error *err)
{
    if (j->whole || (j->in_core && j->narrow))
        return emit_blocks_run(j, !j->whole, err);
    uint64_t nv = j->st.vertices, next_id = 0;
    int rc = feed_open(j, &j->feed, j->faces, j->narrow ? 2 : 4, err);
    if (rc)
        return rc;
    for (uint64_t rank = 0; rank < nv;) {
        size_t nb = nv - rank < BATCH ? (size_t)(nv - rank) : BATCH;
        if ((rc = read_vertices(j, j->vsorted, nb, err)))
            return rc;
        for (size_t b = 0; b < nb; b++, rank++) {
            uint64_t last;
            if ((rc = last_use_of(j, rank, &last, err)))
                return rc;
            if (last == NONE) {
                j->st.unreferenced++;
                continue;
            }
            double p[3];
            vrec_get(j, b, p);
            if ((rc = emit_vertex(j, p, vrec_attr(j, b), err)))
                return rc;
            if (live_add(&j->live, rank, next_id++, last))
                return nomem(j, err);
            if (j->live.count > j->st.max_width)
                j->st.max_width = j->live.count;
            size_t n = 0;
            const uint64_t *f;
            while ((f = feed_peek(j, &j->feed, &rc, err)) && (j->narrow ? f[0] & UINT32_MAX : f[0]) == rank) {
                if (n == j->group_cap && en_grow((void **)&j->group, &j->group_cap, n + 1, 5 * sizeof *j->group))
                    return nomem(j, err);
                const uint64_t *it = f;
                uint64_t *g = j->group + 5 * n;
                j->feed.pos++;
                g[0] = rank;
                g[1] = 0;
                if (j->narrow) {
                    g[2] = it[0] >> 32;
                    g[3] = it[1] & UINT32_MAX;
                    g[4] = it[1] >> 32;
                } else {
                    memcpy(g + 2, it + 1, 3 * sizeof *g);
                }
                n++;
            }
            if (rc < 0 || (rc = over_budget(j, err)))
                return rc;
            if (n && (rc = emit_group(j, rank, n, err)))
                return rc;
        }
        if ((rc = progress(j, rank, nv, err)))
            return rc;
    }
    if (j->live.count)
        return internal(j, "vertices left live at the end", err);
    return 0;
}

/* ---- driver ---- */

static char *dir_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        return en_strdup(".");
    size_t n = slash == path ? 1 : (size_t)(slash - path);
    char *d = en_malloc(n + 1);
    if (d) {
        memcpy(d, path, n);
        d[n] = '\0';
    }
    return d;
}

/* The sort's own workers when it was given none (sort_pool: the read
 * ahead, the whole path's pieces, passes 5 and 6; an external sorter
 * given no pool forms its runs on a thread of its own), and the whole
 * path's ring: as epsnet_settings.threads (0 = all
 * cores, 1 = this thread). A thread that cannot start leaves the work to
 * this one: the output does not depend on it. */
static int start_pool(sort_job *j, epsnet_error *err)
{
    long n = sort_workers(j);
    j->chunks = 1;
    if (n <= 1)
        return 0;
    int rc = j->shared ? 0 : en_pool_new(&j->pool, (int)n);
    if (rc == 0 && en_jobring_new(&j->ring, sort_pool(j), (size_t)n)) {
        en_pool_free(&j->pool);
        rc = EPSNET_ENOMEM;
    }
    if (rc == EPSNET_ENOMEM)
        return nomem(j, err);
    if (rc == 0)
        j->chunks = (size_t)n;
    return 0;
}

static int open_job(sort_job *j, epsnet_error *err)
{
    j->tmpdir = j->set.tmpdir ? en_strdup(j->set.tmpdir) : dir_of(j->owner);
    j->fbuf = en_malloc(BATCH * 3 * sizeof *j->fbuf);
    if (!j->tmpdir || !j->fbuf)
        return nomem(j, err);
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    /* note: a streaming input's live set is the reader's memory; the budget
     * bounds it (docs/architecture.md §12: a stream that never finalizes hits the budget). */
    rs.mem_limit = j->set.mem;
    int rc = j->r ? 0 : epsnet_reader_open(&j->r, j->in_path, &rs, err); /* en_sort_open_reader: open */
    if (rc)
        return rc;
    /* note: only what the consumer can hold is sorted; the rest is named
     * in the reader's one warning line (docs/architecture.md §5). */
    const en_format *out = NULL;
    if (j->keep_attrs & EN_SORT_KEEP_FORMAT)
        out = j->set.format ? en_format_by_name(j->set.format) : en_format_by_path(j->owner);
    /* KEEP_ALL: every attribute (a lock property the output may not hold) */
    en_reader_keep_attrs(j->r, out, (j->keep_attrs & EN_SORT_KEEP_ALL) != 0,
                         (j->keep_attrs & EN_SORT_DROP_NORMALS) != 0);
    j->attrs = epsnet_reader_info(j->r)->vertex_attrs;
    j->asz = j->attrs.size;
    j->aw = (j->asz + 7) / 8;
    j->ct = epsnet_reader_info(j->r)->coord_type;
    j->cbytes = j->ct == EPSNET_COORD_FLOAT32 ? sizeof(float) : sizeof(double);
    j->vrec = 3 * j->cbytes + j->asz;
    j->fwide_from = UINT64_MAX;
    j->vbuf = en_malloc(BATCH * j->vrec);
    if (!j->vbuf)
        return nomem(j, err);
    const epsnet_mesh_info *in = epsnet_reader_info(j->r);
    int counted = in->nverts != EPSNET_COUNT_UNKNOWN && in->nfaces != EPSNET_COUNT_UNKNOWN;
    /* note: a header that announces too much for memory sends the read to
     * the spills at once, rather than after filling half of the budget */
    j->whole = counted ? whole_fits(j, in->nverts, in->nfaces) : whole_fits(j, 0, 0);
    if (j->whole && counted) {
        /* note: the header's counts are only a hint; growth still checks */
        j->xyz = en_malloc(in->nverts ? (size_t)in->nverts * 3 * sizeof *j->xyz : 1);
        j->tri = en_malloc(in->nfaces ? (size_t)in->nfaces * 3 * sizeof *j->tri : 1);
        j->attr = j->asz ? en_malloc(in->nverts ? (size_t)in->nverts * j->asz : 1) : NULL;
        if (!j->xyz || !j->tri || (j->asz && !j->attr))
            return nomem(j, err);
        j->xyz_cap = (size_t)in->nverts;
        j->tri_cap = (size_t)in->nfaces;
        j->whole_bytes = (24 + j->asz) * in->nverts + 12 * in->nfaces;
        en_mem_take(&j->mem, j->whole_bytes);
    }
    /* the pool of the read ahead, the whole path and passes 5 and 6 */
    if ((rc = start_pool(j, err)))
        return rc;
    if ((rc = open_spill(j, &j->vraw, err)) || (rc = open_spill(j, &j->fraw, err)) ||
        (rc = open_spill(j, &j->vsorted, err)) ||
        (rc = open_sorter(j, &j->corners, 2, 0, err)) ||
        (rc = open_sorter(j, &j->verts, vert_words(j) + j->aw, 0, err)) ||
        (rc = open_sorter(j, &j->map, 2, 0, err)) || (rc = open_sorter(j, &j->joined, 2, 0, err)) ||
        (rc = open_sorter(j, &j->lastuse, 2, 0, err)))
        return rc;
    return 0;
}

static void close_job(sort_job *j)
{
    feed_close(j, &j->feed); /* first: a fill in flight uses sorter F */
    epsnet_reader_close(&j->r);
    en_face_names_copy_free(&j->materials);
    en_face_names_copy_free(&j->groups);
    close_spill(j, &j->vraw);
    close_spill(j, &j->vsorted);
    close_spill(j, &j->fraw);
    close_stretches(j);
    close_sorter(j, &j->corners);
    close_sorter(j, &j->verts);
    close_sorter(j, &j->map);
    close_sorter(j, &j->joined);
    close_sorter(j, &j->faces);
    close_sorter(j, &j->lastuse);
    en_free(j->live.slots);
    en_free(j->group);
    en_free(j->vbuf);
    en_free(j->fbuf);
    en_free(j->rank_of);
    en_free(j->last_of);
    en_free(j->xyz);
    en_free(j->tri);
    en_free(j->attr);
    en_free(j->sattr);
    en_free(j->sxyz);
    en_free(j->fend);
    en_free(j->fitems);
    en_jobring_free(&j->ring, NULL);
    en_pool_free(&j->pool);
    en_mem_give(&j->mem, j->arrays_bytes);
    en_free(j->tmpdir);
}

/*
 * note: when two 32-bit arrays over the vertices fit in half of the
 * budget, ranks and last uses are looked up in memory instead of joined
 * externally (passes 4 and the L sorter of sort.h): the same output, a
 * third of the temporary traffic. Past that, the external join keeps
 * memory at O(mem) whatever the mesh.
 */
static int choose_relabel(sort_job *j, epsnet_error *err)
{
    uint64_t nv = j->st.vertices;
    j->in_core = nv < UINT32_MAX && 2 * nv * sizeof(uint32_t) <= j->set.mem / 2;
    if (!j->in_core)
        return 0;
    j->rank_of = en_malloc(nv ? nv * sizeof *j->rank_of : 1);
    j->last_of = en_malloc(nv ? nv * sizeof *j->last_of : 1);
    if (!j->rank_of || !j->last_of)
        return nomem(j, err);
    j->arrays_bytes = 2 * nv * sizeof(uint32_t);
    en_mem_take(&j->mem, j->arrays_bytes);
    return 0;
}

/* Passes 1 to 5: everything but the output walk. */
static int run_passes(sort_job *j, epsnet_error *err)
{
    int rc;
    j->phase = 1;
    if ((rc = open_job(j, err)))
        return rc;
    /* the file's bytes are read ahead on a worker while this thread parses
     * them (ENOMEM: it reads them itself) */
    (void)en_reader_use_pool(j->r, sort_pool(j));
    if ((rc = pass_read(j, err)))
        return rc;
    j->st.dropped = en_reader_warn_dropped(j->r, j->set.warning, j->set.warning_opaque);
    const epsnet_mesh_info *ri = epsnet_reader_info(j->r);
    if ((rc = en_face_names_copy_of(&j->materials, ri->materials)) != 0 ||
        (rc = en_face_names_copy_of(&j->groups, ri->groups)) != 0)
        return en_error_set(err, rc, j->owner, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    epsnet_reader_close(&j->r);
    if (j->set.axis < 0)
        j->axis = j->st.vertices ? en_sort_longest_axis(j->lo, j->hi) : 2;
    j->st.axis = j->axis;
    if (j->whole) {
        j->in_core = 1; /* ranks and last uses are arrays */
        j->phase = 2;
        if ((rc = whole_order(j, err)))
            return rc;
        j->phase = 5;
        return whole_faces(j, err);
    }
    j->narrow = j->st.vertices < UINT32_MAX;
    if ((rc = open_sorter(j, &j->faces, j->narrow ? 2 : 4, j->narrow ? UINT32_MAX : 0, err)) ||
        (rc = choose_relabel(j, err)) || (rc = open_stretches(j, err)))
        return rc;
    j->phase = 2;
    if ((rc = pass_order(j, err)))
        return rc;
    j->phase = 3;
    if ((rc = pass_rank(j, err)))
        return rc;
    j->phase = 4;
    if (!j->in_core && (rc = pass_relabel(j, err)))
        return rc;
    j->phase = 5;
    rc = j->in_core ? pass_faces_in_core(j, err) : pass_faces(j, err);
    return rc ? rc : stretches_read_back(j, err);
}

static int sort_open(en_sort **out, epsnet_reader *r, const char *in_path, const char *owner,
                     const epsnet_sort_settings *settings, int keep_attrs, en_sort_stretches_fn stretches,
                     en_pool *pool, epsnet_error *err)
{
    *out = NULL;
    if (!in_path || !owner) {
        epsnet_reader_close(&r);
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "sort: NULL path");
    }
    sort_job *j = en_calloc(1, sizeof *j);
    if (!j) {
        epsnet_reader_close(&r);
        return en_error_set(err, EPSNET_ENOMEM, owner, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    j->r = r; /* closed by close_job, also on the failures below */
    j->t0 = en_now();
    j->in_path = in_path;
    j->owner = owner;
    if (settings)
        j->set = *settings;
    else
        epsnet_sort_default_settings(&j->set);
    if (j->set.axis < -1 || j->set.axis > 2) {
        epsnet_reader_close(&j->r);
        en_free(j);
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "sort axis %d is not -1 (auto), 0, 1 or 2", j->set.axis);
    }
    if (j->set.mem == 0)
        j->set.mem = (uint64_t)512 << 20;
    j->axis = j->set.axis;
    j->keep_attrs = keep_attrs;
    j->stretches = stretches;
    j->shared = pool;
    *out = j;
    return run_passes(j, err);
}

int en_sort_open(en_sort **out, const char *in_path, const char *owner, const epsnet_sort_settings *settings,
                 int keep_attrs, en_sort_stretches_fn stretches, en_pool *pool, epsnet_error *err)
{
    return sort_open(out, NULL, in_path, owner, settings, keep_attrs, stretches, pool, err);
}

int en_sort_open_reader(en_sort **out, epsnet_reader *r, const char *name, const char *owner,
                        const epsnet_sort_settings *settings, int keep_attrs, en_sort_stretches_fn stretches,
                        en_pool *pool, epsnet_error *err)
{
    return sort_open(out, r, name, owner, settings, keep_attrs, stretches, pool, err);
}

void en_sort_info(const en_sort *j, epsnet_mesh_info *info)
{
    memset(info, 0, sizeof *info);
    /* vertices read: those no face uses are dropped as they are emitted,
     * so what comes out is at most this (a bound, for planning) */
    info->nverts = j->st.vertices;
    info->nfaces = j->st.faces;
    info->coord_type = j->ct;
    info->streaming = 1;
    info->sorted_axis = j->axis;
    info->vertex_attrs = j->attrs;
    info->materials = j->materials.of;
    info->groups = j->groups.of;
    /* of every vertex read, a face's or not */
    info->has_bbox = j->st.vertices > 0;
    for (int k = 0; info->has_bbox && k < 3; k++)
        info->bbox_min[k] = j->lo[k], info->bbox_max[k] = j->hi[k];
}

int en_sort_windowed(const en_sort *j, uint64_t *ranks)
{
    *ranks = j->st.vertices;
    return (j->whole && j->sxyz && j->fend && j->fitems && j->last_of) || j->kept;
}

int en_sort_window(en_sort *j, uint64_t lo, uint64_t hi, uint64_t base, en_stage *into, uint64_t *pushed,
                   uint64_t *cut, epsnet_error *err)
{
    return j->whole ? whole_window(j, lo, hi, base, into, pushed, cut, err)
                    : stretch_window(j, lo, hi, base, into, pushed, cut, err);
}

int en_sort_emit(en_sort *j, en_sort_emit_fn emit, void *opaque, epsnet_error *err)
{
    close_stretches(j); /* the windows were walked before */
    j->phase = 6;
    j->emit = emit;
    j->emit_opaque = opaque;
    return pass_emit(j, err);
}

void en_sort_close(en_sort **pj, epsnet_sort_stats *stats)
{
    sort_job *j = *pj;
    if (!j)
        return;
    close_job(j);
    j->st.runs = j->runs;
    j->st.temp_bytes = j->temp_bytes;
    j->st.peak_memory = j->mem.peak;
    j->st.peak_rss = en_peak_rss_bytes();
    j->st.seconds = en_now() - j->t0;
    if (stats)
        *stats = j->st;
    en_free(j);
    *pj = NULL;
}

static int writer_put(void *w, epsnet_record **recs, size_t *cap, size_t n, epsnet_error *err)
{
    (void)cap;
    int rc = 0;
    for (size_t i = 0; i < n && rc == 0; i++)
        rc = epsnet_writer_put(w, &(*recs)[i], err);
    return rc;
}

int epsnet_sort_file(const char *in_path, const char *out_path, const epsnet_sort_settings *settings,
                     epsnet_sort_stats *stats, epsnet_error *err)
{
    if (!in_path || !out_path)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_sort_file: NULL path");
    en_sort *j = NULL;
    epsnet_writer *w = NULL;
    int rc = en_sort_open(&j, in_path, out_path, settings, EN_SORT_KEEP_FORMAT, NULL, NULL, err);
    if (rc == 0) {
        epsnet_writer_settings ws;
        epsnet_writer_default_settings(&ws);
        ws.format = j->set.format;
        ws.tmpdir = j->tmpdir;
        epsnet_mesh_info info;
        en_sort_info(j, &info);
        rc = epsnet_writer_open(&w, out_path, &ws, &info, err);
    }
    /* note: the output's blocks are encoded and compressed on the sort's
     * pool when its format can (a .smz), as a simplify run's are on its
     * pool: on the calling thread they were 60% of `epsnet sort` of a
     * shuffled 20M-face PLY, with the workers a third busy
     * (bench/RESULTS.md, session 38); ENOMEM: it encodes alone */
    if (rc == 0)
        (void)en_writer_use_pool(w, sort_pool(j));
    if (rc == 0)
        rc = en_sort_emit(j, writer_put, w, err);
    if (w)
        (void)en_writer_use_pool(w, NULL); /* before the pool goes; a failure is the writer's, its commit reports it */
    if (rc == 0)
        rc = epsnet_writer_commit(&w, err);
    epsnet_writer_abort(&w);
    if (j)
        en_sort_close(&j, stats);
    else if (stats)
        memset(stats, 0, sizeof *stats);
    return rc;
}
