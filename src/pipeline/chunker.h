/*
 * The chunker (docs/architecture.md §8): cuts a finalized streaming mesh into slabs.
 *
 * Slab k owns the next vertices to be finalized, in stream order, and gets
 * every face around them (the faces are all read by then, since a vertex
 * is finalized after its last face), with the faces' other corners as
 * ghosts. It owns slab_vertices; or, with hold_all, what the slab before's
 * ghosts left of slab_vertices, so that a slab holds about slab_vertices in
 * all however wide the stream (and owns at least a quarter of it). So cuts
 * depend only on the stream and those settings, never on the thread
 * count, and every owned vertex has its whole star.
 *
 * Memory is the active set of the stream (paper Table 3): live vertices and
 * the faces that still have a corner not owned by a cut slab. Vertices still
 * live at the end of the stream are finalized there, in id order, into one
 * last slab: a stream without finalization (an ordinary PLY) is the
 * one-slab, in-core case of the same code.
 */
#ifndef EN_PIPELINE_CHUNKER_H
#define EN_PIPELINE_CHUNKER_H

#include <stdint.h>

#include "common/ctxpool.h"
#include "common/idmap.h"
#include "common/u64map.h"
#include "epsnet/epsnet.h"
#include "pipeline/slab_work.h"

typedef struct en_chunk_vertex {
    uint64_t gid;
    double xyz[3];
    uint32_t nref;        /* live faces using it */
    uint32_t local;       /* its local id in the slab being cut ... */
    int64_t local_slab;   /* ... valid when this equals that slab's index */
    int64_t owner;        /* owning slab; EN_OWNER_LIVE / EN_OWNER_FINAL before its cut */
    uint8_t skeleton;     /* its record's marks held EN_MARK_SKELETON (with mark_at) */
} en_chunk_vertex;

#define EN_OWNER_LIVE (-1)
#define EN_OWNER_FINAL (-2)

typedef struct en_chunker {
    uint32_t slab_vertices;    /* vertices a slab owns, at most */
    int hold_all;              /* a slab holds about slab_vertices in all, its ghosts included */
    uint32_t owns;             /* vertices the next slab owns (next_owns in chunker.c) */
    uint32_t mark_at;          /* where a vertex record's attribute bytes hold its marks
                                * (EN_CARRIED_MARKS_AT), whose EN_MARK_SKELETON becomes
                                * EN_V_SKELETON; UINT32_MAX: nowhere (the default) */
    int mark_level;            /* a mark is the skeleton at this level or below (EN_MARK_LEVEL_SHIFT) */
    int cut_last;              /* the end always cuts a last slab (empty if need be): a streamed
                                * target's stitcher aims its last take at the target */
    uint32_t attr_size;        /* vertex attribute bytes per record (0: none) */
    uint8_t *attr;             /* attr_size bytes per pool slot, beside v */
    size_t attr_cap;           /* slots */
    const char *path;          /* for messages, may be NULL */
    en_chunk_vertex *v;        /* pool, reused through free_list */
    size_t v_len, v_cap;
    uint32_t *free_list;
    size_t free_len, free_cap;
    en_idmap map;              /* gid -> pool index, for vertices in the pool */
    uint32_t *faces;           /* live faces: 3 pool indices each, in stream order */
    size_t nfaces, faces_cap;
    uint32_t *fin;             /* finalized, not yet cut (pool indices) */
    size_t nfin, fin_cap;
    uint64_t next_gid;         /* vertices read */
    uint64_t low;              /* every gid below was owned by a cut slab */
    uint64_t records;          /* for messages */
    uint32_t next_slab;
    int ended, last_cut;
    uint64_t max_active;       /* largest live vertices + live faces seen at a cut */
    en_slab_work **spare;      /* handed back by en_chunker_recycle, for the next cuts */
    size_t nspare, spare_cap;
    en_ctxpool *stash;         /* NULL, or where cuts take slab works from when spare is empty,
                                * and where spare goes at the end (en_chain_spares) */
    uint32_t *pool_of;         /* scratch of a cut: pool index per local vertex */
    size_t pool_of_cap;
    uint32_t *sort_tmp;        /* scratch of a cut: radix sort of fin by gid */
    size_t sort_tmp_cap;
    /* Copies of a position (a UV or material seam, docs/method.md §6) are
     * cut into one slab: a finalized vertex waits for the next cut while a
     * vertex at the same coordinates' bits is still live, so that no cut
     * leaves a seam pair's copies in two slabs, each alone as a boundary
     * (a locked sample). Kept only with copies set, where the records carry
     * attributes of their own (copies come from those; a target's carried
     * block alone makes none, and a round without attributes then holds its
     * vertices as the default path does): a hash of the bits -> live
     * vertices there. */
    int copies;
    en_u64map live_at;
    uint32_t *waiting;         /* scratch of a cut: the vertices that wait */
    size_t waiting_cap;
    size_t cut_at;             /* cut when nfin reaches it: owns more than waited */
    uint64_t deferred;         /* finalized vertices a cut left for the next one */
} en_chunker;

/* @return 0 or EPSNET_ENOMEM. */
int en_chunker_init(en_chunker *c, uint32_t slab_vertices, int hold_all, const char *path);
void en_chunker_free(en_chunker *c);

/*
 * Take one record. When it completes a slab, *out is a slab work (owned by
 * the caller: give it back with en_chunker_recycle(), or free it with
 * en_slab_work_free() and en_free()), else NULL.
 * Records are validated like the reader front end does (a triangle names
 * live vertices, a vertex is finalized once), since callers of the push API
 * bring their own.
 * @return 0 or a negative code with err filled.
 */
int en_chunker_put(en_chunker *c, const epsnet_record *rec, en_slab_work **out, epsnet_error *err);

/* Keep a slab work the caller is done with for a later cut (its arrays are
 * reused, not allocated again); frees it when it cannot be kept. */
void en_chunker_recycle(en_chunker *c, en_slab_work *w);

/* End of the stream: call until *out is NULL; finalizes what is still live. */
int en_chunker_finish(en_chunker *c, en_slab_work **out, epsnet_error *err);

/* Bytes held for vertices and faces not yet cut (capacities), for the
 * memory budget. */
uint64_t en_chunker_bytes(const en_chunker *c);

#endif
