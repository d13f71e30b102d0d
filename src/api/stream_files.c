/*
 * File runs of the stage chain: epsnet_simplify_file(), en_simplify_streamed()
 * (any output stage: the writer, render's collector) and the point output of
 * epsnet_sample_file(). The input is read, or sorted, on this thread and
 * pushed into the run's chain; the last pass's records go to the output.
 */
#include <stdio.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>

#include "api/run.h"
#include "api/smz_windows.h"
#include "api/windows.h"
#include "api/stream_files.h"
#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"
#include "io/format.h"
#include "io/samples_ply.h"
#include "pipeline/normals_stage.h"
#include "pipeline/slab_server.h"
#include "sort/sort.h"

/* Records between two progress callbacks. */
#define PROGRESS_EVERY 65536

static int writer_put(void *self, const epsnet_record *rec, epsnet_error *err)
{
    return epsnet_writer_put(self, rec, err);
}

/*
 * One bar for the whole chain when the input is sorted first. The sort
 * reports its six passes as equal parts of its total; passes 1 to 5 only
 * sort, while records of pass 6 go through every ε-net pass as they leave,
 * which is most of the run (2M shuffled faces, -j2: 0.6 s of sorting in
 * 2.6, bench/RESULTS.md; more when the sort spills). So passes 1 to 5 fill
 * the first SORT_SHARE of the feed's part of the bar and pass 6 the rest,
 * and the ETA (elapsed / fraction) counts the stages still to come; a
 * streamed target's one-slab finish has the bar's last part
 * (en_run_feed_share).
 */
#define SORT_SHARE 0.3

/* share: the part of the bar the feed fills (en_run_feed_share: a
 * streamed target's one-slab finish fills the rest). */
typedef struct chain_progress {
    int (*user)(void *opaque, uint64_t done, uint64_t total);
    void *opaque;
    double share;
} chain_progress;

static int sort_progress(void *opaque, uint64_t done, uint64_t total)
{
    const chain_progress *cp = opaque;
    double f = total ? (double)done / (double)total : 0, pass6 = 5.0 / 6.0;
    double bar = f < pass6 ? f / pass6 * SORT_SHARE : SORT_SHARE + (f - pass6) / (1 - pass6) * (1 - SORT_SHARE);
    return cp->user(cp->opaque, (uint64_t)(bar * cp->share * EN_RUN_BAR_UNITS), EN_RUN_BAR_UNITS);
}

/* The reader's bytes as the feed's part of the bar. */
static int feed_progress(const epsnet_context *ctx, const en_run *run, const epsnet_reader *r)
{
    uint64_t done = epsnet_reader_bytes_read(r), total = epsnet_reader_file_size(r);
    if (run->feed_share >= 1 || total == 0)
        return ctx->settings.progress(ctx->settings.progress_opaque, done, total);
    double bar = (double)(done < total ? done : total) / (double)total * run->feed_share;
    return ctx->settings.progress(ctx->settings.progress_opaque, (uint64_t)(bar * EN_RUN_BAR_UNITS),
                                  EN_RUN_BAR_UNITS);
}

/*
 * The run's input: a stream read as it is (r), or an ordinary mesh that the
 * sort turns into one on the fly (sort). info is what the writer and the
 * chain need to know of the stream either way; sorted holds the sort's
 * statistics once the input is closed.
 */
typedef struct en_input {
    epsnet_reader *r;
    en_sort *sort;
    chain_progress progress;      /* the user's callback, behind sort_progress */
    epsnet_mesh_info info;
    en_budget budget;             /* --mem split for a stream, or for the sort and the chain */
    int was_sorted;
    int had_normals;              /* the file's vertices had normals (--drop-normals left them) */
    epsnet_sort_stats sorted;
} en_input;

static void input_close(en_input *in)
{
    epsnet_reader_close(&in->r);
    if (in->sort)
        en_sort_close(&in->sort, &in->sorted);
}

static int run_put(void *self, epsnet_record **recs, size_t *cap, size_t n, epsnet_error *err)
{
    return cap ? en_run_put_owned(self, recs, cap, n, err) : en_run_put_many(self, *recs, n, err);
}

/* Push the input into the run, then end it. A sorted input's records leave
 * the sort's last pass straight into the first chunker; the sort reports
 * progress itself. */
static int feed(epsnet_context *ctx, en_run *run, en_input *in, const char *path, epsnet_error *err)
{
    int rc;
    if (in->sort) {
        if ((rc = en_sort_emit(in->sort, run_put, run, err)))
            return rc;
        return en_run_end(run, err);
    }
    epsnet_reader *r = in->r;
    const epsnet_record *recs;
    size_t n;
    uint64_t seen = 0, next_report = PROGRESS_EVERY;
    /* note: straight from the reader's queue, one copy fewer than
     * epsnet_reader_next() (docs/architecture.md §10) */
    while ((rc = en_reader_next_batch(r, &recs, &n, err)) == 1) {
        if ((rc = en_run_put_many(run, recs, n, err)) != 0)
            return rc;
        seen += n;
        if (ctx->settings.progress && seen >= next_report) {
            next_report = seen + PROGRESS_EVERY;
            if (feed_progress(ctx, run, r))
                return en_error_set(err, EPSNET_EINTR, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "cancelled");
        }
    }
    if (rc < 0)
        return rc;
    ctx->stats.dropped += en_reader_warn_dropped(r, ctx->settings.warning, ctx->settings.warning_opaque);
    return en_run_end(run, err);
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
 * no finalization) is sorted first (docs/architecture.md §13): passes 1 to
 * 5 of the sort run here, the last one inside feed(), whose records go to
 * the first chunker without a temporary copy. Without this the whole mesh
 * would be one slab: correct, but in memory.
 *
 * The budget (api/budget.h) is split for a stream first, which gives the
 * reader its share while it tells what the file is, and again for the sort
 * and the chain when the file must be sorted: the sort then reads the file
 * itself, within its share.
 */
static int open_input(epsnet_context *ctx, const char *in_path, const epsnet_arrays *arrays, const char *out_path,
                      const en_format *keep, en_pool *pool, en_input *in, double *sort_seconds, epsnet_error *err)
{
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    en_budget_split(&in->budget, &ctx->settings, EN_BUDGET_STREAM);
    rs.mem_limit = in->budget.reader;
    int rc = arrays ? epsnet_reader_open_arrays(&in->r, arrays, &rs, err) : epsnet_reader_open(&in->r, in_path, &rs, err);
    /* note: the chain carries the vertex attributes the output's format
     * holds (keep; NULL: none, e.g. a picture or sample points); the
     * others are named in the one dropped warning (docs/architecture.md §5).
     * Arrays go to arrays, which hold every attribute. */
    int all = arrays || (keep && ctx->settings.lock_property); /* the lock travels even where the output drops it */
    if (rc == 0) {
        in->had_normals = epsnet_attr_layout_find(&in->r->file_attrs, "nx") >= 0;
        en_reader_keep_attrs(in->r, keep, all, ctx->settings.drop_normals);
    }
    if (rc == 0)
        in->info = *epsnet_reader_info(in->r);
    if (rc || in->info.streaming)
        return rc;
    /* note: a file is read again by the sort, within its own share of the
     * budget; arrays are handed over unread, as they are */
    epsnet_reader *unread = arrays ? in->r : NULL;
    if (!arrays)
        epsnet_reader_close(&in->r);
    in->r = NULL;
    char dir[PATH_MAX];
    temp_folder(ctx, arrays ? "-" : out_path, dir, sizeof dir);
    epsnet_sort_settings ss;
    epsnet_sort_default_settings(&ss);
    en_budget_split(&in->budget, &ctx->settings, EN_BUDGET_SORTED);
    if (in->budget.sort)
        ss.mem = in->budget.sort;
    ss.tmpdir = dir;
    ss.threads = ctx->settings.threads;
    if (ctx->settings.progress) {
        in->progress = (chain_progress){ ctx->settings.progress, ctx->settings.progress_opaque,
                                         en_run_feed_share(&ctx->settings, &in->info, EN_BUDGET_SORTED) };
        ss.progress = sort_progress;
        ss.progress_opaque = &in->progress;
    }
    ss.warning = ctx->settings.warning;
    ss.warning_opaque = ctx->settings.warning_opaque;
    in->was_sorted = 1;
    double t0 = en_now();
    int keep_attrs = all ? EN_SORT_KEEP_ALL : keep ? EN_SORT_KEEP_FORMAT : 0;
    if (ctx->settings.drop_normals)
        keep_attrs |= EN_SORT_DROP_NORMALS;
    /* a size prices its thinning on windows of the sorted stream (api/windows.h) */
    en_sort_stretches_fn stretches = en_run_has_target(&ctx->settings) ? en_windows_stretches : NULL;
    rc = unread ? en_sort_open_reader(&in->sort, unread, in_path, in_path, &ss, keep_attrs, stretches, pool, err)
                : en_sort_open(&in->sort, in_path, out_path, &ss, keep_attrs, stretches, pool, err);
    *sort_seconds = en_now() - t0;
    if (rc == 0) {
        en_sort_info(in->sort, &in->info);
    }
    return rc;
}

/*
 * A run of the chain on a file: one pool for the whole chain, the sort's
 * passes and the .smz decoding included (docs/architecture.md §10), the
 * input (read or sorted), and the run. file_run_open() makes the pool and
 * opens the input; file_run_feed() opens the run on what the input is and
 * pushes every record through; file_run_close() takes it all down, the
 * pool last, and counts the sort in ctx->stats.
 */
typedef struct file_run {
    en_pool *pool;
    en_input in;
    en_run run;
    double sort_seconds, cpu0;
} file_run;

static int file_run_open(file_run *fr, epsnet_context *ctx, const char *in_path, const epsnet_arrays *arrays,
                         const char *near_path, const en_format *keep, epsnet_error *err)
{
    memset(fr, 0, sizeof *fr);
    fr->cpu0 = en_thread_cpu_seconds();
    int rc = en_run_pool_new(&fr->pool, &ctx->settings, in_path, err);
    return rc ? rc : open_input(ctx, in_path, arrays, near_path, keep, fr->pool, &fr->in, &fr->sort_seconds, err);
}

static int sort_walk(void *opaque, uint64_t lo, uint64_t hi, uint64_t base, en_stage *into, uint64_t *pushed,
                     uint64_t *cut, epsnet_error *err)
{
    return en_sort_window(opaque, lo, hi, base, into, pushed, cut, err);
}

static int file_run_feed(file_run *fr, epsnet_context *ctx, en_slab_mode mode, const char *in_path, en_stage out,
                         en_sample_fn on_sample, void *sample_opaque, epsnet_error *err)
{
    /* a size's pricing windows (api/windows.h): a sorted .smz through its
     * index, a sort through its arrays when it ran in memory */
    en_window_backend wb = { 0 };
    en_smz_windows *sw = NULL;
    int rc = 0;
    if (mode == EN_SLAB_SIMPLIFY && en_run_has_target(&ctx->settings)) {
        uint64_t ranks;
        if (fr->in.sort && en_sort_windowed(fr->in.sort, &ranks))
            wb = (en_window_backend){ ranks, sort_walk, fr->in.sort };
        else if (!fr->in.sort)
            rc = en_smz_windows_open(&sw, in_path, &fr->in.info.vertex_attrs, fr->pool, &wb, err);
    }
    if (rc == 0)
        rc = en_run_open(&fr->run, ctx, mode, in_path, &fr->in.info, &wb, &fr->in.budget, 1, fr->pool, out,
                         on_sample, sample_opaque, err);
    en_smz_windows_close(&sw);
    fr->run.cpu_start = fr->cpu0; /* the sort before the run is its work too */
    if (rc == 0)
        en_reader_use_pool(fr->in.r, fr->pool); /* ENOMEM: it decodes alone, as before */
    return rc ? rc : feed(ctx, &fr->run, &fr->in, in_path, err);
}

static void file_run_close(file_run *fr, epsnet_context *ctx)
{
    en_reader_use_pool(fr->in.r, NULL); /* before the pool goes */
    en_run_close(&fr->run);
    input_close(&fr->in);
    en_pool_free(&fr->pool);
    ctx->stats.seconds_sort = fr->sort_seconds;
    ctx->stats.dropped += fr->in.sorted.dropped;
}

int en_simplify_streamed(epsnet_context *ctx, const char *in_path, const epsnet_arrays *arrays, const char *near_path,
                         const en_format *keep, en_open_out_fn open_out, en_release_out_fn release_out, void *opaque,
                         epsnet_error *err)
{
    double t0 = en_now();
    file_run fr;
    en_stage out = { 0 };
    int rc = file_run_open(&fr, ctx, in_path, arrays, near_path, keep, err);
    int opened = rc == 0;
    /* --drop-normals did not read the input's normals; an output that holds
     * normals gets them from its own faces (pipeline/normals_stage.h) */
    epsnet_mesh_info info = fr.in.info;
    en_normals_stage *normals = NULL;
    int recompute = rc == 0 && ctx->settings.drop_normals && fr.in.had_normals && keep && keep->holds_attr &&
                    en_normals_layout(&fr.in.info.vertex_attrs, &info.vertex_attrs) == 0 &&
                    keep->holds_attr(&info.vertex_attrs, info.vertex_attrs.count - 3);
    if (!recompute)
        info = fr.in.info;
    if (rc == 0)
        rc = open_out(opaque, &info, fr.pool, &out, err);
    if (rc == 0 && recompute && (rc = en_normals_stage_new(&normals, fr.in.info.vertex_attrs.size, out, err)) == 0)
        out = en_normals_stage_input(normals);
    if (rc == 0)
        rc = file_run_feed(&fr, ctx, EN_SLAB_SIMPLIFY, in_path, out, NULL, NULL, err);
    if (opened && release_out)
        release_out(opaque);
    file_run_close(&fr, ctx);
    en_normals_stage_free(&normals); /* after the run, which may hold it */
    /* note: the sort passes on only referenced vertices, so a mesh without
     * faces is told by the sort's count of the input. */
    uint64_t nv = fr.in.was_sorted ? fr.in.sorted.vertices : ctx->stats.vertices;
    if (rc == 0 && nv > 0 && ctx->stats.faces == 0 && ctx->settings.warning) {
        char msg[PATH_MAX + 128];
        snprintf(msg, sizeof msg, "%s: %llu vertices but no faces: nothing to simplify, the output is empty",
                 in_path, (unsigned long long)nv);
        ctx->settings.warning(ctx->settings.warning_opaque, msg);
    } else if (rc == 0 && fr.in.was_sorted) {
        /* the sort passes on only vertices on faces: the stats count the
         * input's own vertices, and those it left out as isolated */
        ctx->stats.vertices = fr.in.sorted.vertices;
        ctx->stats.isolated_vertices += fr.in.sorted.unreferenced;
    }
    ctx->stats.seconds_simplify = en_now() - t0;
    return rc;
}

typedef struct file_out {
    epsnet_context *ctx;
    const char *path;
    epsnet_writer *w;
} file_out;

static int open_writer(void *opaque, const epsnet_mesh_info *in, en_pool *pool, en_stage *out, epsnet_error *err)
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
    info.vertex_attrs = in->vertex_attrs; /* kept vertices keep their bytes */
    info.materials = in->materials;       /* and so their faces' materials */
    info.groups = in->groups;             /* and groups */
    int rc = epsnet_writer_open(&f->w, f->path, &ws, &info, err);
    /* note: the writer encodes on the run's pool, if its format can
     * (docs/architecture.md §10); ENOMEM: it encodes alone, as before */
    if (rc == 0)
        (void)en_writer_use_pool(f->w, pool);
    *out = (en_stage){ writer_put, NULL, f->w };
    return rc;
}

/* Another rank's run (epsnet.h section 8a): slabs from rank 0, worked on
 * this rank's threads (at least one: this thread carries the messages),
 * within the budget's share for them (all of it: it reads, sorts and
 * writes nothing). */
static int serve_slabs(epsnet_context *ctx, const char *in_path, epsnet_error *err)
{
    en_pool *pool = NULL;
    int workers = en_run_workers(&ctx->settings);
    int rc = en_pool_new(&pool, workers ? workers : 1);
    if (rc)
        return en_error_set(err, rc, in_path, EPSNET_POS_NONE, EPSNET_POS_NONE, "cannot start %d worker threads",
                            workers ? workers : 1);
    memset(&ctx->stats, 0, sizeof ctx->stats);
    en_budget b;
    en_budget_split(&b, &ctx->settings, EN_BUDGET_SERVED);
    rc = en_slab_serve(ctx->peers, pool, b.chain, in_path, err);
    en_pool_free(&pool);
    return rc;
}

static void release_writer(void *opaque)
{
    file_out *f = opaque;
    (void)en_writer_use_pool(f->w, NULL); /* a failure is the writer's, its commit reports it */
}

int epsnet_simplify_file(epsnet_context *ctx, const char *in_path, const char *out_path, epsnet_error *err)
{
    if (!ctx || !in_path || !out_path)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_simplify_file: NULL argument");
    snprintf(ctx->command, sizeof ctx->command, "simplify");
    file_out f = { ctx, out_path, NULL };
    /* shared among processes (epsnet.h section 8a): rank 0 runs the
     * chain, the others serve it slabs */
    int rc = 0;
    if (ctx->settings.peers) {
        rc = en_peer_link_new(&ctx->peers, ctx->settings.peers, in_path, err);
        if (rc == 0 && en_peer_rank(ctx->peers) != 0) {
            rc = serve_slabs(ctx, in_path, err);
            rc = en_peer_agree(ctx->peers, rc, err);
            en_peer_link_free(&ctx->peers);
            return rc;
        }
    }
    if (rc == 0)
        rc = en_simplify_streamed(ctx, in_path, NULL, out_path, en_format_by_path(out_path), open_writer,
                                  release_writer, &f, err);
    /* what the writer leaves out (only the lock property can get this far
     * unfiltered: the reader kept every attribute for it) */
    uint64_t left_out = 0;
    const char *dropped = rc == 0 && f.w ? epsnet_writer_dropped(f.w, &left_out) : NULL;
    if (dropped && ctx->settings.warning) {
        char msg[PATH_MAX + 512];
        snprintf(msg, sizeof msg, "%s: dropped: %s", out_path, dropped);
        ctx->settings.warning(ctx->settings.warning_opaque, msg);
    }
    ctx->stats.dropped += left_out;
    if (ctx->peers) {
        ctx->stats.slabs_shipped = en_peer_slabs_shipped(ctx->peers);
        /* the output whole in its temporary file, then every rank's end
         * and one verdict, before it is moved into place */
        if (rc == 0 && f.w)
            rc = en_writer_settle(f.w, err);
        rc = en_peer_agree(ctx->peers, rc, err);
        en_peer_link_free(&ctx->peers);
    }
    if (rc == 0 && f.w)
        rc = epsnet_writer_commit(&f.w, err);
    else
        epsnet_writer_abort(&f.w);
    if (rc == 0)
        en_warn_unreferenced(ctx, in_path, "written");
    ctx->stats.peak_rss = en_peak_rss_bytes();
    return rc;
}

void en_warn_unreferenced(epsnet_context *ctx, const char *name, const char *where)
{
    /* the output is a surface: a vertex no face uses is not on it and is
     * not written (the sort or the stitcher leaves it out); named
     * (docs/architecture.md §5) once the output is there (a mesh of no
     * face at all was said before) */
    if (!ctx->stats.isolated_vertices || !ctx->stats.faces || !ctx->settings.warning)
        return;
    char msg[PATH_MAX + 160];
    snprintf(msg, sizeof msg, "%s: %llu vertices that no face uses%s are not %s", name,
             (unsigned long long)ctx->stats.isolated_vertices,
             ctx->stats.membrane_faces ? " (once the glued membranes' faces are removed)" : "", where);
    ctx->settings.warning(ctx->settings.warning_opaque, msg);
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
    file_run fr;
    sample_list l = { 0 };
    epsnet_coord_type ct = EPSNET_COORD_FLOAT32;
    int rc = file_run_open(&fr, ctx, in_path, NULL, out_path, NULL, err);
    if (rc == 0) {
        ct = fr.in.info.coord_type;
        rc = file_run_feed(&fr, ctx, EN_SLAB_SAMPLE, in_path, (en_stage){ 0 }, collect, &l, err);
    }
    file_run_close(&fr, ctx);
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
