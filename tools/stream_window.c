#include "stream_window.h"

#include <stdlib.h>

static uint64_t *ring_at(stream_window *w, uint64_t v)
{
    return &w->slot[v & (w->cap - 1)];
}

static int reserve(stream_window *w, uint64_t need)
{
    if (need <= w->cap)
        return 0;
    uint64_t cap = w->cap ? w->cap : 4096;
    while (cap < need)
        cap *= 2;
    if (w->max_bytes && cap * sizeof *w->slot > w->max_bytes)
        return -1;
    uint64_t *s = calloc(cap, sizeof *s);
    if (!s)
        return -1;
    for (uint64_t v = w->base; v < w->next; v++)
        s[v & (cap - 1)] = *ring_at(w, v);
    free(w->slot);
    w->slot = s;
    w->cap = cap;
    return 0;
}

int sw_add_vertex(stream_window *w)
{
    if (reserve(w, w->next + 1 - w->base))
        return -1;
    *ring_at(w, w->next) = 0;
    w->next++;
    w->live++;
    if (w->live > w->width)
        w->width = w->live;
    if (w->next - w->base > w->span)
        w->span = w->next - w->base;
    return 0;
}

void sw_use(stream_window *w, uint64_t v, uint64_t t)
{
    *ring_at(w, v) = t + 1;
}

uint64_t sw_finalize(stream_window *w, uint64_t v)
{
    uint64_t *s = ring_at(w, v);
    uint64_t was = *s;
    *s = SW_FINALIZED;
    w->live--;
    while (w->base < w->next && *ring_at(w, w->base) == SW_FINALIZED)
        w->base++;
    return was;
}

uint64_t sw_bytes(const stream_window *w)
{
    return w->cap * sizeof *w->slot;
}

void sw_free(stream_window *w)
{
    free(w->slot);
    w->slot = NULL;
    w->cap = 0;
}

int sc_record(stream_check *k, stream_window *w, int streaming, const epsnet_record *rec)
{
    if (rec->kind == EPSNET_REC_VERTEX) {
        for (int a = 0; a < 3; a++) {
            if (k->nv && rec->xyz[a] < k->prev[a])
                k->sorted[a] = 0;
            k->prev[a] = rec->xyz[a];
        }
        k->nv++;
        k->vertex_since_triangle = 1;
        return streaming ? sw_add_vertex(w) : 0;
    }
    if (rec->kind == EPSNET_REC_TRIANGLE) {
        for (int s = 0; s < 3 && streaming; s++)
            sw_use(w, rec->v[s], k->nt);
        k->nt++;
        k->vertex_since_triangle = 0;
        return 0;
    }
    uint64_t was = sw_finalize(w, rec->v[0]);
    k->nfin++;
    if (was == 0)
        k->unused_finalized++;
    else if (was != k->nt || k->vertex_since_triangle)
        k->late++;
    return 0;
}
