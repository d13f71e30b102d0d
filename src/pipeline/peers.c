/*
 * One run's slabs shared among processes: the ranks' messages, a slab's
 * input out and its results back, array by array (pipeline/peers.h,
 * docs/distributed.md).
 */
#include "pipeline/peers.h"

#include <stdio.h>
#include <string.h>

#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"

#define MSG_MAGIC 0x65707332u /* "eps2" */

enum { MSG_SLAB = 1, MSG_WANT, MSG_END, MSG_INPUT, MSG_NONE, MSG_DONE, MSG_VERDICT };

/* The header of every message. Ranks run one build, so its layout is
 * theirs alike. */
typedef struct en_peer_msg {
    uint32_t magic, type;
    uint64_t slab;                /* SLAB, INPUT */
    uint64_t bytes;               /* SLAB, INPUT: its head's bytes; the arrays follow */
    int32_t status;               /* END, VERDICT: 0 or a negative code */
    int32_t rank;                 /* the sender; VERDICT: the rank that failed */
    epsnet_error err;             /* END, VERDICT with a failure */
} en_peer_msg;

/* Rank 0: the slabs shipped to one rank whose results it has not handed
 * on yet, oldest first (a rank works and returns them in that order). */
typedef struct shipped {
    en_slab_work **w;
    uint8_t *got;                 /* its results are in */
    size_t head, n, cap;
} shipped;

struct en_peer_link {
    epsnet_peers p;
    char path[512];               /* the input, for messages */
    uint8_t *ended;               /* rank 0: per rank, its END taken */
    uint8_t *waiting;             /* rank 0: per rank, its WANT taken and not yet answered */
    shipped *out;                 /* rank 0: per rank */
    /* rank 0, what it weighs where a slab goes (en_peer_pick): */
    int dealing;                  /* it has dealt a slab */
    uint64_t shipped_total;       /* the slabs it sent */
    double cpu_start;             /* its own CPU seconds then (a sort before the pass is not counted) */
    double *worked;               /* per rank: the seconds its workers took over the slabs returned */
    uint64_t *returned;           /* ... and their count */
    uint8_t *scratch;             /* rank r: a results array's entries alive, packed to be sent */
    size_t scratch_cap;
    int culprit;                  /* rank 0: a rank whose failing END stopped the run (0: none), */
    epsnet_error culprit_err;     /* ... in its own words */
};

int en_peer_link_new(en_peer_link **out, const epsnet_peers *peers, const char *path, epsnet_error *err)
{
    *out = NULL;
    if (!peers->send || !peers->recv || !peers->poll || peers->size < 1 || peers->rank < 0 ||
        peers->rank >= peers->size)
        return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "settings.peers: rank %d of %d, or no send, recv or poll function", peers->rank,
                            peers->size);
    en_peer_link *l = en_calloc(1, sizeof *l);
    if (!l || !(l->ended = en_calloc((size_t)peers->size, 1)) || !(l->waiting = en_calloc((size_t)peers->size, 1)) ||
        !(l->out = en_calloc((size_t)peers->size, sizeof *l->out)) ||
        !(l->worked = en_calloc((size_t)peers->size, sizeof *l->worked)) ||
        !(l->returned = en_calloc((size_t)peers->size, sizeof *l->returned))) {
        if (l) {
            en_free(l->ended);
            en_free(l->waiting);
            en_free(l->out);
            en_free(l->worked);
        }
        en_free(l);
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    l->p = *peers;
    snprintf(l->path, sizeof l->path, "%s", path ? path : "");
    *out = l;
    return 0;
}

void en_peer_link_free(en_peer_link **pl)
{
    en_peer_link *l = *pl;
    if (!l)
        return;
    for (int r = 0; r < l->p.size; r++) {
        en_free(l->out[r].w);
        en_free(l->out[r].got);
    }
    en_free(l->out);
    en_free(l->scratch);
    en_free(l->worked);
    en_free(l->returned);
    en_free(l->ended);
    en_free(l->waiting);
    en_free(l);
    *pl = NULL;
}

int en_peer_rank(const en_peer_link *link)
{
    return link->p.rank;
}

int en_peer_count(const en_peer_link *link)
{
    return link->p.size;
}

uint64_t en_peer_slabs_shipped(const en_peer_link *l)
{
    return l->shipped_total;
}

size_t en_peer_slabs_held(int workers)
{
    return (size_t)(workers > 1 ? workers : 1) + 2;
}

static int transport_failed(const en_peer_link *l, const char *what, int other, epsnet_error *err)
{
    return en_error_set(err, EPSNET_EIO, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "rank %d: the transport failed to %s rank %d", l->p.rank, what, other);
}

static int send_bytes(en_peer_link *l, int to, const void *p, size_t n, epsnet_error *err)
{
    return l->p.send(l->p.opaque, to, p, n) ? transport_failed(l, "send to", to, err) : 0;
}

static int recv_bytes(en_peer_link *l, int from, void *p, size_t n, epsnet_error *err)
{
    return l->p.recv(l->p.opaque, from, p, n) ? transport_failed(l, "receive from", from, err) : 0;
}

/* rank: the sender, or for a VERDICT the rank whose failure it is */
static int send_msg(en_peer_link *l, int to, uint32_t type, uint64_t slab, uint64_t bytes, int status, int rank,
                    const epsnet_error *e, epsnet_error *err)
{
    en_peer_msg m;
    memset(&m, 0, sizeof m);
    m.magic = MSG_MAGIC;
    m.type = type;
    m.slab = slab;
    m.bytes = bytes;
    m.status = status;
    m.rank = rank;
    if (e && status)
        m.err = *e;
    return send_bytes(l, to, &m, sizeof m, err);
}

static int recv_msg(en_peer_link *l, int from, en_peer_msg *m, epsnet_error *err)
{
    int rc = recv_bytes(l, from, m, sizeof *m, err);
    if (rc == 0 && (m->magic != MSG_MAGIC || m->type < MSG_SLAB || m->type > MSG_VERDICT))
        rc = en_error_set(err, EPSNET_EIO, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                          "rank %d: a message from rank %d is not epsnet's (another program, or another build?)",
                          l->p.rank, from);
    return rc;
}

/* The error another rank failed with, named by its rank. */
static int peer_failure(const en_peer_link *l, const en_peer_msg *m, epsnet_error *err)
{
    *err = m->err;
    if (m->rank != 0 || l->p.rank != 0) {
        char reason[sizeof err->reason];
        snprintf(reason, sizeof reason, "%s", m->err.reason);
        snprintf(err->reason, sizeof err->reason, "rank %d: %.*s", m->rank, (int)sizeof err->reason - 16, reason);
    }
    err->code = m->status;
    return m->status;
}

static int unexpected(const en_peer_link *l, const en_peer_msg *m, const char *wanted, epsnet_error *err)
{
    return en_error_set(err, EPSNET_EINTERNAL, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "rank %d: message %u (slab %llu) from rank %d where %s was due (a bug)", l->p.rank,
                        m->type, (unsigned long long)m->slab, m->rank, wanted);
}

/* ---- a slab work's results, array by array ----
 *
 * A slab's results go as a head (its shape, which arrays follow, the
 * scalars, and each array's bytes), then one message per array, sent
 * from the slab work's own arrays and received straight into the ones
 * rank 0's chunker cut (a copy of every slab's results made rank 0 peak
 * 20 MB above one process at 20M faces). The arrays of the vertices'
 * quadrics and of the faces' corners and normals carry only the entries
 * still alive, packed (the stitcher reads no other; about a tenth of them
 * on the default path), in order: valive and falive come before them.
 * Rank 0 keeps them packed (en_slab_work.packed): the slab work shed its
 * full-size ones when the slab was shipped, and scattered back into them
 * the results waiting for the stitcher held about 11 MB a slab, most of
 * rank 0's excess over one process (bench/RESULTS.md, session 35). */

#define MAX_SECTIONS 24

typedef struct section {
    void *p;
    size_t n;                     /* bytes */
    const uint8_t *alive;         /* NULL, or per entry: only the ones alive travel */
    size_t unit;                  /* ... each of this many bytes */
    void **packed;                /* rank 0: the array the entries alive arrive in, packed (p is set */
    size_t *cap, size;            /* ... once it has room: its capacity, its element's bytes) */
} section;

#define SCALARS(X)                                                                                                    \
    X(faces_in) X(membrane_faces) X(counts) X(has_levels) X(level_count) X(band_nonsamples) X(inner_nonsamples)       \
    X(collapses) X(refused) X(given_up) X(skeleton_kept) X(keep_faces) X(faces_left) X(vertices_left) X(units_in)     \
    X(stopped_by_error) X(level) X(counted_vertices) X(seconds)

#define SCALAR_BYTES(f) +sizeof(((en_slab_work *)0)->f)
/* The head: shape (3 words), which arrays (4 bytes), the scalars, the
 * count of arrays, each one's bytes, and the bytes sent of each (fewer
 * where only the entries alive go). */
#define ARRAYS_AT (3 * sizeof(uint32_t) + 4 SCALARS(SCALAR_BYTES))
#define HEAD_BYTES (ARRAYS_AT + (1 + 2 * MAX_SECTIONS) * sizeof(uint64_t))

/* The count of arrays after a head, each one's bytes, and those sent. */
static void head_arrays(const uint8_t *head, uint64_t *count, uint64_t bytes[MAX_SECTIONS],
                        uint64_t sent[MAX_SECTIONS])
{
    memcpy(count, head + ARRAYS_AT, sizeof *count);
    memcpy(bytes, head + ARRAYS_AT + sizeof *count, MAX_SECTIONS * sizeof *bytes);
    memcpy(sent, head + ARRAYS_AT + sizeof *count + MAX_SECTIONS * sizeof *bytes, MAX_SECTIONS * sizeof *sent);
}

static size_t weighed_doubles(const en_slab_work *w)
{
    uint32_t channels = w->weights && w->attr ? w->weights->channels : 0;
    return channels ? en_aq_doubles(channels) : 0;
}

typedef struct head {
    uint32_t shape[3];            /* owned vertices, vertices, faces (after the glued membranes) */
    uint8_t has[4];               /* attribute quadrics, cost, level and taken histograms */
} head;

/* The arrays of w's results, in order, for a slab of shape h: where they
 * are (after growing them to fit, grow: rank 0) and their bytes. @return
 * the count, or -1 (out of memory). */
static int sections(en_slab_work *w, const head *h, int grow, section *out)
{
    size_t no = h->shape[0], nt = h->shape[2], na = weighed_doubles(w);
    int n = 0;
#define ARRAY(ptr, capf, count, size)                                                                                 \
    do {                                                                                                              \
        if (grow && en_grow((void **)&(ptr), &(capf), (size_t)(count) + 1, (size)))                                   \
            return -1;                                                                                                \
        out[n++] = (section){ .p = (ptr), .n = (size_t)(count) * (size) };                                            \
    } while (0)
/* an array whose entries alive alone travel: rank 0 takes them packed */
#define ALIVE(ptr, capf, count, esize, mask, entries)                                                                 \
    do {                                                                                                              \
        out[n] = (section){ .p = grow ? NULL : (ptr), .n = (size_t)(count) * (esize) };                               \
        if (entries)                                                                                                  \
            out[n].alive = (mask), out[n].unit = out[n].n / (entries);                                                \
        if (grow)                                                                                                     \
            out[n].packed = (void **)&(ptr), out[n].cap = &(capf), out[n].size = (esize);                             \
        n++;                                                                                                          \
    } while (0)
#define HIST(ptr, count)                                                                                              \
    do {                                                                                                              \
        if (grow && !(ptr) && !((ptr) = en_malloc((size_t)(count) * sizeof *(ptr))))                                  \
            return -1;                                                                                                \
        out[n++] = (section){ .p = (ptr), .n = (size_t)(count) * sizeof *(ptr) };                                     \
    } while (0)
    out[n++] = (section){ .p = w->s.vflags, .n = no }; /* rank 0's chunker made them: boundary and seam flags come */
    ARRAY(w->vclass, w->cap.vclass, no, 1);
    if (w->has_levels)
        ARRAY(w->vlevel, w->cap.vlevel, no, 1);
    ARRAY(w->valive, w->cap.valive, no, 1);
    ARRAY(w->degree, w->cap.degree, no, sizeof *w->degree);
    ARRAY(w->future, w->cap.future, no, sizeof *w->future);
    ARRAY(w->border, w->cap.border, no, 1);
    ARRAY(w->band, w->cap.band, no, 1);
    ALIVE(w->q, w->cap.q, no, sizeof *w->q, w->valive, no);
    if (h->has[0])
        ALIVE(w->aq, w->cap.aq, na * no, sizeof *w->aq, w->valive, no);
    out[n++] = (section){ .p = w->fflags, .n = nt }; /* compacted with the membranes' faces gone */
    ARRAY(w->falive, w->cap.falive, nt, 1);
    ALIVE(w->tri, w->cap.tri, 3 * nt, sizeof *w->tri, w->falive, nt);
    ALIVE(w->ref, w->cap.ref, 3 * nt, sizeof *w->ref, w->falive, nt);
    if (h->has[1])
        HIST(w->cost_hist, EN_COST_BUCKETS);
    if (h->has[2])
        HIST(w->level_hist, (size_t)EN_LEVELS * EN_COST_BUCKETS);
    if (h->has[3])
        HIST(w->taken_hist, EN_COST_BUCKETS);
#undef ARRAY
#undef ALIVE
#undef HIST
    return n;
}

/* The bytes of a section that travel. */
static size_t sent_bytes(const section *x)
{
    if (!x->alive)
        return x->n;
    size_t entries = x->n / x->unit, alive = 0;
    for (size_t i = 0; i < entries; i++)
        alive += x->alive[i] != 0;
    return alive * x->unit;
}

/* Where a section's bytes travel from: the section itself, or, when only
 * its entries alive travel, those packed in order into the link's scratch.
 * NULL: out of memory. */
static void *packed_from(en_peer_link *l, const section *x, size_t bytes)
{
    if (!x->alive)
        return x->p;
    if (en_grow((void **)&l->scratch, &l->scratch_cap, bytes + 1, 1))
        return NULL;
    size_t entries = x->n / x->unit;
    const uint8_t *entry = x->p;
    uint8_t *to = l->scratch;
    for (size_t i = 0; i < entries; i++, entry += x->unit)
        if (x->alive[i]) {
            memcpy(to, entry, x->unit);
            to += x->unit;
        }
    return l->scratch;
}

static void put(uint8_t **at, const void *p, size_t n)
{
    memcpy(*at, p, n);
    *at += n;
}

static void get(const uint8_t **at, void *p, size_t n)
{
    memcpy(p, *at, n);
    *at += n;
}


/* ---- rank r: results out ---- */

int en_peer_send_slab(en_peer_link *l, const en_slab_work *cw, epsnet_error *err)
{
    en_slab_work *w = (en_slab_work *)cw; /* sections() only reads it here (grow 0) */
    head h = { { w->nowned, w->s.nv, w->s.nt },
               { weighed_doubles(w) && w->aq, w->cost_hist != NULL, w->level_hist != NULL, w->taken_hist != NULL } };
    section sec[MAX_SECTIONS];
    int n = sections(w, &h, 0, sec);
    uint8_t buf[HEAD_BYTES], *at = buf;
    put(&at, h.shape, sizeof h.shape);
    put(&at, h.has, sizeof h.has);
#define PUT_SCALAR(f) put(&at, &w->f, sizeof w->f);
    SCALARS(PUT_SCALAR)
#undef PUT_SCALAR
    uint64_t count = (uint64_t)n, bytes[MAX_SECTIONS] = { 0 }, sent[MAX_SECTIONS] = { 0 };
    for (int i = 0; i < n; i++) {
        bytes[i] = sec[i].n;
        sent[i] = sent_bytes(&sec[i]);
    }
    put(&at, &count, sizeof count);
    put(&at, bytes, sizeof bytes);
    put(&at, sent, sizeof sent);
    int rc = send_msg(l, 0, MSG_SLAB, w->index, HEAD_BYTES, 0, l->p.rank, NULL, err);
    if (rc == 0)
        rc = send_bytes(l, 0, buf, sizeof buf, err);
    for (int i = 0; i < n && rc == 0; i++) {
        if (!sent[i]) /* an empty array is not sent: both sides know it is */
            continue;
        void *from = packed_from(l, &sec[i], sent[i]);
        if (!from)
            return en_error_set(err, EPSNET_ENOMEM, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        rc = send_bytes(l, 0, from, sent[i], err);
    }
    return rc;
}

static int not_this_slab(const en_peer_link *l, const en_slab_work *w, int from, epsnet_error *err)
{
    return en_error_set(err, EPSNET_EINTERNAL, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "slab %u from rank %d does not fit the slab shipped there (a bug)", w->index, from);
}

/* Rank 0: slab w's results, after their header m, from rank `from`. */
static int take_results(en_peer_link *l, int from, const en_peer_msg *m, en_slab_work *w, epsnet_error *err)
{
    uint8_t buf[HEAD_BYTES];
    const uint8_t *at = buf;
    if (m->bytes != HEAD_BYTES || m->slab != w->index)
        return not_this_slab(l, w, from, err);
    int rc = recv_bytes(l, from, buf, sizeof buf, err);
    if (rc)
        return rc;
    head h;
    get(&at, h.shape, sizeof h.shape);
    get(&at, h.has, sizeof h.has);
    if (h.shape[0] != w->nowned || h.shape[1] != w->s.nv || h.shape[2] > w->s.nt || (h.has[0] && !weighed_doubles(w)))
        return not_this_slab(l, w, from, err);
#define GET_SCALAR(f) get(&at, &w->f, sizeof w->f);
    SCALARS(GET_SCALAR)
#undef GET_SCALAR
    uint64_t count, bytes[MAX_SECTIONS], sent[MAX_SECTIONS];
    head_arrays(buf, &count, bytes, sent);
    w->s.nt = h.shape[2]; /* after the glued membranes the worker dropped */
    section sec[MAX_SECTIONS];
    int n = sections(w, &h, 1, sec);
    if (n < 0)
        return en_error_set(err, EPSNET_ENOMEM, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory taking slab %u from rank %d", w->index, from);
    if (count != (uint64_t)n)
        return not_this_slab(l, w, from, err);
    for (int i = 0; i < n; i++)
        if (bytes[i] != sec[i].n)
            return not_this_slab(l, w, from, err);
    for (int i = 0; i < n && rc == 0; i++) {
        /* a packed array's size follows from its mask, received before it */
        if (sent[i] != sent_bytes(&sec[i]))
            return not_this_slab(l, w, from, err);
        if (sec[i].packed) {
            if (en_grow(sec[i].packed, sec[i].cap, sent[i] / sec[i].size + 1, sec[i].size))
                return en_error_set(err, EPSNET_ENOMEM, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                    "out of memory taking slab %u from rank %d", w->index, from);
            sec[i].p = *sec[i].packed;
        }
        if (sent[i])
            rc = recv_bytes(l, from, sec[i].p, sent[i], err);
    }
    w->packed = 1;
    return rc;
}

/* ---- a slab's input out, with the settings it is worked at ----
 *
 * The head: the slab's shape and scalars, and its settings as rank 0 has
 * them (ranks run one build, so the structures' layouts are theirs alike;
 * a plan's count ranges are a pricing pass's, which is never shipped).
 * Then its arrays, each from and into the slab work's own. */

typedef struct input_head {
    uint32_t nv, nt, nowned, attr_size;
    int32_t last, lock_type;
    uint32_t frequency, quadric_at, lock_offset;
    uint8_t has_plan, has_weights;
    double max_normal_dev;
    gauss_rotation rot;
    en_pass_plan plan;
    en_attr_weights weights;
} input_head;

/* The input arrays of w, whose slab's shape is set (after growing the
 * slab work's own to it, grow). */
static int input_sections(en_slab_work *w, int grow, section *out)
{
    size_t nv = w->s.nv, nt = w->s.nt;
    if (grow && (en_grow((void **)&w->owner, &w->cap.owner, nv + 1, sizeof *w->owner) ||
                 en_grow((void **)&w->fflags, &w->cap.fflags, nt + 1, 1) ||
                 (w->attr_size && en_grow((void **)&w->attr, &w->cap.attr, nv * w->attr_size + 1, 1))))
        return -1;
    int n = 0;
    out[n++] = (section){ .p = w->s.gid, .n = nv * sizeof *w->s.gid };
    out[n++] = (section){ .p = w->s.pos, .n = nv * 3 * sizeof *w->s.pos };
    out[n++] = (section){ .p = w->s.vflags, .n = nv };
    out[n++] = (section){ .p = w->owner, .n = nv * sizeof *w->owner };
    out[n++] = (section){ .p = w->attr, .n = w->attr_size ? nv * w->attr_size : 0 };
    out[n++] = (section){ .p = w->s.tri, .n = nt * 3 * sizeof *w->s.tri };
    out[n++] = (section){ .p = w->fflags, .n = nt };
    return n;
}

/* ---- rank 0 ---- */

/* The oldest slab shipped to r whose results are not in yet: its place
 * after o->head (o->n: none). */
static size_t first_missing(const shipped *o)
{
    size_t i = 0;
    while (i < o->n && o->got[o->head + i])
        i++;
    return i;
}

/* Rank 0: the next message from rank r, acted on: results into the slab
 * they are for, a WANT noted, an END a failure. */
static int take(en_peer_link *l, int r, epsnet_error *err)
{
    en_peer_msg m;
    int rc = recv_msg(l, r, &m, err);
    if (rc)
        return rc;
    shipped *o = &l->out[r];
    switch (m.type) {
    case MSG_WANT:
        if (l->waiting[r])
            return unexpected(l, &m, "a slab's results", err);
        l->waiting[r] = 1;
        return 0;
    case MSG_SLAB: {
        size_t i = first_missing(o);
        if (i == o->n)
            return unexpected(l, &m, "a want", err);
        if ((rc = take_results(l, r, &m, o->w[o->head + i], err)) == 0) {
            o->got[o->head + i] = 1;
            l->worked[r] += o->w[o->head + i]->seconds;
            l->returned[r]++;
        }
        return rc;
    }
    case MSG_END:
        l->ended[r] = 1;
        if (m.status) {
            l->culprit = r;
            l->culprit_err = m.err;
            return peer_failure(l, &m, err);
        }
        return en_error_set(err, EPSNET_EINTERNAL, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "rank %d ended in the middle of the run without a failure (a bug)", r);
    default:
        return unexpected(l, &m, "a want or a slab", err);
    }
}

/* The slabs rank r holds: shipped, their results not in. */
static size_t holding(const en_peer_link *l, int r)
{
    const shipped *o = &l->out[r];
    size_t n = 0;
    for (size_t i = 0; i < o->n; i++)
        n += !o->got[o->head + i];
    return n;
}

/*
 * Is rank 0 no busier than the other ranks, on average? Its own part of a
 * run (reading, cutting, stitching, writing: about a fifth of what one
 * process spends at -j 1) comes on top of the slabs it works, so it keeps
 * a slab only while its CPU seconds so far are at most the seconds the
 * others' workers took over the slabs they returned or hold, on average
 * (the ones held counted at the mean slab's seconds; every rank runs one
 * command, so its -j is rank 0's). With many ranks its own part alone is more,
 * and it deals every slab out. Who works a slab never changes the bytes,
 * so this may follow the timing of the moment.
 */
static int rank0_has_time(const en_peer_link *l)
{
    double worked = 0, held = 0;
    uint64_t returned = 0;
    for (int r = 1; r < l->p.size; r++) {
        worked += l->worked[r];
        returned += l->returned[r];
        held += (double)holding(l, r);
    }
    if (l->p.size == 1)
        return 1;
    if (!returned)
        return 1; /* nothing to weigh against yet: it works while the others do */
    double others = (worked + held * worked / (double)returned) / (double)(l->p.size - 1);
    return (en_process_cpu_seconds() - l->cpu_start) <= others;
}

/* The waiting rank holding fewest slabs (0: none waits). */
static int fewest_waiting(const en_peer_link *l)
{
    int best = 0;
    for (int r = 1; r < l->p.size; r++)
        if (l->waiting[r] && (!best || holding(l, r) < holding(l, best)))
            best = r;
    return best;
}

int en_peer_pick(en_peer_link *l, int *rank, epsnet_error *err)
{
    *rank = 0;
    if (!l->dealing) {
        /* the first slab waits for every rank's first want: each sends
         * one as soon as it serves (or ends, failing), and a rank not yet
         * heard from is idle, so rank 0 keeping the slab would leave it
         * so for a whole slab: at 20M faces and two ranks, rank 1's first
         * slab came 0.15 s after its start instead of 0.04 (a gain within
         * the machine's noise; bench/RESULTS.md, session 33) */
        for (int r = 1; r < l->p.size; r++)
            while (!l->waiting[r]) {
                int rc = take(l, r, err);
                if (rc)
                    return rc;
            }
        l->dealing = 1;
        l->cpu_start = en_process_cpu_seconds();
    }
    for (int r = 1; r < l->p.size; r++)
        for (;;) {
            int there = l->p.poll(l->p.opaque, r);
            if (there < 0)
                return transport_failed(l, "poll", r, err);
            if (!there)
                break;
            int rc = take(l, r, err);
            if (rc)
                return rc;
        }
    int r = fewest_waiting(l);
    /* an idle rank gets it; else rank 0, while it has the time */
    if ((!r || holding(l, r) > 0) && rank0_has_time(l)) {
        /* the waiting ones go on with what they hold: a rank waiting for
         * a reply sends no results, and its workers may run dry */
        for (int q = 1; q < l->p.size; q++)
            if (l->waiting[q]) {
                l->waiting[q] = 0;
                int rc = send_msg(l, q, MSG_NONE, 0, 0, 0, 0, NULL, err);
                if (rc)
                    return rc;
            }
        return 0;
    }
    /* every other rank holds a slab (it wants one as soon as it holds
     * fewer than it may): the one holding most sends its results soonest */
    while (!r) {
        int most = 1;
        for (int q = 2; q < l->p.size; q++)
            if (holding(l, q) > holding(l, most))
                most = q;
        int rc = take(l, most, err);
        if (rc)
            return rc;
        r = fewest_waiting(l);
    }
    *rank = r;
    return 0;
}

/* The rank slab work w was shipped to and not yet taken back from (0: none). */
static int holder(const en_peer_link *l, const en_slab_work *w)
{
    for (int r = 1; r < l->p.size; r++)
        for (size_t i = 0; i < l->out[r].n; i++)
            if (l->out[r].w[l->out[r].head + i] == w)
                return r;
    return 0;
}

int en_peer_ship(en_peer_link *l, int r, en_slab_work *w, epsnet_error *err)
{
    shipped *o = &l->out[r];
    if (w->plan && w->plan->count_nranges)
        return en_error_set(err, EPSNET_EINTERNAL, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "a pricing pass's slab shipped to rank %d (a bug)", r);
    if (o->head + o->n == o->cap) { /* room at the end: move the ones held to the front, or grow */
        if (o->head) {
            memmove(o->w, o->w + o->head, o->n * sizeof *o->w);
            memmove(o->got, o->got + o->head, o->n);
            o->head = 0;
        } else {
            size_t cw = o->cap, cg = o->cap;
            if (en_grow((void **)&o->w, &cw, o->n + 1, sizeof *o->w) || en_grow((void **)&o->got, &cg, o->n + 1, 1))
                return en_error_set(err, EPSNET_ENOMEM, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
            o->cap = cw < cg ? cw : cg;
        }
    }
    if (r <= 0 || r >= l->p.size || !l->waiting[r])
        return en_error_set(err, EPSNET_EINTERNAL, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "slab %u shipped to rank %d, which did not ask for one (a bug)", w->index, r);
    int rc = 0;
    input_head h;
    memset(&h, 0, sizeof h); /* its padding too: every byte sent is set */
    h.nv = w->s.nv, h.nt = w->s.nt, h.nowned = w->nowned, h.attr_size = w->attr_size;
    h.last = w->last, h.lock_type = w->lock_type;
    h.frequency = w->g->n, h.quadric_at = w->quadric_at, h.lock_offset = w->lock_offset;
    h.has_plan = w->plan != NULL, h.has_weights = w->weights != NULL;
    h.max_normal_dev = w->max_normal_dev;
    h.rot = w->g->rot;
    if (w->plan)
        h.plan = *w->plan;
    h.plan.count_ranges = NULL;
    if (w->weights)
        h.weights = *w->weights;
    section sec[MAX_SECTIONS];
    int n = input_sections(w, 0, sec);
    l->waiting[r] = 0;
    rc = send_msg(l, r, MSG_INPUT, w->index, sizeof h, 0, 0, NULL, err);
    if (rc == 0)
        rc = send_bytes(l, r, &h, sizeof h, err);
    for (int i = 0; i < n && rc == 0; i++)
        if (sec[i].n)
            rc = send_bytes(l, r, sec[i].p, sec[i].n, err);
    if (rc == 0) {
        en_slab_work_shed(w); /* rank 0 holds its input and, later, its results */
        l->shipped_total++;
        o->w[o->head + o->n] = w;
        o->got[o->head + o->n] = 0;
        o->n++;
    }
    return rc;
}

int en_peer_recv_slab(en_peer_link *l, en_slab_work *w, epsnet_error *err)
{
    int r = holder(l, w);
    if (!r)
        return 0; /* rank 0's own */
    shipped *o = &l->out[r];
    if (o->w[o->head] != w)
        return en_error_set(err, EPSNET_EINTERNAL, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "slab %u was not the oldest shipped to rank %d (a bug)", w->index, r);
    int rc = 0;
    while (rc == 0 && !o->got[o->head]) {
        if (l->waiting[r]) { /* it waits for a reply: it is to go on with what it holds */
            l->waiting[r] = 0;
            rc = send_msg(l, r, MSG_NONE, 0, 0, 0, 0, NULL, err);
        }
        if (rc == 0)
            rc = take(l, r, err);
    }
    if (rc == 0) {
        o->head++;
        o->n--;
        if (o->n == 0)
            o->head = 0;
    }
    return rc;
}

/* ---- rank r: slabs in ---- */

int en_peer_want(en_peer_link *l, en_slab_work *w, en_peer_settings *set, en_peer_reply *reply, epsnet_error *err)
{
    en_peer_msg m;
    int rc = send_msg(l, 0, MSG_WANT, 0, 0, 0, l->p.rank, NULL, err);
    if (rc == 0)
        rc = recv_msg(l, 0, &m, err);
    if (rc)
        return rc;
    switch (m.type) {
    case MSG_NONE:
        *reply = EN_PEER_NONE;
        return 0;
    case MSG_DONE:
        *reply = EN_PEER_DONE;
        return 0;
    case MSG_VERDICT:
        return peer_failure(l, &m, err);
    case MSG_INPUT:
        break;
    default:
        return unexpected(l, &m, "a reply to a want", err);
    }
    input_head h;
    if (m.bytes != sizeof h)
        return unexpected(l, &m, "a slab's input", err);
    if ((rc = recv_bytes(l, 0, &h, sizeof h, err)) != 0)
        return rc;
    en_slab_work_reset(w);
    w->index = (uint32_t)m.slab;
    w->nowned = h.nowned;
    w->attr_size = h.attr_size;
    w->last = h.last;
    section sec[MAX_SECTIONS];
    int n = en_slab_resize(&w->s, h.nv, h.nt) ? -1 : input_sections(w, 1, sec);
    if (n < 0)
        return en_error_set(err, EPSNET_ENOMEM, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory taking slab %llu from rank 0", (unsigned long long)m.slab);
    for (int i = 0; i < n && rc == 0; i++)
        if (sec[i].n)
            rc = recv_bytes(l, 0, sec[i].p, sec[i].n, err);
    if (rc)
        return rc;
    if (gauss_init(&set->g, h.frequency, &h.rot))
        return en_error_set(err, EPSNET_ENOMEM, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    set->plan = h.plan;
    set->weights = h.weights;
    w->g = &set->g;
    w->plan = h.has_plan ? &set->plan : NULL;
    w->weights = h.has_weights ? &set->weights : NULL;
    w->mode = EN_SLAB_SIMPLIFY;
    w->max_normal_dev = h.max_normal_dev;
    w->quadric_at = h.quadric_at;
    w->lock_offset = h.lock_offset;
    w->lock_type = h.lock_type;
    *reply = EN_PEER_INPUT;
    return 0;
}

/* ---- the end ---- */

/* A slab's head and arrays received and dropped (a run that failed). */
static int pass_over_slab(en_peer_link *l, int r, const en_peer_msg *m, epsnet_error *err)
{
    uint8_t buf[HEAD_BYTES];
    if (m->bytes != HEAD_BYTES)
        return unexpected(l, m, "a slab's head", err);
    int rc = recv_bytes(l, r, buf, sizeof buf, err);
    uint64_t count, bytes[MAX_SECTIONS], sent[MAX_SECTIONS];
    head_arrays(buf, &count, bytes, sent);
    if (rc == 0 && count > MAX_SECTIONS)
        return unexpected(l, m, "a slab's head", err);
    for (uint64_t i = 0; i < count && rc == 0; i++) {
        if (!sent[i])
            continue;
        void *scratch = sent[i] <= SIZE_MAX ? en_malloc((size_t)sent[i]) : NULL;
        if (!scratch)
            return en_error_set(err, EPSNET_ENOMEM, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        rc = recv_bytes(l, r, scratch, (size_t)sent[i], err);
        en_free(scratch);
    }
    return rc;
}

/* Rank 0, at the end: rank r's messages until its END, a slab's bytes
 * passed over, a WANT answered with DONE, or with the failure rc (rank
 * `from`'s, in its words `why`). */
static int drain(en_peer_link *l, int r, int rc, int from, const epsnet_error *why, en_peer_msg *end,
                 epsnet_error *err)
{
    while (!l->ended[r]) {
        if (l->waiting[r]) {
            l->waiting[r] = 0;
            int trc = rc ? send_msg(l, r, MSG_VERDICT, 0, 0, rc, from, why, err)
                         : send_msg(l, r, MSG_DONE, 0, 0, 0, 0, NULL, err);
            if (trc)
                return trc;
        }
        en_peer_msg m;
        int trc = recv_msg(l, r, &m, err);
        if (trc)
            return trc;
        if (m.type == MSG_SLAB) {
            if (!rc) /* every slab shipped came back before the run's end */
                return unexpected(l, &m, "an end", err);
            if ((trc = pass_over_slab(l, r, &m, err)) != 0)
                return trc;
        } else if (m.type == MSG_WANT) {
            l->waiting[r] = 1;
        } else if (m.type == MSG_END) {
            l->ended[r] = 1;
            *end = m;
        } else {
            return unexpected(l, &m, "an end", err);
        }
    }
    return 0;
}

int en_peer_agree(en_peer_link *l, int rc, epsnet_error *err)
{

    en_peer_msg m;
    if (l->p.rank != 0) {
        epsnet_error terr;
        int trc = send_msg(l, 0, MSG_END, 0, 0, rc, l->p.rank, err, &terr);
        if (trc == 0)
            trc = recv_msg(l, 0, &m, &terr);
        if (trc == 0 && m.type != MSG_VERDICT)
            trc = unexpected(l, &m, "the verdict", &terr);
        if (trc) {
            *err = terr;
            return trc;
        }
        if (m.status == 0)
            return rc; /* 0: rank 0 saw every rank succeed, this one included */
        if (m.rank == l->p.rank && rc) /* its own failure came back: its own words */
            return rc;
        return peer_failure(l, &m, err);
    }
    /* rank 0: every rank's END; the verdict is rank 0's failure, else the
     * first rank's (by rank), sent in that rank's own words */
    epsnet_error mine = *err, raw = *err;
    int verdict = rc, from = 0, trc = 0;
    if (rc && l->culprit) { /* another rank's failure stopped rank 0: told as that rank's */
        from = l->culprit;
        raw = l->culprit_err;
    }
    for (int r = 1; r < l->p.size && trc == 0; r++) {
        memset(&m, 0, sizeof m);
        if ((trc = drain(l, r, rc, from, &raw, &m, err)) != 0)
            break;
        if (m.type == MSG_END && m.status && !verdict) {
            verdict = m.status;
            from = r;
            raw = m.err;
            peer_failure(l, &m, err); /* rank 0's own return names that rank */
        }
    }
    if (trc) /* the transport itself failed: what is left cannot be told */
        return trc;
    epsnet_error terr;
    for (int r = 1; r < l->p.size && trc == 0; r++)
        trc = send_msg(l, r, MSG_VERDICT, 0, 0, verdict, from, &raw, &terr);
    if (trc) {
        *err = terr;
        return trc;
    }
    if (rc)
        *err = mine;
    return verdict;
}
