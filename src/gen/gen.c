/*
 * Public generator API (epsnet.h §5): settings, info, and the run that
 * pushes records into a writer.
 */
#include <math.h>
#include <string.h>

#include "common/error.h"
#include "gen/gen_internal.h"

void epsnet_gen_default_settings(epsnet_gen_settings *s)
{
    memset(s, 0, sizeof *s);
    s->shape = "sphere";
    s->faces = 20000;
    s->seed = 1;
    s->shuffle = 0;
    s->param = NAN;
}

const char *epsnet_gen_shapes(void)
{
    return "sphere ellipsoid roundcube torus dimple bumpy terrain cad";
}

int epsnet_gen_info(const epsnet_gen_settings *s, epsnet_mesh_info *info, epsnet_error *err)
{
    if (!info)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_gen_info: NULL info");
    en_gen_grid g;
    int rc = en_gen_grid_init(&g, s, err);
    if (rc)
        return rc;
    memset(info, 0, sizeof *info);
    info->format = "gen";
    info->encoding = "synthetic";
    info->compressed = 0;
    info->nverts = g.nrecords;
    info->nfaces = g.nfaces;
    info->has_bbox = 0;
    info->coord_type = EPSNET_COORD_FLOAT32;
    info->streaming = s->shuffle ? 0 : 1;
    info->sorted_axis = s->shuffle ? -1 : g.axis;
    if (g.chart_rows) {
        epsnet_attr_layout_add(&info->vertex_attrs, "texture_u", EPSNET_ATTR_FLOAT32);
        epsnet_attr_layout_add(&info->vertex_attrs, "texture_v", EPSNET_ATTR_FLOAT32);
    }
    return 0;
}

int en_gen_run(const epsnet_gen_settings *s, en_gen_emit_fn emit, void *ctx, en_gen_stats *stats,
               epsnet_error *err)
{
    en_gen_grid g;
    int rc = en_gen_grid_init(&g, s, err);
    if (rc)
        return rc;
    if (s->shuffle)
        return en_gen_emit_shuffled(&g, s->seed, emit, ctx, err);
    return en_gen_emit_sorted(&g, emit, ctx, stats, err);
}

static int put_to_writer(void *ctx, const epsnet_record *rec, epsnet_error *err)
{
    return epsnet_writer_put((epsnet_writer *)ctx, rec, err);
}

int epsnet_gen(const epsnet_gen_settings *s, epsnet_writer *w, epsnet_error *err)
{
    if (!w)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_gen: NULL writer");
    return en_gen_run(s, put_to_writer, w, NULL, err);
}
