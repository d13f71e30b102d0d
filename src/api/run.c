#include "api/run.h"

#include <string.h>
#include <unistd.h>

#include "common/error.h"
#include "common/util.h"

uint32_t en_run_slab_vertices(const epsnet_settings *set)
{
    if (set->slab_vertices)
        return set->slab_vertices;
    if (set->mem) {
        uint64_t n = set->mem / 4800;
        return n < 1024 ? 1024 : n > (1u << 24) ? (1u << 24) : (uint32_t)n;
    }
    return 65536;
}

uint64_t en_run_mem_budget(const epsnet_settings *set)
{
    if (set->mem)
        return set->mem;
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0)
        return 0;
    return (uint64_t)pages * (uint64_t)page / 2;
}

int en_run_workers(const epsnet_settings *set)
{
    long n = set->threads > 0 ? set->threads : sysconf(_SC_NPROCESSORS_ONLN);
    if (n > 256)
        n = 256;
    /* One thread means the caller's own: slabs run inline, no pool threads. */
    return n <= 1 ? 0 : (int)n;
}

int en_run_open(en_run *run, epsnet_context *ctx, en_slab_mode mode, const char *path, en_stage out,
                en_sample_fn on_sample, void *sample_opaque, epsnet_error *err)
{
    memset(run, 0, sizeof *run);
    run->ctx = ctx;
    run->cpu_start = en_thread_cpu_seconds();
    run->wall_start = en_now();
    memset(&ctx->stats, 0, sizeof ctx->stats);
    ctx->stats.gaussian_vertices = ctx->sphere.nverts;
    const epsnet_settings *set = &ctx->settings;
    int workers = en_run_workers(set);
    int rc = en_pool_new(&run->pool, workers);
    if (rc == EPSNET_ENOMEM)
        return en_error_set(err, rc, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    if (rc)
        return en_error_set(err, rc, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "cannot start %d worker threads",
                            workers);
    en_chain_config cfg = {
        .mode = mode,
        .path = path,
        .sphere = &ctx->sphere,
        .seed = set->seed,
        .passes = set->passes,
        .max_normal_dev = set->max_normal_dev,
        .slab_vertices = en_run_slab_vertices(set),
        .mem_budget = en_run_mem_budget(set),
        /* note: two slabs per worker keep every worker busy while the
         * caller stitches the oldest one. */
        .ring_capacity = workers ? 2 * (size_t)workers : 1,
        .out = out,
        .on_sample = on_sample,
        .sample_opaque = sample_opaque,
    };
    rc = en_chain_new(&run->chain, &cfg, run->pool, err);
    if (rc == 0)
        run->input = en_chain_input(run->chain);
    return rc;
}

int en_run_put(en_run *run, const epsnet_record *rec, epsnet_error *err)
{
    run->ctx->stats.faces += rec->kind == EPSNET_REC_TRIANGLE; /* live, for progress reports */
    return en_stage_put(&run->input, rec, err);
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
}

int en_run_end(en_run *run, epsnet_error *err)
{
    int rc = en_stage_end(&run->input, err);
    if (rc)
        return rc;
    epsnet_stats *st = &run->ctx->stats;
    en_chain_stats cs;
    en_chain_stats_get(run->chain, &cs);
    fill_stats(st, &cs);
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
    en_pool_free(&run->pool);
}
