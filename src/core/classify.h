/*
 * Vertex classification on a slab (paper §4, docs/method.md §8): face normals into
 * G's frame, face -> Gaussian triangle, candidates (vertices on a feature
 * edge), and the exact sample rule: a vertex is a sample iff the spherical
 * polygon of its face normals has a non-zero winding number about a vertex of
 * G. Boundary and non-manifold vertices are locked as samples; isolated
 * (unreferenced) vertices are not on the surface and are neither.
 *
 * Work is split into index ranges so the worker pool can share one slab;
 * every function writes only the entries of its range.
 */
#ifndef EN_CORE_CLASSIFY_H
#define EN_CORE_CLASSIFY_H

#include <stdint.h>

#include "core/gauss.h"
#include "core/slab.h"

/* Per-vertex classification bits. */
enum {
    EN_C_CANDIDATE = 1 << 0, /* touches a feature edge (paper Definition 5) */
    EN_C_SAMPLE = 1 << 1,    /* kept: winding != 0, needle, or locked */
    EN_C_LOCKED = 1 << 2,    /* boundary / non-manifold (docs/method.md §6) */
    EN_C_NEEDLE = 1 << 3,    /* normals not in an open hemisphere */
    EN_C_MULTI = 1 << 4,     /* encloses more than one Gaussian vertex */
    EN_C_USER = 1 << 5,      /* with EN_C_LOCKED: locked by the user (settings.lock_property) */
};

typedef struct en_classify_counts {
    uint64_t zero_area_faces;
    uint64_t feature_edges;
    uint64_t candidates;
    uint64_t samples;
    uint64_t locked;
    uint64_t boundary;
    uint64_t nonmanifold;
    uint64_t seam;      /* copies of a seam pair (EN_V_SEAM), classified as the surface they stand for */
    uint64_t cut_ends;  /* of the boundary vertices, those sharing their position with other copies (a seam's end) */
    uint64_t needles;
    uint64_t multi_cover;
    uint64_t unverified_hemisphere; /* see gauss_in_open_hemisphere() */
    uint64_t isolated;
} en_classify_counts;

/*
 * Faces [f0, f1): frame normal (3 doubles, zero for a zero-area face) and
 * Gaussian triangle (-1 for a zero-area face), from en_triangle_normal().
 * @return 0, EPSNET_EFORMAT when a normal overflows, or EPSNET_EINTERNAL if
 * point location fails (a bug); *bad_face is set on failure.
 */
int en_classify_faces(const gauss_sphere *g, const en_slab *s, uint32_t f0, uint32_t f1,
                      double *fnormal, int32_t *ftri, en_classify_counts *counts, uint32_t *bad_face);

/*
 * Owned vertices in [v0, v1): classification bits and the smallest Gaussian
 * vertex id each sample encloses (-1 for non-samples, locked vertices and
 * needles). Needs en_slab_build_stars() and en_classify_faces() for every
 * face around those vertices. @return 0 or EPSNET_ENOMEM (scratch).
 */
int en_classify_vertices(const gauss_sphere *g, const en_slab *s, const double *fnormal,
                         const int32_t *ftri, uint32_t v0, uint32_t v1, uint8_t *vclass,
                         int32_t *vgvertex, en_classify_counts *counts);

/*
 * en_classify_vertices(), and for each sample the halvings of G it stays a
 * sample through: vlevel[v] = j means v is a sample at every frequency
 * n / 2^i, i <= j, that is whole (G at n / 2^i is a subset of G: its
 * vertices are the lattice points of G divisible by 2^i, and the sample
 * rule is a winding number about a vertex, so a sample there is a sample
 * here). Locked vertices and needles are samples at every frequency
 * (EN_LEVEL_ALL). vlevel is written for samples only.
 */
#define EN_LEVEL_ALL 255
int en_classify_vertices_levels(const gauss_sphere *g, const en_slab *s, const double *fnormal,
                                const int32_t *ftri, uint32_t v0, uint32_t v1, uint8_t *vclass,
                                int32_t *vgvertex, uint8_t *vlevel, en_classify_counts *counts);

void en_classify_counts_add(en_classify_counts *into, const en_classify_counts *c);

#endif
