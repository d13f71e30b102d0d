/*
 * Closest point on a triangle mesh: the exact point-to-triangle routine and a
 * bounding-volume hierarchy over triangles that answers nearest-triangle
 * queries with pruning (used by the Metro-style error of hausdorff.h).
 *
 * The hierarchy is a linear BVH: triangles are ordered along the Morton curve
 * of their centroids and a node is split at the highest Morton bit on which
 * its triangles differ (at the middle when they all share one code). Building
 * is O(n log n) at worst (a radix sort, then O(n) per level, and the depth is
 * at most 64 bit splits plus log2(n) middle splits), whatever the input.
 */
#ifndef EN_METRICS_BVH_H
#define EN_METRICS_BVH_H

#include <stddef.h>
#include <stdint.h>

/*
 * A triangle is degenerate (zero area: a segment or a point) when its cross
 * product is negligible against its edge lengths: |n|^2 <= 1e-24 * l^4 with l
 * its longest edge, i.e. its smallest angle is below about 1e-12 radians.
 * Such a triangle is measured as the union of its three edges. Coordinates
 * must stay within 1e75 in magnitude so that l^4 does not overflow.
 */
int en_tri_is_degenerate(const double a[3], const double b[3], const double c[3]);

/*
 * Closest point q on triangle abc to p; degenerate triangles (see above) are
 * handled as their edges, so a zero-area triangle is a segment or a point,
 * never "everywhere". @return |p - q|^2.
 */
double en_closest_on_triangle(const double p[3], const double a[3], const double b[3],
                              const double c[3], double q[3]);

/* Closest point q on segment ab to p (a == b allowed). @return |p - q|^2. */
double en_closest_on_segment(const double p[3], const double a[3], const double b[3], double q[3]);

typedef struct en_bvh_node {
    float lo[3], hi[3];   /* rounded outward from the double coordinates */
    uint32_t first;   /* leaf: first slot in en_bvh.order; inner: index of the left child */
    uint32_t count;   /* leaf: number of triangles (>= 1); inner: 0, right child = first + 1 */
} en_bvh_node;

typedef struct en_bvh {
    const double *xyz;    /* borrowed: 3 per vertex */
    const uint32_t *tri;  /* borrowed: 3 vertex ids per triangle */
    uint32_t nt;
    uint32_t nnodes;
    en_bvh_node *nodes;   /* nodes[0] is the root when nt > 0 */
    uint32_t *order;      /* triangle id of each slot (leaf order, i.e. Morton order): nt */
    double *packed;       /* 9 per slot: the triangle's corners, copied */
    uint8_t *degenerate;  /* per slot: en_tri_is_degenerate() */
} en_bvh;

/*
 * Build the hierarchy over nt triangles. xyz and tri are borrowed and must
 * outlive the hierarchy; indices must be valid (the caller checks them).
 * @return 0, or -1 when out of memory (bvh is then empty and needs no free).
 */
int en_bvh_build(en_bvh *bvh, const double *xyz, const uint32_t *tri, uint32_t nt);

void en_bvh_free(en_bvh *bvh);

/*
 * The answer to a nearest-triangle query.
 *
 * d2 and point are the exact minimum over all triangles (pruning never
 * discards a triangle that could be closer). face is a nearest triangle;
 * when several triangles lie within a rounding tolerance of the minimum (the
 * point projects onto a shared edge or vertex), and a preferred direction was
 * given, face is the non-degenerate one whose unit normal is closest to that
 * direction, so that the normal of the surface at an edge is the one that
 * agrees best with the sample (the normal cone's nearest member).
 */
typedef struct en_bvh_hit {
    double d2;
    double point[3];
    uint32_t face;
    double face_dot;      /* dot(prefer, unit normal of face); -2 when none */
    uint32_t slot;        /* where the nearest triangle sits: the hint of a next query */
} en_bvh_hit;

/*
 * Nearest triangle to p. hint is the slot of a previous answer to start from
 * (in a coherent sequence of queries it is nearly right), or UINT32_MAX. prefer is a unit
 * direction for the tie rule above, or NULL. tie_dist is how much farther
 * than the nearest a triangle may be and still tie (e.g. 1e-10 * diagonal).
 * @return 0, or -1 when the hierarchy is empty.
 */
int en_bvh_nearest(const en_bvh *bvh, const double p[3], uint32_t hint, const double *prefer,
                   double tie_dist, en_bvh_hit *hit);

#endif /* EN_METRICS_BVH_H */
