/*
 * File-to-file runs of the streaming pipeline: epsnet_simplify_file() and
 * the point output of epsnet_sample_file(). The reader feeds the stream on
 * this thread; the stitcher's records go straight to the writer.
 */
#include <stdio.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>

#include "api/context.h"
#include "api/jobs.h"
#include "api/stream_files.h"
#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"
#include "io/samples_ply.h"
#include "io/sink.h"
#include "pipeline/stream.h"
#include "sort/sort.h"

/* Records between two progress callbacks. */
#define PROGRESS_EVERY 65536

static int writer_sink(void *opaque, const epsnet_record *rec, epsnet_error *err)
{
    return epsnet_writer_put(opaque, rec, err);
}

/*
 * The run's input: a stream read as it is (r), or an ordinary mesh that the
 * sort turns into one on the fly (sort). info is what the writer and the
 * pipeline need to know of the stream either way.
 */
typedef struct en_input {
    epsnet_reader *r;
    en_sort *sort;
    epsnet_mesh_info info;
} en_input;

static void input_close(en_input *in)
{
    epsnet_reader_close(&in->r);
    en_sort_close(&in->sort, NULL);
}

static int stream_sink(void *opaque, const epsnet_record *rec, epsnet_error *err)
{
    return en_stream_put(opaque, rec, err);
}

/* Read the input into s. A sorted input's records leave the sort's last
 * pass straight into the first chunker; the sort reports progress itself. */
static int feed(epsnet_context *ctx, epsnet_stream *s, en_input *in, const char *path, epsnet_error *err)
{
    int rc;
    if (in->sort) {
        if ((rc = en_sort_emit(in->sort, stream_sink, s, err)))
            return rc;
        return en_stream_finish(s, err);
    }
    epsnet_reader *r = in->r;
    epsnet_record rec;
    uint64_t n = 0;
    while ((rc = epsnet_reader_next(r, &rec, err)) == 1) {
        if ((rc = en_stream_put(s, &rec, err)) != 0)
            return rc;
        if (ctx->settings.progress && ++n % PROGRESS_EVERY == 0 &&
            ctx->settings.progress(ctx->settings.progress_opaque, epsnet_reader_bytes_read(r),
                                   epsnet_reader_file_size(r)))
            return en_error_set(err, EPSNET_EINTR, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "cancelled");
    }
    if (rc < 0)
        return rc;
    return en_stream_finish(s, err);
}

/* Folder for the sort's runs: --tmpdir, else the output's folder. */
static void temp_folder(const epsnet_context *ctx, const char *out_path, char *dir, size_t n)
{
    const char *slash = strrchr(out_path, '/');
    if (ctx->tmpdir)
        snprintf(dir, n, "%s", ctx->tmpdir);
    else if (strcmp(out_path, "-") == 0)
        snprintf(dir, n, "%s", getenv("TMPDIR") && *getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    else if (slash)
        snprintf(dir, n, "%.*s", (int)(slash - out_path) + (slash == out_path), out_path);
    else
        snprintf(dir, n, ".");
}

/*
 * Open in_path as a finalized stream. An ordinary mesh (PLY, OBJ, OFF, STL:
 * no finalization) is sorted first (issue 5, SPEC §2): passes 1 to 5 of the
 * sort run here, the last one inside feed(), whose records go to the first
 * chunker without a temporary copy. Without this the whole mesh would be
 * one slab: correct, but in memory.
 *
 * note: the budget split. The sort's buffers get half of --mem and the
 * pipeline keeps its own sizing from the whole of it: its slabs (and so
 * the output bytes) must be those of the same run on the sorted file, and
 * the sort's last pass, which runs beside the pipeline, holds only what
 * passes 1 to 5 left within that half: the in-memory sort's arrays (at
 * most half of its share, src/sort/sort.c: whole_bytes), or the final
 * merge of the faces, the in-core last-use array and the live vertices,
 * which the sort itself stops at half of its share. With no --mem the sort
 * keeps its default (512M) and the pipeline its own limits.
 */
static int open_input(epsnet_context *ctx, const char *in_path, const char *out_path, en_input *in,
                      double *sort_seconds, epsnet_error *err)
{
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    rs.mem_limit = en_stream_mem_budget(&ctx->settings);
    int rc = epsnet_reader_open(&in->r, in_path, &rs, err);
    if (rc == 0)
        in->info = *epsnet_reader_info(in->r);
    if (rc || in->info.streaming)
        return rc;
    epsnet_reader_close(&in->r);
    char dir[PATH_MAX];
    temp_folder(ctx, out_path, dir, sizeof dir);
    epsnet_sort_settings ss;
    epsnet_sort_default_settings(&ss);
    if (ctx->settings.mem)
        ss.mem = ctx->settings.mem / 2;
    ss.tmpdir = dir;
    ss.threads = ctx->settings.threads;
    ss.progress = ctx->settings.progress;
    ss.progress_opaque = ctx->settings.progress_opaque;
    double t0 = en_now();
    rc = en_sort_open(&in->sort, in_path, out_path, &ss, err);
    *sort_seconds = en_now() - t0;
    if (rc == 0)
        en_sort_info(in->sort, &in->info);
    return rc;
}

int epsnet_simplify_file(epsnet_context *ctx, const char *in_path, const char *out_path, epsnet_error *err)
{
    if (!ctx || !in_path || !out_path)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_simplify_file: NULL argument");
    snprintf(ctx->command, sizeof ctx->command, "simplify");
    double t0 = en_now();
    en_input in = { 0 };
    epsnet_writer *w = NULL;
    epsnet_stream *s = NULL;
    double sort_seconds = 0;
    int rc = open_input(ctx, in_path, out_path, &in, &sort_seconds, err);
    if (rc == 0) {
        epsnet_writer_settings ws;
        epsnet_writer_default_settings(&ws);
        ws.ascii = ctx->settings.ascii;
        ws.tmpdir = ctx->tmpdir;
        epsnet_mesh_info info;
        memset(&info, 0, sizeof info);
        info.nverts = EPSNET_COUNT_UNKNOWN;
        info.nfaces = EPSNET_COUNT_UNKNOWN;
        info.coord_type = in.info.coord_type;
        info.streaming = 1;
        info.sorted_axis = in.info.sorted_axis; /* output vertices keep the input's order */
        rc = epsnet_writer_open(&w, out_path, &ws, &info, err);
    }
    if (rc == 0)
        rc = en_stream_new(&s, ctx, EN_SLAB_SIMPLIFY, in_path, err);
    ctx->stats.seconds_sort = sort_seconds;
    if (rc == 0) {
        en_stream_set_sink(s, writer_sink, w);
        rc = feed(ctx, s, &in, in_path, err);
    }
    epsnet_stream_close(&s);
    input_close(&in);
    if (rc == 0)
        rc = epsnet_writer_commit(&w, err);
    else
        epsnet_writer_abort(&w);
    ctx->stats.seconds_simplify = en_now() - t0;
    ctx->stats.peak_rss = en_peak_rss_bytes();
    return rc;
}

typedef struct sample_point {
    uint64_t gid;
    double xyz[3];
    int32_t gvertex;
} sample_point;

typedef struct sample_list {
    sample_point *p;
    size_t n, cap;
} sample_list;

static int collect(void *opaque, uint64_t gid, const double xyz[3], int32_t gvertex, epsnet_error *err)
{
    sample_list *l = opaque;
    if (en_grow((void **)&l->p, &l->cap, l->n + 1, sizeof *l->p))
        return en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory: %zu samples", l->n);
    l->p[l->n].gid = gid;
    memcpy(l->p[l->n].xyz, xyz, sizeof l->p[l->n].xyz);
    l->p[l->n].gvertex = gvertex;
    l->n++;
    return 0;
}

static int by_gid(const void *a, const void *b)
{
    uint64_t x = ((const sample_point *)a)->gid, y = ((const sample_point *)b)->gid;
    return (x > y) - (x < y);
}

int en_sample_points_streamed(epsnet_context *ctx, const char *in_path, const char *out_path, int ascii,
                              epsnet_error *err)
{
    double t0 = en_now();
    en_input in = { 0 };
    epsnet_stream *s = NULL;
    sample_list l = { 0 };
    epsnet_coord_type ct = EPSNET_COORD_FLOAT32;
    double sort_seconds = 0;
    int rc = open_input(ctx, in_path, out_path, &in, &sort_seconds, err);
    if (rc == 0) {
        ct = in.info.coord_type;
        rc = en_stream_new(&s, ctx, EN_SLAB_SAMPLE, in_path, err);
    }
    ctx->stats.seconds_sort = sort_seconds;
    if (rc == 0) {
        en_stream_set_sample_sink(s, collect, &l);
        rc = feed(ctx, s, &in, in_path, err);
    }
    epsnet_stream_close(&s);
    input_close(&in);
    ctx->stats.seconds_classify = en_now() - t0;
    /* Samples are few (about one per Gaussian vertex per feature): written in
     * input order, as the one-slab run writes them. */
    double *pos = NULL;
    int32_t *gv = NULL;
    uint8_t *one = NULL;
    if (rc == 0) {
        qsort(l.p, l.n, sizeof *l.p, by_gid);
        pos = en_malloc(3 * sizeof *pos * l.n + 8);
        gv = en_malloc(sizeof *gv * l.n + 8);
        one = en_malloc(l.n + 1);
        if (!pos || !gv || !one)
            rc = en_error_set(err, EPSNET_ENOMEM, in_path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    if (rc == 0) {
        for (size_t i = 0; i < l.n; i++) {
            memcpy(pos + 3 * i, l.p[i].xyz, 3 * sizeof *pos);
            gv[i] = l.p[i].gvertex;
            one[i] = 1;
        }
        double t1 = en_now();
        rc = en_write_sample_points(out_path, ascii, ct, l.n, pos, one, gv, err);
        ctx->stats.seconds_write = en_now() - t1;
    }
    en_free(pos);
    en_free(gv);
    en_free(one);
    en_free(l.p);
    ctx->stats.peak_rss = en_peak_rss_bytes();
    return rc;
}
