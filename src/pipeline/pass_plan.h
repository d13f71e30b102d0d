/*
 * How one pass's slabs and seams collapse (docs/architecture.md §7).
 *
 * A chain pass is a chunker, workers and a stitcher. With no plan (NULL)
 * it is the ε-net pass: every non-sample goes where it can. With a plan it
 * is a pass of a size or error target (docs/method.md §13): the samples
 * are a skeleton, and the other vertices go cheapest first by quadric cost
 * until the plan's stop. Each field below means one thing in every plan;
 * the chain, the slab work and the stitcher read the fields, never the
 * stage that planned the pass. The planners: api/run.c (one slab of the
 * whole mesh, a streamed error bound) and pipeline/target_stage.c (the
 * thinning, the rounds and the last round of a streamed size).
 */
#ifndef EN_PIPELINE_PASS_PLAN_H
#define EN_PIPELINE_PASS_PLAN_H

#include <stdint.h>

/* Where a slab's skeleton comes from. */
typedef enum en_skeleton_rule {
    EN_SKELETON_SPHERE,   /* the samples at the pass's sphere */
    /* The finest power-of-two frequency, at most finest_frequency, whose
     * samples are at most the skeleton's budget, from the whole pass's
     * counts (slab_work.c: nested_density). */
    EN_SKELETON_CHOSEN,
    /* The records' marks (EN_MARK_SKELETON) of samples at 2^skeleton_level
     * or coarser: an earlier pass's skeleton. */
    EN_SKELETON_MARKED,
} en_skeleton_rule;

/* Levels of the skeleton's density: log2 of a frequency, 0 ... EN_LEVELS - 1. */
#define EN_LEVELS 8

/* Where the collapses of W, the seams, stop. */
typedef enum en_seam_rule {
    EN_SEAMS_NONE,        /* one slab: there are none */
    EN_SEAMS_PACED,       /* W keeps the plan's share of the units taken so far; the
                           * last take ends the pass at goal (stitcher.c: seam_keep) */
    EN_SEAMS_LEVEL,       /* W goes as far as the two newest slabs went (en_slab_work.level) */
    EN_SEAMS_CEILING,     /* the slabs' cost ceiling */
    EN_SEAMS_ERROR,       /* the slabs' error bound */
} en_seam_rule;

typedef struct en_pass_plan {
    /* The skeleton. */
    en_skeleton_rule skeleton;
    /* The skeleton's most (EN_SKELETON_CHOSEN), and the most the corners of
     * glued membranes may lock: a share of the vertices the plan keeps. */
    double skeleton_share;
    /* EN_SKELETON_CHOSEN: the finest candidate (a power of two, at most
     * 2^(EN_LEVELS - 1)), and on slabs the skeleton's most in the whole
     * pass (one slab: skeleton_share of what it keeps). */
    uint32_t finest_frequency;
    uint64_t skeleton_budget;
    /* EN_SKELETON_CHOSEN on slabs: when not 0, the vertices the pass
     * expects, and each candidate's check holds the counts so far to the
     * budget's share of the vertices so far, not to the whole budget (a
     * pricing pass, whose few windows stand for the whole stream). */
    uint64_t skeleton_expected;
    int skeleton_level;           /* EN_SKELETON_MARKED: see there */
    /* Samples (and the non-manifold corners kept as samples) are a second
     * tier that a count takes last, when it cannot be met without them;
     * 0: they stay. */
    int samples_may_go;

    /* The stop: a count, a share, a cost ceiling, an error bound. */
    uint64_t faces, vertices;     /* a one-slab pass keeps at most this many (0: none) */
    double ratio;                 /* ... or this share of its faces (0: none) */
    /* Each slab keeps this share of the units (faces, or vertices with
     * by_vertices) its own collapses can reach (0: no share). A paced
     * pass whose one slab is its whole input keeps `goal` units instead. */
    double keep_share;
    int by_vertices;
    /* The shares (keep_share, floor_share) count the inner vertices a
     * slab's collapses may take, whatever the target counts: each collapse
     * takes exactly one, where the faces on inner vertices alone leave out
     * those a collapse removes beside a frozen vertex. A share that is only
     * a guard under a ceiling, counted in such faces, stopped the slabs of
     * thin streams long before the ceiling while their seams went on to
     * it (docs/architecture.md §7). */
    int share_of_vertices;
    uint64_t goal, expected_in;   /* the pass keeps goal units of the expected_in it takes */
    /* The share of a slab's vertices on faces that the plan keeps, which
     * the skeleton and the membranes are sized from (0: the count's). */
    double goal_share;
    double cost_ceiling;          /* > 0: every collapse cheaper is done, none dearer */
    /* A guard under a ceiling (0: none): each slab keeps at least this
     * share of the units its own collapses can reach, as keep_share
     * would, and W at least its pace to goal of expected_in, so that a
     * round whose ceiling was set from a histogram that missed what it
     * holds cannot pass the target (docs/architecture.md §7). */
    double floor_share;
    double max_error;             /* < 0: none; else times the diagonal, a distance */
    double diagonal;              /* the whole mesh's (0: the slab's own, when it is the whole) */
    /* The quadrics are taken afresh once the count is near
     * (en_collapse_settings.refresh_faces). */
    int refresh;

    en_seam_rule seams;
    /* The pass leaves, in each output vertex's carried block, its marks
     * and its quadric, and counts the costs of the collapses it left
     * (en_chain_cost_hist): a target stage's pass before its last. */
    int priced;
    /* The target stage's pricing pass over windows of the input
     * (target_stage.h: en_window_source): when count_nranges > 0, the
     * vertices whose ids lie in these sorted ranges [lo, hi) (2 values
     * each; the windows' insides, away from their cut ends) are the ones
     * the pass counts: its collapses of them, by the level the slab or
     * seam had reached (en_chain_taken_hist), and a chosen skeleton's
     * samples. */
    const uint64_t *count_ranges;
    uint32_t count_nranges;
    /* The pass is one slab of its whole input, held against the memory
     * budget as such. */
    int one_slab;
} en_pass_plan;

#endif
