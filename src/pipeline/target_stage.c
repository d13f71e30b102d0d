#include "pipeline/target_stage.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "common/alloc.h"
#include "common/error.h"
#include "common/fault.h"
#include "io/sink.h"

/*
 * note: the numbers of the rounds (docs/architecture.md §7).
 * - ROUND_AIM: a round's ceiling is set where the histogram holds this
 *   share of the collapses still needed, when much is still to go. The
 *   quadrics ride along from pass to pass (en_chain_config.quadrics_in),
 *   so the histogram prices the next round's collapses as they will be
 *   priced; but a collapse changes its neighbours' costs, and measured on
 *   `gen bumpy` 2M at 10% a round did 72-87% of what it aimed at (and,
 *   with coarser buckets, once 124% when little was left: a bucket holds
 *   many vertices of about one cost).
 *   So the aim falls to ROUND_AIM_NEAR when the gap is small, and rounds
 *   stop at ROUND_CLOSE: the last round's own order decides the rest. A
 *   round costs what passing the whole kept mesh through slabs and seams
 *   costs, however little it takes: on `gen bumpy` 20M at 10% the round
 *   from 6.6% over the target to 4% took 1.9 s of 19.6, and leaving those
 *   6.6% to the last round moved the mean error by 0.5% and the
 *   Hausdorff distance not at all (bench/RESULTS.md, session 19).
 * - ROUND_STALL: a round that takes less than this share of the gap says
 *   the rest is held by refusals or by the skeleton: the last round sees to it.
 */
#define ROUND_AIM 0.9
#define ROUND_AIM_NEAR 0.6
#define ROUND_NEAR 0.2
#define ROUND_CLOSE 0.1
#define ROUND_STALL 0.05
#define ROUND_MAX 12
/* - ROUND_RETRIES: a round that passed the target is run again from the
 *   same stream at ROUND_RETRY_AIM of its aim, and after this many tries
 *   with a floor instead (pass_plan.h: floor_share) that cannot pass it. A
 *   histogram that misses what W left unpriced was the cause found
 *   (ceiling_for); a floor on every round made `gen bumpy` 20M at 10% take
 *   9 rounds instead of 4, its slabs stopped at their share near the end
 *   where the global order would take some of them further. */
#define ROUND_RETRIES 2
#define ROUND_RETRY_AIM 0.25
static en_fault round_aim_fault = EN_FAULT_INIT("EPSNET_FAIL_ROUND_AIM");
static en_fault price_high_fault = EN_FAULT_INIT("EPSNET_FAIL_PRICE_HIGH");
static en_fault round_lean_fault = EN_FAULT_INIT("EPSNET_FAIL_ROUND_LEAN");
static en_fault price_skip_fault = EN_FAULT_INIT("EPSNET_FAIL_PRICE_SKIP");
/* For the progress bar's estimate of the rounds to come: the share of a
 * round's gap to the goal that is left after it (measured on `gen bumpy`
 * 20M at 10%: 3.51M kept vertices, then 1.66M, 1.30M, 1.12M, 1.06M for a
 * goal of 1.05M, so 0.25 to 0.6 of the gap), and the share of a one-slab
 * last round's time spent taking its records before the collapses start. */
#define ROUND_LEFT_EST 0.4
#define LAST_FEED_SHARE 0.2
/* Records between two reports while a round takes its input. */
#define TICK_RECORDS 65536

/* A record of the kept stream, as the chain's stitcher wrote it: its kind
 * in a byte, then what that kind has. A vertex: its coordinates, its
 * attribute bytes (attr_size) and the carried block, its accumulated
 * quadric (and attribute part) and marks (kept_attr in all); a triangle:
 * its corners; a finalize: its vertex. note: whole epsnet_records (56
 * bytes each, a finalize for every vertex) were 1.8 times these bytes,
 * written and read again by every round (bench/RESULTS.md, session 19). */
#define KEPT_MAX_RECORD (1 + 3 * 8)

/* A kept stream: the temporary file and what it holds. Records pass
 * through buf a block at a time: one zstd call per record cost more than
 * the round's collapses (0.35 s of feeding for 335K faces). note: the file
 * is plain, not zstd's: its fastest level made `gen bumpy` 20M at 10%
 * 1.06 times slower (writing on the workers, reading again on the calling
 * thread) for a third fewer temporary bytes, 152 MB against 225 MB
 * (bench/RESULTS.md, session 19). */
#define KEPT_BLOCK ((size_t)1 << 18)
typedef struct kept {
    en_spill *sp;
    int lean;                     /* the carried quadric left out (kept_lean_bytes) */
    uint64_t vertices, faces;
    uint8_t *buf;
    size_t len, pos;              /* writing: bytes in buf; reading: [pos, len) not yet parsed */
} kept;

struct en_target_stage {
    en_target_stage_config cfg;
    en_pool *pool;
    const en_chain *thin;
    kept in;                      /* what the stage's input (the thinning, or a round) wrote */
    uint64_t *hist;               /* EN_COST_BUCKETS: the costs the last pass left */
    uint64_t *hist_before;        /* ... and before a round (its retries start from it) */
    uint32_t retries;             /* rounds run again (ROUND_RETRIES) */
    double priced;                /* the share of its non-samples hist holds (ceiling_for) */
    uint32_t kept_attr;           /* a kept vertex's bytes: its attributes, then its quadric */
    uint8_t *lean_attr;           /* replay's scratch: a lean stream's vertex bytes made whole */
    en_chain_stats rounds;        /* the rounds' counts, summed */
    en_chain_stats last;          /* the last round's */
    /* Progress (cfg.tick), in records taken by the rounds: those of the
     * rounds done, the current round's input and how many it has taken,
     * whether it is the last, and, when that is one slab, the share of
     * its collapses done. */
    double records_done, round_records, round_taken, last_collapsed;
    int in_last_round, last_one_slab;
    double reported;              /* the last fraction reported: it never falls */
    int nrounds;
    int failed;
    epsnet_error failure;
};

static int kept_open(en_target_stage *ts, kept *k, epsnet_error *err)
{
    memset(k, 0, sizeof *k);
    if (!(k->buf = en_malloc(KEPT_BLOCK)))
        return en_error_set(err, EPSNET_ENOMEM, ts->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    return en_spill_open_plain(&k->sp, ts->cfg.tmpdir, ts->cfg.path ? ts->cfg.path : "target stage", err);
}

static void kept_close(kept *k)
{
    en_spill_close(&k->sp);
    en_free(k->buf);
    memset(k, 0, sizeof *k);
}

static int kept_write(kept *k, const void *p, size_t n, epsnet_error *err)
{
    if (k->len + n > KEPT_BLOCK) {
        int rc = en_spill_write(k->sp, k->buf, k->len, err);
        if (rc)
            return rc;
        k->len = 0;
    }
    memcpy(k->buf + k->len, p, n);
    k->len += n;
    return 0;
}

/* The next n bytes of the kept stream (n <= KEPT_BLOCK / 2), or NULL at
 * its end (*got: how many it had, for a torn record) or on an error (rc). */
static const uint8_t *kept_read(kept *k, size_t n, size_t *got, int *rc, epsnet_error *err)
{
    if (k->len - k->pos < n) {
        memmove(k->buf, k->buf + k->pos, k->len - k->pos);
        k->len -= k->pos;
        k->pos = 0;
        int64_t r = en_spill_read(k->sp, k->buf + k->len, KEPT_BLOCK - k->len, err);
        if (r < 0) {
            *rc = (int)r;
            return NULL;
        }
        k->len += (size_t)r;
        if (k->len < n) {
            *got = k->len;
            return NULL;
        }
    }
    const uint8_t *p = k->buf + k->pos;
    k->pos += n;
    return p;
}

/* What a lean kept stream leaves out of each vertex: the carried block's
 * quadric and attribute part, before its marks (slab_work.h). The last
 * round starts afresh from its faces (run_chain: quadrics_in) and reads
 * only the marks, so a round whose output goes to the last round writes
 * that part for nothing: 80 of a vertex's 113 bytes without attributes,
 * written into the page cache in the take and read back (at 100M faces
 * the kernel's copy was 8% of the rounds' CPU; bench/RESULTS.md, session
 * 30). */
static uint32_t kept_lean_bytes(const en_target_stage *ts)
{
    return en_carried_marks_at(ts->cfg.weights ? ts->cfg.weights->channels : 0);
}

/* A stage that appends records to a kept stream. */
typedef struct kept_sink {
    en_target_stage *ts;
    kept *k;
} kept_sink;

static int kept_put(void *self, const epsnet_record *rec, epsnet_error *err)
{
    kept_sink *to = self;
    uint8_t r[KEPT_MAX_RECORD];
    size_t n = 1 + (rec->kind == EPSNET_REC_FINALIZE ? 8 : 24);
    r[0] = (uint8_t)rec->kind;
    memcpy(r + 1, rec->kind == EPSNET_REC_VERTEX ? (const void *)rec->xyz : (const void *)rec->v, n - 1);
    int rc = kept_write(to->k, r, n, err);
    if (rc == 0 && rec->kind == EPSNET_REC_VERTEX) {
        /* the attributes, then the carried block (lean: without its quadric) */
        uint32_t a = to->ts->cfg.attr_size, skip = to->k->lean ? kept_lean_bytes(to->ts) : 0;
        rc = kept_write(to->k, rec->attr, a, err);
        if (rc == 0)
            rc = kept_write(to->k, rec->attr + a + skip, to->ts->kept_attr - a - skip, err);
    }
    to->k->vertices += rec->kind == EPSNET_REC_VERTEX;
    to->k->faces += rec->kind == EPSNET_REC_TRIANGLE;
    return rc;
}

static int kept_end(void *self, epsnet_error *err)
{
    (void)self;
    (void)err;
    return 0;
}

/* Is a kept stream of v vertices small enough for one slab? */
static int fits_one_slab_n(const en_target_stage *ts, double v)
{
    return v <= (double)ts->cfg.one_slab_vertices &&
           v * (double)EN_ONE_SLAB_BYTES_PER_VERTEX <= (double)ts->cfg.one_slab_bytes;
}

/* The records the rounds after the current one will take, which has v
 * vertices: the rounds' loop in stage_end, with each round leaving
 * ROUND_LEFT_EST of its gap to the goal, then the last round. 0 during the
 * last. */
static double records_ahead(const en_target_stage *ts, double v)
{
    if (ts->in_last_round)
        return 0;
    const en_target_size *size = &ts->cfg.size;
    double goal = size->by_vertices ? (double)size->goal : (double)size->goal / 2; /* two faces a vertex */
    double sum = 0;
    for (int r = ts->nrounds + 1;; r++) {
        v = v > goal ? goal + (v - goal) * ROUND_LEFT_EST : goal; /* what the round before r leaves */
        if (r >= ROUND_MAX || v <= goal * (1 + ROUND_CLOSE) || fits_one_slab_n(ts, v))
            return sum + 3 * v; /* the last round */
        sum += 3 * v; /* a vertex and two faces */
    }
}

/* Report the stage's progress to cfg.tick. */
static int report(en_target_stage *ts, epsnet_error *err)
{
    if (!ts->cfg.tick)
        return 0;
    double now = ts->round_taken;
    if (ts->in_last_round && ts->last_one_slab)
        now = ts->round_taken * LAST_FEED_SHARE + ts->round_records * (1 - LAST_FEED_SHARE) * ts->last_collapsed;
    double total = ts->records_done + ts->round_records + records_ahead(ts, ts->round_records / 3);
    double f = total > 0 ? (ts->records_done + now) / total : 0;
    if (f > ts->reported)
        ts->reported = f < 1 ? f : 1;
    if (ts->cfg.tick(ts->cfg.tick_opaque, (uint64_t)(ts->reported * 1e6), 1000000u))
        return en_error_set(err, EPSNET_EINTR, ts->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE, "cancelled");
    return 0;
}

/* A one-slab last round's collapses, as its chain reports them. */
static int last_tick(void *opaque, uint64_t done, uint64_t total)
{
    en_target_stage *ts = opaque;
    epsnet_error err;
    ts->last_collapsed = total ? (double)done / (double)total : 1;
    return report(ts, &err);
}

/* Push the kept stream k into `into`, then end it. */
static int replay(en_target_stage *ts, kept *k, en_stage into, epsnet_error *err)
{
    int rc = k->len ? en_spill_write(k->sp, k->buf, k->len, err) : 0;
    k->len = k->pos = 0;
    if (rc == 0)
        rc = en_spill_rewind(k->sp, err);
    while (rc == 0) {
        size_t got = 0;
        const uint8_t *p = kept_read(k, 1, &got, &rc, err);
        if (!p) {
            if (rc == 0 && got == 0)
                return en_stage_end(&into, err); /* the end, between records */
            break;
        }
        epsnet_record rec = { .kind = (epsnet_record_kind)*p };
        size_t n = rec.kind == EPSNET_REC_FINALIZE ? 8 : 24;
        if (rec.kind != EPSNET_REC_VERTEX && rec.kind != EPSNET_REC_TRIANGLE && rec.kind != EPSNET_REC_FINALIZE)
            return en_error_set(err, EPSNET_EIO, ts->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "the target stage's temporary file holds a record of unknown kind %d", *p);
        if (!(p = kept_read(k, n, &got, &rc, err)))
            break;
        memcpy(rec.kind == EPSNET_REC_VERTEX ? (void *)rec.xyz : (void *)rec.v, p, n);
        if (rec.kind == EPSNET_REC_VERTEX) {
            uint32_t a = ts->cfg.attr_size, skip = k->lean ? kept_lean_bytes(ts) : 0;
            if (!(p = kept_read(k, ts->kept_attr - skip, &got, &rc, err)))
                break;
            rec.attr = p; /* valid until the next kept_read, after the put has copied it */
            if (skip) {
                /* made whole, the quadric's bytes zero (no chain reads them) */
                memcpy(ts->lean_attr, p, a);
                memcpy(ts->lean_attr + a + skip, p + a, ts->kept_attr - a - skip);
                rec.attr = ts->lean_attr;
            }
        }
        rc = en_stage_put(&into, &rec, err);
        if (rc == 0 && (uint64_t)++ts->round_taken % TICK_RECORDS == 0)
            rc = report(ts, err);
    }
    return rc ? rc
              : en_error_set(err, EPSNET_EIO, ts->cfg.path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                             "the target stage's temporary file ended in the middle of a record");
}

/* The ceiling that takes `want` of the collapses still to do, from a
 * histogram that holds `priced` of them (all of them when it holds fewer
 * than want).
 * note: W prices a vertex only while it has a neighbour that may receive;
 * one whose neighbours settled first leaves unpriced, though a round can
 * take it. Where slabs are thinner than the stream is wide, nearly all is
 * W's, and the histogram held 65% of the non-samples (a 2M-face PLY
 * sorted on the way in, `--slab 4096`): the want is taken as that share
 * of the histogram, as if the missing ones cost what the others do. */
static double ceiling_for(const uint64_t *hist, double want, double priced)
{
    want *= priced;
    double sum = 0;
    int top = 0;
    for (int b = 0; b < EN_COST_BUCKETS; b++) {
        if (!hist[b])
            continue;
        top = b;
        sum += (double)hist[b];
        if (sum >= want)
            return en_cost_bucket_top(b);
    }
    return en_cost_bucket_top(top);
}

/* The share of a pass's non-samples left that its histogram holds (1
 * when it holds them all, or more: freed samples are priced too). */
static double priced_share(const uint64_t *hist, uint64_t nonsamples)
{
    double held = 0;
    for (int b = 0; b < EN_COST_BUCKETS; b++)
        held += (double)hist[b];
    return nonsamples && held < (double)nonsamples ? held / (double)nonsamples : 1;
}

static void add_counts(en_chain_stats *to, const en_chain_stats *from)
{
    to->slabs += from->slabs;
    to->collapses += from->collapses;
    to->seam_faces += from->seam_faces;
    to->seam_collapses += from->seam_collapses;
    to->membrane_faces += from->membrane_faces;
    if (from->max_active > to->max_active)
        to->max_active = from->max_active;
}

/* A round's slabs: a sixteenth of what is kept, so that a round much
 * smaller than the thinning's input still keeps every worker busy, but no
 * smaller than ROUND_SLAB_MIN (seams grow as slabs shrink) and no larger
 * than the thinning's or ROUND_SLAB_MAX.
 * note: ROUND_SLAB_MAX: a kept vertex carries its quadric and marks, and
 * the rounds' slabs of 65,536 in flight took `gen bumpy` 20M at 10% from
 * the thinning's 269 MB to 399 MB; of 20,000 (a 64th of what was kept),
 * 313 MB, with the same Hausdorff and mean error (1.158e-4 and 7.178e-6
 * against 1.142e-4 and 7.176e-6; bench/RESULTS.md, session 18). Since the
 * thinning's slab works go before the rounds (stage_end), 32,768 peaks as
 * 16,384 did (272 MB), 0.94 times the wall at 10% (fewer seams), the same
 * Hausdorff distance; 65,536 still peaks at 335 MB (session 20). */
#define ROUND_SLABS 16
#define ROUND_SLAB_MIN 8192
#define ROUND_SLAB_MAX 32768
static uint32_t round_slab(const en_target_stage *ts, const kept *from)
{
    uint64_t n = from->vertices / (uint64_t)ROUND_SLABS;
    n = n < ROUND_SLAB_MIN ? ROUND_SLAB_MIN : n > ROUND_SLAB_MAX ? ROUND_SLAB_MAX : n;
    return n < ts->cfg.slab_vertices ? (uint32_t)n : ts->cfg.slab_vertices;
}

/* A chain of the stage under plan p: the run's settings; its input was
 * checked (a stitcher or a pricing window wrote it). */
static en_chain_config stage_chain(const en_target_stage *ts, const en_pass_plan *p)
{
    const en_target_stage_config *cfg = &ts->cfg;
    return (en_chain_config){
        .mode = EN_SLAB_SIMPLIFY,
        .path = cfg->path,
        .sphere = cfg->sphere,
        .passes = 1,
        .max_normal_dev = cfg->max_normal_dev,
        .plan = p,
        .attr_size = cfg->attr_size,
        .lock_offset = cfg->lock_offset,
        .lock_type = cfg->lock_type,
        .weights = cfg->weights,
        .slab_vertices = cfg->slab_vertices,
        .hold_all = cfg->hold_all,
        .mem_budget = cfg->mem_budget,
        .ring_capacity = cfg->ring_capacity,
        .checked_input = 1,
        .spares = cfg->spares,
    };
}

/* One chain over the kept stream `from`: a round into `to`, or the last one
 * into cfg.out (to NULL). */
static int run_chain(en_target_stage *ts, const en_pass_plan *t, kept *from, kept *to, int last, en_chain_stats *got,
                     epsnet_error *err)
{
    const en_target_stage_config *cfg = &ts->cfg;
    kept_sink sink = { ts, to };
    en_chain_config cc = stage_chain(ts, t);
    cc.quadrics_in = !last; /* the last round starts afresh, as its refresh would (slab_work.c) */
    cc.quadrics_out = !last;
    cc.slab_vertices = t->one_slab ? UINT32_MAX - 1 : round_slab(ts, from);
    /* a round's slabs own round_slab(), or hold it in all as the
     * thinning's hold theirs */
    cc.hold_all = cfg->hold_all && !t->one_slab;
    cc.tick = last && cfg->tick ? last_tick : NULL;
    cc.tick_opaque = ts;
    cc.out = last ? cfg->out : (en_stage){ kept_put, kept_end, &sink };
    cc.out_on_workers = !last; /* the kept stream is the stage's own */
    en_chain *c = NULL;
    ts->round_records = (double)(from->vertices + from->faces);
    ts->round_taken = 0;
    ts->in_last_round = last;
    ts->last_one_slab = last && t->one_slab; /* and stays, for the stats */
    int rc = report(ts, err);
    if (rc == 0)
        rc = en_chain_new(&c, &cc, ts->pool, err);
    if (rc == 0)
        rc = replay(ts, from, en_chain_input(c), err);
    ts->records_done += ts->round_records;
    ts->round_records = ts->round_taken = 0;
    if (rc == 0) {
        en_chain_stats_get(c, got);
        if (!last) {
            memset(ts->hist, 0, EN_COST_BUCKETS * sizeof *ts->hist);
            en_chain_cost_hist(c, 0xff, ts->hist);
            ts->priced = priced_share(ts->hist, got->remaining_nonsamples);
        }
    }
    en_chain_free(&c);
    return rc;
}

/*
 * The thinning (docs/architecture.md §7): each slab keeps half as much
 * again as the target (and a point more) of what it can reach, so that the
 * collapses that decide the result are ranked by the rounds, in one global
 * order.
 *
 * note: the thinning's slabs were twice the default while a one-slab
 * finish took its whole seams (fewer slabs, smaller seams); with the
 * rounds after it they are the default's, whose cost a collapse is lower
 * (a slab past the caches cost 37% more at 262,144 vertices) and whose
 * memory is the default path's (bench/RESULTS.md).
 */
void en_target_stage_plan_thin(const en_target_size *size, uint64_t nv, uint64_t nf, uint64_t one_slab_bytes,
                               uint64_t one_slab_vertices, en_pass_plan *thin)
{
    double keep = EN_TARGET_THIN_KEEP * size->share + 0.01;
    double wide = EN_TARGET_THIN_KEEP_ONE_SLAB * size->share + 0.01, wide_v = wide * (double)nv;
    if (wide_v <= (double)one_slab_vertices && wide_v * EN_ONE_SLAB_BYTES_PER_VERTEX <= (double)one_slab_bytes)
        keep = wide;
    keep = keep < 1 ? keep : 1;
    *thin = (en_pass_plan){
        .skeleton = size->choose_density ? EN_SKELETON_CHOSEN : EN_SKELETON_SPHERE,
        .skeleton_share = EN_TARGET_SKELETON_SHARE,
        .finest_frequency = EN_TARGET_FINEST_FREQUENCY,
        /* the final target's vertices on faces, as a slab counts them */
        .skeleton_budget = (uint64_t)(EN_TARGET_SKELETON_SHARE * size->share * (double)nv),
        .keep_share = keep,
        .goal = (uint64_t)llround(keep * (double)nf),
        .expected_in = nf,
        .goal_share = size->share, /* the skeleton is the final target's */
        .max_error = -1,
        /* note: the seams go only to their slabs' level, and the rounds
         * order the rest with everything else (thinned by their own pacing
         * to the share, they took the mean error up by a quarter on the
         * shared scans; whole, they held a third of the thinning's output
         * at 20M faces: bench/RESULTS.md), unless what they keep would not
         * fit the budget: a finish in one slab after whole seams held 1.11
         * times keep at 2M faces, 1.27 at 20M, 4.2 on 6,000 faces in slabs
         * of 300; then they are paced */
        .seams = 2 * keep * (double)nv * EN_ONE_SLAB_BYTES_PER_VERTEX <= (double)one_slab_bytes ? EN_SEAMS_LEVEL
                                                                                                 : EN_SEAMS_PACED,
        .priced = 1,
    };
}

/*
 * note: the pricing pass (docs/architecture.md §7). The thinning's slabs
 * each kept EN_TARGET_THIN_KEEP times the target's share, and the rounds
 * after it took the rest of the way in a global order: at 20M faces four
 * rounds, as long as the thinning itself (bench/RESULTS.md, session 17).
 * A ceiling for the thinning from the slabs retired so far failed: the
 * sorted stream is not stationary (its first slabs collapsed at costs two
 * to three orders below the rest). Windows spread along the whole stream
 * see all of it: each is thinned as the thinning would thin it, on its
 * slabs, at its density, past the target (PRICE_DEEP of its share),
 * counting what its collapses took at each level; a run under a ceiling
 * is the prefix of that order below it, so the ceiling under which the
 * windows' insides would have kept PRICE_AIM times the target's share is
 * one the thinning can hold every slab and seam to.
 * - PRICE_AIM: the thinning is not taken to the target itself. On `gen
 *   bumpy` 20M at 10%, a ceiling aimed at 1.06 times the target ended the
 *   thinning 3% above it and a last round took the rest: 1.26 times the
 *   mean error of the rounds' way (0.73 times its Hausdorff); aimed at
 *   1.25, then rounds: 1.015 times (0.64), in 0.84 times the time of
 *   the thinning without a ceiling and its rounds. The
 *   collapses near the thinning's seams, where W may only merge band
 *   vertices with each other, are what the rounds, on other cuts, do
 *   better (bench/RESULTS.md, session 18). Measured again in session 27
 *   against the same runs unpriced: aimed at 1.25, 1.09 times the mean
 *   error and 1.38 times the Hausdorff distance on the sorted .smz, 1.075
 *   and 1.27 on the shuffled PLY; aimed at 1.5, 1.00 and 1.03, 1.034 and
 *   1.06, for 1.005 times the CPU; a 20M torus still 1.18 and 1.63. Most
 *   of that was the floor below (session 28): with it counted in
 *   vertices, aimed at 1.25, the mean error is 1.001, 1.032 and 1.015
 *   times the unpriced rounds' (bumpy .smz, shuffled PLY, torus), each
 *   after one round (aimed at 1.5: 1.002, 1.015 and 1.010 after two,
 *   8.6% more time on the bumpy .smz; at 1.35, 1.028 on the bumpy mesh,
 *   after two: a round's landing moves these by a few percent).
 * - PRICE_AIM_COARSEST: at the coarsest density the share is small and
 *   the windows, a few slabs of a stream whose surface is not stationary,
 *   see too little of it. Aimed at 1.25 on `gen bumpy` 100M at 1%, the
 *   ceiling took the thinning to the target itself, no round, for 1.41
 *   times the mean error of the unpriced thinning and its rounds and 1.52
 *   times the Hausdorff distance (session 34). Aimed at 4 and 8, four and
 *   five rounds followed: 1.024 and 1.014 times the mean error, 0.98 and
 *   1.05 times the Hausdorff distance, in 0.74 and 0.76 times the time;
 *   on a 120K-vertex tube at 1% (slabs of 256), 1.28 and 1.02 times the
 *   mean error, 1.22 and 0.89 times the Hausdorff distance (at 16: 1.00
 *   and 1.02). Both went unpriced before (bench/RESULTS.md, session 36).
 * - PRICE_FLOOR and the pace: each slab keeps at least PRICE_FLOOR of the
 *   target's share of the inner vertices its collapses can reach
 *   (share_of_vertices), and W at least its pace to the target
 *   (floor_share), so that windows that missed a harder part of the stream
 *   do not take the thinning past the target: on a 120K-vertex tube whose
 *   four windows held 512 counted vertices, the ceiling took it 14-42%
 *   past without the pace, and exactly to the target with it. No
 *   guarantee: W holds only what the seams hold (api/run.c warns when a
 *   thinning ends below). Until session 28 the floor was half the share,
 *   counted in the faces on inner vertices, which leave out the faces a
 *   collapse removes beside a frozen vertex: on the 20M torus, whose slabs
 *   are 6.4 stream widths long, the slabs stopped at it at a twentieth of
 *   the ceiling while their seams went on to it, and the thinning kept a
 *   quarter of the slabs' middles but 8% of the bands around the cuts,
 *   fewer than the target keeps, which no round gives back. It is now
 *   counted in vertices (in the windows' deep slabs too, so that they go
 *   as deep as their seams), at the whole share: at half of it the bumpy
 *   mesh's flattest slabs went to half the target's density (1.013 times
 *   the unpriced mean error at aim 1.5, against 1.002 at the whole).
 */
#define PRICE_DEEP 0.5
#define PRICE_AIM 1.25
#define PRICE_AIM_COARSEST 8.0
#define PRICE_FLOOR 1.0

double en_target_price_margin_widths(double share)
{
    double w = 10 * sqrt(0.1 / (share > 1e-6 ? share : 1e-6));
    return w > 3 ? w : 3;
}

/* One chain of the pricing pass over the windows of src, under plan p:
 * its counts, and what it took (en_chain_taken_hist) in hist_before. */
static int price_chain(en_target_stage *ts, const en_window_source *src, int inside, const en_pass_plan *p,
                       en_chain_stats *st, epsnet_error *err)
{
    en_chain_config cc = stage_chain(ts, p);
    cc.out = EN_STAGE_DISCARD;
    en_chain *c = NULL;
    int rc = en_chain_new(&c, &cc, ts->pool, err);
    en_stage in = rc == 0 ? en_chain_input(c) : (en_stage){ 0 };
    uint64_t base = 0;
    for (uint32_t w = 0; rc == 0 && w < src->windows; w++)
        rc = src->push(src->opaque, w, inside, base, &in, &base, err);
    if (rc == 0)
        rc = en_stage_end(&in, err);
    if (rc == 0) {
        en_chain_stats_get(c, st);
        memset(ts->hist_before, 0, EN_COST_BUCKETS * sizeof *ts->hist_before);
        en_chain_taken_hist(c, ts->hist_before);
    }
    en_chain_free(&c);
    return rc;
}

int en_target_stage_price(en_target_stage *ts, const en_window_source *src, en_pass_plan *thin, double *ceiling,
                          epsnet_error *err)
{
    *ceiling = 0;
    const en_target_size *size = &ts->cfg.size;
    if (!src->windows || !src->inside_vertices || en_fault_hit(&price_skip_fault))
        return 0;
    en_pass_plan p = *thin;
    p.priced = 0;
    p.seams = EN_SEAMS_CEILING; /* 0: no ceiling; W goes as deep as it can */
    p.share_of_vertices = 1; /* (pass_plan.h) the windows' slabs go as deep as their seams */
    p.count_ranges = src->inside;
    p.count_nranges = src->windows;
    en_chain_stats st;
    int rc = 0;
    double aim = PRICE_AIM;
    if (p.skeleton == EN_SKELETON_CHOSEN) {
        /* The density first, from the windows' counts, without collapses
         * (a choice on slabs classifies its first slabs at the finest
         * candidate, whose samples would hold the windows above the
         * target). At the coarsest the share is small, and the ceiling is
         * aimed higher (PRICE_AIM_COARSEST); when even its samples are
         * over what the target keeps, the last round gives samples up
         * whatever the ceiling. It reads the insides alone, each with the
         * ring that completes its stars (a vertex's level is its own
         * star's): the margins are for the collapses' cuts. On `gen bumpy` 20M at
         * 10% that took it from 0.58 s to 0.31 s, the same frequency from
         * the same level shares (bench/RESULTS.md, session 19). */
        en_pass_plan d = p;
        d.keep_share = 1;
        /* and no collapses in W either: at the level of slabs that took
         * nothing, W takes nothing (stitcher.c: collapse_seams). Under the
         * windows' rule (no ceiling yet) W went as deep as it could, for
         * an output no one reads: two thirds of this chain's 0.24 s at 20M
         * faces (bench/RESULTS.md, session 30) */
        d.seams = EN_SEAMS_LEVEL;
        d.skeleton_budget =
            (uint64_t)(EN_TARGET_SKELETON_SHARE * size->share * (double)src->inside_ring_vertices);
        d.skeleton_expected = src->inside_ring_vertices;
        d.count_ranges = src->inside_alone;
        if ((rc = price_chain(ts, src, 1, &d, &st, err)) == 0) {
            p.finest_frequency = st.skeleton_frequency;
            aim = st.skeleton_frequency <= 1 ? PRICE_AIM_COARSEST : PRICE_AIM;
        }
    }
    /* Then past the target, counting what each level takes. */
    p.keep_share = size->share * PRICE_DEEP;
    if (rc == 0)
        rc = price_chain(ts, src, 0, &p, &st, err);
    if (rc == EPSNET_ENOMEM || rc == EPSNET_EINTR)
        return rc;
    if (rc)
        return 0; /* a bad block or record: no ceiling, and the stream's reader reports it where it is */
    /* The level under which the windows' insides keep the aim, in
     * vertices (two faces a vertex inside a surface, whatever the target
     * counts); within its bucket, the costs taken as spread evenly on a
     * log scale. Windows that never get there (refusals, locks) price
     * nothing. */
    double may_take = (double)src->inside_vertices * (1 - aim * size->share), taken = 0, part = 1;
    int top = 0;
    for (int b = 0; b < EN_COST_BUCKETS; b++) {
        if (!ts->hist_before[b])
            continue;
        top = b;
        if (taken + (double)ts->hist_before[b] > may_take) {
            part = (may_take - taken) / (double)ts->hist_before[b];
            taken = may_take;
            break;
        }
        taken += (double)ts->hist_before[b];
    }
    if (top == 0 || !(may_take > 0) || taken < may_take)
        return 0;
    double lo = en_cost_bucket_top(top - 1), hi = en_cost_bucket_top(top);
    *ceiling = lo > 0 ? lo * pow(hi / lo, part) : hi;
    /* (EPSNET_FAIL_PRICE_HIGH: a ceiling far too high, as windows that
     * missed a much harder stream would price it, so that the tests see
     * the floor and the pace hold the thinning) */
    if (en_fault_hit(&price_high_fault))
        *ceiling *= 1e6;
    /* The thinning: every slab and seam under the ceiling, each slab above
     * the floor and W above the pace to the target; its skeleton's
     * candidate the windows' density (the whole stream's counts may still
     * lower it, never raise it). */
    thin->cost_ceiling = *ceiling;
    thin->seams = EN_SEAMS_CEILING;
    thin->keep_share = size->share * PRICE_FLOOR;
    thin->share_of_vertices = 1; /* a guard, not a stop (pass_plan.h) */
    thin->floor_share = size->share;
    thin->goal = size->goal; /* W's pace (stitcher.c: seam_keep) */
    thin->finest_frequency = p.finest_frequency;
    return 0;
}

static int stage_fail(en_target_stage *ts, int rc, const epsnet_error *err)
{
    if (!ts->failed) {
        ts->failed = rc;
        ts->failure = *err;
    }
    return rc;
}

static int stage_put(void *self, const epsnet_record *rec, epsnet_error *err)
{
    en_target_stage *ts = self;
    if (ts->failed) {
        *err = ts->failure;
        return ts->failed;
    }
    kept_sink sink = { ts, &ts->in };
    int rc = kept_put(&sink, rec, err);
    return rc ? stage_fail(ts, rc, err) : 0;
}

/* Is a kept stream k close enough to the goal for the last round: within
 * ROUND_CLOSE of it, or small enough for its one slab? */
static int close_enough(const en_target_stage *ts, const kept *k)
{
    uint64_t left = ts->cfg.size.by_vertices ? k->vertices : k->faces;
    return (double)left <= (double)ts->cfg.size.goal * (1 + ROUND_CLOSE) || fits_one_slab_n(ts, (double)k->vertices);
}

/* Does what is kept fit the last round's one slab? */
static int fits_one_slab(const en_target_stage *ts)
{
    return fits_one_slab_n(ts, (double)ts->in.vertices);
}

/* The thinning's stream is all here: rounds, then the last one. */
static int stage_end(void *self, epsnet_error *err)
{
    en_target_stage *ts = self;
    if (ts->failed) {
        *err = ts->failure;
        return ts->failed;
    }
    const en_target_size *size = &ts->cfg.size;
    int by_vertices = size->by_vertices;
    uint64_t goal = size->goal;
    /* the thinning's skeleton: its samples at the density it chose from
     * its whole stream (the marks carry each one's level; pass_plan.h) */
    int level = 0xff;
    if (ts->thin) {
        en_chain_stats thin;
        en_chain_stats_get(ts->thin, &thin);
        if (thin.skeleton_finest_frequency)
            level = en_level_of(thin.skeleton_frequency);
        /* the non-samples' share priced, then the freed samples' costs */
        en_chain_cost_hist(ts->thin, 0xff, ts->hist);
        ts->priced = priced_share(ts->hist, thin.remaining_nonsamples);
        memset(ts->hist, 0, EN_COST_BUCKETS * sizeof *ts->hist);
        en_chain_cost_hist(ts->thin, level, ts->hist);
    }
    int rc = 0;
    if (ts->cfg.spares) {
        /* the thinning's slab works are its slabs' size, larger than a
         * round's (round_slab): they go, and the rounds make their own */
        en_ctxpool_trim(ts->cfg.spares->slab_works);
        en_ctxpool_trim(ts->cfg.spares->collapse_arrays);
        en_ctxpool_trim(ts->cfg.spares->scratch);
    }
    for (; ts->nrounds < ROUND_MAX && rc == 0; ts->nrounds++) {
        uint64_t left = by_vertices ? ts->in.vertices : ts->in.faces;
        if (close_enough(ts, &ts->in))
            break;
        /* a collapse takes one vertex, and two faces inside a surface */
        double need = (double)(left - goal) / (by_vertices ? 1.0 : 2.0);
        double gap = (double)(left - goal) / (double)goal;
        en_pass_plan round = {
            .skeleton = EN_SKELETON_MARKED,
            .skeleton_level = level,
            .skeleton_share = EN_TARGET_SKELETON_SHARE,
            .by_vertices = by_vertices,
            .goal = goal,
            .expected_in = left,
            .max_error = -1,
            .seams = EN_SEAMS_CEILING,
            .priced = 1,
        };
        kept next;
        en_chain_stats got;
        double aim = (gap > ROUND_NEAR ? ROUND_AIM : ROUND_AIM_NEAR) * need, priced = ts->priced;
        /* lean (kept_lean_bytes) when the round, taking its aim, lands
         * within half the last round's reach */
        int lean = ts->nrounds + 1 >= ROUND_MAX || en_fault_hit(&round_lean_fault) ||
                   (double)left - aim * (by_vertices ? 1.0 : 2.0) <= (double)goal * (1 + ROUND_CLOSE / 2);
        memcpy(ts->hist_before, ts->hist, EN_COST_BUCKETS * sizeof *ts->hist);
        for (int attempt = 0;; attempt++) {
            /* (EPSNET_FAIL_ROUND_AIM: the N-th and later ceilings take
             * everything, as a histogram that missed most of W did, so
             * that the tests reach the retries and the floor) */
            round.cost_ceiling = en_fault_hit(&round_aim_fault) ? DBL_MAX : ceiling_for(ts->hist_before, aim, priced);
            /* the last try holds its slabs and W to the target's share, so
             * that it cannot pass the target (pass_plan.h: floor_share) */
            round.floor_share = attempt == ROUND_RETRIES ? (double)goal / (double)left : 0;
            if ((rc = kept_open(ts, &next, err)) == 0) {
                next.lean = lean;
                rc = run_chain(ts, &round, &ts->in, &next, 0, &got, err);
            }
            if (rc || round.floor_share > 0 || (by_vertices ? next.vertices : next.faces) >= goal)
                break;
            /* it passed the target: the histogram misjudged what the
             * ceiling takes; the round again from the same stream, aiming
             * lower */
            kept_close(&next);
            aim *= ROUND_RETRY_AIM;
            ts->retries++;
        }
        uint64_t now = by_vertices ? next.vertices : next.faces;
        int stalled = (double)(left - now) < ROUND_STALL * (double)(left - goal);
        if (rc == 0 && next.lean && !stalled && ts->nrounds + 1 < ROUND_MAX && !close_enough(ts, &next)) {
            /* it landed short of the last round: another round follows,
             * which starts from the quadrics; the same round again, whole
             * (the same bytes, as if it had been whole from the start) */
            kept_close(&next);
            if ((rc = kept_open(ts, &next, err)) == 0)
                rc = run_chain(ts, &round, &ts->in, &next, 0, &got, err);
        }
        if (rc) {
            kept_close(&next);
            break;
        }
        add_counts(&ts->rounds, &got);
        kept_close(&ts->in);
        ts->in = next;
        if (stalled) {
            ts->nrounds++;
            break;
        }
    }
    if (rc)
        return stage_fail(ts, rc, err);
    /* The last round: the exact count, by its plan from what is kept. */
    uint64_t left = by_vertices ? ts->in.vertices : ts->in.faces;
    double keep = left ? fmin(1.0, (double)goal / (double)left) : 1.0;
    en_pass_plan fin = {
        .skeleton = EN_SKELETON_MARKED,
        .skeleton_level = level,
        .skeleton_share = EN_TARGET_SKELETON_SHARE,
        .samples_may_go = 1, /* the last round gives samples up when the count needs it */
        .keep_share = keep,
        .by_vertices = by_vertices,
        .goal = goal,
        .expected_in = left,
        .goal_share = keep,
        .max_error = -1,
        .refresh = 1,
        .seams = EN_SEAMS_PACED,
        .one_slab = fits_one_slab(ts),
    };
    if (fin.one_slab && ts->cfg.spares) {
        /* the rounds' slab works and arrays are the wrong size for one
         * slab of the whole: they go before it is built */
        en_ctxpool_trim(ts->cfg.spares->slab_works);
        en_ctxpool_trim(ts->cfg.spares->collapse_arrays);
        en_ctxpool_trim(ts->cfg.spares->scratch);
    }
    rc = run_chain(ts, &fin, &ts->in, NULL, 1, &ts->last, err);
    ts->last_collapsed = 1;
    if (rc == 0)
        rc = report(ts, err); /* the stage's end: done */
    return rc ? stage_fail(ts, rc, err) : 0;
}

int en_target_stage_new(en_target_stage **out, const en_target_stage_config *cfg, en_pool *pool, epsnet_error *err)
{
    *out = NULL;
    en_target_stage *ts = en_calloc(1, sizeof *ts);
    if (!ts || !(ts->hist = en_calloc(EN_COST_BUCKETS, sizeof *ts->hist)) ||
        !(ts->hist_before = en_calloc(EN_COST_BUCKETS, sizeof *ts->hist))) {
        en_target_stage_free(&ts);
        return en_error_set(err, EPSNET_ENOMEM, cfg->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    ts->cfg = *cfg;
    ts->pool = pool;
    ts->priced = 1;
    ts->kept_attr = cfg->attr_size + en_carried_bytes(cfg->weights ? cfg->weights->channels : 0);
    if (!(ts->lean_attr = en_calloc(1, ts->kept_attr))) {
        en_target_stage_free(&ts);
        return en_error_set(err, EPSNET_ENOMEM, cfg->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    int rc = kept_open(ts, &ts->in, err);
    if (rc) {
        en_target_stage_free(&ts);
        return rc;
    }
    *out = ts;
    return 0;
}

en_stage en_target_stage_input(en_target_stage *ts)
{
    return (en_stage){ stage_put, stage_end, ts };
}

void en_target_stage_after(en_target_stage *ts, const en_chain *thin)
{
    ts->thin = thin;
}

void en_target_stage_stats(const en_target_stage *ts, en_chain_stats *cs, int *rounds, int *retries,
                           int *last_on_slabs)
{
    add_counts(cs, &ts->rounds);
    add_counts(cs, &ts->last);
    cs->output_vertices = ts->last.output_vertices;
    cs->output_faces = ts->last.output_faces;
    cs->remaining_nonsamples = ts->last.remaining_nonsamples;
    cs->skeleton_kept = ts->last.skeleton_kept;
    cs->samples_given_up = ts->last.samples_given_up;
    cs->target_faces = ts->last.target_faces;
    cs->stopped_by_error |= ts->last.stopped_by_error;
    cs->passes += (uint64_t)ts->nrounds + 1;
    *rounds = ts->nrounds;
    *retries = (int)ts->retries;
    *last_on_slabs = !ts->last_one_slab;
}

void en_target_stage_free(en_target_stage **pts)
{
    en_target_stage *ts = pts ? *pts : NULL;
    if (!ts)
        return;
    kept_close(&ts->in);
    en_free(ts->hist);
    en_free(ts->hist_before);
    en_free(ts->lean_attr);
    en_free(ts);
    *pts = NULL;
}
