/*
 * The two emitters.
 *
 * Sorted (docs/architecture.md §6): rows are visited by their stream-axis value
 * (ties by row index), columns in order, so vertices come in non-decreasing
 * axis order. A triangle is emitted right after the last of its corners,
 * and a vertex is finalized right after its last triangle: each live vertex
 * holds a count of its triangles not yet emitted, set from the topology
 * when its row is emitted. Working memory: the row order (one entry per
 * row), a few cached rows of positions and diagonals, and the counts of the
 * rows still live, so O(rows + columns) = O(sqrt(faces)).
 *
 * Shuffled: a keyed bijection of the vertex records' indices and another of
 * the face indices; each record is computed from its index. With an atlas
 * the records are numbered row by row (each row's first record kept, one
 * entry per row), a vertex's copies together, so a record finds its vertex
 * and copy by two searches.
 */
#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "common/error.h"
#include "gen/gen_internal.h"

#define ROW_SLOTS 8
#define STRIP_SLOTS 8

typedef struct row_slot {
    uint64_t row;      /* UINT64_MAX when empty */
    uint64_t tick;
    float *xyz;        /* 3 per column */
} row_slot;

typedef struct strip_slot {
    uint64_t strip;
    uint64_t tick;
    uint8_t *diag;     /* one per quad */
} strip_slot;

typedef struct streamer {
    const en_gen_grid *g;
    en_gen_emit_fn emit;
    void *ctx;
    epsnet_error *err;

    uint64_t *rank_of;   /* row -> position in emission order */
    uint64_t *first_out; /* row -> output index of its column 0 */
    uint32_t **remaining;/* row -> triangles still to come per column (live rows only) */
    uint64_t *row_live;  /* row -> columns not yet finalized */

    row_slot rows[ROW_SLOTS];
    strip_slot strips[STRIP_SLOTS];
    uint64_t tick;

    uint64_t bytes, peak_bytes;
    uint64_t live, peak_live;
} streamer;

static void account(streamer *st, int64_t delta)
{
    st->bytes = (uint64_t)((int64_t)st->bytes + delta);
    if (st->bytes > st->peak_bytes)
        st->peak_bytes = st->bytes;
}

static const float *row_xyz(streamer *st, uint64_t row)
{
    row_slot *victim = &st->rows[0];
    for (int i = 0; i < ROW_SLOTS; i++) {
        if (st->rows[i].row == row) {
            st->rows[i].tick = ++st->tick;
            return st->rows[i].xyz;
        }
        if (st->rows[i].tick < victim->tick)
            victim = &st->rows[i];
    }
    uint64_t n = en_gen_row_size(st->g, row);
    for (uint64_t c = 0; c < n; c++)
        en_gen_point_f(st->g, row, c, victim->xyz + 3 * c);
    victim->row = row;
    victim->tick = ++st->tick;
    return victim->xyz;
}

static const uint8_t *strip_diag(streamer *st, uint64_t strip)
{
    strip_slot *victim = &st->strips[0];
    for (int i = 0; i < STRIP_SLOTS; i++) {
        if (st->strips[i].strip == strip) {
            st->strips[i].tick = ++st->tick;
            return st->strips[i].diag;
        }
        if (st->strips[i].tick < victim->tick)
            victim = &st->strips[i];
    }
    const en_gen_grid *g = st->g;
    uint64_t a, b;
    en_gen_strip_rows(g, strip, &a, &b);
    /* note: fetch b second; a stays cached because it was just used */
    const float *pa = row_xyz(st, a);
    const float *pb = row_xyz(st, b);
    uint64_t na = en_gen_row_size(g, a), nb = en_gen_row_size(g, b);
    uint64_t quads = en_gen_strip_quads(g, strip);
    for (uint64_t q = 0; q < quads; q++) {
        uint64_t q1 = q + 1 == g->ncols ? 0 : q + 1;
        const float *a0 = pa + 3 * (na == 1 ? 0 : q), *a1 = pa + 3 * (na == 1 ? 0 : q1);
        const float *b0 = pb + 3 * (nb == 1 ? 0 : q), *b1 = pb + 3 * (nb == 1 ? 0 : q1);
        victim->diag[q] = (uint8_t)(na == 1 || nb == 1 ? 0 : en_gen_quad_diag(g, strip, q, a0, a1, b0, b1));
    }
    victim->strip = strip;
    victim->tick = ++st->tick;
    return victim->diag;
}

/* Strips touching row r: lower (r is its upper row) then upper. */
static int row_strips(const en_gen_grid *g, uint64_t r, uint64_t out[2])
{
    int n = 0;
    if (r > 0)
        out[n++] = r - 1;
    else if (g->wrap_rows)
        out[n++] = g->nrows - 1;
    if (r + 1 < g->nrows || g->wrap_rows)
        out[n++] = r;
    return n;
}

/* Quads of a strip that touch column col of a non-pole row. */
static int quads_at(const en_gen_grid *g, uint64_t strip, uint64_t col, uint64_t out[2])
{
    uint64_t quads = en_gen_strip_quads(g, strip);
    int n = 0;
    if (col > 0)
        out[n++] = col - 1;
    else if (!g->open_cols)
        out[n++] = g->ncols - 1;
    if (col < quads)
        out[n++] = col;
    return n;
}

static int emit_record(streamer *st, epsnet_record_kind kind, uint64_t a, uint64_t b, uint64_t c,
                       const float *xyz, const uint8_t *attr)
{
    epsnet_record rec;
    memset(&rec, 0, sizeof rec);
    rec.attr = attr;
    rec.kind = kind;
    rec.v[0] = a;
    rec.v[1] = b;
    rec.v[2] = c;
    if (xyz) {
        rec.xyz[0] = xyz[0];
        rec.xyz[1] = xyz[1];
        rec.xyz[2] = xyz[2];
    }
    return st->emit(st->ctx, &rec, st->err);
}

/* The record of v that the faces of quad q of strip use (its copy in
 * that quad's chart, gen_atlas.c). */
static uint64_t out_index(const streamer *st, en_gen_vtx v, uint64_t strip, uint64_t q)
{
    return st->first_out[v.row] + en_gen_col_offset(st->g, v) + en_gen_copy_of(st->g, v, strip, q);
}

/* Start row r: count each column's triangles. */
static int open_row(streamer *st, uint64_t r)
{
    const en_gen_grid *g = st->g;
    uint64_t n = en_gen_row_size(g, r);
    uint32_t *rem = en_calloc(n, sizeof *rem);
    if (!rem)
        return en_error_set(st->err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory generating a mesh");
    account(st, (int64_t)(n * sizeof *rem));
    st->remaining[r] = rem;
    st->row_live[r] = n;
    uint64_t strips[2];
    int ns = row_strips(g, r, strips);
    for (int s = 0; s < ns; s++) {
        if (n == 1) {
            rem[0] += (uint32_t)en_gen_strip_quads(g, strips[s]);
            continue;
        }
        const uint8_t *diag = strip_diag(st, strips[s]);
        for (uint64_t c = 0; c < n; c++) {
            uint64_t qs[2];
            int nq = quads_at(g, strips[s], c, qs);
            for (int k = 0; k < nq; k++) {
                en_gen_vtx tri[2][3];
                int nt = en_gen_quad_tris(g, strips[s], qs[k], diag[qs[k]], tri);
                for (int t = 0; t < nt; t++)
                    for (int v = 0; v < 3; v++)
                        if (tri[t][v].row == r && tri[t][v].col == c)
                            rem[c]++;
            }
        }
    }
    return 0;
}

static int retire_corner(streamer *st, en_gen_vtx v)
{
    uint32_t *rem = st->remaining[v.row];
    if (--rem[v.col] > 0)
        return 0;
    uint64_t first = st->first_out[v.row] + en_gen_col_offset(st->g, v), copies = en_gen_copies(st->g, v);
    int rc = 0;
    for (uint64_t k = 0; k < copies && rc == 0; k++)
        rc = emit_record(st, EPSNET_REC_FINALIZE, first + k, 0, 0, NULL, NULL);
    st->live -= copies;
    if (--st->row_live[v.row] == 0) {
        account(st, -(int64_t)(en_gen_row_size(st->g, v.row) * sizeof *rem));
        en_free(rem);
        st->remaining[v.row] = NULL;
    }
    return rc;
}

static int emit_triangle(streamer *st, const en_gen_vtx tri[3], uint64_t strip, uint64_t q)
{
    int rc = emit_record(st, EPSNET_REC_TRIANGLE, out_index(st, tri[0], strip, q),
                         out_index(st, tri[1], strip, q), out_index(st, tri[2], strip, q), NULL, NULL);
    for (int v = 0; v < 3 && rc == 0; v++)
        rc = retire_corner(st, tri[v]);
    return rc;
}

/* Triangles whose last corner is (r, col): those of strips whose other row
 * came earlier, with col the largest column among their corners in row r. */
static int emit_triangles_at(streamer *st, uint64_t r, uint64_t col)
{
    const en_gen_grid *g = st->g;
    uint64_t strips[2];
    int ns = row_strips(g, r, strips);
    int pole = en_gen_row_size(g, r) == 1;
    for (int s = 0; s < ns; s++) {
        uint64_t a, b;
        en_gen_strip_rows(g, strips[s], &a, &b);
        uint64_t other = a == r ? b : a;
        if (st->rank_of[other] > st->rank_of[r])
            continue;
        const uint8_t *diag = strip_diag(st, strips[s]);
        uint64_t qs[2], all = en_gen_strip_quads(g, strips[s]);
        int nq = pole ? 0 : quads_at(g, strips[s], col, qs);
        for (uint64_t k = 0; k < (pole ? all : (uint64_t)nq); k++) {
            uint64_t q = pole ? k : qs[k];
            en_gen_vtx tri[2][3];
            int nt = en_gen_quad_tris(g, strips[s], q, diag[q], tri);
            for (int t = 0; t < nt; t++) {
                uint64_t last = 0;
                for (int v = 0; v < 3; v++)
                    if (tri[t][v].row == r && tri[t][v].col > last)
                        last = tri[t][v].col;
                if (last != col)
                    continue;
                int rc = emit_triangle(st, tri[t], strips[s], q);
                if (rc)
                    return rc;
            }
        }
    }
    return 0;
}

typedef struct row_key {
    float axis;
    uint64_t row;
} row_key;

static int row_key_cmp(const void *pa, const void *pb)
{
    const row_key *a = pa, *b = pb;
    if (a->axis != b->axis)
        return a->axis < b->axis ? -1 : 1;
    return a->row < b->row ? -1 : a->row > b->row;
}

static void streamer_free(streamer *st)
{
    if (st->remaining)
        for (uint64_t r = 0; r < st->g->nrows; r++)
            en_free(st->remaining[r]);
    en_free(st->remaining);
    en_free(st->row_live);
    en_free(st->rank_of);
    en_free(st->first_out);
    for (int i = 0; i < ROW_SLOTS; i++)
        en_free(st->rows[i].xyz);
    for (int i = 0; i < STRIP_SLOTS; i++)
        en_free(st->strips[i].diag);
}

static int streamer_init(streamer *st, const en_gen_grid *g, row_key **order)
{
    uint64_t R = g->nrows, C = g->ncols;
    st->rank_of = en_calloc(R, sizeof *st->rank_of);
    st->first_out = en_calloc(R, sizeof *st->first_out);
    st->remaining = en_calloc(R, sizeof *st->remaining);
    st->row_live = en_calloc(R, sizeof *st->row_live);
    *order = en_calloc(R, sizeof **order);
    int ok = st->rank_of && st->first_out && st->remaining && st->row_live && *order;
    account(st, (int64_t)(R * (3 * sizeof(uint64_t) + sizeof(void *) + sizeof(row_key))));
    for (int i = 0; i < ROW_SLOTS && ok; i++) {
        st->rows[i].row = UINT64_MAX;
        ok = (st->rows[i].xyz = en_malloc(3 * C * sizeof(float))) != NULL;
        account(st, (int64_t)(3 * C * sizeof(float)));
    }
    for (int i = 0; i < STRIP_SLOTS && ok; i++) {
        st->strips[i].strip = UINT64_MAX;
        ok = (st->strips[i].diag = en_malloc(C)) != NULL;
        account(st, (int64_t)C);
    }
    if (!ok)
        return en_error_set(st->err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory generating a mesh");
    for (uint64_t r = 0; r < R; r++) {
        float p[3];
        en_gen_point_f(g, r, 0, p);
        (*order)[r].axis = p[g->axis];
        (*order)[r].row = r;
    }
    qsort(*order, R, sizeof **order, row_key_cmp);
    uint64_t out = 0;
    for (uint64_t k = 0; k < R; k++) {
        uint64_t r = (*order)[k].row;
        st->rank_of[r] = k;
        st->first_out[r] = out;
        out += en_gen_row_records(g, r);
    }
    return 0;
}

int en_gen_emit_sorted(const en_gen_grid *g, en_gen_emit_fn emit, void *ctx, en_gen_stats *stats,
                       epsnet_error *err)
{
    streamer st;
    memset(&st, 0, sizeof st);
    st.g = g;
    st.emit = emit;
    st.ctx = ctx;
    st.err = err;
    row_key *order = NULL;
    int rc = streamer_init(&st, g, &order);
    for (uint64_t k = 0; k < g->nrows && rc == 0; k++) {
        uint64_t r = order[k].row;
        rc = open_row(&st, r);
        uint64_t n = en_gen_row_size(g, r);
        for (uint64_t c = 0; c < n && rc == 0; c++) {
            const float *xyz = row_xyz(&st, r) + 3 * c;
            en_gen_vtx v = { r, c };
            uint64_t copies = en_gen_copies(g, v);
            for (uint64_t cp = 0; cp < copies && rc == 0; cp++) {
                float uv[2];
                const uint8_t *attr = NULL;
                if (g->chart_rows) {
                    en_gen_copy_uv(g, v, cp, uv);
                    attr = (const uint8_t *)uv;
                }
                rc = emit_record(&st, EPSNET_REC_VERTEX, 0, 0, 0, xyz, attr);
            }
            st.live += copies;
            if (st.live > st.peak_live)
                st.peak_live = st.live;
            if (rc == 0)
                rc = emit_triangles_at(&st, r, c);
        }
    }
    if (rc == 0 && st.live != 0)
        rc = en_error_set(err, EPSNET_EINTERNAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                          "generator left %llu vertices unfinalized", (unsigned long long)st.live);
    if (stats) {
        stats->peak_bytes = st.peak_bytes;
        stats->peak_live = st.peak_live;
    }
    en_free(order);
    streamer_free(&st);
    return rc;
}

/* Row r's first record, numbered row by row (first[R]: all of them). */
static uint64_t *records_by_row(const en_gen_grid *g)
{
    uint64_t *first = en_malloc((g->nrows + 1) * sizeof *first);
    if (!first)
        return NULL;
    first[0] = 0;
    for (uint64_t r = 0; r < g->nrows; r++)
        first[r + 1] = first[r] + en_gen_row_records(g, r);
    return first;
}

/* The vertex and the copy of record id of an atlas (numbered by
 * records_by_row). */
static en_gen_vtx record_at(const en_gen_grid *g, const uint64_t *first, uint64_t id, uint64_t *copy)
{
    uint64_t lo = 0, hi = g->nrows; /* the last row whose first record is at or before id */
    while (hi - lo > 1) {
        uint64_t mid = lo + (hi - lo) / 2;
        *(first[mid] <= id ? &lo : &hi) = mid;
    }
    en_gen_vtx v = { lo, 0 };
    uint64_t within = id - first[lo], n = en_gen_row_size(g, lo);
    uint64_t clo = 0, chi = n; /* the last column whose records start at or before within */
    while (chi - clo > 1) {
        uint64_t mid = clo + (chi - clo) / 2;
        en_gen_vtx m = { lo, mid };
        *(en_gen_col_offset(g, m) <= within ? &clo : &chi) = mid;
    }
    v.col = clo;
    *copy = within - en_gen_col_offset(g, v);
    return v;
}

int en_gen_emit_shuffled(const en_gen_grid *g, uint64_t seed, en_gen_emit_fn emit, void *ctx,
                         epsnet_error *err)
{
    /* without an atlas the records are the grid's vertices, in its own order */
    uint64_t *first = NULL;
    if (g->chart_rows && !(first = records_by_row(g)))
        return en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory generating a mesh");
    en_gen_perm vperm, fperm;
    en_gen_perm_init(&vperm, g->nrecords, seed);
    en_gen_perm_init(&fperm, g->nfaces, ~seed);
    epsnet_record rec;
    memset(&rec, 0, sizeof rec);
    rec.kind = EPSNET_REC_VERTEX;
    int rc = 0;
    float uv[2];
    for (uint64_t p = 0; p < g->nrecords && rc == 0; p++) {
        uint64_t id = en_gen_perm_inv(&vperm, p), copy = 0;
        en_gen_vtx v = first ? record_at(g, first, id, &copy) : en_gen_vertex_at(g, id);
        float xyz[3];
        en_gen_point_f(g, v.row, v.col, xyz);
        for (int k = 0; k < 3; k++)
            rec.xyz[k] = xyz[k];
        if (first) {
            en_gen_copy_uv(g, v, copy, uv);
            rec.attr = (const uint8_t *)uv;
        }
        rc = emit(ctx, &rec, err);
    }
    memset(&rec, 0, sizeof rec);
    rec.kind = EPSNET_REC_TRIANGLE;
    for (uint64_t p = 0; p < g->nfaces && rc == 0; p++) {
        en_gen_vtx tri[3];
        uint64_t strip, q;
        en_gen_face_at(g, en_gen_perm_inv(&fperm, p), tri, &strip, &q);
        for (int k = 0; k < 3; k++)
            rec.v[k] = en_gen_perm_fwd(&vperm, first ? first[tri[k].row] + en_gen_col_offset(g, tri[k]) +
                                                           en_gen_copy_of(g, tri[k], strip, q)
                                                     : en_gen_vertex_id(g, tri[k]));
        rc = emit(ctx, &rec, err);
    }
    en_free(first);
    return rc;
}
