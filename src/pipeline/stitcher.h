/*
 * The stitcher (docs/architecture.md §9): takes the slabs back in stream order, finishes
 * the seams between them and emits one ordered, finalized stream.
 *
 * Seams. Each slab hands over its frozen vertices (owned, with a neighbour
 * elsewhere), the ring of inner vertices around them and the faces of both,
 * after its own collapses. These form the seam mesh W. A frozen vertex is
 * *complete* once every slab holding one of its faces has been taken; then
 * its whole star is in W, and W's non-samples are collapsed exactly as a
 * slab does (paper §4.2: cheapest quadric first, same refusals), so no seam
 * stays unsimplified. A vertex is *settled* once it and its neighbours are
 * complete: it is not collapsed or collapsed onto any more, and faces whose
 * corners are all settled leave W for the output.
 *
 * Order. Output vertices come in increasing input id, which keeps the
 * input's sort along its axis; each triangle comes right after its last
 * vertex and each vertex is finalized right after its last triangle. A
 * vertex is written once every vertex with a smaller id is decided (kept or
 * collapsed): the slab's frontier and W's unsettled vertices bound that.
 * All of it depends on the slabs alone, never on which worker ran them.
 */
#ifndef EN_PIPELINE_STITCHER_H
#define EN_PIPELINE_STITCHER_H

#include <stdint.h>

#include "common/ctxpool.h"
#include "common/stage.h"
#include "common/u64map.h"
#include "core/collapse.h"
#include "epsnet/epsnet.h"
#include "pipeline/attr_weights.h"
#include "pipeline/slab_work.h"

typedef struct en_stitch_vertex en_stitch_vertex;
typedef struct en_seam_face en_seam_face;
typedef struct en_out_face en_out_face;
typedef struct en_vheap_entry en_vheap_entry;

typedef struct en_stitch_stats {
    uint64_t seam_faces;              /* faces that went through W */
    uint64_t seam_collapses;          /* collapses done in W */
    uint64_t seam_steps;              /* W collapse runs */
    uint64_t band_nonsamples, band_left;   /* input non-samples near a slab border / still in the output */
    uint64_t inner_nonsamples, inner_left; /* the same elsewhere */
    uint64_t remaining_nonsamples;
    uint64_t max_active;              /* largest W + waiting vertices and faces */
    uint64_t out_vertices, out_faces;
} en_stitch_stats;

typedef struct en_stitcher {
    en_stage out;                     /* where the finished records go (its end is the caller's) */
    double max_normal_dev;
    en_stitch_vertex *v;              /* pool of vertices not yet finalized in the output */
    size_t v_len, v_cap;
    uint32_t *free_list;
    size_t free_len, free_cap;
    en_u64map map;                    /* gid -> pool index, for W's vertices */
    uint32_t *wv;                     /* W's vertices (pool indices), in arrival order */
    size_t nwv, wv_cap;
    en_seam_face *wf;                 /* W's faces */
    size_t nwf, wf_cap;
    /* Decided vertices waiting for output, by id: those decided in id
     * order (nearly all) in a run read from vrun_head, the others in a
     * heap; the next out is the smaller front. */
    en_vheap_entry *vrun;
    size_t vrun_head, nvrun, vrun_cap;
    en_vheap_entry *vheap;
    size_t nvheap, vheap_cap;
    /* Final faces waiting for their last vertex (the corner with the
     * highest id), listed at that vertex in arrival order (first_face):
     * slots of fpool, the free ones stacked in ffree. */
    en_out_face *fpool;
    size_t fpool_len, fpool_cap;
    uint32_t *ffree;
    size_t nffree, ffree_cap;
    uint64_t nfwait;
    uint64_t next_out;
    uint64_t frontier;                /* output waits for this input id (UINT64_MAX: for nothing) */
    uint32_t *local;                  /* scratch: slab local id -> pool index */
    size_t local_cap;
    en_slab ws;                       /* scratch for W's collapses */
    /* The pass's plan when it has seams to rule (pipeline/pass_plan.h;
     * NULL: the ε-net pass, whose seams lose every non-sample they can):
     * W's collapses go cheapest first and stop where its seam rule says;
     * under a priced plan samples leave marked (write_quadrics). Read
     * only, set before the first take; the fields below are the take
     * jobs' (one at a time). */
    const en_pass_plan *plan;
    uint32_t takes;                   /* slabs taken */
    uint64_t taken;                   /* plan units the slabs taken so far brought */
    uint64_t faces_final;             /* faces that left W, or never entered it, for the output */
    uint64_t decided;                 /* vertices decided (kept) */
    uint64_t given_up;                /* samples collapsed in W (samples_may_go) */
    /* EN_SEAMS_LEVEL: the level the two newest slabs' counts
     * stopped their collapses at (en_slab_work.level); W collapses below
     * the lower of them, as those slabs did (0: price only). */
    double level_before, seam_level;
    /* A priced plan's: the costs of the collapses W left to do, one count per
     * W vertex as it is written, in its last W run's bucket
     * (en_slab_work.cost_hist has the slabs' own); NULL otherwise. */
    uint64_t *cost_hist;
    /* ... and with the slabs' levels (en_slab_work.level_hist), those of
     * the samples, by level. */
    uint64_t *level_hist;
    /* A plan with count ranges: W's collapses of vertices in them, by
     * level (en_collapse_settings.taken); NULL otherwise. */
    uint64_t *taken_hist;
    /* Vertex attributes: attr_size bytes per pool slot (beside v), from
     * the slab works, into the vertex records it emits. */
    uint32_t attr_size;
    uint8_t *attr;
    size_t attr_cap;
    /* With write_quadrics, each vertex record's bytes end in the carried
     * block (EN_CARRIED_BYTES): its accumulated quadric, at quadric_at, and
     * its marks (a target stage's passes, en_chain_config.quadrics_out). */
    uint32_t quadric_at;
    int write_quadrics;
    /* The attributes weighed (NULL or no channels: none): each pool slot's
     * attribute part (core/attr_quadric.h), na doubles beside v, from the
     * slab works; W's runs work out the values from attr. */
    const en_attr_weights *weights;
    size_t na;
    double *aq;
    size_t aq_cap;
    uint8_t *scratch;                 /* a run over W's arrays, kept from take to take (a worker's
                                       * scratch: not in en_stitcher_bytes, docs/architecture.md §12) */
    size_t scratch_cap;
    en_ctxpool *collapse_arrays;      /* NULL, or the pool W's collapses borrow their arrays from */
    en_stitch_stats stats;
} en_stitcher;

/* @return 0 or EPSNET_ENOMEM. */
int en_stitcher_init(en_stitcher *st, double max_normal_dev, en_stage out);
void en_stitcher_free(en_stitcher *st);

/* Take slab w (simplify mode), in slab order, and emit what became final.
 * @return 0 or a negative code with err filled. */
int en_stitcher_take(en_stitcher *st, const en_slab_work *w, epsnet_error *err);

/* After the last slab: everything must have been emitted (EINTERNAL if not). */
int en_stitcher_finish(en_stitcher *st, epsnet_error *err);

/* After en_stitcher_finish: free the seams' and queues' memory; the
 * counts stay (stats, given_up, cost_hist), and so does the plan. */
void en_stitcher_release(en_stitcher *st);

/* Bytes held by the seams and the output queues (capacities, not just
 * what is in use), for the memory budget. */
/* W's vertices and faces plus the vertices and faces waiting for output:
 * what the stitcher holds (0 once everything is written). */
uint64_t en_stitcher_active(const en_stitcher *st);

uint64_t en_stitcher_bytes(const en_stitcher *st);

#endif
