#include "pipeline/stitcher.h"

#include <math.h>
#include <string.h>

#include "common/alloc.h"
#include "common/error.h"

enum {
    S_IN_W = 1 << 0,
    S_COMPLETE = 1 << 1,   /* whole star in W (or decided by its slab) */
    S_SETTLED = 1 << 2,    /* no more collapses from or onto it */
    S_FIXED = 1 << 3,      /* a sample (locked included): never removed */
    S_BAND = 1 << 4,       /* near a slab border in the input (stats) */
    S_BLOCKED = 1 << 5,    /* scratch (settle): has a neighbour that is not complete */
    S_IN_FACE = 1 << 6,    /* scratch (settle): still a corner of a seam face */
    S_SKELETON = 1 << 7,   /* a sample by the sample rule, not by its topology: marked for a finish */
    S_USER_LOCK = 1 << 8,  /* locked by the user: LOCKED wherever it is, never a second tier */
};

struct en_stitch_vertex {
    uint64_t gid;
    double xyz[3];
    en_quadric q;
    uint64_t out;          /* output id, UINT64_MAX until written */
    uint32_t remaining;    /* faces around it not yet written */
    uint32_t future;       /* faces still to come from later slabs */
    uint32_t wlocal;       /* scratch: index in W */
    uint32_t take;         /* the take it arrived in (a streamed target's seams) */
    uint8_t border;        /* EN_BORDER_* */
    uint8_t level;         /* a sample's level (en_slab_work.vlevel), for its marks */
    uint16_t state;        /* S_* */
    uint16_t bucket;       /* a priced plan: its cheapest collapse left at W's last run (EN_COST_NONE: none) */
    uint32_t first_face, last_face; /* final faces it is the last corner of (fpool slots, NO_SLOT: none) */
};

struct en_seam_face {
    uint32_t v[3];         /* pool indices */
    double ref[3];         /* input unit normal (the bound of §4.2's refusals) */
};

struct en_out_face {
    uint32_t v[3];         /* pool indices */
    uint32_t next;         /* the next slot in its vertex's list */
};
#define NO_SLOT UINT32_MAX

/* note: W's vertices are pool slots scattered over the pool, and each loop
 * over W (its rebuild for a run, the run's results, settling, the pace)
 * visits all of them, so most visits missed the cache: 3% of a size's CPU at
 * 20M faces, and W grows with the stream's width (bench/RESULTS.md, session
 * 30). Each loop starts its misses W_AHEAD items early. They are written in
 * the loops: a helper doing nothing but prefetches reads as free of effects
 * to the compiler, which drops its calls. */
#define W_AHEAD 16
#define PREFETCH_WV(st, i, field)                                                                               \
    do {                                                                                                        \
        if ((i) + W_AHEAD < (st)->nwv)                                                                          \
            __builtin_prefetch(&(st)->v[(st)->wv[(i) + W_AHEAD]].field);                                        \
    } while (0)
#define PREFETCH_WF(st, f, field)                                                                               \
    do {                                                                                                        \
        if ((f) + W_AHEAD < (st)->nwf)                                                                          \
            for (int pj_ = 0; pj_ < 3; pj_++)                                                                   \
                __builtin_prefetch(&(st)->v[(st)->wf[(f) + W_AHEAD].v[pj_]].field);                             \
    } while (0)

struct en_vheap_entry {
    uint64_t gid;
    uint32_t idx;          /* pool index */
};

int en_stitcher_init(en_stitcher *st, double max_normal_dev, en_stage out)
{
    memset(st, 0, sizeof *st);
    st->out = out;
    st->max_normal_dev = max_normal_dev;
    en_slab_init(&st->ws);
    return en_u64map_init(&st->map) ? EPSNET_ENOMEM : 0;
}

void en_stitcher_free(en_stitcher *st)
{
    en_stitcher_release(st);
    en_free(st->cost_hist);
    en_free(st->level_hist);
    en_free(st->taken_hist);
    memset(st, 0, sizeof *st);
}

void en_stitcher_release(en_stitcher *st)
{
    en_free(st->scratch);
    st->scratch = NULL;
    st->scratch_cap = 0;
    en_free(st->v);
    en_free(st->free_list);
    en_u64map_free(&st->map);
    en_free(st->wv);
    en_free(st->wf);
    en_free(st->vrun);
    en_free(st->vheap);
    en_free(st->fpool);
    en_free(st->ffree);
    en_free(st->local);
    en_slab_free(&st->ws);
    en_free(st->attr);
    en_free(st->aq);
    st->aq = NULL;
    st->aq_cap = 0;
    st->v = NULL, st->free_list = NULL, st->wv = NULL, st->wf = NULL, st->vrun = NULL, st->vheap = NULL, st->fpool = NULL;
    st->local = NULL, st->attr = NULL, st->ffree = NULL;
    st->v_len = st->v_cap = st->free_len = st->free_cap = 0;
    st->nwv = st->wv_cap = st->nwf = st->wf_cap = st->nvheap = st->vheap_cap = 0;
    st->vrun_head = st->nvrun = st->vrun_cap = st->fpool_len = st->fpool_cap = 0;
    st->nffree = st->ffree_cap = 0;
    st->nfwait = 0;
    st->local_cap = st->attr_cap = 0;
    en_slab_init(&st->ws);
}

static int oom(epsnet_error *err)
{
    return en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory stitching slabs");
}

static int internal(epsnet_error *err, const char *what)
{
    return en_error_set(err, EPSNET_EINTERNAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "stitcher: %s (a bug)", what);
}

static int sv_new(en_stitcher *st, uint32_t *idx)
{
    if (en_grow((void **)&st->free_list, &st->free_cap, st->v_len + 1, sizeof *st->free_list))
        return -1; /* room to free every vertex later, so freeing never fails */
    if (st->free_len) {
        *idx = st->free_list[--st->free_len];
        st->v[*idx].first_face = st->v[*idx].last_face = NO_SLOT;
        return 0;
    }
    if (st->v_len >= UINT32_MAX - 1 || en_grow((void **)&st->v, &st->v_cap, st->v_len + 1, sizeof *st->v))
        return -1;
    if (st->attr_size && en_grow((void **)&st->attr, &st->attr_cap, st->v_len + 1, st->attr_size))
        return -1;
    if (st->na && en_grow((void **)&st->aq, &st->aq_cap, (st->v_len + 1) * st->na, sizeof *st->aq))
        return -1;
    *idx = (uint32_t)st->v_len++;
    st->v[*idx].first_face = st->v[*idx].last_face = NO_SLOT;
    return 0;
}

static void sv_free(en_stitcher *st, uint32_t idx)
{
    if (st->v[idx].state & S_IN_W)
        en_u64map_remove(&st->map, st->v[idx].gid);
    st->v[idx].state = 0;
    st->free_list[st->free_len++] = idx;
}

/* A 4-ary min-heap for the vertices decided out of id order; ids are
 * unique, so the order out is the same whatever the heap's shape.
 *
 * note: four children a node and a hole that moves instead of swaps: half
 * the levels of a binary heap, one move a level. Nearly every vertex is
 * decided in id order and goes to the run instead, and final faces wait in
 * lists at their last vertex: the heaps that held them all had become a
 * tenth of a streamed target's time (bench/RESULTS.md, session 13). */
static int vheap_less(const en_vheap_entry *a, const en_vheap_entry *b)
{
    return a->gid < b->gid;
}

#define HEAP_FUNCS(name, type, less)                                                                            \
    static void name##_up(type *h, size_t i)                                                                    \
    {                                                                                                           \
        type e = h[i];                                                                                          \
        while (i > 0) {                                                                                         \
            size_t p = (i - 1) / 4;                                                                             \
            if (!less(&e, &h[p]))                                                                               \
                break;                                                                                          \
            h[i] = h[p];                                                                                        \
            i = p;                                                                                              \
        }                                                                                                       \
        h[i] = e;                                                                                               \
    }                                                                                                           \
    static type name##_pop(type *h, size_t *n)                                                                  \
    {                                                                                                           \
        type top = h[0], e = h[--*n];                                                                           \
        size_t i = 0;                                                                                           \
        for (;;) {                                                                                              \
            size_t c = 4 * i + 1, end = c + 4 < *n ? c + 4 : *n, m = c;                                         \
            if (c >= *n)                                                                                        \
                break;                                                                                          \
            for (size_t k = c + 1; k < end; k++)                                                                \
                if (less(&h[k], &h[m]))                                                                         \
                    m = k;                                                                                      \
            if (!less(&h[m], &e))                                                                               \
                break;                                                                                          \
            h[i] = h[m];                                                                                        \
            i = m;                                                                                              \
        }                                                                                                       \
        h[i] = e;                                                                                               \
        return top;                                                                                             \
    }

HEAP_FUNCS(vheap, en_vheap_entry, vheap_less)

/* The vertex will not change any more: it waits for its turn in id order. */
static int decide(en_stitcher *st, uint32_t idx)
{
    en_vheap_entry e = { st->v[idx].gid, idx };
    if (st->vrun_head == st->nvrun)
        st->vrun_head = st->nvrun = 0;
    if (st->nvrun == st->vrun_head || st->vrun[st->nvrun - 1].gid < e.gid) {
        if (st->nvrun == st->vrun_cap && st->vrun_head > 0 && 2 * st->vrun_head >= st->nvrun) {
            /* half the run is read: move the rest down rather than grow */
            memmove(st->vrun, st->vrun + st->vrun_head, (st->nvrun - st->vrun_head) * sizeof *st->vrun);
            st->nvrun -= st->vrun_head;
            st->vrun_head = 0;
        }
        if (en_grow((void **)&st->vrun, &st->vrun_cap, st->nvrun + 1, sizeof *st->vrun))
            return -1;
        st->vrun[st->nvrun++] = e;
    } else {
        if (en_grow((void **)&st->vheap, &st->vheap_cap, st->nvheap + 1, sizeof *st->vheap))
            return -1;
        st->vheap[st->nvheap] = e;
        vheap_up(st->vheap, st->nvheap++);
    }
    st->decided++;
    return 0;
}

/* The face is final: it waits at its last corner, after those already
 * there, and leaves right after that corner is written (write_until).
 * note: the free slots are a stack of their own, not a chain through
 * fpool: taking one reads the stack's top, not the slot (a miss the take
 * waited on: 72% of this function's time in a target's rounds,
 * bench/RESULTS.md, session 30). */
static int final_face(en_stitcher *st, const uint32_t p[3])
{
    uint32_t slot;
    if (st->nffree) {
        slot = st->ffree[--st->nffree];
    } else {
        if (st->fpool_len >= NO_SLOT ||
            en_grow((void **)&st->fpool, &st->fpool_cap, st->fpool_len + 1, sizeof *st->fpool) ||
            en_grow((void **)&st->ffree, &st->ffree_cap, st->fpool_len + 1, sizeof *st->ffree))
            return -1; /* room to free every slot later, so freeing never fails */
        slot = (uint32_t)st->fpool_len++;
    }
    uint32_t last = p[0];
    for (int j = 1; j < 3; j++)
        if (st->v[p[j]].gid > st->v[last].gid)
            last = p[j];
    st->faces_final++;
    st->nfwait++;
    en_out_face *f = &st->fpool[slot];
    memcpy(f->v, p, sizeof f->v);
    f->next = NO_SLOT;
    en_stitch_vertex *x = &st->v[last];
    if (x->first_face == NO_SLOT)
        x->first_face = slot;
    else
        st->fpool[x->last_face].next = slot;
    x->last_face = slot;
    return 0;
}

static int add_seam_face(en_stitcher *st, const uint32_t p[3], const double ref[3])
{
    if (en_grow((void **)&st->wf, &st->wf_cap, st->nwf + 1, sizeof *st->wf))
        return -1;
    memcpy(st->wf[st->nwf].v, p, sizeof st->wf[st->nwf].v);
    memcpy(st->wf[st->nwf].ref, ref, sizeof st->wf[st->nwf].ref);
    st->nwf++;
    st->stats.seam_faces++;
    return 0;
}

/* A W vertex's kind under the seam rules (pipeline/seam.h). vflags: its
 * topology in W, or 0 before W's stars are built (then LOCKED reads as
 * FREE or SAMPLE, which only the removal test below tells apart). */
static en_vertex_kind kind_in_w(const en_stitch_vertex *x, uint8_t vflags)
{
    return en_vertex_kind_of((x->state & S_COMPLETE) != 0, (x->state & S_SETTLED) != 0,
                             en_seam_locked(vflags) || (x->state & S_USER_LOCK), (x->state & S_FIXED) != 0);
}

/*
 * Under a streamed target: how many units (faces, or vertices) W may keep
 * after this take, so that the pass keeps the target's share of what it has
 * taken in (docs/architecture.md §7). Units that cannot change yet (faces
 * with a corner whose star is not whole, vertices not complete) are left
 * out of both sides: they count when a later take can collapse them, so the
 * seam next to the newest slab is not thinned for what is still to come. The
 * slabs' own shortfalls and excesses are made up here, seam by seam, and the
 * last take aims at the goal itself.
 */
static uint64_t seam_keep(const en_stitcher *st, int last)
{
    const en_pass_plan *t = st->plan;
    uint64_t pending = 0, settled = 0;
    if (t->by_vertices) {
        for (size_t i = 0; i < st->nwv; i++) {
            PREFETCH_WV(st, i, state);
            uint16_t state = st->v[st->wv[i]].state;
            pending += !(state & S_COMPLETE);
            settled += (state & S_SETTLED) != 0;
        }
    } else {
        for (size_t f = 0; f < st->nwf; f++) {
            PREFETCH_WF(st, f, state);
            const uint32_t *p = st->wf[f].v;
            pending += !(st->v[p[0]].state & st->v[p[1]].state & st->v[p[2]].state & S_COMPLETE);
        }
    }
    uint64_t done = st->taken > pending ? st->taken - pending : 0;
    uint64_t goal = t->goal, expected = t->expected_in;
    if (!last && expected && done < expected)
        goal = (uint64_t)llround((double)t->goal * (double)done / (double)expected);
    /* what the output already holds outside W */
    uint64_t out = t->by_vertices ? st->decided - settled : st->faces_final;
    return (goal > out ? goal - out : 0) + pending;
}

/* One run of the slab core's collapses over W (paper §4.2, §5). */
static int collapse_seams(en_stitcher *st, int last, epsnet_error *err)
{
    /* EN_SEAMS_LEVEL: seams only go to the level of the slabs around
     * them, and are priced for the target stage's first ceiling (its
     * histogram counts every vertex that may go) */
    en_seam_rule rule = st->plan ? st->plan->seams : EN_SEAMS_NONE;
    if (rule == EN_SEAMS_LEVEL && !st->cost_hist && !(st->seam_level > 0))
        return 0;
    int any = 0, tier2 = st->plan && st->plan->samples_may_go;
    for (size_t i = 0; i < st->nwv && !any; i++) {
        PREFETCH_WV(st, i, state);
        en_vertex_kind k = kind_in_w(&st->v[st->wv[i]], 0);
        any = en_removable(k) || (tier2 && k == EN_VK_SAMPLE);
    }
    if (!any)
        return 0;
    en_slab *ws = &st->ws;
    en_slab_reset(ws);
    for (size_t i = 0; i < st->nwv; i++) {
        PREFETCH_WV(st, i, gid);
        PREFETCH_WV(st, i, state);
        en_stitch_vertex *x = &st->v[st->wv[i]];
        x->wlocal = (uint32_t)i;
        uint8_t flags = EN_V_OWNED | (en_receives(kind_in_w(x, 0)) ? EN_V_TARGET : 0);
        if (en_slab_add_vertex(ws, x->gid, x->xyz, flags) < 0)
            return oom(err);
    }
    for (size_t f = 0; f < st->nwf; f++) {
        PREFETCH_WF(st, f, wlocal);
        const uint32_t *p = st->wf[f].v;
        if (en_slab_add_face(ws, st->v[p[0]].wlocal, st->v[p[1]].wlocal, st->v[p[2]].wlocal))
            return oom(err);
    }
    if (en_slab_build_stars(ws))
        return oom(err);
    for (uint32_t i = 0; st->plan && st->plan->count_nranges && i < ws->nv; i++)
        if (en_cut_end(st->plan, ws, i)) /* a pricing pass's window cuts receive nothing */
            ws->vflags[i] &= (uint8_t)~EN_V_TARGET;
    /* the run's arrays, in one buffer the stitcher keeps from take to take
     * (a steady run allocates nothing per take) */
    size_t nv = st->nwv + 1, nt = st->nwf + 1;
    uint32_t channels = st->na ? st->weights->channels : 0;
    size_t at[10] = { 0 }, size[9] = { nv * sizeof(en_quadric), 3 * nt * sizeof(double), 3 * nt * sizeof(uint32_t),
                                        nv * sizeof(uint16_t), nv, nv, nt, nv * st->na * sizeof(double),
                                        nv * channels * sizeof(double) };
    for (int k = 0; k < 9; k++)
        at[k + 1] = at[k] + (size[k] + 7) / 8 * 8;
    if (en_grow((void **)&st->scratch, &st->scratch_cap, at[9], 1))
        return oom(err);
    double *aq = (double *)(void *)(st->scratch + at[7]), *avalue = (double *)(void *)(st->scratch + at[8]);
    en_quadric *q = (en_quadric *)(void *)st->scratch;
    double *ref = (double *)(void *)(st->scratch + at[1]);
    uint32_t *tri = (uint32_t *)(void *)(st->scratch + at[2]);
    uint16_t *bucket_of = st->cost_hist ? (uint16_t *)(void *)(st->scratch + at[3]) : NULL;
    uint8_t *removable = st->scratch + at[4], *valive = st->scratch + at[5], *falive = st->scratch + at[6];
    int rc = 0;
    for (size_t i = 0; i < st->nwv; i++) {
        PREFETCH_WV(st, i, q);
        PREFETCH_WV(st, i, state);
        const en_stitch_vertex *x = &st->v[st->wv[i]];
        en_vertex_kind k = kind_in_w(x, ws->vflags[i]);
        removable[i] = (uint8_t)en_removable(k);
        if (tier2 && k == EN_VK_SAMPLE)
            removable[i] = 2; /* the second tier, as in a slab (slab_work.c) */
        if (st->level_hist && (x->state & S_SKELETON) && x->level > 0)
            removable[i] = EN_TIER_PRICED; /* a sample the pass's density may free (slab_work.c) */
        q[i] = x->q;
        if (channels) {
            memcpy(aq + st->na * i, st->aq + st->na * st->wv[i], st->na * sizeof *aq);
            en_attr_weights_values(st->weights, st->weights->diagonal, st->attr + (size_t)st->wv[i] * st->attr_size,
                                   avalue + (size_t)channels * i);
        }
    }
    for (size_t f = 0; f < st->nwf; f++)
        memcpy(ref + 3 * f, st->wf[f].ref, 3 * sizeof *ref);
    en_collapse_settings cs = { .max_normal_dev_deg = st->max_normal_dev,
                                .attr_channels = channels,
                                .attr_value = avalue,
                                .aq = aq };
    if (rule == EN_SEAMS_ERROR) {
        cs.by_error = 1; /* the slabs' bound, on the whole mesh's diagonal */
        cs.max_error = st->plan->max_error * st->plan->diagonal;
    } else if (rule == EN_SEAMS_CEILING) {
        cs.cost_ceiling = st->plan->cost_ceiling; /* the slabs' ceiling */
    } else if (rule == EN_SEAMS_LEVEL) {
        /* the seam goes to the level its slabs reached (below 0: none,
         * only priced), so that the thinning keeps no more of a seam than
         * of the slabs around it: whole seams held a third of its output
         * at 20M faces (docs/architecture.md §7) */
        cs.cost_ceiling = st->seam_level > 0 ? st->seam_level : -1;
    } else if (rule == EN_SEAMS_PACED) {
        cs.by_error = 1;
        cs.max_error = -1;
    }
    if (rule == EN_SEAMS_PACED || (rule == EN_SEAMS_CEILING && st->plan->floor_share > 0)) {
        /* paced, or a round's guard under its ceiling: never below the pace to the goal */
        uint64_t keep = seam_keep(st, last);
        if (keep >= (st->plan->by_vertices ? st->nwv : st->nwf))
            goto out; /* on course: nothing to collapse here */
        /* 0 would be "no limit": one unit is the least there can be */
        *(st->plan->by_vertices ? &cs.keep_vertices : &cs.keep_faces) = keep ? keep : 1;
    }
    en_collapse_counts cc;
    cs.bucket_of = bucket_of;
    if (st->taken_hist) {
        cs.taken = st->taken_hist;
        cs.taken_ranges = st->plan->count_ranges;
        cs.taken_nranges = st->plan->count_nranges;
    }
    if (en_collapse_slab(ws, removable, q, ref, &cs, falive, valive, tri, &cc, st->collapse_arrays)) {
        rc = oom(err);
        goto out;
    }
    st->stats.seam_collapses += cc.collapses;
    st->given_up += cc.given_up;
    st->stats.seam_steps++;
    /* Faces: every corner change moves a count of faces still to write. */
    size_t kept = 0;
    for (size_t f = 0; f < st->nwf; f++) {
        PREFETCH_WF(st, f, remaining);
        en_seam_face sf = st->wf[f];
        for (int j = 0; j < 3; j++)
            st->v[sf.v[j]].remaining--;
        if (!falive[f])
            continue;
        for (int j = 0; j < 3; j++) {
            sf.v[j] = st->wv[tri[3 * f + (size_t)j]];
            st->v[sf.v[j]].remaining++;
        }
        st->wf[kept++] = sf;
    }
    st->nwf = kept;
    kept = 0;
    for (size_t i = 0; i < st->nwv; i++) {
        PREFETCH_WV(st, i, q);
        PREFETCH_WV(st, i, state);
        uint32_t idx = st->wv[i];
        if (!valive[i]) {
            if (st->v[idx].remaining != 0) {
                rc = internal(err, "a collapsed vertex still has faces");
                goto out;
            }
            sv_free(st, idx);
            continue;
        }
        st->v[idx].q = q[i];
        if (channels)
            memcpy(st->aq + st->na * idx, aq + st->na * i, st->na * sizeof *aq);
        if (bucket_of)
            st->v[idx].bucket = bucket_of[i];
        st->wv[kept++] = idx;
    }
    st->nwv = kept;
out:
    return rc;
}

/* Settle what can no longer change and let its faces go (see the header).
 * Under a pace or a ceiling, what arrived in this take waits one take
 * more, unless it is the last: the last take's seams, which end a paced
 * pass at its goal, then always hold the newest seam, even when the
 * stream's end cuts an empty slab after it. */
static int settle(en_stitcher *st, int last)
{
    int wait = st->plan && (st->plan->seams == EN_SEAMS_PACED || st->plan->seams == EN_SEAMS_CEILING) && !last;
    for (size_t i = 0; i < st->nwv; i++) {
        PREFETCH_WV(st, i, state);
        st->v[st->wv[i]].state &= (uint16_t)~(S_BLOCKED | S_IN_FACE);
    }
    for (size_t f = 0; f < st->nwf; f++) {
        PREFETCH_WF(st, f, state);
        const uint32_t *p = st->wf[f].v;
        int open = 0;
        for (int j = 0; j < 3; j++)
            open |= !(st->v[p[j]].state & (S_COMPLETE | S_SETTLED));
        if (open)
            for (int j = 0; j < 3; j++)
                st->v[p[j]].state |= S_BLOCKED;
    }
    for (size_t i = 0; i < st->nwv; i++) {
        PREFETCH_WV(st, i, state);
        en_stitch_vertex *x = &st->v[st->wv[i]];
        if ((x->state & (S_SETTLED | S_BLOCKED)) || !(x->state & S_COMPLETE) || (wait && x->take == st->takes))
            continue;
        x->state |= S_SETTLED;
        if (decide(st, st->wv[i]))
            return -1;
    }
    size_t kept = 0;
    for (size_t f = 0; f < st->nwf; f++) {
        PREFETCH_WF(st, f, state);
        const uint32_t *p = st->wf[f].v;
        int final = 1;
        for (int j = 0; j < 3; j++)
            final &= (st->v[p[j]].state & S_SETTLED) != 0;
        if (!final) {
            st->wf[kept++] = st->wf[f];
            for (int j = 0; j < 3; j++)
                st->v[p[j]].state |= S_IN_FACE;
        } else if (final_face(st, p)) {
            return -1;
        }
    }
    st->nwf = kept;
    kept = 0;
    for (size_t i = 0; i < st->nwv; i++) {
        PREFETCH_WV(st, i, state);
        en_stitch_vertex *x = &st->v[st->wv[i]];
        if ((x->state & S_SETTLED) && !(x->state & S_IN_FACE)) {
            en_u64map_remove(&st->map, x->gid);
            x->state &= (uint16_t)~S_IN_W;
            continue;
        }
        st->wv[kept++] = st->wv[i];
    }
    st->nwv = kept;
    return 0;
}

static int put(en_stitcher *st, epsnet_record_kind kind, uint64_t a, uint64_t b, uint64_t c, const double *xyz,
               const uint8_t *attr, epsnet_error *err)
{
    epsnet_record rec;
    memset(&rec, 0, sizeof rec);
    rec.kind = kind;
    rec.attr = attr;
    rec.v[0] = a, rec.v[1] = b, rec.v[2] = c;
    if (xyz)
        memcpy(rec.xyz, xyz, sizeof rec.xyz);
    return en_stage_put(&st->out, &rec, err);
}

/* note: the run is written in id order, but its vertices' pool slots, their
 * attribute bytes and their faces' slots lie anywhere, and each was a miss
 * the loop waited on (write_until was 9% of a target's rounds, most of it
 * the first touch of the vertex and of its first face; bench/RESULTS.md,
 * session 30). Started WRITE_AHEAD entries early, the misses overlap; the
 * face slot, which needs the vertex, half as early. */
#define WRITE_AHEAD 8

/* Write every decided vertex below frontier, each with the faces it ends. */
static int write_until(en_stitcher *st, uint64_t frontier, epsnet_error *err)
{
    for (;;) {
        /* (in the loop itself, as W_AHEAD's) */
        if (st->vrun_head + WRITE_AHEAD < st->nvrun) {
            uint32_t ahead = st->vrun[st->vrun_head + WRITE_AHEAD].idx;
            __builtin_prefetch((const char *)&st->v[ahead], 1);
            __builtin_prefetch((const char *)&st->v[ahead] + 64, 1);
            __builtin_prefetch((const char *)&st->v[ahead] + 128, 1);
            if (st->attr_size)
                __builtin_prefetch(st->attr + (size_t)ahead * st->attr_size, 1);
            uint32_t slot = st->v[st->vrun[st->vrun_head + WRITE_AHEAD / 2].idx].first_face;
            if (slot != NO_SLOT)
                __builtin_prefetch(&st->fpool[slot], 1);
        }
        const en_vheap_entry *r = st->vrun_head < st->nvrun ? &st->vrun[st->vrun_head] : NULL;
        const en_vheap_entry *h = st->nvheap ? &st->vheap[0] : NULL;
        const en_vheap_entry *next = r && (!h || r->gid < h->gid) ? r : h;
        if (!next || next->gid >= frontier)
            break;
        en_vheap_entry e = next == r ? st->vrun[st->vrun_head++] : vheap_pop(st->vheap, &st->nvheap);
        en_stitch_vertex *x = &st->v[e.idx];
        if (x->remaining == 0) {
            if (!(x->state & S_IN_W))
                sv_free(st, e.idx); /* no face left around it: not written (docs/architecture.md §9) */
            continue;
        }
        x->out = st->next_out++;
        st->stats.out_vertices++;
        if (st->cost_hist && x->bucket != EN_COST_NONE && !(x->state & S_FIXED))
            st->cost_hist[x->bucket]++; /* what W left it to do, once */
        else if (st->level_hist && x->bucket != EN_COST_NONE && (x->state & S_SKELETON))
            st->level_hist[(size_t)x->level * EN_COST_BUCKETS + x->bucket]++;
        if (!(x->state & S_FIXED)) {
            st->stats.remaining_nonsamples++;
            if (x->state & S_BAND)
                st->stats.band_left++;
            else
                st->stats.inner_left++;
        }
        if (st->write_quadrics) {
            uint64_t marks = st->plan && st->plan->priced && (x->state & S_SKELETON)
                                 ? EN_MARK_SKELETON | (uint64_t)x->level << EN_MARK_LEVEL_SHIFT
                                 : 0;
            uint8_t *block = st->attr + (size_t)e.idx * st->attr_size + st->quadric_at;
            memcpy(block, &x->q, sizeof x->q);
            if (st->na)
                memcpy(block + sizeof x->q, st->aq + st->na * e.idx, st->na * sizeof *st->aq);
            memcpy(block + en_carried_marks_at(st->na ? st->weights->channels : 0), &marks, sizeof marks);
        }
        int rc = put(st, EPSNET_REC_VERTEX, 0, 0, 0, x->xyz,
                     st->attr_size ? st->attr + (size_t)e.idx * st->attr_size : NULL, err);
        if (rc)
            return rc;
        uint32_t slot = x->first_face;
        x->first_face = x->last_face = NO_SLOT;
        while (slot != NO_SLOT) {
            en_out_face f = st->fpool[slot];
            st->ffree[st->nffree++] = slot;
            st->nfwait--;
            slot = f.next;
            uint64_t o[3];
            for (int j = 0; j < 3; j++) {
                o[j] = st->v[f.v[j]].out;
                if (o[j] == UINT64_MAX)
                    return internal(err, "a face came before its vertices");
            }
            if ((rc = put(st, EPSNET_REC_TRIANGLE, o[0], o[1], o[2], NULL, NULL, err)) != 0)
                return rc;
            st->stats.out_faces++;
            for (int j = 0; j < 3; j++) {
                en_stitch_vertex *y = &st->v[f.v[j]];
                if (--y->remaining == 0 && !(y->state & S_IN_W)) {
                    if ((rc = put(st, EPSNET_REC_FINALIZE, y->out, 0, 0, NULL, NULL, err)) != 0)
                        return rc;
                    sv_free(st, f.v[j]);
                }
            }
        }
    }
    return 0;
}

static int take_vertices(en_stitcher *st, const en_slab_work *w, epsnet_error *err)
{
    if (en_grow((void **)&st->local, &st->local_cap, (size_t)w->s.nv + 1, sizeof *st->local))
        return oom(err);
    uint32_t at = 0; /* l's entry in q and aq (en_slab_work.packed) */
    for (uint32_t l = 0; l < w->nowned; l++) {
        st->local[l] = UINT32_MAX;
        uint32_t ql = w->packed ? at : l;
        at += w->valive[l] != 0;
        if (!w->valive[l] || w->degree[l] == 0)
            continue; /* collapsed in the slab, or used by no face */
        uint32_t idx;
        if (sv_new(st, &idx))
            return oom(err);
        en_stitch_vertex *x = &st->v[idx];
        x->gid = w->s.gid[l];
        memcpy(x->xyz, w->s.pos + 3 * (size_t)l, sizeof x->xyz);
        if (st->attr_size && w->attr_size) /* the slab's bytes may lack the quadric this writes */
            memcpy(st->attr + (size_t)idx * st->attr_size, w->attr + (size_t)l * w->attr_size,
                   w->attr_size < st->attr_size ? w->attr_size : st->attr_size);
        x->q = w->q[ql];
        if (st->na && w->aq)
            memcpy(st->aq + st->na * idx, w->aq + st->na * ql, st->na * sizeof *st->aq);
        x->out = UINT64_MAX;
        x->take = st->takes;
        x->bucket = EN_COST_NONE;
        x->remaining = w->degree[l];
        x->future = w->future[l];
        x->border = w->border[l];
        x->level = w->has_levels && (w->vclass[l] & EN_C_SAMPLE) ? w->vlevel[l] : 0;
        x->state = (uint16_t)(((w->vclass[l] & (EN_C_SAMPLE | EN_C_LOCKED)) ? S_FIXED : 0) |
                              ((w->vclass[l] & EN_C_USER) ? S_USER_LOCK : 0) | (w->band[l] ? S_BAND : 0));
        /* the finish finds boundaries and non-manifold spots again in its
         * own stars (docs/method.md §13: its membranes may be gone) */
        if ((w->vclass[l] & EN_C_SAMPLE) && !en_seam_locked(w->s.vflags[l]))
            x->state |= S_SKELETON;
        st->local[l] = idx;
        if (x->border == EN_BORDER_INNER) {
            x->state |= S_COMPLETE | S_SETTLED;
            if (decide(st, idx))
                return oom(err);
            continue;
        }
        if (en_grow((void **)&st->wv, &st->wv_cap, st->nwv + 1, sizeof *st->wv) ||
            en_u64map_put(&st->map, x->gid, idx)) {
            st->v[idx].state = 0;
            st->free_list[st->free_len++] = idx;
            return oom(err);
        }
        st->wv[st->nwv++] = idx;
        x->state |= S_IN_W;
        if (x->border == EN_BORDER_RING || x->future == 0)
            x->state |= S_COMPLETE;
        if (x->border == EN_BORDER_OUTER) {
            x->state |= S_SETTLED; /* decided by its slab; only a face corner here */
            if (decide(st, idx))
                return oom(err);
        }
    }
    for (uint32_t l = w->nowned; l < w->s.nv; l++)
        if (!en_u64map_get(&st->map, w->s.gid[l], &st->local[l]))
            st->local[l] = UINT32_MAX;
    return 0;
}

static int take_faces(en_stitcher *st, const en_slab_work *w, epsnet_error *err)
{
    size_t at = 0; /* f's entry in tri and ref (en_slab_work.packed) */
    for (uint32_t f = 0; f < w->s.nt; f++) {
        size_t tf = w->packed ? at : f;
        at += w->falive[f] != 0;
        if (!w->falive[f] || !(w->fflags[f] & EN_F_HOME))
            continue; /* collapsed away, or a later slab brings it */
        const uint32_t *t = w->tri + 3 * tf;
        uint32_t p[3];
        int seam = !(w->fflags[f] & EN_F_INTERIOR);
        for (int j = 0; j < 3; j++) {
            p[j] = st->local[t[j]];
            if (p[j] == UINT32_MAX)
                return internal(err, "a face names a vertex no slab handed over");
            seam |= t[j] < w->nowned && (w->border[t[j]] == EN_BORDER_FROZEN || w->border[t[j]] == EN_BORDER_RING);
        }
        if (!seam) {
            if (final_face(st, p))
                return oom(err);
            continue;
        }
        if (add_seam_face(st, p, w->ref + 3 * tf))
            return oom(err);
        if (w->fflags[f] & EN_F_INTERIOR)
            continue;
        for (int j = 0; j < 3; j++) {
            if (t[j] < w->nowned)
                continue;
            en_stitch_vertex *x = &st->v[p[j]];
            if (x->future == 0)
                return internal(err, "more faces arrived than a vertex expected");
            if (--x->future == 0)
                x->state |= S_COMPLETE;
        }
    }
    return 0;
}

int en_stitcher_take(en_stitcher *st, const en_slab_work *w, epsnet_error *err)
{
    st->stats.band_nonsamples += w->band_nonsamples;
    st->stats.inner_nonsamples += w->inner_nonsamples;
    st->taken += w->units_in;
    if (st->plan && st->plan->seams == EN_SEAMS_LEVEL) {
        double before = st->takes ? st->level_before : w->level;
        st->seam_level = fmin(before, w->level);
        st->level_before = w->level;
    }
    int rc = take_vertices(st, w, err);
    if (rc == 0)
        rc = take_faces(st, w, err);
    if (rc == 0)
        rc = collapse_seams(st, w->last, err);
    if (rc == 0 && settle(st, w->last))
        rc = oom(err);
    st->takes++;
    if (rc)
        return rc;
    uint64_t active = en_stitcher_active(st);
    if (active > st->stats.max_active)
        st->stats.max_active = active;
    uint64_t frontier = w->frontier;
    for (size_t i = 0; i < st->nwv; i++) {
        PREFETCH_WV(st, i, state);
        const en_stitch_vertex *x = &st->v[st->wv[i]];
        if (!(x->state & S_SETTLED) && x->gid < frontier)
            frontier = x->gid;
    }
    st->frontier = frontier;
    return write_until(st, frontier, err);
}

uint64_t en_stitcher_active(const en_stitcher *st)
{
    return st->nwv + st->nwf + st->nvheap + (st->nvrun - st->vrun_head) + st->nfwait;
}

uint64_t en_stitcher_bytes(const en_stitcher *st)
{
    return (uint64_t)st->v_cap * sizeof *st->v + st->free_cap * sizeof *st->free_list + en_u64map_bytes(&st->map) +
           st->wv_cap * sizeof *st->wv + st->wf_cap * sizeof *st->wf + st->vheap_cap * sizeof *st->vheap +
           st->vrun_cap * sizeof *st->vrun + st->fpool_cap * sizeof *st->fpool + st->ffree_cap * sizeof *st->ffree +
           st->local_cap * sizeof *st->local + st->attr_cap * st->attr_size + st->aq_cap * sizeof *st->aq;
}

int en_stitcher_finish(en_stitcher *st, epsnet_error *err)
{
    int rc = write_until(st, UINT64_MAX, err);
    if (rc == 0 && en_stitcher_active(st))
        return internal(err, "seams left open at the end of the stream");
    return rc;
}
