/*
 * Half-edge collapses of non-samples, cheapest first (paper §4.2, §5; docs/method.md §9).
 *
 * Papers implemented:
 *   Garland, Heckbert. Surface simplification using quadric error metrics.
 *     SIGGRAPH 1997 (the plane quadrics and their accumulation).
 *   Dey, Edelsbrunner, Guha, Nekhayev. Topology preserving edge contraction.
 *     1999 (the link condition).
 *
 * The outline, in passes until no collapse is left (docs/method.md §9):
 *   1. rebuild the faces around each vertex from the faces alive (two
 *      linear sweeps into one flat array);
 *   2. rank: each removable vertex's cheapest target by quadric cost;
 *   3. order the candidates by cost bucket (a counting sort, 16 buckets to
 *      an octave);
 *   4. collapse them in that order up to the pass's bound, each after the
 *      checks (link condition, normals, zero area, duplicates), skipping
 *      any with an end that collapsed or absorbed a collapse earlier in the
 *      pass (per-pass locks: the next pass ranks it afresh).
 *
 * note: a heap kept the exact cheapest-first order, but every collapse
 * then updated scattered face lists and heap entries, and the run waited
 * on memory: 1.6 us a collapse on a slab-sized mesh, where flat arrays
 * swept in order cost a fraction of that (bench/RESULTS.md, session 13).
 * The order is cheapest first to within a bucket and a pass's slack; the
 * error at equal face count was measured against the exact order there.
 *
 * note: a vertex whose cheapest target is refused is checked against its
 * others at once, and its cheapest valid one (or "none", or "over the
 * error bound") is kept until a collapse changes its star or a neighbour's
 * (changed_at against eval_at): a vertex refused once costs no check again
 * until then.
 */
#include "core/collapse.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "common/alloc.h"
#include "epsnet/epsnet.h"

/* ---- quadrics ---- */

static void quadric_add(en_quadric *a, const en_quadric *b)
{
    a->a2 += b->a2, a->ab += b->ab, a->ac += b->ac, a->ad += b->ad, a->b2 += b->b2;
    a->bc += b->bc, a->bd += b->bd, a->c2 += b->c2, a->cd += b->cd, a->d2 += b->d2;
}

static double quadric_eval(const en_quadric *q, const double p[3])
{
    double x = p[0], y = p[1], z = p[2];
    return q->a2 * x * x + 2 * q->ab * x * y + 2 * q->ac * x * z + 2 * q->ad * x + q->b2 * y * y +
           2 * q->bc * y * z + 2 * q->bd * y + q->c2 * z * z + 2 * q->cd * z + q->d2;
}

/* The area-weighted plane quadric of face t into k, its unit normal into
 * un (0 for a zero-area face, whose quadric is then 0 too). */
static void face_quadric(const double *pos, const uint32_t *t, en_quadric *k, double un[3])
{
    double n[3];
    en_triangle_normal(pos, t, n);
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (len == 0) {
        un[0] = un[1] = un[2] = 0;
        memset(k, 0, sizeof *k);
        return;
    }
    /* note: weight = area, so a plane counts by how much surface it
     * carries and sliver triangles do not dominate. */
    double area = 0.5 * len, a = n[0] / len, b = n[1] / len, c = n[2] / len;
    un[0] = a, un[1] = b, un[2] = c;
    const double *p = pos + 3 * (size_t)t[0];
    double d = -(a * p[0] + b * p[1] + c * p[2]);
    *k = (en_quadric){ area * a * a, area * a * b, area * a * c, area * a * d, area * b * b,
                       area * b * c, area * b * d, area * c * c, area * c * d, area * d * d };
}

void en_quadrics_from_faces(const en_slab *s, en_quadric *q, double *unit_normal)
{
    memset(q, 0, (size_t)s->nv * sizeof *q);
    for (uint32_t f = 0; f < s->nt; f++) {
        const uint32_t *t = s->tri + 3 * (size_t)f;
        en_quadric k;
        face_quadric(s->pos, t, &k, unit_normal + 3 * (size_t)f);
        for (int i = 0; i < 3; i++)
            quadric_add(&q[t[i]], &k);
    }
}

/* ---- the working arrays ---- */

/* A vertex's target: none yet, or none at all. */
#define NO_TARGET UINT32_MAX

/* st->flag bits, per vertex */
enum {
    F_ACTIVE = 1 << 0,  /* removable in the tiers now collapsing */
    F_ALIVE = 1 << 1,   /* not collapsed away (mirrors vertex_alive) */
    F_LOCKED = 1 << 2,  /* collapsed or absorbed a collapse in this pass (per-pass lock) */
    F_CHECKED = 1 << 3, /* its candidate is its cheapest valid collapse, checked */
    F_RANK = 1 << 4,    /* its candidate is ranked afresh in this pass */
};

/* What a vertex's cached evaluation (eval_at) found. */
enum { E_VALID = 0, E_REFUSED = 1, E_OVER_ERROR = 2 };

/*
 * One set of working arrays, every one flat, per vertex or per face, swept
 * in index order once a pass. Kept between calls in an
 * en_collapse_arrays_new() pool so that they stay warm (bench/RESULTS.md,
 * session 10). Every field is written by the one call that holds the set.
 */
typedef struct arrays {
    uint32_t *off;        /* nv + 1: where each vertex's faces start in adj */
    uint32_t *adj;        /* the alive faces around each vertex, in face order */
    uint32_t *live;       /* alive faces, ascending */
    uint32_t *verts;      /* alive vertices with a face, ascending */
    uint32_t *order;      /* this pass's candidates, cheapest bucket first */
    uint32_t *sorted;     /* scratch of the counting sort */
    uint32_t *hist;       /* EN_COST_BUCKETS + 1 counters of the counting sort */
    double *self_err;     /* q[v] at v's own position */
    double *cost;         /* the candidate's quadric cost */
    uint32_t *target;     /* the candidate's target, or NO_TARGET */
    uint32_t *changed_at; /* the collapse (1, 2, ...) that last changed the star or quadric */
    uint32_t *eval_at;    /* 0, or 1 + the collapse count when eval was cached */
    uint32_t *mark;       /* stamps of the link test */
    uint16_t *key;        /* the candidate's cost bucket */
    uint8_t *flag;        /* F_* */
    uint8_t *eval;        /* E_*: what the cached evaluation found */
    uint8_t *refused;     /* EN_REFUSE_* of the last refusal */
    struct target *cand;  /* scratch: one vertex's targets */
    size_t cap_off, cap_adj, cap_live, cap_verts, cap_order, cap_sorted, cap_hist, cap_self_err, cap_cost, cap_target,
        cap_changed_at, cap_eval_at, cap_mark, cap_key, cap_flag, cap_eval, cap_refused, cap_cand;
} arrays;

typedef struct target {
    double cost;
    uint32_t u;
} target;

typedef struct state {
    const en_slab *s;
    arrays *a;
    en_quadric *q;            /* the caller's, accumulating */
    double cos_bound;
    uint32_t *tri;
    uint8_t *falive, *valive;
    const double *ref_normal; /* unit normal each face had in the input (0 if none) */
    uint32_t nlive, nverts;
    uint32_t stamp;
    uint32_t seq;             /* collapses so far: the clock of changed_at and eval_at */

    /* Limits (en_collapse_settings) and what they count. */
    const uint8_t *tier;      /* the caller's removable[]: 2 = second tier */
    int by_error;
    double max_cost;          /* by_error: max_error squared; otherwise +inf */
    uint64_t keep_faces, keep_vertices;
    uint64_t faces_alive, vertices_alive;
    uint64_t given_up;
    int stopped_by_error;
    double ceiling;           /* cost_ceiling, +inf when none */
    double top_cost;          /* the highest cost collapsed so far */
    int stopped_by_ceiling;
} state;

/* ---- the mesh as it is at the start of a pass ---- */

static int has_corner(const uint32_t *t, uint32_t v)
{
    return t[0] == v || t[1] == v || t[2] == v;
}

/* Corner of t at v (the first, should a face repeat v). */
static int corner_at(const uint32_t *t, uint32_t v)
{
    return t[0] == v ? 0 : t[1] == v ? 1 : 2;
}

/* The two corners of triangle t other than v, in counter-clockwise order. */
static void other_corners(const uint32_t *t, uint32_t v, uint32_t *x, uint32_t *y)
{
    int k = corner_at(t, v);
    *x = t[(k + 1) % 3];
    *y = t[(k + 2) % 3];
}

/*
 * Rebuild the faces around every vertex from the faces alive now (a
 * counting pass, then a filling pass, both in face order), and drop the
 * faces and vertices gone since the last pass from the lists swept.
 * note: within a pass the lists are not updated. A collapse v -> u renames
 * v to u in v's faces and kills the two on the edge, so a vertex gains
 * faces only by absorbing a collapse: every vertex but the locked ones
 * still has all its faces in its list, and skipping the dead ones gives
 * its star exactly.
 */
static void rebuild(state *st)
{
    arrays *a = st->a;
    uint32_t nv = st->s->nv, n = 0;
    memset(a->off, 0, ((size_t)nv + 1) * sizeof *a->off);
    for (uint32_t i = 0; i < st->nlive; i++) {
        uint32_t f = a->live[i];
        if (!st->falive[f])
            continue;
        a->live[n++] = f;
        const uint32_t *t = st->tri + 3 * (size_t)f;
        a->off[t[0] + 1]++, a->off[t[1] + 1]++, a->off[t[2] + 1]++;
    }
    st->nlive = n;
    for (uint32_t v = 0; v < nv; v++)
        a->off[v + 1] += a->off[v];
    /* fill with off[v] as the cursor, then shift back */
    for (uint32_t i = 0; i < n; i++) {
        uint32_t f = a->live[i];
        const uint32_t *t = st->tri + 3 * (size_t)f;
        a->adj[a->off[t[0]]++] = f;
        a->adj[a->off[t[1]]++] = f;
        a->adj[a->off[t[2]]++] = f;
    }
    for (uint32_t v = nv; v > 0; v--)
        a->off[v] = a->off[v - 1];
    a->off[0] = 0;
    uint32_t m = 0;
    for (uint32_t i = 0; i < st->nverts; i++) {
        uint32_t v = a->verts[i];
        if ((a->flag[v] & F_ALIVE) && a->off[v + 1] > a->off[v])
            a->verts[m++] = v;
    }
    st->nverts = m;
}

/* Does u have a face on both x and y? */
static int has_face_on(const state *st, uint32_t u, uint32_t x, uint32_t y)
{
    const arrays *a = st->a;
    for (uint32_t i = a->off[u]; i < a->off[u + 1]; i++) {
        if (!st->falive[a->adj[i]])
            continue; /* gone in this pass */
        const uint32_t *t = st->tri + 3 * (size_t)a->adj[i];
        if (has_corner(t, x) && has_corner(t, y))
            return 1;
    }
    return 0;
}

/*
 * Can v collapse onto u? Returns 0 or the EN_REFUSE_* reason. Both must be
 * unlocked in this pass (their lists exact).
 * Link condition: the neighbours v and u share must be exactly the two
 * vertices opposite the edge v-u, else the collapse pinches the surface.
 */
static int check_collapse(state *st, uint32_t v, uint32_t u)
{
    if (!(st->s->vflags[u] & EN_V_TARGET))
        return EN_REFUSE_INCOMPLETE;
    arrays *a = st->a;
    uint32_t stamp = ++st->stamp, *mark = a->mark;
    for (uint32_t i = a->off[u]; i < a->off[u + 1]; i++) {
        if (!st->falive[a->adj[i]])
            continue; /* gone in this pass */
        const uint32_t *t = st->tri + 3 * (size_t)a->adj[i];
        mark[t[0]] = mark[t[1]] = mark[t[2]] = stamp;
    }
    uint32_t opp[2], nedge = 0;
    for (uint32_t i = a->off[v]; i < a->off[v + 1]; i++) {
        if (!st->falive[a->adj[i]])
            continue; /* gone in this pass */
        const uint32_t *t = st->tri + 3 * (size_t)a->adj[i];
        if (!has_corner(t, u))
            continue;
        if (nedge == 2)
            return EN_REFUSE_LINK; /* edge with more than two faces */
        opp[nedge++] = t[0] != v && t[0] != u ? t[0] : t[1] != v && t[1] != u ? t[1] : t[2];
    }
    if (nedge != 2)
        return EN_REFUSE_LINK;
    /* note: unmarking the allowed shared vertices leaves one test per corner;
     * 0 is below every stamp. */
    mark[v] = mark[u] = mark[opp[0]] = mark[opp[1]] = 0;
    for (uint32_t i = a->off[v]; i < a->off[v + 1]; i++) {
        if (!st->falive[a->adj[i]])
            continue; /* gone in this pass */
        const uint32_t *t = st->tri + 3 * (size_t)a->adj[i];
        if (mark[t[0]] == stamp || mark[t[1]] == stamp || mark[t[2]] == stamp)
            return EN_REFUSE_LINK;
    }
    for (uint32_t i = a->off[v]; i < a->off[v + 1]; i++) {
        if (!st->falive[a->adj[i]])
            continue; /* gone in this pass */
        uint32_t f = a->adj[i];
        const uint32_t *t = st->tri + 3 * (size_t)f;
        if (has_corner(t, u))
            continue;
        uint32_t nt[3] = { t[0] == v ? u : t[0], t[1] == v ? u : t[1], t[2] == v ? u : t[2] };
        double n[3];
        en_triangle_normal(st->s->pos, nt, n);
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len == 0)
            return EN_REFUSE_ZERO_AREA;
        /* note: measured against the face's *input* normal, not its current
         * one, so that turns cannot add up over many collapses into a fold. */
        const double *c = st->ref_normal + 3 * (size_t)f;
        if ((c[0] != 0 || c[1] != 0 || c[2] != 0) &&
            (n[0] * c[0] + n[1] * c[1] + n[2] * c[2]) / len < st->cos_bound)
            return EN_REFUSE_NORMAL;
        uint32_t x, y;
        other_corners(t, v, &x, &y);
        /* note: a face of u on x and y makes both shared neighbours, which
         * the link condition just limited to opp: other corners spare the
         * O(deg u) search. */
        if ((x == opp[0] || x == opp[1]) && (y == opp[0] || y == opp[1]) && has_face_on(st, u, x, y))
            return EN_REFUSE_DUPLICATE;
    }
    return 0;
}

/* ---- costs ---- */

static int target_less(const target *a, const target *b)
{
    return a->cost != b->cost ? a->cost < b->cost : a->u < b->u;
}

/* The area a quadric carries: each plane enters with its area times a unit
 * normal's outer product, whose trace is 1. */
static double quadric_area(const en_quadric *q)
{
    return q->a2 + q->b2 + q->c2;
}

static double pair_cost(const state *st, uint32_t w, uint32_t x)
{
    double c = quadric_eval(&st->q[w], st->s->pos + 3 * (size_t)x) + st->a->self_err[x];
    /* Huge coordinates (1e200) overflow quadrics to inf - inf = NaN, which
     * no comparison orders: such pairs go last, at +inf. */
    return c == c ? c : INFINITY;
}

/* The squared error of collapsing w onto x at quadric cost c: the cost per
 * unit of the area the merged quadric carries, an area-weighted mean squared
 * distance to its planes (en_collapse_settings.max_error). */
static double collapse_error2(const state *st, uint32_t w, uint32_t x, double c)
{
    double area = quadric_area(&st->q[w]) + quadric_area(&st->q[x]);
    double e = area > 0 ? c / area : c;
    return e > 0 ? e : 0; /* rounding can take a sum of squares below zero */
}

/* v's cheapest target among those that may receive a collapse at all
 * (EN_V_TARGET), unchecked (u NO_TARGET: none). Each neighbour is the
 * corner after v in exactly one face of v's (manifold, closed) star. */
static target cheapest_target(const state *st, uint32_t v)
{
    const arrays *a = st->a;
    target best = { 0, NO_TARGET };
    for (uint32_t i = a->off[v]; i < a->off[v + 1]; i++) {
        if (!st->falive[a->adj[i]])
            continue; /* gone in this pass */
        const uint32_t *tr = st->tri + 3 * (size_t)a->adj[i];
        uint32_t u = tr[(corner_at(tr, v) + 1) % 3];
        if (!(st->s->vflags[u] & EN_V_TARGET))
            continue;
        target t = { pair_cost(st, v, u), u };
        if (best.u == NO_TARGET || target_less(&t, &best))
            best = t;
    }
    return best;
}

/* Every target of v with its cost, cheapest first, in a->cand; @return the
 * count or -1 when out of memory. */
static int64_t rank_targets(state *st, uint32_t v)
{
    arrays *a = st->a;
    uint32_t deg = a->off[v + 1] - a->off[v];
    if (en_grow((void **)&a->cand, &a->cap_cand, deg ? deg : 1, sizeof *a->cand))
        return -1;
    target *cand = a->cand;
    uint32_t n = 0;
    for (uint32_t i = a->off[v]; i < a->off[v + 1]; i++) {
        if (!st->falive[a->adj[i]])
            continue; /* gone in this pass */
        const uint32_t *t = st->tri + 3 * (size_t)a->adj[i];
        uint32_t u = t[(corner_at(t, v) + 1) % 3];
        cand[n++] = (target){ pair_cost(st, v, u), u };
    }
    /* insertion sort: stars are small (a vertex that absorbed a fan is the
     * rare long one) */
    for (uint32_t i = 1; i < n; i++) {
        target t = cand[i];
        uint32_t j = i;
        while (j > 0 && target_less(&t, &cand[j - 1])) {
            cand[j] = cand[j - 1];
            j--;
        }
        cand[j] = t;
    }
    return n;
}

/*
 * v's cheapest valid target into *out (u NO_TARGET: none, with the reasons
 * in a->refused[v]). Targets locked in this pass cannot be checked (their
 * lists are stale): meeting one before a valid target returns 1, "ask
 * again next pass". @return 0, 1, or -1 when out of memory.
 */
static int cheapest_valid(state *st, uint32_t v, target *out)
{
    int64_t n = rank_targets(st, v);
    if (n < 0)
        return -1;
    uint8_t reasons = 0;
    out->u = NO_TARGET;
    for (int64_t i = 0; i < n; i++) {
        target t = st->a->cand[i];
        if (st->a->flag[t.u] & F_LOCKED)
            return 1;
        int why = check_collapse(st, v, t.u);
        if (why == 0) {
            *out = t;
            st->a->refused[v] = 0;
            return 0;
        }
        reasons |= (uint8_t)why;
    }
    st->a->refused[v] = reasons;
    return 0;
}

/* Is v's cached evaluation still what an evaluation now would find: has no
 * collapse since changed v's star or a neighbour's star or quadric? */
static int eval_holds(const state *st, uint32_t v)
{
    const arrays *a = st->a;
    uint32_t at = a->eval_at[v];
    if (at == 0 || a->changed_at[v] >= at)
        return 0;
    for (uint32_t i = a->off[v]; i < a->off[v + 1]; i++) {
        if (!st->falive[a->adj[i]])
            continue; /* gone in this pass */
        const uint32_t *t = st->tri + 3 * (size_t)a->adj[i];
        if (a->changed_at[t[0]] >= at || a->changed_at[t[1]] >= at || a->changed_at[t[2]] >= at)
            return 0;
    }
    return 1;
}

static void cache_eval(state *st, uint32_t v, uint8_t what, target t)
{
    st->a->eval_at[v] = st->seq + 1;
    st->a->eval[v] = what;
    st->a->target[v] = t.u;
    st->a->cost[v] = t.cost;
}

/* ---- collapsing ---- */

/* v onto u (both unlocked, the collapse checked): v's faces on u go, its
 * others take u for v. v and u are locked for the rest of the pass (u's
 * list lacks v's faces); every vertex of v's star is stamped as changed,
 * which is what cached evaluations are tested against. */
static void do_collapse(state *st, uint32_t v, uint32_t u)
{
    arrays *a = st->a;
    uint32_t seq = ++st->seq;
    for (uint32_t i = a->off[v]; i < a->off[v + 1]; i++) {
        if (!st->falive[a->adj[i]])
            continue; /* gone in this pass */
        uint32_t f = a->adj[i];
        uint32_t *t = st->tri + 3 * (size_t)f;
        if (has_corner(t, u)) {
            st->falive[f] = 0;
            st->faces_alive--;
        }
        for (int k = 0; k < 3; k++) {
            a->changed_at[t[k]] = seq;
            if (t[k] == v)
                t[k] = u;
        }
    }
    a->flag[v] |= F_LOCKED;
    a->flag[u] |= F_LOCKED;
    st->valive[v] = 0;
    a->flag[v] &= (uint8_t)~(F_ALIVE | F_ACTIVE);
    st->vertices_alive--;
    st->given_up += st->tier[v] == 2;
    quadric_add(&st->q[u], &st->q[v]);
    a->self_err[u] = quadric_eval(&st->q[u], st->s->pos + 3 * (size_t)u);
}

/* Every vertex's quadric from the faces alive now, as
 * en_quadrics_from_faces() takes them from the input's (the reference
 * normals of the normal bound stay the input's). Every cached evaluation
 * goes with them. */
static void refresh_quadrics(state *st)
{
    const en_slab *s = st->s;
    memset(st->q, 0, (size_t)s->nv * sizeof *st->q);
    for (uint32_t i = 0; i < st->nlive; i++) {
        const uint32_t *t = st->tri + 3 * (size_t)st->a->live[i];
        en_quadric k;
        double un[3];
        face_quadric(s->pos, t, &k, un);
        for (int j = 0; j < 3; j++)
            quadric_add(&st->q[t[j]], &k);
    }
    for (uint32_t v = 0; v < s->nv; v++) {
        st->a->self_err[v] = quadric_eval(&st->q[v], s->pos + 3 * (size_t)v);
        st->a->eval_at[v] = 0;
    }
}

static int limits_met(const state *st)
{
    return (st->keep_faces && st->faces_alive <= st->keep_faces) ||
           (st->keep_vertices && st->vertices_alive <= st->keep_vertices);
}

/* How many collapses the limits still ask for (UINT64_MAX: no limit). */
static uint64_t collapses_wanted(const state *st)
{
    uint64_t want = UINT64_MAX;
    if (st->keep_faces)
        want = (st->faces_alive - st->keep_faces + 1) / 2;
    if (st->keep_vertices && st->vertices_alive - st->keep_vertices < want)
        want = st->vertices_alive - st->keep_vertices;
    return want;
}

/*
 * This pass's candidates: every active vertex's cheapest target (its
 * cached evaluation when that still holds), those above the ceiling left
 * out, in a->order by cost bucket (a stable counting sort: within a bucket,
 * by vertex). The targets are ranked in one sweep over the faces: each
 * neighbour of v is the corner after v in exactly one face of its star, so
 * the sweep prices every pair once and reads the faces in order.
 * @return the count; *above: a vertex waits above the ceiling.
 */
static uint32_t gather(state *st, int *above)
{
    arrays *a = st->a;
    const uint8_t *vflags = st->s->vflags;
    for (uint32_t i = 0; i < st->nverts; i++) {
        uint32_t v = a->verts[i];
        uint8_t fl = a->flag[v] & (uint8_t)~(F_LOCKED | F_CHECKED | F_RANK);
        if (fl & F_ACTIVE) {
            if (eval_holds(st, v)) {
                fl |= a->eval[v] == E_VALID ? F_CHECKED : 0;
            } else {
                a->eval_at[v] = 0;
                a->target[v] = NO_TARGET;
                fl |= F_RANK;
            }
        }
        a->flag[v] = fl;
    }
    for (uint32_t i = 0; i < st->nlive; i++) {
        const uint32_t *t = st->tri + 3 * (size_t)a->live[i];
        for (int k = 0; k < 3; k++) {
            uint32_t v = t[k], u = t[k == 2 ? 0 : k + 1];
            if (!(a->flag[v] & F_RANK) || !(vflags[u] & EN_V_TARGET))
                continue;
            double c = pair_cost(st, v, u);
            if (a->target[v] == NO_TARGET || c < a->cost[v] || (c == a->cost[v] && u < a->target[v]))
                a->cost[v] = c, a->target[v] = u;
        }
    }
    uint32_t n = 0;
    memset(a->hist, 0, (EN_COST_BUCKETS + 1) * sizeof *a->hist);
    for (uint32_t i = 0; i < st->nverts; i++) {
        uint32_t v = a->verts[i];
        if (!(a->flag[v] & (F_RANK | F_CHECKED)) || a->target[v] == NO_TARGET)
            continue;
        if (a->cost[v] > st->ceiling) {
            *above = 1;
            continue;
        }
        int b = en_cost_bucket(a->cost[v]);
        a->key[v] = (uint16_t)b;
        a->hist[b + 1]++;
        a->sorted[n++] = v; /* in vertex order for now */
    }
    for (int b = 0; b < EN_COST_BUCKETS; b++)
        a->hist[b + 1] += a->hist[b];
    for (uint32_t i = 0; i < n; i++) {
        uint32_t v = a->sorted[i];
        a->order[a->hist[a->key[v]]++] = v;
    }
    return n;
}

/*
 * One pass: the candidates in order, each collapsed when neither end is
 * locked, it is valid (or v's cheapest valid target is, still within the
 * pass), under the error bound, and the limits are unmet. The pass ends
 * after the bucket of its middle candidate, or of the candidate halfway to
 * the limits when those are nearer: what a lock deferred is ranked afresh
 * in the next pass, and the passes near the limits are short, so that the
 * last collapses are chosen from fresh costs.
 * note: measured (bench/RESULTS.md, session 13): ending a pass 1.5x above
 * that bucket, or at the candidate that meets the limits, raised the mean
 * error at equal faces by 3-4% (up to 17% on fandisk), against the exact
 * order; this rule is within 1% of it, at 25 passes on a slab-sized mesh.
 * @return 0, EPSNET_ENOMEM or EPSNET_EINTR; *done: collapses this pass.
 */
static int collapse_pass(state *st, uint32_t n, const en_collapse_settings *cs, uint64_t refresh, uint64_t *done)
{
    arrays *a = st->a;
    uint64_t want = collapses_wanted(st), k = (want < n ? want : n) / 2;
    int bound = a->key[a->order[k]];
    uint64_t before = st->seq;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t v = a->order[i], u = a->target[v];
        if (a->key[v] > bound || limits_met(st) || (refresh && st->faces_alive <= refresh))
            break;
        if ((a->flag[v] | a->flag[u]) & F_LOCKED)
            continue;
        target t = { a->cost[v], u };
        if (!(a->flag[v] & F_CHECKED) && check_collapse(st, v, u)) {
            /* its cheapest target is refused: its cheapest valid one,
             * kept for later passes while nothing near v changes */
            int r = cheapest_valid(st, v, &t);
            if (r < 0)
                return EPSNET_ENOMEM;
            if (r > 0)
                continue;
            cache_eval(st, v, t.u == NO_TARGET ? E_REFUSED : E_VALID, t);
            if (t.u == NO_TARGET || t.cost > st->ceiling || en_cost_bucket(t.cost) > bound)
                continue;
        }
        if (st->by_error && collapse_error2(st, v, t.u, t.cost) > st->max_cost) {
            /* over the error bound: v waits until a collapse near it
             * changes its quadric or its neighbours' */
            st->stopped_by_error = 1;
            cache_eval(st, v, E_OVER_ERROR, t);
            continue;
        }
        do_collapse(st, v, t.u);
        st->top_cost = t.cost > st->top_cost ? t.cost : st->top_cost;
        if (cs->progress && (st->seq & 1023) == 0) {
            atomic_store_explicit(cs->progress, st->seq, memory_order_relaxed);
            if (cs->stop && atomic_load_explicit(cs->stop, memory_order_relaxed))
                return EPSNET_EINTR; /* cancelled: the caller drops the slab */
        }
    }
    *done = st->seq - before;
    return 0;
}

static void arrays_destroy(void *item)
{
    arrays *a = item;
    en_free(a->off);
    en_free(a->adj);
    en_free(a->live);
    en_free(a->verts);
    en_free(a->order);
    en_free(a->sorted);
    en_free(a->hist);
    en_free(a->self_err);
    en_free(a->cost);
    en_free(a->target);
    en_free(a->changed_at);
    en_free(a->eval_at);
    en_free(a->mark);
    en_free(a->key);
    en_free(a->flag);
    en_free(a->eval);
    en_free(a->refused);
    en_free(a->cand);
    en_free(a);
}

int en_collapse_arrays_new(en_ctxpool **pool)
{
    return en_ctxpool_new(pool, arrays_destroy);
}

/* Every array of a sized for the slab s (grown, never shrunk). */
static int arrays_size(arrays *a, const en_slab *s)
{
    size_t nv = (size_t)s->nv + 1, nt = (size_t)s->nt + 1;
    return en_grow((void **)&a->off, &a->cap_off, nv + 1, sizeof *a->off) ||
           en_grow((void **)&a->adj, &a->cap_adj, 3 * nt, sizeof *a->adj) ||
           en_grow((void **)&a->live, &a->cap_live, nt, sizeof *a->live) ||
           en_grow((void **)&a->verts, &a->cap_verts, nv, sizeof *a->verts) ||
           en_grow((void **)&a->order, &a->cap_order, nv, sizeof *a->order) ||
           en_grow((void **)&a->sorted, &a->cap_sorted, nv, sizeof *a->sorted) ||
           en_grow((void **)&a->hist, &a->cap_hist, EN_COST_BUCKETS + 1, sizeof *a->hist) ||
           en_grow((void **)&a->self_err, &a->cap_self_err, nv, sizeof *a->self_err) ||
           en_grow((void **)&a->cost, &a->cap_cost, nv, sizeof *a->cost) ||
           en_grow((void **)&a->target, &a->cap_target, nv, sizeof *a->target) ||
           en_grow((void **)&a->changed_at, &a->cap_changed_at, nv, sizeof *a->changed_at) ||
           en_grow((void **)&a->eval_at, &a->cap_eval_at, nv, sizeof *a->eval_at) ||
           en_grow((void **)&a->mark, &a->cap_mark, nv, sizeof *a->mark) ||
           en_grow((void **)&a->key, &a->cap_key, nv, sizeof *a->key) ||
           en_grow((void **)&a->flag, &a->cap_flag, nv, sizeof *a->flag) ||
           en_grow((void **)&a->eval, &a->cap_eval, nv, sizeof *a->eval) ||
           en_grow((void **)&a->refused, &a->cap_refused, nv, sizeof *a->refused)
               ? EPSNET_ENOMEM
               : 0;
}

int en_collapse_slab(const en_slab *s, const uint8_t *removable, en_quadric *q, const double *ref_normal,
                     const en_collapse_settings *cs, uint8_t *face_alive, uint8_t *vertex_alive,
                     uint32_t *tri_out, en_collapse_counts *counts, en_ctxpool *pool)
{
    arrays *a = en_ctxpool_take(pool);
    if (!a && !(a = en_calloc(1, sizeof *a)))
        return EPSNET_ENOMEM;
    int rc = arrays_size(a, s);
    if (rc)
        goto out;
    state st = { 0 };
    st.s = s;
    st.a = a;
    st.q = q;
    st.cos_bound = cos(cs->max_normal_dev_deg * (M_PI / 180.0));
    st.tri = tri_out;
    st.falive = face_alive;
    st.valive = vertex_alive;
    st.ref_normal = ref_normal;
    memcpy(st.tri, s->tri, 3 * sizeof *st.tri * (size_t)s->nt);
    memset(st.falive, 1, s->nt);
    memset(st.valive, 1, s->nv);
    for (uint32_t f = 0; f < s->nt; f++)
        a->live[f] = f;
    st.nlive = s->nt;
    for (uint32_t v = 0; v < s->nv; v++) {
        a->self_err[v] = quadric_eval(&q[v], s->pos + 3 * (size_t)v);
        a->changed_at[v] = a->eval_at[v] = a->mark[v] = 0;
        a->flag[v] = (uint8_t)(F_ALIVE | (removable[v] == 1 ? F_ACTIVE : 0));
        a->refused[v] = 0;
        a->verts[v] = v;
    }
    st.nverts = s->nv;
    st.tier = removable;
    st.by_error = cs->by_error;
    st.max_cost = cs->by_error && cs->max_error >= 0 ? cs->max_error * cs->max_error : INFINITY;
    st.keep_faces = cs->keep_faces;
    st.keep_vertices = cs->keep_vertices;
    st.ceiling = cs->cost_ceiling != 0 ? cs->cost_ceiling : INFINITY;
    st.faces_alive = s->nt;
    int tier2 = 0, met = 0, stale = 0;
    uint64_t refresh = cs->refresh_faces, done = 0;
    rebuild(&st);
    st.vertices_alive = st.nverts; /* every vertex on a face */
    while (rc == 0) {
        if (stale)
            rebuild(&st);
        stale = 0;
        if ((met = limits_met(&st)) != 0)
            break;
        if (refresh && st.faces_alive <= refresh) {
            /* every price changes: every vertex is ranked again */
            refresh = 0;
            refresh_quadrics(&st);
        }
        int above = 0;
        uint32_t n = gather(&st, &above);
        if (n == 0) {
            if (above) {
                /* the cheapest collapse left is above the round's
                 * ceiling: the round ends here, the rest wait for the
                 * next one */
                st.stopped_by_ceiling = 1;
                break;
            }
            if (tier2 || !(st.keep_faces || st.keep_vertices))
                break;
            /* The first tier is spent and the target is not met: the
             * second tier joins, cheapest first like the rest. */
            tier2 = 1;
            for (uint32_t i = 0; i < st.nverts; i++)
                a->flag[a->verts[i]] |= removable[a->verts[i]] == 2 ? F_ACTIVE : 0;
            continue;
        }
        rc = collapse_pass(&st, n, cs, refresh, &done);
        stale = done > 0;
    }
    if (rc == 0) {
        if (stale)
            rebuild(&st); /* the lists as the mesh ends, for what follows */
        for (uint32_t i = 0; i < st.nverts; i++)
            a->flag[a->verts[i]] &= (uint8_t)~F_LOCKED;
        memset(counts, 0, sizeof *counts);
        counts->collapses = st.seq;
        counts->given_up = st.given_up;
        counts->faces_left = st.faces_alive;
        counts->vertices_left = st.vertices_alive;
        counts->stopped_by_error = st.stopped_by_error;
        counts->top_cost = st.top_cost;
        if (cs->bucket_of) {
            /* what waits: each first-tier vertex's cheapest collapse (its
             * cheapest valid one where that is known and still holds) */
            for (uint32_t v = 0; v < s->nv; v++)
                cs->bucket_of[v] = EN_COST_NONE;
            for (uint32_t i = 0; i < st.nverts; i++) {
                uint32_t v = st.a->verts[i];
                if (removable[v] != 1 && removable[v] != EN_TIER_PRICED)
                    continue;
                target t = { 0, NO_TARGET };
                if (removable[v] == 1 && eval_holds(&st, v)) {
                    if (a->eval[v] == E_VALID)
                        t = (target){ a->cost[v], a->target[v] };
                } else {
                    t = cheapest_target(&st, v);
                }
                if (t.u != NO_TARGET)
                    cs->bucket_of[v] = (uint16_t)en_cost_bucket(t.cost);
            }
        }
        for (uint32_t i = 0; i < st.nverts && rc == 0; i++) {
            uint32_t v = st.a->verts[i];
            if (!(a->flag[v] & F_ACTIVE))
                continue;
            counts->remaining++;
            if (met || st.stopped_by_ceiling)
                continue; /* left by the target, not refused */
            target t;
            if (cheapest_valid(&st, v, &t) < 0) {
                rc = EPSNET_ENOMEM;
                break;
            }
            for (int k = 0; k < EN_REFUSE_KINDS; k++)
                counts->refused[k] += (a->refused[v] >> k) & 1;
        }
    }
out:
    /* the arrays, grown or not, back to the pool (or freed with the call's own) */
    if (pool)
        en_ctxpool_give(pool, a);
    else
        arrays_destroy(a);
    return rc;
}

int en_slab_compact(const en_slab *s, const uint32_t *tri, const uint8_t *face_alive, const en_quadric *q,
                    const double *ref_normal, en_slab *out, en_quadric **q_out, double **ref_out)
{
    en_slab_init(out);
    *q_out = NULL;
    *ref_out = NULL;
    int64_t *map = en_malloc(((size_t)s->nv + 1) * sizeof *map);
    if (!map)
        return -1;
    for (uint32_t v = 0; v < s->nv; v++)
        map[v] = -1;
    for (uint32_t f = 0; f < s->nt; f++)
        if (face_alive[f])
            for (int k = 0; k < 3; k++)
                map[tri[3 * (size_t)f + k]] = 0;
    en_quadric *nq = en_malloc(((size_t)s->nv + 1) * sizeof *nq);
    int rc = nq ? 0 : -1;
    for (uint32_t v = 0; v < s->nv && rc == 0; v++) {
        if (map[v] < 0)
            continue;
        uint8_t keep = s->vflags[v] & (EN_V_OWNED | EN_V_TARGET);
        map[v] = en_slab_add_vertex(out, s->gid[v], s->pos + 3 * (size_t)v, keep);
        if (map[v] < 0)
            rc = -1;
        else
            nq[map[v]] = q[v];
    }
    double *nr = en_malloc(3 * sizeof *nr * ((size_t)s->nt + 1));
    if (!nr)
        rc = -1;
    for (uint32_t f = 0; f < s->nt && rc == 0; f++)
        if (face_alive[f]) {
            memcpy(nr + 3 * (size_t)out->nt, ref_normal + 3 * (size_t)f, 3 * sizeof *nr);
            rc = en_slab_add_face(out, (uint32_t)map[tri[3 * (size_t)f]], (uint32_t)map[tri[3 * (size_t)f + 1]],
                                  (uint32_t)map[tri[3 * (size_t)f + 2]]);
        }
    if (rc == 0)
        rc = en_slab_build_stars(out);
    en_free(map);
    if (rc) {
        en_free(nq);
        en_free(nr);
        en_slab_free(out);
        return -1;
    }
    *q_out = nq;
    *ref_out = nr;
    return 0;
}
