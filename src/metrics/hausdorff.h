/*
 * The Metro-style error between two in-memory meshes (include/epsnet/epsnet.h
 * §10 states what is sampled, how it is weighted and what is reported).
 */
#ifndef EN_METRICS_HAUSDORFF_H
#define EN_METRICS_HAUSDORFF_H

#include <stdint.h>

#include "epsnet/epsnet.h"

/* An indexed triangle mesh, borrowed: indices must be < nv, coordinates
 * finite and within 1e75 in magnitude (see en_tri_is_degenerate()). */
typedef struct en_hd_mesh {
    const double *xyz;     /* 3 per vertex */
    uint32_t nv;
    const uint32_t *tri;   /* 3 per triangle */
    uint32_t nt;
} en_hd_mesh;

/*
 * Measure a against b and b against a. s may be NULL for defaults; its
 * thread count changes the speed, never the numbers.
 * @return 0 with *out filled; EPSNET_EINVAL for settings out of range or
 * when exactly one mesh has no faces; EPSNET_ENOMEM.
 */
int en_hausdorff(const en_hd_mesh *a, const en_hd_mesh *b, const epsnet_hausdorff_settings *s,
                 epsnet_hausdorff_result *out);

#endif /* EN_METRICS_HAUSDORFF_H */
