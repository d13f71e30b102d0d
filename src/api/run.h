/*
 * One run of the stage chain for the api (docs/architecture.md §7): the
 * context's settings turned into sizes, one pool of -j workers for the
 * whole run, the chain of ε-net passes on it, and the only place where
 * epsnet_stats is filled from what the chain counted.
 */
#ifndef EN_API_RUN_H
#define EN_API_RUN_H

#include "api/budget.h"
#include "api/windows.h"
#include "api/context.h"
#include "common/pool.h"
#include "pipeline/attr_weights.h"
#include "pipeline/chain.h"
#include "pipeline/target_stage.h"

/* Worker threads: 0 when one thread is asked for (jobs run inline). */
int en_run_workers(const epsnet_settings *set);

/* Does set ask for a size or an error target? */
int en_run_has_target(const epsnet_settings *set);

/*
 * One progress bar for a run (epsnet_settings.progress): EN_RUN_BAR_UNITS
 * in all. Feeding the input (reading or sorting it) fills the first
 * en_run_feed_share() of it; a streamed target's one-slab finish, which
 * comes after the last record and takes a third of the run or more
 * (bench/RESULTS.md, session 8), fills the rest as its collapses go. 1 when
 * nothing long follows the feed. in: what is known of the input.
 */
#define EN_RUN_BAR_UNITS 1000000u
double en_run_feed_share(const epsnet_settings *set, const epsnet_mesh_info *in, en_budget_input input);

typedef struct en_run {
    epsnet_context *ctx;
    en_pool *pool;
    en_chain *chain;
    en_stage input;               /* the chain's input stage */
    en_budget budget;             /* the split of --mem this run works within (api/budget.h) */
    en_pass_plan plan;            /* SIMPLIFY with a target: the chain's pass 1 */
    en_target_size size;          /* a streamed size: what the target stage plans from */
    int passes;                   /* the chain's passes (1 with a streamed target: the thinning) */
    int staged;                   /* a streamed target: the target stage follows the chain */
    en_target_stage *stage;
    double ceiling;               /* the thinning's, from a pricing pass (0: none), */
    uint64_t price_vertices;      /* ... and the windows' vertices */
    en_chain_spares spares;       /* slab works and collapse arrays, from chain to chain */
    int has_target;
    int has_normals;              /* the input's vertices carry normals (nx): its seams may be theirs */
    en_attr_weights weights;      /* settings.attribute_weights as read against the input */
    int borrowed_pool;
    const char *path;
    double cpu_start;             /* calling thread's CPU clock at open */
    double wall_start;
    double feed_share;            /* of the progress bar (en_run_feed_share) */
} en_run;

/*
 * Start a run in `mode` on ctx's settings: resets ctx->stats, starts the
 * workers. in: what is known of the input (counts, bbox; NULL: nothing).
 * pool: the workers to run on (the caller's, when the sort before the run
 * used them too; it must outlive the run, and the caller then sets
 * cpu_start to where its own CPU count began), or NULL for a pool of the
 * run's own.
 * budget: the split of --mem the caller made for what it reads (NULL: the
 * push API's, the chain alone; api/budget.h).
 * out: SIMPLIFY's output stage; on_sample: SAMPLE's sample sink.
 * checked: the records were checked before the run (a reader front end,
 * the sort), so the chain may cut slabs on the pool and report a bad
 * record later than its put (en_chain_config.checked_input); 0: each put
 * checks its record (the push API).
 * @return 0, or a negative code with err filled (then nothing is left
 * running and run_close() is still safe).
 */
int en_run_open(en_run *run, epsnet_context *ctx, en_slab_mode mode, const char *path,
                const epsnet_mesh_info *in, const en_window_backend *windows, const en_budget *budget, int checked,
                en_pool *pool, en_stage out, en_sample_fn on_sample, void *sample_opaque, epsnet_error *err);

/* The run's one pool of -j workers (en_run_workers), made before the run
 * when the sort must share it. @return 0 or a negative code with err. */
int en_run_pool_new(en_pool **pool, const epsnet_settings *set, const char *path, epsnet_error *err);

/* Push one input record (counts it for progress in ctx->stats.faces). */
int en_run_put(en_run *run, const epsnet_record *rec, epsnet_error *err);
/* n input records at once (en_chain_put_many). */
int en_run_put_many(en_run *run, const epsnet_record *recs, size_t n, epsnet_error *err);
/* n input records in an array the run may keep (en_chain_put_owned). */
int en_run_put_owned(en_run *run, epsnet_record **recs, size_t *cap, size_t n, epsnet_error *err);

/* End of input: finish the chain and fill ctx->stats (all but the stage
 * times and peak_rss, which the caller knows). A target that was not met
 * is said in one warning line (docs/method.md §13: no silent miss). */
int en_run_end(en_run *run, epsnet_error *err);

/* Free the chain, stop the workers. Accepts a run that failed to open. */
void en_run_close(en_run *run);

#endif
