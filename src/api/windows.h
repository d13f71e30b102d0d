/*
 * A size's pricing windows (pipeline/target_stage.h: en_window_source,
 * docs/architecture.md §7) over any stream that can be read in stretches:
 * where they go along it, how long they are, and what of them the pricing
 * pass counts. The stretches come from a backend: a sorted .smz through
 * its block index (api/smz_windows.h), or a sort that ran in memory
 * (sort/sort.h: en_sort_window).
 */
#ifndef EN_API_WINDOWS_H
#define EN_API_WINDOWS_H

#include <stdint.h>

#include "common/stage.h"
#include "epsnet/epsnet.h"
#include "pipeline/target_stage.h"

typedef struct en_window_backend {
    uint64_t vertices;            /* ids 0 .. vertices - 1 along the stream */
    /* Push the stretch of ids [lo, hi) into `into` (NULL: only count) as a
     * mesh of its own, its vertices numbered from base, a face with a
     * corner outside it left out, every vertex finalized by its end; add
     * how many vertices it pushed to *pushed and how many of them are on
     * a face left out to *cut (cut NULL: not counted; with into NULL too,
     * a backend that pushes every id of the stretch counts without reading
     * it). @return 0, EPSNET_EFORMAT for what does not
     * read (the stream's reader reports it where it is), or a negative
     * code with err filled. */
    int (*walk)(void *opaque, uint64_t lo, uint64_t hi, uint64_t base, en_stage *into, uint64_t *pushed,
                uint64_t *cut, epsnet_error *err);
    void *opaque;
} en_window_backend;

typedef struct en_windows en_windows;

/*
 * EN_PRICE_WINDOWS windows over b for slabs of slab_vertices: each a slab
 * (the inside the pass counts) between margins of whole slabs at least
 * margin_widths times the stream's width at its middle, at 1/8, 3/8, 5/8
 * and 7/8 along it. *w is NULL, and src has no windows, when the stream is
 * too wide for its slabs (under EN_PRICE_SLAB_WIDTHS widths) or too short
 * (windows over EN_PRICE_MAX_SHARE of it), or its middle does not read.
 * src stays valid while *w is open. @return 0, or a negative code with
 * err filled (out of memory).
 */
int en_windows_open(en_windows **w, const en_window_backend *b, uint64_t slab_vertices, double margin_widths,
                    en_window_source *src, epsnet_error *err);
/* Every stretch of ids en_windows_open() may walk on a stream of total ids,
 * whatever the slabs and margins (en_sort_stretches_fn: what an external
 * sort keeps for them): the middle one the width is measured on and each
 * window, at their longest. @return how many (at most EN_PRICE_WINDOWS + 1). */
uint32_t en_windows_stretches(uint64_t total, uint64_t *lo, uint64_t *hi);
void en_windows_close(en_windows **w);

#endif
