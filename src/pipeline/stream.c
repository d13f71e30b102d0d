/*
 * The streaming pipeline (SPEC §2): reader -> chunker -> worker pool ->
 * stitcher -> writer, one such chain per ε-net pass, each pass's stitcher
 * feeding the next pass's chunker directly (paper §5: passes re-sample the
 * previous result under a new rotation).
 *
 * Threads: everything here runs on the caller's thread; only
 * en_slab_work_run() runs on the workers, on a slab nobody else touches
 * until the pool hands it back, in submission order.
 */
#include "pipeline/stream.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "api/context.h"
#include "api/jobs.h"
#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"
#include "pipeline/chunker.h"
#include "common/pool.h"
#include "pipeline/stitcher.h"

typedef struct en_pass {
    epsnet_stream *run;
    int index;
    gauss_sphere g;
    en_chunker ch;
    en_pool *pool;
    en_stitcher st;
    int ended;
    uint64_t in_flight_elements;   /* vertices + faces of slabs in the pool */
} en_pass;

struct epsnet_stream {
    epsnet_context *ctx;
    const char *path;
    en_slab_mode mode;
    int npasses;
    en_pass *pass;
    en_emit_fn sink;              /* NULL: output waits in the queue for pull */
    void *sink_opaque;
    en_sample_fn on_sample;
    void *sample_opaque;
    epsnet_record *queue;
    size_t qhead, qlen, qcap;
    int failed;
    epsnet_error failure;
    en_classify_counts counts;    /* pass 1 */
    uint64_t collapses, slabs, max_active;
    uint64_t refused[EN_REFUSE_KINDS];
    uint64_t vertices_in, faces_in;
    uint64_t budget;              /* en_stream_mem_budget(), 0 = none */
};

static int pass_put(en_pass *p, const epsnet_record *rec, epsnet_error *err);

static int fail(epsnet_stream *s, int rc, const epsnet_error *err)
{
    if (!s->failed) {
        s->failed = rc;
        s->failure = *err;
    }
    return rc;
}

static int queue_record(epsnet_stream *s, const epsnet_record *rec, epsnet_error *err)
{
    if (s->qlen == s->qcap) {
        size_t cap = s->qcap ? 2 * s->qcap : 256;
        epsnet_record *q = en_malloc(cap * sizeof *q);
        if (!q)
            return en_error_set(err, EPSNET_ENOMEM, s->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "out of memory: %zu output records not pulled", s->qlen);
        for (size_t i = 0; i < s->qlen; i++)
            q[i] = s->queue[(s->qhead + i) % s->qcap];
        en_free(s->queue);
        s->queue = q;
        s->qcap = cap;
        s->qhead = 0;
    }
    s->queue[(s->qhead + s->qlen++) % s->qcap] = *rec;
    return 0;
}

/* A pass's stitcher output: the next pass's input, or the run's output. */
static int pass_emit(void *opaque, const epsnet_record *rec, epsnet_error *err)
{
    en_pass *p = opaque;
    epsnet_stream *s = p->run;
    if (p->index + 1 < s->npasses)
        return pass_put(&s->pass[p->index + 1], rec, err);
    if (s->sink)
        return s->sink(s->sink_opaque, rec, err);
    return queue_record(s, rec, err);
}

static void free_work(en_slab_work *w)
{
    en_slab_work_free(w);
    en_free(w);
}

static void note_active(epsnet_stream *s)
{
    uint64_t total = 0;
    for (int i = 0; i < s->npasses; i++) {
        const en_pass *p = &s->pass[i];
        total += p->ch.map.count + p->ch.nfaces + p->in_flight_elements + p->st.nwv + p->st.nwf + p->st.nvheap +
                 p->st.nfheap;
    }
    if (total > s->max_active)
        s->max_active = total;
}

static int take_samples(epsnet_stream *s, const en_slab_work *w, epsnet_error *err)
{
    for (uint32_t v = 0; v < w->nowned; v++)
        if (w->vclass[v] & EN_C_SAMPLE) {
            int rc = s->on_sample(s->sample_opaque, w->s.gid[v], w->s.pos + 3 * (size_t)v, w->vgvertex[v], err);
            if (rc)
                return rc;
        }
    return 0;
}

/*
 * What the budget bounds beyond the reader's live vertices (SPEC §5): faces
 * the chunker holds on vertices still open (a stream can repeat a face on
 * three live vertices forever) and output the stitcher holds back (output
 * leaves in input id order, so one vertex used again far later in the
 * stream holds everything after it). Over budget, say which one grew.
 */
static int check_budget(epsnet_stream *s, epsnet_error *err)
{
    uint64_t total = 0, worst = 0;
    const en_pass *wp = NULL;
    int waiting = 0; /* the worst is the chunker's (1) or the stitcher's (0) */
    for (int i = 0; i < s->npasses; i++) {
        const en_pass *p = &s->pass[i];
        uint64_t cut = en_chunker_bytes(&p->ch), held = s->mode == EN_SLAB_SIMPLIFY ? en_stitcher_bytes(&p->st) : 0;
        total += cut + held;
        if (!wp || cut > worst || held > worst) {
            wp = p;
            waiting = cut >= held;
            worst = waiting ? cut : held;
        }
    }
    if (!s->budget || total <= s->budget)
        return 0;
    if (waiting)
        return en_error_set(err, EPSNET_ELIMIT, s->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "pass %d: %llu vertices and %llu faces wait for vertices to be finalized (%llu bytes "
                            "in all), over the memory budget of %llu bytes (does the stream finalize its vertices?)",
                            wp->index + 1, (unsigned long long)wp->ch.map.count, (unsigned long long)wp->ch.nfaces,
                            (unsigned long long)total, (unsigned long long)s->budget);
    return en_error_set(err, EPSNET_ELIMIT, s->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "pass %d: the output waits for vertex %llu, still open, and holds %llu bytes in all, "
                        "over the memory budget of %llu bytes (is a vertex used again far later in the stream?)",
                        wp->index + 1, (unsigned long long)wp->st.frontier, (unsigned long long)total,
                        (unsigned long long)s->budget);
}

/* Hand back the oldest slab of pass p and stitch it. */
static int retire_one(en_pass *p, epsnet_error *err)
{
    epsnet_stream *s = p->run;
    void *job;
    int result;
    if (!en_pool_retire(p->pool, &job, &result))
        return 0;
    en_slab_work *w = job;
    p->in_flight_elements -= (uint64_t)w->s.nv + w->s.nt;
    int rc = result;
    if (rc) {
        *err = w->err;
        snprintf(err->file, sizeof err->file, "%s", s->path ? s->path : "");
    }
    if (rc == 0) {
        if (p->index == 0)
            en_classify_counts_add(&s->counts, &w->counts);
        s->collapses += w->collapses;
        for (int k = 0; k < EN_REFUSE_KINDS; k++)
            s->refused[k] += w->refused[k];
        s->slabs++;
        rc = s->mode == EN_SLAB_SAMPLE ? take_samples(s, w, err) : en_stitcher_take(&p->st, w, err);
    }
    free_work(w);
    if (rc == 0)
        rc = check_budget(s, err);
    return rc;
}

static int submit(en_pass *p, en_slab_work *w, epsnet_error *err)
{
    epsnet_stream *s = p->run;
    w->g = &p->g;
    w->mode = s->mode;
    w->max_normal_dev = s->ctx->settings.max_normal_dev;
    int rc = 0;
    while (rc == 0 && en_pool_full(p->pool))
        rc = retire_one(p, err);
    if (rc == 0) {
        p->in_flight_elements += (uint64_t)w->s.nv + w->s.nt;
        note_active(s);
        rc = en_pool_submit(p->pool, en_slab_work_run, w);
        if (rc) {
            p->in_flight_elements -= (uint64_t)w->s.nv + w->s.nt;
            en_error_set(err, rc, s->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "worker pool refused a slab");
        }
    }
    if (rc)
        free_work(w);
    return rc;
}

static int pass_put(en_pass *p, const epsnet_record *rec, epsnet_error *err)
{
    en_slab_work *w = NULL;
    int rc = en_chunker_put(&p->ch, rec, &w, err);
    if (rc == 0 && w)
        rc = submit(p, w, err);
    if (rc == 0 && (p->ch.records & 4095) == 0)
        rc = check_budget(p->run, err);
    return rc;
}

static int pass_end(en_pass *p, epsnet_error *err)
{
    if (p->ended)
        return 0;
    p->ended = 1;
    en_slab_work *w = NULL;
    int rc;
    do {
        rc = en_chunker_finish(&p->ch, &w, err);
        if (rc == 0 && w)
            rc = submit(p, w, err);
    } while (rc == 0 && w);
    while (rc == 0 && en_pool_in_flight(p->pool))
        rc = retire_one(p, err);
    if (rc == 0 && p->run->mode == EN_SLAB_SIMPLIFY)
        rc = en_stitcher_finish(&p->st, err);
    return rc;
}

uint32_t en_stream_slab_vertices(const epsnet_settings *set)
{
    if (set->slab_vertices)
        return set->slab_vertices;
    if (set->mem) {
        uint64_t n = set->mem / 4800;
        return n < 1024 ? 1024 : n > (1u << 24) ? (1u << 24) : (uint32_t)n;
    }
    return 65536;
}

uint64_t en_stream_mem_budget(const epsnet_settings *set)
{
    if (set->mem)
        return set->mem;
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0)
        return 0;
    return (uint64_t)pages * (uint64_t)page / 2;
}

int en_stream_workers(const epsnet_settings *set)
{
    long n = set->threads > 0 ? set->threads : sysconf(_SC_NPROCESSORS_ONLN);
    if (n > 256)
        n = 256;
    /* One thread means the caller's own: slabs run inline, no pool threads. */
    return n <= 1 ? 0 : (int)n;
}

int en_stream_new(epsnet_stream **out, epsnet_context *ctx, en_slab_mode mode, const char *path, epsnet_error *err)
{
    *out = NULL;
    epsnet_stream *s = en_calloc(1, sizeof *s);
    if (!s)
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    s->ctx = ctx;
    s->path = path;
    s->mode = mode;
    s->npasses = mode == EN_SLAB_SAMPLE ? 1 : ctx->settings.passes < 1 ? 1 : ctx->settings.passes;
    s->budget = en_stream_mem_budget(&ctx->settings);
    s->pass = en_calloc((size_t)s->npasses, sizeof *s->pass);
    if (!s->pass) {
        en_free(s);
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    int workers = en_stream_workers(&ctx->settings);
    uint32_t slab = en_stream_slab_vertices(&ctx->settings);
    int rc = 0;
    for (int i = 0; i < s->npasses && rc == 0; i++) {
        en_pass *p = &s->pass[i];
        p->run = s;
        p->index = i;
        p->g = ctx->sphere;
        if (i > 0) {
            gauss_rotation r;
            gauss_pass_rotation(ctx->settings.seed, i + 1, &r);
            gauss_init(&p->g, ctx->sphere.n, &r);
        }
        if (en_chunker_init(&p->ch, slab, path) ||
            en_stitcher_init(&p->st, ctx->settings.max_normal_dev, pass_emit, p)) {
            rc = en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
            break;
        }
        rc = en_pool_new(&p->pool, workers, workers ? 2 * (size_t)workers : 1);
        if (rc == EPSNET_ENOMEM)
            en_error_set(err, rc, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        else if (rc)
            en_error_set(err, rc, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "cannot start %d worker threads",
                         workers);
    }
    memset(&ctx->stats, 0, sizeof ctx->stats);
    ctx->stats.gaussian_vertices = ctx->sphere.nverts;
    if (rc) {
        epsnet_stream_close(&s);
        return rc;
    }
    *out = s;
    return 0;
}

void en_stream_set_sink(epsnet_stream *s, en_emit_fn sink, void *opaque)
{
    s->sink = sink;
    s->sink_opaque = opaque;
}

void en_stream_set_sample_sink(epsnet_stream *s, en_sample_fn fn, void *opaque)
{
    s->on_sample = fn;
    s->sample_opaque = opaque;
}

int en_stream_put(epsnet_stream *s, const epsnet_record *rec, epsnet_error *err)
{
    if (s->failed) {
        *err = s->failure;
        return s->failed;
    }
    s->vertices_in += rec->kind == EPSNET_REC_VERTEX;
    s->faces_in += rec->kind == EPSNET_REC_TRIANGLE;
    s->ctx->stats.faces = s->faces_in; /* live, for progress reports */
    int rc = pass_put(&s->pass[0], rec, err);
    return rc ? fail(s, rc, err) : 0;
}

int en_stream_finish(epsnet_stream *s, epsnet_error *err)
{
    if (s->failed) {
        *err = s->failure;
        return s->failed;
    }
    int rc = 0;
    for (int i = 0; i < s->npasses && rc == 0; i++)
        rc = pass_end(&s->pass[i], err);
    if (rc)
        return fail(s, rc, err);
    epsnet_stats *st = &s->ctx->stats;
    st->vertices = s->vertices_in;
    st->faces = s->faces_in;
    en_job_count(s->ctx, &s->counts);
    st->passes = s->mode == EN_SLAB_SIMPLIFY ? (uint64_t)s->npasses : 0;
    st->slabs = s->slabs;
    st->collapses = s->collapses;
    st->refused_link = s->refused[0];
    st->refused_normal = s->refused[1];
    st->refused_zero_area = s->refused[2];
    st->refused_duplicate = s->refused[3];
    uint64_t chunk_active = 0;
    for (int i = 0; i < s->npasses; i++) {
        const en_stitch_stats *ss = &s->pass[i].st.stats;
        st->seam_faces += ss->seam_faces;
        st->seam_collapses += ss->seam_collapses;
        st->collapses += ss->seam_collapses;
        st->band_nonsamples += ss->band_nonsamples;
        st->band_nonsamples_left += ss->band_left;
        st->inner_nonsamples += ss->inner_nonsamples;
        st->inner_nonsamples_left += ss->inner_left;
        chunk_active += s->pass[i].ch.max_active;
    }
    st->max_active = s->max_active > chunk_active ? s->max_active : chunk_active;
    if (s->mode == EN_SLAB_SIMPLIFY) {
        const en_stitch_stats *last = &s->pass[s->npasses - 1].st.stats;
        st->output_vertices = last->out_vertices;
        st->output_faces = last->out_faces;
        st->remaining_nonsamples = last->remaining_nonsamples;
    }
    return 0;
}

void epsnet_stream_close(epsnet_stream **ps)
{
    if (!ps || !*ps)
        return;
    epsnet_stream *s = *ps;
    for (int i = 0; s->pass && i < s->npasses; i++) {
        en_pass *p = &s->pass[i];
        if (p->pool) {
            void *job;
            int result;
            while (en_pool_retire(p->pool, &job, &result))
                free_work(job);
            en_pool_free(&p->pool);
        }
        en_chunker_free(&p->ch);
        en_stitcher_free(&p->st);
    }
    en_free(s->pass);
    en_free(s->queue);
    en_free(s);
    *ps = NULL;
}

int epsnet_stream_open(epsnet_stream **s, epsnet_context *ctx, epsnet_error *err)
{
    if (!s || !ctx)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_stream_open: NULL argument");
    snprintf(ctx->command, sizeof ctx->command, "simplify");
    return en_stream_new(s, ctx, EN_SLAB_SIMPLIFY, NULL, err);
}

int epsnet_stream_push(epsnet_stream *s, const epsnet_record *rec, epsnet_error *err)
{
    if (!s || !rec)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_stream_push: NULL argument");
    return en_stream_put(s, rec, err);
}

int epsnet_stream_end(epsnet_stream *s, epsnet_error *err)
{
    if (!s)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_stream_end: NULL argument");
    int rc = en_stream_finish(s, err);
    if (rc == 0)
        s->ctx->stats.peak_rss = en_peak_rss_bytes();
    return rc;
}

int epsnet_stream_pull(epsnet_stream *s, epsnet_record *rec, epsnet_error *err)
{
    if (!s || !rec)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_stream_pull: NULL argument");
    if (s->qlen == 0) {
        if (s->failed) {
            *err = s->failure;
            return s->failed;
        }
        return 0;
    }
    *rec = s->queue[s->qhead];
    s->qhead = (s->qhead + 1) % s->qcap;
    s->qlen--;
    return 1;
}
