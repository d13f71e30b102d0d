/*
 * The live window of a streaming mesh as a reader sees it (docs/architecture.md §6): the
 * vertices read and not yet finalized lie in [base, next); one slot per
 * vertex of that window, in a ring, says whether the vertex is finalized
 * and which triangle used it last. Memory follows the span, not the mesh.
 * Used by `epsnet check` (and its fuzz target, tests/fuzz/fuzz_stream.c);
 * the width/span definitions are those that `epsnet info` prints.
 */
#ifndef EPSNET_TOOLS_STREAM_WINDOW_H
#define EPSNET_TOOLS_STREAM_WINDOW_H

#include <stdint.h>

#include "epsnet/epsnet.h"

typedef struct stream_window {
    uint64_t base;      /* oldest vertex that may still be live */
    uint64_t next;      /* vertices read so far */
    uint64_t live;      /* read and not finalized */
    uint64_t width;     /* most vertices live at once */
    uint64_t span;      /* largest next - base */
    uint64_t *slot;     /* ring: SW_FINALIZED, or 1 + last triangle using it, 0 = unused */
    uint64_t cap;       /* power of two */
    uint64_t max_bytes; /* 0 = no limit */
} stream_window;

#define SW_FINALIZED UINT64_MAX

/* @return 0, or -1 when the window would exceed max_bytes or memory runs out. */
int sw_add_vertex(stream_window *w);
/* Record that triangle t (0-based) uses vertex v (which must be live). */
void sw_use(stream_window *w, uint64_t v, uint64_t t);
/* Finalize v; @return the slot value it had (0 = never used). */
uint64_t sw_finalize(stream_window *w, uint64_t v);
uint64_t sw_bytes(const stream_window *w);
void sw_free(stream_window *w);

/* What `epsnet check` counts over the records of a stream. */
typedef struct stream_check {
    uint64_t nv, nt, nfin;
    uint64_t late;              /* finalized, but not right after the last triangle using it */
    uint64_t unused_finalized;  /* finalized without any triangle using it */
    double prev[3];
    int sorted[3];              /* start at 1: still sorted along x, y, z */
    int vertex_since_triangle;
} stream_check;

/* Count one record; a streaming input also moves the window w.
 * @return 0, or -1 when the window goes over its budget (w->max_bytes). */
int sc_record(stream_check *k, stream_window *w, int streaming, const epsnet_record *rec);

#endif
