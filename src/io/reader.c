/*
 * Reader front end: format selection, the record queue, and the checks every
 * stream gets whatever its format (docs/architecture.md §5): coordinates are finite, triangle
 * corners exist and are not finalized, header counts are not absurd, and a
 * streaming input cannot grow its live set past the memory budget.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "common/alloc.h"
#include "common/idmap.h"
#include "io/format.h"

void epsnet_reader_default_settings(epsnet_reader_settings *s)
{
    memset(s, 0, sizeof *s);
    s->max_count = (uint64_t)1 << 34;
    s->mem_limit = 0;
    s->format = NULL;
}

static int reader_vfail(epsnet_reader *r, int code, uint64_t line, uint64_t offset,
                        const char *fmt, va_list ap)
{
    if (r->failed)
        return r->err.code;
    r->failed = 1;
    en_error_vset(&r->err, code, r->path, line, offset, fmt, ap);
    r->err.zst = r->src && r->src->zstd != NULL && offset != EPSNET_POS_NONE;
    return code;
}

int en_reader_fail(epsnet_reader *r, int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    uint64_t line = EPSNET_POS_NONE, off = EPSNET_POS_NONE;
    if (r->text && r->src)
        line = r->src->lineno ? r->src->lineno : 1;
    else if (r->here_set || r->src)
        off = r->here_set ? r->here : en_source_offset(r->src);
    int rc = reader_vfail(r, code, line, off, fmt, ap);
    va_end(ap);
    return rc;
}

int en_reader_fail_at(epsnet_reader *r, int code, uint64_t offset, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int rc = reader_vfail(r, code, EPSNET_POS_NONE, offset, fmt, ap);
    va_end(ap);
    return rc;
}

int en_reader_check_count(epsnet_reader *r, uint64_t n, const char *what)
{
    if (n > r->settings.max_count)
        return en_reader_fail(r, EPSNET_ELIMIT, "%s %llu exceeds the limit of %llu", what,
                              (unsigned long long)n, (unsigned long long)r->settings.max_count);
    return 0;
}

void en_reader_drop(epsnet_reader *r, const char *name, uint64_t n, int counted)
{
    for (size_t i = 0; i < r->ndrop; i++)
        if (strcmp(r->drop[i].name, name) == 0) {
            r->drop[i].count += n;
            return;
        }
    if (r->ndrop == EN_DROP_MAX) {
        /* note: only a name never seen can land here, and a driver names
         * each item once (PLY) or per statement kind (OBJ); a file with
         * more kinds than that is counted, not listed. */
        r->drop_more++;
        return;
    }
    en_dropped *d = &r->drop[r->ndrop++];
    snprintf(d->name, sizeof d->name, "%s", name);
    d->count = n;
    d->counted = counted;
}

const char *epsnet_reader_dropped(epsnet_reader *r, uint64_t *count)
{
    if (count)
        *count = r ? r->ndrop + r->drop_more : 0;
    if (!r || r->ndrop == 0)
        return NULL;
    size_t cap = r->ndrop * (EN_DROP_NAME + 32) + 64;
    en_free(r->drop_text);
    r->drop_text = en_malloc(cap);
    if (!r->drop_text)
        return "(out of memory listing what is dropped)";
    size_t len = 0;
    for (size_t i = 0; i < r->ndrop; i++) {
        const en_dropped *d = &r->drop[i];
        int n = d->counted ? snprintf(r->drop_text + len, cap - len, "%s%s (%llu)", i ? ", " : "", d->name,
                                      (unsigned long long)d->count)
                           : snprintf(r->drop_text + len, cap - len, "%s%s", i ? ", " : "", d->name);
        if (n > 0)
            len += (size_t)n;
    }
    if (r->drop_more)
        snprintf(r->drop_text + len, cap - len, " and %llu more", (unsigned long long)r->drop_more);
    return r->drop_text;
}

uint64_t en_reader_warn_dropped(epsnet_reader *r, void (*warning)(void *opaque, const char *message),
                                void *opaque)
{
    uint64_t n = 0;
    const char *what = epsnet_reader_dropped(r, &n);
    if (warning && r && r->note[0])
        warning(opaque, r->note);
    if (!what || !warning)
        return n;
    size_t cap = strlen(r->path) + strlen(what) + 16;
    char *msg = en_malloc(cap);
    if (!msg) {
        warning(opaque, what);
        return n;
    }
    snprintf(msg, cap, "%s: dropped: %s", r->path, what);
    warning(opaque, msg);
    en_free(msg);
    return n;
}

static int queue_push(epsnet_reader *r, const epsnet_record *rec)
{
    if (r->qpos == r->qlen)
        r->qpos = r->qlen = 0;
    if (r->qlen == r->qcap &&
        en_grow((void **)&r->queue, &r->qcap, r->qlen + 1, sizeof *r->queue))
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    r->queue[r->qlen++] = *rec;
    return 0;
}

int en_reader_add_attr(epsnet_reader *r, const char *name, epsnet_attr_type type)
{
    return en_reader_add_attr_of(r, name, type, 0);
}

int en_reader_add_attr_of(epsnet_reader *r, const char *name, epsnet_attr_type type, int of_face)
{
    if (epsnet_attr_layout_find(&r->file_attrs, name) >= 0)
        return en_reader_fail(r, EPSNET_EFORMAT, "vertex property '%s' appears twice", name);
    int rc = en_attr_layout_add_as(&r->file_attrs, name, type, of_face);
    if (rc) {
        /* note: past EPSNET_ATTR_MAX, or a name a layout refuses (too long,
         * unprintable bytes): skipped and named, as before attributes were
         * carried (docs/architecture.md §5) */
        char what[EN_DROP_NAME];
        snprintf(what, sizeof what, "vertex property %s", name);
        for (char *c = what; *c; c++)
            if ((unsigned char)*c < 0x20 || (unsigned char)*c == 0x7f)
                *c = '?';
        en_reader_drop(r, what, 0, 0);
        return 0;
    }
    r->info.vertex_attrs = r->file_attrs;
    return 1;
}

static int is_normal(const char *name)
{
    return !strcmp(name, "nx") || !strcmp(name, "ny") || !strcmp(name, "nz");
}

void en_reader_keep_attrs(epsnet_reader *r, const en_format *out, int keep_all, int drop_normals)
{
    const epsnet_attr_layout *f = &r->file_attrs;
    epsnet_attr_layout kept;
    memset(&kept, 0, sizeof kept);
    for (uint32_t i = 0; i < f->count; i++) {
        if (drop_normals && is_normal(f->attr[i].name)) {
            en_reader_drop(r, "vertex normals (--drop-normals: not read; an output that holds normals gets them "
                                  "recomputed from its faces)", 0, 0);
            continue;
        }
        if (keep_all || (out && out->holds_attr && out->holds_attr(f, i))) {
            r->attr_from[kept.count] = f->attr[i].offset;
            (void)en_attr_layout_add_as(&kept, f->attr[i].name, f->attr[i].type, (int)f->attr[i].of_face);
            continue;
        }
        char what[EN_DROP_NAME];
        snprintf(what, sizeof what, "vertex property %s", f->attr[i].name);
        en_reader_drop(r, what, 0, 0);
    }
    r->attrs_subset = kept.count != f->count;
    r->info.vertex_attrs = kept;
}

/* The queue's attribute bytes have room for `need` records.
 * note: made before the vertex is queued, so that a vertex the queue holds
 * always has its bytes: records queued before a failure are delivered. */
static int attr_room(epsnet_reader *r, size_t need)
{
    size_t asz = r->info.vertex_attrs.size;
    if (r->qattr_cap >= need)
        return 0;
    if (need < 2 * r->qattr_cap)
        need = 2 * r->qattr_cap;
    if (need < 64)
        need = 64;
    uint8_t *p = en_realloc(r->qattr, need * asz);
    if (!p)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    r->qattr = p;
    r->qattr_cap = need;
    return 0;
}

static int push_xyz(epsnet_reader *r, double x, double y, double z);

int en_reader_push_vertex(epsnet_reader *r, double x, double y, double z)
{
    return en_reader_push_vertex_attr(r, x, y, z, NULL);
}

int en_reader_push_vertex_attr(epsnet_reader *r, double x, double y, double z, const uint8_t *attr)
{
    const epsnet_attr_layout *l = &r->info.vertex_attrs;
    int rc = l->size ? attr_room(r, r->qlen + 1) : 0;
    if (rc == 0)
        rc = push_xyz(r, x, y, z);
    if (rc || l->size == 0)
        return rc;
    uint8_t *dst = r->qattr + (r->qlen - 1) * (size_t)l->size;
    if (!attr)
        memset(dst, 0, l->size);
    else if (!r->attrs_subset)
        memcpy(dst, attr, l->size);
    else
        for (uint32_t i = 0; i < l->count; i++)
            memcpy(dst + l->attr[i].offset, attr + r->attr_from[i], epsnet_attr_type_size(l->attr[i].type));
    return 0;
}

int en_reader_check_vertex(epsnet_reader *r, double x, double y, double z)
{
    if (!isfinite(x) || !isfinite(y) || !isfinite(z))
        return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu has a non-finite coordinate (%g %g %g)",
                              (unsigned long long)r->nverts + 1, x, y, z);
    if (r->live) {
        if (en_idmap_put(r->live, r->nverts, 0))
            return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
        uint64_t n = r->live->count;
        if (n > r->live_peak)
            r->live_peak = n;
        if (r->settings.mem_limit && en_idmap_bytes(r->live) > r->settings.mem_limit)
            return en_reader_fail(r, EPSNET_ELIMIT,
                                  "%llu vertices are live at once, over the memory budget of %llu bytes "
                                  "(does the stream finalize its vertices?)",
                                  (unsigned long long)n, (unsigned long long)r->settings.mem_limit);
    }
    r->nverts++;
    return 0;
}

static int push_xyz(epsnet_reader *r, double x, double y, double z)
{
    int rc = en_reader_check_vertex(r, x, y, z);
    if (rc)
        return rc;
    epsnet_record rec = { .kind = EPSNET_REC_VERTEX, .xyz = { x, y, z } };
    return queue_push(r, &rec);
}

static int check_corner(epsnet_reader *r, uint64_t v)
{
    if (v >= r->nverts)
        return en_reader_fail(r, EPSNET_EFORMAT,
                              "triangle %llu references vertex %llu but only %llu vertices precede it",
                              (unsigned long long)r->ntris + 1, (unsigned long long)v + 1,
                              (unsigned long long)r->nverts);
    uint32_t unused;
    if (r->live && !en_idmap_get(r->live, v, &unused))
        return en_reader_fail(r, EPSNET_EFORMAT, "triangle %llu references vertex %llu, which was finalized",
                              (unsigned long long)r->ntris + 1, (unsigned long long)v + 1);
    return 0;
}

int en_reader_grow_held(epsnet_reader *r, size_t *held, void **buf, size_t *cap, size_t need, size_t elem,
                        size_t *over)
{
    if (need <= *cap)
        return 0;
    size_t ncap = *cap ? *cap : 1024;
    while (ncap < need && ncap <= SIZE_MAX / 2)
        ncap *= 2;
    if (ncap < need || (elem && ncap > SIZE_MAX / elem))
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    size_t bytes = *held - *cap * elem + ncap * elem;
    if (r->settings.mem_limit && bytes > r->settings.mem_limit) {
        *over = bytes;
        return EPSNET_ELIMIT;
    }
    void *p = en_realloc(*buf, ncap * elem);
    if (!p)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    *buf = p;
    *cap = ncap;
    *held = bytes;
    return 0;
}

int en_reader_check_triangle(epsnet_reader *r, uint64_t a, uint64_t b, uint64_t c)
{
    int rc;
    if ((rc = check_corner(r, a)) || (rc = check_corner(r, b)) || (rc = check_corner(r, c)))
        return rc;
    r->ntris++;
    return 0;
}

int en_reader_push_triangle(epsnet_reader *r, uint64_t a, uint64_t b, uint64_t c)
{
    int rc = en_reader_check_triangle(r, a, b, c);
    if (rc)
        return rc;
    epsnet_record rec = { .kind = EPSNET_REC_TRIANGLE, .v = { a, b, c } };
    return queue_push(r, &rec);
}

void en_reader_count_checked(epsnet_reader *r, uint64_t vertices, uint64_t triangles)
{
    r->nverts += vertices;
    r->ntris += triangles;
}

int en_reader_check_finalize(epsnet_reader *r, uint64_t v)
{
    if (v >= r->nverts)
        return en_reader_fail(r, EPSNET_EFORMAT, "finalizes vertex %llu but only %llu vertices exist",
                              (unsigned long long)v + 1, (unsigned long long)r->nverts);
    if (r->live && !en_idmap_remove(r->live, v))
        return en_reader_fail(r, EPSNET_EFORMAT, "vertex %llu is finalized twice", (unsigned long long)v + 1);
    return 0;
}

int en_reader_push_finalize(epsnet_reader *r, uint64_t v)
{
    int rc = en_reader_check_finalize(r, v);
    if (rc)
        return rc;
    epsnet_record rec = { .kind = EPSNET_REC_FINALIZE, .v = { v, 0, 0 } };
    return queue_push(r, &rec);
}

/* Content that names its format: a magic number (PLY's "ply" line, .smz's
 * eight bytes, an SMB header that checks out) or a binary STL whose face
 * count gives the file's exact size. NULL: the content says nothing sure. */
static const en_format *format_by_magic(const en_source *s, size_t n)
{
    /* the exact size first: an STL title of zero bytes also passes SMB's
     * header checks, which are weaker (no magic number, four small fields) */
    if (!s->zstd && s->file_size >= 84 && n >= 84) {
        const uint8_t *c = s->cur + 80;
        uint64_t faces = (uint64_t)c[0] | (uint64_t)c[1] << 8 | (uint64_t)c[2] << 16 | (uint64_t)c[3] << 24;
        if (84 + 50 * faces == s->file_size)
            return en_format_by_name("stl");
    }
    static const char *const sure[] = { "ply", "smz", "smb" };
    for (size_t k = 0; k < sizeof sure / sizeof *sure; k++) {
        const en_format *f = en_format_by_name(sure[k]);
        if (f && f->probe && f->probe(s->cur, n) >= 50)
            return f;
    }
    return NULL;
}

/*
 * The format: the one forced, else the extension's, else the content's.
 * Content that names its format (format_by_magic) wins over an extension
 * that says otherwise, with a note (a PLY renamed .obj was read as an OBJ
 * of unknown statements: an empty mesh, and success).
 */
static const en_format *detect(epsnet_reader *r, const char *path, const char *forced)
{
    if (forced)
        return en_format_by_name(forced);
    en_source *s = r->src;
    size_t n = en_source_fill(s, 4096);
    const en_format *f = en_format_by_path(path), *magic = format_by_magic(s, n);
    if (f && magic && magic != f) {
        snprintf(r->note, sizeof r->note, "%s: named as %s but its content is %s: read as %s", path, f->name,
                 magic->name, magic->name);
        return magic;
    }
    if (f)
        return f;
    /* Unknown extension: let the content decide. */
    int best = 0;
    for (size_t i = 0; en_formats[i]; i++) {
        int score = en_formats[i]->probe ? en_formats[i]->probe(s->cur, n) : 0;
        if (score > best) {
            best = score;
            f = en_formats[i];
        }
    }
    return best >= 50 ? f : NULL;
}

const char *epsnet_reader_note(const epsnet_reader *r)
{
    return r && r->note[0] ? r->note : NULL;
}

int epsnet_reader_open(epsnet_reader **out, const char *path,
                       const epsnet_reader_settings *settings, epsnet_error *err)
{
    if (!out || !path)
        return en_error_set(err, EPSNET_EINVAL, NULL, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "epsnet_reader_open: NULL argument");
    *out = NULL;
    epsnet_reader *r = en_calloc(1, sizeof *r);
    if (!r)
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    if (settings)
        r->settings = *settings;
    else
        epsnet_reader_default_settings(&r->settings);
    r->path = en_strdup(path);
    if (!r->path) {
        en_free(r);
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    int rc = en_source_open(&r->src, path, err);
    if (rc) {
        epsnet_reader_close(&r);
        return rc;
    }
    r->fmt = detect(r, path, r->settings.format);
    if (!r->fmt) {
        rc = en_error_set(err, EPSNET_EUNSUPPORTED, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                          r->settings.format ? "unknown format '%s' (readable: %s)"
                                             : "cannot tell the mesh format%s (readable: %s)",
                          r->settings.format ? r->settings.format : " from the name or the content",
                          epsnet_formats_readable());
        epsnet_reader_close(&r);
        return rc;
    }
    r->info.format = r->fmt->name;
    r->info.encoding = "ascii";
    r->info.compressed = r->src->zstd != NULL;
    r->info.nverts = EPSNET_COUNT_UNKNOWN;
    r->info.nfaces = EPSNET_COUNT_UNKNOWN;
    r->info.coord_type = EPSNET_COORD_FLOAT32;
    r->info.sorted_axis = -1;
    rc = r->fmt->open_reader(r);
    if (rc == 0 && r->info.streaming) {
        /* note: ids come in order and most die young (a stream's window),
         * so a ring indexed by id answers with one array access where a
         * hash set probes; the ring grows to the window's width. */
        r->live = en_malloc(sizeof *r->live);
        if (!r->live || en_idmap_init_growing(r->live, (size_t)1 << 24)) {
            en_free(r->live);
            r->live = NULL;
            rc = en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
        }
    }
    if (rc) {
        if (err)
            *err = r->err;
        if (!r->failed)
            en_error_set(err, rc, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "%s", epsnet_strerror(rc));
        epsnet_reader_close(&r);
        return rc;
    }
    *out = r;
    return 0;
}

int en_reader_open_memory(epsnet_reader **out, const char *name, const en_format *fmt, void *state,
                          const epsnet_reader_settings *settings, epsnet_error *err)
{
    *out = NULL;
    epsnet_reader *r = en_calloc(1, sizeof *r);
    char *path = en_strdup(name);
    if (!r || !path) {
        en_free(r);
        en_free(path);
        en_free(state);
        return en_error_set(err, EPSNET_ENOMEM, name, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    if (settings)
        r->settings = *settings;
    else
        epsnet_reader_default_settings(&r->settings);
    r->path = path;
    r->fmt = fmt;
    r->state = state;
    r->info.format = fmt->name;
    r->info.encoding = "memory";
    r->info.nverts = EPSNET_COUNT_UNKNOWN;
    r->info.nfaces = EPSNET_COUNT_UNKNOWN;
    r->info.coord_type = EPSNET_COORD_FLOAT32;
    r->info.sorted_axis = -1;
    int rc = fmt->open_reader(r);
    if (rc) {
        if (err)
            *err = r->err;
        if (!r->failed)
            en_error_set(err, rc, name, EPSNET_POS_NONE, EPSNET_POS_NONE, "%s", epsnet_strerror(rc));
        epsnet_reader_close(&r);
        return rc;
    }
    *out = r;
    return 0;
}

const epsnet_mesh_info *epsnet_reader_info(const epsnet_reader *r)
{
    return &r->info;
}

/* Refill the queue when it is empty. @return 1 with records queued, 0 at
 * the end, or a negative code with err filled. */
static int queue_ready(epsnet_reader *r, epsnet_error *err)
{
    while (r->qpos == r->qlen) {
        if (r->failed) {
            if (err)
                *err = r->err;
            return r->err.code;
        }
        if (r->done)
            return 0;
        r->qpos = r->qlen = 0;
        int rc = r->fmt->fill(r);
        if (rc < 0) {
            if (!r->failed)
                en_reader_fail(r, rc, "%s", epsnet_strerror(rc));
            /* note: records the driver queued before it failed are valid and
             * are delivered first; the error follows on the next call. */
            if (r->qlen)
                break;
            if (err)
                *err = r->err;
            return r->err.code;
        }
        if (rc == 0)
            r->done = 1;
    }
    return 1;
}

int epsnet_reader_next(epsnet_reader *r, epsnet_record *rec, epsnet_error *err)
{
    int rc = queue_ready(r, err);
    if (rc <= 0)
        return rc;
    *rec = r->queue[r->qpos];
    rec->attr = NULL;
    if (rec->kind == EPSNET_REC_VERTEX && r->info.vertex_attrs.size)
        rec->attr = r->qattr + r->qpos * (size_t)r->info.vertex_attrs.size;
    r->qpos++;
    return 1;
}

int en_reader_next_batch(epsnet_reader *r, const epsnet_record **recs, size_t *n, epsnet_error *err)
{
    *n = 0;
    if (r->qpos == r->qlen && r->fmt->next_in_place && !r->attrs_subset && !r->failed && !r->done) {
        /* the driver's own records, checked and not copied: the pushes
         * into the queue and its copy were most of the calling thread's
         * reading of a .smz (bench/RESULTS.md, session 39) */
        int rc = r->fmt->next_in_place(r, recs, n);
        if (rc < 0 && !r->failed)
            en_reader_fail(r, rc, "%s", epsnet_strerror(rc));
        if (*n)
            return 1; /* an error follows the records before it, at the next call */
        if (rc == 0) {
            r->done = 1;
            return 0;
        }
        if (rc < 0) {
            if (err)
                *err = r->err;
            return r->err.code;
        }
        /* none in place now: the driver's fill() goes on, through the queue */
    }
    int rc = queue_ready(r, err);
    if (rc <= 0)
        return rc;
    size_t asz = r->info.vertex_attrs.size;
    for (size_t i = r->qpos; i < r->qlen; i++)
        r->queue[i].attr = asz && r->queue[i].kind == EPSNET_REC_VERTEX ? r->qattr + i * asz : NULL;
    *recs = r->queue + r->qpos;
    *n = r->qlen - r->qpos;
    r->qpos = r->qlen;
    return 1;
}

uint64_t epsnet_reader_bytes_read(const epsnet_reader *r)
{
    return r->src ? r->src->raw_read : r->mem_read;
}

uint64_t epsnet_reader_file_size(const epsnet_reader *r)
{
    return r->src ? r->src->file_size : r->mem_size;
}

void epsnet_reader_close(epsnet_reader **pr)
{
    epsnet_reader *r = pr ? *pr : NULL;
    if (!r)
        return;
    if (r->fmt && r->fmt->close_reader)
        r->fmt->close_reader(r);
    if (r->live)
        en_idmap_free(r->live);
    en_free(r->live);
    en_source_close(&r->src);
    en_free(r->queue);
    en_free(r->qattr);
    en_free(r->drop_text);
    en_free(r->path);
    en_free(r);
    *pr = NULL;
}

int en_reader_use_pool(epsnet_reader *r, struct en_pool *pool)
{
    if (!r || !r->state)
        return 0;
    if (r->fmt->use_pool)
        return r->fmt->use_pool(r, pool);
    /* a driver that parses on the caller's thread: its bytes are read ahead */
    return r->src ? en_source_use_pool(r->src, pool) : 0;
}
