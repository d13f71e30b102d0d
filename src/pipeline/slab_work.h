/*
 * The worker's half of the streaming pipeline (docs/architecture.md §8): one
 * slab, classified and simplified on its own.
 *
 * A slab k owns the vertices finalized in its stretch of the stream and holds
 * every face around them, so each owned vertex has its whole star and its
 * classification (paper §4) is exactly the one-slab result. Faces whose
 * corners all belong to slab k are *interior*; the others are shared with
 * other slabs and never changed here.
 *
 * Collapses (paper §4.2, §5) run only where nothing outside the slab can see
 * them: v and its target u must both be *inner* (every neighbour owned by
 * this slab), so every face read or written is interior. An owned vertex
 * with a neighbour in another slab is *frozen*: it is classified here but its
 * collapses are left to the stitcher, together with the ring of inner
 * vertices around it (paper §4.2: the ε-net is local, so a band of one ring
 * decides a seam).
 */
#ifndef EN_PIPELINE_SLAB_WORK_H
#define EN_PIPELINE_SLAB_WORK_H

#include <stdatomic.h>
#include <stdint.h>

#include "common/ctxpool.h"
#include "core/classify.h"
#include "core/collapse.h"
#include "core/gauss.h"
#include "core/slab.h"
#include "pipeline/attr_weights.h"
#include "pipeline/pass_plan.h"
#include "pipeline/seam.h"

typedef enum en_slab_mode { EN_SLAB_SAMPLE, EN_SLAB_SIMPLIFY } en_slab_mode;

/* Between the passes of a target stage (pipeline/target_stage.h), a vertex
 * record's attribute bytes end, after the input's own, in a carried block:
 * the vertex's accumulated quadric, its attribute part when attributes are
 * weighed (core/attr_quadric.h: en_aq_doubles(channels) doubles), then a
 * word of marks (EN_MARK_*), at en_carried_marks_at() in the block. The
 * public record's fields keep their meaning. Only the chain's own passes
 * write the block (the stitcher's write_quadrics) or read it (the
 * chunker's mark_at, the slab work's quadric_at). */
static inline uint32_t en_carried_marks_at(uint32_t channels)
{
    return (uint32_t)(sizeof(en_quadric) + en_aq_doubles(channels) * sizeof(double));
}
static inline uint32_t en_carried_bytes(uint32_t channels)
{
    return en_carried_marks_at(channels) + (uint32_t)sizeof(uint64_t);
}
#define EN_MARK_SKELETON 1u            /* a skeleton sample */
/* ... and, in the byte above, log2 of the coarsest frequency it is a
 * sample at (the thinning's levels, nested_density; 0 when not known,
 * a sample at every frequency the passes after it may keep). */
#define EN_MARK_LEVEL_SHIFT 8

/* A slab's collapses as they go, read on another thread (a one-slab
 * pass's progress, docs/architecture.md §10): `total` is set once before
 * they start, `done` now and then; `stop`, raised by that other thread,
 * ends them early (a cancelled run). All relaxed. */
typedef struct en_slab_progress {
    _Atomic uint64_t done, total;
    _Atomic int stop;
} en_slab_progress;

typedef struct en_slab_work {
    /* Input, filled by the chunker. Local vertices: the owned ones first
     * (s.vflags EN_V_OWNED), in increasing global id, then the ghosts. */
    uint32_t index;               /* k */
    en_slab s;
    uint32_t nowned;
    int64_t *owner;               /* per local vertex: owning slab, -1 when not yet known (> k) */
    uint8_t *fflags;              /* EN_F_* per face */
    uint64_t frontier;            /* every global id below was finalized in a slab <= k */
    uint64_t live_vertices, live_faces; /* chunker's active set at the cut */
    int last;                     /* cut at the end of the stream: no slab comes after it */
    /* Vertex attributes (docs/architecture.md §7): attr_size bytes per
     * local vertex, copied by the chunker, carried untouched (a kept vertex
     * is an input vertex) and read by the stitcher. */
    uint32_t attr_size;
    uint8_t *attr;
    /* A target stage's pass: each vertex's bytes end in its quadric, at
     * this offset, which the slab starts from (UINT32_MAX: none). */
    uint32_t quadric_at;
    /* The user's lock (settings.lock_property): the offset of that
     * attribute in a vertex's bytes and its type; lock_type 0: none. */
    uint32_t lock_offset;
    int lock_type;
    /* The attributes weighed (NULL or no channels: none); their values and
     * the vertices' attribute parts are worked out here, from attr. */
    const en_attr_weights *weights;

    /* Settings (shared, read only). */
    const gauss_sphere *g;
    en_slab_mode mode;
    double max_normal_dev;
    const en_pass_plan *plan;     /* NULL: the ε-net pass */
    en_slab_progress *progress;   /* NULL, or where the collapses are reported (the chain's) */
    en_ctxpool *collapse_arrays;  /* the chain's en_collapse_arrays_new() pool */
    /* NULL, or an en_slab_scratch_pool_new() pool: the worker's scratch
     * below (and the slab's stars) is then lent from it for the run and
     * given back at its end, so a run holds one set a worker, not one a
     * slab work in flight (docs/architecture.md §12). */
    en_ctxpool *scratch;

    /* Output. */
    int rc;
    epsnet_error err;
    double seconds;
    en_classify_counts counts;    /* owned vertices; zero-area faces counted at their home */
    uint8_t *vclass;              /* EN_C_* per local vertex (owned) */
    int32_t *vgvertex;
    en_quadric *q;                /* SIMPLIFY: per local vertex, accumulated */
    double *aq;                   /* SIMPLIFY with weights: en_aq_doubles() per local vertex, accumulated */
    double *avalue;               /* SIMPLIFY with weights: the weighted values, channels per local vertex */
    double *ref;                  /* SIMPLIFY: per face, input unit normal */
    uint32_t *tri;                /* SIMPLIFY: corners after the collapses */
    uint8_t *falive, *valive;
    /* q, aq, tri and ref hold only the entries of the vertices (faces)
     * alive, in order: a slab worked on another rank, whose results arrive
     * so (pipeline/peers.c); the stitcher reads them in step. */
    int packed;
    uint8_t *border;              /* EN_BORDER_* per owned vertex */
    uint32_t *future;             /* per owned vertex: alive faces whose home is a later slab */
    uint32_t *degree;             /* per owned vertex: alive faces around it */
    uint8_t *band;                /* per owned vertex: frozen or next to one in the input */
    uint64_t band_nonsamples, inner_nonsamples; /* owned non-samples of each kind */
    uint64_t collapses;
    uint64_t refused[EN_REFUSE_KINDS]; /* inner non-samples left, by reason */
    /* With a target: the sphere the skeleton was taken at (g points here
     * when the density was chosen), samples collapsed to meet the target,
     * samples kept, and whether the error bound left collapses undone. */
    gauss_sphere chosen;
    /* EN_SKELETON_CHOSEN (slab_work.c: nested_density): with has_levels,
     * per owned sample the log2 of the coarsest power-of-two frequency it
     * is a sample at; and the owned samples by that level. */
    uint8_t *vlevel;
    int has_levels;
    uint64_t level_count[EN_LEVELS];
    uint64_t given_up, skeleton_kept, keep_faces;
    /* The faces the slab came with, and, under a target, the faces of
     * glued membranes removed before the classification (docs/method.md
     * §13); s.nt is then faces_in - membrane_faces. */
    uint64_t faces_in, membrane_faces;
    uint64_t faces_left, vertices_left;
    /* A plan's units (en_pass_plan.by_vertices) this slab brings to its pass:
     * its home faces, membranes included, or its owned vertices on faces. */
    uint64_t units_in;
    int stopped_by_error;
    /* The highest quadric cost the slab's collapses reached before its
     * count stopped them (0: none), the level EN_SEAMS_LEVEL seams go to. */
    double level;
    /* A priced plan's: the costs of the collapses left to do (EN_COST_BUCKETS
     * counts, en_cost_bucket) at the vertices this slab decides (inner and
     * outer; the ring's go with the seams, whose stitcher counts them),
     * which the target stage sums to set the next round's ceiling. */
    uint64_t *cost_hist;
    /* ... and with has_levels, those of the samples, by level (EN_LEVELS
     * rows of EN_COST_BUCKETS): what the pass's choice of density frees. */
    uint64_t *level_hist;
    /* A plan with count ranges: the collapses of vertices in them, by
     * level (en_collapse_settings.taken; EN_COST_BUCKETS counts), and the
     * vertices in them this slab owns. */
    uint64_t *taken_hist;
    uint64_t counted_vertices;

    /* Worker scratch (its own, or lent by the scratch pool for the run),
     * and the capacity of every array above: a slab work is reused for a
     * later cut (en_slab_work_reset), so a run in its steady state
     * allocates nothing per slab. */
    double *fnormal;
    int32_t *ftri;
    uint8_t *removable;
    uint16_t *bucket_of;          /* a priced plan's: en_collapse_settings.bucket_of */
    struct { /* in elements; attr in bytes */
        size_t owner, fflags, vclass, vgvertex, q, ref, tri, falive, valive, border, future, degree, band, fnormal,
            ftri, removable, attr, bucket_of, vlevel, aq, avalue;
    } cap;
} en_slab_work;

void en_slab_work_init(en_slab_work *w);
/* Forget the input and the outputs, keep the memory for the next cut. */
void en_slab_work_reset(en_slab_work *w);
/* Free everything (w is then as after en_slab_work_init). */
void en_slab_work_free(en_slab_work *w);
/* Free what only a run uses and the slab work keeps (vgvertex; the rest
 * of the worker's scratch is lent from w->scratch for the run only), and
 * the full-size q, aq, tri and ref: a slab work whose slab is worked
 * elsewhere (pipeline/peers.h) holds only its input and its results,
 * packed. A later run grows them again. */
void en_slab_work_shed(en_slab_work *w);
/* The bytes w's arrays take, as allocated (its slab's included). */
uint64_t en_slab_work_bytes(const en_slab_work *w);

/* A pool of worker scratch for en_slab_work.scratch (its items free
 * themselves). @return 0 or EPSNET_ENOMEM. */
int en_slab_scratch_pool_new(en_ctxpool **pool);

/* The level of a power-of-two frequency n: log2 n. */
int en_level_of(uint32_t n);

/* The finest level k <= top (log2 of a frequency) whose samples, the
 * counts of levels 0 ... k summed, are at most budget; 0 when none is. */
int en_skeleton_level(const uint64_t *level_count, int top, double budget);

/* The pool's job function: classify (and simplify) w. Fills w->rc/err. */
int en_slab_work_run(void *w);

#endif
