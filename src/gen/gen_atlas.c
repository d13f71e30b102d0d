/*
 * A UV atlas for the generator (settings.charts, epsnet.h §5), like a
 * photogrammetry texture: the grid of quads is cut into charts of
 * chart_rows strips by chart_cols quads, and each chart gets its own tile of
 * the unit square, laid out on a T x T board (T = ceil(sqrt(charts))) with
 * a margin, so no two charts share texture space. Inside a chart, u and v
 * follow the grid's columns and rows, so the texture bends with the shape.
 *
 * A vertex where charts meet is one record per chart (its copies, as an OBJ
 * reader makes them from `vt`): two along a seam, four where four charts
 * meet, one per chart column at a pole. Copies are numbered from the chart
 * that a face uses at the vertex (en_gen_copy_of), so every map here is
 * O(1) and the sorted emitter still holds only a few rows.
 */
#include <math.h>

#include "gen/gen_internal.h"

void en_gen_atlas_init(en_gen_grid *g, uint64_t charts)
{
    g->chart_rows = g->chart_cols = 0;
    g->nrecords = g->nverts;
    if (charts == 0)
        return;
    uint64_t strips = en_gen_nstrips(g), quads = en_gen_strip_quads(g, 0);
    /* note: square charts in grid cells, of the side (near the square root
     * of cells per chart) whose count comes closest to the request; sqrt is
     * correctly rounded, so the cut is the same on every IEEE machine */
    double side = sqrt((double)strips * (double)quads / (double)charts);
    uint64_t k0 = side < 2 ? 1 : (uint64_t)side - 1, best = 0, best_miss = UINT64_MAX;
    for (uint64_t k = k0; k <= k0 + 3; k++) {
        uint64_t kr = k < strips ? k : strips, kc = k < quads ? k : quads;
        uint64_t n = ((strips + kr - 1) / kr) * ((quads + kc - 1) / kc);
        uint64_t miss = n > charts ? n - charts : charts - n;
        if (miss < best_miss) {
            best_miss = miss;
            best = k;
        }
    }
    g->chart_rows = best < strips ? best : strips;
    g->chart_cols = best < quads ? best : quads;
    g->ncharts_r = (strips + g->chart_rows - 1) / g->chart_rows;
    g->ncharts_c = (quads + g->chart_cols - 1) / g->chart_cols;
    uint64_t t = 1;
    while (t * t < g->ncharts_r * g->ncharts_c)
        t++;
    g->board = t;
    g->nrecords = 0;
    for (uint64_t r = 0; r < g->nrows; r++)
        g->nrecords += en_gen_row_records(g, r);
}

/* Row r is where two chart rows meet: both its strips exist and lie in
 * different chart rows. */
static int row_seam(const en_gen_grid *g, uint64_t r)
{
    if (en_gen_is_pole(g, r))
        return 0;
    if (r == 0)
        return g->wrap_rows && g->ncharts_r > 1;
    return r < en_gen_nstrips(g) && r % g->chart_rows == 0;
}

/* Column c is where two chart columns meet. */
static int col_seam(const en_gen_grid *g, uint64_t c)
{
    if (c == 0)
        return !g->open_cols && g->ncharts_c > 1;
    return c < en_gen_strip_quads(g, 0) && c % g->chart_cols == 0;
}

uint64_t en_gen_copies(const en_gen_grid *g, en_gen_vtx v)
{
    if (!g->chart_rows)
        return 1;
    if (en_gen_is_pole(g, v.row))
        return g->ncharts_c;
    return (uint64_t)(1 + row_seam(g, v.row)) * (uint64_t)(1 + col_seam(g, v.col));
}

uint64_t en_gen_row_records(const en_gen_grid *g, uint64_t row)
{
    if (!g->chart_rows)
        return en_gen_row_size(g, row);
    if (en_gen_is_pole(g, row))
        return g->ncharts_c;
    uint64_t col_seams = (uint64_t)col_seam(g, 0) + (en_gen_strip_quads(g, 0) - 1) / g->chart_cols;
    return (uint64_t)(1 + row_seam(g, row)) * (g->ncols + col_seams);
}

uint64_t en_gen_col_offset(const en_gen_grid *g, en_gen_vtx v)
{
    if (!g->chart_rows)
        return v.col;
    if (en_gen_is_pole(g, v.row) || v.col == 0)
        return 0;
    uint64_t seams_before = (uint64_t)col_seam(g, 0) + (v.col - 1) / g->chart_cols;
    return (uint64_t)(1 + row_seam(g, v.row)) * (v.col + seams_before);
}

uint64_t en_gen_copy_of(const en_gen_grid *g, en_gen_vtx v, uint64_t strip, uint64_t q)
{
    if (!g->chart_rows)
        return 0;
    if (en_gen_is_pole(g, v.row))
        return q / g->chart_cols;
    int cs = col_seam(g, v.col);
    uint64_t rowbit = row_seam(g, v.row) && strip == v.row;
    uint64_t colbit = cs && q == v.col;
    return rowbit * (uint64_t)(1 + cs) + colbit;
}

void en_gen_copy_uv(const en_gen_grid *g, en_gen_vtx v, uint64_t copy, float uv[2])
{
    uint64_t strips = en_gen_nstrips(g), quads = en_gen_strip_quads(g, 0);
    uint64_t s, q;
    double ru, cu;   /* the vertex's row and column, unwrapped into the face's chart */
    if (en_gen_is_pole(g, v.row)) {
        s = v.row == 0 ? 0 : strips - 1;
        uint64_t cc = copy, width = quads - cc * g->chart_cols;
        if (width > g->chart_cols)
            width = g->chart_cols;
        q = cc * g->chart_cols;
        ru = v.row == 0 ? 0.0 : (double)strips;
        cu = (double)q + 0.5 * (double)width;
    } else {
        int rs = row_seam(g, v.row), cs = col_seam(g, v.col);
        uint64_t rowbit = copy / (uint64_t)(1 + cs), colbit = copy % (uint64_t)(1 + cs);
        if (rs)
            s = rowbit ? v.row : (v.row == 0 ? strips - 1 : v.row - 1);
        else
            s = v.row < strips ? v.row : v.row - 1;
        if (cs)
            q = colbit ? v.col : (v.col == 0 ? quads - 1 : v.col - 1);
        else
            q = v.col < quads ? v.col : v.col - 1;
        ru = (double)(s == v.row ? v.row : s + 1);
        cu = (double)(q == v.col ? v.col : q + 1);
    }
    uint64_t cr = s / g->chart_rows, cc = q / g->chart_cols;
    double lv = (ru - (double)(cr * g->chart_rows)) / (double)g->chart_rows;
    double lu = (cu - (double)(cc * g->chart_cols)) / (double)g->chart_cols;
    uint64_t tile = cr * g->ncharts_c + cc;
    double tx = (double)(tile % g->board), ty = (double)(tile / g->board), t = (double)g->board;
    uv[0] = (float)((tx + 0.05 + 0.9 * lu) / t);
    uv[1] = (float)((ty + 0.05 + 0.9 * lv) / t);
}
