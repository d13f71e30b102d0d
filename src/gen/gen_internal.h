/*
 * Synthetic mesh generator, internal side (public API: epsnet.h §5).
 *
 * Every shape is a *ring stack*: rows of vertices, each row a closed loop of
 * C columns (an open polyline for terrain) or a single pole vertex, joined
 * to the next row by a strip of quads (each split into two triangles) or a
 * pole fan. Rows follow the surface in adjacency order; a torus-like shape
 * also joins its last row to its first.
 *
 * note: every row lies in one plane of constant stream-axis coordinate
 * (shapes displace their vertices only within that plane), so the sorted
 * streaming order (docs/architecture.md §6) is "rows by axis value, columns in order" and
 * the streamer only ever holds a few rows, whatever the face count.
 *
 * Every vertex position and every face's corners are computed from its
 * index in O(1), which is what lets the shuffled order (a keyed bijection of
 * the index range) run in constant memory too.
 */
#ifndef EN_GEN_INTERNAL_H
#define EN_GEN_INTERNAL_H

#include <stdint.h>

#include "epsnet/epsnet.h"

/* ---- deterministic arithmetic (gen_math.c) ---- */

/* sin and cos of 2*pi*num/den radians (den > 0), from + - * / only, so the
 * result is the same on every IEEE machine built without FMA contraction. */
void en_gen_sincos_turn(int64_t num, int64_t den, double *s, double *c);

uint64_t en_gen_mix64(uint64_t x);

/*
 * Sign of the orientation of d relative to the plane through a, b, c:
 * +1 when d lies on the side the normal (b-a)x(c-a) points to, -1 on the
 * other side, 0 when coplanar. Exact for all finite float inputs (a
 * floating-point filter, then 128-bit integers, then 1024-bit integers).
 */
int en_gen_orient(const float a[3], const float b[3], const float c[3], const float d[3]);

/* Keyed bijection of [0, n) (Feistel network with cycle walking). */
typedef struct en_gen_perm {
    uint64_t n;
    unsigned left_bits, right_bits;
    uint64_t keys[4];
} en_gen_perm;

void en_gen_perm_init(en_gen_perm *p, uint64_t n, uint64_t seed);
uint64_t en_gen_perm_fwd(const en_gen_perm *p, uint64_t x);
uint64_t en_gen_perm_inv(const en_gen_perm *p, uint64_t y);

/* ---- shapes (gen_shapes.c) ---- */

typedef enum en_gen_shape_id {
    EN_SHAPE_SPHERE,
    EN_SHAPE_ELLIPSOID,
    EN_SHAPE_ROUNDCUBE,
    EN_SHAPE_TORUS,
    EN_SHAPE_DIMPLE,
    EN_SHAPE_BUMPY,
    EN_SHAPE_TERRAIN,
    EN_SHAPE_CAD,
} en_gen_shape_id;

/* Diagonal rule for the quads of a strip. */
typedef enum en_gen_diag_rule {
    EN_DIAG_CONVEX,   /* the fold that keeps the quad's diagonal edge convex */
    EN_DIAG_CHECKER,  /* alternating by column and row parity, from indices
                       * alone, so shuffled faces need no positions */
} en_gen_diag_rule;

#define EN_GEN_MAX_DENTS 6
#define EN_GEN_CAD_SEGMENTS 10

typedef struct en_gen_grid {
    en_gen_shape_id shape;
    double param;
    uint64_t seed;

    /* topology */
    uint64_t nrows;     /* rows in adjacency order, poles included */
    uint64_t ncols;     /* C: vertices in a non-pole row */
    int pole_first;     /* row 0 is a single vertex */
    int pole_last;      /* row nrows-1 is a single vertex */
    int wrap_rows;      /* a strip joins row nrows-1 to row 0 */
    int open_cols;      /* columns do not wrap (terrain) */
    en_gen_diag_rule diag;
    int axis;           /* stream axis: every row has one value on it */

    uint64_t nverts, nfaces;   /* grid vertices and triangles */

    /* UV atlas (gen_atlas.c): charts of chart_rows strips by chart_cols
     * quads, ncharts_r x ncharts_c of them on a board x board layout;
     * chart_rows 0: none. nrecords: vertex records, copies included
     * (nverts without an atlas). */
    uint64_t chart_rows, chart_cols, ncharts_r, ncharts_c, board;
    uint64_t nrecords;

    /* ring stack of rounded squares (sphere, ellipsoid, roundcube, dimple,
     * bumpy): see gen_shapes.c */
    uint64_t n_side, n_arc;       /* columns per quadrant on a side / an arc */
    uint64_t n_flat, n_lat, n_band;
    double s, rho0, c_flat, r_flat;

    /* dimple */
    int ndents;
    double dent[EN_GEN_MAX_DENTS][3];
    double dent_width;

    /* bumpy, terrain */
    int octaves;
    double base_freq;

    /* cad: profile corner k has kind (0 circle, 1 hexagon), radius, z, and
     * the segment from corner k to k+1 has seg_rows[k] rows */
    int cad_kind[EN_GEN_CAD_SEGMENTS];
    double cad_r[EN_GEN_CAD_SEGMENTS], cad_z[EN_GEN_CAD_SEGMENTS];
    uint64_t seg_rows[EN_GEN_CAD_SEGMENTS];
    uint64_t seg_first[EN_GEN_CAD_SEGMENTS + 1];
} en_gen_grid;

/* Fill g for settings s (faces, shape, param, seed). @return 0 or a negative
 * code with err filled. */
int en_gen_grid_init(en_gen_grid *g, const epsnet_gen_settings *s, epsnet_error *err);

/* Position of a vertex before rounding; col is ignored on pole rows. */
void en_gen_point(const en_gen_grid *g, uint64_t row, uint64_t col, double out[3]);

/* The position as written: each coordinate rounded to float once. */
void en_gen_point_f(const en_gen_grid *g, uint64_t row, uint64_t col, float out[3]);

/* Name -> id; -1 when unknown. */
int en_gen_shape_by_name(const char *name);

/* ---- topology (gen_grid.c) ---- */

/* A vertex of the grid: row and column (column 0 on poles). */
typedef struct en_gen_vtx {
    uint64_t row, col;
} en_gen_vtx;

/* Row is a single pole vertex. */
int en_gen_is_pole(const en_gen_grid *g, uint64_t row);
uint64_t en_gen_row_size(const en_gen_grid *g, uint64_t row);
uint64_t en_gen_nstrips(const en_gen_grid *g);
/* Rows joined by strip k: lower (a) and upper (b) in adjacency order. */
void en_gen_strip_rows(const en_gen_grid *g, uint64_t strip, uint64_t *a, uint64_t *b);
/* Quads (or fan triangles) in a strip. */
uint64_t en_gen_strip_quads(const en_gen_grid *g, uint64_t strip);

/* Diagonal of quad q of a strip, with rounded corners a0, a1 (lower row,
 * columns q and q+1) and b0, b1 (upper row), by the grid's rule: 0 or 1
 * (see gen_grid.c). The corners may be NULL unless the rule is
 * EN_DIAG_CONVEX. */
int en_gen_quad_diag(const en_gen_grid *g, uint64_t strip, uint64_t q, const float *a0,
                     const float *a1, const float *b0, const float *b1);

/* Triangles of quad q of a strip, counter-clockwise seen from outside; a
 * pole row repeats its one vertex and gives a single triangle.
 * @return 1 or 2. */
int en_gen_quad_tris(const en_gen_grid *g, uint64_t strip, uint64_t q, int diag,
                     en_gen_vtx tri[2][3]);

/* Global grid indices (adjacency order) and back. */
uint64_t en_gen_vertex_id(const en_gen_grid *g, en_gen_vtx v);
en_gen_vtx en_gen_vertex_at(const en_gen_grid *g, uint64_t id);
/* Corners of face id (strip-major), computing the positions it needs, and
 * its strip and quad (for en_gen_copy_of). */
void en_gen_face_at(const en_gen_grid *g, uint64_t id, en_gen_vtx tri[3], uint64_t *strip, uint64_t *quad);

/* ---- UV atlas (gen_atlas.c) ---- */

/* Cut g's grid into about charts charts (0: no atlas); after the layout. */
void en_gen_atlas_init(en_gen_grid *g, uint64_t charts);
/* Records of vertex v (its copies, one per chart at it); 1 without an atlas. */
uint64_t en_gen_copies(const en_gen_grid *g, en_gen_vtx v);
/* Records of a row, and those before v's first copy in its row. */
uint64_t en_gen_row_records(const en_gen_grid *g, uint64_t row);
uint64_t en_gen_col_offset(const en_gen_grid *g, en_gen_vtx v);
/* The copy of v that the faces of quad q of strip use. */
uint64_t en_gen_copy_of(const en_gen_grid *g, en_gen_vtx v, uint64_t strip, uint64_t q);
/* texture_u, texture_v of copy `copy` of v. */
void en_gen_copy_uv(const en_gen_grid *g, en_gen_vtx v, uint64_t copy, float uv[2]);

/* ---- emitters (gen_stream.c) ---- */

typedef int (*en_gen_emit_fn)(void *ctx, const epsnet_record *rec, epsnet_error *err);

typedef struct en_gen_stats {
    uint64_t peak_bytes;   /* largest working memory held at once */
    uint64_t peak_live;    /* most vertices emitted but not yet finalized */
} en_gen_stats;

/* Sorted, finalized streaming mesh along g->axis. stats may be NULL. */
int en_gen_emit_sorted(const en_gen_grid *g, en_gen_emit_fn emit, void *ctx,
                       en_gen_stats *stats, epsnet_error *err);

/* Vertices then faces, each in keyed random order, no finalization. */
int en_gen_emit_shuffled(const en_gen_grid *g, uint64_t seed, en_gen_emit_fn emit, void *ctx,
                         epsnet_error *err);

/* Run settings s into emit (what epsnet_gen does with a writer). */
int en_gen_run(const epsnet_gen_settings *s, en_gen_emit_fn emit, void *ctx,
               en_gen_stats *stats, epsnet_error *err);

#endif /* EN_GEN_INTERNAL_H */
