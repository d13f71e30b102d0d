/*
 * STL reader and writer (docs/architecture.md §13: ascii and binary, with
 * coincident corners welded exactly when read).
 *
 * STL stores three corners per facet and no indices. Corners are welded into
 * an indexed mesh when their float32 coordinates are bit-identical, with -0.0
 * and +0.0 taken as the same value; nothing else is merged, so no tolerance
 * can change the topology. A vertex record is emitted when its point is
 * first seen, then the triangle, which is a valid record order. The weld map
 * grows with the number of distinct points and respects the reader's memory
 * budget.
 *
 * Binary or ascii? Many binary files start their 80-byte header with
 * "solid", so that word proves nothing: a file whose size is exactly
 * 84 + 50 * count is binary; otherwise a file that starts with "solid" and
 * reads as text is ascii; anything else is binary (and a count that does not
 * match the size is then a lying header).
 */
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "common/idmap.h"
#include "io/format.h"

#define STL_HEADER 84
#define STL_RECORD 50
#define STL_BATCH 4096
#define STL_LINE_MAX ((size_t)1 << 16)
#define STL_SNIFF 512

/* ------------------------------------------------------------------------
 * Exact weld map: float32 bit patterns -> vertex index
 * ------------------------------------------------------------------------ */

typedef struct stl_weld_slot {
    uint32_t key[3];
    uint64_t index;          /* STL_EMPTY when the slot is free */
} stl_weld_slot;

#define STL_EMPTY UINT64_MAX

typedef struct stl_weld {
    stl_weld_slot *slots;
    size_t cap;              /* power of two */
    size_t used;
} stl_weld;

static uint32_t float_key(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    return u == 0x80000000u ? 0 : u;   /* -0.0 welds with +0.0 */
}

static size_t weld_hash(const uint32_t key[3])
{
    uint64_t h = key[0] * 0x9E3779B97F4A7C15ull;
    h ^= (h >> 29) ^ key[1] * 0xC2B2AE3D27D4EB4Full;
    h ^= (h >> 31) ^ key[2] * 0x165667B19E3779F9ull;
    h ^= h >> 32;
    return (size_t)h;
}

static int weld_grow(epsnet_reader *r, stl_weld *w)
{
    size_t cap = w->cap ? w->cap * 2 : 4096;
    if (cap > SIZE_MAX / sizeof(stl_weld_slot))
        return en_reader_fail(r, EPSNET_ELIMIT, "too many distinct vertices to weld");
    uint64_t bytes = (uint64_t)cap * sizeof(stl_weld_slot);
    if (r->settings.mem_limit && bytes > r->settings.mem_limit)
        return en_reader_fail(r, EPSNET_ELIMIT,
                              "welding %zu distinct vertices needs %" PRIu64 " bytes, over the memory budget "
                              "of %" PRIu64 " bytes",
                              w->used + 1, bytes, r->settings.mem_limit);
    stl_weld_slot *slots = en_malloc((size_t)bytes);
    if (!slots)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory welding %zu vertices", w->used + 1);
    for (size_t i = 0; i < cap; i++)
        slots[i].index = STL_EMPTY;
    for (size_t i = 0; i < w->cap; i++) {
        if (w->slots[i].index == STL_EMPTY)
            continue;
        size_t j = weld_hash(w->slots[i].key) & (cap - 1);
        while (slots[j].index != STL_EMPTY)
            j = (j + 1) & (cap - 1);
        slots[j] = w->slots[i];
    }
    en_free(w->slots);
    w->slots = slots;
    w->cap = cap;
    return 0;
}

/* Index of the corner p, pushing a vertex record when p is new. */
static int weld_corner(epsnet_reader *r, stl_weld *w, const float p[3], uint64_t *index)
{
    if ((w->used + 1) * 2 > w->cap) {
        int rc = weld_grow(r, w);
        if (rc)
            return rc;
    }
    uint32_t key[3] = { float_key(p[0]), float_key(p[1]), float_key(p[2]) };
    size_t j = weld_hash(key) & (w->cap - 1);
    for (; w->slots[j].index != STL_EMPTY; j = (j + 1) & (w->cap - 1)) {
        const stl_weld_slot *s = &w->slots[j];
        if (s->key[0] == key[0] && s->key[1] == key[1] && s->key[2] == key[2]) {
            *index = s->index;
            return 0;
        }
    }
    *index = r->nverts;
    int rc = en_reader_push_vertex(r, p[0], p[1], p[2]);
    if (rc)
        return rc;
    memcpy(w->slots[j].key, key, sizeof key);
    w->slots[j].index = *index;
    w->used++;
    return 0;
}

static int weld_facet(epsnet_reader *r, stl_weld *w, const float corner[3][3])
{
    uint64_t v[3];
    for (int k = 0; k < 3; k++) {
        int rc = weld_corner(r, w, corner[k], &v[k]);
        if (rc)
            return rc;
    }
    return en_reader_push_triangle(r, v[0], v[1], v[2]);
}

/* ------------------------------------------------------------------------
 * Reader state
 * ------------------------------------------------------------------------ */

typedef struct stl_reader {
    int binary;
    stl_weld weld;
    uint64_t facets;         /* facets read so far */
    /* binary */
    uint64_t count;          /* facets announced in the header */
    /* ascii */
    char *cursor;            /* rest of the current line */
    int in_solid;
    int seen_solid;
} stl_reader;

static int adopt_error(epsnet_reader *r, const epsnet_error *e)
{
    if (!r->failed) {
        r->failed = 1;
        r->err = *e;
    }
    return r->err.code;
}

static int source_failure(epsnet_reader *r)
{
    epsnet_error e;
    en_source_error(r->src, &e);
    return adopt_error(r, &e);
}

static uint32_t load_le32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static float load_le_float(const uint8_t *p)
{
    uint32_t u = load_le32(p);
    float f;
    memcpy(&f, &u, 4);
    return f;
}

/* ------------------------------------------------------------------------
 * Binary
 * ------------------------------------------------------------------------ */

static int binary_open(epsnet_reader *r, stl_reader *st)
{
    en_source *s = r->src;
    if (en_source_fill(s, STL_HEADER) < STL_HEADER) {
        if (s->failed)
            return source_failure(r);
        return en_reader_fail_at(r, EPSNET_EFORMAT, en_source_offset(s),
                                 "truncated file: a binary STL starts with an 84-byte header");
    }
    st->count = load_le32(s->cur + 80);
    if (!s->zstd && s->file_size && STL_HEADER + STL_RECORD * st->count != s->file_size)
        return en_reader_fail_at(r, EPSNET_EFORMAT, 80,
                                 "binary STL header announces %" PRIu64 " triangles (%" PRIu64
                                 " bytes) but the file has %" PRIu64 " bytes",
                                 st->count, STL_HEADER + STL_RECORD * st->count, s->file_size);
    int rc = en_reader_check_count(r, st->count, "triangle count");
    if (rc)
        return rc;
    s->cur += STL_HEADER;
    r->info.encoding = "binary_le";
    r->info.nfaces = st->count;
    return 0;
}

static int binary_fill(epsnet_reader *r, stl_reader *st)
{
    en_source *s = r->src;
    if (st->facets == st->count) {
        size_t extra = en_source_fill(s, 1);
        if (s->failed)
            return source_failure(r);
        if (extra)
            return en_reader_fail_at(r, EPSNET_EFORMAT, en_source_offset(s),
                                     "trailing data after the %" PRIu64 " triangles the header announces",
                                     st->count);
        return 0;
    }
    uint64_t left = st->count - st->facets;
    size_t want = left < STL_BATCH ? (size_t)left : STL_BATCH;
    size_t avail = (size_t)(s->end - s->cur);
    if (avail < want * STL_RECORD)
        avail = en_source_fill(s, want * STL_RECORD);
    size_t n = avail / STL_RECORD < want ? avail / STL_RECORD : want;
    if (n == 0) {
        if (s->failed)
            return source_failure(r);
        return en_reader_fail_at(r, EPSNET_EFORMAT, en_source_offset(s),
                                 "truncated file: triangle %" PRIu64 " of %" PRIu64 " is incomplete",
                                 st->facets + 1, st->count);
    }
    for (size_t i = 0; i < n; i++) {
        const uint8_t *rec = s->cur;
        float corner[3][3];
        for (int k = 0; k < 3; k++)
            for (int c = 0; c < 3; c++)
                corner[k][c] = load_le_float(rec + 12 + 12 * k + 4 * c);
        int rc = weld_facet(r, &st->weld, corner);
        if (rc)
            return rc;
        /* the 16-bit "attribute byte count", which some writers fill with a
         * facet colour: not carried, so named (docs/architecture.md §5) */
        if (rec[48] | rec[49])
            en_reader_drop(r, "facet attribute (colour) bytes", 1, 1);
        s->cur += STL_RECORD;
        st->facets++;
    }
    return 1;
}

/* ------------------------------------------------------------------------
 * ASCII
 * ------------------------------------------------------------------------ */

static int is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

/* Next token of the text, across lines. @return 1, 0 at the end, or a
 * negative code. */
static int next_token(epsnet_reader *r, stl_reader *st, char **tok)
{
    for (;;) {
        char *s = st->cursor;
        while (s && is_space(*s))
            s++;
        if (s && *s) {
            char *t = s;
            while (*s && !is_space(*s))
                s++;
            if (*s)
                *s++ = '\0';
            st->cursor = s;
            *tok = t;
            return 1;
        }
        size_t len;
        epsnet_error e;
        int rc = en_source_line(r->src, &st->cursor, &len, STL_LINE_MAX, &e);
        if (rc < 0)
            return adopt_error(r, &e);
        if (rc == 0) {
            st->cursor = NULL;
            return 0;
        }
    }
}

static int expect_word(epsnet_reader *r, stl_reader *st, const char *word)
{
    char *tok;
    int rc = next_token(r, st, &tok);
    if (rc < 0)
        return rc;
    if (rc == 0)
        return en_reader_fail(r, EPSNET_EFORMAT, "truncated file: facet %" PRIu64 " ends before '%s'",
                              st->facets + 1, word);
    if (strcmp(tok, word) != 0)
        return en_reader_fail(r, EPSNET_EFORMAT, "facet %" PRIu64 ": expected '%s', found '%s'",
                              st->facets + 1, word, tok);
    return 0;
}

static int expect_numbers(epsnet_reader *r, stl_reader *st, float out[3], const char *what)
{
    for (int c = 0; c < 3; c++) {
        char *tok, *end;
        int rc = next_token(r, st, &tok);
        if (rc < 0)
            return rc;
        if (rc == 0)
            return en_reader_fail(r, EPSNET_EFORMAT, "truncated file: facet %" PRIu64 " ends inside its %s",
                                  st->facets + 1, what);
        out[c] = strtof(tok, &end);
        if (end == tok || *end)
            return en_reader_fail(r, EPSNET_EFORMAT, "facet %" PRIu64 ": %s value '%s' is not a number",
                                  st->facets + 1, what, tok);
    }
    return 0;
}

/* The rest of a facet, after its "facet" keyword. */
static int ascii_facet(epsnet_reader *r, stl_reader *st)
{
    float normal[3], corner[3][3];
    int rc;
    if ((rc = expect_word(r, st, "normal")) || (rc = expect_numbers(r, st, normal, "normal")) ||
        (rc = expect_word(r, st, "outer")) || (rc = expect_word(r, st, "loop")))
        return rc;
    for (int k = 0; k < 3; k++)
        if ((rc = expect_word(r, st, "vertex")) || (rc = expect_numbers(r, st, corner[k], "vertex")))
            return rc;
    if ((rc = expect_word(r, st, "endloop")) || (rc = expect_word(r, st, "endfacet")))
        return rc;
    if ((rc = weld_facet(r, &st->weld, corner)))
        return rc;
    st->facets++;
    return 0;
}

static int ascii_fill(epsnet_reader *r, stl_reader *st)
{
    const uint64_t pushed = r->ntris;
    while (r->ntris - pushed < STL_BATCH) {
        char *tok;
        int rc = next_token(r, st, &tok);
        if (rc < 0)
            return rc;
        if (rc == 0) {
            if (st->in_solid)
                return en_reader_fail(r, EPSNET_EFORMAT, "truncated file: no 'endsolid' after facet %" PRIu64,
                                      st->facets);
            return r->ntris != pushed;
        }
        if (!st->in_solid) {
            if (strcmp(tok, "solid") != 0)
                return en_reader_fail(r, EPSNET_EFORMAT, st->seen_solid ? "trailing data after 'endsolid': '%s'"
                                                                        : "expected 'solid', found '%s'", tok);
            st->in_solid = st->seen_solid = 1;
            st->cursor = NULL;   /* the rest of the line is the solid's name */
        } else if (strcmp(tok, "facet") == 0) {
            if ((rc = ascii_facet(r, st)))
                return rc;
        } else if (strcmp(tok, "endsolid") == 0) {
            st->in_solid = 0;
            st->cursor = NULL;
        } else {
            return en_reader_fail(r, EPSNET_EFORMAT, "expected 'facet' or 'endsolid', found '%s'", tok);
        }
    }
    return 1;
}

/* ------------------------------------------------------------------------
 * Detection and driver
 * ------------------------------------------------------------------------ */

static int starts_with_solid(const uint8_t *p, size_t n)
{
    size_t i = en_source_utf8_bom(p, n);
    while (i < n && (p[i] == ' ' || p[i] == '\t'))
        i++;
    return n - i >= 5 && memcmp(p + i, "solid", 5) == 0;
}

static int looks_like_text(const uint8_t *p, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if ((p[i] < 0x20 && p[i] != '\t' && p[i] != '\n' && p[i] != '\r' && p[i] != '\f' && p[i] != '\v') ||
            p[i] == 0x7f)
            return 0;
    return 1;
}

static int is_binary(const en_source *s, size_t avail)
{
    const uint8_t *p = s->cur;
    if (!s->zstd && s->file_size && avail >= STL_HEADER &&
        STL_HEADER + (uint64_t)STL_RECORD * load_le32(p + 80) == s->file_size)
        return 1;
    size_t sniff = avail < STL_SNIFF ? avail : STL_SNIFF;
    return !(starts_with_solid(p, avail) && looks_like_text(p, sniff));
}

static int stl_open_reader(epsnet_reader *r)
{
    stl_reader *st = en_calloc(1, sizeof *st);
    if (!st)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    r->state = st;
    r->info.coord_type = EPSNET_COORD_FLOAT32;
    size_t avail = en_source_fill(r->src, STL_SNIFF);
    if (r->src->failed)
        return source_failure(r);
    st->binary = is_binary(r->src, avail);
    if (st->binary) {
        r->text = 0;
        return binary_open(r, st);
    }
    r->text = 1;
    r->info.encoding = "ascii";
    return 0;
}

static int stl_fill(epsnet_reader *r)
{
    stl_reader *st = r->state;
    return st->binary ? binary_fill(r, st) : ascii_fill(r, st);
}

static void stl_close_reader(epsnet_reader *r)
{
    stl_reader *st = r->state;
    if (!st)
        return;
    en_free(st->weld.slots);
    en_free(st);
    r->state = NULL;
}

static int stl_probe(const uint8_t *head, size_t n)
{
    if (starts_with_solid(head, n) && looks_like_text(head, n < STL_SNIFF ? n : STL_SNIFF))
        return 60;
    return 0;
}

/* ---- writer ----
 *
 * A facet is its three corners' coordinates (float32: a float64 stream is
 * rounded, and says so in epsnet_writer_dropped()), after the unit normal
 * of their plane (0 0 0 for a zero-area facet). Faces name vertices by
 * index, so the writer keeps each vertex's position until its finalize
 * record (all of them for a stream that finalizes nothing), in a pool of
 * slots that finalized vertices hand back. Binary STL wants the facet
 * count in its header: patched at the end, or, for an output that cannot
 * be patched (a pipe, .zst), the facets wait in a temporary file. ASCII
 * STL has no count and streams. */

typedef struct stl_writer {
    int ascii;
    int patch;                /* binary: the count is patched at the end */
    en_idmap live;            /* vertex index -> slot in pos */
    float *pos;               /* 3 per slot */
    uint32_t *free_slots;
    size_t nslots, slot_cap, nfree, free_cap;
    en_spill *facets;         /* binary without patch */
} stl_writer;

/* The 80 bytes before the count. note: not "solid", which readers take
 * for an ascii file. */
static void stl_title(uint8_t head[80])
{
    memset(head, ' ', 80);
    memcpy(head, "binary STL written by epsnet", 28);
}

static int stl_oom(epsnet_writer *w)
{
    return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
}

static int stl_open_writer(epsnet_writer *w)
{
    stl_writer *st = en_calloc(1, sizeof *st);
    if (!st)
        return stl_oom(w);
    w->state = st;
    if (en_idmap_init_growing(&st->live, (size_t)1 << 20))
        return stl_oom(w);
    st->ascii = w->settings.ascii != 0;
    if (w->coord_type == EPSNET_COORD_FLOAT64 && en_writer_drop(w, "float64 coordinates (STL rounds them to float32)"))
        return stl_oom(w);
    if (st->ascii)
        return en_writer_printf(w, "solid epsnet\n");
    st->patch = en_sink_can_patch(w->sink);
    if (!st->patch)
        return 0;
    uint8_t head[STL_HEADER];
    stl_title(head);
    memset(head + 80, 0, 4);
    return en_writer_bytes(w, head, sizeof head);
}

static int stl_put_vertex(epsnet_writer *w, stl_writer *st, const double xyz[3])
{
    uint32_t slot;
    if (st->nfree) {
        slot = st->free_slots[--st->nfree];
    } else {
        if (st->nslots == UINT32_MAX ||
            en_grow((void **)&st->pos, &st->slot_cap, st->nslots + 1, 3 * sizeof *st->pos))
            return stl_oom(w);
        slot = (uint32_t)st->nslots++;
    }
    for (int k = 0; k < 3; k++)
        st->pos[3 * (size_t)slot + k] = (float)xyz[k];
    return en_idmap_put(&st->live, w->nverts - 1, slot) ? stl_oom(w) : 0;
}

static int stl_finalize(epsnet_writer *w, stl_writer *st, uint64_t v)
{
    uint32_t slot;
    if (!en_idmap_get(&st->live, v, &slot))
        return 0;
    en_idmap_remove(&st->live, v);
    if (en_grow((void **)&st->free_slots, &st->free_cap, st->nfree + 1, sizeof *st->free_slots))
        return stl_oom(w);
    st->free_slots[st->nfree++] = slot;
    return 0;
}

static void put_le32f(uint8_t *p, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    p[0] = (uint8_t)u;
    p[1] = (uint8_t)(u >> 8);
    p[2] = (uint8_t)(u >> 16);
    p[3] = (uint8_t)(u >> 24);
}

static int stl_put_facet(epsnet_writer *w, stl_writer *st, const uint64_t v[3])
{
    const float *c[3];
    for (int k = 0; k < 3; k++) {
        uint32_t slot;
        if (!en_idmap_get(&st->live, v[k], &slot))
            return en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "triangle %" PRIu64 " uses vertex %" PRIu64 " after it was finalized", w->ntris,
                                v[k] + 1);
        c[k] = st->pos + 3 * (size_t)slot;
    }
    double e1[3], e2[3], n[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = (double)c[1][k] - c[0][k];
        e2[k] = (double)c[2][k] - c[0][k];
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    float nf[3];
    for (int k = 0; k < 3; k++)
        nf[k] = len > 0 ? (float)(n[k] / len) : 0.0f;
    if (st->ascii) {
        char t[12][32];
        for (int k = 0; k < 3; k++)
            en_format_coord(t[k], nf[k], EPSNET_COORD_FLOAT32);
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                en_format_coord(t[3 + 3 * j + k], c[j][k], EPSNET_COORD_FLOAT32);
        return en_writer_printf(w,
                                "facet normal %s %s %s\n outer loop\n  vertex %s %s %s\n  vertex %s %s %s\n"
                                "  vertex %s %s %s\n endloop\nendfacet\n",
                                t[0], t[1], t[2], t[3], t[4], t[5], t[6], t[7], t[8], t[9], t[10], t[11]);
    }
    uint8_t rec[STL_RECORD];
    for (int k = 0; k < 3; k++)
        put_le32f(rec + 4 * k, nf[k]);
    for (int j = 0; j < 3; j++)
        for (int k = 0; k < 3; k++)
            put_le32f(rec + 12 + 12 * j + 4 * k, c[j][k]);
    rec[48] = rec[49] = 0;
    if (st->patch)
        return en_writer_bytes(w, rec, sizeof rec);
    int rc = en_writer_open_spill(w, &st->facets);
    return rc ? rc : en_spill_write(st->facets, rec, sizeof rec, &w->err);
}

static int stl_put(epsnet_writer *w, const epsnet_record *rec)
{
    stl_writer *st = w->state;
    switch (rec->kind) {
    case EPSNET_REC_VERTEX: return stl_put_vertex(w, st, rec->xyz);
    case EPSNET_REC_TRIANGLE: return stl_put_facet(w, st, rec->v);
    case EPSNET_REC_FINALIZE: return stl_finalize(w, st, rec->v[0]);
    default: return 0;
    }
}

static int stl_finish(epsnet_writer *w)
{
    stl_writer *st = w->state;
    if (st->ascii)
        return en_writer_printf(w, "endsolid epsnet\n");
    if (w->ntris > UINT32_MAX)
        return en_error_set(&w->err, EPSNET_EUNSUPPORTED, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "binary STL holds at most 2^32 - 1 facets, not %" PRIu64, w->ntris);
    uint8_t count[4];
    uint32_t n = (uint32_t)w->ntris;
    for (int k = 0; k < 4; k++)
        count[k] = (uint8_t)(n >> (8 * k));
    if (st->patch)
        return en_sink_patch(w->sink, 80, count, 4, &w->err);
    uint8_t head[80];
    stl_title(head);
    int rc = en_writer_bytes(w, head, 80);
    if (rc == 0)
        rc = en_writer_bytes(w, count, 4);
    if (rc || !st->facets)
        return rc;
    if ((rc = en_spill_rewind(st->facets, &w->err)))
        return rc;
    uint8_t buf[STL_RECORD * 1024];
    for (;;) {
        int64_t got = en_spill_read(st->facets, buf, sizeof buf, &w->err);
        if (got <= 0)
            return (int)got;
        if ((rc = en_writer_bytes(w, buf, (size_t)got)))
            return rc;
    }
}

static void stl_close_writer(epsnet_writer *w)
{
    stl_writer *st = w->state;
    if (!st)
        return;
    en_idmap_free(&st->live);
    en_free(st->pos);
    en_free(st->free_slots);
    en_spill_close(&st->facets);
    en_free(st);
    w->state = NULL;
}

const en_format en_format_stl = {
    .name = "stl",
    .extensions = "stl",
    .probe = stl_probe,
    .open_reader = stl_open_reader,
    .fill = stl_fill,
    .close_reader = stl_close_reader,
    .open_writer = stl_open_writer,
    .put = stl_put,
    .finish = stl_finish,
    .close_writer = stl_close_writer,
};
