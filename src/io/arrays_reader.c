/*
 * A reader over arrays in the caller's memory (epsnet.h §13): the driver
 * contract of format.h with no en_source behind it. It gives the records a
 * PLY of the same content gives (every vertex in array order, then every
 * face, no finalization), so every stage after it (the sort, the chain, the
 * in-core jobs, the measure) treats arrays as it treats that file
 * (docs/architecture.md §14).
 *
 * note: the front end's checks (finite coordinates, corners that exist)
 * would also catch bad values, but they count from 1 like a file's lines.
 * A caller of arrays indexes from 0 and has negative indices to make, so
 * this driver checks each value first and names it as the caller would
 * write it: faces[12, 1].
 */
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "common/alloc.h"
#include "io/format.h"

/* Records pushed per fill: the queue stays small whatever the mesh. */
#define FILL_RECORDS 8192

typedef struct arrays_state {
    epsnet_arrays a;
    uint64_t next_vertex, next_face;
    size_t xyz_bytes;                /* bytes of one coordinate */
    uint8_t packed[EPSNET_ATTR_MAX * 8];
} arrays_state;

void epsnet_arrays_init(epsnet_arrays *a)
{
    memset(a, 0, sizeof *a);
    a->coord_type = EPSNET_COORD_FLOAT32;
    a->index_bytes = 4;
}

/* Bytes of one vertex and of one face: what progress counts. */
static uint64_t vertex_bytes(const arrays_state *st)
{
    return 3 * st->xyz_bytes + st->a.attrs.size;
}

static int open_arrays(epsnet_reader *r)
{
    arrays_state *st = r->state;
    for (uint32_t i = 0; i < st->a.attrs.count; i++) {
        int rc = en_reader_add_attr_of(r, st->a.attrs.attr[i].name, st->a.attrs.attr[i].type,
                                       (int)st->a.attrs.attr[i].of_face);
        if (rc < 0)
            return rc;
    }
    r->info.nverts = st->a.nverts;
    r->info.nfaces = st->a.nfaces;
    r->info.coord_type = st->a.coord_type;
    r->mem_size = st->a.nverts * vertex_bytes(st) + st->a.nfaces * 3 * (uint64_t)st->a.index_bytes;
    return 0;
}

static int push_vertex(epsnet_reader *r, arrays_state *st, uint64_t v)
{
    double p[3];
    if (st->a.coord_type == EPSNET_COORD_FLOAT32) {
        const float *f = (const float *)st->a.xyz + 3 * v;
        p[0] = f[0], p[1] = f[1], p[2] = f[2];
    } else {
        const double *d = (const double *)st->a.xyz + 3 * v;
        p[0] = d[0], p[1] = d[1], p[2] = d[2];
    }
    if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
        return en_reader_fail(r, EPSNET_EFORMAT, "vertices[%" PRIu64 "] is not finite (%g %g %g)", v, p[0], p[1],
                              p[2]);
    const epsnet_attr_layout *l = &st->a.attrs;
    for (uint32_t i = 0; i < l->count; i++) {
        size_t n = epsnet_attr_type_size(l->attr[i].type);
        memcpy(st->packed + l->attr[i].offset, (const uint8_t *)st->a.attr[i] + n * v, n);
    }
    return en_reader_push_vertex_attr(r, p[0], p[1], p[2], l->count ? st->packed : NULL);
}

static int push_face(epsnet_reader *r, arrays_state *st, uint64_t f)
{
    uint64_t c[3];
    for (int k = 0; k < 3; k++) {
        int64_t i = st->a.index_bytes == 4 ? ((const int32_t *)st->a.faces)[3 * f + (uint64_t)k]
                                           : ((const int64_t *)st->a.faces)[3 * f + (uint64_t)k];
        if (i < 0 || (uint64_t)i >= st->a.nverts)
            return st->a.nverts ? en_reader_fail(r, EPSNET_EFORMAT,
                                                 "faces[%" PRIu64 ", %d] = %" PRId64
                                                 " is not a vertex index (0 .. %" PRIu64 ")",
                                                 f, k, i, st->a.nverts - 1)
                                : en_reader_fail(r, EPSNET_EFORMAT,
                                                 "faces[%" PRIu64 ", %d] = %" PRId64 " names a vertex, but there are none",
                                                 f, k, i);
        c[k] = (uint64_t)i;
    }
    return en_reader_push_triangle(r, c[0], c[1], c[2]);
}

static int fill_arrays(epsnet_reader *r)
{
    arrays_state *st = r->state;
    int rc = 0;
    int n = 0;
    for (; rc == 0 && n < FILL_RECORDS; n++) {
        if (st->next_vertex < st->a.nverts)
            rc = push_vertex(r, st, st->next_vertex++);
        else if (st->next_face < st->a.nfaces)
            rc = push_face(r, st, st->next_face++);
        else
            break;
    }
    r->mem_read = st->next_vertex * vertex_bytes(st) + st->next_face * 3 * (uint64_t)st->a.index_bytes;
    return rc < 0 ? rc : n > 0;
}

static void close_arrays(epsnet_reader *r)
{
    en_free(r->state);
    r->state = NULL;
}

static const en_format arrays_format = {
    .name = "arrays",
    .extensions = "",
    .open_reader = open_arrays,
    .fill = fill_arrays,
    .close_reader = close_arrays,
};

/* What the caller described: counts with their arrays, known types, and a
 * layout that is packed (en_attr_layout_check) with every column given. */
static int check_arrays(const epsnet_arrays *a, const char *name, epsnet_error *err)
{
    const char *why = NULL;
    char buf[256];
    if (a->nverts && !a->xyz)
        why = "vertices are counted but not given";
    else if (a->nfaces && !a->faces)
        why = "faces are counted but not given";
    else if (a->coord_type != EPSNET_COORD_FLOAT32 && a->coord_type != EPSNET_COORD_FLOAT64)
        why = "coordinates must be float32 or float64";
    else if (a->index_bytes != 4 && a->index_bytes != 8)
        why = "face indices must be 4 or 8 bytes (int32 or int64)";
    else if (a->nverts > ((uint64_t)1 << 40) || a->nfaces > ((uint64_t)1 << 40))
        why = "more than 2^40 vertices or faces";
    else if (en_attr_layout_check(&a->attrs, buf, sizeof buf))
        why = buf;
    for (uint32_t i = 0; !why && a->nverts && i < a->attrs.count; i++)
        if (!a->attr[i]) {
            snprintf(buf, sizeof buf, "attribute '%s' has no values", a->attrs.attr[i].name);
            why = buf;
        }
    return why ? en_error_set(err, EPSNET_EINVAL, name, EPSNET_POS_NONE, EPSNET_POS_NONE, "%s", why) : 0;
}

int epsnet_reader_open_arrays(epsnet_reader **r, const epsnet_arrays *a, const epsnet_reader_settings *settings,
                              epsnet_error *err)
{
    if (!r || !a)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_reader_open_arrays: NULL argument");
    *r = NULL;
    const char *name = a->name ? a->name : "arrays";
    int rc = check_arrays(a, name, err);
    if (rc)
        return rc;
    arrays_state *st = en_calloc(1, sizeof *st);
    if (!st)
        return en_error_set(err, EPSNET_ENOMEM, name, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    st->a = *a;
    st->xyz_bytes = a->coord_type == EPSNET_COORD_FLOAT32 ? sizeof(float) : sizeof(double);
    return en_reader_open_memory(r, name, &arrays_format, st, settings, err);
}
