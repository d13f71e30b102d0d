/*
 * File-to-file runs of the streaming pipeline: epsnet_simplify_file() and
 * the point output of epsnet_sample_file(). The reader feeds the stream on
 * this thread; the stitcher's records go straight to the writer.
 */
#include <stdio.h>
#include <errno.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "api/run.h"
#include "api/stream_files.h"
#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"
#include "io/format.h"
#include "io/samples_ply.h"
#include "io/sink.h"

/* Records between two progress callbacks. */
#define PROGRESS_EVERY 65536

static int writer_put(void *self, const epsnet_record *rec, epsnet_error *err)
{
    return epsnet_writer_put(self, rec, err);
}

/* Read r into the run, then end it; r is opened and closed by the caller. */
static int feed(epsnet_context *ctx, en_run *run, epsnet_reader *r, const char *path, epsnet_error *err)
{
    epsnet_record rec;
    uint64_t n = 0;
    int rc;
    while ((rc = epsnet_reader_next(r, &rec, err)) == 1) {
        if ((rc = en_run_put(run, &rec, err)) != 0)
            return rc;
        if (ctx->settings.progress && ++n % PROGRESS_EVERY == 0 &&
            ctx->settings.progress(ctx->settings.progress_opaque, epsnet_reader_bytes_read(r),
                                   epsnet_reader_file_size(r)))
            return en_error_set(err, EPSNET_EINTR, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "cancelled");
    }
    if (rc < 0)
        return rc;
    ctx->stats.dropped += en_reader_warn_dropped(r, ctx->settings.warning, ctx->settings.warning_opaque);
    return en_run_end(run, err);
}

/* Folder for the sorted copy: --tmpdir, else the output's folder. */
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
 * no finalization) is first sorted into a temporary .smz (issue 5, SPEC
 * §2), read back and unlinked as soon as it is open; it is registered for
 * removal on SIGINT/SIGTERM meanwhile. Without this the whole mesh would be
 * one slab: correct, but in memory. *sorted gets the sort's statistics
 * (axis -1 when the input was a stream and no sort ran).
 */
static int open_input(epsnet_context *ctx, const char *in_path, const char *out_path, epsnet_reader **r,
                      double *sort_seconds, epsnet_sort_stats *sorted, epsnet_error *err)
{
    memset(sorted, 0, sizeof *sorted);
    sorted->axis = -1; /* no sort ran */
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    rs.mem_limit = en_run_mem_budget(&ctx->settings);
    int rc = epsnet_reader_open(r, in_path, &rs, err);
    if (rc || epsnet_reader_info(*r)->streaming)
        return rc;
    epsnet_reader_close(r);
    char dir[PATH_MAX], tmp[PATH_MAX + 64];
    temp_folder(ctx, out_path, dir, sizeof dir);
    int slot;
    int fd = en_temp_create(dir, ".epsnet-sorted-", ".smz", 0600, tmp, sizeof tmp, &slot);
    if (fd < 0)
        return en_error_set(err, EPSNET_EIO, out_path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "cannot create the sorted copy of %s in %s: %s", in_path, dir, strerror(errno));
    close(fd);
    epsnet_sort_settings ss;
    epsnet_sort_default_settings(&ss);
    if (ctx->settings.mem)
        ss.mem = ctx->settings.mem;
    ss.tmpdir = ctx->tmpdir;
    ss.format = "smz";
    ss.warning = ctx->settings.warning;
    ss.warning_opaque = ctx->settings.warning_opaque;
    double t0 = en_now();
    rc = epsnet_sort_file(in_path, tmp, &ss, sorted, err);
    *sort_seconds = en_now() - t0;
    if (rc && err && strcmp(err->file, tmp) == 0) {
        /* The copy's random name means nothing to the user and is gone by
         * the time they read the message: name the output and the folder. */
        char reason[sizeof err->reason];
        snprintf(reason, sizeof reason, "%s", err->reason);
        en_error_set(err, rc, out_path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                     "writing the sorted copy of the input in %s: %s", dir, reason);
    }
    if (rc == 0)
        rc = epsnet_reader_open(r, tmp, &rs, err);
    unlink(tmp); /* the reader keeps it open; nothing is left behind */
    en_temp_unregister(slot);
    return rc;
}

int en_simplify_streamed(epsnet_context *ctx, const char *in_path, const char *near_path, en_open_out_fn open_out,
                         void *opaque, epsnet_error *err)
{
    double t0 = en_now();
    epsnet_reader *r = NULL;
    en_run run;
    memset(&run, 0, sizeof run);
    double sort_seconds = 0;
    en_stage out = { 0 };
    epsnet_sort_stats sorted;
    int rc = open_input(ctx, in_path, near_path, &r, &sort_seconds, &sorted, err);
    if (rc == 0)
        rc = open_out(opaque, epsnet_reader_info(r), &out, err);
    if (rc == 0)
        rc = en_run_open(&run, ctx, EN_SLAB_SIMPLIFY, in_path, out, NULL, NULL, err);
    ctx->stats.dropped = sorted.dropped; /* after en_run_open(), which resets the stats */
    if (rc == 0)
        rc = feed(ctx, &run, r, in_path, err);
    en_run_close(&run);
    epsnet_reader_close(&r);
    ctx->stats.seconds_sort = sort_seconds;
    /* note: a sorted copy holds only referenced vertices, so a mesh without
     * faces is told by the sort's count of the input. */
    uint64_t nv = sorted.axis >= 0 ? sorted.vertices : ctx->stats.vertices;
    if (rc == 0 && nv > 0 && ctx->stats.faces == 0 && ctx->settings.warning) {
        char msg[PATH_MAX + 128];
        snprintf(msg, sizeof msg, "%s: %llu vertices but no faces: nothing to simplify, the output is empty",
                 in_path, (unsigned long long)nv);
        ctx->settings.warning(ctx->settings.warning_opaque, msg);
    }
    ctx->stats.seconds_simplify = en_now() - t0;
    return rc;
}

typedef struct file_out {
    epsnet_context *ctx;
    const char *path;
    epsnet_writer *w;
} file_out;

static int open_writer(void *opaque, const epsnet_mesh_info *in, en_stage *out, epsnet_error *err)
{
    file_out *f = opaque;
    epsnet_writer_settings ws;
    epsnet_writer_default_settings(&ws);
    ws.ascii = f->ctx->settings.ascii;
    ws.tmpdir = f->ctx->tmpdir;
    epsnet_mesh_info info;
    memset(&info, 0, sizeof info);
    info.nverts = EPSNET_COUNT_UNKNOWN;
    info.nfaces = EPSNET_COUNT_UNKNOWN;
    info.coord_type = in->coord_type;
    info.streaming = 1;
    info.sorted_axis = in->sorted_axis; /* output vertices keep the input's order */
    int rc = epsnet_writer_open(&f->w, f->path, &ws, &info, err);
    *out = (en_stage){ writer_put, NULL, f->w };
    return rc;
}

int epsnet_simplify_file(epsnet_context *ctx, const char *in_path, const char *out_path, epsnet_error *err)
{
    if (!ctx || !in_path || !out_path)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_simplify_file: NULL argument");
    snprintf(ctx->command, sizeof ctx->command, "simplify");
    file_out f = { ctx, out_path, NULL };
    int rc = en_simplify_streamed(ctx, in_path, out_path, open_writer, &f, err);
    if (rc == 0)
        rc = epsnet_writer_commit(&f.w, err);
    else
        epsnet_writer_abort(&f.w);
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
    epsnet_reader *r = NULL;
    en_run run;
    memset(&run, 0, sizeof run);
    sample_list l = { 0 };
    epsnet_coord_type ct = EPSNET_COORD_FLOAT32;
    double sort_seconds = 0;
    epsnet_sort_stats sorted;
    int rc = open_input(ctx, in_path, out_path, &r, &sort_seconds, &sorted, err);
    if (rc == 0) {
        ct = epsnet_reader_info(r)->coord_type;
        rc = en_run_open(&run, ctx, EN_SLAB_SAMPLE, in_path, (en_stage){ 0 }, collect, &l, err);
    }
    ctx->stats.dropped = sorted.dropped;
    if (rc == 0)
        rc = feed(ctx, &run, r, in_path, err);
    en_run_close(&run);
    ctx->stats.seconds_sort = sort_seconds;
    epsnet_reader_close(&r);
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
