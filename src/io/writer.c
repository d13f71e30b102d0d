/*
 * Writer front end: picks the driver, owns the sink (temporary file renamed on
 * commit), and checks that triangles only reference vertices already written.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "io/format.h"
#include "io/text_scan.h"

void epsnet_writer_default_settings(epsnet_writer_settings *s)
{
    memset(s, 0, sizeof *s);
    s->format = NULL;
    s->ascii = 0;
    s->coord_type = -1;
    s->zstd_level = 3;
    s->tmpdir = NULL;
}

int en_writer_printf(epsnet_writer *w, const char *fmt, ...)
{
    char buf[512];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof buf)
        return en_error_set(&w->err, EPSNET_EINTERNAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "formatted output too long");
    return en_writer_bytes(w, buf, (size_t)n);
}

int en_writer_open_spill(epsnet_writer *w, en_spill **sp)
{
    if (*sp)
        return 0;
    char *dir = NULL;
    if (!w->settings.tmpdir && strcmp(w->path, "-") != 0) {
        const char *slash = strrchr(w->path, '/');
        if (!slash)
            dir = en_strdup(".");
        else if (slash == w->path)
            dir = en_strdup("/");
        else if ((dir = en_malloc((size_t)(slash - w->path) + 1))) {
            memcpy(dir, w->path, (size_t)(slash - w->path));
            dir[slash - w->path] = '\0';
        }
        if (!dir)
            return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "out of memory");
    }
    int rc = en_spill_open(sp, w->settings.tmpdir ? w->settings.tmpdir : dir, w->path, &w->err);
    en_free(dir);
    return rc;
}

int en_format_coord(char *buf, double v, epsnet_coord_type t)
{
    /* note: shortest text that parses back to the same bits, so ASCII
     * round trips keep every coordinate exact (docs/method.md §11: output vertices are
     * bit-identical input vertices); src/io/text_scan.c explains the method. */
    return en_text_format_coord(buf, v, t);
}

/* The attributes the format holds go to the driver (w->attrs); the others
 * are named for epsnet_writer_dropped(). @return 0 or -1 out of memory. */
static int choose_attrs(epsnet_writer *w)
{
    const epsnet_attr_layout *in = &w->info.vertex_attrs;
    memset(&w->attrs, 0, sizeof w->attrs);
    for (uint32_t i = 0; i < in->count; i++) {
        if (w->fmt->holds_attr && w->fmt->holds_attr(in, i)) {
            w->attr_from[w->attrs.count] = in->attr[i].offset;
            (void)en_attr_layout_add_as(&w->attrs, in->attr[i].name, in->attr[i].type, (int)in->attr[i].of_face);
            continue;
        }
        char what[EPSNET_ATTR_NAME_MAX + 24];
        snprintf(what, sizeof what, "vertex property %s", in->attr[i].name);
        if (en_writer_drop(w, what))
            return -1;
    }
    w->attrs_subset = w->attrs.count != in->count;
    /* the names a material_index or group_index stands for: OBJ's usemtl
     * and g, PLY's header comments */
    static const char *const names[2] = { "material names (usemtl, mtllib)", "group names (g)" };
    for (int k = 0; k < 2; k++)
        if ((k ? w->info.groups : w->info.materials) &&
            !(w->fmt->holds_names && w->fmt->holds_names(&w->attrs, k)) && en_writer_drop(w, names[k]))
            return -1;
    return 0;
}

int en_writer_drop(epsnet_writer *w, const char *what)
{
    size_t old = w->drop_text ? strlen(w->drop_text) : 0, cap = old + strlen(what) + 3;
    char *t = en_malloc(cap);
    if (!t)
        return -1;
    snprintf(t, cap, "%s%s%s", old ? w->drop_text : "", old ? ", " : "", what);
    en_free(w->drop_text);
    w->drop_text = t;
    w->ndrop++;
    return 0;
}

const char *epsnet_writer_dropped(const epsnet_writer *w, uint64_t *count)
{
    if (count)
        *count = w ? w->ndrop : 0;
    return w ? w->drop_text : NULL;
}

int epsnet_writer_open(epsnet_writer **out, const char *path,
                       const epsnet_writer_settings *settings,
                       const epsnet_mesh_info *info, epsnet_error *err)
{
    if (!out || !path)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_writer_open: NULL argument");
    *out = NULL;
    epsnet_writer *w = en_calloc(1, sizeof *w);
    if (!w)
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    if (settings)
        w->settings = *settings;
    else
        epsnet_writer_default_settings(&w->settings);
    w->path = en_strdup(path);
    w->tmpdir = w->settings.tmpdir ? en_strdup(w->settings.tmpdir) : NULL;
    w->settings.tmpdir = w->tmpdir;
    w->settings.format = NULL; /* resolved below; the caller's string is not kept */
    if (!w->path || (settings && settings->tmpdir && !w->tmpdir)) {
        epsnet_writer_abort(&w);
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    if (info) {
        w->info = *info;
    } else {
        w->info.nverts = w->info.nfaces = EPSNET_COUNT_UNKNOWN;
        w->info.coord_type = EPSNET_COORD_FLOAT32;
        w->info.sorted_axis = -1;
    }
    w->info.format = NULL;
    w->info.encoding = NULL;
    w->coord_type = settings && settings->coord_type >= 0 ? (epsnet_coord_type)settings->coord_type
                                                          : w->info.coord_type;
    const char *fname = settings ? settings->format : NULL;
    w->fmt = fname ? en_format_by_name(fname) : en_format_by_path(path);
    if (!w->fmt || !w->fmt->open_writer) {
        int rc = en_error_set(err, EPSNET_EUNSUPPORTED, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                              "cannot write %s%s (writable: %s)", fname ? "format " : "this file type",
                              fname ? fname : "", epsnet_formats_writable());
        epsnet_writer_abort(&w);
        return rc;
    }
    if (info) {
        char why[256];
        if (en_attr_layout_check(&w->info.vertex_attrs, why, sizeof why)) {
            int rc = en_error_set(err, EPSNET_EINVAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "%s", why);
            epsnet_writer_abort(&w);
            return rc;
        }
    }
    if (choose_attrs(w)) {
        epsnet_writer_abort(&w);
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    int zl = en_path_has_zst(path) ? (w->settings.zstd_level > 0 ? w->settings.zstd_level : 3) : 0;
    int rc = en_sink_open(&w->sink, path, zl, err);
    if (rc == 0) {
        rc = w->fmt->open_writer(w);
        if (rc && err)
            *err = w->err;
    }
    if (rc) {
        epsnet_writer_abort(&w);
        return rc;
    }
    *out = w;
    return 0;
}

int epsnet_writer_put(epsnet_writer *w, const epsnet_record *rec, epsnet_error *err)
{
    if (w->failed)
        goto fail;
    epsnet_record repacked;
    switch (rec->kind) {
    case EPSNET_REC_VERTEX:
        if (w->info.vertex_attrs.count && !rec->attr) {
            en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                         "vertex %llu has no attribute bytes, but the stream announced %u attributes",
                         (unsigned long long)w->nverts + 1, w->info.vertex_attrs.count);
            w->failed = 1;
            goto fail;
        }
        if (w->attrs_subset) {
            repacked = *rec;
            for (uint32_t i = 0; i < w->attrs.count; i++)
                memcpy(w->abuf + w->attrs.attr[i].offset, rec->attr + w->attr_from[i],
                       epsnet_attr_type_size(w->attrs.attr[i].type));
            repacked.attr = w->attrs.count ? w->abuf : NULL;
            rec = &repacked;
        } else if (!w->attrs.count) {
            repacked = *rec;
            repacked.attr = NULL;
            rec = &repacked;
        }
        w->nverts++;
        break;
    case EPSNET_REC_TRIANGLE:
        for (int k = 0; k < 3; k++)
            if (rec->v[k] >= w->nverts) {
                en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                             "triangle %llu references vertex %llu before it was written",
                             (unsigned long long)w->ntris + 1, (unsigned long long)rec->v[k] + 1);
                w->failed = 1;
                goto fail;
            }
        w->ntris++;
        break;
    case EPSNET_REC_FINALIZE:
        if (rec->v[0] >= w->nverts) {
            en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                         "finalizes vertex %llu before it was written", (unsigned long long)rec->v[0] + 1);
            w->failed = 1;
            goto fail;
        }
        break;
    default:
        en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                     "unknown record kind %d", (int)rec->kind);
        w->failed = 1;
        goto fail;
    }
    if (w->fmt->put(w, rec) == 0)
        return 0;
    w->failed = 1;
fail:
    if (err)
        *err = w->err;
    return w->err.code ? w->err.code : EPSNET_EIO;
}

int en_writer_use_pool(epsnet_writer *w, struct en_pool *pool)
{
    if (!w || !w->fmt || !w->fmt->writer_use_pool || !w->state)
        return 0;
    return w->fmt->writer_use_pool(w, pool);
}

/* The driver's end of the file (once: fmt is NULL after it). */
static int finish(epsnet_writer *w, epsnet_error *err)
{
    if (!w->fmt)
        return 0;
    int rc = w->failed ? (w->err.code ? w->err.code : EPSNET_EIO) : w->fmt->finish(w);
    if (rc) {
        if (err)
            *err = w->err;
        return rc;
    }
    if (w->fmt->close_writer)
        w->fmt->close_writer(w);
    w->fmt = NULL;
    return 0;
}

int en_writer_settle(epsnet_writer *w, epsnet_error *err)
{
    int rc = finish(w, err);
    return rc ? rc : en_sink_settle(w->sink, err);
}

int epsnet_writer_commit(epsnet_writer **pw, epsnet_error *err)
{
    epsnet_writer *w = pw ? *pw : NULL;
    if (!w)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_writer_commit: NULL writer");
    int rc = finish(w, err);
    if (rc) {
        epsnet_writer_abort(pw);
        return rc;
    }
    rc = en_sink_commit(&w->sink, err);
    epsnet_writer_abort(pw);
    return rc;
}

void epsnet_writer_abort(epsnet_writer **pw)
{
    epsnet_writer *w = pw ? *pw : NULL;
    if (!w)
        return;
    if (w->fmt && w->fmt->close_writer)
        w->fmt->close_writer(w);
    en_sink_abort(&w->sink);
    en_free(w->drop_text);
    en_free(w->tmpdir);
    en_free(w->path);
    en_free(w);
    *pw = NULL;
}
