/*
 * Software rasterizer for `epsnet render` (issue 9): an orthographic camera
 * framed from a bounding box, a z-buffer, two-sided Lambert shading with a
 * little ambient light, optional wireframe, and depth-tested dots for the
 * samples. Triangles are drawn one at a time as a stream delivers them, so
 * the only memory that grows with the picture is the image itself.
 *
 * Screen space: x to the right and y downwards in pixels, pixel (i, j)
 * covering [i, i+1) x [j, j+1) with its centre at (i + 0.5, j + 0.5); depth
 * in the same units as x and y, growing away from the viewer. Because the
 * projection is a similarity, shading can be computed from screen-space
 * coordinates and gives the same result as in model space.
 *
 * Everything is single-threaded and computed in a fixed order in double
 * precision, so the same calls give the same pixels on every run.
 */
#ifndef EN_RENDER_RASTER_H
#define EN_RENDER_RASTER_H

#include <stdint.h>

/* Margin left on each side of a panel by en_camera_frame(), as a fraction of
 * the panel's width and height. */
#define EN_CAMERA_MARGIN 0.05

typedef struct en_camera {
    double right[3], up[3], toward_eye[3]; /* orthonormal view basis */
    double centre[3];                      /* model point at (ox, oy) */
    double scale;                          /* pixels per model unit */
    double ox, oy;                         /* pixel position of centre */
} en_camera;

/*
 * Look at the box [bmin, bmax] from azimuth az_deg (about +y; 0 looks along
 * -z, 90 along -x) and elevation el_deg (above the xz plane), +y up, and
 * scale it so that the projections of its 8 corners fill the panel
 * [px, px + pw) x [py, py + ph) minus EN_CAMERA_MARGIN on each side, centred.
 * A box that projects to a point or a segment is framed as if its missing
 * extent were the other one (or 1 model unit for a point).
 */
void en_camera_frame(en_camera *c, const double bmin[3], const double bmax[3], double az_deg, double el_deg,
                     double px, double py, double pw, double ph);

/* Screen position (x, y) and depth of model point p. */
void en_camera_project(const en_camera *c, const double p[3], double out[3]);

typedef struct en_raster {
    uint32_t width, height;
    uint8_t *rgb;     /* 3 bytes per pixel, rows top to bottom */
    float *depth;     /* per pixel, INFINITY where nothing is drawn */
} en_raster;

/* Allocate a width x height image filled with background.
 * @return 0, or -1 when out of memory (r is then empty). */
int en_raster_init(en_raster *r, uint32_t width, uint32_t height, const uint8_t background[3]);
void en_raster_free(en_raster *r);

/* Pixels a draw call may touch: [x0, x1) x [y0, y1), inside the image. */
typedef struct en_clip {
    uint32_t x0, y0, x1, y1;
} en_clip;

typedef struct en_surface_style {
    uint8_t colour[3];    /* albedo of the surface */
    int wire;             /* 1: darken the pixels within a pixel of an edge */
} en_surface_style;

/*
 * Draw the triangle with screen-space corners p[0..2] (from
 * en_camera_project): every pixel whose centre lies inside or on it and whose
 * depth is nearer than what is there. Zero-area and non-finite triangles
 * draw nothing.
 * @return the number of pixels written.
 */
uint64_t en_raster_triangle(en_raster *r, const en_clip *clip, const double p[3][3],
                            const en_surface_style *style);

/*
 * Draw a dot of the given radius (pixels) centred at screen point p, with a
 * dark outline from radius 3 up, when p's depth is at most depth_slack behind the surface
 * drawn at its centre pixel (so samples on the visible side show and those
 * on the far side do not). Dots are drawn over the surface, not into the
 * z-buffer.
 * @return 1 when drawn, 0 when hidden or outside the clip.
 */
int en_raster_dot(en_raster *r, const en_clip *clip, const double p[3], double radius, double depth_slack,
                  const uint8_t colour[3]);

#endif /* EN_RENDER_RASTER_H */
