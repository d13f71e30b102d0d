/*
 * Pass 6's records for one block of ranks (emit_block.h). The order is the
 * sort's (sort.h): each used rank's vertex, then the faces whose last
 * corner it is, in input order, each followed by the finalization of every
 * corner whose last use it is; only the thread that builds them differs.
 */
#include "sort/emit_block.h"

#include <string.h>

#include "common/alloc.h"
#include "common/hash64.h"

#define NO_ID UINT32_MAX

uint64_t en_rank_ids_bytes(uint64_t ranks)
{
    return 2 * ((ranks + 63) / 64 + 1) * sizeof(uint64_t);
}

int en_rank_ids_init(en_rank_ids *ids, uint64_t ranks)
{
    memset(ids, 0, sizeof *ids);
    ids->words = (ranks + 63) / 64 + 1; /* never empty */
    ids->unref = en_calloc(ids->words, sizeof *ids->unref);
    ids->before = en_calloc(ids->words, sizeof *ids->before);
    if (!ids->unref || !ids->before) {
        en_rank_ids_free(ids);
        return -1;
    }
    return 0;
}

void en_rank_ids_free(en_rank_ids *ids)
{
    en_free(ids->unref);
    en_free(ids->before);
    memset(ids, 0, sizeof *ids);
}

uint64_t en_rank_ids_fill(en_rank_ids *ids, const uint32_t *last_of, uint64_t lo, size_t n)
{
    uint64_t start = ids->count;
    for (size_t i = 0; i < n; i++) {
        uint64_t r = lo + i;
        if ((r & 63) == 0)
            ids->before[r >> 6] = ids->count;
        if (last_of[r] == NO_ID) {
            ids->unref[r >> 6] |= UINT64_C(1) << (r & 63);
            ids->count++;
        }
    }
    return ids->count - start;
}

/* note: by an eighth over what is needed, not by doubling: a simplify
 * run's chain keeps a block's array as a batch (sort.c: blocks_retire), so
 * an array twice the size a block needs would sit in each of its up to 16
 * batches (at 2,048 ranks a block and doubling, a size peaked 8 MB higher
 * on a shuffled 20M PLY, session 37). */
static int room(en_emit_block *b, size_t more)
{
    size_t need = b->nrecs + more;
    if (need <= b->recs_cap)
        return 0;
    size_t cap = need + need / 8;
    epsnet_record *r = en_realloc(b->recs, cap * sizeof *r);
    if (!r)
        return -1;
    b->recs = r;
    b->recs_cap = cap;
    return 0;
}

static void put(en_emit_block *b, epsnet_record_kind kind, uint64_t a, uint64_t c1, uint64_t c2)
{
    epsnet_record *r = &b->recs[b->nrecs++];
    memset(r, 0, sizeof *r);
    r->kind = kind;
    r->v[0] = a;
    r->v[1] = c1;
    r->v[2] = c2;
}

/* The group's table: where corner c was last used among the group's faces. */
static uint32_t *slot(en_emit_block *b, uint32_t c)
{
    size_t mask = b->fin_cap - 1;
    for (size_t i = en_hash_slot(c, mask);; i = (i + 1) & mask) {
        uint32_t *s = b->fin + 3 * i;
        if (s[1] != b->stamp || s[0] == c)
            return s;
    }
}

/* A fresh table with room for a group of n faces. @return 0 or -1. */
static int group_table(en_emit_block *b, size_t n)
{
    size_t want = 64;
    while (want < 8 * n)
        want *= 2;
    if (want > b->fin_cap) {
        uint32_t *t = en_calloc(want, 3 * sizeof *t);
        if (!t)
            return -1;
        en_free(b->fin);
        b->fin = t;
        b->fin_cap = want;
        b->stamp = 0;
    }
    if (++b->stamp == 0) { /* wrapped: no stamp left that no slot holds */
        memset(b->fin, 0, b->fin_cap * 3 * sizeof *b->fin);
        b->stamp = 1;
    }
    return 0;
}

static void corners(const uint64_t *it, uint32_t c[3])
{
    c[0] = (uint32_t)(it[0] >> 32);
    c[1] = (uint32_t)it[1];
    c[2] = (uint32_t)(it[1] >> 32);
}

/* Whether face i is the last of the group's n faces (items) to use c. */
static int last_user(const uint64_t *items, size_t n, size_t i, uint32_t c)
{
    for (size_t k = i + 1; k < n; k++) {
        uint32_t d[3];
        corners(items + 2 * k, d);
        if (d[0] == c || d[1] == c || d[2] == c)
            return 0;
    }
    return 1;
}

/* A group of at most this many faces is searched, not hashed: most groups
 * hold one to three faces. */
#define SMALL_GROUP 16

/* The faces of rank's group, each followed by the finalizations it ends. */
static int emit_group(en_emit_block *b, uint64_t rank, const uint64_t *items, size_t n)
{
    int small = n <= SMALL_GROUP;
    if ((!small && group_table(b, n)) || room(b, 4 * n))
        return -1;
    const uint32_t *last_of = b->last_of;
    for (size_t i = 0; !small && i < n; i++) {
        uint32_t c[3];
        corners(items + 2 * i, c);
        for (int s = 0; s < 3; s++)
            if (last_of[c[s]] == rank) {
                uint32_t *t = slot(b, c[s]);
                t[0] = c[s], t[1] = b->stamp, t[2] = (uint32_t)i;
            }
    }
    for (size_t i = 0; i < n; i++) {
        uint32_t c[3];
        corners(items + 2 * i, c);
        put(b, EPSNET_REC_TRIANGLE, en_rank_id(b->ids, c[0]), en_rank_id(b->ids, c[1]), en_rank_id(b->ids, c[2]));
        for (int s = 0; s < 3; s++) {
            if ((s > 0 && c[s] == c[0]) || (s > 1 && c[s] == c[1]) || last_of[c[s]] != rank)
                continue;
            if (small ? !last_user(items, n, i, c[s]) : slot(b, c[s])[2] != i)
                continue;
            put(b, EPSNET_REC_FINALIZE, en_rank_id(b->ids, c[s]), 0, 0);
            b->live_delta--;
        }
    }
    return 0;
}

int en_emit_block_run(void *job)
{
    en_emit_block *b = job;
    b->nrecs = 0;
    b->live_delta = b->live_peak = 0;
    size_t it = 0;
    for (size_t i = 0; i < b->nranks; i++) {
        uint64_t rank = b->rank0 + i;
        if (b->last_of[rank] == NO_ID)
            continue;
        if (room(b, 1))
            return EPSNET_ENOMEM;
        epsnet_record *r = &b->recs[b->nrecs++];
        memset(r, 0, sizeof *r);
        r->kind = EPSNET_REC_VERTEX;
        const uint8_t *p = b->xyz + i * b->xyz_stride;
        if (b->xyz_float) {
            float f[3];
            memcpy(f, p, sizeof f);
            for (int k = 0; k < 3; k++)
                r->xyz[k] = f[k];
        } else {
            memcpy(r->xyz, p, sizeof r->xyz);
        }
        r->attr = b->attr ? b->attr + i * b->attr_stride : NULL;
        if (++b->live_delta > b->live_peak)
            b->live_peak = b->live_delta;
        size_t n = 0;
        while (it + n < b->nitems && (uint32_t)b->items[2 * (it + n)] == rank)
            n++;
        if (n && emit_group(b, rank, b->items + 2 * it, n))
            return EPSNET_ENOMEM;
        it += n;
    }
    return it == b->nitems ? 0 : EPSNET_EINTERNAL; /* a face whose last corner is not in the block */
}

uint64_t en_emit_block_bytes(const en_emit_block *b)
{
    return b->recs_cap * sizeof *b->recs + b->fin_cap * 3 * sizeof *b->fin;
}

void en_emit_block_free(en_emit_block *b)
{
    en_free(b->recs);
    en_free(b->fin);
    b->recs = NULL;
    b->fin = NULL;
    b->recs_cap = b->fin_cap = 0;
}
