/* settings.attribute_weights against the input's properties: see the header. */
#include "api/attr_weights_spec.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/error.h"

static const char *const uv_names[][2] = { { "texture_u", "texture_v" }, { "s", "t" }, { "u", "v" } };
static const char *const normal_names[3] = { "nx", "ny", "nz" };

static int bad(epsnet_error *err, const char *path, const char *why, const char *item)
{
    return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "--attribute-weight: %s: '%s'", why,
                        item);
}

/* Add the properties named to aw at weight w (all must exist: n > 0). */
static int add(en_attr_weights *aw, const epsnet_attr_layout *l, const char *const *names, int n, double w,
               const char *path, const char *item, epsnet_error *err)
{
    for (int i = 0; i < n; i++) {
        int a = epsnet_attr_layout_find(l, names[i]);
        if (a < 0)
            return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "--attribute-weight: no vertex property '%s' to weigh (the input has %u vertex "
                                "properties beyond x, y, z; 'epsnet info' lists them)",
                                names[i], l->count);
        for (uint32_t c = 0; c < aw->channels; c++)
            if (aw->ch[c].offset == l->attr[a].offset)
                return bad(err, path, "a property weighed twice", item);
        if (aw->channels == EN_AQ_MAX_CHANNELS)
            return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "--attribute-weight: more than %d properties weighed", EN_AQ_MAX_CHANNELS);
        aw->ch[aw->channels].offset = l->attr[a].offset;
        aw->ch[aw->channels].type = (int)l->attr[a].type;
        aw->ch[aw->channels].weight = w;
        aw->channels++;
    }
    return 0;
}

/* The input's texture coordinates: a pair of names, or NULL. */
static const char *const *uv_of(const epsnet_attr_layout *l)
{
    for (size_t i = 0; i < sizeof uv_names / sizeof uv_names[0]; i++)
        if (epsnet_attr_layout_find(l, uv_names[i][0]) >= 0 && epsnet_attr_layout_find(l, uv_names[i][1]) >= 0)
            return uv_names[i];
    return NULL;
}

int en_attr_weights_from_spec(en_attr_weights *aw, const epsnet_settings *set, const epsnet_mesh_info *in,
                              const char *path, epsnet_error *err)
{
    memset(aw, 0, sizeof *aw);
    if (!set->attribute_weights)
        return 0;
    static const epsnet_attr_layout none;
    const epsnet_attr_layout *l = in ? &in->vertex_attrs : &none;
    char buf[512];
    if (strlen(set->attribute_weights) >= sizeof buf)
        return bad(err, path, "too long", "...");
    snprintf(buf, sizeof buf, "%s", set->attribute_weights);
    int rc = 0;
    for (char *item = buf, *next; item && rc == 0; item = next) {
        /* (not strtok: a library call may run on any thread) */
        if ((next = strchr(item, ',')) != NULL)
            *next++ = 0;
        char *eq = strchr(item, '=');
        const char *wtext = eq ? eq + 1 : item;
        char *end;
        double w = strtod(wtext, &end);
        if (end == wtext || *end || !isfinite(w) || w < 0)
            return bad(err, path, "a weight is a number, 0 or more", item);
        if (eq)
            *eq = 0;
        const char *const *uv = uv_of(l);
        int has_normals = epsnet_attr_layout_find(l, "nx") >= 0;
        if (!eq) { /* the texture coordinates and normals there are */
            if (uv)
                rc = add(aw, l, uv, 2, w, path, item, err);
            if (rc == 0 && has_normals)
                rc = add(aw, l, normal_names, 3, w, path, item, err);
            if (rc == 0 && !uv && !has_normals && set->warning) {
                char msg[1024];
                snprintf(msg, sizeof msg, "%s: --attribute-weight %s weighs nothing: the input has neither texture "
                         "coordinates nor vertex normals", path ? path : "input", item);
                set->warning(set->warning_opaque, msg);
            }
        } else if (!strcmp(item, "uv")) {
            if (!uv)
                return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                    "--attribute-weight uv: the input has no texture coordinates "
                                    "(texture_u/texture_v, s/t or u/v)");
            rc = add(aw, l, uv, 2, w, path, item, err);
        } else if (!strcmp(item, "normal") || !strcmp(item, "normals")) {
            if (!has_normals)
                return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                    "--attribute-weight %s: the input has no vertex normals (nx, ny, nz)", item);
            rc = add(aw, l, normal_names, 3, w, path, item, err);
        } else if (*item) {
            const char *one = item;
            rc = add(aw, l, &one, 1, w, path, item, err);
        } else {
            return bad(err, path, "a name before '='", "=");
        }
    }
    if (rc || aw->channels == 0)
        return rc;
    if (!in || !in->has_bbox)
        return en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "--attribute-weight needs the mesh's bounding box ahead, to scale the weights by its "
                            "diagonal; this input does not give one (a stream without a header): sort it first "
                            "(epsnet sort)");
    double d2 = 0;
    for (int k = 0; k < 3; k++)
        d2 += (in->bbox_max[k] - in->bbox_min[k]) * (in->bbox_max[k] - in->bbox_min[k]);
    aw->diagonal = sqrt(d2);
    return 0;
}
