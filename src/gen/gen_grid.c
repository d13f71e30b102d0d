/*
 * Ring-stack topology: rows, strips, quads and their triangles, and the
 * O(1) maps between grid indices and (row, column) / (strip, quad, triangle)
 * that both emitters use.
 *
 *   upper row b   b0 ---- b1        diagonal 0: (a0 a1 b1) (a0 b1 b0)
 *                 |     / |         diagonal 1: (a0 a1 b0) (a1 b1 b0)
 *                 |   /   |
 *   lower row a   a0 ---- a1        columns increase counter-clockwise seen
 *                 q      q+1        from outside, rows go "up" the surface
 */
#include "gen/gen_internal.h"

int en_gen_is_pole(const en_gen_grid *g, uint64_t row)
{
    return (g->pole_first && row == 0) || (g->pole_last && row == g->nrows - 1);
}

uint64_t en_gen_row_size(const en_gen_grid *g, uint64_t row)
{
    return en_gen_is_pole(g, row) ? 1 : g->ncols;
}

uint64_t en_gen_nstrips(const en_gen_grid *g)
{
    return g->wrap_rows ? g->nrows : g->nrows - 1;
}

void en_gen_strip_rows(const en_gen_grid *g, uint64_t strip, uint64_t *a, uint64_t *b)
{
    *a = strip;
    *b = strip + 1 == g->nrows ? 0 : strip + 1;
}

uint64_t en_gen_strip_quads(const en_gen_grid *g, uint64_t strip)
{
    (void)strip;
    return g->open_cols ? g->ncols - 1 : g->ncols;
}

static uint64_t strip_faces(const en_gen_grid *g, uint64_t strip)
{
    uint64_t a, b;
    en_gen_strip_rows(g, strip, &a, &b);
    uint64_t quads = en_gen_strip_quads(g, strip);
    return en_gen_is_pole(g, a) || en_gen_is_pole(g, b) ? quads : 2 * quads;
}

int en_gen_quad_diag(const en_gen_grid *g, uint64_t strip, uint64_t q, const float *a0,
                     const float *a1, const float *b0, const float *b1)
{
    if (g->diag == EN_DIAG_CONVEX)
        /* note: fold along a0-b1 only when b0 is on or below the plane of
         * (a0 a1 b1); otherwise the other fold is the convex one. */
        return en_gen_orient(a0, a1, b1, b0) <= 0 ? 0 : 1;
    return (int)((q + strip) & 1);
}

int en_gen_quad_tris(const en_gen_grid *g, uint64_t strip, uint64_t q, int diag,
                     en_gen_vtx tri[2][3])
{
    uint64_t a, b;
    en_gen_strip_rows(g, strip, &a, &b);
    uint64_t q1 = q + 1 == g->ncols ? 0 : q + 1;
    int pa = en_gen_is_pole(g, a), pb = en_gen_is_pole(g, b);
    en_gen_vtx a0 = {a, pa ? 0 : q}, a1 = {a, pa ? 0 : q1};
    en_gen_vtx b0 = {b, pb ? 0 : q}, b1 = {b, pb ? 0 : q1};
    if (pa) {
        tri[0][0] = a0, tri[0][1] = b1, tri[0][2] = b0;
        return 1;
    }
    if (pb) {
        tri[0][0] = a0, tri[0][1] = a1, tri[0][2] = b0;
        return 1;
    }
    if (diag == 0) {
        tri[0][0] = a0, tri[0][1] = a1, tri[0][2] = b1;
        tri[1][0] = a0, tri[1][1] = b1, tri[1][2] = b0;
    } else {
        tri[0][0] = a0, tri[0][1] = a1, tri[0][2] = b0;
        tri[1][0] = a1, tri[1][1] = b1, tri[1][2] = b0;
    }
    return 2;
}

uint64_t en_gen_vertex_id(const en_gen_grid *g, en_gen_vtx v)
{
    uint64_t n0 = en_gen_row_size(g, 0);
    return v.row == 0 ? v.col : n0 + (v.row - 1) * g->ncols + v.col;
}

en_gen_vtx en_gen_vertex_at(const en_gen_grid *g, uint64_t id)
{
    uint64_t n0 = en_gen_row_size(g, 0);
    en_gen_vtx v;
    if (id < n0) {
        v.row = 0;
        v.col = id;
    } else {
        v.row = 1 + (id - n0) / g->ncols;
        v.col = (id - n0) % g->ncols;
    }
    return v;
}

void en_gen_face_at(const en_gen_grid *g, uint64_t id, en_gen_vtx out[3], uint64_t *strip_out, uint64_t *quad_out)
{
    uint64_t count0 = strip_faces(g, 0), strip, within;
    if (id < count0) {
        strip = 0;
        within = id;
    } else {
        /* note: only the first and the last strip can be pole fans, and a
         * fan is never larger than a quad strip, so plain division finds
         * the strip. */
        uint64_t per = 2 * en_gen_strip_quads(g, 1);
        strip = 1 + (id - count0) / per;
        within = (id - count0) % per;
    }
    uint64_t per_quad = strip_faces(g, strip) / en_gen_strip_quads(g, strip);
    uint64_t q = within / per_quad, t = within % per_quad;
    uint64_t a, b;
    en_gen_strip_rows(g, strip, &a, &b);
    uint64_t q1 = q + 1 == g->ncols ? 0 : q + 1;
    int diag = 0;
    if (per_quad == 2 && g->diag == EN_DIAG_CONVEX) {
        float pa0[3], pa1[3], pb0[3], pb1[3];
        en_gen_point_f(g, a, q, pa0);
        en_gen_point_f(g, a, q1, pa1);
        en_gen_point_f(g, b, q, pb0);
        en_gen_point_f(g, b, q1, pb1);
        diag = en_gen_quad_diag(g, strip, q, pa0, pa1, pb0, pb1);
    } else if (per_quad == 2) {
        diag = en_gen_quad_diag(g, strip, q, NULL, NULL, NULL, NULL);
    }
    en_gen_vtx tri[2][3];
    en_gen_quad_tris(g, strip, q, diag, tri);
    out[0] = tri[t][0];
    out[1] = tri[t][1];
    out[2] = tri[t][2];
    *strip_out = strip;
    *quad_out = q;
}
