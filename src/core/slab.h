/*
 * The per-slab mesh: the unit of work of the whole pipeline (docs/architecture.md §8). A slab
 * is a piece of the mesh with global vertex ids; it *owns* the vertices whose
 * classification and collapses it is responsible for and holds *ghost*
 * vertices (and the faces around its owned vertices) as read-only context.
 * A whole-mesh, in-core run is the one-slab case: every vertex owned.
 *
 * Everything is explicit arrays indexed by local ids (uint32: a slab is far
 * smaller than 4G vertices by construction); no globals, no hidden state.
 */
#ifndef EN_CORE_SLAB_H
#define EN_CORE_SLAB_H

#include <stddef.h>
#include <stdint.h>

#include "common/u64set.h"
#include "epsnet/epsnet.h"

enum {
    EN_V_OWNED = 1 << 0,      /* classified (and later simplified) by this slab */
    EN_V_TARGET = 1 << 4,     /* may receive a collapse: its whole star is here and undecided
                               * (the holder's seam rules decide: pipeline/seam.h) */
    EN_V_BOUNDARY = 1 << 1,   /* on an open boundary: locked (docs/method.md §6) */
    EN_V_NONMANIFOLD = 1 << 2,/* star is not one fan: locked (docs/method.md §6) */
    EN_V_ISOLATED = 1 << 3,   /* referenced by no face */
    EN_V_SKELETON = 1 << 5,   /* a skeleton sample of an earlier pass (docs/method.md §13) */
    EN_V_SEAM = 1 << 6,       /* one of two copies of a position along a seam (en_slab.wedge):
                               * open as a record, inside the surface (docs/method.md §6) */
};

typedef struct en_slab {
    uint32_t nv, nt;
    uint32_t cap_v, cap_t;
    uint64_t *gid;            /* global vertex id, per local vertex */
    double *pos;              /* 3 per local vertex, bit-exact input coordinates */
    uint8_t *vflags;          /* EN_V_* */
    uint32_t *tri;            /* 3 local vertex ids per face, counter-clockwise */

    /* Vertex -> incident faces (CSR), built by en_slab_build_stars(); for
     * manifold vertices the faces of a star are in rotational order
     * (counter-clockwise seen from outside), starting, for a boundary
     * vertex, at the face whose edge (v, next) is on the boundary. */
    uint32_t *star_start;     /* nv + 1 */
    uint32_t *star;           /* 3 * nt */
    uint32_t *star_fill;      /* scratch of en_slab_build_stars, nv */
    size_t cap_star_start, cap_star, cap_star_fill; /* kept across en_slab_reset */

    /* Seams (docs/method.md §6), found by en_slab_build_stars() among the
     * owned boundary vertices: when has_welds, wedge[v] is the next of the
     * owned boundary vertices at v's exact coordinates, in a cycle (v
     * itself for every other vertex); for one of a seam pair (EN_V_SEAM) it is
     * the other copy. Without has_welds it is not filled: no two boundary
     * vertices share a position. */
    int has_welds;
    uint32_t *wedge;
    size_t cap_wedge;
    /* scratch of the seams' search, kept across en_slab_reset: the owned
     * boundary vertices and a set of their positions' hashes */
    struct en_by_position *by_position;
    size_t cap_by_position;
    en_u64set *positions;
} en_slab;

void en_slab_init(en_slab *s);
void en_slab_free(en_slab *s);
/* Forget the contents, keep the memory (slabs are reused between jobs). */
void en_slab_reset(en_slab *s);

/* @return the new local id, or -1 when out of memory / over 2^32-2 vertices. */
int64_t en_slab_add_vertex(en_slab *s, uint64_t gid, const double xyz[3], uint8_t flags);
/* @return 0, or -1 when out of memory. Local ids must exist. */
int en_slab_add_face(en_slab *s, uint32_t a, uint32_t b, uint32_t c);
/* nv vertices and nt faces, their contents to be filled by the caller (a
 * slab's input received whole, pipeline/peers.c). @return 0, or -1 when
 * out of memory / over the limits above. */
int en_slab_resize(en_slab *s, uint32_t nv, uint32_t nt);

/*
 * Build the stars of all vertices, order them rotationally and flag boundary,
 * non-manifold and isolated vertices. Faces that repeat a corner do not make
 * a vertex non-manifold by themselves; they are ordered like any face.
 *
 * Then the seams: a mesh cut open where its corners' attributes differ (a UV
 * or normal seam, a change of material: docs/architecture.md §13) has two
 * boundary vertices at each position along the cut. Two owned boundary
 * vertices, alone at their exact coordinates, whose open edges lead to the
 * same positions in opposite directions (the two sides of one surface, as
 * meshoptimizer's seam vertices are) become a seam pair: EN_V_SEAM
 * instead of EN_V_BOUNDARY, each the other's wedge[]. A cut's end, where
 * three copies meet or a seam meets a true boundary, stays a boundary.
 * @return 0, or -1 when out of memory.
 */
int en_slab_build_stars(en_slab *s);

/*
 * Normal (not normalised) of the triangle t over positions pos: the double
 * cross product taken from the corner with the smallest coordinates, so it
 * does not depend on which corner a file lists first. A zero result is what
 * "zero-area face" means everywhere (docs/method.md §5: such faces have no normal).
 */
void en_triangle_normal(const double *pos, const uint32_t t[3], double n[3]);

static inline uint32_t en_slab_degree(const en_slab *s, uint32_t v)
{
    return s->star_start[v + 1] - s->star_start[v];
}

/*
 * Read a whole mesh into a one-slab slab (every vertex owned and complete).
 * Unreferenced vertices are kept (local ids equal global ids). path names
 * the input in messages. @return 0 or a negative code with err filled
 * (ELIMIT past 2^32-2 vertices, ENOMEM).
 */
int en_slab_read(en_slab *s, epsnet_reader *r, const char *path, epsnet_error *err);

/* en_slab_read() and then en_slab_build_stars(). */
int en_slab_read_all(en_slab *s, epsnet_reader *r, const char *path, epsnet_error *err);

#endif /* EN_CORE_SLAB_H */
