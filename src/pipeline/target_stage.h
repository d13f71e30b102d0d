/*
 * The size target's stage (docs/architecture.md §7, "target stage"): rounds
 * under a rising global cost threshold, on slabs, after the thinning pass.
 *
 * The stage plans the thinning pass (en_target_stage_plan_thin: the chain
 * pass before it, which chooses the skeleton, classifies and collapses each
 * slab to a share of the target), which hands its output stream to this
 * stage, which keeps it in a compressed temporary file. At the end of that stream the stage knows what no streamed step
 * knows before it: how many faces are left, and what the collapses still
 * to do cost (a histogram the thinning's slabs and seams filled). Then:
 *
 *  - rounds: while what is left is well above the target, one more pass
 *    over the kept stream, on slabs of the one pool, does every collapse
 *    below a global ceiling on quadric cost, in every slab and seam alike,
 *    cheapest first: the same ceiling held everywhere is the streaming form
 *    of one global cheapest-first order (an error bound held by every
 *    collapse is slab-invariant, docs/architecture.md §7). The ceiling is
 *    set from the histogram so that the round removes a part of what is
 *    still to go, never more; each round counts the costs it leaves for
 *    the next one;
 *  - the last round meets the count exactly, in one slab when what is
 *    left is small, else on slabs whose seams pace it to the target
 *    (stitcher.c: seam_keep), over a mesh already close to it.
 *
 * The skeleton's samples ride through the rounds as marks (never removed
 * by a round; the last one gives them up only when the target needs it),
 * and so do the user's locks, which every slab reads from the attributes.
 *
 * Every pass here is a chain pass with a plan (pipeline/pass_plan.h); the
 * plans are made in this file, and nothing else knows them as a thinning,
 * a round or a last round.
 *
 * Threads: the stage runs on the calling thread, as the chain's output
 * stage; each round is a chain of its own on the run's pool.
 */
#ifndef EN_PIPELINE_TARGET_STAGE_H
#define EN_PIPELINE_TARGET_STAGE_H

#include <stdint.h>

#include "common/pool.h"
#include "common/stage.h"
#include "pipeline/chain.h"

typedef struct en_target_stage en_target_stage;

/* A size target, as the stage plans its passes from it. */
typedef struct en_target_size {
    uint64_t goal;                /* faces, or vertices with by_vertices */
    int by_vertices;
    double share;                 /* the goal's share of the input's faces (vertices) */
    int choose_density;           /* 0: the skeleton at the sphere given (a --level) */
} en_target_size;

/* The skeleton's share of the vertices a target keeps (measured on the
 * real scans at 5-50% of their faces: bench/RESULTS.md). */
#define EN_TARGET_SKELETON_SHARE 0.25

/* The finest density a target's skeleton may take (EN_SKELETON_CHOSEN).
 * A streamed thinning classifies its first slabs there and keeps their
 * samples until the counts rule it out: at 32, `gen bumpy` 20M at 10%
 * took 1.2 times the wall time it takes at 16, for the same skeleton
 * (N = 4); a vertex at 128 took 7 times what it takes at 8. Only a CAD
 * part at half its faces chose finer on the shared meshes (fandisk: 23 in
 * the old list, 32 without the cap): bench/RESULTS.md, session 12. */
#define EN_TARGET_FINEST_FREQUENCY 16

/* What a streamed thinning keeps of each slab's faces: this many times the
 * target's share (plus 1%). Each slab stops at its own count, whatever its
 * costs, so a slab harder than its neighbours (rougher, or cut by seams)
 * goes deeper than the global order would: at 1.5, `gen bumpy` 200K at 25%
 * through slabs of 8,192 had twice the one-slab Hausdorff (five times with
 * a UV atlas); at 2 both are within 1.05, the shared scans' streamed order
 * went from 1.070 to 1.048 of the one-slab Hausdorff (geometric mean), and
 * `gen bumpy` 20M at 10% took 1.07 times the wall time (bench/RESULTS.md,
 * session 16). */
#define EN_TARGET_THIN_KEEP 2.0
/* ... and this many times where that is few enough to go straight to the
 * last round's one slab, with no round between: keeping more there costs
 * a larger slab, not a pass, and the one slab's global order does more of
 * the work. The shared scans forced through `--slab 4096` and `16384`,
 * against one slab: Hausdorff 1.048 and 1.035 times (geometric means,
 * worst 1.31 and 1.58) at 2, 1.030 and 1.016 (worst 1.14 and 1.19) at 3,
 * 1.059 and 1.063 at 2.5 (the maximum distance moves case by case). Where
 * rounds follow, 3 made a shuffled 20M-face PLY at 10% take four rounds
 * instead of three and 1.02-1.10 times the wall (bench/RESULTS.md,
 * session 19). */
#define EN_TARGET_THIN_KEEP_ONE_SLAB 3.0

/* The thinning pass's plan, the chain pass before the stage, on an input
 * of nv vertices and nf faces; one_slab_bytes, one_slab_vertices: what the
 * last round's one slab may hold (budget.h; en_target_stage_config). */
void en_target_stage_plan_thin(const en_target_size *size, uint64_t nv, uint64_t nf, uint64_t one_slab_bytes,
                               uint64_t one_slab_vertices, en_pass_plan *thin);

/*
 * Windows of the input for the pricing pass (en_target_stage_price): a
 * few stretches of the sorted stream, spread evenly along it, each pushed
 * as a mesh of its own (a face with a corner outside its window is left
 * out, so its cut ends are borders). The caller who can seek into its
 * input offers them (a sorted .smz, through its block index).
 */
/* note: a window is a slab (its inside, which the pass counts) between
 * two margins of whole slabs. A cut changes what the slabs near it do:
 * on `gen bumpy` 20M at 10% (slabs 14 times as long as the stream is
 * wide), margins of half a slab priced the ceiling at a third of the whole
 * stream's, margins of one slab at its value; on 400K faces with slabs of
 * 1.5 widths and margins of 3, the thinning ended at half the target
 * (bench/RESULTS.md, session 18). So a margin is at least
 * en_target_price_margin_widths() widths (longer where the target keeps
 * less: its collapses reach further), a slab at least
 * EN_PRICE_SLAB_WIDTHS, and the windows at most EN_PRICE_MAX_SHARE of the
 * stream; else no pricing. Four windows: eight cost twice the time, and
 * the thinning under their ceiling ended 1.02 times where it aimed, under
 * four's 1.03. */
#define EN_PRICE_WINDOWS 4
#define EN_PRICE_SLAB_WIDTHS 4
double en_target_price_margin_widths(double share);
#define EN_PRICE_MAX_SHARE 0.15

typedef struct en_window_source {
    uint32_t windows;
    /* The insides the pass counts: one sorted range [lo, hi) of vertex ids
     * per window (2 values each), ids numbered as the windows push them,
     * and how many vertices they hold. */
    const uint64_t *inside;
    uint64_t inside_vertices;
    uint64_t vertices;            /* in all the windows */
    /* What push(inside = 1) pushes instead: each inside and the ring of
     * ids either side that completes its vertices' stars (what a
     * classification needs; the margins are for the collapses' cuts):
     * how many vertices, and the insides as it numbers them. */
    uint64_t inside_ring_vertices;
    const uint64_t *inside_alone;
    /* Push window w's records into `into` (not ended), or with inside
     * only its inside and ring, its vertices numbered after the `base`
     * vertices of the windows before it; add how many vertices it pushed
     * to *pushed. @return 0, EPSNET_EFORMAT for a block that does not
     * read (the stream's reader reports it, later, where it is), or a
     * negative code with err filled. */
    int (*push)(void *opaque, uint32_t w, int inside, uint64_t base, en_stage *into, uint64_t *pushed,
                epsnet_error *err);
    void *opaque;
} en_window_source;

typedef struct en_target_stage_config {
    const char *path;             /* names the input in messages */
    const gauss_sphere *sphere;   /* the chains' (unused by rounds: their skeleton is marked) */
    double max_normal_dev;
    uint32_t attr_size, lock_offset;
    int lock_type;
    const en_attr_weights *weights; /* as the thinning's (NULL: none; outlives the stage) */
    uint32_t slab_vertices;       /* the rounds' slabs: the thinning pass's */
    int hold_all;                 /* the thinning's slabs hold slab_vertices in all, and so the rounds' (chunker.h) */
    uint64_t mem_budget;          /* each round's chain (budget.h: the chain's share) */
    uint64_t one_slab_bytes;      /* what a last round in one slab may hold (budget.h) */
    uint32_t one_slab_vertices;   /* ... and at most this many vertices (a few slabs) */
    size_t ring_capacity;
    const char *tmpdir;           /* the kept stream's temporary file (NULL: $TMPDIR or /tmp) */
    en_target_size size;          /* what the thinning was planned against */
    /* The stage's progress, now and then: done of total units of its whole
     * work, rounds to come included (an estimate that firms up as they
     * run; done/total never falls); non-zero cancels (EPSNET_EINTR).
     * NULL: none. */
    int (*tick)(void *opaque, uint64_t done, uint64_t total);
    void *tick_opaque;
    en_chain_spares *spares;      /* the rounds' chains' (en_chain_config.spares) */
    en_stage out;                 /* where the last round's records go */
} en_target_stage_config;

/* @return 0, or a negative code with err filled. */
int en_target_stage_new(en_target_stage **ts, const en_target_stage_config *cfg, en_pool *pool,
                        epsnet_error *err);

/* The stage the thinning chain writes into. Its end runs the rounds and
 * the last one, and ends cfg.out. Its put may be called on any thread, one
 * call at a time (en_chain_config.out_on_workers); its end on the thread
 * that made the stage. */
en_stage en_target_stage_input(en_target_stage *ts);

/*
 * The pricing pass: the thinning's own plan run over the windows, first
 * for the skeleton's density, then deeper than the target, counting what
 * its collapses took by cost; from those counts, a global cost ceiling for
 * the thinning (thin->cost_ceiling, thin->seams) under which the windows
 * keep 1.25 times the target, the density as its candidate, and a floor
 * and a pace under it. Run before the thinning chain takes its first
 * record. *ceiling: the ceiling set (0: none, and thin as it was: the
 * skeleton alone over the target, windows that never got there, or a
 * block that does not read). @return 0, or a negative code with err.
 */
int en_target_stage_price(en_target_stage *ts, const en_window_source *src, en_pass_plan *thin, double *ceiling,
                          epsnet_error *err);

/* The thinning chain, whose costs left (en_chain_cost_hist) the first
 * round's ceiling comes from; set before the chain's end. */
void en_target_stage_after(en_target_stage *ts, const en_chain *thin);

/* The rounds' counts added into *cs (collapses, slabs, seams), and the
 * last round's output, skeleton and target figures put in its place.
 * rounds: how many rounds ran before the last one; last_on_slabs: whether
 * the last one ran on slabs (over the budget's one slab). */
void en_target_stage_stats(const en_target_stage *ts, en_chain_stats *cs, int *rounds, int *retries,
                           int *last_on_slabs);

void en_target_stage_free(en_target_stage **ts);

#endif
