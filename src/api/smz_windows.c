#include "api/smz_windows.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include "common/alloc.h"
#include "common/error.h"
#include "io/smz.h"

/* A window: the vertices [first_vertex, end_vertex), in blocks [first_block, end_block). */
typedef struct window {
    uint64_t first_block, end_block;
    uint64_t first_vertex, end_vertex;
} window;

struct en_smz_windows {
    int fd;
    const char *path;
    en_smz_index idx;
    window *win;
    uint32_t n;
    uint64_t *inside;             /* en_window_source.inside */
    /* the kept attributes' offsets in the file's vertex bytes */
    uint32_t nattr, from[EPSNET_ATTR_MAX], to[EPSNET_ATTR_MAX], size[EPSNET_ATTR_MAX];
    uint32_t kept_size;
    ZSTD_DCtx *dctx;
    en_smz_scratch sc;
    uint8_t *payload, *raw, *attrs, *kept_attr, *finalized;
    size_t payload_cap, raw_cap, attrs_cap, recs_cap, finalized_cap;
    epsnet_record *recs;
};

/* Window x's records into `into` (NULL: only counted), its vertices
 * numbered from base (docs/smz.md: a face follows its corners; one with a
 * corner before the window is left out); what the stream finalizes only
 * after the window is finalized at its end. *cut counts the vertices on
 * its two cuts (corners of faces left out): twice the stream's width
 * there. A block that does not read is EPSNET_EFORMAT:
 * the caller goes without the windows, and the stream's reader reports it
 * in place. */
#define FINAL 1
#define CUT 2
static int walk(en_smz_windows *sw, const window *x, uint64_t base, en_stage *into, uint64_t *cut,
                epsnet_error *err)
{
    const en_smz_header *h = &sw->idx.header;
    uint64_t nv = x->end_vertex - x->first_vertex;
    if (en_grow((void **)&sw->finalized, &sw->finalized_cap, nv, 1))
        return en_error_set(err, EPSNET_ENOMEM, sw->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    memset(sw->finalized, 0, nv);
    char why[200];
    int rc = 0;
    for (uint64_t bi = x->first_block; bi < x->end_block && rc == 0; bi++) {
        const en_smz_index_entry *e = &sw->idx.entries[bi];
        uint8_t bh[EN_SMZ_BLOCK_HEADER_BYTES];
        en_smz_block_header b;
        if (pread(sw->fd, bh, sizeof bh, (off_t)e->offset) != (ssize_t)sizeof bh ||
            en_smz_block_header_decode(bh, &b, why, sizeof why) || b.first_vertex != e->first_vertex)
            return en_error_set(err, EPSNET_EFORMAT, sw->path, EPSNET_POS_NONE, e->offset, "a window's block");
        if (en_grow((void **)&sw->payload, &sw->payload_cap, b.compressed_bytes, 1) ||
            en_grow((void **)&sw->raw, &sw->raw_cap, b.raw_bytes, 1) ||
            en_grow((void **)&sw->recs, &sw->recs_cap, b.records, sizeof *sw->recs) ||
            (h->attrs.size && en_grow((void **)&sw->attrs, &sw->attrs_cap, (size_t)b.nverts * h->attrs.size, 1)) ||
            en_smz_scratch_reserve(&sw->sc, &b, h))
            return en_error_set(err, EPSNET_ENOMEM, sw->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        if (pread(sw->fd, sw->payload, b.compressed_bytes, (off_t)(e->offset + sizeof bh)) !=
                (ssize_t)b.compressed_bytes ||
            en_smz_unpack(sw->dctx, sw->payload, &b, sw->raw, why, sizeof why) ||
            en_smz_decode_block_h(sw->raw, &b, h, sw->attrs, &sw->sc, sw->recs, why, sizeof why))
            return en_error_set(err, EPSNET_EFORMAT, sw->path, EPSNET_POS_NONE, e->offset, "a window's block");
        uint64_t nvb = 0;
        for (uint32_t i = 0; i < b.records && rc == 0; i++) {
            epsnet_record r = sw->recs[i];
            if (r.kind == EPSNET_REC_VERTEX) {
                uint64_t id = b.first_vertex + nvb++;
                if (id < x->first_vertex || id >= x->end_vertex)
                    continue;
                if (sw->kept_size) {
                    for (uint32_t a = 0; a < sw->nattr; a++)
                        memcpy(sw->kept_attr + sw->to[a], r.attr + sw->from[a], sw->size[a]);
                    r.attr = sw->kept_attr;
                } else {
                    r.attr = NULL;
                }
                rc = into ? en_stage_put(into, &r, err) : 0;
                continue;
            }
            int k = r.kind == EPSNET_REC_TRIANGLE ? 3 : 1, in = 0;
            for (int j = 0; j < k; j++)
                if (r.v[j] >= x->first_vertex && r.v[j] < x->end_vertex) {
                    in |= 1 << j;
                    r.v[j] -= x->first_vertex;
                }
            if (in != (1 << k) - 1) {
                /* a face across a cut: its corners inside are on the cut */
                for (int j = 0; j < k && r.kind == EPSNET_REC_TRIANGLE; j++)
                    if (in & (1 << j))
                        sw->finalized[r.v[j]] |= CUT;
                continue;
            }
            if (r.kind != EPSNET_REC_TRIANGLE) {
                if (sw->finalized[r.v[0]] & FINAL)
                    continue;
                sw->finalized[r.v[0]] |= FINAL;
            }
            for (int j = 0; j < k; j++)
                r.v[j] += base;
            rc = into ? en_stage_put(into, &r, err) : 0;
        }
    }
    for (uint64_t v = 0; v < nv && rc == 0; v++) {
        *cut += (sw->finalized[v] & CUT) != 0;
        if (sw->finalized[v] & FINAL)
            continue;
        if (into)
            rc = en_stage_put(into, &(epsnet_record){ .kind = EPSNET_REC_FINALIZE, .v = { base + v } }, err);
    }
    return rc;
}

static int push_window(void *opaque, uint32_t wi, uint64_t base, en_stage *into, uint64_t *pushed,
                       epsnet_error *err)
{
    en_smz_windows *sw = opaque;
    const window *x = &sw->win[wi];
    uint64_t cut = 0;
    *pushed += x->end_vertex - x->first_vertex;
    return walk(sw, x, base, into, &cut, err);
}

/* The first block holding vertex v (the last entry starting at or before it). */
static uint64_t block_of(const en_smz_index *idx, uint64_t v)
{
    uint64_t lo = 0, hi = idx->trailer.blocks;
    while (hi - lo > 1) {
        uint64_t mid = lo + (hi - lo) / 2;
        if (idx->entries[mid].first_vertex <= v)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* The window of nv vertices around vertex mid (fewer at the stream's ends):
 * its vertices by id, whatever the blocks, and the blocks that hold them
 * and the faces after the last of them in its block. */
static window place(const en_smz_index *idx, uint64_t mid, uint64_t nv)
{
    const en_smz_trailer *t = &idx->trailer;
    window x;
    x.first_vertex = mid > nv / 2 ? mid - nv / 2 : 0;
    x.end_vertex = x.first_vertex + nv < t->nverts ? x.first_vertex + nv : t->nverts;
    x.first_block = block_of(idx, x.first_vertex);
    x.end_block = block_of(idx, x.end_vertex - 1) + 1;
    return x;
}

int en_smz_windows_open(en_smz_windows **out, const char *path, const epsnet_attr_layout *kept,
                        uint64_t slab_vertices, double margin_widths, en_window_source *src, epsnet_error *err)
{
    *out = NULL;
    memset(src, 0, sizeof *src);
    if (!path || strcmp(path, "-") == 0)
        return 0;
    en_smz_windows *sw = en_calloc(1, sizeof *sw);
    if (!sw)
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    sw->path = path;
    sw->fd = open(path, O_RDONLY | O_CLOEXEC);
    struct stat sb;
    uint8_t magic[8];
    epsnet_error ignored;
    int usable = sw->fd >= 0 && fstat(sw->fd, &sb) == 0 && S_ISREG(sb.st_mode) &&
                 pread(sw->fd, magic, sizeof magic, 0) == (ssize_t)sizeof magic &&
                 memcmp(magic, en_smz_magic, sizeof magic) == 0 &&
                 en_smz_read_index(sw->fd, path, (uint64_t)sb.st_size, &sw->idx, &ignored) == 0;
    const en_smz_trailer *t = &sw->idx.trailer;
    usable = usable && t->sorted && t->blocks > 0 && t->nverts != EPSNET_COUNT_UNKNOWN;
    /* the kept attributes, found by name in the file's */
    const epsnet_attr_layout *fa = &sw->idx.header.attrs;
    for (uint32_t a = 0; usable && kept && a < kept->count; a++) {
        int i = epsnet_attr_layout_find(fa, kept->attr[a].name);
        usable = i >= 0 && fa->attr[i].type == kept->attr[a].type;
        if (usable) {
            sw->from[sw->nattr] = fa->attr[i].offset;
            sw->to[sw->nattr] = kept->attr[a].offset;
            sw->size[sw->nattr++] = (uint32_t)epsnet_attr_type_size(kept->attr[a].type);
        }
    }
    sw->kept_size = kept ? kept->size : 0;
    uint32_t n = EN_PRICE_WINDOWS;
    if (usable && (!(sw->win = en_calloc(n, sizeof *sw->win)) || !(sw->inside = en_calloc(2 * n, sizeof *sw->inside)) ||
                   !(sw->dctx = ZSTD_createDCtx()) || (sw->kept_size && !(sw->kept_attr = en_calloc(1, sw->kept_size))))) {
        en_smz_windows_close(&sw);
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    /* the stream's width, at its middle, sizes the windows and their margins */
    uint64_t width = 0;
    if (usable) {
        /* long enough that its cuts are two rings of the stream, not all of it */
        uint64_t len = 4 * slab_vertices > 4096 ? 4 * slab_vertices : 4096;
        window probe = place(&sw->idx, t->nverts / 2, len < t->nverts / 2 ? len : t->nverts / 2);
        int rc = walk(sw, &probe, 0, NULL, &width, err);
        width /= 2; /* two cuts */
        if (rc && rc != EPSNET_EFORMAT) {
            en_smz_windows_close(&sw);
            return rc;
        }
        usable = rc == 0;
    }
    /* a window: a slab (the inside) between two margins of whole slabs,
     * so that the chunker cuts the inside as the stream's own slabs and no
     * slab that holds a cut holds any of it (target_stage.h) */
    usable = usable && (double)slab_vertices >= EN_PRICE_SLAB_WIDTHS * (double)width;
    uint64_t margin = slab_vertices;
    while ((double)margin < margin_widths * (double)width)
        margin += slab_vertices;
    uint64_t nv = slab_vertices + 2 * margin;
    usable = usable && (double)(n * nv) <= EN_PRICE_MAX_SHARE * (double)t->nverts;
    uint64_t base = 0;
    for (uint32_t w = 0; usable && w < n; w++) {
        window *x = &sw->win[w];
        *x = place(&sw->idx, (2 * (uint64_t)w + 1) * t->nverts / (2 * (uint64_t)n), nv);
        uint64_t len = x->end_vertex - x->first_vertex;
        usable = len == nv;
        sw->inside[2 * w] = base + margin;
        sw->inside[2 * w + 1] = base + len - margin;
        src->inside_vertices += len - 2 * margin;
        src->vertices += len;
        base += len;
    }
    if (!usable) {
        en_smz_windows_close(&sw);
        memset(src, 0, sizeof *src);
        return 0;
    }
    sw->n = n;
    src->windows = n;
    src->inside = sw->inside;
    src->push = push_window;
    src->opaque = sw;
    *out = sw;
    return 0;
}

void en_smz_windows_close(en_smz_windows **psw)
{
    en_smz_windows *sw = *psw;
    if (!sw)
        return;
    if (sw->fd >= 0)
        close(sw->fd);
    en_smz_index_free(&sw->idx);
    ZSTD_freeDCtx(sw->dctx);
    en_smz_scratch_free(&sw->sc);
    en_free(sw->win);
    en_free(sw->inside);
    en_free(sw->payload);
    en_free(sw->raw);
    en_free(sw->attrs);
    en_free(sw->kept_attr);
    en_free(sw->finalized);
    en_free(sw->recs);
    en_free(sw);
    *psw = NULL;
}
