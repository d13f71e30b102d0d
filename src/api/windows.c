#include "api/windows.h"

#include <string.h>

#include "common/alloc.h"
#include "common/error.h"

struct en_windows {
    en_window_backend b;
    uint64_t lo[EN_PRICE_WINDOWS], hi[EN_PRICE_WINDOWS];
    uint64_t margin;                       /* ids of each margin */
    /* ids either side of an inside that complete its vertices' stars:
     * twice the stream's width (a vertex's neighbours are about one width
     * from it along the stream), at most the margin */
    uint64_t ring;
    uint64_t inside[2 * EN_PRICE_WINDOWS]; /* en_window_source.inside */
    uint64_t inside_alone[2 * EN_PRICE_WINDOWS]; /* en_window_source.inside_alone */
};

static int push(void *opaque, uint32_t w, int inside, uint64_t base, en_stage *into, uint64_t *pushed,
                epsnet_error *err)
{
    en_windows *x = opaque;
    uint64_t m = inside ? x->margin - x->ring : 0;
    return x->b.walk(x->b.opaque, x->lo[w] + m, x->hi[w] - m, base, into, pushed, NULL, err);
}

/* The middle of window w on a stream of total ids: 1/8, 3/8, 5/8, 7/8. */
static uint64_t window_mid(uint64_t total, uint32_t w)
{
    return (2 * (uint64_t)w + 1) * total / (2 * EN_PRICE_WINDOWS);
}

/* The stretch the width is measured on, for slabs of slab_vertices: long
 * enough that its two cuts are two rings of it, not all. */
static uint64_t width_stretch(uint64_t slab_vertices)
{
    return 4 * slab_vertices > 4096 ? 4 * slab_vertices : 4096;
}

/* The stretch of n ids around mid, within the stream. */
static void place(uint64_t total, uint64_t mid, uint64_t n, uint64_t *lo, uint64_t *hi)
{
    *lo = mid > n / 2 ? mid - n / 2 : 0;
    *hi = *lo + n < total ? *lo + n : total;
}

int en_windows_open(en_windows **out, const en_window_backend *b, uint64_t slab_vertices, double margin_widths,
                    en_window_source *src, epsnet_error *err)
{
    *out = NULL;
    memset(src, 0, sizeof *src);
    /* a window is at least three slabs (the inside and a margin each
     * side): a stream too short for them is not read at all */
    uint64_t total = b->vertices;
    if (!slab_vertices || (double)EN_PRICE_WINDOWS * 3.0 * (double)slab_vertices > EN_PRICE_MAX_SHARE * (double)total)
        return 0;
    /* the stream's width at its middle: half the vertices on the two cuts
     * of a stretch long enough that they are two rings of it, not all */
    uint64_t len = width_stretch(slab_vertices), lo, hi, n = 0, width = 0;
    place(total, total / 2, len < total / 2 ? len : total / 2, &lo, &hi);
    int rc = b->walk(b->opaque, lo, hi, 0, NULL, &n, &width, err);
    if (rc)
        return rc == EPSNET_EFORMAT ? 0 : rc;
    width /= 2;
    if ((double)slab_vertices < EN_PRICE_SLAB_WIDTHS * (double)width)
        return 0;
    uint64_t margin = slab_vertices;
    while ((double)margin < margin_widths * (double)width)
        margin += slab_vertices;
    uint64_t len_w = slab_vertices + 2 * margin;
    if ((double)EN_PRICE_WINDOWS * (double)len_w > EN_PRICE_MAX_SHARE * (double)total)
        return 0;
    en_windows *x = en_calloc(1, sizeof *x);
    if (!x)
        return en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    x->b = *b;
    x->margin = margin;
    x->ring = 2 * width < margin ? 2 * width : margin;
    /* the insides, numbered as the windows push their vertices (a backend
     * may push fewer than it spans: a sort drops the vertices no face uses) */
    uint64_t base = 0, base_alone = 0;
    for (uint32_t w = 0; w < EN_PRICE_WINDOWS && rc == 0; w++) {
        place(total, window_mid(total, w), len_w, &x->lo[w], &x->hi[w]);
        uint64_t in_lo = x->lo[w] + margin, in_hi = x->hi[w] - margin;
        /* counts only: a .smz answers them from the ids, without reading */
        uint64_t before = 0, inside = 0, after = 0, ring_before = 0, ring_after = 0;
        if ((rc = b->walk(b->opaque, x->lo[w], in_lo, 0, NULL, &before, NULL, err)) == 0 &&
            (rc = b->walk(b->opaque, in_lo, in_hi, 0, NULL, &inside, NULL, err)) == 0 &&
            (rc = b->walk(b->opaque, in_hi, x->hi[w], 0, NULL, &after, NULL, err)) == 0 &&
            (rc = b->walk(b->opaque, in_lo - x->ring, in_lo, 0, NULL, &ring_before, NULL, err)) == 0)
            rc = b->walk(b->opaque, in_hi, in_hi + x->ring, 0, NULL, &ring_after, NULL, err);
        x->inside[2 * w] = base + before;
        x->inside[2 * w + 1] = base + before + inside;
        x->inside_alone[2 * w] = base_alone + ring_before;
        x->inside_alone[2 * w + 1] = base_alone + ring_before + inside;
        src->inside_vertices += inside;
        src->vertices += before + inside + after;
        src->inside_ring_vertices += ring_before + inside + ring_after;
        base += before + inside + after;
        base_alone += ring_before + inside + ring_after;
    }
    if (rc || !src->inside_vertices) {
        en_free(x);
        memset(src, 0, sizeof *src);
        return rc == EPSNET_EFORMAT ? 0 : rc;
    }
    src->windows = EN_PRICE_WINDOWS;
    src->inside = x->inside;
    src->inside_alone = x->inside_alone;
    src->push = push;
    src->opaque = x;
    *out = x;
    return 0;
}

/* The stretch of n ids around mid as place() puts them, with a margin of
 * two ids for the roundings. */
static void around(uint64_t total, uint64_t mid, uint64_t n, uint64_t *lo, uint64_t *hi)
{
    place(total, mid, n + 4, lo, hi);
}

uint32_t en_windows_stretches(uint64_t total, uint64_t *lo, uint64_t *hi)
{
    /* en_windows_open() measures the width only where windows of three
     * slabs fit EN_PRICE_MAX_SHARE, so with slabs of at most max_slab; a
     * window is at most EN_PRICE_MAX_SHARE / EN_PRICE_WINDOWS of the stream */
    uint64_t max_slab = (uint64_t)(EN_PRICE_MAX_SHARE * (double)total / (3.0 * EN_PRICE_WINDOWS));
    uint64_t mid_len = width_stretch(max_slab);
    uint64_t win_len = (uint64_t)(EN_PRICE_MAX_SHARE * (double)total / EN_PRICE_WINDOWS);
    around(total, total / 2, mid_len < total / 2 ? mid_len : total / 2, &lo[0], &hi[0]);
    for (uint32_t w = 0; w < EN_PRICE_WINDOWS; w++)
        around(total, window_mid(total, w), win_len, &lo[w + 1], &hi[w + 1]);
    return EN_PRICE_WINDOWS + 1;
}

void en_windows_close(en_windows **w)
{
    en_free(*w);
    *w = NULL;
}
