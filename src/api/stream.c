/*
 * The push/pull streaming API (epsnet.h §8b): a run of the stage chain
 * whose output stage is a queue the caller pulls from.
 *
 * Back-pressure: push refuses (EPSNET_EAGAIN, the record not taken) while
 * output waits, so the queue only ever holds what one push, or the end,
 * produced: the slabs it finished, bounded by the slab size and the slabs
 * in flight, never by the length of the mesh.
 */
#include <stdio.h>
#include <string.h>

#include "api/run.h"
#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"

struct epsnet_stream {
    en_run run;
    epsnet_record *queue;         /* output waiting for pull */
    size_t qhead, qlen, qcap;
    int failed;                   /* sticky: every later call returns it */
    epsnet_error failure;
};

static int fail(epsnet_stream *s, int rc, const epsnet_error *err)
{
    if (!s->failed) {
        s->failed = rc;
        s->failure = *err;
    }
    return rc;
}

static int queue_put(void *self, const epsnet_record *rec, epsnet_error *err)
{
    epsnet_stream *s = self;
    if (s->qlen == s->qcap) {
        size_t cap = s->qcap ? 2 * s->qcap : 256;
        epsnet_record *q = en_malloc(cap * sizeof *q);
        if (!q)
            return en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
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

int epsnet_stream_open(epsnet_stream **out, epsnet_context *ctx, epsnet_error *err)
{
    if (!out || !ctx)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_stream_open: NULL argument");
    *out = NULL;
    epsnet_stream *s = en_calloc(1, sizeof *s);
    if (!s)
        return en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    snprintf(ctx->command, sizeof ctx->command, "simplify");
    int rc = en_run_open(&s->run, ctx, EN_SLAB_SIMPLIFY, NULL, NULL, NULL, NULL, 0, NULL, (en_stage){ queue_put, NULL, s }, NULL,
                         NULL, err);
    if (rc) {
        epsnet_stream_close(&s);
        return rc;
    }
    *out = s;
    return 0;
}

int epsnet_stream_push(epsnet_stream *s, const epsnet_record *rec, epsnet_error *err)
{
    if (!s || !rec)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_stream_push: NULL argument");
    if (s->failed) {
        *err = s->failure;
        return s->failed;
    }
    if (s->qlen)
        return en_error_set(err, EPSNET_EAGAIN, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "%zu output records wait: pull them before pushing more", s->qlen);
    int rc = en_run_put(&s->run, rec, err);
    return rc ? fail(s, rc, err) : 0;
}

int epsnet_stream_end(epsnet_stream *s, epsnet_error *err)
{
    if (!s)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_stream_end: NULL argument");
    if (s->failed) {
        *err = s->failure;
        return s->failed;
    }
    int rc = en_run_end(&s->run, err);
    if (rc)
        return fail(s, rc, err);
    s->run.ctx->stats.seconds_simplify = en_now() - s->run.wall_start;
    s->run.ctx->stats.peak_rss = en_peak_rss_bytes();
    return 0;
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

void epsnet_stream_close(epsnet_stream **ps)
{
    if (!ps || !*ps)
        return;
    epsnet_stream *s = *ps;
    en_run_close(&s->run);
    en_free(s->queue);
    en_free(s);
    *ps = NULL;
}
