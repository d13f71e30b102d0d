#include "io/samples_ply.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "common/error.h"
#include "io/format.h"
#include "io/sink.h"

void en_gvertex_colour(int32_t id, uint8_t rgb[3])
{
    if (id < 0) {
        rgb[0] = rgb[1] = rgb[2] = 160;
        return;
    }
    /* note: golden-ratio hue steps keep neighbouring ids (which are also
     * neighbours on G) visibly different, as in the paper's figures. */
    double h = fmod((double)id * 0.6180339887498949, 1.0) * 6.0;
    double s = 0.75, v = 0.95 - 0.25 * (double)(id % 3) / 2.0;
    int i = (int)h;
    double f = h - i, p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
    double r, g, b;
    switch (i % 6) {
    case 0: r = v, g = t, b = p; break;
    case 1: r = q, g = v, b = p; break;
    case 2: r = p, g = v, b = t; break;
    case 3: r = p, g = q, b = v; break;
    case 4: r = t, g = p, b = v; break;
    default: r = v, g = p, b = q; break;
    }
    rgb[0] = (uint8_t)lround(r * 255);
    rgb[1] = (uint8_t)lround(g * 255);
    rgb[2] = (uint8_t)lround(b * 255);
}

typedef struct out {
    en_sink *sink;
    int ascii;
    epsnet_coord_type ct;
    epsnet_error *err;
} out;

static int put(out *o, const void *p, size_t n)
{
    return en_sink_write(o->sink, p, n, o->err);
}

static int put_text(out *o, const char *text)
{
    return put(o, text, strlen(text));
}

static int header(out *o, uint64_t nv, uint64_t nt, int mesh)
{
    char buf[1024];
    const char *ty = o->ct == EPSNET_COORD_FLOAT64 ? "double" : "float";
    snprintf(buf, sizeof buf,
             "ply\nformat %s 1.0\ncomment epsnet %s samples (paper: Gaussian epsilon-nets)\n"
             "element vertex %llu\nproperty %s x\nproperty %s y\nproperty %s z\n"
             "%sproperty int gvertex\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n",
             o->ascii ? "ascii" : "binary_little_endian", mesh ? "mesh with" : "point set of",
             (unsigned long long)nv, ty, ty, ty, mesh ? "property uchar sample\n" : "");
    int rc = put_text(o, buf);
    if (rc == 0 && mesh) {
        snprintf(buf, sizeof buf, "element face %llu\nproperty list uchar uint vertex_indices\n",
                 (unsigned long long)nt);
        rc = put_text(o, buf);
    }
    return rc ? rc : put_text(o, "end_header\n");
}

static int vertex(out *o, const double *p, int mesh, uint8_t flag, int32_t g)
{
    uint8_t rgb[3];
    en_gvertex_colour(flag ? g : -1, rgb);
    if (flag && g < 0)
        rgb[0] = 255, rgb[1] = 255, rgb[2] = 255; /* locked: white */
    if (o->ascii) {
        char buf[160], c[3][32];
        for (int k = 0; k < 3; k++)
            en_format_coord(c[k], p[k], o->ct);
        if (mesh)
            snprintf(buf, sizeof buf, "%s %s %s %u %d %u %u %u\n", c[0], c[1], c[2], flag, g, rgb[0], rgb[1], rgb[2]);
        else
            snprintf(buf, sizeof buf, "%s %s %s %d %u %u %u\n", c[0], c[1], c[2], g, rgb[0], rgb[1], rgb[2]);
        return put_text(o, buf);
    }
    uint8_t rec[40];
    size_t n = 0;
    for (int k = 0; k < 3; k++) {
        if (o->ct == EPSNET_COORD_FLOAT64) {
            memcpy(rec + n, &p[k], 8);
            n += 8;
        } else {
            float f = (float)p[k];
            memcpy(rec + n, &f, 4);
            n += 4;
        }
    }
    if (mesh)
        rec[n++] = flag;
    memcpy(rec + n, &g, 4);
    n += 4;
    memcpy(rec + n, rgb, 3);
    n += 3;
    return put(o, rec, n);
}

static int begin(out *o, const char *path, int ascii, epsnet_coord_type ct, epsnet_error *err)
{
    o->ascii = ascii;
    o->ct = ct;
    o->err = err;
    o->sink = NULL;
    return en_sink_open(&o->sink, path, en_path_has_zst(path) ? 3 : 0, err);
}

static int end(out *o, int rc)
{
    if (rc == 0)
        return en_sink_commit(&o->sink, o->err);
    en_sink_abort(&o->sink);
    return rc;
}

int en_write_sample_points(const char *path, int ascii, epsnet_coord_type ct, uint64_t nv,
                           const double *pos, const uint8_t *is_sample, const int32_t *gvertex,
                           epsnet_error *err)
{
    out o;
    int rc = begin(&o, path, ascii, ct, err);
    if (rc)
        return rc;
    uint64_t ns = 0;
    for (uint64_t v = 0; v < nv; v++)
        ns += is_sample[v] != 0;
    rc = header(&o, ns, 0, 0);
    for (uint64_t v = 0; v < nv && rc == 0; v++)
        if (is_sample[v])
            rc = vertex(&o, pos + 3 * v, 0, 1, gvertex[v]);
    return end(&o, rc);
}

int en_write_sample_mesh(const char *path, int ascii, epsnet_coord_type ct, uint64_t nv,
                         const double *pos, const uint8_t *is_sample, const int32_t *gvertex,
                         uint64_t nt, const uint32_t *tri, epsnet_error *err)
{
    out o;
    int rc = begin(&o, path, ascii, ct, err);
    if (rc)
        return rc;
    rc = header(&o, nv, nt, 1);
    for (uint64_t v = 0; v < nv && rc == 0; v++)
        rc = vertex(&o, pos + 3 * v, 1, is_sample[v] ? 1 : 0, gvertex[v]);
    for (uint64_t t = 0; t < nt && rc == 0; t++) {
        const uint32_t *c = tri + 3 * t;
        if (ascii) {
            char buf[64];
            snprintf(buf, sizeof buf, "3 %u %u %u\n", c[0], c[1], c[2]);
            rc = put_text(&o, buf);
        } else {
            uint8_t rec[13];
            rec[0] = 3;
            memcpy(rec + 1, c, 12);
            rc = put(&o, rec, 13);
        }
    }
    return end(&o, rc);
}
