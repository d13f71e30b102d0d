/*
 * Vertex normals recomputed from the output's faces (--drop-normals,
 * docs/architecture.md §13): a stage between the last pass and the writer
 * that gives every vertex record three more float32 attributes, nx, ny, nz,
 * the unit sum of its faces' area-weighted normals (0, 0, 0 when they
 * cancel or there are none). The records of one position (the copies at a
 * UV seam or a material border: docs/method.md §6) get one normal, the sum
 * over all their faces: the copies split what the texture or the material
 * needs, not the surface, and a writer can weld them again (a PLY's face
 * values: docs/architecture.md §13).
 *
 * A vertex's faces are all known only when it is finalized, which in a
 * stream comes after them; so the stage holds each vertex from its record
 * to its finalization, writes vertices in their input order (a sorted
 * stream stays sorted, and the ids do not change), each face once its last
 * corner is written, and each finalization once the vertex's faces are; a
 * vertex waits, too, for the copies of its position that arrived before it
 * is written (a copy that comes after that gets a normal of its own). It
 * holds what the stream's window holds, not the mesh.
 */
#ifndef EN_PIPELINE_NORMALS_STAGE_H
#define EN_PIPELINE_NORMALS_STAGE_H

#include <stdint.h>

#include "common/stage.h"
#include "epsnet/epsnet.h"

typedef struct en_normals_stage en_normals_stage;

/* in_attr_size: the bytes of each vertex record coming in; the records
 * going to next have 12 more (nx, ny, nz, float32) after them.
 * @return 0 or EPSNET_ENOMEM (err filled). */
int en_normals_stage_new(en_normals_stage **out, uint32_t in_attr_size, en_stage next, epsnet_error *err);
en_stage en_normals_stage_input(en_normals_stage *ns);
void en_normals_stage_free(en_normals_stage **ns);

/* The layout the records leaving the stage have: in's, then nx, ny, nz.
 * @return 0, or -1 when there is no room for three more attributes or in
 * has one of those names. */
int en_normals_layout(const epsnet_attr_layout *in, epsnet_attr_layout *out);

#endif /* EN_PIPELINE_NORMALS_STAGE_H */
