/*
 * PLY output of a classification (docs/architecture.md §13): either a point
 * set of the samples, each with the id of the Gaussian vertex it covers and a
 * colour per id, or the whole mesh with a per-vertex sample flag and colour
 * for viewing in MeshLab.
 */
#ifndef EN_IO_SAMPLES_PLY_H
#define EN_IO_SAMPLES_PLY_H

#include <stdint.h>

#include "epsnet/epsnet.h"

/* Colour of Gaussian vertex id (stable, well spread hues); grey for -1. */
void en_gvertex_colour(int32_t id, uint8_t rgb[3]);

/*
 * Write the point set: the vertices v with is_sample[v] != 0.
 * pos: 3 doubles per vertex; gvertex: id per vertex (-1 none).
 * @return 0 or a negative code with err filled (nothing left at path).
 */
int en_write_sample_points(const char *path, int ascii, epsnet_coord_type ct, uint64_t nv,
                           const double *pos, const uint8_t *is_sample, const int32_t *gvertex,
                           epsnet_error *err);

/* Write the whole mesh with `sample`, `gvertex` and colour per vertex. */
int en_write_sample_mesh(const char *path, int ascii, epsnet_coord_type ct, uint64_t nv,
                         const double *pos, const uint8_t *is_sample, const int32_t *gvertex,
                         uint64_t nt, const uint32_t *tri, epsnet_error *err);

#endif
