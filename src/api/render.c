/*
 * epsnet_render_file(): pictures of a mesh, its samples (paper §4, drawn as
 * in the paper's figures: dots coloured by Gaussian vertex) and its
 * simplification (§4.2). The plain picture streams: the bounding box comes
 * from the header or a first pass, then triangles are rasterized as they
 * are read. The samples panel classifies the whole mesh as one slab (the
 * one-slab case of the per-slab core); the simplification is the stage
 * chain's own output, collected in memory.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "api/budget.h"
#include "api/jobs.h"
#include "api/stream_files.h"
#include "common/alloc.h"
#include "common/error.h"
#include "common/util.h"
#include "io/samples_ply.h"
#include "render/png_out.h"
#include "render/raster.h"
#include "render/vertex_table.h"

#define RENDER_MAX_SIDE 8192u
/* Records between two progress callbacks. */
#define PROGRESS_EVERY (1u << 16)

static const uint8_t background[3] = { 255, 255, 255 };
static const en_surface_style input_style = { { 200, 200, 208 }, 0 };
static const en_surface_style simplified_style = { { 196, 206, 222 }, 0 };

void epsnet_render_default_settings(epsnet_render_settings *s)
{
    memset(s, 0, sizeof *s);
    s->width = 640;
    s->height = 480;
    s->azimuth = 30;
    s->elevation = 20;
}

static int check_settings(const epsnet_render_settings *rs, epsnet_error *err)
{
    if (rs->width < 1 || rs->width > RENDER_MAX_SIDE || rs->height < 1 || rs->height > RENDER_MAX_SIDE)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "image size %ux%u: each side must be between 1 and %u", rs->width, rs->height,
                            RENDER_MAX_SIDE);
    if (rs->simplified && rs->width < 2)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "image width %u: two panels need at least 2 pixels", rs->width);
    if (!isfinite(rs->azimuth) || !(rs->elevation >= -90 && rs->elevation <= 90))
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "view: azimuth must be finite and elevation between -90 and 90 degrees");
    if (!(rs->dot_radius >= 0 && rs->dot_radius <= 1000))
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "dot radius must be between 0 and 1000 pixels");
    return 0;
}

/* Calls the context's progress callback now and then; non-zero cancels. */
static int report_progress(const epsnet_context *ctx, const epsnet_reader *r, uint64_t records, const char *path,
                           epsnet_error *err)
{
    if (!ctx->settings.progress || records % PROGRESS_EVERY)
        return 0;
    if (ctx->settings.progress(ctx->settings.progress_opaque, epsnet_reader_bytes_read(r),
                               epsnet_reader_file_size(r)))
        return en_error_set(err, EPSNET_EINTR, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "cancelled");
    return 0;
}

static int usable_bbox(const epsnet_mesh_info *info)
{
    if (!info->has_bbox)
        return 0;
    for (int k = 0; k < 3; k++)
        if (!isfinite(info->bbox_min[k]) || !isfinite(info->bbox_max[k]) || info->bbox_min[k] > info->bbox_max[k])
            return 0;
    return 1;
}

/* The box the camera frames: the header's, else that of every vertex (a
 * first pass over the file); an empty mesh gets the unit cube. */
static int mesh_bbox(const epsnet_context *ctx, const char *path, double bmin[3], double bmax[3],
                     epsnet_error *err)
{
    epsnet_reader_settings rset;
    epsnet_reader_default_settings(&rset);
    en_budget budget; /* a pass that only reads: the reader has it all */
    en_budget_split(&budget, &ctx->settings, EN_BUDGET_IN_CORE);
    rset.mem_limit = budget.reader;
    epsnet_reader *r = NULL;
    int rc = epsnet_reader_open(&r, path, &rset, err);
    if (rc)
        return rc;
    const epsnet_mesh_info *info = epsnet_reader_info(r);
    if (usable_bbox(info)) {
        memcpy(bmin, info->bbox_min, 3 * sizeof *bmin);
        memcpy(bmax, info->bbox_max, 3 * sizeof *bmax);
        epsnet_reader_close(&r);
        return 0;
    }
    for (int k = 0; k < 3; k++)
        bmin[k] = INFINITY, bmax[k] = -INFINITY;
    epsnet_record rec;
    uint64_t records = 0;
    while ((rc = epsnet_reader_next(r, &rec, err)) > 0) {
        if (rec.kind == EPSNET_REC_VERTEX)
            for (int k = 0; k < 3; k++)
                bmin[k] = fmin(bmin[k], rec.xyz[k]), bmax[k] = fmax(bmax[k], rec.xyz[k]);
        if ((rc = report_progress(ctx, r, ++records, path, err)))
            break;
    }
    epsnet_reader_close(&r);
    if (rc < 0)
        return rc;
    if (!(bmin[0] <= bmax[0]))
        for (int k = 0; k < 3; k++)
            bmin[k] = -1, bmax[k] = 1;
    return 0;
}

/* One panel: the camera and the pixels it may touch. */
typedef struct panel {
    en_camera cam;
    en_clip clip;
} panel;

static void panel_frame(panel *p, const epsnet_render_settings *rs, const double bmin[3], const double bmax[3],
                        uint32_t x0, uint32_t x1)
{
    en_camera_frame(&p->cam, bmin, bmax, rs->azimuth, rs->elevation, x0, 0, x1 - x0, rs->height);
    p->clip = (en_clip){ x0, 0, x1, rs->height };
}

static void draw_face(en_raster *img, const panel *p, const double *a, const double *b, const double *c,
                      const en_surface_style *style)
{
    double s[3][3];
    en_camera_project(&p->cam, a, s[0]);
    en_camera_project(&p->cam, b, s[1]);
    en_camera_project(&p->cam, c, s[2]);
    en_raster_triangle(img, &p->clip, s, style);
}

static int table_failure(int code, const en_vertex_table *t, const char *path, epsnet_error *err)
{
    if (code == EN_VT_LIMIT)
        return en_error_set(err, EPSNET_ELIMIT, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "the memory budget is too small for the %zu vertex positions held (%s); "
                            "sort the mesh into a streaming mesh first (epsnet sort)",
                            t->count, t->hashed ? "live vertices of the stream" : "every vertex");
    return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "out of memory for %zu vertex positions", t->count);
}

/* Rasterize the mesh at path as it is read: vertex positions in a table
 * (live ones only for streaming input), triangles drawn and forgotten. */
static int draw_stream(epsnet_context *ctx, const char *path, en_raster *img, const panel *p,
                       const en_surface_style *style, epsnet_error *err)
{
    epsnet_reader_settings rset;
    epsnet_reader_default_settings(&rset);
    /* a stream's split: the reader's live set, and the table of positions
     * in the chain's place */
    en_budget budget;
    en_budget_split(&budget, &ctx->settings, EN_BUDGET_STREAM);
    rset.mem_limit = budget.reader;
    epsnet_reader *r = NULL;
    double t0 = en_now();
    int rc = epsnet_reader_open(&r, path, &rset, err);
    if (rc)
        return rc;
    en_vertex_table table;
    en_vertex_table_init(&table, epsnet_reader_info(r)->streaming, budget.chain);
    epsnet_record rec;
    uint64_t records = 0, vertices = 0, faces = 0, peak = 0;
    while ((rc = epsnet_reader_next(r, &rec, err)) > 0) {
        if (rec.kind == EPSNET_REC_VERTEX) {
            int trc = en_vertex_table_add(&table, vertices++, rec.xyz);
            if (trc) {
                rc = table_failure(trc, &table, path, err);
                break;
            }
            peak = table.count > peak ? table.count : peak;
        } else if (rec.kind == EPSNET_REC_TRIANGLE) {
            const double *a = en_vertex_table_get(&table, rec.v[0]);
            const double *b = en_vertex_table_get(&table, rec.v[1]);
            const double *c = en_vertex_table_get(&table, rec.v[2]);
            if (!a || !b || !c) {
                rc = en_error_set(err, EPSNET_EINTERNAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                  "triangle %llu uses a vertex the reader accepted but the renderer lost",
                                  (unsigned long long)faces + 1);
                break;
            }
            draw_face(img, p, a, b, c, style);
            faces++;
        } else {
            en_vertex_table_remove(&table, rec.v[0]);
        }
        if ((rc = report_progress(ctx, r, ++records, path, err)))
            break;
    }
    ctx->stats.vertices = vertices;
    ctx->stats.faces = faces;
    ctx->stats.max_active = peak;
    ctx->stats.seconds_read += en_now() - t0;
    en_vertex_table_free(&table);
    epsnet_reader_close(&r);
    return rc < 0 ? rc : 0;
}

static void draw_slab(const en_slab *s, en_raster *img, const panel *p, const en_surface_style *style)
{
    for (uint32_t f = 0; f < s->nt; f++) {
        const uint32_t *t = s->tri + 3 * (size_t)f;
        draw_face(img, p, s->pos + 3 * (size_t)t[0], s->pos + 3 * (size_t)t[1], s->pos + 3 * (size_t)t[2], style);
    }
}

typedef struct dot {
    double screen[3];
    uint32_t vertex;
} dot;

/* Far dots first, so nearer ones overlap them; ties by vertex keep the
 * order total and the picture deterministic. */
static int dot_order(const void *pa, const void *pb)
{
    const dot *a = pa, *b = pb;
    if (a->screen[2] != b->screen[2])
        return a->screen[2] > b->screen[2] ? -1 : 1;
    return (a->vertex > b->vertex) - (a->vertex < b->vertex);
}

static int draw_samples(const en_slab *s, const en_classification *c, en_raster *img, const panel *p,
                        double radius, const char *path, epsnet_error *err)
{
    size_t n = 0;
    for (uint32_t v = 0; v < s->nv; v++)
        n += (c->vclass[v] & EN_C_SAMPLE) != 0;
    dot *dots = en_malloc(n * sizeof *dots + 1);
    if (!dots)
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory for %zu sample dots", n);
    n = 0;
    for (uint32_t v = 0; v < s->nv; v++)
        if (c->vclass[v] & EN_C_SAMPLE) {
            en_camera_project(&p->cam, s->pos + 3 * (size_t)v, dots[n].screen);
            dots[n++].vertex = v;
        }
    qsort(dots, n, sizeof *dots, dot_order);
    /* note: a vertex's own depth can lie a little behind the z-buffer of the
     * surface around it (rounding, and the pixel centre is not the vertex),
     * most of all on steep faces near the silhouette; a slack of 2% of the
     * panel keeps those while the far side of a shape stays hidden. */
    uint32_t side = p->clip.x1 - p->clip.x0 < p->clip.y1 - p->clip.y0 ? p->clip.x1 - p->clip.x0
                                                                      : p->clip.y1 - p->clip.y0;
    double slack = 0.02 * side;
    for (size_t i = 0; i < n; i++) {
        uint8_t rgb[3];
        en_gvertex_colour(c->vgvertex[dots[i].vertex], rgb);
        en_raster_dot(img, &p->clip, dots[i].screen, radius, slack, rgb);
    }
    en_free(dots);
    return 0;
}

/* The input with its samples: the whole-mesh classification of sample.c. */
static int draw_input_with_samples(epsnet_context *ctx, const char *in, en_raster *img, const panel *p,
                                   const en_surface_style *style, double radius, epsnet_error *err)
{
    en_slab slab;
    en_slab_init(&slab);
    en_classification c = { 0 };
    epsnet_coord_type ct;
    int rc = en_job_load(ctx, in, NULL, &slab, &ct, err);
    if (rc == 0)
        rc = en_job_classify(ctx, &ctx->sphere, &slab, &c, in, err);
    if (rc == 0) {
        en_job_count(ctx, &c.counts);
        draw_slab(&slab, img, p, style);
        rc = draw_samples(&slab, &c, img, p, radius, in, err);
    }
    en_classification_free(&c);
    en_slab_free(&slab);
    return rc;
}

/* The simplified mesh, collected from the stage chain's output: output
 * vertex ids are 0, 1, 2, ... in record order, so they index the slab. */
static int collect_put(void *self, const epsnet_record *rec, epsnet_error *err)
{
    en_slab *s = self;
    int bad = 0;
    if (rec->kind == EPSNET_REC_VERTEX)
        bad = en_slab_add_vertex(s, s->nv, rec->xyz, EN_V_OWNED) < 0;
    else if (rec->kind == EPSNET_REC_TRIANGLE)
        bad = en_slab_add_face(s, (uint32_t)rec->v[0], (uint32_t)rec->v[1], (uint32_t)rec->v[2]) != 0;
    return bad ? en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                              "out of memory collecting the simplified mesh")
               : 0;
}

static int open_collector(void *opaque, const epsnet_mesh_info *in, struct en_pool *pool, en_stage *out,
                          epsnet_error *err)
{
    (void)in;
    (void)pool;
    (void)err;
    *out = (en_stage){ collect_put, NULL, opaque };
    return 0;
}

static int draw_simplified(epsnet_context *ctx, const char *in, const char *out_png, en_raster *img,
                           const panel *p, const en_surface_style *style, epsnet_error *err)
{
    en_slab slab;
    en_slab_init(&slab);
    int rc = en_simplify_streamed(ctx, in, NULL, out_png, NULL, open_collector, NULL, &slab, err);
    if (rc == 0)
        draw_slab(&slab, img, p, style);
    en_slab_free(&slab);
    return rc;
}

int epsnet_render_file(epsnet_context *ctx, const char *in, const char *out_png, const epsnet_render_settings *rs,
                       epsnet_error *err)
{
    if (!ctx || !in || !out_png)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_render_file: NULL argument");
    epsnet_render_settings defaults;
    if (!rs) {
        epsnet_render_default_settings(&defaults);
        rs = &defaults;
    }
    int rc = check_settings(rs, err);
    if (rc)
        return rc;
    if (!strcmp(in, "-"))
        return en_error_set(err, EPSNET_EUNSUPPORTED, "-", EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "render reads its input twice (bounding box, then drawing): give a file, "
                            "not standard input");
    /* a picture is a PNG: any other name would hold a PNG under a name
     * that says otherwise (render -o pic.jpg) */
    size_t n = strlen(out_png);
    if (strcmp(out_png, "-") != 0 && (n < 4 || strcasecmp(out_png + n - 4, ".png") != 0))
        return en_error_set(err, EPSNET_EUNSUPPORTED, out_png, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "render writes PNG pictures only: name the output .png");
    memset(&ctx->stats, 0, sizeof ctx->stats);
    snprintf(ctx->command, sizeof ctx->command, "render");
    ctx->stats.gaussian_vertices = ctx->sphere.nverts;

    double bmin[3], bmax[3];
    if ((rc = mesh_bbox(ctx, in, bmin, bmax, err)))
        return rc;
    en_raster img;
    if (en_raster_init(&img, rs->width, rs->height, background))
        return en_error_set(err, EPSNET_ENOMEM, out_png, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory for a %ux%u image", rs->width, rs->height);
    uint32_t split = rs->simplified ? rs->width / 2 : rs->width;
    panel left, right;
    panel_frame(&left, rs, bmin, bmax, 0, split);
    panel_frame(&right, rs, bmin, bmax, split, rs->width);
    en_surface_style in_style = input_style, simp_style = simplified_style;
    in_style.wire = simp_style.wire = rs->wire;
    double radius = rs->dot_radius;
    if (radius == 0) {
        uint32_t side = split < rs->height ? split : rs->height;
        radius = fmax(2.0, side / 160.0);
    }

    if (rs->samples)
        rc = draw_input_with_samples(ctx, in, &img, &left, &in_style, radius, err);
    else
        rc = draw_stream(ctx, in, &img, &left, &in_style, err);
    if (rc == 0 && rs->simplified)
        rc = draw_simplified(ctx, in, out_png, &img, &right, &simp_style, err);
    if (rc == 0) {
        double t0 = en_now();
        rc = en_png_write(out_png, img.rgb, img.width, img.height, err);
        ctx->stats.seconds_write = en_now() - t0;
    }
    ctx->stats.peak_rss = en_peak_rss_bytes();
    en_raster_free(&img);
    return rc;
}
