/* Vertex normals from the output's faces: see the header. */
#include "pipeline/normals_stage.h"

#include <math.h>
#include <string.h>

#include "common/alloc.h"
#include "common/error.h"
#include "common/hash64.h"
#include "common/idmap.h"
#include "common/u64map.h"

#define NO_FACE UINT32_MAX

typedef struct held {
    double xyz[3];
    double n[3];              /* Σ of its faces' cross products (twice their areas) */
    uint32_t faces_left;      /* faces that arrived and are not written yet */
    uint32_t first, last;     /* faces whose last corner it is, in arrival order */
    uint32_t copy;            /* the next held copy of its position (a ring; itself when alone) */
    uint8_t finalized, written;
    uint8_t shared;           /* n is its position's whole sum, set when the first copy is written */
} held;

typedef struct face {
    uint64_t v[3];
    uint32_t next;            /* in its last corner's list, or the free chain */
} face;

struct en_normals_stage {
    en_stage next;
    uint32_t in_size, out_size;
    en_idmap map;             /* live id -> slot in v */
    en_u64map at;             /* position -> a slot of its ring of copies, until one is written */
    held *v;
    uint8_t *attr;            /* out_size bytes per slot: the record's, then the normal */
    uint32_t *free_v;
    size_t nv, cap_v, cap_attr, nfree_v, cap_free_v;
    face *f;
    size_t nf, cap_f;
    uint32_t free_f;
    uint64_t next_in, next_out;   /* ids: records taken, vertices written */
    int failed;
};

int en_normals_layout(const epsnet_attr_layout *in, epsnet_attr_layout *out)
{
    static const char *const names[3] = { "nx", "ny", "nz" };
    *out = *in;
    for (int k = 0; k < 3; k++)
        if (epsnet_attr_layout_find(in, names[k]) >= 0 || epsnet_attr_layout_add(out, names[k], EPSNET_ATTR_FLOAT32) < 0)
            return -1;
    return 0;
}

static int oom(en_normals_stage *ns, epsnet_error *err)
{
    ns->failed = EPSNET_ENOMEM;
    return en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "out of memory recomputing vertex normals");
}

static int internal(en_normals_stage *ns, epsnet_error *err, const char *what)
{
    ns->failed = EPSNET_EINTERNAL;
    return en_error_set(err, EPSNET_EINTERNAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "normals: %s (a bug)", what);
}

/* Is corner k of face v one of its earlier corners? A face that repeats a
 * corner counts it once. */
static int repeats(const uint64_t v[3], int k)
{
    return (k > 0 && v[k] == v[0]) || (k == 2 && v[2] == v[1]);
}

static held *slot_of(en_normals_stage *ns, uint64_t id, uint32_t *slot)
{
    return en_idmap_get(&ns->map, id, slot) ? &ns->v[*slot] : NULL;
}

/* The key of a position in `at` (UINT64_MAX is the map's own). */
static uint64_t position_key(const double xyz[3])
{
    uint64_t k = en_hash_bytes(xyz, 3 * sizeof *xyz);
    return k == UINT64_MAX ? k - 1 : k;
}

/* Take slot's position out of `at` when the entry is its ring's (another
 * position with the same key may have taken it over). */
static void forget_position(en_normals_stage *ns, uint32_t slot)
{
    uint64_t key = position_key(ns->v[slot].xyz);
    uint32_t s;
    if (en_u64map_get(&ns->at, key, &s) && memcmp(ns->v[s].xyz, ns->v[slot].xyz, sizeof ns->v[s].xyz) == 0)
        en_u64map_remove(&ns->at, key);
}

/* Whether slot can be written: it is finalized, and so are the copies of
 * its position, unless their sum is taken already. */
static int ready(const en_normals_stage *ns, uint32_t slot)
{
    const held *h = &ns->v[slot];
    if (!h->finalized)
        return 0;
    for (uint32_t c = h->copy; !h->shared && c != slot; c = ns->v[c].copy)
        if (!ns->v[c].finalized)
            return 0;
    return 1;
}

/* Give slot's ring of copies their position's sum, once. */
static void share(en_normals_stage *ns, uint32_t slot)
{
    held *h = &ns->v[slot];
    if (h->shared)
        return;
    double sum[3] = { h->n[0], h->n[1], h->n[2] };
    for (uint32_t c = h->copy; c != slot; c = ns->v[c].copy)
        for (int k = 0; k < 3; k++)
            sum[k] += ns->v[c].n[k];
    uint32_t c = slot;
    do {
        memcpy(ns->v[c].n, sum, sizeof sum);
        ns->v[c].shared = 1;
        c = ns->v[c].copy;
    } while (c != slot);
    forget_position(ns, slot); /* later copies make a ring of their own */
}

/* Vertex id's finalization, once it is written and its faces are. */
static int maybe_finalize(en_normals_stage *ns, uint64_t id, uint32_t slot, epsnet_error *err)
{
    held *h = &ns->v[slot];
    if (!h->finalized || !h->written || h->faces_left)
        return 0;
    epsnet_record r = { .kind = EPSNET_REC_FINALIZE, .v = { id, 0, 0 } };
    int rc = en_stage_put(&ns->next, &r, err);
    if (rc)
        return rc;
    en_idmap_remove(&ns->map, id);
    uint32_t p = slot;
    while (ns->v[p].copy != slot)
        p = ns->v[p].copy;
    ns->v[p].copy = h->copy; /* out of its ring */
    ns->free_v[ns->nfree_v++] = slot;
    return 0;
}

/* Write vertex next_out (it is finalized: its normal is whole), then the
 * faces it is the last corner of, then what they free. */
static int write_next(en_normals_stage *ns, epsnet_error *err)
{
    uint64_t id = ns->next_out;
    uint32_t slot;
    held *h = slot_of(ns, id, &slot);
    if (!h)
        return internal(ns, err, "a vertex to write is not held");
    share(ns, slot);
    float n[3] = { 0, 0, 0 };
    double len = sqrt(h->n[0] * h->n[0] + h->n[1] * h->n[1] + h->n[2] * h->n[2]);
    if (len > 0 && isfinite(len))
        for (int k = 0; k < 3; k++)
            n[k] = (float)(h->n[k] / len);
    uint8_t *a = ns->attr + (size_t)slot * ns->out_size;
    memcpy(a + ns->in_size, n, sizeof n);
    epsnet_record r = { .kind = EPSNET_REC_VERTEX, .xyz = { h->xyz[0], h->xyz[1], h->xyz[2] }, .attr = a };
    int rc = en_stage_put(&ns->next, &r, err);
    if (rc)
        return rc;
    ns->next_out++;
    h->written = 1;
    uint32_t fi = h->first;
    h->first = h->last = NO_FACE;
    /* (its own finalization comes in the loop when it is a corner of the
     * last face written here) */
    int last_face_here = fi != NO_FACE;
    while (fi != NO_FACE && rc == 0) {
        face *f = &ns->f[fi];
        epsnet_record t = { .kind = EPSNET_REC_TRIANGLE, .v = { f->v[0], f->v[1], f->v[2] } };
        rc = en_stage_put(&ns->next, &t, err);
        uint32_t next = f->next;
        f->next = ns->free_f;
        ns->free_f = fi;
        fi = next;
        for (int k = 0; k < 3 && rc == 0; k++) {
            uint32_t cs;
            held *c = slot_of(ns, t.v[k], &cs);
            if (!c)
                return internal(ns, err, "a face's corner is not held");
            if (repeats(t.v, k))
                continue;
            c->faces_left--;
            rc = maybe_finalize(ns, t.v[k], cs, err);
        }
    }
    return rc || last_face_here ? rc : maybe_finalize(ns, id, slot, err);
}

static int flush(en_normals_stage *ns, epsnet_error *err)
{
    int rc = 0;
    uint32_t slot;
    while (rc == 0 && ns->next_out < ns->next_in) {
        if (!slot_of(ns, ns->next_out, &slot) || !ready(ns, slot))
            break;
        rc = write_next(ns, err);
    }
    return rc;
}

static int stage_put(void *self, const epsnet_record *rec, epsnet_error *err)
{
    en_normals_stage *ns = self;
    if (ns->failed)
        return en_error_set(err, ns->failed, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "normals: failed before");
    if (rec->kind == EPSNET_REC_VERTEX) {
        if (ns->nfree_v == 0) {
            if (ns->nv >= UINT32_MAX - 1 || en_grow((void **)&ns->v, &ns->cap_v, ns->nv + 1, sizeof *ns->v))
                return oom(ns, err);
            if (en_grow((void **)&ns->attr, &ns->cap_attr, ns->nv + 1, ns->out_size) ||
                en_grow((void **)&ns->free_v, &ns->cap_free_v, ns->nv + 1, sizeof *ns->free_v))
                return oom(ns, err);
            ns->free_v[ns->nfree_v++] = (uint32_t)ns->nv++;
        }
        uint32_t slot = ns->free_v[ns->nfree_v - 1];
        if (en_idmap_put(&ns->map, ns->next_in, slot))
            return oom(ns, err);
        ns->nfree_v--;
        held *h = &ns->v[slot];
        memset(h, 0, sizeof *h);
        memcpy(h->xyz, rec->xyz, sizeof h->xyz);
        h->first = h->last = NO_FACE;
        h->copy = slot;
        uint64_t key = position_key(h->xyz);
        uint32_t other;
        if (en_u64map_get(&ns->at, key, &other) && memcmp(ns->v[other].xyz, h->xyz, sizeof h->xyz) == 0) {
            h->copy = ns->v[other].copy; /* into the ring of its position's copies */
            ns->v[other].copy = slot;
        } else if (en_u64map_put(&ns->at, key, slot)) {
            return oom(ns, err);
        }
        if (ns->in_size)
            memcpy(ns->attr + (size_t)slot * ns->out_size, rec->attr, ns->in_size);
        ns->next_in++;
        return 0;
    }
    if (rec->kind == EPSNET_REC_TRIANGLE) {
        uint32_t s[3];
        held *c[3];
        for (int k = 0; k < 3; k++)
            if (!(c[k] = slot_of(ns, rec->v[k], &s[k])) || c[k]->written)
                return internal(ns, err, "a face on a vertex not held, or already written");
        double e1[3], e2[3];
        for (int k = 0; k < 3; k++)
            e1[k] = c[1]->xyz[k] - c[0]->xyz[k], e2[k] = c[2]->xyz[k] - c[0]->xyz[k];
        double n[3] = { e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0] };
        uint64_t last = rec->v[0];
        uint32_t ls = s[0];
        for (int k = 0; k < 3; k++) {
            if (repeats(rec->v, k))
                continue;
            for (int i = 0; i < 3; i++)
                c[k]->n[i] += n[i];
            c[k]->faces_left++;
            if (rec->v[k] > last)
                last = rec->v[k], ls = s[k];
        }
        uint32_t fi = ns->free_f;
        if (fi != NO_FACE) {
            ns->free_f = ns->f[fi].next;
        } else {
            if (ns->nf >= UINT32_MAX - 1 || en_grow((void **)&ns->f, &ns->cap_f, ns->nf + 1, sizeof *ns->f))
                return oom(ns, err);
            fi = (uint32_t)ns->nf++;
        }
        face *f = &ns->f[fi];
        memcpy(f->v, rec->v, sizeof f->v);
        f->next = NO_FACE;
        held *h = &ns->v[ls];
        if (h->last == NO_FACE)
            h->first = fi;
        else
            ns->f[h->last].next = fi;
        h->last = fi;
        return 0;
    }
    if (rec->kind == EPSNET_REC_FINALIZE) {
        uint32_t slot;
        held *h = slot_of(ns, rec->v[0], &slot);
        if (!h || h->finalized)
            return internal(ns, err, "a finalization of a vertex not held");
        h->finalized = 1;
        return flush(ns, err);
    }
    return 0;
}

static int stage_end(void *self, epsnet_error *err)
{
    en_normals_stage *ns = self;
    if (ns->failed)
        return en_error_set(err, ns->failed, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "normals: failed before");
    /* what the stream never finalized is final at its end, in id order */
    int rc = 0;
    for (uint64_t id = ns->next_out; id < ns->next_in && rc == 0; id++) {
        uint32_t slot;
        held *h = slot_of(ns, id, &slot);
        if (h)
            h->finalized = 1;
    }
    rc = flush(ns, err);
    if (rc == 0 && (ns->next_out != ns->next_in || ns->map.count))
        rc = internal(ns, err, "vertices left at the end");
    return rc ? rc : en_stage_end(&ns->next, err);
}

int en_normals_stage_new(en_normals_stage **out, uint32_t in_attr_size, en_stage next, epsnet_error *err)
{
    en_normals_stage *ns = en_calloc(1, sizeof *ns);
    if (!ns || en_idmap_init_growing(&ns->map, (size_t)1 << 24) || en_u64map_init(&ns->at)) {
        if (ns)
            en_idmap_free(&ns->map);
        en_free(ns);
        *out = NULL;
        return en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    ns->next = next;
    ns->in_size = in_attr_size;
    ns->out_size = in_attr_size + 3 * (uint32_t)sizeof(float);
    ns->free_f = NO_FACE;
    *out = ns;
    return 0;
}

en_stage en_normals_stage_input(en_normals_stage *ns)
{
    return (en_stage){ stage_put, stage_end, ns };
}

void en_normals_stage_free(en_normals_stage **p)
{
    en_normals_stage *ns = *p;
    if (!ns)
        return;
    en_idmap_free(&ns->map);
    en_u64map_free(&ns->at);
    en_free(ns->v);
    en_free(ns->attr);
    en_free(ns->free_v);
    en_free(ns->f);
    en_free(ns);
    *p = NULL;
}
