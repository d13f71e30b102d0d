/*
 * epsnet_hausdorff_files() and its JSON report: read both meshes through the
 * public reader into indexed arrays (polygons arrive triangulated, zero-area
 * faces as they are) and hand them to the measure in metrics/hausdorff.c.
 */
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "common/error.h"
#include "core/slab.h"
#include "io/sink.h"
#include "metrics/hausdorff.h"

/* Beyond this, the fourth power of an edge length (the zero-area test in
 * metrics/bvh.c compares |n|^2 with it) would overflow a double. */
#define MAX_COORDINATE 1e75

/* Read path into a slab (no stars: distances need none) and refuse
 * coordinates whose squared lengths would overflow the zero-area test.
 * note: the slab's own limits keep every id below UINT32_MAX, which the
 * hierarchy keeps free as "no face". */
static int load_mesh(const char *path, const epsnet_arrays *arrays, en_slab *m, epsnet_error *err)
{
    epsnet_reader *r = NULL;
    int rc = arrays ? epsnet_reader_open_arrays(&r, arrays, NULL, err) : epsnet_reader_open(&r, path, NULL, err);
    if (rc == 0)
        rc = en_slab_read(m, r, path, err);
    epsnet_reader_close(&r);
    for (uint32_t v = 0; rc == 0 && v < m->nv; v++)
        for (int k = 0; k < 3; k++)
            if (fabs(m->pos[3 * (size_t)v + k]) > MAX_COORDINATE) {
                rc = en_error_set(err, EPSNET_EUNSUPPORTED, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                  "vertex %" PRIu32 ": coordinate %g is too large to measure distances "
                                  "(limit 1e75)", v + 1, m->pos[3 * (size_t)v + k]);
                break;
            }
    return rc;
}

/* Both meshes from files (a, b) or from arrays (aa, ab; a and b name them). */
static int measure(const char *a, const epsnet_arrays *aa, const char *b, const epsnet_arrays *ab,
                   const epsnet_hausdorff_settings *s, epsnet_hausdorff_result *out, epsnet_error *err)
{
    epsnet_hausdorff_settings defaults;
    if (!s) {
        epsnet_hausdorff_default_settings(&defaults);
        s = &defaults;
    }
    if (s->samples_per_face < 1 || s->samples_per_face > 100000 || s->threads < 0)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "samples per face must be 1..100000 and threads 0 or more");
    en_slab ma, mb;
    en_slab_init(&ma);
    en_slab_init(&mb);
    int rc = load_mesh(a, aa, &ma, err);
    if (rc == 0)
        rc = load_mesh(b, ab, &mb, err);
    if (rc == 0 && (ma.nt == 0) != (mb.nt == 0))
        rc = en_error_set(err, EPSNET_EINVAL, ma.nt == 0 ? a : b, EPSNET_POS_NONE, EPSNET_POS_NONE,
                          "no faces: the distance to an empty surface is undefined");
    if (rc == 0) {
        en_hd_mesh ha = { ma.pos, ma.nv, ma.tri, ma.nt }, hb = { mb.pos, mb.nv, mb.tri, mb.nt };
        rc = en_hausdorff(&ha, &hb, s, out);
        if (rc == EPSNET_ENOMEM)
            en_error_set(err, rc, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                         "out of memory measuring %s against %s", a, b);
        else if (rc)
            en_error_set(err, rc, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                         "measuring %s against %s failed", a, b);
    }
    en_slab_free(&ma);
    en_slab_free(&mb);
    return rc;
}

int epsnet_hausdorff_files(const char *a, const char *b, const epsnet_hausdorff_settings *s,
                           epsnet_hausdorff_result *out, epsnet_error *err)
{
    en_error_clear(err);
    if (!a || !b || !out)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_hausdorff_files: NULL argument");
    return measure(a, NULL, b, NULL, s, out, err);
}

int epsnet_hausdorff_arrays(const epsnet_arrays *a, const epsnet_arrays *b, const epsnet_hausdorff_settings *s,
                            epsnet_hausdorff_result *out, epsnet_error *err)
{
    en_error_clear(err);
    if (!a || !b || !out)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_hausdorff_arrays: NULL argument");
    return measure(a->name ? a->name : "a", a, b->name ? b->name : "b", b, s, out, err);
}

/* ---- JSON ---- */

static int sink_printf(en_sink *sink, epsnet_error *err, const char *fmt, ...) EN_PRINTF(3, 4);

static int sink_printf(en_sink *sink, epsnet_error *err, const char *fmt, ...)
{
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof buf)
        return en_error_set(err, EPSNET_EINTERNAL, en_sink_path(sink), EPSNET_POS_NONE,
                            EPSNET_POS_NONE, "JSON line too long");
    return en_sink_write(sink, buf, (size_t)n, err);
}

/* A JSON string (or null), escaping quotes, backslashes and control bytes. */
static int sink_json_string(en_sink *sink, const char *text, epsnet_error *err)
{
    if (!text)
        return en_sink_write(sink, "null", 4, err);
    int rc = en_sink_write(sink, "\"", 1, err);
    for (const unsigned char *c = (const unsigned char *)text; rc == 0 && *c; c++) {
        if (*c == '"' || *c == '\\')
            rc = sink_printf(sink, err, "\\%c", *c);
        else if (*c < 0x20)
            rc = sink_printf(sink, err, "\\u%04x", *c);
        else
            rc = en_sink_write(sink, c, 1, err);
    }
    return rc ? rc : en_sink_write(sink, "\"", 1, err);
}

/* value / diagonal, as a JSON number, or null when there is no diagonal. */
static void relative(char *buf, size_t n, double value, double diagonal)
{
    if (diagonal > 0)
        snprintf(buf, n, "%.9g", value / diagonal);
    else
        snprintf(buf, n, "null");
}

static int write_side(en_sink *sink, const char *name, const epsnet_hausdorff_side *s, double diagonal,
                      int last, epsnet_error *err)
{
    char rmax[32], rmean[32], rrms[32];
    relative(rmax, sizeof rmax, s->max, diagonal);
    relative(rmean, sizeof rmean, s->mean, diagonal);
    relative(rrms, sizeof rrms, s->rms, diagonal);
    return sink_printf(sink, err,
                       "  \"%s\": {\"max\": %.17g, \"mean\": %.17g, \"rms\": %.17g, "
                       "\"max_relative\": %s, \"mean_relative\": %s, \"rms_relative\": %s, "
                       "\"max_at\": [%.17g, %.17g, %.17g], \"samples\": %" PRIu64 ", \"area\": %.17g, "
                       "\"normal_deviation_deg\": {\"max\": %.17g, \"mean\": %.17g, \"samples\": %" PRIu64
                       "}}%s\n",
                       name, s->max, s->mean, s->rms, rmax, rmean, rrms, s->max_at[0], s->max_at[1],
                       s->max_at[2], s->samples, s->area,
                       s->normal_max, s->normal_mean, s->normal_samples, last ? "" : ",");
}

static int write_mesh(en_sink *sink, const char *key, const char *name, uint64_t nv, uint64_t nt,
                      uint64_t zero_area, epsnet_error *err)
{
    int rc = sink_printf(sink, err, "  \"%s\": {\"path\": ", key);
    if (rc == 0)
        rc = sink_json_string(sink, name, err);
    if (rc == 0)
        rc = sink_printf(sink, err,
                         ", \"vertices\": %" PRIu64 ", \"faces\": %" PRIu64 ", \"zero_area_faces\": %" PRIu64
                         "},\n",
                         nv, nt, zero_area);
    return rc;
}

int epsnet_hausdorff_write_json(const epsnet_hausdorff_result *r, const char *a_name, const char *b_name,
                                const char *path, epsnet_error *err)
{
    en_error_clear(err);
    if (!r || !path)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_hausdorff_write_json: NULL argument");
    en_sink *sink = NULL;
    int rc = en_sink_open(&sink, path, 0, err);
    if (rc)
        return rc;
    char rh[32];
    relative(rh, sizeof rh, r->hausdorff, r->diagonal);
    rc = sink_printf(sink, err, "{\n  \"command\": \"hausdorff\",\n  \"version\": \"%s\",\n", epsnet_version());
    if (rc == 0)
        rc = write_mesh(sink, "a", a_name, r->a_vertices, r->a_faces, r->a_zero_area_faces, err);
    if (rc == 0)
        rc = write_mesh(sink, "b", b_name, r->b_vertices, r->b_faces, r->b_zero_area_faces, err);
    if (rc == 0)
        rc = sink_printf(sink, err, "  \"diagonal\": %.17g,\n  \"hausdorff\": %.17g,\n  \"hausdorff_relative\": %s,\n",
                         r->diagonal, r->hausdorff, rh);
    if (rc == 0)
        rc = write_side(sink, "a_to_b", &r->a_to_b, r->diagonal, 0, err);
    if (rc == 0)
        rc = write_side(sink, "b_to_a", &r->b_to_a, r->diagonal, 1, err);
    if (rc == 0)
        rc = sink_printf(sink, err, "}\n");
    if (rc == 0)
        return en_sink_commit(&sink, err);
    en_sink_abort(&sink);
    return rc;
}
