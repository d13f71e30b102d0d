/*
 * `epsnet render` (issue 9): the rasterizer puts exactly the pixels whose
 * centres a triangle covers, the z-buffer keeps the nearest surface
 * whatever the drawing order, the camera frames the bounding box, a sphere
 * covers pi r^2 of the picture, the streamed and in-memory paths agree, and
 * the same call gives the same PNG bytes.
 *
 * PNGs are decoded with libpng's own reader, independent of our writer.
 */
#include <png.h>

#include "render/png_out.h"
#include "render/raster.h"
#include "render/vertex_table.h"
#include "testlib.h"

static const uint8_t white[3] = { 255, 255, 255 };
static const en_surface_style grey = { { 200, 200, 200 }, 0 };

/* ---- helpers ---- */

static uint64_t count_non_background(const en_raster *r)
{
    uint64_t n = 0;
    for (size_t i = 0; i < (size_t)r->width * r->height; i++)
        n += memcmp(r->rgb + 3 * i, white, 3) != 0;
    return n;
}

/* Decode an RGB PNG; @return malloc'ed pixels or NULL. */
static uint8_t *read_png(const char *path, uint32_t *w, uint32_t *h)
{
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&img, path))
        return NULL;
    img.format = PNG_FORMAT_RGB;
    uint8_t *px = malloc(PNG_IMAGE_SIZE(img));
    if (!px || !png_image_finish_read(&img, NULL, px, 0, NULL)) {
        free(px);
        png_image_free(&img);
        return NULL;
    }
    *w = img.width;
    *h = img.height;
    return px;
}

static const char *gen_file(const char *shape, uint64_t faces, const char *name)
{
    epsnet_error err;
    const char *path = tl_path(name);
    if (tl_gen_file(path, shape, faces, NAN, 1, 0, &err)) {
        fprintf(stderr, "gen %s: %s\n", name, epsnet_error_message(&err));
        exit(2);
    }
    return path;
}

static epsnet_context *new_context(void)
{
    epsnet_context *ctx = NULL;
    epsnet_error err;
    if (epsnet_context_new(&ctx, NULL, &err)) {
        fprintf(stderr, "context: %s\n", epsnet_error_message(&err));
        exit(2);
    }
    return ctx;
}

/* ---- rasterizer ---- */

/*
 *   y=0 +---+---+---+---+
 *       |\  |   |   |   |      corners (0,0) (4,0) (0,4) in pixels: the
 *       +---\---+---+---+      centres (i+.5, j+.5) with i+j <= 3 are inside
 *       |   | \ |   |   |      or on it: 4+3+2+1 = 10 pixels
 *       +---+---\---+---+
 *       ...
 */
TEST(triangle_covers_exactly_the_pixel_centres_inside_it)
{
    en_raster r;
    CHECK(en_raster_init(&r, 8, 8, white) == 0);
    en_clip all = { 0, 0, 8, 8 };
    const double p[3][3] = { { 0, 0, 1 }, { 4, 0, 1 }, { 0, 4, 1 } };
    CHECK_EQ_U64(en_raster_triangle(&r, &all, p, &grey), 10);
    CHECK_EQ_U64(count_non_background(&r), 10);
    for (uint32_t y = 0; y < 8; y++)
        for (uint32_t x = 0; x < 8; x++)
            CHECK_EQ_INT(r.rgb[3 * (y * 8 + x)] != 255, x + y <= 3);
    en_raster_free(&r);
}

TEST(either_winding_is_drawn_and_zero_area_draws_nothing)
{
    en_raster r;
    CHECK(en_raster_init(&r, 8, 8, white) == 0);
    en_clip all = { 0, 0, 8, 8 };
    const double cw[3][3] = { { 0, 0, 1 }, { 0, 4, 1 }, { 4, 0, 1 } };
    CHECK_EQ_U64(en_raster_triangle(&r, &all, cw, &grey), 10);
    const double flat[3][3] = { { 0, 0.5, 0 }, { 4, 0.5, 0 }, { 8, 0.5, 0 } };
    CHECK_EQ_U64(en_raster_triangle(&r, &all, flat, &grey), 0);
    en_raster_free(&r);
}

/*
 * Two 6x6 squares (two triangles each) overlapping on 4x4 pixels, A nearer
 * (depth 1) than B (depth 2), in different colours: the overlap shows A
 * whether A or B is drawn first.
 */
TEST(nearer_surface_wins_whatever_the_order)
{
    const en_surface_style red = { { 200, 0, 0 }, 0 }, blue = { { 0, 0, 200 }, 0 };
    const double a[2][3][3] = { { { 0, 0, 1 }, { 6, 0, 1 }, { 6, 6, 1 } }, { { 0, 0, 1 }, { 6, 6, 1 }, { 0, 6, 1 } } };
    const double b[2][3][3] = { { { 2, 2, 2 }, { 8, 2, 2 }, { 8, 8, 2 } }, { { 2, 2, 2 }, { 8, 8, 2 }, { 2, 8, 2 } } };
    en_clip all = { 0, 0, 8, 8 };
    en_raster first, second;
    CHECK(en_raster_init(&first, 8, 8, white) == 0);
    CHECK(en_raster_init(&second, 8, 8, white) == 0);
    for (int t = 0; t < 2; t++)
        en_raster_triangle(&first, &all, a[t], &red);
    for (int t = 0; t < 2; t++)
        en_raster_triangle(&first, &all, b[t], &blue);
    for (int t = 0; t < 2; t++)
        en_raster_triangle(&second, &all, b[t], &blue);
    for (int t = 0; t < 2; t++)
        en_raster_triangle(&second, &all, a[t], &red);
    CHECK(memcmp(first.rgb, second.rgb, 3 * 64) == 0);
    const uint8_t *overlap = first.rgb + 3 * (3 * 8 + 3); /* pixel (3,3) */
    CHECK(overlap[0] > 0 && overlap[2] == 0);
    const uint8_t *only_b = first.rgb + 3 * (7 * 8 + 7);
    CHECK(only_b[0] == 0 && only_b[2] > 0);
    en_raster_free(&first);
    en_raster_free(&second);
}

TEST(clip_bounds_every_write_even_for_absurd_coordinates)
{
    en_raster r;
    CHECK(en_raster_init(&r, 16, 4, white) == 0);
    en_clip left = { 0, 0, 8, 4 };
    const double huge[3][3] = { { -1e300, -1e300, 0 }, { 1e300, -1e300, 0 }, { 0, 1e300, 0 } };
    uint64_t n = en_raster_triangle(&r, &left, huge, &grey);
    CHECK(n <= 32);
    for (uint32_t y = 0; y < 4; y++)
        for (uint32_t x = 8; x < 16; x++)
            CHECK(r.rgb[3 * (y * 16 + x)] == 255);
    const double inf[3][3] = { { 0, 0, 0 }, { INFINITY, 0, 0 }, { 0, 4, 0 } };
    CHECK_EQ_U64(en_raster_triangle(&r, &left, inf, &grey), 0);
    en_raster_free(&r);
}

/*
 * A red quad at depth 5 fills the 20x20 image; a dot at depth 4 (in front)
 * and one at depth 5 + slack/2 show; one at depth 5 + 2*slack is hidden.
 */
TEST(dots_behind_the_surface_are_hidden)
{
    en_raster r;
    CHECK(en_raster_init(&r, 20, 20, white) == 0);
    en_clip all = { 0, 0, 20, 20 };
    const double q[2][3][3] = { { { 0, 0, 5 }, { 20, 0, 5 }, { 20, 20, 5 } }, { { 0, 0, 5 }, { 20, 20, 5 }, { 0, 20, 5 } } };
    en_raster_triangle(&r, &all, q[0], &grey);
    en_raster_triangle(&r, &all, q[1], &grey);
    const uint8_t green[3] = { 0, 255, 0 };
    const double front[3] = { 5, 5, 4 }, near_enough[3] = { 15, 5, 6 }, behind[3] = { 10, 15, 9 };
    CHECK_EQ_INT(en_raster_dot(&r, &all, front, 3, 2, green), 1);
    CHECK_EQ_INT(en_raster_dot(&r, &all, near_enough, 3, 2, green), 1);
    CHECK_EQ_INT(en_raster_dot(&r, &all, behind, 3, 2, green), 0);
    CHECK(memcmp(r.rgb + 3 * (5 * 20 + 5), green, 3) == 0);
    CHECK(memcmp(r.rgb + 3 * (15 * 20 + 10), green, 3) != 0);
    en_raster_free(&r);
}

/* ---- camera ---- */

TEST(camera_frames_the_box_with_the_margin)
{
    /* Box 4 wide, 2 high, seen along -z: the width limits the scale in a
     * 100x100 panel, 90 px for 4 units; the centre goes mid-panel. */
    const double bmin[3] = { -1, 0, 0 }, bmax[3] = { 3, 2, 1 };
    en_camera c;
    en_camera_frame(&c, bmin, bmax, 0, 0, 0, 0, 100, 100);
    double s[3];
    en_camera_project(&c, bmin, s);
    CHECK(fabs(s[0] - 5) < 1e-9 && fabs(s[1] - 72.5) < 1e-9);
    en_camera_project(&c, bmax, s);
    CHECK(fabs(s[0] - 95) < 1e-9 && fabs(s[1] - 27.5) < 1e-9);
    /* +z is toward the viewer at azimuth 0: nearer means smaller depth. */
    CHECK(s[2] < 0);
    /* Azimuth 90 looks along -x: +x comes toward the viewer. */
    en_camera_frame(&c, bmin, bmax, 90, 0, 0, 0, 100, 100);
    const double px[3] = { 3, 1, 0.5 }, pz[3] = { 1, 1, 1 };
    double sx[3], sz[3], centre[3];
    const double mid[3] = { 1, 1, 0.5 };
    en_camera_project(&c, px, sx);
    en_camera_project(&c, pz, sz);
    en_camera_project(&c, mid, centre);
    CHECK(sx[2] < centre[2]);
    CHECK(sz[0] < centre[0]); /* looking along -x with +y up, +z is on the left */
    CHECK(fabs(centre[0] - 50) < 1e-9 && fabs(centre[1] - 50) < 1e-9);
}

/* ---- vertex table ---- */

TEST(streaming_table_keeps_only_live_vertices)
{
    /* A stream whose window is 100 vertices wide: vertex i is finalized
     * when vertex i+100 arrives. The table never holds more than 101, and
     * every live vertex is found with its own position. */
    en_vertex_table t;
    en_vertex_table_init(&t, 1, 0);
    size_t most = 0;
    int all_found = 1;
    for (uint64_t i = 0; i < 20000; i++) {
        double xyz[3] = { (double)i, -(double)i, 0.5 * (double)i };
        CHECK_EQ_INT(en_vertex_table_add(&t, i, xyz), 0);
        most = t.count > most ? t.count : most;
        if (i >= 100)
            en_vertex_table_remove(&t, i - 100);
        for (uint64_t j = i >= 100 ? i - 99 : 0; j <= i; j += 7) {
            const double *p = en_vertex_table_get(&t, j);
            all_found &= p && p[0] == (double)j && p[1] == -(double)j;
        }
        if (i >= 100)
            all_found &= en_vertex_table_get(&t, i - 100) == NULL;
    }
    CHECK(all_found);
    CHECK_EQ_U64(most, 101);
    CHECK(en_vertex_table_bytes(&t) <= 1024 * 32);
    en_vertex_table_free(&t);
}

TEST(dense_table_over_budget_is_a_limit)
{
    en_vertex_table t;
    en_vertex_table_init(&t, 0, 24 * 1000);
    double xyz[3] = { 1, 2, 3 };
    int rc = 0;
    uint64_t i = 0;
    for (; i < 5000 && rc == 0; i++)
        rc = en_vertex_table_add(&t, i, xyz);
    CHECK_EQ_INT(rc, EN_VT_LIMIT);
    CHECK_EQ_U64(t.count, 1000);
    CHECK(en_vertex_table_bytes(&t) <= 24 * 1000);
    en_vertex_table_free(&t);
}

/* ---- whole pictures ---- */

/*
 * The unit sphere seen along -z (view 0,0) in W x H. Its silhouette is the
 * projection of a convex polyhedron whose vertices lie on the unit sphere
 * (float32: radius within 1e-7 of 1) and whose face planes are all at least
 * r_in from the centre, so it contains the disc of radius s*r_in and lies in
 * the disc of radius s*r_out, s = pixels per unit.
 *
 * A pixel counts when its centre is covered. Every such pixel's square lies
 * within sqrt(2)/2 of the silhouette, and every point at least sqrt(2)/2
 * inside it belongs to a counted pixel, so
 *     pi (s r_in - 0.7072)^2  <=  count  <=  pi (s r_out + 0.7072)^2.
 * With about 20000 faces r_in > 0.999, so at s ~ 90-135 px the window is
 * within about 1.5% of pi (s r)^2: a wrong scale, margin or a hole in the
 * coverage falls outside it.
 *
 * s follows the documented framing: the bbox of every vertex (PLY has none
 * in its header), projected, fit into the image minus 5% on each side.
 */
static void check_sphere_fraction(const char *sphere, uint32_t w, uint32_t h)
{
    tl_mesh m;
    epsnet_error err;
    CHECK(tl_read_mesh(sphere, &m, &err) == 0);
    double lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    double r_out = 0, r_in = INFINITY;
    for (uint64_t v = 0; v < m.nv; v++) {
        const double *p = m.xyz + 3 * v;
        for (int k = 0; k < 3; k++)
            lo[k] = fmin(lo[k], p[k]), hi[k] = fmax(hi[k], p[k]);
        r_out = fmax(r_out, sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]));
    }
    for (uint64_t f = 0; f < m.nt; f++) {
        const double *a = m.xyz + 3 * m.tri[3 * f], *b = m.xyz + 3 * m.tri[3 * f + 1],
                     *c = m.xyz + 3 * m.tri[3 * f + 2];
        double u[3], v[3], n[3];
        for (int k = 0; k < 3; k++)
            u[k] = b[k] - a[k], v[k] = c[k] - a[k];
        n[0] = u[1] * v[2] - u[2] * v[1];
        n[1] = u[2] * v[0] - u[0] * v[2];
        n[2] = u[0] * v[1] - u[1] * v[0];
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len > 0)
            r_in = fmin(r_in, fabs(n[0] * a[0] + n[1] * a[1] + n[2] * a[2]) / len);
    }
    tl_mesh_free(&m);
    CHECK(r_in > 0.999 && r_out < 1.000001);
    double s = fmin(0.9 * w / (hi[0] - lo[0]), 0.9 * h / (hi[1] - lo[1]));

    epsnet_render_settings rs;
    epsnet_render_default_settings(&rs);
    rs.width = w;
    rs.height = h;
    rs.azimuth = 0;
    rs.elevation = 0;
    epsnet_context *ctx = new_context();
    const char *out = tl_path("sphere.png");
    CHECK(epsnet_render_file(ctx, sphere, out, &rs, &err) == 0);
    epsnet_context_free(&ctx);
    uint32_t pw = 0, ph = 0;
    uint8_t *px = read_png(out, &pw, &ph);
    CHECK(px != NULL);
    if (!px)
        return;
    CHECK_EQ_INT(pw, w);
    CHECK_EQ_INT(ph, h);
    uint64_t covered = 0;
    for (size_t i = 0; i < (size_t)w * h; i++)
        covered += memcmp(px + 3 * i, white, 3) != 0;
    free(px);
    const double pi = 3.14159265358979323846, half_diag = 0.7072;
    double lower = pi * (s * r_in - half_diag) * (s * r_in - half_diag);
    double upper = pi * (s * r_out + half_diag) * (s * r_out + half_diag);
    double expected = pi * s * s;
    if (!((double)covered >= lower && (double)covered <= upper))
        fprintf(stderr, "sphere %ux%u: %llu pixels covered, want %.0f .. %.0f (pi r^2 = %.0f)\n", w, h,
                (unsigned long long)covered, lower, upper, expected);
    CHECK((double)covered >= lower && (double)covered <= upper);
    CHECK(fabs((double)covered / ((double)w * h) - expected / ((double)w * h)) < 0.01);
}

TEST(sphere_covers_pi_r_squared_of_the_image)
{
    const char *sphere = gen_file("sphere", 20000, "sphere.ply");
    check_sphere_fraction(sphere, 320, 200); /* height limits the scale */
    check_sphere_fraction(sphere, 200, 300); /* width limits it */
}

/* Every panel of every kind of picture (plain, samples, input beside its
 * simplification) holds the whole mesh: the band of one panel margin
 * (EN_CAMERA_MARGIN less a pixel) around each panel is background, and each
 * panel shows something. Views from every side of an asymmetric CAD part. */
TEST(every_picture_frames_the_whole_mesh)
{
    char mesh[512], out[512]; /* tl_path's buffers rotate: keep copies */
    snprintf(mesh, sizeof mesh, "%s", gen_file("cad", 8000, "frame_cad.ply"));
    snprintf(out, sizeof out, "%s", tl_path("frame.png"));
    static const double views[][2] = { { 30, 20 }, { 120, 30 }, { 210, 25 }, { 300, -40 }, { 0, 89 } };
    for (int kind = 0; kind < 3; kind++)
        for (size_t v = 0; v < sizeof views / sizeof views[0]; v++) {
            epsnet_render_settings rs;
            epsnet_render_default_settings(&rs);
            rs.width = kind == 2 ? 400 : 200;
            rs.height = 150;
            rs.azimuth = views[v][0];
            rs.elevation = views[v][1];
            rs.samples = kind == 1;
            rs.simplified = kind == 2;
            epsnet_context *ctx = new_context();
            epsnet_error err;
            CHECK_EQ_INT(epsnet_render_file(ctx, mesh, out, &rs, &err), 0);
            epsnet_context_free(&ctx);
            uint32_t w = 0, h = 0;
            uint8_t *px = read_png(out, &w, &h);
            CHECK(px != NULL);
            if (!px)
                continue;
            uint32_t panels = kind == 2 ? 2 : 1, pw = w / panels;
            for (uint32_t p = 0; p < panels; p++) {
                uint32_t mx = (uint32_t)(EN_CAMERA_MARGIN * pw) - 1, my = (uint32_t)(EN_CAMERA_MARGIN * h) - 1;
                uint64_t border_hits = 0, inside = 0;
                for (uint32_t y = 0; y < h; y++)
                    for (uint32_t x = p * pw; x < (p + 1) * pw; x++) {
                        int bg = memcmp(px + 3 * ((size_t)y * w + x), white, 3) == 0;
                        int band = y < my || y >= h - my || x < p * pw + mx || x >= (p + 1) * pw - mx;
                        border_hits += band && !bg;
                        inside += !band && !bg;
                    }
                if (border_hits)
                    fprintf(stderr, "kind %d view %g,%g panel %u: %llu pixels in the margin\n", kind, views[v][0],
                            views[v][1], p, (unsigned long long)border_hits);
                CHECK_EQ_U64(border_hits, 0);
                CHECK(inside > 100);
            }
            free(px);
        }
}

TEST(same_call_gives_the_same_bytes)
{
    const char *mesh = gen_file("dimple", 6000, "dimple.ply");
    epsnet_render_settings rs;
    epsnet_render_default_settings(&rs);
    rs.width = 240;
    rs.height = 120;
    rs.samples = rs.simplified = rs.wire = 1;
    epsnet_error err;
    const char *outs[3] = { tl_path("same1.png"), tl_path("same2.png"), tl_path("other.png") };
    for (int i = 0; i < 3; i++) {
        epsnet_context *ctx = new_context();
        if (i == 2)
            rs.azimuth += 10;
        CHECK(epsnet_render_file(ctx, mesh, outs[i], &rs, &err) == 0);
        if (i == 0) {
            const epsnet_stats *st = epsnet_context_stats(ctx);
            CHECK(st->samples > 0 && st->output_faces > 0 && st->output_faces < st->faces);
        }
        epsnet_context_free(&ctx);
    }
    CHECK(tl_same_file(outs[0], outs[1]));
    CHECK(!tl_same_file(outs[0], outs[2]));
}

static uint64_t differing_pixels(const char *a, const char *b)
{
    uint32_t wa = 0, ha = 0, wb = 0, hb = 0;
    uint8_t *pa = read_png(a, &wa, &ha), *pb = read_png(b, &wb, &hb);
    uint64_t n = UINT64_MAX;
    if (pa && pb && wa == wb && ha == hb) {
        n = 0;
        for (size_t i = 0; i < (size_t)wa * ha; i++)
            n += memcmp(pa + 3 * i, pb + 3 * i, 3) != 0;
    }
    free(pa);
    free(pb);
    return n;
}

/* The streamed path (live-vertex table of an .sma, dense table of a PLY)
 * and the in-memory path of --samples draw the same triangles in the same
 * order: the streamed pictures are identical, and the in-memory one differs
 * only under the dots, which at radius 0.25 cover at most one pixel centre
 * each. */
TEST(streaming_and_ordinary_inputs_give_the_same_picture)
{
    const char *ply = gen_file("torus", 8000, "torus.ply");
    const char *sma = gen_file("torus", 8000, "torus.sma");
    epsnet_render_settings rs;
    epsnet_render_default_settings(&rs);
    rs.width = 160;
    rs.height = 120;
    epsnet_error err;
    epsnet_context *ctx = new_context();
    CHECK(epsnet_render_file(ctx, ply, tl_path("t_ply.png"), &rs, &err) == 0);
    uint64_t faces = epsnet_context_stats(ctx)->faces;
    CHECK(faces > 7000 && faces < 9000);
    CHECK(epsnet_render_file(ctx, sma, tl_path("t_sma.png"), &rs, &err) == 0);
    CHECK_EQ_U64(epsnet_context_stats(ctx)->faces, faces);
    /* the stream's live set is far below its vertex count */
    CHECK(epsnet_context_stats(ctx)->max_active < epsnet_context_stats(ctx)->vertices / 4);
    rs.samples = 1;
    rs.dot_radius = 0.25;
    CHECK(epsnet_render_file(ctx, ply, tl_path("t_mem.png"), &rs, &err) == 0);
    uint64_t samples = epsnet_context_stats(ctx)->samples;
    epsnet_context_free(&ctx);
    CHECK(tl_same_file(tl_path("t_ply.png"), tl_path("t_sma.png")));
    uint64_t diff = differing_pixels(tl_path("t_ply.png"), tl_path("t_mem.png"));
    CHECK(samples > 0 && diff <= samples);
}

TEST(empty_mesh_gives_a_blank_picture)
{
    const char *empty = tl_write_str("empty.off", "OFF\n0 0 0\n");
    epsnet_render_settings rs;
    epsnet_render_default_settings(&rs);
    rs.width = 32;
    rs.height = 16;
    epsnet_error err;
    epsnet_context *ctx = new_context();
    const char *out = tl_path("empty.png");
    CHECK(epsnet_render_file(ctx, empty, out, &rs, &err) == 0);
    epsnet_context_free(&ctx);
    uint32_t w = 0, h = 0;
    uint8_t *px = read_png(out, &w, &h);
    CHECK(px && w == 32 && h == 16);
    int blank = px != NULL;
    for (size_t i = 0; px && i < 32 * 16 * 3; i++)
        blank &= px[i] == 255;
    CHECK(blank);
    free(px);
}

TEST(bad_settings_and_bad_input_leave_nothing)
{
    const char *tri = tl_write_str("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    const char *bad = tl_write_str("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
    const char *out = tl_path("never.png");
    epsnet_render_settings rs;
    epsnet_render_default_settings(&rs);
    epsnet_error err;
    epsnet_context *ctx = new_context();
    rs.width = 0;
    CHECK_EQ_INT(epsnet_render_file(ctx, tri, out, &rs, &err), EPSNET_EINVAL);
    rs.width = 64;
    rs.elevation = 95;
    CHECK_EQ_INT(epsnet_render_file(ctx, tri, out, &rs, &err), EPSNET_EINVAL);
    rs.elevation = 0;
    CHECK_EQ_INT(epsnet_render_file(ctx, bad, out, &rs, &err), EPSNET_EFORMAT);
    CHECK_STR_CONTAINS(err.file, "bad.obj");
    CHECK_EQ_U64(err.line, 4);
    CHECK(!tl_exists(out));
    CHECK_EQ_INT(epsnet_render_file(ctx, tri, out, &rs, &err), 0);
    CHECK(tl_exists(out));
    epsnet_context_free(&ctx);
}

TEST(memory_budget_bounds_the_vertex_table)
{
    /* A PLY keeps every vertex position: 5000 vertices need 120 KB, more
     * than a 64 KB budget. The same mesh streamed needs only its width. */
    const char *ply = gen_file("sphere", 10000, "budget.ply");
    const char *sma = gen_file("sphere", 10000, "budget.sma");
    epsnet_settings set;
    epsnet_default_settings(&set);
    set.mem = 64 * 1024;
    epsnet_context *ctx = NULL;
    epsnet_error err;
    CHECK(epsnet_context_new(&ctx, &set, &err) == 0);
    epsnet_render_settings rs;
    epsnet_render_default_settings(&rs);
    rs.width = 64;
    rs.height = 64;
    const char *out = tl_path("budget.png");
    CHECK_EQ_INT(epsnet_render_file(ctx, ply, out, &rs, &err), EPSNET_ELIMIT);
    CHECK_STR_CONTAINS(err.reason, "epsnet sort");
    CHECK(!tl_exists(out));
    CHECK_EQ_INT(epsnet_render_file(ctx, sma, out, &rs, &err), 0);
    CHECK(tl_exists(out));
    epsnet_context_free(&ctx);
}

TEST(png_writer_round_trips_pixels)
{
    uint8_t px[5 * 3 * 3];
    for (size_t i = 0; i < sizeof px; i++)
        px[i] = (uint8_t)(i * 37 + 11);
    epsnet_error err;
    const char *out = tl_path("rt.png");
    CHECK(en_png_write(out, px, 5, 3, &err) == 0);
    uint32_t w = 0, h = 0;
    uint8_t *back = read_png(out, &w, &h);
    CHECK(back && w == 5 && h == 3 && memcmp(back, px, sizeof px) == 0);
    free(back);
    CHECK_EQ_INT(en_png_write(tl_path("no/such/dir.png"), px, 5, 3, &err), EPSNET_EIO);
}

int main(void)
{
    RUN(triangle_covers_exactly_the_pixel_centres_inside_it);
    RUN(either_winding_is_drawn_and_zero_area_draws_nothing);
    RUN(nearer_surface_wins_whatever_the_order);
    RUN(clip_bounds_every_write_even_for_absurd_coordinates);
    RUN(dots_behind_the_surface_are_hidden);
    RUN(camera_frames_the_box_with_the_margin);
    RUN(streaming_table_keeps_only_live_vertices);
    RUN(dense_table_over_budget_is_a_limit);
    RUN(sphere_covers_pi_r_squared_of_the_image);
    RUN(every_picture_frames_the_whole_mesh);
    RUN(same_call_gives_the_same_bytes);
    RUN(streaming_and_ordinary_inputs_give_the_same_picture);
    RUN(empty_mesh_gives_a_blank_picture);
    RUN(bad_settings_and_bad_input_leave_nothing);
    RUN(memory_budget_bounds_the_vertex_table);
    RUN(png_writer_round_trips_pixels);
    tl_cleanup();
    return tl_finish();
}
