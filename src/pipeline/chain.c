/*
 * The ε-net passes of the stage chain (docs/architecture.md §7): for
 * each pass a chunker cuts slabs, the pool's workers classify and simplify
 * them through the pass's job ring, and a stitcher takes them back in order,
 * finishes the seams and hands its records to the next pass (paper §5:
 * passes re-sample the previous result under a new rotation), or to `out`.
 *
 * Threads (docs/architecture.md §10): the budget checks and the hand-over
 * of records between passes run on the caller's thread. Three kinds of job
 * run on the workers: en_slab_work_run() on a slab nobody else touches
 * until its ring hands it back, in submission order; each pass's stitcher,
 * one take at a time (stitch_job), so that the seam collapses leave the
 * caller's thread (a pass of one slab takes it on the caller's thread:
 * stitch_submit); and, for a pass whose input is already checked, its
 * chunker, one batch of records at a time, in order (chunk_job), so that
 * the caller only copies records into batches. A take's records and a
 * batch's slabs
 * are buffered in their job and handed on by the caller when it retires the
 * job, in order, so the records, and the bytes, are the same for every
 * thread count.
 */
#include "pipeline/chain.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "common/alloc.h"
#include "common/error.h"
#include "pipeline/chunker.h"
#include "pipeline/stitcher.h"

typedef struct en_pass en_pass;

/*
 * One stitcher take as a pool job. Ownership: the caller's thread fills w
 * and submits; from then until the ring retires the job, only the worker
 * running it touches the job, the pass's stitcher (st) and its record
 * buffer (out); after the retire only the caller's thread does.
 */
typedef struct stitch_job {
    en_pass *p;                    /* caller writes at submit; worker reads */
    en_slab_work *w;               /* caller writes at submit; worker reads; caller recycles after retire */
    epsnet_error err;              /* worker writes on failure; caller reads after retire */
} stitch_job;

/*
 * Records a pass's chunker takes per chunk job: small enough that the
 * budget's view of the chunker (copied at each retire) lags little, large
 * enough that a job's cost dwarfs its submission (docs/architecture.md §10).
 * Up to CHUNK_JOBS batches may wait or run at once: the chunker runs when a
 * worker is free, and while the workers are in long slab jobs the caller
 * reads on into the next batches instead of waiting (measured: with one
 * batch in flight, 20M faces at -j 2 took 38 s instead of 21,
 * bench/RESULTS.md). Slab jobs last about as long as their slab is large,
 * so a pass takes about a slab's records (some 4 per vertex) in batches,
 * at least CHUNK_JOBS_MIN of them (chunk_slots).
 */
#define CHUNK_BATCH 8192
#define CHUNK_JOBS 16
#define CHUNK_JOBS_MIN 4

/*
 * One batch of a pass's input records as a pool job: the chunker takes
 * them, cuts the slabs they complete and, at the pass's end, the last ones.
 * The pass's chunk ring is serial: its jobs run one at a time, in order, so
 * each finds the chunker as the one before left it. Ownership: the
 * caller's thread fills the batch (recs, attr, finish, give) and submits;
 * from then until the ring retires the job only the worker running it
 * touches the job, and the pass's chunker (ch) is touched only by the chunk
 * jobs; after the retire the caller's thread reads the job (cut, err, the
 * copies of the chunker's sizes) and submits the slabs cut, in order. The
 * caller's thread never touches the chunker while the pass is batched.
 */
typedef struct chunk_job {
    en_pass *p;                    /* caller writes at init; worker reads */
    epsnet_record *recs;           /* caller writes before submit; worker reads (attr not used) */
    size_t nrecs, recs_cap;
    uint8_t *attr;                 /* caller: attr_size bytes per vertex record, in order; worker reads */
    size_t nattr, attr_cap;        /* vertex records in the batch; capacity in vertices */
    int finish;                    /* caller: the pass's end, finish the chunker after the records */
    en_slab_work **give;           /* caller: slab works done with; worker hands them to the chunker */
    size_t ngive, give_cap;
    en_slab_work **cut;            /* worker appends the slabs cut; caller submits and clears after retire */
    size_t ncut, cut_cap;
    uint64_t ch_bytes, ch_vertices, ch_faces; /* worker: the chunker's, after the batch; caller reads */
    epsnet_error err;              /* worker writes on failure; caller reads after retire */
} chunk_job;

struct en_pass {
    en_chain *chain;
    int index;
    gauss_sphere g;
    /* Its plan (NULL: the ε-net pass). Under EN_SKELETON_CHOSEN, g is the
     * candidate frequency the next slab is classified at, and level_total
     * the samples of the slabs retired, by level (en_slab_work.level_count). */
    const en_pass_plan *plan;
    uint64_t level_total[EN_LEVELS];
    uint64_t retired_vertices;    /* ... and their vertices (en_pass_plan.skeleton_expected) */
    /* Batched: only the chunk jobs touch it (see chunk_job). */
    en_chunker ch;
    /* batched: the chunker runs as chunk jobs (the pass's input was checked
     * before it: a checked reader, the sort, or the pass before). */
    int batched;
    en_jobring *chunk_ring;        /* nchunk slots, serial, urgent */
    chunk_job *chunk;              /* nchunk, in the ring's order */
    size_t nchunk;                 /* a power of two, CHUNK_JOBS_MIN ... CHUNK_JOBS */
    uint64_t chunk_submitted;      /* caller: chunk[chunk_submitted % nchunk] is filling */
    chunk_job *fill;               /* caller: that one, with room for CHUNK_BATCH records */
    size_t batch_attr_size;        /* caller: a vertex record's bytes in a batch, fixed at init: the
                                    * chunker's attr_size, and the carried block it reads marks from */
    int chunk_failed;              /* chunk jobs only: one failed, the later ones do nothing */
    en_slab_work **returned;       /* caller: slab works done with, for the next batch's give */
    size_t nreturned, returned_cap;
    uint64_t records;              /* records the caller's thread handed to this pass */
    /* What the caller's thread knows of the chunker, for the budget checks:
     * copied from it (not batched) or from the last retired batch. */
    uint64_t ch_bytes, ch_vertices, ch_faces;
    en_jobring *ring;
    en_stitcher st;                /* between submit and retire of job: the worker's (see stitch_job) */
    en_jobring *stitch_ring;       /* one stitcher take in flight at most (simplify mode) */
    stitch_job job;
    epsnet_record *out;            /* records of the take in flight, handed on at its retire */
    size_t nout, out_cap;
    /* What the caller's thread knows of the stitcher, copied at each
     * retire, for the budget checks while a take runs. */
    uint64_t st_bytes, st_active, st_frontier;
    int ended;
    int direct;                    /* the takes put into cfg.out themselves (out_on_workers) */
    int here;                      /* a take runs on the caller's thread (stitch_submit): its
                                    * records go straight on */
    uint64_t in_flight_elements;   /* vertices + faces of slabs in the ring */
    /* A one-slab pass's collapses: its worker writes the counts, the
     * caller's thread reads them while it waits (pass_end) and raises
     * stop to cancel; all relaxed. */
    en_slab_progress progress;
};

struct en_chain {
    en_chain_config cfg;
    en_pass *pass;
    int failed;
    epsnet_error failure;
    en_chain_stats stats;          /* pass-summed counts; seam counts are added at the end */
    uint64_t *cost_hist;           /* a priced plan: the slabs' costs left (EN_COST_BUCKETS), summed at retire */
    uint64_t *level_hist;          /* ... and their samples', by level (en_slab_work.level_hist) */
    uint64_t *taken_hist;          /* a plan with count ranges: the slabs' (en_slab_work.taken_hist),
                                    * summed at retire */
    en_chain_spares own;           /* without cfg.spares */
    en_chain_spares *spares;       /* cfg.spares, or &own */
};

static void destroy_slab_work(void *item)
{
    en_slab_work_free(item);
    en_free(item);
}

int en_chain_spares_new(en_chain_spares *sp)
{
    if (en_ctxpool_new(&sp->slab_works, destroy_slab_work) || en_collapse_arrays_new(&sp->collapse_arrays) ||
        en_slab_scratch_pool_new(&sp->scratch)) {
        en_chain_spares_free(sp);
        return EPSNET_ENOMEM;
    }
    return 0;
}

void en_chain_spares_free(en_chain_spares *sp)
{
    en_ctxpool_free(&sp->slab_works);
    en_ctxpool_free(&sp->collapse_arrays);
    en_ctxpool_free(&sp->scratch);
}

static int pass_put(void *self, const epsnet_record *rec, epsnet_error *err);
static int pass_end(void *self, epsnet_error *err);

/* Where pass p's stitcher sends its records: the next pass, or out. */
static en_stage downstream(en_chain *c, int p)
{
    if (p + 1 < c->cfg.passes)
        return (en_stage){ pass_put, pass_end, &c->pass[p + 1] };
    return c->cfg.out;
}

static void free_work(void *job)
{
    en_slab_work_free(job);
    en_free(job);
}

static void drop_stitch(void *job)
{
    stitch_job *j = job;
    if (j->w)
        free_work(j->w);
    j->w = NULL;
}

/* Copy what the budget checks read of p's chunker; only where it is the
 * caller's (p not batched). */
static void chunker_seen(en_pass *p)
{
    p->ch_bytes = en_chunker_bytes(&p->ch);
    p->ch_vertices = p->ch.map.count;
    p->ch_faces = p->ch.nfaces;
}

/* Before reading the copies: a pass that is not batched has its chunker on
 * this thread at all times, so its copy can be fresh. */
static void chunkers_seen(en_chain *c)
{
    for (int i = 0; i < c->cfg.passes; i++)
        if (!c->pass[i].batched)
            chunker_seen(&c->pass[i]);
}

static void note_active(en_chain *c)
{
    uint64_t total = 0;
    chunkers_seen(c);
    for (int i = 0; i < c->cfg.passes; i++) {
        const en_pass *p = &c->pass[i];
        total += p->ch_vertices + p->ch_faces + p->in_flight_elements + p->st_active;
    }
    if (total > c->stats.max_active)
        c->stats.max_active = total;
}

static int take_samples(en_chain *c, const en_slab_work *w, epsnet_error *err)
{
    for (uint32_t v = 0; v < w->nowned; v++)
        if (w->vclass[v] & EN_C_SAMPLE) {
            int rc = c->cfg.on_sample(c->cfg.sample_opaque, w->s.gid[v], w->s.pos + 3 * (size_t)v, w->vgvertex[v],
                                      err);
            if (rc)
                return rc;
        }
    return 0;
}

/*
 * What the budget bounds beyond the reader's live vertices (docs/
 * architecture.md §12): faces the chunker holds on vertices still open (a
 * stream can repeat a face on three live vertices forever) and output the
 * stitcher holds back (output leaves in input id order, so one vertex used
 * again far later in the stream holds everything after it). Over budget,
 * say which one grew.
 */
static int check_budget(en_chain *c, epsnet_error *err)
{
    uint64_t total = 0, worst = 0;
    const en_pass *wp = NULL;
    int waiting = 0; /* the worst is the chunker's (1) or the stitcher's (0) */
    chunkers_seen(c);
    for (int i = 0; i < c->cfg.passes; i++) {
        const en_pass *p = &c->pass[i];
        uint64_t cut = p->ch_bytes;
        /* a one-slab pass: what the cut will hold, not just the chunker */
        if (p->plan && p->plan->one_slab &&
            cut < p->ch_vertices * (uint64_t)EN_ONE_SLAB_BYTES_PER_VERTEX)
            cut = p->ch_vertices * (uint64_t)EN_ONE_SLAB_BYTES_PER_VERTEX;
        uint64_t held = c->cfg.mode == EN_SLAB_SIMPLIFY ? p->st_bytes : 0;
        total += cut + held;
        if (!wp || cut > worst || held > worst) {
            wp = p;
            waiting = cut >= held;
            worst = waiting ? cut : held;
        }
    }
    if (!c->cfg.mem_budget || total <= c->cfg.mem_budget)
        return 0;
    if (waiting && wp->plan && wp->plan->one_slab)
        return en_error_set(err, EPSNET_ELIMIT, c->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "pass %d holds the whole mesh as one slab to meet its target: %llu vertices so far, "
                            "about %llu bytes in all, over the memory budget of %llu bytes (give more --mem)",
                            wp->index + 1, (unsigned long long)wp->ch_vertices, (unsigned long long)total,
                            (unsigned long long)c->cfg.mem_budget);
    if (waiting)
        return en_error_set(err, EPSNET_ELIMIT, c->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "pass %d: %llu vertices and %llu faces wait for vertices to be finalized (%llu bytes "
                            "in all), over the memory budget of %llu bytes (does the stream finalize its vertices?)",
                            wp->index + 1, (unsigned long long)wp->ch_vertices, (unsigned long long)wp->ch_faces,
                            (unsigned long long)total, (unsigned long long)c->cfg.mem_budget);
    return en_error_set(err, EPSNET_ELIMIT, c->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "pass %d: the output waits for vertex %llu, still open, and holds %llu bytes in all, "
                        "over the memory budget of %llu bytes (is a vertex used again far later in the stream?)",
                        wp->index + 1, (unsigned long long)wp->st_frontier, (unsigned long long)total,
                        (unsigned long long)c->cfg.mem_budget);
}

/* A slab work p is done with goes back to its chunker for a later cut: at
 * once when the chunker is this thread's, else with the next batch. */
static void pass_recycle(en_pass *p, en_slab_work *w)
{
    if (!p->batched) {
        en_chunker_recycle(&p->ch, w);
        return;
    }
    if (en_grow((void **)&p->returned, &p->returned_cap, p->nreturned + 1, sizeof *p->returned)) {
        free_work(w);
        return;
    }
    p->returned[p->nreturned++] = w;
}

/* Is pass p's slab work shared among processes (pipeline/peers.h)? Pass 1
 * of a simplification only (the chain is rank 0's: the other ranks serve
 * slabs, pipeline/slab_server.h); the passes after it and a target's rounds
 * stay here. */
static en_peer_link *shared(const en_pass *p)
{
    const en_chain_config *cfg = &p->chain->cfg;
    return p->index == 0 && cfg->mode == EN_SLAB_SIMPLIFY ? cfg->peers : NULL;
}

/* A slab shipped to another rank keeps its place in the ring with this
 * job; its results come at its retire. */
static int worked_elsewhere(void *job)
{
    (void)job;
    return 0;
}

/* The stitcher's output stage while a take runs (worker's thread): the
 * take's records wait in the job's buffer, or go straight on when the
 * chain's output stage may be called here (en_chain_config.out_on_workers;
 * takes run one at a time, in order, each after the retire of the one
 * before, so the calls are ordered as they would be on one thread). */
static int buffer_put(void *self, const epsnet_record *rec, epsnet_error *err)
{
    en_pass *p = self;
    if (p->direct || p->here) { /* (direct: the last pass, whose downstream is cfg.out) */
        en_stage next = downstream(p->chain, p->index);
        return en_stage_put(&next, rec, err);
    }
    if (en_grow((void **)&p->out, &p->out_cap, p->nout + 1, sizeof *p->out))
        return en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory holding a stitched slab's output");
    /* note: a vertex record's attr points into the stitcher's pool slot;
     * it stays valid until the flush, since slots are freed but not
     * reused or moved until the next take, which starts after it */
    p->out[p->nout++] = *rec;
    return 0;
}

static int buffer_end(void *self, epsnet_error *err)
{
    (void)self;
    (void)err;
    return 0; /* the pass's end ends the next stage (pass_end) */
}

/* The take on a worker (see stitch_job). */
static int stitch_run(void *job)
{
    stitch_job *j = job;
    return en_stitcher_take(&j->p->st, j->w, &j->err);
}

/* Caller's thread, nothing in flight: hand the buffered records on, in order. */
static int flush(en_pass *p, epsnet_error *err)
{
    en_stage next = downstream(p->chain, p->index);
    int rc = 0;
    for (size_t i = 0; i < p->nout && rc == 0; i++)
        rc = en_stage_put(&next, &p->out[i], err);
    p->nout = 0;
    p->st_bytes = en_stitcher_bytes(&p->st) + p->out_cap * sizeof *p->out;
    p->st_active = en_stitcher_active(&p->st);
    p->st_frontier = p->st.frontier;
    return rc;
}

/* Wait for pass p's take in flight, if any, recycle its slab and hand its
 * records on. */
static int stitch_retire(en_pass *p, epsnet_error *err)
{
    void *job;
    int result;
    if (!en_jobring_retire(p->stitch_ring, &job, &result))
        return 0;
    stitch_job *j = job;
    pass_recycle(p, j->w);
    j->w = NULL;
    if (result) {
        *err = j->err;
        return result;
    }
    return flush(p, err);
}

/* Stitch slab w on the pool, after the take before it (one in flight). */
static int stitch_submit(en_pass *p, en_slab_work *w, epsnet_error *err)
{
    int rc = stitch_retire(p, err);
    if (rc) {
        pass_recycle(p, w);
        return rc;
    }
    if (w->index == 0 && w->last) {
        /* note: a pass of one slab (a last round's, an in-core mesh's) has
         * nothing to run beside its take, whose records are the pass's
         * whole output: buffered for the caller, they were 20 MB at the
         * end of `gen bumpy` 20M at 1%, on top of the slab and the writer
         * (bench/RESULTS.md, session 35). The take runs here instead. */
        p->here = 1;
        rc = en_stitcher_take(&p->st, w, err);
        p->here = 0;
        pass_recycle(p, w);
        return rc ? rc : flush(p, err);
    }
    p->job.p = p;
    p->job.w = w;
    memset(&p->job.err, 0, sizeof p->job.err);
    rc = en_jobring_submit(p->stitch_ring, stitch_run, &p->job);
    if (rc) {
        p->job.w = NULL;
        pass_recycle(p, w);
        en_error_set(err, rc, p->chain->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE, "worker pool refused a seam");
    }
    return rc;
}

/* Hand back the oldest slab of pass p and stitch it. */
static int retire_one(en_pass *p, epsnet_error *err)
{
    en_chain *c = p->chain;
    void *job;
    int result;
    if (!en_jobring_retire(p->ring, &job, &result))
        return 0;
    en_slab_work *w = job;
    if (result == 0 && shared(p))
        result = en_peer_recv_slab(shared(p), w, &w->err);
    /* the worker may have dropped membrane faces (slab_work.c) */
    p->in_flight_elements -= (uint64_t)w->s.nv + w->s.nt + w->membrane_faces;
    int rc = result;
    if (rc) {
        *err = w->err;
        snprintf(err->file, sizeof err->file, "%s", c->cfg.path ? c->cfg.path : "");
    }
    if (rc == 0) {
        if (p->index == 0)
            en_classify_counts_add(&c->stats.counts, &w->counts);
        c->stats.collapses += w->collapses;
        c->stats.membrane_faces += w->membrane_faces;
        const en_pass_plan *plan = w->plan;
        if (plan && plan->priced && w->cost_hist && c->cost_hist)
            for (int b = 0; b < EN_COST_BUCKETS; b++)
                c->cost_hist[b] += w->cost_hist[b];
        if (plan && plan->priced && w->has_levels && w->level_hist && c->level_hist)
            for (size_t b = 0; b < (size_t)EN_LEVELS * EN_COST_BUCKETS; b++)
                c->level_hist[b] += w->level_hist[b];
        if (plan && plan->count_nranges && w->taken_hist && c->taken_hist)
            for (int b = 0; b < EN_COST_BUCKETS; b++)
                c->taken_hist[b] += w->taken_hist[b];
        if (plan && !plan->priced) { /* a priced pass's skeleton goes on to the next */
            c->stats.skeleton_kept += w->skeleton_kept;
            c->stats.samples_given_up += w->given_up;
            if (plan->one_slab && plan->seams == EN_SEAMS_NONE)
                c->stats.target_faces += w->keep_faces;
            c->stats.stopped_by_error |= w->stopped_by_error;
        }
        if (plan && plan->skeleton == EN_SKELETON_CHOSEN) {
            for (int k = 0; k < EN_LEVELS; k++)
                p->level_total[k] += w->level_count[k];
            p->retired_vertices += plan->count_nranges ? w->counted_vertices : w->nowned;
            if (plan->one_slab)
                c->stats.skeleton_frequency = w->chosen.n;
        }
        for (int k = 0; k < EN_REFUSE_KINDS; k++)
            c->stats.refused[k] += w->refused[k];
        c->stats.slabs++;
        if (c->cfg.mode == EN_SLAB_SIMPLIFY) {
            /* the stitcher job owns w now, and recycles it */
            rc = stitch_submit(p, w, err);
            return rc ? rc : check_budget(c, err);
        }
        rc = take_samples(c, w, err);
    }
    pass_recycle(p, w);
    if (rc == 0)
        rc = check_budget(c, err);
    return rc;
}

/* A one-slab pass, whose collapses the calling thread reports while it
 * waits for them (en_chain_config.tick). */
static int watched(const en_pass *p)
{
    return p->chain->cfg.tick && p->plan && p->plan->one_slab && p->chain->cfg.mode == EN_SLAB_SIMPLIFY;
}

/* One report of a watched slab: while in flight, or once it is done (all
 * of it). */
static int tick(en_pass *p, int done_now, epsnet_error *err)
{
    const en_chain_config *cfg = &p->chain->cfg;
    uint64_t done = atomic_load_explicit(&p->progress.done, memory_order_relaxed);
    uint64_t total = atomic_load_explicit(&p->progress.total, memory_order_relaxed);
    if (done_now || done > total)
        done = total;
    if (cfg->tick(cfg->tick_opaque, done, total)) {
        /* the slab stops within a thousand collapses, so the chain's end
         * (which waits for it) is not held up by the rest of it */
        atomic_store_explicit(&p->progress.stop, 1, memory_order_relaxed);
        return en_error_set(err, EPSNET_EINTR, cfg->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "cancelled");
    }
    return 0;
}

/* The skeleton's budget for the vertices retired so far: with
 * skeleton_expected, its share of them (en_pass_plan.skeleton_expected). */
static double budget_so_far(const en_pass *p)
{
    double budget = (double)p->plan->skeleton_budget;
    if (p->plan->skeleton_expected)
        budget *= fmin(1.0, (double)p->retired_vertices / (double)p->plan->skeleton_expected);
    return budget;
}

/* The candidate frequency n from here on: the pass's sphere at n, its
 * rotation kept. */
static int set_candidate(en_pass *p, uint32_t n, epsnet_error *err)
{
    gauss_rotation rot = p->g.rot;
    if (gauss_init(&p->g, n, &rot))
        return en_error_set(err, EPSNET_ENOMEM, p->chain->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory");
    return 0;
}

/*
 * EN_SKELETON_CHOSEN on slabs (slab_work.c: nested_density), before slab
 * k = 1, 2, 4, 8, ..., and every CANDIDATE_EVERY slabs from there: with
 * every slab before it retired, the candidate falls to the finest power of
 * two whose samples so far are within the skeleton's budget. A finer one is out for good (counts only grow), so
 * the candidate is never below the frequency the pass ends up choosing.
 * At fixed slabs, after all the slabs before them, so that every -j
 * classifies each slab at the same candidate; a fine candidate costs (a
 * vertex at frequency 128 took 7 times what it takes at 8) and its slabs
 * thin less, so the first checkpoints come early, and the later ones
 * often enough that a large mesh does not keep a candidate for hundreds of
 * slabs after its counts ruled it out (each one waits for the slabs in
 * flight: about a slab's time).
 */
#define CANDIDATE_EVERY 64
static int lower_candidate(en_pass *p, epsnet_error *err)
{
    int rc = 0;
    while (rc == 0 && en_jobring_in_flight(p->ring))
        rc = retire_one(p, err);
    int top = en_level_of(p->g.n);
    int k = en_skeleton_level(p->level_total, top, budget_so_far(p));
    return rc == 0 && k < top ? set_candidate(p, 1u << k, err) : rc;
}

/* The frequency a chosen skeleton ends at (after the pass's end). A
 * pricing pass counts no cut end (seam.h: en_cut_end): its budget is pro
 * rata to the vertices it counted; any other's is the whole budget. */
static uint32_t chosen_frequency(const en_pass *p)
{
    double budget = p->plan->count_nranges ? budget_so_far(p) : (double)p->plan->skeleton_budget;
    return 1u << en_skeleton_level(p->level_total, en_level_of(p->g.n), budget);
}

static int submit(en_pass *p, en_slab_work *w, epsnet_error *err)
{
    en_chain *c = p->chain;
    int checkpoint = p->plan && p->plan->skeleton == EN_SKELETON_CHOSEN && !p->plan->one_slab &&
                     c->cfg.mode == EN_SLAB_SIMPLIFY && w->index > 0 &&
                     (!(w->index & (w->index - 1)) || w->index % CANDIDATE_EVERY == 0);
    if (checkpoint) {
        int rc = lower_candidate(p, err);
        if (rc) {
            free_work(w);
            return rc;
        }
    }
    w->g = &p->g;
    w->mode = c->cfg.mode;
    w->max_normal_dev = c->cfg.max_normal_dev;
    w->collapse_arrays = c->spares->collapse_arrays;
    w->scratch = c->spares->scratch;
    w->quadric_at = c->cfg.quadrics_in ? c->cfg.attr_size : UINT32_MAX;
    w->lock_offset = c->cfg.lock_offset;
    w->lock_type = c->cfg.mode == EN_SLAB_SIMPLIFY ? c->cfg.lock_type : 0;
    w->weights = c->cfg.mode == EN_SLAB_SIMPLIFY ? c->cfg.weights : NULL;
    w->plan = c->cfg.mode == EN_SLAB_SIMPLIFY ? p->plan : NULL;
    if (watched(p))
        w->progress = &p->progress; /* its only slab: the counts start at zero */
    int rc = 0, elsewhere = 0;
    while (rc == 0 && en_jobring_full(p->ring))
        rc = retire_one(p, err);
    /* to another rank with room for it (pipeline/peers.h); the only slab
     * of a pass stays */
    en_peer_link *l = shared(p);
    if (rc == 0 && l && !(w->index == 0 && w->last) && !(p->plan && p->plan->one_slab) && !watched(p)) {
        int rank = 0;
        if ((rc = en_peer_pick(l, &rank, err)) == 0 && rank)
            rc = en_peer_ship(l, rank, w, err);
        elsewhere = rank != 0;
        if (rc) {
            free_work(w);
            return rc;
        }
    }
    if (rc == 0) {
        p->in_flight_elements += (uint64_t)w->s.nv + w->s.nt;
        note_active(c);
        rc = en_jobring_submit(p->ring, elsewhere ? worked_elsewhere : en_slab_work_run, w);
        if (rc) {
            p->in_flight_elements -= (uint64_t)w->s.nv + w->s.nt;
            en_error_set(err, rc, c->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE, "worker pool refused a slab");
            free_work(w);
            return rc;
        }
    } else {
        free_work(w);
        return rc;
    }
    return rc;
}

/* The chunker on a worker (see chunk_job): the batch's records, then, at
 * the end, what the stream left live; the slabs cut wait in the job. */
static int chunk_run(void *job)
{
    chunk_job *j = job;
    en_chunker *ch = &j->p->ch;
    size_t asz = j->p->batch_attr_size, vi = 0; /* the records' bytes (the chunker may keep fewer) */
    int rc = 0;
    for (size_t i = 0; i < j->ngive; i++)
        en_chunker_recycle(ch, j->give[i]);
    j->ngive = 0;
    if (j->p->chunk_failed) /* the caller stops at that one; the chunker is not to be trusted */
        return en_error_set(&j->err, EPSNET_EINTERNAL, ch->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "a batch after a failed one (a bug if reported)");
    for (size_t i = 0; i < j->nrecs || (j->finish && rc == 0); i++) {
        en_slab_work *w = NULL;
        if (i < j->nrecs) {
            epsnet_record rec = j->recs[i];
            rec.attr = NULL;
            if (rec.kind == EPSNET_REC_VERTEX && asz)
                rec.attr = j->attr + vi++ * asz;
            rc = en_chunker_put(ch, &rec, &w, &j->err);
        } else {
            rc = en_chunker_finish(ch, &w, &j->err);
            if (rc == 0 && !w)
                break;
        }
        if (rc)
            break;
        if (w && en_grow((void **)&j->cut, &j->cut_cap, j->ncut + 1, sizeof *j->cut)) {
            free_work(w);
            rc = en_error_set(&j->err, EPSNET_ENOMEM, ch->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                              "out of memory");
            break;
        }
        if (w)
            j->cut[j->ncut++] = w;
    }
    j->ch_bytes = en_chunker_bytes(ch);
    j->ch_vertices = ch->map.count;
    j->ch_faces = ch->nfaces;
    j->p->chunk_failed = rc != 0;
    return rc;
}

/* Wait for pass p's oldest chunk job in flight, if any, and submit the
 * slabs it cut, in order. */
static int chunk_retire(en_pass *p, epsnet_error *err)
{
    void *job;
    int result;
    if (!en_jobring_retire(p->chunk_ring, &job, &result))
        return 0;
    chunk_job *j = job;
    p->ch_bytes = j->ch_bytes;
    p->ch_vertices = j->ch_vertices;
    p->ch_faces = j->ch_faces;
    int rc = result;
    if (rc)
        *err = j->err;
    size_t i = 0;
    for (; i < j->ncut && rc == 0; i++)
        rc = submit(p, j->cut[i], err); /* frees it on failure */
    for (; i < j->ncut; i++)
        free_work(j->cut[i]);
    j->ncut = 0;
    return rc ? rc : check_budget(p->chain, err);
}

/* The next batch to fill, with room for a whole batch made at once, so that
 * batch_put, on the calling thread, only copies.
 * @return 0 or -1 (out of memory). */
static int next_fill(en_pass *p)
{
    chunk_job *j = &p->chunk[p->chunk_submitted % p->nchunk];
    j->nrecs = j->nattr = 0; /* retired (at most nchunk - 1 in flight), or never used */
    p->fill = NULL;
    if (en_grow((void **)&j->recs, &j->recs_cap, CHUNK_BATCH, sizeof *j->recs) ||
        (p->batch_attr_size && en_grow((void **)&j->attr, &j->attr_cap, CHUNK_BATCH, p->batch_attr_size)))
        return -1;
    p->fill = j;
    return 0;
}

/* Hand the batch being filled to the pool, behind those in flight; first
 * retire those done (their slabs go on at once), and the oldest while the
 * slot after this one, the next to fill, is still in flight. */
static int chunk_submit(en_pass *p, int finish, epsnet_error *err)
{
    int rc = 0;
    while (rc == 0 && (en_jobring_in_flight(p->chunk_ring) + 1 >= p->nchunk || en_jobring_ready(p->chunk_ring)))
        rc = chunk_retire(p, err);
    if (rc)
        return rc;
    chunk_job *j = p->fill;
    j->finish = finish;
    memset(&j->err, 0, sizeof j->err);
    /* the slab works returned so far travel with the batch (see chunk_job) */
    en_slab_work **t = j->give;
    size_t tcap = j->give_cap;
    j->give = p->returned, j->give_cap = p->returned_cap, j->ngive = p->nreturned;
    p->returned = t, p->returned_cap = tcap, p->nreturned = 0;
    rc = en_jobring_submit(p->chunk_ring, chunk_run, j);
    if (rc)
        return en_error_set(err, rc, p->chain->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "worker pool refused a batch of records");
    p->chunk_submitted++;
    if (next_fill(p))
        return en_error_set(err, EPSNET_ENOMEM, p->chain->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory");
    return 0;
}

/* A batched pass takes n records: copies into the batch, whole runs at a
 * time (their attribute bytes live only until the producer's next record). */
static int batch_put(en_pass *p, const epsnet_record *recs, size_t n, epsnet_error *err)
{
    size_t asz = p->batch_attr_size;
    int rc = 0;
    while (n > 0 && rc == 0) {
        chunk_job *j = p->fill;
        if (!j)
            return en_error_set(err, EPSNET_ENOMEM, p->chain->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "out of memory");
        size_t k = CHUNK_BATCH - j->nrecs < n ? CHUNK_BATCH - j->nrecs : n;
        memcpy(&j->recs[j->nrecs], recs, k * sizeof *recs);
        for (size_t i = 0; asz && i < k; i++) {
            if (recs[i].kind != EPSNET_REC_VERTEX)
                continue;
            uint8_t *to = j->attr + j->nattr++ * asz;
            if (recs[i].attr)
                memcpy(to, recs[i].attr, asz);
            else
                memset(to, 0, asz);
        }
        j->nrecs += k;
        recs += k;
        n -= k;
        if (j->nrecs >= CHUNK_BATCH)
            rc = chunk_submit(p, 0, err);
    }
    return rc;
}

static int pass_put(void *self, const epsnet_record *rec, epsnet_error *err)
{
    en_pass *p = self;
    p->records++;
    if (p->batched)
        return batch_put(p, rec, 1, err);
    en_slab_work *w = NULL;
    int rc = en_chunker_put(&p->ch, rec, &w, err);
    if (rc == 0 && w)
        rc = submit(p, w, err);
    if (rc == 0 && (p->records & 4095) == 0)
        rc = check_budget(p->chain, err);
    return rc;
}

static int pass_end(void *self, epsnet_error *err)
{
    en_pass *p = self;
    if (p->ended)
        return 0;
    p->ended = 1;
    en_slab_work *w = NULL;
    int rc = 0;
    if (p->batched) {
        rc = chunk_submit(p, 1, err);
        while (rc == 0 && en_jobring_in_flight(p->chunk_ring))
            rc = chunk_retire(p, err);
    } else {
        do {
            rc = en_chunker_finish(&p->ch, &w, err);
            if (rc == 0 && w)
                rc = submit(p, w, err);
        } while (rc == 0 && w);
    }
    while (rc == 0 && en_jobring_in_flight(p->ring))
        /* a tenth of a second at most between reports, and none after the end */
        rc = watched(p) && !en_jobring_wait(p->ring, 0.1) ? tick(p, 0, err) : retire_one(p, err);
    if (rc == 0 && watched(p))
        rc = tick(p, 1, err); /* with one thread, the only report */
    if (rc || p->chain->cfg.mode != EN_SLAB_SIMPLIFY)
        return rc;
    rc = stitch_retire(p, err);
    if (rc == 0)
        rc = en_stitcher_finish(&p->st, err);
    if (rc == 0)
        rc = flush(p, err);
    if (rc == 0) {
        /* the pass is over: what it holds goes before the next stage's end,
         * which may run long (a target's rounds, pipeline/target_stage.h) */
        uint64_t max_active = p->ch.max_active;
        en_chunker_free(&p->ch);
        p->ch.max_active = max_active;
        en_stitcher_release(&p->st);
        for (size_t n = 0; n < p->nreturned; n++)
            en_ctxpool_give(p->chain->spares->slab_works, p->returned[n]);
        p->nreturned = 0;
        en_stage next = downstream(p->chain, p->index);
        rc = en_stage_end(&next, err);
    }
    return rc;
}

static int fail(en_chain *c, int rc, const epsnet_error *err)
{
    if (!c->failed) {
        c->failed = rc;
        c->failure = *err;
    }
    return rc;
}

/* The chain's input counts (faces_in is also the run's progress count,
 * en_chain_faces_in). */
static void count_in(en_chain *c, const epsnet_record *recs, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        c->stats.vertices_in += recs[i].kind == EPSNET_REC_VERTEX;
        c->stats.faces_in += recs[i].kind == EPSNET_REC_TRIANGLE;
    }
}

static int chain_put(void *self, const epsnet_record *rec, epsnet_error *err)
{
    en_chain *c = self;
    if (c->failed) {
        *err = c->failure;
        return c->failed;
    }
    count_in(c, rec, 1);
    int rc = pass_put(&c->pass[0], rec, err);
    return rc ? fail(c, rc, err) : 0;
}

int en_chain_put_many(en_chain *c, const epsnet_record *recs, size_t n, epsnet_error *err)
{
    en_pass *p = &c->pass[0];
    int rc = 0;
    if (!p->batched) {
        for (size_t i = 0; i < n && rc == 0; i++)
            rc = chain_put(c, &recs[i], err);
        return rc;
    }
    if (c->failed) {
        *err = c->failure;
        return c->failed;
    }
    count_in(c, recs, n);
    p->records += n;
    rc = batch_put(p, recs, n, err);
    return rc ? fail(c, rc, err) : 0;
}

int en_chain_put_owned(en_chain *c, epsnet_record **recs, size_t *cap, size_t n, epsnet_error *err)
{
    en_pass *p = &c->pass[0];
    chunk_job *j = p->fill;
    /* with attributes the batch keeps their bytes beside it: copied */
    if (!p->batched || p->batch_attr_size || !j || j->nrecs || c->failed || n == 0)
        return en_chain_put_many(c, *recs, n, err);
    count_in(c, *recs, n);
    p->records += n;
    epsnet_record *t = j->recs;
    size_t tcap = j->recs_cap;
    j->recs = *recs, j->recs_cap = *cap, j->nrecs = n;
    *recs = t, *cap = tcap;
    int rc = chunk_submit(p, 0, err);
    return rc ? fail(c, rc, err) : 0;
}

static int chain_end(void *self, epsnet_error *err)
{
    en_chain *c = self;
    if (c->failed) {
        *err = c->failure;
        return c->failed;
    }
    /* Each pass's end ends the next one, and the last one ends out. */
    int rc = pass_end(&c->pass[0], err);
    return rc ? fail(c, rc, err) : 0;
}

en_stage en_chain_input(en_chain *c)
{
    return (en_stage){ chain_put, chain_end, c };
}

/* Batch slots of a pass whose slabs own slab_vertices (see CHUNK_JOBS). */
static size_t chunk_slots(uint32_t slab_vertices)
{
    uint64_t want = 4 * (uint64_t)slab_vertices / CHUNK_BATCH;
    size_t n = CHUNK_JOBS_MIN;
    while (n < want && n < CHUNK_JOBS)
        n *= 2;
    return n;
}

int en_chain_new(en_chain **out, const en_chain_config *cfg, en_pool *pool, epsnet_error *err)
{
    *out = NULL;
    en_chain *c = en_calloc(1, sizeof *c);
    if (!c)
        return en_error_set(err, EPSNET_ENOMEM, cfg->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    c->cfg = *cfg;
    if (c->cfg.mode == EN_SLAB_SAMPLE || c->cfg.passes < 1)
        c->cfg.passes = 1;
    c->pass = en_calloc((size_t)c->cfg.passes, sizeof *c->pass);
    if (!c->pass) {
        en_free(c);
        return en_error_set(err, EPSNET_ENOMEM, cfg->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    c->spares = cfg->spares ? cfg->spares : &c->own;
    int rc = cfg->spares ? 0 : en_chain_spares_new(&c->own);
    if (rc)
        rc = en_error_set(err, EPSNET_ENOMEM, cfg->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    for (int i = 0; i < c->cfg.passes && rc == 0; i++) {
        en_pass *p = &c->pass[i];
        p->chain = c;
        p->index = i;
        p->g = *cfg->sphere;
        p->plan = i == 0 ? cfg->plan : NULL;
        if (p->plan && p->plan->skeleton == EN_SKELETON_CHOSEN &&
            gauss_init(&p->g, p->plan->finest_frequency, &cfg->sphere->rot))
            rc = en_error_set(err, EPSNET_ENOMEM, cfg->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        if (i > 0) {
            gauss_rotation r;
            gauss_pass_rotation(cfg->seed, i + 1, &r);
            gauss_init(&p->g, cfg->sphere->n, &r);
        }
        p->batched = i > 0 || cfg->checked_input;
        p->direct = cfg->out_on_workers && cfg->mode == EN_SLAB_SIMPLIFY && i == c->cfg.passes - 1;
        uint32_t slab = cfg->slab_vertices;
        p->nchunk = chunk_slots(slab);
        if (p->batched && (p->chunk = en_calloc(p->nchunk, sizeof *p->chunk)) != NULL)
            for (size_t k = 0; k < p->nchunk; k++)
                p->chunk[k].p = p;
        if ((p->batched && !p->chunk) ||
            en_chunker_init(&p->ch, slab, cfg->hold_all, cfg->path) ||
            en_stitcher_init(&p->st, cfg->max_normal_dev, (en_stage){ buffer_put, buffer_end, p }) ||
            en_jobring_new(&p->ring, pool, cfg->ring_capacity) ||
            (p->batched && en_jobring_new(&p->chunk_ring, pool, p->nchunk)) ||
            (c->cfg.mode == EN_SLAB_SIMPLIFY && en_jobring_new(&p->stitch_ring, pool, 1)))
            rc = en_error_set(err, EPSNET_ENOMEM, cfg->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        if (p->chunk_ring) /* see chunk_job */
            en_jobring_set_order(p->chunk_ring, 1, 1);
        /* the records' bytes: the attributes, then the carried block (slab_work.h)
         * where the marks are read; the chunker keeps a quadric it starts from */
        int marked = p->plan && p->plan->skeleton == EN_SKELETON_MARKED;
        uint32_t channels = cfg->mode == EN_SLAB_SIMPLIFY && cfg->weights ? cfg->weights->channels : 0;
        size_t in_size = cfg->attr_size + (cfg->quadrics_in ? en_carried_marks_at(channels) : 0);
        p->batch_attr_size =
            cfg->mode != EN_SLAB_SIMPLIFY ? 0
                                          : cfg->attr_size + (marked || cfg->quadrics_in ? en_carried_bytes(channels) : 0);
        if (rc == 0 && p->batched && next_fill(p))
            rc = en_error_set(err, EPSNET_ENOMEM, cfg->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        p->ch.mark_at = marked ? cfg->attr_size + en_carried_marks_at(channels) : UINT32_MAX;
        p->ch.mark_level = marked ? p->plan->skeleton_level : 0xff;
        p->ch.stash = c->spares->slab_works;
        p->st.collapse_arrays = c->spares->collapse_arrays;
        p->ch.attr_size = cfg->mode == EN_SLAB_SIMPLIFY ? (uint32_t)in_size : 0;
        p->ch.copies = cfg->mode == EN_SLAB_SIMPLIFY && cfg->attr_size > 0;
        p->st.attr_size = cfg->mode == EN_SLAB_SIMPLIFY ? cfg->attr_size : 0;
        p->st.weights = channels ? cfg->weights : NULL;
        p->st.na = en_aq_doubles(channels);
        if (cfg->mode == EN_SLAB_SIMPLIFY && (cfg->quadrics_in || cfg->quadrics_out)) {
            p->st.attr_size += en_carried_bytes(channels);
            p->st.quadric_at = cfg->attr_size;
            p->st.write_quadrics = cfg->quadrics_out;
        }
        int streamed = p->plan && p->plan->seams != EN_SEAMS_NONE;
        int priced = p->plan && p->plan->priced; /* leaves marks and costs */
        p->st.plan = streamed ? p->plan : NULL;
        if (rc == 0 && priced &&
            (!(p->st.cost_hist = en_calloc(EN_COST_BUCKETS, sizeof *p->st.cost_hist)) ||
             (!c->cost_hist && !(c->cost_hist = en_calloc(EN_COST_BUCKETS, sizeof *c->cost_hist)))))
            rc = en_error_set(err, EPSNET_ENOMEM, cfg->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        size_t nlevel = (size_t)EN_LEVELS * EN_COST_BUCKETS;
        if (rc == 0 && priced && p->plan->skeleton == EN_SKELETON_CHOSEN &&
            (!(p->st.level_hist = en_calloc(nlevel, sizeof *p->st.level_hist)) ||
             (!c->level_hist && !(c->level_hist = en_calloc(nlevel, sizeof *c->level_hist)))))
            rc = en_error_set(err, EPSNET_ENOMEM, cfg->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        if (rc == 0 && p->plan && p->plan->count_nranges && streamed &&
            (!(p->st.taken_hist = en_calloc(EN_COST_BUCKETS, sizeof *p->st.taken_hist)) ||
             (!c->taken_hist && !(c->taken_hist = en_calloc(EN_COST_BUCKETS, sizeof *c->taken_hist)))))
            rc = en_error_set(err, EPSNET_ENOMEM, cfg->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        /* a paced pass's last take aims at its goal (an error bound's last
         * slab is as any other) */
        p->ch.cut_last = streamed && p->plan->seams != EN_SEAMS_ERROR;
    }
    if (rc) {
        en_chain_free(&c);
        return rc;
    }
    c->stats.passes = c->cfg.mode == EN_SLAB_SIMPLIFY ? (uint64_t)c->cfg.passes : 0;
    *out = c;
    return 0;
}

uint64_t en_chain_faces_in(const en_chain *c)
{
    return c->stats.faces_in;
}

void en_chain_stats_get(const en_chain *c, en_chain_stats *out)
{
    *out = c->stats;
    const en_pass *first = &c->pass[0];
    if (first->plan && first->plan->skeleton == EN_SKELETON_CHOSEN) {
        out->skeleton_finest_frequency = first->plan->finest_frequency;
        if (!first->plan->one_slab)
            out->skeleton_frequency = chosen_frequency(first);
    }
    uint64_t chunk_active = 0;
    for (int i = 0; i < c->cfg.passes; i++) {
        const en_stitch_stats *ss = &c->pass[i].st.stats;
        out->seam_faces += ss->seam_faces;
        out->seam_collapses += ss->seam_collapses;
        out->collapses += ss->seam_collapses;
        out->band_nonsamples += ss->band_nonsamples;
        out->band_left += ss->band_left;
        out->inner_nonsamples += ss->inner_nonsamples;
        out->inner_left += ss->inner_left;
        chunk_active += c->pass[i].ch.max_active;
    }
    if (chunk_active > out->max_active)
        out->max_active = chunk_active;
    for (int i = 0; i < c->cfg.passes; i++) {
        /* samples the seams of a finish gave up, counted by their slabs as kept */
        const en_stitcher *st = &c->pass[i].st;
        out->samples_given_up += st->given_up;
        out->skeleton_kept -= st->given_up < out->skeleton_kept ? st->given_up : out->skeleton_kept;
        if (st->plan && !st->plan->priced && st->plan->seams == EN_SEAMS_PACED && !st->plan->by_vertices)
            out->target_faces = st->plan->goal;
    }
    if (c->cfg.mode == EN_SLAB_SIMPLIFY) {
        const en_stitch_stats *last = &c->pass[c->cfg.passes - 1].st.stats;
        out->output_vertices = last->out_vertices;
        out->output_faces = last->out_faces;
        out->remaining_nonsamples = last->remaining_nonsamples;
    }
}

void en_chain_cost_hist(const en_chain *c, int skeleton_level, uint64_t *add)
{
    for (int b = 0; c->cost_hist && b < EN_COST_BUCKETS; b++)
        add[b] += c->cost_hist[b];
    for (int i = 0; i < c->cfg.passes; i++)
        for (int b = 0; c->pass[i].st.cost_hist && b < EN_COST_BUCKETS; b++)
            add[b] += c->pass[i].st.cost_hist[b];
    /* the samples finer than the skeleton chosen are free from now on */
    for (int k = skeleton_level + 1; k < EN_LEVELS; k++) {
        size_t row = (size_t)k * EN_COST_BUCKETS;
        for (int b = 0; c->level_hist && b < EN_COST_BUCKETS; b++)
            add[b] += c->level_hist[row + (size_t)b];
        for (int i = 0; i < c->cfg.passes; i++)
            for (int b = 0; c->pass[i].st.level_hist && b < EN_COST_BUCKETS; b++)
                add[b] += c->pass[i].st.level_hist[row + (size_t)b];
    }
}

void en_chain_taken_hist(const en_chain *c, uint64_t *add)
{
    for (int b = 0; c->taken_hist && b < EN_COST_BUCKETS; b++)
        add[b] += c->taken_hist[b];
    for (int i = 0; i < c->cfg.passes; i++)
        for (int b = 0; c->pass[i].st.taken_hist && b < EN_COST_BUCKETS; b++)
            add[b] += c->pass[i].st.taken_hist[b];
}

void en_chain_free(en_chain **pc)
{
    en_chain *c = pc ? *pc : NULL;
    if (!c)
        return;
    for (int i = 0; c->pass && i < c->cfg.passes; i++) {
        en_pass *p = &c->pass[i];
        /* the jobs in flight first: the chunk job reads the chunker and
         * may take spare slab works, the take reads a slab work and the
         * stitcher */
        en_jobring_free(&p->chunk_ring, NULL);
        en_jobring_free(&p->stitch_ring, drop_stitch);
        en_jobring_free(&p->ring, free_work);
        for (size_t k = 0; p->chunk && k < p->nchunk; k++) {
            chunk_job *j = &p->chunk[k];
            for (size_t n = 0; n < j->ncut; n++)
                free_work(j->cut[n]);
            for (size_t n = 0; n < j->ngive; n++)
                free_work(j->give[n]);
            en_free(j->cut);
            en_free(j->give);
            en_free(j->recs);
            en_free(j->attr);
        }
        en_free(p->chunk);
        for (size_t n = 0; n < p->nreturned; n++)
            en_ctxpool_give(c->spares->slab_works, p->returned[n]);
        en_free(p->returned);
        en_free(p->out);
        en_chunker_free(&p->ch);
        en_stitcher_free(&p->st);
    }
    en_free(c->pass);
    en_free(c->cost_hist);
    en_free(c->level_hist);
    en_free(c->taken_hist);
    en_chain_spares_free(&c->own);
    en_free(c);
    *pc = NULL;
}
