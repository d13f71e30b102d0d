/*
 * Out-of-core spatial sort of any mesh into a sorted, finalized streaming
 * mesh (SPEC §2 "Input"; epsnet_sort_file() in the public header is the
 * entry point and states the output order). The passes:
 *
 *   1. read        vertices -> a temporary file in input order (and the
 *                  bbox, for the automatic axis); faces -> another
 *   2. order       vertices -> sorter V by (axis coordinate, old id)
 *   3. rank        merge V: the sorted coordinates -> a temporary file, and
 *                  (old id, rank) -> sorter M
 *   4. relabel     each face corner -> sorter C as (old vertex, face, slot);
 *                  merge C against M (both by old id): (face, slot, rank)
 *                  -> sorter J
 *   5. faces       merge J: whole faces in ranks -> sorter F by (last
 *                  corner, face); every corner -> sorter L as (rank, last
 *                  corner of its face)
 *   6. emit        walk the ranks once: a vertex no L item names is dropped;
 *                  otherwise it is written, then the faces whose last corner
 *                  it is, and each vertex is finalized after the last of the
 *                  faces of its largest L value that uses it
 *
 * Only the vertices live in the output stream (its width) and the faces
 * sharing one last corner are ever in memory together, beside the sorters'
 * bounded buffers. When a 32-bit rank and a 32-bit last use per vertex fit
 * in half of the budget, pass 3 fills an array of ranks, pass 5 relabels
 * the faces through it and fills an array of last uses, and pass 4 and
 * sorter L are skipped: the same output with a third of the temporary
 * traffic.
 */
#ifndef EN_SORT_SORT_H
#define EN_SORT_SORT_H

#include "epsnet/epsnet.h"

/* The automatic axis: the longest side of [lo, hi], the earlier axis on a
 * tie. */
int en_sort_longest_axis(const double lo[3], const double hi[3]);

#endif /* EN_SORT_SORT_H */
