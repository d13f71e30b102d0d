#include "api/run.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "api/attr_weights_spec.h"
#include "api/windows.h"
#include "common/error.h"
#include "common/thread.h"
#include "common/util.h"

int en_run_workers(const epsnet_settings *set)
{
    long n = set->threads > 0 ? set->threads : en_cpus_usable();
    if (n > 256)
        n = 256;
    /* One thread means the caller's own: slabs run inline, no pool threads. */
    return n <= 1 ? 0 : (int)n;
}

int en_run_has_target(const epsnet_settings *set)
{
    return set->target_faces || set->target_ratio != 0 || set->target_vertices || set->target_error > 0;
}

/* A small input (at most this many of the settings' slabs) is one slab
 * (plan_target), and the target stage's last round takes at most this
 * many slabs in one: the thinning's, or the default's at least, so that
 * memory does not grow with the mesh (a larger one goes through rounds on
 * slabs first). */
#define ONE_SLAB_SLABS 4
static uint64_t last_slab_vertices(uint32_t slab_vertices)
{
    return ONE_SLAB_SLABS *
           (uint64_t)(slab_vertices > EN_BUDGET_DEFAULT_SLAB ? slab_vertices : EN_BUDGET_DEFAULT_SLAB);
}

/*
 * A streamed size (docs/architecture.md §7): the thinning pass on slabs,
 * then the target stage over what it left (pipeline/target_stage.h): rounds
 * under a rising global cost ceiling, on slabs, and a last round that meets
 * the count. The stage plans both.
 */
static void plan_streamed(en_run *run, const epsnet_settings *set, uint64_t nv, uint64_t nf)
{
    int by_vertices = !set->target_faces && !(set->target_ratio > 0);
    uint64_t n_faces = set->target_faces ? set->target_faces : (uint64_t)llround(set->target_ratio * (double)nf);
    run->size = (en_target_size){
        .goal = by_vertices ? set->target_vertices : n_faces,
        .by_vertices = by_vertices,
        .share = by_vertices ? (double)set->target_vertices / (double)nv : (double)n_faces / (double)nf,
        .choose_density = !set->target_level_given,
    };
    en_target_stage_plan_thin(&run->size, nv, nf, run->budget.one_slab, last_slab_vertices(run->budget.slab_vertices),
                              &run->plan);
    run->passes = 1;
    run->staged = 1;
}

/*
 * The target stage (docs/architecture.md §7, docs/method.md §13): the
 * settings' target for the slab works, and the slabs. A small input (at
 * most ONE_SLAB_SLABS of the settings' slabs), or one of unknown size, or
 * one with an error bound, is one slab: the order of collapses is global
 * and the target is met exactly. A larger one is streamed (plan_streamed),
 * and so is one over the budget or over a slab size the settings give.
 * @return 0, or ELIMIT when the input is known to be over the budget (an
 * input of unknown size meets the chain's own check while it is read).
 *
 * note: one slab is one thread, in a slab larger than the caches, at
 * 640 bytes a vertex: at 2M faces it took 3.4 times the wall time of the
 * ε-net pass and 700 MB, the streamed shape 1.09 times its CPU in 353 MB at
 * the same error (bench/RESULTS.md). Below a few slabs the two cost alike
 * and one slab's global order is the better result.
 */
static int plan_target(en_run *run, const epsnet_settings *set, const char *path, const epsnet_mesh_info *in,
                       uint32_t *slab_vertices, int *hold_all, epsnet_error *err)
{
    /* one slab of the whole mesh, unless it streams (below) */
    en_pass_plan *t = &run->plan;
    *t = (en_pass_plan){
        /* no count (an error bound alone): the sphere given, as the
         * ε-net pass's */
        .skeleton = set->target_level_given || !(set->target_faces || set->target_ratio > 0 || set->target_vertices)
                        ? EN_SKELETON_SPHERE
                        : EN_SKELETON_CHOSEN,
        .skeleton_share = EN_TARGET_SKELETON_SHARE,
        .finest_frequency = EN_TARGET_FINEST_FREQUENCY,
        .samples_may_go = 1,
        .faces = set->target_faces,
        .vertices = set->target_vertices,
        .ratio = set->target_ratio,
        .max_error = set->target_error > 0 ? set->target_error : -1,
        .refresh = !(set->target_error > 0), /* an error bound measures against the input's planes */
        .seams = EN_SEAMS_NONE,
        .one_slab = 1,
    };
    uint64_t known_v = in ? in->nverts : EPSNET_COUNT_UNKNOWN, known_f = in ? in->nfaces : EPSNET_COUNT_UNKNOWN;
    if (known_f != EPSNET_COUNT_UNKNOWN && t->faces > known_f)
        return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "a target of %llu faces is more than the input's %llu", (unsigned long long)t->faces,
                            (unsigned long long)known_f);
    if (known_v != EPSNET_COUNT_UNKNOWN && t->vertices > known_v)
        return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "a target of %llu vertices is more than the input's %llu",
                            (unsigned long long)t->vertices, (unsigned long long)known_v);
    const en_budget *b = &run->budget;
    /* streamed: over the budget's one slab, over the slab size the user
     * asked for, or over a few of the slabs the settings give */
    uint64_t one_slab = b->one_slab / EN_ONE_SLAB_BYTES_PER_VERTEX;
    int over = known_v != EPSNET_COUNT_UNKNOWN && b->one_slab && known_v > one_slab;
    uint64_t large = set->slab_vertices ? set->slab_vertices : ONE_SLAB_SLABS * (uint64_t)b->slab_vertices;
    int streams = known_v != EPSNET_COUNT_UNKNOWN && (over || known_v > large);
    if (streams && known_f != EPSNET_COUNT_UNKNOWN && known_f > 0 && t->max_error < 0) {
        plan_streamed(run, set, known_v, known_f);
        /* note: the thinning's and the rounds' slabs hold the derived size
         * in all (pipeline/chunker.h: hold_all), so that a size's memory is
         * flat in the stream's width; its quality held (1.006 and 0.999
         * times the mean error at 20M, 10% and 1%). The default path's
         * slabs own it: held in all, its in-slab collapses gave way to
         * seams, 1.06 times the mean error at 20M (bench/RESULTS.md,
         * session 36). */
        *hold_all = b->slab_derived;
        return 0;
    }
    int bound_streams = known_v != EPSNET_COUNT_UNKNOWN &&
                        (over || (set->slab_vertices && known_v > set->slab_vertices));
    if (bound_streams && t->max_error >= 0 && !t->faces && !(t->ratio > 0) && !t->vertices && in->has_bbox) {
        /* An error bound alone is local: each collapse is held to it
         * wherever it runs, so the slabs and seams of one pass apply it,
         * on the whole mesh's diagonal from the header (of every vertex
         * the input lists, where one slab takes those on faces). Only over
         * the budget (or the --slab given): one slab's global order gave
         * a lower maximum error (`gen bumpy` 2M at 0.001: Hausdorff 1.83‰
         * in one slab, 3.34‰ on slabs of 65,536; mean 0.192‰ and 0.206‰,
         * 70,184 and 70,162 faces; bench/RESULTS.md). */
        double d2 = 0;
        for (int k = 0; k < 3; k++)
            d2 += (in->bbox_max[k] - in->bbox_min[k]) * (in->bbox_max[k] - in->bbox_min[k]);
        t->skeleton = EN_SKELETON_SPHERE;
        t->diagonal = sqrt(d2);
        t->seams = EN_SEAMS_ERROR;
        t->one_slab = 0;
        return 0;
    }
    if (over)
        return en_error_set(err, EPSNET_ELIMIT, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "this target needs the whole mesh in one slab: %llu vertices take about %llu MB, over "
                            "the %llu MB that a memory budget of %llu MB gives one slab (an error bound with a "
                            "count, or on an input without a bounding box, or an input whose face count is not "
                            "known ahead, is not streamed)",
                            (unsigned long long)known_v,
                            (unsigned long long)(known_v * EN_ONE_SLAB_BYTES_PER_VERTEX >> 20),
                            (unsigned long long)(b->one_slab >> 20), (unsigned long long)(b->total >> 20));
    *slab_vertices = UINT32_MAX - 1;
    return 0;
}

/* The target stage (its rounds, last round and output) took 47% of the
 * run on `gen bumpy` 20M at 10%, 28% at 1%, 55-60% at 2M and 4M at 10%
 * (session 10, `-j 2`): the feed gets the first 55% of the bar, and the
 * stage the rest, which it fills by its own estimate of the rounds to
 * come (pipeline/target_stage.h: tick). */
#define FEED_SHARE_BEFORE_FINISH 0.55

static double feed_share(const en_run *planned)
{
    return planned->staged ? FEED_SHARE_BEFORE_FINISH : 1.0;
}

double en_run_feed_share(const epsnet_settings *set, const epsnet_mesh_info *in, en_budget_input input)
{
    if (!en_run_has_target(set) || !in)
        return 1.0;
    /* a PLY's faces may be polygons, so its triangles are counted by the
     * sort; for the bar, a closed surface's two a vertex will do */
    epsnet_mesh_info known = *in;
    if (known.nfaces == EPSNET_COUNT_UNKNOWN && known.nverts != EPSNET_COUNT_UNKNOWN)
        known.nfaces = 2 * known.nverts;
    en_run scratch;
    memset(&scratch, 0, sizeof scratch);
    en_budget_split(&scratch.budget, set, input);
    uint32_t slab = scratch.budget.slab_vertices;
    int hold_all = 0;
    epsnet_error err;
    return plan_target(&scratch, set, NULL, &known, &slab, &hold_all, &err) == 0 ? feed_share(&scratch) : 1.0;
}

/* The target stage's share of the bar: the last 5% is for the output's
 * commit. */
static int stage_tick(void *opaque, uint64_t done, uint64_t total)
{
    const en_run *run = opaque;
    const epsnet_settings *set = &run->ctx->settings;
    double f = total ? (double)done / (double)total : 0;
    double bar = run->feed_share + (1 - run->feed_share) * 0.95 * f;
    return set->progress(set->progress_opaque, (uint64_t)(bar * EN_RUN_BAR_UNITS), EN_RUN_BAR_UNITS);
}

/* The split the run works within, as the statistics report it. */
static void fill_budget_stats(epsnet_stats *st, const en_budget *b)
{
    st->budget_total = b->total;
    st->budget_reader = b->reader;
    st->budget_sort = b->sort;
    st->budget_chain = b->chain;
    st->budget_one_slab = b->one_slab;
}

int en_run_pool_new(en_pool **pool, const epsnet_settings *set, const char *path, epsnet_error *err)
{
    int workers = en_run_workers(set);
    int usable = en_cpus_usable();
    if (set->warning && workers > usable) {
        /* the threads would share fewer cores: slower than -j at the cores,
         * and under mpirun (which binds each of two ranks or fewer to one
         * core) easy to miss (bench/RESULTS.md, session 33) */
        char msg[384];
        snprintf(msg, sizeof msg,
                 "-j %d starts %d worker threads, but this process may run on %d processor%s only (its CPU "
                 "affinity or its cgroup's CPU quota: taskset, a container, Slurm, or mpirun, which binds each "
                 "of two ranks or fewer to one core unless given --bind-to none); they will share %s",
                 set->threads, workers, usable, usable == 1 ? "" : "s", usable == 1 ? "it" : "them");
        set->warning(set->warning_opaque, msg);
    }
    int rc = en_pool_new(pool, workers);
    if (rc == EPSNET_ENOMEM)
        return en_error_set(err, rc, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    if (rc)
        return en_error_set(err, rc, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "cannot start %d worker threads",
                            workers);
    return 0;
}

int en_run_open(en_run *run, epsnet_context *ctx, en_slab_mode mode, const char *path,
                const epsnet_mesh_info *in, const en_window_backend *windows, const en_budget *budget, int checked,
                en_pool *pool, en_stage out, en_sample_fn on_sample, void *sample_opaque, epsnet_error *err)
{
    memset(run, 0, sizeof *run);
    if (ctx->settings.peers && !ctx->peers)
        return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "settings.peers: only epsnet_simplify_file() shares its run among processes");
    if (budget)
        run->budget = *budget;
    else
        en_budget_split(&run->budget, &ctx->settings, EN_BUDGET_PUSHED);
    run->ctx = ctx;
    run->path = path;
    run->cpu_start = en_thread_cpu_seconds();
    run->wall_start = en_now();
    memset(&ctx->stats, 0, sizeof ctx->stats);
    ctx->stats.gaussian_vertices = ctx->sphere.nverts;
    ctx->run_sphere = ctx->sphere;
    fill_budget_stats(&ctx->stats, &run->budget);
    const epsnet_settings *set = &ctx->settings;
    uint32_t slab_vertices = run->budget.slab_vertices;
    int hold_all = 0;
    int target = mode == EN_SLAB_SIMPLIFY && en_run_has_target(set);
    run->has_target = target;
    run->has_normals = in && epsnet_attr_layout_find(&in->vertex_attrs, "nx") >= 0;
    int rc = target ? plan_target(run, set, path, in, &slab_vertices, &hold_all, err) : 0;
    if (rc)
        return rc;
    run->feed_share = feed_share(run);
    uint32_t lock_offset = 0;
    int lock_type = 0;
    if (mode == EN_SLAB_SIMPLIFY && set->lock_property) {
        int i = in ? epsnet_attr_layout_find(&in->vertex_attrs, set->lock_property) : -1;
        if (i < 0)
            return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "no vertex property '%s' to lock by (the input has %u vertex properties "
                                "beyond x, y, z; 'epsnet info' lists them)",
                                set->lock_property, in ? in->vertex_attrs.count : 0);
        lock_offset = in->vertex_attrs.attr[i].offset;
        lock_type = (int)in->vertex_attrs.attr[i].type;
    }
    if (mode == EN_SLAB_SIMPLIFY && (rc = en_attr_weights_from_spec(&run->weights, set, in, path, err)) != 0)
        return rc;
    const en_attr_weights *weights = run->weights.channels ? &run->weights : NULL;
    if (pool) {
        run->pool = pool;
        run->borrowed_pool = 1;
    } else if ((rc = en_run_pool_new(&run->pool, set, path, err)) != 0) {
        return rc;
    }
    if (en_chain_spares_new(&run->spares))
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    int workers = en_pool_threads(run->pool);
    size_t ring = workers ? 2 * (size_t)workers : 1;
    /* rank 0 of a shared run: room for the slabs every other rank holds
     * (pipeline/peers.h), so that it cuts on while they work */
    if (ctx->peers)
        ring += (size_t)(en_peer_count(ctx->peers) - 1) * en_peer_slabs_held(workers);
    if (run->staged) {
        /* the target stage after the thinning pass (pipeline/target_stage.h) */
        en_target_stage_config tc = {
            .path = path,
            .sphere = &ctx->sphere,
            .max_normal_dev = set->max_normal_dev,
            .attr_size = in ? in->vertex_attrs.size : 0,
            .lock_offset = lock_offset,
            .lock_type = lock_type,
            .weights = weights,
            .slab_vertices = slab_vertices,
            .hold_all = hold_all,
            .mem_budget = run->budget.chain,
            .one_slab_bytes = run->budget.one_slab,
            .one_slab_vertices = (uint32_t)last_slab_vertices(slab_vertices),
            .ring_capacity = ring,
            .tmpdir = ctx->tmpdir,
            .size = run->size,
            .tick = set->progress ? stage_tick : NULL,
            .tick_opaque = run,
            .spares = &run->spares,
            .out = out,
        };
        if ((rc = en_target_stage_new(&run->stage, &tc, run->pool, err)) != 0)
            return rc;
        /* a long stream that can be read in stretches: the thinning's
         * ceiling from windows of it (api/windows.h) */
        if (windows && windows->vertices) {
            en_windows *w = NULL;
            en_window_source src;
            rc = en_windows_open(&w, windows, slab_vertices, en_target_price_margin_widths(run->size.share), &src,
                                 err);
            if (rc == 0 && w)
                rc = en_target_stage_price(run->stage, &src, &run->plan, &run->ceiling, err);
            run->price_vertices = run->ceiling > 0 ? src.vertices : 0;
            en_windows_close(&w);
            if (rc)
                return rc;
        }
        out = en_target_stage_input(run->stage);
    }
    en_chain_config cfg = {
        .mode = mode,
        .path = path,
        .sphere = &ctx->sphere,
        .seed = set->seed,
        .passes = run->passes ? run->passes : set->passes,
        .max_normal_dev = set->max_normal_dev,
        .plan = target ? &run->plan : NULL,
        .attr_size = mode == EN_SLAB_SIMPLIFY && in ? in->vertex_attrs.size : 0,
        .quadrics_out = run->staged, /* the target stage goes on from them */
        .out_on_workers = run->staged, /* the target stage's put keeps the stream */
        .lock_offset = lock_offset,
        .lock_type = lock_type,
        .weights = weights,
        .slab_vertices = slab_vertices,
        .hold_all = hold_all,
        .mem_budget = run->budget.chain,
        /* note: two slabs per worker keep every worker busy while the
         * caller stitches the oldest one. */
        .ring_capacity = ring,
        .checked_input = checked,
        .out = out,
        .on_sample = on_sample,
        .sample_opaque = sample_opaque,
        .spares = &run->spares,
        .peers = mode == EN_SLAB_SIMPLIFY ? ctx->peers : NULL,
    };
    rc = en_chain_new(&run->chain, &cfg, run->pool, err);
    if (rc == 0)
        run->input = en_chain_input(run->chain);
    if (rc == 0 && run->stage)
        en_target_stage_after(run->stage, run->chain);
    return rc;
}

/* The faces put so far, live for progress reports: the chain's own count
 * (its input stage is run->input), not a second pass over the records. */
static int counted(en_run *run, int rc)
{
    run->ctx->stats.faces = en_chain_faces_in(run->chain);
    return rc;
}

int en_run_put(en_run *run, const epsnet_record *rec, epsnet_error *err)
{
    return counted(run, en_stage_put(&run->input, rec, err));
}

int en_run_put_many(en_run *run, const epsnet_record *recs, size_t n, epsnet_error *err)
{
    return counted(run, en_chain_put_many(run->chain, recs, n, err));
}

int en_run_put_owned(en_run *run, epsnet_record **recs, size_t *cap, size_t n, epsnet_error *err)
{
    return counted(run, en_chain_put_owned(run->chain, recs, cap, n, err));
}

/* The one place where the chain's counts become the public statistics. */
static void fill_stats(epsnet_stats *st, const en_chain_stats *cs)
{
    st->vertices = cs->vertices_in;
    st->faces = cs->faces_in;
    st->zero_area_faces = cs->counts.zero_area_faces;
    st->feature_edges = cs->counts.feature_edges;
    st->candidates = cs->counts.candidates;
    st->samples = cs->counts.samples;
    st->locked = cs->counts.locked;
    st->boundary_vertices = cs->counts.boundary;
    st->nonmanifold_vertices = cs->counts.nonmanifold;
    st->seam_vertices = cs->counts.seam;
    st->cut_end_vertices = cs->counts.cut_ends;
    st->needle_vertices = cs->counts.needles;
    st->multi_cover_samples = cs->counts.multi_cover;
    st->isolated_vertices = cs->counts.isolated;
    st->passes = cs->passes;
    st->slabs = cs->slabs;
    st->collapses = cs->collapses;
    st->refused_link = cs->refused[0];
    st->refused_normal = cs->refused[1];
    st->refused_zero_area = cs->refused[2];
    st->refused_duplicate = cs->refused[3];
    st->seam_faces = cs->seam_faces;
    st->seam_collapses = cs->seam_collapses;
    st->band_nonsamples = cs->band_nonsamples;
    st->band_nonsamples_left = cs->band_left;
    st->inner_nonsamples = cs->inner_nonsamples;
    st->inner_nonsamples_left = cs->inner_left;
    st->max_active = cs->max_active;
    st->output_vertices = cs->output_vertices;
    st->output_faces = cs->output_faces;
    st->remaining_nonsamples = cs->remaining_nonsamples;
    st->skeleton_vertices = cs->skeleton_kept;
    st->samples_given_up = cs->samples_given_up;
    st->skeleton_finest_frequency = cs->skeleton_finest_frequency;
    st->membrane_faces = cs->membrane_faces;
    st->target_faces = cs->target_faces;
}

/* A count target the run ended above (or, priced, below): why, in one line. */
static void warn_missed_target(const en_run *run, const epsnet_stats *st, int stopped_by_error, int last_on_slabs)
{
    const epsnet_settings *set = &run->ctx->settings;
    int faces = st->target_faces > 0;
    uint64_t want = faces ? st->target_faces : set->target_vertices;
    uint64_t got = faces ? st->output_faces : st->output_vertices;
    char msg[1024], cut_ends[96] = "";
    if (set->warning && want && got < want && run->ceiling > 0) {
        /* docs/architecture.md §7, "known weak points" */
        snprintf(msg, sizeof msg,
                 "%s: target of %llu %s passed by %llu: the thinning pass held every slab to a cost ceiling priced "
                 "from %llu vertices of the stream, and the rest of the stream was easier to thin than they were",
                 run->path ? run->path : "input", (unsigned long long)want, faces ? "faces" : "vertices",
                 (unsigned long long)(want - got), (unsigned long long)run->price_vertices);
        set->warning(set->warning_opaque, msg);
        return;
    }
    if (!set->warning || !want || got <= want)
        return;
    if (st->cut_end_vertices)
        snprintf(cut_ends, sizeof cut_ends, ", %llu of them where seams end",
                 (unsigned long long)st->cut_end_vertices);
    if (stopped_by_error)
        snprintf(msg, sizeof msg,
                 "%s: the error bound (%g of the diagonal) stopped simplification at %llu %s, above the target "
                 "of %llu",
                 run->path ? run->path : "input", set->target_error, (unsigned long long)got,
                 faces ? "faces" : "vertices", (unsigned long long)want);
    else if (run->staged && last_on_slabs && got - want > want / 200)
        /* docs/architecture.md §7, "known weak points" */
        snprintf(msg, sizeof msg,
                 "%s: target of %llu %s missed by %llu: the finish ran on slabs (the thinned mesh was over "
                 "--mem as one slab) and its last seams could not make up what the thinning pass left beyond "
                 "its plan; a larger --mem lets the finish be one slab",
                 run->path ? run->path : "input", (unsigned long long)want, faces ? "faces" : "vertices",
                 (unsigned long long)(got - want));
    else
        snprintf(msg, sizeof msg,
                 "%s: target of %llu %s missed by %llu: %llu non-samples are left (refusals: link %llu, normal "
                 "%llu, zero-area %llu, duplicate %llu; a vertex may have several); boundary vertices (%llu%s)%s "
                 "are kept%s",
                 run->path ? run->path : "input", (unsigned long long)want, faces ? "faces" : "vertices",
                 (unsigned long long)(got - want), (unsigned long long)st->remaining_nonsamples,
                 (unsigned long long)st->refused_link, (unsigned long long)st->refused_normal,
                 (unsigned long long)st->refused_zero_area, (unsigned long long)st->refused_duplicate,
                 (unsigned long long)st->boundary_vertices, cut_ends,
                 set->lock_property ? " and the vertices --lock names" : "",
                 run->has_normals && st->boundary_vertices
                     ? " (a mesh split along its normals, as flat shading or hard edges split an OBJ, simplifies "
                       "as one surface with --drop-normals)"
                     : "");
    set->warning(set->warning_opaque, msg);
}

int en_run_end(en_run *run, epsnet_error *err)
{
    int rc = en_stage_end(&run->input, err);
    if (rc)
        return rc;
    epsnet_stats *st = &run->ctx->stats;
    en_chain_stats cs;
    en_chain_stats_get(run->chain, &cs);
    int rounds = 0, retries = 0, last_on_slabs = 0;
    if (run->stage)
        en_target_stage_stats(run->stage, &cs, &rounds, &retries, &last_on_slabs);
    fill_stats(st, &cs);
    st->target_rounds = (uint32_t)rounds;
    st->target_round_retries = (uint32_t)retries;
    st->target_price_ceiling = run->ceiling;
    st->target_price_vertices = run->price_vertices;
    st->attribute_channels = run->weights.channels;
    if (cs.skeleton_frequency && cs.skeleton_frequency != run->ctx->sphere.n) {
        /* the stats report the sphere the skeleton was taken at */
        gauss_sphere chosen;
        if (gauss_init(&chosen, cs.skeleton_frequency, &run->ctx->sphere.rot) == 0)
            run->ctx->run_sphere = chosen;
    }
    st->gaussian_vertices = run->ctx->run_sphere.nverts;
    if (run->has_target && !st->skeleton_finest_frequency)
        st->skeleton_finest_frequency = run->ctx->run_sphere.n; /* the density was given */
    if (run->has_target)
        warn_missed_target(run, st, cs.stopped_by_error, last_on_slabs);
    st->cpu_workers = en_pool_job_cpu_seconds(run->pool);
    st->cpu_main = en_thread_cpu_seconds() - run->cpu_start;
    if (en_pool_threads(run->pool) == 0)
        st->cpu_main -= st->cpu_workers; /* the jobs ran on this thread */
    if (st->cpu_main < 0)
        st->cpu_main = 0;
    return 0;
}

void en_run_close(en_run *run)
{
    en_chain_free(&run->chain);
    en_target_stage_free(&run->stage);
    en_chain_spares_free(&run->spares);
    if (!run->borrowed_pool)
        en_pool_free(&run->pool);
    run->pool = NULL;
}
