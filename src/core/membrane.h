/*
 * Membranes: zero-volume double sheets (docs/method.md §13, "Membranes").
 *
 * Two faces on the same three corners with opposite orientations are the
 * two sides of one sheet: as an oriented surface they cancel, so the solid
 * the mesh bounds is the same with or without them. Scans reconstructed
 * from volumes (the dragon's fins and folded patches) carry many, glued to
 * the surface along edges of four faces, which makes every corner
 * non-manifold and locks it (docs/method.md §6). Only the target stage
 * removes them; the ε-net pass keeps every face.
 */
#ifndef EN_CORE_MEMBRANE_H
#define EN_CORE_MEMBRANE_H

#include <stdint.h>

#include "core/slab.h"

/*
 * Mark in drop[] (nt bytes, overwritten) the faces of the glued membranes
 * of s: every face that pairs with a face on the same corners and of the
 * opposite orientation (in a group of such faces, the lowest-numbered ones
 * of each orientation pair up, as many as the scarcer orientation has), in
 * a sheet (pairs joined by edges) that shares an edge with some other face.
 * A sheet that touches no other face is a component of its own and stays,
 * as a collapse would never remove a component; so does a sheet with an
 * edge that one other face only would be left on: that face would get a
 * boundary, so the sheet is part of the surface (a surface face doubled by
 * its reverse). Faces that repeat a corner are never membranes. With
 * fflags, a sheet goes only when every face of it has all the bits of need
 * (a slab drops only what no other slab holds).
 * Needs the stars of s and their flags (en_slab_build_stars), an owned
 * vertex's star whole (slab.h: EN_V_OWNED). Deterministic: it depends on
 * the faces and their order only.
 * @return the number of faces marked, or -1 when out of memory.
 */
int64_t en_find_membranes(const en_slab *s, const uint8_t *fflags, uint8_t need, uint8_t *drop);

#endif
