/*
 * The seam protocol in one place (docs/architecture.md §8): how the chunker
 * marks faces, how a worker tells the stitcher where each vertex stands, and
 * which collapses any holder of part of the mesh (a slab worker, the
 * stitcher's seam mesh W, a later stage) may do.
 */
#ifndef EN_PIPELINE_SEAM_H
#define EN_PIPELINE_SEAM_H

#include <stdint.h>

#include "core/classify.h"
#include "core/collapse.h"
#include "core/slab.h"
#include "pipeline/pass_plan.h"

/* Face flags, set by the chunker for each face of a slab. */
enum {
    EN_F_INTERIOR = 1 << 0,  /* every corner owned by this slab */
    EN_F_HOME = 1 << 1,      /* every corner owned by this slab or an earlier one:
                              * the last slab that holds the face (its home) */
};

/* Where an owned vertex of a slab stands once the slab's own collapses are
 * done; the worker sets it, the stitcher reads it. */
enum {
    EN_BORDER_INNER = 0,       /* every neighbour owned here: decided here, kept or collapsed */
    EN_BORDER_FROZEN = 1,      /* has a neighbour owned by another slab: left to the stitcher */
    EN_BORDER_RING = 2,        /* inner, next to a frozen vertex: the stitcher tries it again */
    EN_BORDER_OUTER = 3,       /* inner, on a face of a ring or frozen vertex: decided, a corner only */
};

/* What a holder of part of the mesh may do with one of its vertices. */
typedef enum en_vertex_kind {
    EN_VK_FREE,              /* whole star held, undecided, neither sample nor locked */
    EN_VK_SAMPLE,            /* whole star held, undecided, a sample of this pass's ε-net */
    EN_VK_LOCKED,            /* whole star held, undecided, on a boundary, non-manifold or isolated */
    EN_VK_OPEN,              /* some of its faces are held elsewhere or still to come */
    EN_VK_SETTLED,           /* decided by an earlier holder: only a corner of faces here */
    EN_VK_COUNT
} en_vertex_kind;

/*
 * The collapse rule. A half-edge collapse v -> u deletes v, rewrites every
 * face around v onto u, and adds v's quadric to u's. So:
 * - v must be FREE: its whole star is here to be rewritten and checked (link
 *   condition, normal bound, areas, duplicates), nobody has decided it yet,
 *   and it is not one the method keeps (a sample: paper §4.2; a locked
 *   vertex, kept as a sample so that boundaries and non-manifold spots stay).
 * - u must have its whole star here and be undecided, whatever it is
 *   otherwise (FREE, SAMPLE or LOCKED): its star changes, and every face of
 *   it must be seen to be checked. An OPEN u has faces we cannot check; a
 *   SETTLED u may already be on its way to the output.
 * Row: the kind of v; column: the kind of u.
 */
static const uint8_t en_can_collapse[EN_VK_COUNT][EN_VK_COUNT] = {
    /*              FREE SAMPLE LOCKED OPEN SETTLED */
    /* FREE    */ { 1,   1,     1,     0,   0 },
    /* SAMPLE  */ { 0,   0,     0,     0,   0 },
    /* LOCKED  */ { 0,   0,     0,     0,   0 },
    /* OPEN    */ { 0,   0,     0,     0,   0 },
    /* SETTLED */ { 0,   0,     0,     0,   0 },
};

/* The kind of a vertex from what its holder knows of it. locked: its
 * topology (en_seam_locked of its flags); sample: this pass classified it a
 * sample. */
static inline en_vertex_kind en_vertex_kind_of(int star_held, int settled, int locked, int sample)
{
    if (settled)
        return EN_VK_SETTLED;
    if (!star_held)
        return EN_VK_OPEN;
    if (locked)
        return EN_VK_LOCKED;
    return sample ? EN_VK_SAMPLE : EN_VK_FREE;
}

/* Topology that locks a vertex (EN_V_* flags from en_slab_build_stars). */
static inline int en_seam_locked(uint8_t vflags)
{
    return (vflags & (EN_V_BOUNDARY | EN_V_NONMANIFOLD | EN_V_ISOLATED)) != 0;
}

/* May a vertex of this kind be removed (collapsed onto some neighbour)? */
static inline int en_removable(en_vertex_kind k)
{
    for (int u = 0; u < EN_VK_COUNT; u++)
        if (en_can_collapse[k][u])
            return 1;
    return 0;
}

/* May a vertex of this kind receive a collapse? The collapse core takes it
 * as the EN_V_TARGET flag. note: the table is separable (a row test times a
 * column test), which is what lets the core take two per-vertex inputs. */
static inline int en_receives(en_vertex_kind k)
{
    return en_can_collapse[EN_VK_FREE][k];
}

/* A pricing pass's window cut (en_pass_plan.count_ranges): a boundary
 * vertex outside the windows' insides stands for a frozen band of the
 * stream, not a border of the mesh, so it receives no collapse, as no
 * slab's frozen band does, and its samples count for no density. (With
 * margins of a few widths the rule did not move the ceiling priced on
 * `gen bumpy` 20M; the margins of whole slabs did: target_stage.h.) */
static inline int en_cut_end(const en_pass_plan *t, const en_slab *s, uint32_t v)
{
    return t && t->count_nranges && (s->vflags[v] & EN_V_BOUNDARY) &&
           !en_in_ranges(t->count_ranges, t->count_nranges, s->gid[v]);
}

#endif
