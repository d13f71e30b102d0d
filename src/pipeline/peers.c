/*
 * One run's slabs shared among processes: the ranks' messages and a slab
 * work's results, array by array (pipeline/peers.h, docs/distributed.md).
 */
#include "pipeline/peers.h"

#include <stdio.h>
#include <string.h>

#include "common/alloc.h"
#include "common/error.h"

#define MSG_MAGIC 0x65707331u /* "eps1" */

enum { MSG_SLAB = 1, MSG_WAIT, MSG_END, MSG_GO, MSG_VERDICT };

/* The header of every message. Ranks run one build, so its layout is
 * theirs alike. */
typedef struct en_peer_msg {
    uint32_t magic, type;
    uint64_t slab;                /* SLAB, WAIT, GO */
    uint64_t value;               /* GO: the frequency */
    uint64_t bytes;               /* SLAB: its head's bytes (HEAD_BYTES); the arrays follow */
    int32_t status;               /* END, VERDICT: 0 or a negative code */
    int32_t rank;                 /* the sender; VERDICT: the rank that failed */
    epsnet_error err;             /* END, VERDICT with a failure */
} en_peer_msg;

struct en_peer_link {
    epsnet_peers p;
    char path[512];               /* the input, for messages */
    uint8_t *ended;               /* rank 0: per rank, its END taken */
    uint8_t *waiting;             /* rank 0: per rank, its WAIT taken and not yet answered */
    int culprit;                  /* rank 0: a rank whose failing END stopped the run (0: none), */
    epsnet_error culprit_err;     /* ... in its own words */
};

int en_peer_link_new(en_peer_link **out, const epsnet_peers *peers, const char *path, epsnet_error *err)
{
    *out = NULL;
    if (!peers->send || !peers->recv || peers->size < 1 || peers->rank < 0 || peers->rank >= peers->size)
        return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "settings.peers: rank %d of %d, or no send/recv function", peers->rank, peers->size);
    if (path && strcmp(path, "-") == 0) /* mpirun hands standard input to rank 0 alone */
        return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "settings.peers: every rank reads the input, which must be a file, not standard input");
    en_peer_link *l = en_calloc(1, sizeof *l);
    if (!l || !(l->ended = en_calloc((size_t)peers->size, 1)) || !(l->waiting = en_calloc((size_t)peers->size, 1))) {
        if (l)
            en_free(l->ended);
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

/*
 * Rank 0 also stitches, so it works fewer slabs. Of every cycle, another
 * rank takes RANK_SHARE (10) parts and rank 0 RANK_SHARE - R (R ranks):
 * measured on `gen bumpy` 20M at -j 1 (bench/RESULTS.md, session 23), the
 * seams cost about a ninth of what the slabs do, and with two ranks rank
 * 0 waited 2-6 s of 17-20 for the other's slabs at 3 parts of 8, 0.2 s at 4
 * of 9 (the run 8% faster), and was itself the slower at 5 of 10. So 8 of
 * 18 slabs at two ranks, 6 of 36 at four, none from ten on. Fixed by the
 * rank count alone, never by timing, and dealt out in turns through the
 * cycle, so that rank 0 never waits long for a run of another rank's slabs.
 */
#define RANK_SHARE 10
int en_peer_of_slab(uint64_t k, int size)
{
    if (size <= 1 || k == 0)
        return 0;
    uint64_t stitcher = size < RANK_SHARE ? (uint64_t)(RANK_SHARE - size) : 0;
    uint64_t cycle = stitcher + (uint64_t)RANK_SHARE * (uint64_t)(size - 1);
    uint64_t i = k % cycle;
    /* turns of every rank while rank 0 has parts left, then turns of the others */
    if (i < stitcher * (uint64_t)size)
        return (int)(i % (uint64_t)size);
    return 1 + (int)((i - stitcher * (uint64_t)size) % (uint64_t)(size - 1));
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
static int send_msg(en_peer_link *l, int to, uint32_t type, uint64_t slab, uint64_t value, uint64_t bytes,
                    int status, int rank, const epsnet_error *e, epsnet_error *err)
{
    en_peer_msg m;
    memset(&m, 0, sizeof m);
    m.magic = MSG_MAGIC;
    m.type = type;
    m.slab = slab;
    m.value = value;
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
 * rank 0's chunker cut: no packed copy on either side (a copy of every
 * slab's results made rank 0 peak 20 MB above one process at 20M faces). */

#define MAX_SECTIONS 24

typedef struct section {
    void *p;
    size_t n;                     /* bytes */
} section;

#define SCALARS(X)                                                                                                    \
    X(faces_in) X(membrane_faces) X(counts) X(has_levels) X(level_count) X(band_nonsamples) X(inner_nonsamples)      \
    X(collapses) X(refused) X(given_up) X(skeleton_kept) X(keep_faces) X(faces_left) X(vertices_left) X(units_in)   \
    X(stopped_by_error) X(level) X(counted_vertices) X(seconds)

#define SCALAR_BYTES(f) +sizeof(((en_slab_work *)0)->f)
/* The head: shape (3 words), which arrays (4 bytes), the scalars, the
 * count of arrays and each one's bytes. */
#define ARRAYS_AT (3 * sizeof(uint32_t) + 4 SCALARS(SCALAR_BYTES))
#define HEAD_BYTES (ARRAYS_AT + (1 + MAX_SECTIONS) * sizeof(uint64_t))

/* The count of arrays after a head, and each one's bytes. */
static void head_arrays(const uint8_t *head, uint64_t *count, uint64_t bytes[MAX_SECTIONS])
{
    memcpy(count, head + ARRAYS_AT, sizeof *count);
    memcpy(bytes, head + ARRAYS_AT + sizeof *count, MAX_SECTIONS * sizeof *bytes);
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
        if (grow && en_grow((void **)&(ptr), &(capf), (size_t)(count) + 1, (size)))                                  \
            return -1;                                                                                                \
        out[n++] = (section){ (ptr), (size_t)(count) * (size) };                                                      \
    } while (0)
#define HIST(ptr, count)                                                                                              \
    do {                                                                                                              \
        if (grow && !(ptr) && !((ptr) = en_malloc((size_t)(count) * sizeof *(ptr))))                                \
            return -1;                                                                                                \
        out[n++] = (section){ (ptr), (size_t)(count) * sizeof *(ptr) };                                               \
    } while (0)
    out[n++] = (section){ w->s.vflags, no }; /* rank 0's chunker made them: boundary and seam flags come */
    ARRAY(w->vclass, w->cap.vclass, no, 1);
    if (w->has_levels)
        ARRAY(w->vlevel, w->cap.vlevel, no, 1);
    ARRAY(w->valive, w->cap.valive, no, 1);
    ARRAY(w->degree, w->cap.degree, no, sizeof *w->degree);
    ARRAY(w->future, w->cap.future, no, sizeof *w->future);
    ARRAY(w->border, w->cap.border, no, 1);
    ARRAY(w->band, w->cap.band, no, 1);
    ARRAY(w->q, w->cap.q, no, sizeof *w->q);
    if (h->has[0])
        ARRAY(w->aq, w->cap.aq, na * no, sizeof *w->aq);
    out[n++] = (section){ w->fflags, nt }; /* compacted with the membranes' faces gone */
    ARRAY(w->falive, w->cap.falive, nt, 1);
    ARRAY(w->tri, w->cap.tri, 3 * nt, sizeof *w->tri);
    ARRAY(w->ref, w->cap.ref, 3 * nt, sizeof *w->ref);
    if (h->has[1])
        HIST(w->cost_hist, EN_COST_BUCKETS);
    if (h->has[2])
        HIST(w->level_hist, (size_t)EN_LEVELS * EN_COST_BUCKETS);
    if (h->has[3])
        HIST(w->taken_hist, EN_COST_BUCKETS);
#undef ARRAY
#undef HIST
    return n;
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
    uint64_t count = (uint64_t)n, bytes[MAX_SECTIONS] = { 0 };
    for (int i = 0; i < n; i++)
        bytes[i] = sec[i].n;
    put(&at, &count, sizeof count);
    put(&at, bytes, sizeof bytes);
    int rc = send_msg(l, 0, MSG_SLAB, w->index, 0, HEAD_BYTES, 0, l->p.rank, NULL, err);
    if (rc == 0)
        rc = send_bytes(l, 0, buf, sizeof buf, err);
    for (int i = 0; i < n && rc == 0; i++)
        if (sec[i].n) /* an empty array is not sent: both sides know it is */
            rc = send_bytes(l, 0, sec[i].p, sec[i].n, err);
    return rc;
}

/* Take the next message from `from`: one of `want` (a type), or the END
 * that rank sent instead (its failure). */
static int expect(en_peer_link *l, int from, uint32_t want, uint64_t slab, en_peer_msg *m, epsnet_error *err)
{
    int rc = recv_msg(l, from, m, err);
    if (rc)
        return rc;
    if (m->type == MSG_END) {
        l->ended[from] = 1;
        if (m->status) {
            l->culprit = from;
            l->culprit_err = m->err;
            return peer_failure(l, m, err);
        }
        return en_error_set(err, EPSNET_EINTERNAL, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "rank %d ended at slab %llu without a failure (a bug)", from, (unsigned long long)slab);
    }
    if (m->type != want || m->slab != slab)
        return unexpected(l, m, want == MSG_SLAB ? "a slab" : "a wait", err);
    return 0;
}

static int not_this_slab(const en_peer_link *l, const en_slab_work *w, int from, epsnet_error *err)
{
    return en_error_set(err, EPSNET_EINTERNAL, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "slab %u from rank %d does not fit the slab cut here (ranks with different inputs or "
                        "settings?)",
                        w->index, from);
}

int en_peer_recv_slab(en_peer_link *l, en_slab_work *w, epsnet_error *err)
{
    int from = en_peer_of_slab(w->index, l->p.size);
    en_peer_msg m;
    int rc = expect(l, from, MSG_SLAB, w->index, &m, err);
    if (rc)
        return rc;
    uint8_t buf[HEAD_BYTES];
    const uint8_t *at = buf;
    if (m.bytes != HEAD_BYTES)
        return not_this_slab(l, w, from, err);
    if ((rc = recv_bytes(l, from, buf, sizeof buf, err)) != 0)
        return rc;
    head h;
    get(&at, h.shape, sizeof h.shape);
    get(&at, h.has, sizeof h.has);
    if (h.shape[0] != w->nowned || h.shape[1] != w->s.nv || h.shape[2] > w->s.nt || (h.has[0] && !weighed_doubles(w)))
        return not_this_slab(l, w, from, err);
#define GET_SCALAR(f) get(&at, &w->f, sizeof w->f);
    SCALARS(GET_SCALAR)
#undef GET_SCALAR
    uint64_t count, bytes[MAX_SECTIONS];
    head_arrays(buf, &count, bytes);
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
    for (int i = 0; i < n && rc == 0; i++)
        if (sec[i].n)
            rc = recv_bytes(l, from, sec[i].p, sec[i].n, err);
    return rc;
}

int en_peer_meet(en_peer_link *l, uint64_t k, uint32_t *frequency, epsnet_error *err)
{
    en_peer_msg m;
    int rc = 0;
    if (l->p.rank != 0) {
        if ((rc = send_msg(l, 0, MSG_WAIT, k, 0, 0, 0, l->p.rank, NULL, err)) != 0 || (rc = recv_msg(l, 0, &m, err)) != 0)
            return rc;
        if (m.type == MSG_VERDICT)
            return peer_failure(l, &m, err);
        if (m.type != MSG_GO || m.slab != k)
            return unexpected(l, &m, "a go", err);
        *frequency = (uint32_t)m.value;
        return 0;
    }
    for (int r = 1; r < l->p.size && rc == 0; r++)
        if ((rc = expect(l, r, MSG_WAIT, k, &m, err)) == 0)
            l->waiting[r] = 1; /* answered here, or by the verdict if another rank failed */
    for (int r = 1; r < l->p.size && rc == 0; r++) {
        rc = send_msg(l, r, MSG_GO, k, *frequency, 0, 0, 0, NULL, err);
        l->waiting[r] = 0;
    }
    return rc;
}

/* A slab's head and arrays received and dropped (a run that failed). */
static int pass_over_slab(en_peer_link *l, int r, const en_peer_msg *m, epsnet_error *err)
{
    uint8_t buf[HEAD_BYTES];
    if (m->bytes != HEAD_BYTES)
        return unexpected(l, m, "a slab's head", err);
    int rc = recv_bytes(l, r, buf, sizeof buf, err);
    uint64_t count, bytes[MAX_SECTIONS];
    head_arrays(buf, &count, bytes);
    if (rc == 0 && count > MAX_SECTIONS)
        return unexpected(l, m, "a slab's head", err);
    for (uint64_t i = 0; i < count && rc == 0; i++) {
        if (!bytes[i])
            continue;
        void *scratch = bytes[i] <= SIZE_MAX ? en_malloc((size_t)bytes[i]) : NULL;
        if (!scratch)
            return en_error_set(err, EPSNET_ENOMEM, l->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        rc = recv_bytes(l, r, scratch, (size_t)bytes[i], err);
        en_free(scratch);
    }
    return rc;
}

/* Rank 0, at the end: rank r's messages until its END, a slab's bytes
 * passed over, a WAIT answered with the failure rc (rank `from`'s, in its
 * words `why`). */
static int drain(en_peer_link *l, int r, int rc, int from, const epsnet_error *why, en_peer_msg *end,
                 epsnet_error *err)
{
    if (l->waiting[r]) { /* it waits at a meeting that another rank's failure broke */
        l->waiting[r] = 0;
        int trc = send_msg(l, r, MSG_VERDICT, 0, 0, 0, rc, from, why, err);
        if (trc)
            return trc;
    }
    while (!l->ended[r]) {
        en_peer_msg m;
        int trc = recv_msg(l, r, &m, err);
        if (trc)
            return trc;
        if (m.type == MSG_SLAB) {
            if ((trc = pass_over_slab(l, r, &m, err)) != 0)
                return trc;
        } else if (m.type == MSG_WAIT) {
            if (!rc) /* a rank cannot be ahead of rank 0 at its end unless rank 0 failed */
                return unexpected(l, &m, "an end", err);
            if ((trc = send_msg(l, r, MSG_VERDICT, m.slab, 0, 0, rc, from, why, err)) != 0)
                return trc;
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
        int trc = send_msg(l, 0, MSG_END, 0, 0, 0, rc, l->p.rank, err, &terr);
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
        trc = send_msg(l, r, MSG_VERDICT, 0, 0, 0, verdict, from, &raw, &terr);
    if (trc) {
        *err = terr;
        return trc;
    }
    if (rc)
        *err = mine;
    return verdict;
}
