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

/* One block read and decoded, on the pool or inline. The caller sets bi
 * before the job runs; the job writes the rest; the caller reads it once
 * the job is retired. */
typedef struct win_block {
    const struct en_smz_windows *sw;
    uint64_t bi;
    en_smz_block_header b;
    int rc; /* 0, EPSNET_EFORMAT (does not read) or EPSNET_ENOMEM */
    ZSTD_DCtx *dctx;
    en_smz_scratch sc;
    uint8_t *payload, *raw, *attrs;
    size_t payload_cap, raw_cap, attrs_cap, recs_cap;
    epsnet_record *recs;
} win_block;

struct en_smz_windows {
    int fd;
    const char *path;
    en_smz_index idx;
    /* the kept attributes' offsets in the file's vertex bytes */
    uint32_t nattr, from[EPSNET_ATTR_MAX], to[EPSNET_ATTR_MAX], size[EPSNET_ATTR_MAX];
    uint32_t kept_size;
    /* note: the blocks are decoded ahead on the pool, as the stream's own
     * reader decodes them (io/fmt_smz.c), so that the calling thread only
     * pushes records; ring NULL: one block at a time, inline */
    en_jobring *ring;
    win_block *blk;
    size_t nblk;
    uint8_t *kept_attr, *finalized;
    size_t finalized_cap;
};

/* en_job_fn: read and decode block j->bi. */
static int decode_block_job(void *job)
{
    win_block *j = job;
    const en_smz_windows *sw = j->sw;
    const en_smz_header *h = &sw->idx.header;
    const en_smz_index_entry *e = &sw->idx.entries[j->bi];
    uint8_t bh[EN_SMZ_BLOCK_HEADER_BYTES];
    char why[200];
    j->rc = EPSNET_EFORMAT;
    if (pread(sw->fd, bh, sizeof bh, (off_t)e->offset) != (ssize_t)sizeof bh ||
        en_smz_block_header_decode(bh, &j->b, why, sizeof why) || j->b.first_vertex != e->first_vertex)
        return 0;
    if (en_smz_block_room(h, &j->b, &j->payload, &j->payload_cap, &j->raw, &j->raw_cap, &j->recs, &j->recs_cap,
                          &j->attrs, &j->attrs_cap) ||
        en_smz_scratch_reserve(&j->sc, &j->b, h)) {
        j->rc = EPSNET_ENOMEM;
        return 0;
    }
    if (pread(sw->fd, j->payload, j->b.compressed_bytes, (off_t)(e->offset + sizeof bh)) ==
            (ssize_t)j->b.compressed_bytes &&
        !en_smz_unpack(j->dctx, j->payload, &j->b, j->raw, why, sizeof why) &&
        !en_smz_decode_block_h(j->raw, &j->b, h, j->attrs, &j->sc, j->recs, why, sizeof why))
        j->rc = 0;
    return 0;
}

/* Start block bi into its slot (blocks are retired in the order started). */
static int start_block(en_smz_windows *sw, uint64_t bi)
{
    win_block *j = &sw->blk[bi % sw->nblk];
    j->bi = bi;
    return sw->ring ? en_jobring_submit(sw->ring, decode_block_job, j) : decode_block_job(j);
}

/* The oldest block started. */
static win_block *finish_block(en_smz_windows *sw, uint64_t bi)
{
    void *job = NULL;
    int result;
    if (sw->ring)
        en_jobring_retire(sw->ring, &job, &result);
    return sw->ring ? job : &sw->blk[bi % sw->nblk];
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

/* en_window_backend.walk: the vertices [lo, hi) by id, from the blocks
 * that hold them (docs/smz.md: a face follows its corners, so the faces
 * among them are in those blocks, after the last of them in its block);
 * what the stream finalizes only after hi is finalized at the end. */
#define FINAL 1
#define CUT 2
static int walk(void *opaque, uint64_t lo, uint64_t hi, uint64_t base, en_stage *into, uint64_t *pushed,
                uint64_t *cut, epsnet_error *err)
{
    en_smz_windows *sw = opaque;
    uint64_t nv = hi - lo;
    if (!into && !cut) {
        *pushed += nv; /* every id of the stretch is pushed (below) */
        return 0;
    }
    if (en_grow((void **)&sw->finalized, &sw->finalized_cap, nv, 1))
        return en_error_set(err, EPSNET_ENOMEM, sw->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    memset(sw->finalized, 0, nv);
    int rc = 0;
    uint64_t first = nv ? block_of(&sw->idx, lo) : 0, end_block = nv ? block_of(&sw->idx, hi - 1) + 1 : 0;
    uint64_t started = first;
    for (uint64_t bi = first; bi < end_block && rc == 0; bi++) {
        while (rc == 0 && started < end_block && started < bi + sw->nblk)
            if (start_block(sw, started++))
                rc = en_error_set(err, EPSNET_ENOMEM, sw->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                  "worker pool refused a window's block");
        if (rc)
            break;
        const win_block *blk = finish_block(sw, bi);
        if (blk->rc == EPSNET_ENOMEM)
            rc = en_error_set(err, EPSNET_ENOMEM, sw->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        else if (blk->rc)
            rc = en_error_set(err, EPSNET_EFORMAT, sw->path, EPSNET_POS_NONE, sw->idx.entries[bi].offset,
                              "a window's block");
        const en_smz_block_header b = blk->b;
        uint64_t nvb = 0;
        for (uint32_t i = 0; i < b.records && rc == 0; i++) {
            epsnet_record r = blk->recs[i];
            if (r.kind == EPSNET_REC_VERTEX) {
                uint64_t id = b.first_vertex + nvb++;
                if (id < lo || id >= hi)
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
                if (r.v[j] >= lo && r.v[j] < hi) {
                    in |= 1 << j;
                    r.v[j] -= lo;
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
    /* the blocks still started, on a failure: nothing outlives the walk */
    for (void *job; sw->ring && en_jobring_retire(sw->ring, &job, &(int){ 0 });)
        ;
    for (uint64_t v = 0; v < nv && rc == 0; v++) {
        if (cut)
            *cut += (sw->finalized[v] & CUT) != 0;
        if (sw->finalized[v] & FINAL)
            continue;
        if (into)
            rc = en_stage_put(into, &(epsnet_record){ .kind = EPSNET_REC_FINALIZE, .v = { base + v } }, err);
    }
    *pushed += nv;
    return rc;
}

int en_smz_windows_open(en_smz_windows **out, const char *path, const epsnet_attr_layout *kept, en_pool *pool,
                        en_window_backend *b, epsnet_error *err)
{
    *out = NULL;
    memset(b, 0, sizeof *b);
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
    if (!usable) {
        en_smz_windows_close(&sw);
        return 0;
    }
    /* two blocks a worker, as the stream's reader reads ahead */
    int threads = pool ? en_pool_threads(pool) : 0;
    sw->nblk = threads ? 2 * (size_t)threads : 1;
    int ok = (sw->blk = en_calloc(sw->nblk, sizeof *sw->blk)) != NULL &&
             (!threads || en_jobring_new(&sw->ring, pool, sw->nblk) == 0) &&
             (!sw->kept_size || (sw->kept_attr = en_calloc(1, sw->kept_size)) != NULL);
    for (size_t i = 0; ok && i < sw->nblk; i++) {
        sw->blk[i].sw = sw;
        ok = (sw->blk[i].dctx = ZSTD_createDCtx()) != NULL;
    }
    if (!ok) {
        en_smz_windows_close(&sw);
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    *b = (en_window_backend){ t->nverts, walk, sw };
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
    en_jobring_free(&sw->ring, NULL); /* none in flight: each walk retires its blocks */
    en_smz_index_free(&sw->idx);
    for (size_t i = 0; sw->blk && i < sw->nblk; i++) {
        win_block *j = &sw->blk[i];
        ZSTD_freeDCtx(j->dctx);
        en_smz_scratch_free(&j->sc);
        en_free(j->payload);
        en_free(j->raw);
        en_free(j->attrs);
        en_free(j->recs);
    }
    en_free(sw->blk);
    en_free(sw->kept_attr);
    en_free(sw->finalized);
    en_free(sw);
    *psw = NULL;
}
