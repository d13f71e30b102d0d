/*
 * Metro-style error between two meshes (Cignoni, Rocchini, Scopigno, "Metro:
 * measuring error on simplified surfaces", 1998), the measure behind the
 * paper's Tables 1 and 2, plus the normal deviation of paper §3.2 (L2,1).
 *
 * One direction S -> T reads like this:
 *   plan     decide every sample of S: which face owns each vertex and edge,
 *            how many points each face and edge gets (plan_build);
 *   measure  in fixed chunks of S's faces, taken in any order by any thread,
 *            generate the chunk's points and find each one's nearest point on
 *            T through T's hierarchy (run_chunk);
 *   combine  add the chunks' sums in chunk order (combine_chunks).
 * Every random draw comes from a generator seeded by (seed, direction, face),
 * and every sum is per chunk and combined in chunk order, so the numbers are
 * bit-identical for any thread count.
 */
#include "metrics/hausdorff.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <string.h>
#include <unistd.h>

#include "common/alloc.h"
#include "common/thread.h"
#include "common/u64set.h"
#include "metrics/bvh.h"

enum {
    CHUNK_FACES = 1024,
    MAX_THREADS = 256,
    MAX_SAMPLES_PER_FACE = 100000,
};

/* Bits of sample_plan.owns: the face samples corner i / edge (i, i+1). */
#define OWN_CORNER(i) (1u << (i))
#define OWN_EDGE(i) (8u << (i))

/* How far, relative to the target's diagonal, a second face may be and still
 * count as touching the closest point for the normal rule (bvh.h). */
#define TIE_RELATIVE 1e-10

static const double rad_to_deg = 57.29577951308232;

/* ---- deterministic jitter: splitmix64 ---- */

static uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

static double rng_unit(uint64_t *state)
{
    *state += 0x9e3779b97f4a7c15ULL;
    return (double)(mix64(*state) >> 11) * 0x1p-53;
}

static uint64_t face_stream(uint64_t seed, unsigned direction, uint32_t face)
{
    return mix64(seed ^ mix64(((uint64_t)face << 1 | direction) + 1));
}

/* ---- geometry of one face ---- */

static const double *vertex_of(const en_hd_mesh *m, uint32_t f, int k)
{
    return m->xyz + 3 * (size_t)m->tri[3 * (size_t)f + k];
}

/* Area of face f and its unit normal; 0 (normal unset) for a degenerate face. */
static double face_area(const double *a, const double *b, const double *c, double unit_normal[3])
{
    if (en_tri_is_degenerate(a, b, c))
        return 0;
    double u[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] };
    double v[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
    double n[3] = { u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0] };
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int k = 0; k < 3; k++)
        unit_normal[k] = n[k] / len;
    return 0.5 * len;
}

static double distance(const double *a, const double *b)
{
    double d[3] = { a[0] - b[0], a[1] - b[1], a[2] - b[2] };
    return sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

static double bbox_diagonal(const en_hd_mesh *m)
{
    if (m->nv == 0)
        return 0;
    double lo[3], hi[3];
    memcpy(lo, m->xyz, sizeof lo);
    memcpy(hi, m->xyz, sizeof hi);
    for (size_t i = 1; i < m->nv; i++)
        for (int k = 0; k < 3; k++) {
            double x = m->xyz[3 * i + k];
            lo[k] = x < lo[k] ? x : lo[k];
            hi[k] = x > hi[k] ? x : hi[k];
        }
    return distance(lo, hi);
}

/* ---- plan: which samples each face owns ---- */

typedef struct sample_plan {
    const en_hd_mesh *mesh;
    const uint32_t *order;      /* faces in the source hierarchy's Morton order */
    uint32_t *face_points;      /* interior points per face id; 0 = zero-area face */
    uint8_t *owns;              /* OWN_* bits per face id */
    double edge_spacing;        /* distance between edge points; 0 = none */
    double area;                /* total area */
    uint64_t zero_area_faces;
} sample_plan;

static void plan_free(sample_plan *p)
{
    en_free(p->face_points);
    en_free(p->owns);
    p->face_points = NULL;
    p->owns = NULL;
}

/*
 * Each vertex and each undirected edge is sampled once, by the first face in
 * Morton order that has it, so that samples stay spatially coherent (the
 * previous answer is a good start for the next query) whatever the order of
 * the file. @return the summed length of the distinct edges, or -1 when out
 * of memory.
 */
static double plan_ownership(sample_plan *p)
{
    const en_hd_mesh *m = p->mesh;
    uint8_t *seen = en_calloc((size_t)m->nv, 1);
    en_u64set *edges = en_u64set_new();
    double length = 0;
    if (!seen || !edges) {
        length = -1;
        goto out;
    }
    for (uint32_t i = 0; i < m->nt; i++) {
        uint32_t f = p->order[i];
        const uint32_t *t = m->tri + 3 * (size_t)f;
        uint8_t own = 0;
        for (int k = 0; k < 3; k++) {
            if (!seen[t[k]]) {
                seen[t[k]] = 1;
                own |= OWN_CORNER(k);
            }
            uint32_t u = t[k], v = t[(k + 1) % 3];
            if (u == v)
                continue;
            uint64_t key = u < v ? (uint64_t)u << 32 | v : (uint64_t)v << 32 | u;
            int added = en_u64set_add(edges, key);
            if (added < 0) {
                length = -1;
                goto out;
            }
            if (added) {
                own |= OWN_EDGE(k);
                length += distance(m->xyz + 3 * (size_t)u, m->xyz + 3 * (size_t)v);
            }
        }
        p->owns[f] = own;
    }
out:
    en_free(seen);
    en_u64set_free(&edges);
    return length;
}

/*
 * Interior points in proportion to area, so that the density is even over
 * the surface as in Metro (a large face of a simplified mesh is not left
 * with ten points); rounding carries from face to face so the total is the
 * budget, and every face with area gets at least one point.
 */
static void plan_face_points(sample_plan *p, double budget)
{
    const en_hd_mesh *m = p->mesh;
    double carried = 0;
    uint64_t given = 0;
    for (uint32_t i = 0; i < m->nt; i++) {
        uint32_t f = p->order[i];
        double n[3];
        double area = face_area(vertex_of(m, f, 0), vertex_of(m, f, 1), vertex_of(m, f, 2), n);
        if (area == 0) {
            p->face_points[f] = 0;
            p->zero_area_faces++;
            continue;
        }
        carried += budget * area / p->area;
        double target = floor(carried + 0.5);
        uint64_t k = target > (double)given ? (uint64_t)target - given : 0;
        given += k;
        if (k < 1)
            k = 1;
        p->face_points[f] = k > UINT32_MAX ? UINT32_MAX : (uint32_t)k;
    }
}

static int plan_build(sample_plan *p, const en_hd_mesh *m, const uint32_t *order, uint32_t per_face)
{
    memset(p, 0, sizeof *p);
    p->mesh = m;
    p->order = order;
    p->face_points = en_malloc((size_t)m->nt * sizeof *p->face_points);
    p->owns = en_malloc((size_t)m->nt);
    if (!p->face_points || !p->owns) {
        plan_free(p);
        return EPSNET_ENOMEM;
    }
    for (uint32_t i = 0; i < m->nt; i++) {
        uint32_t f = order[i];
        double n[3];
        p->area += face_area(vertex_of(m, f, 0), vertex_of(m, f, 1), vertex_of(m, f, 2), n);
    }
    double edge_length = plan_ownership(p);
    if (edge_length < 0) {
        plan_free(p);
        return EPSNET_ENOMEM;
    }
    double budget = (double)per_face * m->nt;
    plan_face_points(p, budget);
    /* Edge points at twice the spacing of the face points: those already come
     * within about one spacing of every edge, so the edge points are there
     * for the maxima on creases, not for density. Never more of them than
     * face points (a mesh of needles has long edges and no area). */
    double spacing = p->area > 0 ? 2 * sqrt(p->area / budget) : 0;
    if (edge_length / budget > spacing)
        spacing = edge_length / budget;
    p->edge_spacing = spacing;
    return 0;
}

/* ---- measure: one chunk of faces ---- */

/* Sums of one chunk; combined in chunk order. */
typedef struct side_sums {
    double max, sum_wd, sum_wd2, sum_w;
    double max_at[3];    /* the first sample, in sampling order, at max */
    uint64_t count;
    double normal_max, sum_wn, sum_wn_w;
    uint64_t normal_count;
} side_sums;

typedef struct direction_job {
    /* Set before the workers start, read-only while they run. */
    const sample_plan *plan;
    const en_bvh *target;
    double tie_dist;
    uint64_t seed;
    unsigned direction;
    uint32_t nchunks;
    /* The next chunk to take; every worker increments it. */
    atomic_uint next_chunk;
    /* partials[c] is written only by the worker that took chunk c and read by
     * the caller after every worker has been joined. */
    side_sums *partials;
} direction_job;

/* One chunk's view while it runs: the previous answer starts the next query. */
typedef struct chunk_state {
    const direction_job *job;
    uint32_t hint;
    side_sums sums;
} chunk_state;

static double normal_angle_deg(const en_bvh *target, uint32_t face, const double unit_n[3])
{
    const double *a = target->xyz + 3 * (size_t)target->tri[3 * (size_t)face];
    const double *b = target->xyz + 3 * (size_t)target->tri[3 * (size_t)face + 1];
    const double *c = target->xyz + 3 * (size_t)target->tri[3 * (size_t)face + 2];
    double m[3];
    face_area(a, b, c, m);
    double x[3] = { unit_n[1] * m[2] - unit_n[2] * m[1], unit_n[2] * m[0] - unit_n[0] * m[2],
                    unit_n[0] * m[1] - unit_n[1] * m[0] };
    double sine = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    double cosine = unit_n[0] * m[0] + unit_n[1] * m[1] + unit_n[2] * m[2];
    /* note: atan2 rather than acos(dot): exact to the last bits near 0,
     * which is where a good simplification lives. */
    return atan2(sine, cosine) * rad_to_deg;
}

/* Measure one point. weight is its share of the mean; unit_n is the normal of
 * the sampled face, NULL for vertex and edge points (no normal there). */
static void measure_point(chunk_state *cs, const double p[3], double weight, const double *unit_n)
{
    const direction_job *job = cs->job;
    en_bvh_hit hit;
    en_bvh_nearest(job->target, p, cs->hint, unit_n, job->tie_dist, &hit);
    cs->hint = hit.slot;
    double d = sqrt(hit.d2);
    side_sums *s = &cs->sums;
    s->count++;
    if (d > s->max) {
        s->max = d;
        memcpy(s->max_at, p, sizeof s->max_at);
    }
    s->sum_wd += weight * d;
    s->sum_wd2 += weight * d * d;
    s->sum_w += weight;
    if (!unit_n || hit.face_dot < -1.5)
        return;
    double angle = normal_angle_deg(job->target, hit.face, unit_n);
    s->normal_count++;
    s->normal_max = angle > s->normal_max ? angle : s->normal_max;
    s->sum_wn += weight * angle;
    s->sum_wn_w += weight;
}

/*
 * k points stratified over the face: the unit square (s, t) is cut into k
 * cells of equal area, in rows along s whose cell counts grow like 2r+1, and
 * mapped to the triangle by the area-preserving (sqrt s, t) map. For k = R^2
 * the rows are the R bands of the classic split into R^2 similar triangles,
 * so the cells are compact rather than slivers, and one jittered point per
 * cell keeps the estimate of the face's integral unbiased.
 */
static void sample_face_interior(chunk_state *cs, const double *a, const double *b, const double *c,
                                 uint32_t k, double weight, const double unit_n[3], uint64_t *rng)
{
    double ab[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] };
    double ac[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
    uint32_t rows = (uint32_t)floor(sqrt((double)k) + 0.5);
    if (rows < 1)
        rows = 1;
    uint64_t row_start = 0;
    for (uint32_t r = 0; r < rows; r++) {
        double frac = (double)(r + 1) / rows;
        uint64_t row_end = r + 1 == rows ? k : (uint64_t)floor((double)k * frac * frac + 0.5);
        uint64_t cells = row_end - row_start;
        for (uint64_t j = 0; j < cells; j++) {
            double s = ((double)row_start + rng_unit(rng) * (double)cells) / k;
            double t = ((double)j + rng_unit(rng)) / (double)cells;
            double root = sqrt(s);
            double along_b = root * (1 - t), along_c = root * t;
            double p[3];
            for (int q = 0; q < 3; q++)
                p[q] = a[q] + along_b * ab[q] + along_c * ac[q];
            measure_point(cs, p, weight, unit_n);
        }
        row_start = row_end;
    }
}

/* Points strictly inside edge uv at the plan's spacing, one per stratum. */
static void sample_edge(chunk_state *cs, const double *u, const double *v, double weight, uint64_t *rng)
{
    double spacing = cs->job->plan->edge_spacing;
    if (spacing <= 0)
        return;
    double points = floor(distance(u, v) / spacing);
    for (double j = 0; j < points; j++) {
        double t = (j + rng_unit(rng)) / points;
        double p[3];
        for (int q = 0; q < 3; q++)
            p[q] = u[q] + t * (v[q] - u[q]);
        measure_point(cs, p, weight, NULL);
    }
}

static void sample_face(chunk_state *cs, uint32_t f)
{
    const direction_job *job = cs->job;
    const sample_plan *plan = job->plan;
    const en_hd_mesh *m = plan->mesh;
    const double *c[3] = { vertex_of(m, f, 0), vertex_of(m, f, 1), vertex_of(m, f, 2) };
    uint64_t rng = face_stream(job->seed, job->direction, f);
    /* note: with area, vertex and edge points count for the max only (the
     * integral is estimated from the face points); without, they are all
     * there is and share the mean equally. */
    double point_weight = plan->area > 0 ? 0 : 1;
    uint8_t own = plan->owns[f];
    for (int k = 0; k < 3; k++)
        if (own & OWN_CORNER(k))
            measure_point(cs, c[k], point_weight, NULL);
    for (int k = 0; k < 3; k++)
        if (own & OWN_EDGE(k))
            sample_edge(cs, c[k], c[(k + 1) % 3], point_weight, &rng);
    uint32_t k = plan->face_points[f];
    if (k == 0)
        return;
    double n[3];
    double area = face_area(c[0], c[1], c[2], n);
    sample_face_interior(cs, c[0], c[1], c[2], k, area / k, n, &rng);
}

static void run_chunk(const direction_job *job, uint32_t chunk)
{
    chunk_state cs = { .job = job, .hint = UINT32_MAX };
    uint32_t nt = job->plan->mesh->nt;
    uint32_t end = nt - chunk * CHUNK_FACES < CHUNK_FACES ? nt : (chunk + 1) * CHUNK_FACES;
    for (uint32_t i = chunk * CHUNK_FACES; i < end; i++)
        sample_face(&cs, job->plan->order[i]);
    job->partials[chunk] = cs.sums;
}

static void *worker(void *arg)
{
    direction_job *job = arg;
    unsigned c;
    while ((c = atomic_fetch_add(&job->next_chunk, 1)) < job->nchunks)
        run_chunk(job, c);
    return NULL;
}

/* ---- combine ---- */

static void combine_chunks(const side_sums *partials, uint32_t n, const sample_plan *plan,
                           epsnet_hausdorff_side *side)
{
    side_sums t = { 0 };
    for (uint32_t c = 0; c < n; c++) {
        const side_sums *s = &partials[c];
        /* note: chunks in order and a strict >, so the place named is the
         * same whatever the thread count */
        if (s->max > t.max) {
            t.max = s->max;
            memcpy(t.max_at, s->max_at, sizeof t.max_at);
        }
        t.sum_wd += s->sum_wd;
        t.sum_wd2 += s->sum_wd2;
        t.sum_w += s->sum_w;
        t.count += s->count;
        t.normal_max = s->normal_max > t.normal_max ? s->normal_max : t.normal_max;
        t.sum_wn += s->sum_wn;
        t.sum_wn_w += s->sum_wn_w;
        t.normal_count += s->normal_count;
    }
    memset(side, 0, sizeof *side);
    side->max = t.max;
    memcpy(side->max_at, t.max_at, sizeof side->max_at);
    side->mean = t.sum_w > 0 ? t.sum_wd / t.sum_w : 0;
    side->rms = t.sum_w > 0 ? sqrt(t.sum_wd2 / t.sum_w) : 0;
    side->samples = t.count;
    side->normal_max = t.normal_max;
    side->normal_mean = t.sum_wn_w > 0 ? t.sum_wn / t.sum_wn_w : 0;
    side->normal_samples = t.normal_count;
    side->area = plan->area;
}

static int thread_count(int requested, uint32_t nchunks)
{
    long n = requested > 0 ? requested : en_cpus_usable();
    if (n < 1)
        n = 1;
    if (n > MAX_THREADS)
        n = MAX_THREADS;
    if ((uint32_t)n > nchunks)
        n = nchunks > 0 ? (long)nchunks : 1;
    return (int)n;
}

/* Run the chunks on `threads` threads, the caller being one of them. A
 * thread that cannot be started leaves its share to the others. */
static void run_parallel(direction_job *job, int threads)
{
    pthread_t tid[MAX_THREADS];
    int started = 0;
    for (int i = 1; i < threads; i++) {
        if (en_thread_create(&tid[started], worker, job) != 0)
            break;
        started++;
    }
    worker(job);
    for (int i = 0; i < started; i++)
        pthread_join(tid[i], NULL);
}

/* Samples of `source` (planned in source_bvh's order) measured against
 * target. */
static int measure_direction(const en_hd_mesh *source, const en_bvh *source_bvh, const en_bvh *target,
                             double target_diagonal, const epsnet_hausdorff_settings *s,
                             unsigned direction, epsnet_hausdorff_side *side, uint64_t *zero_area)
{
    sample_plan plan;
    int rc = plan_build(&plan, source, source_bvh->order, s->samples_per_face);
    if (rc)
        return rc;
    *zero_area = plan.zero_area_faces;
    direction_job job = {
        .plan = &plan,
        .target = target,
        .tie_dist = TIE_RELATIVE * target_diagonal,
        .seed = s->seed,
        .direction = direction,
        .nchunks = (uint32_t)((source->nt + (uint64_t)CHUNK_FACES - 1) / CHUNK_FACES),
    };
    atomic_init(&job.next_chunk, 0);
    job.partials = en_calloc((size_t)job.nchunks + 1, sizeof *job.partials);
    if (!job.partials) {
        plan_free(&plan);
        return EPSNET_ENOMEM;
    }
    run_parallel(&job, thread_count(s->threads, job.nchunks));
    combine_chunks(job.partials, job.nchunks, &plan, side);
    en_free(job.partials);
    plan_free(&plan);
    return 0;
}

int en_hausdorff(const en_hd_mesh *a, const en_hd_mesh *b, const epsnet_hausdorff_settings *s,
                 epsnet_hausdorff_result *out)
{
    epsnet_hausdorff_settings defaults;
    if (!s) {
        epsnet_hausdorff_default_settings(&defaults);
        s = &defaults;
    }
    if (!a || !b || !out || s->samples_per_face < 1 || s->samples_per_face > MAX_SAMPLES_PER_FACE ||
        s->threads < 0)
        return EPSNET_EINVAL;
    if ((a->nt == 0) != (b->nt == 0))
        return EPSNET_EINVAL;
    memset(out, 0, sizeof *out);
    out->a_vertices = a->nv;
    out->a_faces = a->nt;
    out->b_vertices = b->nv;
    out->b_faces = b->nt;
    out->diagonal = bbox_diagonal(a);
    if (a->nt == 0)
        return 0;
    en_bvh bvh_a, bvh_b;
    if (en_bvh_build(&bvh_a, a->xyz, a->tri, a->nt))
        return EPSNET_ENOMEM;
    if (en_bvh_build(&bvh_b, b->xyz, b->tri, b->nt)) {
        en_bvh_free(&bvh_a);
        return EPSNET_ENOMEM;
    }
    int rc = measure_direction(a, &bvh_a, &bvh_b, bbox_diagonal(b), s, 0, &out->a_to_b,
                               &out->a_zero_area_faces);
    if (rc == 0)
        rc = measure_direction(b, &bvh_b, &bvh_a, out->diagonal, s, 1, &out->b_to_a,
                               &out->b_zero_area_faces);
    en_bvh_free(&bvh_a);
    en_bvh_free(&bvh_b);
    if (rc == 0)
        out->hausdorff = out->a_to_b.max > out->b_to_a.max ? out->a_to_b.max : out->b_to_a.max;
    return rc;
}

void epsnet_hausdorff_default_settings(epsnet_hausdorff_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof *s);
    s->samples_per_face = 10;
    s->seed = 1;
    s->threads = 0;
}
