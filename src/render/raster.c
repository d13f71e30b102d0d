#include "render/raster.h"

#include <math.h>
#include <string.h>

#include "common/alloc.h"

/* note: a headlight from the upper left, slightly off the view axis, so that
 * faces square to the viewer are bright and the shape still reads from its
 * shading; given toward the light in screen space (x right, y down, depth
 * away). Ambient keeps faces lit edge-on from going black. */
static const double light_dir[3] = { -0.3713906763541037, -0.5570860145311556, -0.7427813527082074 };
static const double ambient = 0.22;
static const uint8_t wire_colour[3] = { 40, 40, 48 };
static const uint8_t outline_colour[3] = { 30, 30, 30 };

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

void en_camera_frame(en_camera *c, const double bmin[3], const double bmax[3], double az_deg, double el_deg,
                     double px, double py, double pw, double ph)
{
    const double deg = 3.14159265358979323846 / 180.0;
    double az = az_deg * deg, el = el_deg * deg;
    memset(c, 0, sizeof *c);
    c->toward_eye[0] = cos(el) * sin(az);
    c->toward_eye[1] = sin(el);
    c->toward_eye[2] = cos(el) * cos(az);
    c->right[0] = cos(az);
    c->right[2] = -sin(az);
    cross3(c->toward_eye, c->right, c->up);
    for (int k = 0; k < 3; k++)
        c->centre[k] = 0.5 * (bmin[k] + bmax[k]);

    /* Extent of the box's projection, from its 8 corners. */
    double lo[2] = { INFINITY, INFINITY }, hi[2] = { -INFINITY, -INFINITY };
    for (int corner = 0; corner < 8; corner++) {
        double d[3];
        for (int k = 0; k < 3; k++)
            d[k] = ((corner >> k) & 1 ? bmax[k] : bmin[k]) - c->centre[k];
        double x = dot3(d, c->right), y = dot3(d, c->up);
        lo[0] = fmin(lo[0], x), hi[0] = fmax(hi[0], x);
        lo[1] = fmin(lo[1], y), hi[1] = fmax(hi[1], y);
    }
    double ex = hi[0] - lo[0], ey = hi[1] - lo[1];
    if (!(ex > 0))
        ex = ey > 0 ? ey : 1.0;
    if (!(ey > 0))
        ey = ex;
    double usable_w = pw * (1 - 2 * EN_CAMERA_MARGIN), usable_h = ph * (1 - 2 * EN_CAMERA_MARGIN);
    c->scale = fmin(usable_w / ex, usable_h / ey);
    if (!(c->scale > 0) || !isfinite(c->scale))
        c->scale = 1.0;
    /* note: a box's projection is symmetric about its centre's, so putting
     * the centre mid-panel centres the picture. */
    c->ox = px + 0.5 * pw;
    c->oy = py + 0.5 * ph;
}

void en_camera_project(const en_camera *c, const double p[3], double out[3])
{
    double d[3] = { p[0] - c->centre[0], p[1] - c->centre[1], p[2] - c->centre[2] };
    out[0] = c->ox + c->scale * dot3(d, c->right);
    out[1] = c->oy - c->scale * dot3(d, c->up);
    out[2] = -c->scale * dot3(d, c->toward_eye);
}

int en_raster_init(en_raster *r, uint32_t width, uint32_t height, const uint8_t background[3])
{
    memset(r, 0, sizeof *r);
    size_t n = (size_t)width * height;
    r->rgb = en_malloc(3 * n + 1);
    r->depth = en_malloc(sizeof *r->depth * n + 1);
    if (!r->rgb || !r->depth) {
        en_raster_free(r);
        return -1;
    }
    r->width = width;
    r->height = height;
    for (size_t i = 0; i < n; i++) {
        memcpy(r->rgb + 3 * i, background, 3);
        r->depth[i] = INFINITY;
    }
    return 0;
}

void en_raster_free(en_raster *r)
{
    en_free(r->rgb);
    en_free(r->depth);
    memset(r, 0, sizeof *r);
}

/* Twice the signed area of (a, b, q): positive when q is on the left of a->b
 * in a y-up frame, i.e. to the right on screen. */
static double edge_fn(const double a[3], const double b[3], double qx, double qy)
{
    return (b[0] - a[0]) * (qy - a[1]) - (b[1] - a[1]) * (qx - a[0]);
}

/* Pixel range [*lo, *hi] whose centres c + 0.5 may lie in [vmin, vmax],
 * limited to [lim0, lim1). @return 0 when empty. Done in double before any
 * conversion, so absurd coordinates cannot overflow an integer. */
static int pixel_span(double vmin, double vmax, uint32_t lim0, uint32_t lim1, uint32_t *lo, uint32_t *hi)
{
    double a = ceil(vmin - 0.5), b = floor(vmax - 0.5);
    if (a < (double)lim0)
        a = (double)lim0;
    if (b > (double)lim1 - 1)
        b = (double)lim1 - 1;
    if (!(a <= b))
        return 0;
    *lo = (uint32_t)a;
    *hi = (uint32_t)b;
    return 1;
}

static uint8_t scale_channel(uint8_t c, double f)
{
    double v = (double)c * f + 0.5;
    return (uint8_t)(v > 255 ? 255 : v < 0 ? 0 : v);
}

static uint8_t mix_channel(uint8_t a, uint8_t b, double t)
{
    double v = (double)a * (1 - t) + (double)b * t + 0.5;
    return (uint8_t)(v > 255 ? 255 : v);
}

uint64_t en_raster_triangle(en_raster *r, const en_clip *clip, const double p[3][3],
                            const en_surface_style *style)
{
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            if (!isfinite(p[i][k]))
                return 0;
    const double *a = p[0], *b = p[1], *c = p[2];
    double area2 = edge_fn(a, b, c[0], c[1]);
    if (area2 == 0 || !isfinite(area2))
        return 0;
    if (area2 < 0) { /* two-sided: either winding is drawn */
        const double *t = b;
        b = c;
        c = t;
        area2 = -area2;
    }
    double e1[3], e2[3], n[3];
    for (int k = 0; k < 3; k++)
        e1[k] = b[k] - a[k], e2[k] = c[k] - a[k];
    cross3(e1, e2, n);
    double nlen = sqrt(dot3(n, n));
    double lambert = nlen > 0 && isfinite(nlen) ? fabs(dot3(n, light_dir)) / nlen : 0;
    double intensity = ambient + (1 - ambient) * lambert;
    uint8_t lit[3];
    for (int k = 0; k < 3; k++)
        lit[k] = scale_channel(style->colour[k], intensity);

    /* Edge lengths turn edge functions into distances in pixels (wire).
     * note: edges fade out on triangles under about 8 pixels across, which
     * would otherwise turn a dense mesh into a black silhouette. */
    double len[3] = { hypot(c[0] - b[0], c[1] - b[1]), hypot(a[0] - c[0], a[1] - c[1]),
                      hypot(b[0] - a[0], b[1] - a[1]) };
    double wire_strength = fmin(1.0, fmax(0.0, (sqrt(0.5 * area2) - 2.0) / 6.0));

    uint32_t x0, x1, y0, y1;
    if (!pixel_span(fmin(a[0], fmin(b[0], c[0])), fmax(a[0], fmax(b[0], c[0])), clip->x0, clip->x1, &x0, &x1) ||
        !pixel_span(fmin(a[1], fmin(b[1], c[1])), fmax(a[1], fmax(b[1], c[1])), clip->y0, clip->y1, &y0, &y1))
        return 0;
    uint64_t written = 0;
    for (uint32_t y = y0; y <= y1; y++) {
        double qy = y + 0.5;
        for (uint32_t x = x0; x <= x1; x++) {
            double qx = x + 0.5;
            double w0 = edge_fn(b, c, qx, qy), w1 = edge_fn(c, a, qx, qy), w2 = edge_fn(a, b, qx, qy);
            if (w0 < 0 || w1 < 0 || w2 < 0)
                continue;
            float z = (float)((w0 * a[2] + w1 * b[2] + w2 * c[2]) / area2);
            size_t i = (size_t)y * r->width + x;
            if (!(z < r->depth[i]))
                continue;
            r->depth[i] = z;
            uint8_t *px = r->rgb + 3 * i;
            memcpy(px, lit, 3);
            if (style->wire && wire_strength > 0) {
                double d = fmin(w0 / len[0], fmin(w1 / len[1], w2 / len[2]));
                double t = d < 1.0 ? 0.85 * wire_strength * (1.0 - d) : 0.0;
                for (int k = 0; k < 3; k++)
                    px[k] = mix_channel(px[k], wire_colour[k], t);
            }
            written++;
        }
    }
    return written;
}

int en_raster_dot(en_raster *r, const en_clip *clip, const double p[3], double radius, double depth_slack,
                  const uint8_t colour[3])
{
    for (int k = 0; k < 3; k++)
        if (!isfinite(p[k]))
            return 0;
    if (!(p[0] >= clip->x0 && p[0] < clip->x1 && p[1] >= clip->y0 && p[1] < clip->y1))
        return 0;
    size_t centre = (size_t)p[1] * r->width + (size_t)p[0];
    if (p[2] > (double)r->depth[centre] + depth_slack)
        return 0;
    uint32_t x0, x1, y0, y1;
    if (!pixel_span(p[0] - radius, p[0] + radius, clip->x0, clip->x1, &x0, &x1) ||
        !pixel_span(p[1] - radius, p[1] + radius, clip->y0, clip->y1, &y0, &y1))
        return 0;
    /* note: a one-pixel outline separates neighbouring dots of similar
     * colour, but on dots under 3 pixels it would be most of the dot. */
    double inner = radius >= 3 ? radius - 1.0 : radius;
    for (uint32_t y = y0; y <= y1; y++)
        for (uint32_t x = x0; x <= x1; x++) {
            double d = hypot(x + 0.5 - p[0], y + 0.5 - p[1]);
            if (d > radius)
                continue;
            memcpy(r->rgb + 3 * ((size_t)y * r->width + x), d > inner ? outline_colour : colour, 3);
        }
    return 1;
}
