/*
 * Settings, the context's lifecycle and its statistics
 * (one opaque context per job, configured by a settings struct with defaults).
 */
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "api/context.h"
#include "api/run.h"
#include "common/alloc.h"
#include "common/error.h"
#include "io/sink.h"

void epsnet_default_settings(epsnet_settings *s)
{
    memset(s, 0, sizeof *s);
    s->level = 3;
    s->frequency = 0;
    s->rotation_mode = EPSNET_ROTATION_DEFAULT;
    s->rotation[0] = 1;
    s->seed = 1;
    s->threads = 0;
    s->mem = 0;
    s->passes = 1;
    s->max_normal_dev = 60.0;
    s->ascii = 0;
}

static int bad(epsnet_error *err, const char *what)
{
    return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "%s", what);
}

/* G from the settings: frequency or level, and the rotation. */
static int make_sphere(const epsnet_settings *s, gauss_sphere *g, epsnet_error *err)
{
    gauss_rotation r;
    switch (s->rotation_mode) {
    case EPSNET_ROTATION_DEFAULT: gauss_rotation_default(&r); break;
    case EPSNET_ROTATION_IDENTITY: gauss_rotation_identity(&r); break;
    case EPSNET_ROTATION_SEED: gauss_rotation_from_seed(s->seed, &r); break;
    case EPSNET_ROTATION_QUATERNION:
        if (gauss_rotation_quaternion(s->rotation[0], s->rotation[1], s->rotation[2], s->rotation[3], &r))
            return bad(err, "the rotation quaternion must be finite and non-zero");
        break;
    default: return bad(err, "unknown rotation mode");
    }
    if (s->frequency) {
        if (gauss_init(g, s->frequency, &r))
            return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "frequency must be between 1 and %u", GAUSS_MAX_FREQUENCY);
    } else if (gauss_init_level(g, s->level, &r)) {
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "level must be between 0 and %d", GAUSS_MAX_LEVEL);
    }
    return 0;
}

int epsnet_context_new(epsnet_context **out, const epsnet_settings *settings, epsnet_error *err)
{
    if (!out)
        return bad(err, "epsnet_context_new: NULL ctx");
    *out = NULL;
    epsnet_context *c = en_calloc(1, sizeof *c);
    if (!c)
        return en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    if (settings)
        c->settings = *settings;
    else
        epsnet_default_settings(&c->settings);
    const char *why = NULL;
    if (c->settings.threads < 0)
        why = "threads must be 0 (all cores) or more";
    else if (c->settings.passes < 1)
        why = "passes must be 1 or more";
    else if (!(c->settings.max_normal_dev > 0 && c->settings.max_normal_dev <= 180))
        why = "max_normal_dev must be in (0, 180] degrees";
    else if ((c->settings.target_faces > 0) + (c->settings.target_ratio != 0) + (c->settings.target_vertices > 0) > 1)
        why = "give one target size: target_faces, target_ratio or target_vertices";
    else if (c->settings.target_ratio != 0 && !(c->settings.target_ratio > 0 && c->settings.target_ratio <= 1))
        why = "target_ratio must be in (0, 1]";
    else if (!(c->settings.target_error >= 0 && c->settings.target_error < INFINITY))
        why = "target_error must be 0 (none) or a positive number";
    else if (c->settings.passes > 1 && en_run_has_target(&c->settings))
        why = "a target size or error needs passes = 1";
    if (why) {
        en_free(c);
        return bad(err, why);
    }
    int rc = make_sphere(&c->settings, &c->sphere, err);
    if (rc == 0 && c->settings.tmpdir) {
        c->tmpdir = en_strdup(c->settings.tmpdir);
        if (!c->tmpdir)
            rc = en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    c->settings.tmpdir = c->tmpdir;
    if (rc == 0 && c->settings.lock_property) {
        c->lock_property = en_strdup(c->settings.lock_property);
        if (!c->lock_property)
            rc = en_error_set(err, EPSNET_ENOMEM, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    c->settings.lock_property = c->lock_property;
    if (rc) {
        epsnet_context_free(&c);
        return rc;
    }
    *out = c;
    return 0;
}

void epsnet_context_free(epsnet_context **pc)
{
    if (!pc || !*pc)
        return;
    en_free((*pc)->tmpdir);
    en_free((*pc)->lock_property);
    en_free(*pc);
    *pc = NULL;
}

const epsnet_stats *epsnet_context_stats(const epsnet_context *c)
{
    return &c->stats;
}

/* The level of frequency n (n = 2^level), or -1 when n is not a power of 2. */
static int level_of(uint32_t n)
{
    for (int l = 0; l <= GAUSS_MAX_LEVEL; l++)
        if (n == 1u << l)
            return l;
    return -1;
}

int epsnet_stats_write_json(const epsnet_context *c, const char *command, const char *path,
                            epsnet_error *err)
{
    const epsnet_stats *s = &c->stats;
    const epsnet_settings *st = &c->settings;
    const gauss_sphere *g = c->run_sphere.n ? &c->run_sphere : &c->sphere;
    char buf[4096];
    int n = snprintf(buf, sizeof buf,
        "{\n"
        "  \"command\": \"%s\",\n"
        "  \"version\": \"%s\",\n"
        "  \"gaussian_sphere\": {\"level\": %d, \"frequency\": %u, \"vertices\": %u, \"triangles\": %u},\n"
        "  \"passes_requested\": %d,\n"
        "  \"max_normal_dev\": %.6g,\n"
        "  \"attribute_channels\": %" PRIu32 ",\n"
        "  \"vertices\": %" PRIu64 ",\n"
        "  \"faces\": %" PRIu64 ",\n"
        "  \"zero_area_faces\": %" PRIu64 ",\n"
        "  \"isolated_vertices\": %" PRIu64 ",\n"
        "  \"gaussian_vertices\": %" PRIu64 ",\n"
        "  \"feature_edges\": %" PRIu64 ",\n"
        "  \"candidates\": %" PRIu64 ",\n"
        "  \"samples\": %" PRIu64 ",\n"
        "  \"locked\": %" PRIu64 ",\n"
        "  \"boundary_vertices\": %" PRIu64 ",\n"
        "  \"nonmanifold_vertices\": %" PRIu64 ",\n"
        "  \"seam_vertices\": %" PRIu64 ",\n"
        "  \"cut_end_vertices\": %" PRIu64 ",\n"
        "  \"needle_vertices\": %" PRIu64 ",\n"
        "  \"multi_cover_samples\": %" PRIu64 ",\n"
        "  \"output_vertices\": %" PRIu64 ",\n"
        "  \"output_faces\": %" PRIu64 ",\n"
        "  \"collapses\": %" PRIu64 ",\n"
        "  \"passes\": %" PRIu64 ",\n"
        "  \"remaining_nonsamples\": %" PRIu64 ",\n"
        "  \"refused\": {\"link\": %" PRIu64 ", \"normal\": %" PRIu64 ", \"zero_area\": %" PRIu64
        ", \"duplicate\": %" PRIu64 "},\n"
        "  \"max_active\": %" PRIu64 ",\n"
        "  \"slabs\": %" PRIu64 ",\n"
        "  \"slabs_shipped\": %" PRIu64 ",\n"
        "  \"seams\": {\"faces\": %" PRIu64 ", \"collapses\": %" PRIu64 "},\n"
        "  \"nonsamples\": {\"band\": %" PRIu64 ", \"band_left\": %" PRIu64 ", \"inner\": %" PRIu64
        ", \"inner_left\": %" PRIu64 "},\n"
        "  \"target\": {\"faces\": %" PRIu64 ", \"skeleton_vertices\": %" PRIu64 ", \"samples_given_up\": %" PRIu64
        ", \"membrane_faces\": %" PRIu64 ", \"finest_frequency\": %" PRIu32 ", \"rounds\": %" PRIu32
        ", \"round_retries\": %" PRIu32 ", \"price_ceiling\": %.9g, \"price_vertices\": %" PRIu64 "},\n"
        "  \"dropped\": %" PRIu64 ",\n"
        "  \"peak_rss\": %" PRIu64 ",\n"
        "  \"budget\": {\"total\": %" PRIu64 ", \"reader\": %" PRIu64 ", \"sort\": %" PRIu64 ", \"chain\": %" PRIu64
        ", \"one_slab\": %" PRIu64 "},\n"
        "  \"seconds\": {\"read\": %.6f, \"normals\": %.6f, \"classify\": %.6f, \"simplify\": %.6f, "
        "\"write\": %.6f, \"sort\": %.6f},\n"
        "  \"cpu\": {\"main\": %.6f, \"workers\": %.6f}\n"
        "}\n",
        command ? command : c->command, epsnet_version(), level_of(g->n), g->n, g->nverts, g->ntris, st->passes, st->max_normal_dev, s->attribute_channels, s->vertices, s->faces,
        s->zero_area_faces, s->isolated_vertices, s->gaussian_vertices, s->feature_edges, s->candidates,
        s->samples, s->locked, s->boundary_vertices, s->nonmanifold_vertices, s->seam_vertices, s->cut_end_vertices, s->needle_vertices,
        s->multi_cover_samples, s->output_vertices, s->output_faces, s->collapses, s->passes,
        s->remaining_nonsamples, s->refused_link, s->refused_normal, s->refused_zero_area, s->refused_duplicate,
        s->max_active, s->slabs, s->slabs_shipped, s->seam_faces, s->seam_collapses, s->band_nonsamples,
        s->band_nonsamples_left, s->inner_nonsamples, s->inner_nonsamples_left, s->target_faces, s->skeleton_vertices, s->samples_given_up, s->membrane_faces, s->skeleton_finest_frequency, s->target_rounds, s->target_round_retries, s->target_price_ceiling, s->target_price_vertices, s->dropped, s->peak_rss, s->budget_total, s->budget_reader, s->budget_sort, s->budget_chain, s->budget_one_slab, s->seconds_read, s->seconds_normals, s->seconds_classify,
        s->seconds_simplify, s->seconds_write, s->seconds_sort, s->cpu_main, s->cpu_workers);
    if (n < 0 || (size_t)n >= sizeof buf)
        return en_error_set(err, EPSNET_EINTERNAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "stats too long");
    en_sink *sink = NULL;
    int rc = en_sink_open(&sink, path, 0, err);
    if (rc == 0)
        rc = en_sink_write(sink, buf, (size_t)n, err);
    if (rc == 0)
        return en_sink_commit(&sink, err);
    en_sink_abort(&sink);
    return rc;
}

int epsnet_parse_rotation(const char *text, epsnet_settings *s)
{
    if (!text || !s)
        return EPSNET_EINVAL;
    if (strcmp(text, "default") == 0) {
        s->rotation_mode = EPSNET_ROTATION_DEFAULT;
        return 0;
    }
    if (strcmp(text, "identity") == 0) {
        s->rotation_mode = EPSNET_ROTATION_IDENTITY;
        return 0;
    }
    int quat = strncmp(text, "q:", 2) == 0;
    double v[4];
    char tail;
    if (sscanf(quat ? text + 2 : text, "%lf,%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &v[3], &tail) != 4)
        return EPSNET_EINVAL;
    for (int i = 0; i < 4; i++)
        if (!isfinite(v[i]))
            return EPSNET_EINVAL;
    if (!quat) {
        double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if (len == 0)
            return EPSNET_EINVAL;
        double half = v[3] * (M_PI / 360.0);
        double sn = sin(half) / len;
        double q[4] = { cos(half), v[0] * sn, v[1] * sn, v[2] * sn };
        memcpy(v, q, sizeof q);
    } else if (v[0] == 0 && v[1] == 0 && v[2] == 0 && v[3] == 0) {
        return EPSNET_EINVAL;
    }
    s->rotation_mode = EPSNET_ROTATION_QUATERNION;
    memcpy(s->rotation, v, sizeof v);
    return 0;
}
