#include "pipeline/chunker.h"

#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "common/error.h"
#include "common/hash64.h"

int en_chunker_init(en_chunker *c, uint32_t slab_vertices, int hold_all, const char *path)
{
    memset(c, 0, sizeof *c);
    c->slab_vertices = slab_vertices ? slab_vertices : 1;
    c->hold_all = hold_all;
    c->owns = c->slab_vertices;
    c->cut_at = c->owns;
    c->path = path;
    c->mark_at = UINT32_MAX;
    c->mark_level = 0xff;
    /* note: live ids span about the stream's width, which a slab's worth
     * of vertices covers twice over in coherent streams; the rest go to the
     * idmap's hash. */
    size_t ring = 2 * (size_t)slab_vertices;
    /* grown as ids come: a one-slab pass (slab_vertices near 2^32) would
     * take 12 MB at once, the whole of a small --mem */
    if (en_idmap_init_growing(&c->map, ring < ((size_t)1 << 20) ? ring : ((size_t)1 << 20)))
        return EPSNET_ENOMEM;
    if (en_u64map_init(&c->live_at)) {
        en_idmap_free(&c->map);
        return EPSNET_ENOMEM;
    }
    return 0;
}

/* One more (delta +1) or one fewer (-1) live vertex at xyz. @return 0 or -1. */
/* note: live_at is keyed by en_position_key, as the slab groups copies
 * (en_slab.wedge); two positions that share a key only make a vertex wait
 * one cut longer. */
static int count_live_at(en_chunker *c, const double xyz[3], int delta)
{
    uint64_t key = en_position_key(xyz);
    uint32_t n = 0;
    en_u64map_get(&c->live_at, key, &n);
    n = (uint32_t)((int64_t)n + delta);
    if (n == 0)
        return en_u64map_remove(&c->live_at, key), 0;
    return en_u64map_put(&c->live_at, key, n);
}

void en_chunker_free(en_chunker *c)
{
    en_free(c->v);
    en_free(c->free_list);
    en_idmap_free(&c->map);
    en_free(c->faces);
    en_free(c->fin);
    for (size_t i = 0; i < c->nspare; i++) {
        if (c->stash) {
            en_ctxpool_give(c->stash, c->spare[i]);
            continue;
        }
        en_slab_work_free(c->spare[i]);
        en_free(c->spare[i]);
    }
    en_free(c->spare);
    en_free(c->pool_of);
    en_free(c->sort_tmp);
    en_free(c->attr);
    en_u64map_free(&c->live_at);
    en_free(c->waiting);
    memset(c, 0, sizeof *c);
}

void en_chunker_recycle(en_chunker *c, en_slab_work *w)
{
    if (en_grow((void **)&c->spare, &c->spare_cap, c->nspare + 1, sizeof *c->spare)) {
        en_slab_work_free(w);
        en_free(w);
        return;
    }
    c->spare[c->nspare++] = w;
}

static int bad(en_chunker *c, epsnet_error *err, const char *what, uint64_t id)
{
    return en_error_set(err, EPSNET_EFORMAT, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "record %llu: %s %llu",
                        (unsigned long long)c->records, what, (unsigned long long)id);
}

static int new_vertex(en_chunker *c, const epsnet_record *rec, epsnet_error *err)
{
    const double *xyz = rec->xyz;
    uint32_t i;
    if (c->free_len) {
        i = c->free_list[--c->free_len];
    } else {
        if (c->v_len >= UINT32_MAX - 1 || en_grow((void **)&c->v, &c->v_cap, c->v_len + 1, sizeof *c->v))
            return en_error_set(err, EPSNET_ENOMEM, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "out of memory: %zu live vertices", c->v_len);
        i = (uint32_t)c->v_len++;
    }
    if (c->attr_size) {
        /* the slot's attribute bytes: copied now, since rec->attr lives
         * only until the producer's next record */
        if (c->attr_cap <= i &&
            en_grow((void **)&c->attr, &c->attr_cap, (size_t)i + 1, c->attr_size)) {
            if (i + 1 == c->v_len)
                c->v_len--;
            else
                c->free_list[c->free_len++] = i;
            return en_error_set(err, EPSNET_ENOMEM, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "out of memory: %zu live vertices with attributes", c->v_len);
        }
        uint8_t *to = c->attr + (size_t)i * c->attr_size;
        if (rec->attr)
            memcpy(to, rec->attr, c->attr_size);
        else
            memset(to, 0, c->attr_size);
    }
    en_chunk_vertex *v = &c->v[i];
    v->gid = c->next_gid;
    memcpy(v->xyz, xyz, sizeof v->xyz);
    v->nref = 0;
    v->local_slab = -1;
    v->owner = EN_OWNER_LIVE;
    uint64_t marks = 0;
    if (c->mark_at != UINT32_MAX && rec->attr)
        memcpy(&marks, rec->attr + c->mark_at, sizeof marks);
    v->skeleton = (marks & EN_MARK_SKELETON) && (int)((marks >> EN_MARK_LEVEL_SHIFT) & 0xff) <= c->mark_level;
    if (en_idmap_put(&c->map, c->next_gid, i)) {
        if (i + 1 == c->v_len)
            c->v_len--;
        else
            c->free_list[c->free_len++] = i; /* it came from there: room is left */
        return en_error_set(err, EPSNET_ENOMEM, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    if (c->copies && count_live_at(c, xyz, +1)) {
        en_idmap_remove(&c->map, c->next_gid);
        if (i + 1 == c->v_len)
            c->v_len--;
        else
            c->free_list[c->free_len++] = i;
        return en_error_set(err, EPSNET_ENOMEM, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    c->next_gid++;
    return 0;
}

static int free_vertex(en_chunker *c, uint32_t i)
{
    if (en_grow((void **)&c->free_list, &c->free_cap, c->free_len + 1, sizeof *c->free_list))
        return -1;
    en_idmap_remove(&c->map, c->v[i].gid);
    c->free_list[c->free_len++] = i;
    return 0;
}

static int live_vertex(en_chunker *c, uint64_t gid, uint32_t *i)
{
    return en_idmap_get(&c->map, gid, i) && c->v[*i].owner == EN_OWNER_LIVE;
}

/*
 * Sort c->fin (pool indices) by global id: a least-significant-digit radix
 * sort on gid - min, 11 bits a pass, as many passes as the span needs.
 * note: ids are unique, so any correct sort gives this order; finalization
 * comes in nearly id order, where a comparison sort still pays n log n.
 */
static int sort_fin_by_gid(en_chunker *c)
{
    size_t n = c->nfin;
    if (n < 2)
        return 0;
    uint64_t lo = UINT64_MAX, hi = 0;
    for (size_t j = 0; j < n; j++) {
        uint64_t g = c->v[c->fin[j]].gid;
        lo = g < lo ? g : lo;
        hi = g > hi ? g : hi;
    }
    if (en_grow((void **)&c->sort_tmp, &c->sort_tmp_cap, n, sizeof *c->sort_tmp))
        return -1;
    uint32_t *a = c->fin, *b = c->sort_tmp;
    for (unsigned shift = 0; shift < 64 && ((hi - lo) >> shift) != 0; shift += 11) {
        size_t count[2049] = { 0 };
        for (size_t j = 0; j < n; j++)
            count[((c->v[a[j]].gid - lo) >> shift & 2047) + 1]++;
        for (int d = 0; d < 2048; d++)
            count[d + 1] += count[d];
        for (size_t j = 0; j < n; j++)
            b[count[(c->v[a[j]].gid - lo) >> shift & 2047]++] = a[j];
        uint32_t *t = a;
        a = b;
        b = t;
    }
    if (a != c->fin)
        memcpy(c->fin, a, n * sizeof *a);
    return 0;
}

static int add_local(en_chunker *c, en_slab_work *w, uint32_t i, uint8_t flags)
{
    en_chunk_vertex *v = &c->v[i];
    if (v->local_slab == (int64_t)w->index)
        return 0;
    int64_t l = en_slab_add_vertex(&w->s, v->gid, v->xyz, (uint8_t)(flags | (v->skeleton ? EN_V_SKELETON : 0)));
    if (l < 0 || en_grow((void **)&c->pool_of, &c->pool_of_cap, (size_t)l + 1, sizeof *c->pool_of))
        return -1;
    c->pool_of[l] = i;
    if (c->attr_size) {
        /* in bytes: a slab work may come from a chain whose records had
         * another size (en_chain_spares) */
        size_t need = ((size_t)l + 1) * c->attr_size;
        if (w->cap.attr < need && en_grow((void **)&w->attr, &w->cap.attr, need, 1))
            return -1;
        memcpy(w->attr + (size_t)l * c->attr_size, c->attr + (size_t)i * c->attr_size, c->attr_size);
    }
    w->attr_size = c->attr_size;
    v->local = (uint32_t)l;
    v->local_slab = w->index;
    return 0;
}

/* Leave in c->fin the vertices a cut may take, and in c->waiting (returned
 * count) those whose position still has a live copy (live_at); the end
 * takes every vertex. @return the count waiting, or -1 (out of memory). */
static int64_t hold_back_copies(en_chunker *c)
{
    if (!c->copies || c->ended)
        return 0;
    if (en_grow((void **)&c->waiting, &c->waiting_cap, c->nfin, sizeof *c->waiting))
        return -1;
    size_t waiting = 0, taken = 0;
    for (size_t j = 0; j < c->nfin; j++) {
        uint32_t i = c->fin[j], n;
        if (en_u64map_get(&c->live_at, en_position_key(c->v[i].xyz), &n))
            c->waiting[waiting++] = i;
        else
            c->fin[taken++] = i;
    }
    c->nfin = taken;
    return (int64_t)waiting;
}

/* After a cut (or none, when every vertex waited): the waiting go first
 * into the next slab, which is due `owns` finalizations later, so that
 * waiting never makes cuts more frequent. */
static void restore_waiting(en_chunker *c, size_t waiting)
{
    if (waiting) /* c->waiting may never have been allocated */
        memcpy(c->fin + c->nfin, c->waiting, waiting * sizeof *c->fin);
    c->nfin += waiting;
    c->cut_at = c->nfin + c->owns;
}

/* With hold_all, the next slab owns what this one's ghosts left of
 * slab_vertices: the ghosts are about two rows of the stream's width, and
 * the next slab's will be about as many, so that a slab holds about
 * slab_vertices in all however wide the stream. Its memory (stars, quadrics, results) goes
 * by all its vertices: counting only the owned ones, a slab of gen bumpy
 * at 100M faces held 86,018 vertices for 65,536 owned, at 20M 74,698, and
 * the peak grew with the width (bench/RESULTS.md, session 36). It owns a
 * quarter of slab_vertices at least, so that a stream wider than the slab
 * still moves by slabs, not by a few vertices at a time. */
static void next_owns(en_chunker *c, uint32_t ghosts)
{
    if (!c->hold_all)
        return;
    uint32_t all = c->slab_vertices, floor = all / 4 ? all / 4 : 1;
    c->owns = ghosts < all - floor ? all - ghosts : floor;
}

/* Cut the finalized vertices in c->fin into slab c->next_slab. */
static int cut(en_chunker *c, en_slab_work **out, epsnet_error *err)
{
    *out = NULL;
    int64_t held = hold_back_copies(c);
    if (held < 0)
        return en_error_set(err, EPSNET_ENOMEM, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    size_t waiting = (size_t)held;
    c->deferred += waiting;
    if (c->nfin == 0 && waiting) {
        restore_waiting(c, waiting); /* no slab of nothing but ghosts */
        return 0;
    }
    en_slab_work *w;
    if (c->nspare || (w = en_ctxpool_take(c->stash)) != NULL) {
        if (c->nspare)
            w = c->spare[--c->nspare];
        en_slab_work_reset(w);
    } else {
        w = en_malloc(sizeof *w);
        if (!w)
            return en_error_set(err, EPSNET_ENOMEM, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        en_slab_work_init(w);
    }
    uint32_t k = c->next_slab;
    w->index = k;
    w->last = c->ended;
    w->nowned = (uint32_t)c->nfin;
    w->live_vertices = c->map.count;
    w->live_faces = c->nfaces;
    if (w->live_vertices + w->live_faces > c->max_active)
        c->max_active = w->live_vertices + w->live_faces;
    int rc = sort_fin_by_gid(c);
    for (size_t j = 0; j < c->nfin && rc == 0; j++) {
        c->v[c->fin[j]].owner = k;
        rc = add_local(c, w, c->fin[j], EN_V_OWNED);
    }
    /* Every face around an owned vertex joins the slab; a face whose corners
     * are now all owned is done with (this is its home: docs/architecture.md §8). */
    size_t kept = 0;
    for (size_t f = 0; f < c->nfaces && rc == 0; f++) {
        uint32_t *t = c->faces + 3 * f;
        int touches = 0, interior = 1, home = 1;
        for (int j = 0; j < 3; j++) {
            int64_t o = c->v[t[j]].owner;
            touches |= o == k;
            interior &= o == k;
            home &= o >= 0;
        }
        if (touches) {
            for (int j = 0; j < 3 && rc == 0; j++)
                rc = add_local(c, w, t[j], 0);
            if (rc == 0)
                rc = en_slab_add_face(&w->s, c->v[t[0]].local, c->v[t[1]].local, c->v[t[2]].local);
            if (rc == 0)
                rc = en_grow((void **)&w->fflags, &w->cap.fflags, w->s.nt, 1);
            if (rc == 0)
                w->fflags[w->s.nt - 1] = (uint8_t)((interior ? EN_F_INTERIOR : 0) | (home ? EN_F_HOME : 0));
        }
        if (rc == 0 && home) {
            for (int j = 0; j < 3; j++)
                c->v[t[j]].nref--;
        } else {
            uint32_t *keep = c->faces + 3 * kept++;
            keep[0] = t[0], keep[1] = t[1], keep[2] = t[2]; /* keep <= t: in place, forwards */
        }
    }
    c->nfaces = kept;
    if (rc == 0) {
        rc = en_grow((void **)&w->owner, &w->cap.owner, (size_t)w->s.nv + 1, sizeof *w->owner);
    }
    if (rc == 0) {
        for (uint32_t l = w->nowned; l < w->s.nv; l++) {
            int64_t o = c->v[c->pool_of[l]].owner;
            w->owner[l] = o >= 0 ? o : -1;
        }
        for (uint32_t l = 0; l < w->nowned; l++)
            w->owner[l] = k;
    }
    for (size_t j = 0; j < c->nfin && rc == 0; j++)
        if (c->v[c->fin[j]].nref == 0)
            rc = free_vertex(c, c->fin[j]);
    /* Ghost corners owned by earlier slabs may have lost their last face too. */
    for (uint32_t l = w->nowned; l < w->s.nv && rc == 0; l++)
        if (w->owner[l] >= 0 && c->v[c->pool_of[l]].nref == 0)
            rc = free_vertex(c, c->pool_of[l]);
    c->nfin = 0;
    if (rc == 0)
        next_owns(c, w->s.nv - w->nowned);
    restore_waiting(c, waiting);
    if (rc) {
        en_slab_work_free(w);
        en_free(w);
        return en_error_set(err, EPSNET_ENOMEM, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory cutting slab %u", k);
    }
    for (;;) {
        uint32_t i;
        if (c->low >= c->next_gid)
            break;
        if (en_idmap_get(&c->map, c->low, &i) && c->v[i].owner < 0)
            break;
        c->low++;
    }
    w->frontier = c->low;
    c->next_slab++;
    *out = w;
    return 0;
}

int en_chunker_put(en_chunker *c, const epsnet_record *rec, en_slab_work **out, epsnet_error *err)
{
    *out = NULL;
    c->records++;
    if (c->ended)
        return en_error_set(err, EPSNET_EINVAL, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "record after the end of the stream");
    if (rec->kind == EPSNET_REC_VERTEX)
        return new_vertex(c, rec, err);
    if (rec->kind == EPSNET_REC_TRIANGLE) {
        uint32_t t[3];
        for (int j = 0; j < 3; j++)
            if (!live_vertex(c, rec->v[j], &t[j]))
                return bad(c, err, rec->v[j] < c->next_gid ? "triangle uses finalized vertex"
                                                           : "triangle uses unknown vertex",
                           rec->v[j]);
        if (en_grow((void **)&c->faces, &c->faces_cap, c->nfaces + 1, 3 * sizeof *c->faces))
            return en_error_set(err, EPSNET_ENOMEM, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "out of memory: %zu live faces", c->nfaces);
        memcpy(c->faces + 3 * c->nfaces++, t, sizeof t);
        for (int j = 0; j < 3; j++)
            c->v[t[j]].nref++;
        return 0;
    }
    if (rec->kind == EPSNET_REC_FINALIZE) {
        uint32_t i;
        if (!live_vertex(c, rec->v[0], &i))
            return bad(c, err, rec->v[0] < c->next_gid ? "vertex finalized twice" : "finalize of unknown vertex",
                       rec->v[0]);
        if (en_grow((void **)&c->fin, &c->fin_cap, c->nfin + 1, sizeof *c->fin))
            return en_error_set(err, EPSNET_ENOMEM, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        c->v[i].owner = EN_OWNER_FINAL;
        c->fin[c->nfin++] = i;
        if (c->copies && count_live_at(c, c->v[i].xyz, -1))
            return en_error_set(err, EPSNET_ENOMEM, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        if (c->nfin >= c->cut_at)
            return cut(c, out, err);
        return 0;
    }
    return en_error_set(err, EPSNET_EINVAL, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "record %llu: unknown kind %d",
                        (unsigned long long)c->records, (int)rec->kind);
}

int en_chunker_finish(en_chunker *c, en_slab_work **out, epsnet_error *err)
{
    *out = NULL;
    if (!c->ended) {
        /* What the stream never finalized is finalized here, in id order,
         * into one last slab. */
        c->ended = 1;
        for (uint64_t g = c->low; g < c->next_gid; g++) {
            uint32_t i;
            if (!live_vertex(c, g, &i))
                continue;
            if (en_grow((void **)&c->fin, &c->fin_cap, c->nfin + 1, sizeof *c->fin))
                return en_error_set(err, EPSNET_ENOMEM, c->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                    "out of memory");
            c->v[i].owner = EN_OWNER_FINAL;
            c->fin[c->nfin++] = i;
        }
    }
    if (c->nfin == 0 && (!c->cut_last || c->last_cut))
        return 0;
    c->last_cut = 1;
    return cut(c, out, err);
}

uint64_t en_chunker_bytes(const en_chunker *c)
{
    return (uint64_t)c->v_cap * sizeof *c->v + c->free_cap * sizeof *c->free_list + en_idmap_bytes(&c->map) +
           3 * c->faces_cap * sizeof *c->faces + c->fin_cap * sizeof *c->fin + c->attr_cap * c->attr_size +
           en_u64map_bytes(&c->live_at) + c->waiting_cap * sizeof *c->waiting;
}
