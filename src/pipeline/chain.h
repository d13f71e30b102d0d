/*
 * The ε-net passes of the stage chain (docs/architecture.md §7): pass 1
 * … K, each a chunker → workers → stitcher, each pass's output the next
 * one's input, the last one's output an en_stage (the writer, a queue, a
 * collector). Its own input is an en_stage too (en_chain_input), so the
 * reader or the sort pushes into it like into any other step.
 *
 * Threads: the chain is driven by one thread (its caller's); slab jobs run
 * on the pool the caller lends it, through one job ring per pass.
 */
#ifndef EN_PIPELINE_CHAIN_H
#define EN_PIPELINE_CHAIN_H

#include <stdint.h>

#include "common/ctxpool.h"
#include "common/pool.h"
#include "common/stage.h"
#include "core/collapse.h"
#include "core/gauss.h"
#include "pipeline/peers.h"
#include "pipeline/slab_work.h"

/* A sample found by a SAMPLE-mode chain, in slab order (ids increase
 * within a slab, not across slabs). */
typedef int (*en_sample_fn)(void *opaque, uint64_t gid, const double xyz[3], int32_t gvertex, epsnet_error *err);

/* Bytes a one-slab pass holds per vertex, every array of the slab work and
 * of the collapse core counted (measured: 610 on a 1M-vertex run,
 * docs/architecture.md §7): what a target's one slab is budgeted at. */
#define EN_ONE_SLAB_BYTES_PER_VERTEX 640

typedef struct en_chain en_chain;

/* Slab works (en_slab_work) and collapse arrays (en_collapse_arrays_new)
 * kept warm from chain to chain: a chain's fresh ones are faulted in page
 * by page, which measured a tenth of a 20M-face run's time with a target
 * of 4 rounds (bench/RESULTS.md, session 10). Thread-safe. */
typedef struct en_chain_spares {
    en_ctxpool *slab_works, *collapse_arrays, *scratch;
} en_chain_spares;

/* @return 0 or EPSNET_ENOMEM. */
int en_chain_spares_new(en_chain_spares *sp);
void en_chain_spares_free(en_chain_spares *sp);

typedef struct en_chain_config {
    en_slab_mode mode;
    const char *path;             /* names the input in messages (may be NULL) */
    const gauss_sphere *sphere;   /* G of pass 1; later passes rotate it */
    uint64_t seed;                /* later passes' rotations (gauss_pass_rotation) */
    int passes;                   /* SIMPLIFY: ε-net passes, >= 1; SAMPLE: 1 */
    double max_normal_dev;
    /* SIMPLIFY: pass 1's plan (pipeline/pass_plan.h: a pass of a size or
     * error target, docs/method.md §13); NULL, and every later pass: the
     * ε-net pass. */
    const en_pass_plan *plan;
    uint32_t attr_size;           /* SIMPLIFY: vertex attribute bytes per record (0: none) */
    /* A target stage's passes (pipeline/target_stage.h): the input records'
     * attribute bytes end in each vertex's accumulated quadric
     * (quadrics_in: the slabs start from it, not from their faces), and the
     * output records' do (quadrics_out), after the attr_size bytes of the
     * input's own attributes. */
    int quadrics_in, quadrics_out;
    uint32_t lock_offset;         /* the lock property's bytes in them, */
    int lock_type;                /* and its epsnet_attr_type (0: no lock) */
    /* SIMPLIFY: the attributes weighed in the collapses' error (NULL: none;
     * must outlive the chain). The carried block then holds each vertex's
     * attribute part after its quadric (slab_work.h). */
    const en_attr_weights *weights;
    uint32_t slab_vertices;       /* vertices a slab owns, at most, */
    int hold_all;                 /* or holds in all, its ghosts included (pipeline/chunker.h) */
    uint64_t mem_budget;          /* bytes the chain may hold beyond the reader's; 0: none */
    size_t ring_capacity;         /* slabs in flight per pass */
    /* The input records were checked before the chain (a reader front end,
     * the sort): pass 1's chunker may then take them in batches on the pool
     * (docs/architecture.md §10), its errors reported a batch later.
     * 0: every record is checked as it is put, and a bad one fails that put
     * (the push API). Later passes always take batches. */
    int checked_input;
    /* While the calling thread waits for a one-slab pass's collapses
     * (with workers; with none the slab runs inside its put): called about
     * ten times a second with the collapses done and planned, and once
     * more when they are over (done = total); non-zero cancels the run
     * (EPSNET_EINTR). NULL: none. */
    int (*tick)(void *opaque, uint64_t done, uint64_t total);
    void *tick_opaque;
    /* Where the chain's slab works and collapse arrays come from and go
     * back to at its end, for the chains after it (a target stage's
     * rounds); NULL: the chain's own, freed with it. */
    en_chain_spares *spares;
    en_stage out;                 /* SIMPLIFY: where the last pass's records go */
    /* out may be called on a worker (one call at a time, in order: a
     * stage that only writes state of its own, as the target stage's kept
     * stream): the last pass's takes then hand it their records
     * themselves, not through the calling thread, which measured 40% of
     * that thread's time in a target's rounds (bench/RESULTS.md). 0: the
     * calling thread makes every call (a writer may report progress to
     * the user, who expects it there). */
    int out_on_workers;
    en_sample_fn on_sample;       /* SAMPLE: where samples go */
    void *sample_opaque;
    /* SIMPLIFY, on rank 0 of a run shared among processes
     * (pipeline/peers.h): pass 1 ships slabs to the ranks with room for
     * one (en_peer_pick) and takes their results back at retire;
     * everything else runs here. NULL: one process. */
    en_peer_link *peers;
} en_chain_config;

/* What a run of the chain did (the api turns it into epsnet_stats). */
typedef struct en_chain_stats {
    en_classify_counts counts;    /* pass 1 */
    uint64_t vertices_in, faces_in;
    uint64_t passes, slabs, collapses;
    uint64_t refused[EN_REFUSE_KINDS];
    uint64_t seam_faces, seam_collapses;
    uint64_t band_nonsamples, band_left, inner_nonsamples, inner_left;
    uint64_t max_active;
    uint64_t output_vertices, output_faces, remaining_nonsamples; /* last pass */
    /* With a target: the skeleton's frequency (0 when not chosen here),
     * samples kept and given up, whether the error bound stopped it. */
    uint32_t skeleton_frequency;       /* the coarsest a slab used */
    uint32_t skeleton_finest_frequency;
    uint64_t target_faces;        /* the face target as resolved (0: none) */
    uint64_t skeleton_kept, samples_given_up, membrane_faces;
    int stopped_by_error;
} en_chain_stats;

/* @return 0, or a negative code with err filled. cfg is copied (path and
 * sphere must outlive the chain); pool must outlive it. */
int en_chain_new(en_chain **chain, const en_chain_config *cfg, en_pool *pool, epsnet_error *err);

/* The chain as a stage: its put takes the next input record, its end
 * finishes every slab and seam of every pass and ends `out`. After an error
 * every call returns it again. */
en_stage en_chain_input(en_chain *chain);

/* n records at once: what n puts to en_chain_input() do, with a batched
 * first pass (en_chain_config.checked_input) taking them by whole runs of
 * records (a file run's calling thread put each record through three calls
 * before: docs/architecture.md §10). */
int en_chain_put_many(en_chain *chain, const epsnet_record *recs, size_t n, epsnet_error *err);
/* n records at *recs, an en_malloc'ed array of *cap records the chain may
 * keep as a batch of its own without copying it (a batched first pass with
 * no attribute bytes, between batches), putting one of its own arrays, of
 * any contents, in its place; else as en_chain_put_many. */
int en_chain_put_owned(en_chain *chain, epsnet_record **recs, size_t *cap, size_t n, epsnet_error *err);

/* Counts so far (complete after the end). */
void en_chain_stats_get(const en_chain *chain, en_chain_stats *stats);
/* The faces put so far (en_chain_stats.faces_in), on the putting thread. */
uint64_t en_chain_faces_in(const en_chain *chain);

/* A priced pass (after the end): add into add[] (EN_COST_BUCKETS) the costs
 * of the collapses it left, one count per vertex that may still go, in its
 * cheapest collapse's bucket (pipeline/target_stage.h): its non-samples,
 * and its samples above skeleton_level (log2 of the frequency the skeleton
 * takes; EN_SKELETON_CHOSEN marks each with its level). */
void en_chain_cost_hist(const en_chain *chain, int skeleton_level, uint64_t *add);
/* A plan with count ranges (after the end): add into add[]
 * (EN_COST_BUCKETS) its slabs' and seams' collapses of the vertices in
 * them, by the level each had reached (en_collapse_settings.taken). */
void en_chain_taken_hist(const en_chain *chain, uint64_t *add);

/* Wait for the slabs in flight, free everything; sets *chain to NULL.
 * Accepts NULL. */
void en_chain_free(en_chain **chain);

#endif
