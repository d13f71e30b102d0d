/*
 * .smz, epsnet's native streaming mesh (docs/smz.md describes
 * every byte): a header, independent zstd blocks each with its own
 * checksum, and an index found through a fixed-size trailer.
 *
 * Reader: reads the blocks in order through the source window (so .smz.zst
 * and pipes work too) and checks what the index would tell a random-access
 * reader: the running CRC of the index entries it would have written must
 * equal the stored index, and the trailer's counts and bbox must match what
 * was decoded. A header that declares the stream sorted is verified vertex
 * by vertex (docs/architecture.md §5: a stream claimed sorted that is not is an error).
 * Errors inside a block name the block and its byte offset.
 *
 * Given a pool (smz_use_pool), the reader reads blocks ahead on the caller's
 * thread and decodes them on the workers; everything above still happens on
 * the caller's thread at each block's turn (docs/architecture.md §10).
 *
 * Writer: counts, bbox and the sorted flag are only known at the end, so the
 * header carries what the caller announced and is patched on seekable
 * outputs; the trailer always holds the exact values. On an output that
 * cannot be patched, an announced count or sorted axis that turns out wrong
 * is an error, and the header bbox is left out.
 *
 * Given a pool (smz_writer_use_pool), the writer gathers each block's
 * records on the caller's thread and encodes and compresses it on a
 * worker; the caller writes the blocks in order as their jobs retire, as
 * zstdmt flushes only its oldest job (docs/architecture.md §10). Blocks are
 * independent (docs/smz.md), so the bytes are the same.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zstd.h>

#include "common/alloc.h"
#include "common/pool.h"
#include "common/idmap.h"
#include "io/format.h"
#include "io/smz.h"

#define SMZ_FILL_BATCH 4096

/* ---- reader ---- */

typedef struct smz_reader smz_reader;

/* A decoded block's extent: along the sorted axis (x when none), for its
 * index entry, and in all three, for the trailer's box. Made where the
 * block is decoded, a worker's when on the pool. */
typedef struct smz_bounds {
    double axis_min, axis_max;
    double lo[3], hi[3];
} smz_bounds;

static void block_bounds(const epsnet_record *recs, uint32_t n, int axis, smz_bounds *bb)
{
    *bb = (smz_bounds){ INFINITY, -INFINITY, { INFINITY, INFINITY, INFINITY }, { -INFINITY, -INFINITY, -INFINITY } };
    for (uint32_t i = 0; i < n; i++) {
        if (recs[i].kind != EPSNET_REC_VERTEX)
            continue;
        for (int k = 0; k < 3; k++) {
            double x = recs[i].xyz[k];
            bb->lo[k] = x < bb->lo[k] ? x : bb->lo[k];
            bb->hi[k] = x > bb->hi[k] ? x : bb->hi[k];
        }
    }
    bb->axis_min = bb->lo[axis];
    bb->axis_max = bb->hi[axis];
}

/*
 * A block read ahead by the caller's thread and decompressed and decoded on
 * a worker (docs/architecture.md §10). Blocks share nothing (docs/smz.md:
 * no state from earlier blocks; version 2 predicts from the block's own
 * vertices and triangles), so a block decodes from its bytes, its header
 * and the file's header alone. The caller's thread writes b, offset,
 * block_no, read_rc, read_err and payload before submitting; the worker
 * writes raw, recs, attrs, bad and why; the caller reads them after its
 * ring retires the job, in block order, and makes every check that depends
 * on the stream (vertices before the block, sortedness, finalizations)
 * then, exactly where the one-thread reader makes them.
 */
typedef struct smz_job {
    en_smz_block_header b;
    const en_smz_header *h;        /* the reader's, read-only once open */
    uint64_t offset;               /* of the block's tag */
    uint64_t block_no;
    int read_rc;                   /* the payload could not be read: raised at the block's turn */
    epsnet_error read_err;
    ZSTD_DCtx *dctx;
    uint8_t *payload;
    size_t payload_cap;
    uint8_t *raw;                  /* worker */
    size_t raw_cap;
    en_smz_scratch sc;             /* worker: the decoder's working arrays */
    epsnet_record *recs;           /* worker; vertex records' attr point into attrs */
    size_t recs_cap;
    uint8_t *attrs;                /* worker */
    size_t attrs_cap;
    int bad;                       /* worker: corrupt, why says how */
    char why[200];
    smz_bounds bounds;             /* worker */
} smz_job;

struct smz_reader {
    en_smz_header header;
    ZSTD_DCtx *dctx;
    uint8_t *payload;
    size_t payload_cap;
    uint8_t *raw;
    size_t raw_cap;
    en_smz_scratch sc;
    epsnet_record *recs;
    size_t recs_cap;
    uint8_t *attrs;                /* the current block's vertex attribute bytes */
    size_t attrs_cap;
    const epsnet_record *cur;      /* the current block's records: recs, or a job's */
    uint32_t nrecs, pos;           /* decoded records of the current block */
    uint64_t block_no;             /* blocks read so far */
    uint64_t block_offset;         /* of the current block */
    uint64_t ntris_before;         /* triangles before the current block */
    uint64_t nfinal;
    uint32_t index_crc;            /* of the index this reader would write */
    double prev_axis;
    double lo[3], hi[3];
    int finished;
    /* Decoding on the pool (smz_use_pool); ring NULL: on the caller's thread. */
    en_jobring *ring;
    smz_job *jobs;                 /* njobs slots: at most njobs - 1 in flight, so the
                                    * current block's job stays untouched while it is pushed */
    size_t njobs;
    uint64_t submitted;            /* jobs ever submitted */
    size_t ahead_bytes;            /* buffers the job slots hold (docs/architecture.md §12) */
    int ahead_stop;                /* the index, the end or anything odd: the one-thread path takes over */
};

static int source_failed(epsnet_reader *r)
{
    r->failed = 1;
    return en_source_error(r->src, &r->err);
}

/* Version 2: the attribute table after the header (docs/smz.md). */
static int read_attr_table(epsnet_reader *r, smz_reader *st)
{
    uint8_t tab[EN_SMZ_MAX_TABLE_BYTES];
    int rc = en_source_read(r->src, tab, 4, "the attribute table", &r->err);
    if (rc) {
        r->failed = 1;
        return rc;
    }
    uint32_t body = (uint32_t)tab[0] | (uint32_t)tab[1] << 8 | (uint32_t)tab[2] << 16 | (uint32_t)tab[3] << 24;
    if (body > EN_SMZ_MAX_TABLE_BYTES - 8)
        return en_reader_fail_at(r, EPSNET_EFORMAT, EN_SMZ_HEADER_BYTES,
                                 "attribute table of %u bytes is longer than %d", body, EN_SMZ_MAX_TABLE_BYTES - 8);
    if ((rc = en_source_read(r->src, tab + 4, body + 4, "the attribute table", &r->err))) {
        r->failed = 1;
        return rc;
    }
    const uint8_t *c = tab + 4 + body;
    uint32_t crc = (uint32_t)c[0] | (uint32_t)c[1] << 8 | (uint32_t)c[2] << 16 | (uint32_t)c[3] << 24;
    char why[200];
    epsnet_attr_layout l;
    if (en_smz_attr_table_decode(tab + 4, body, crc, &l, why, sizeof why))
        return en_reader_fail_at(r, EPSNET_EFORMAT, EN_SMZ_HEADER_BYTES, "%s", why);
    for (uint32_t i = 0; i < l.count; i++)
        if ((rc = en_reader_add_attr_of(r, l.attr[i].name, l.attr[i].type, (int)l.attr[i].of_face)) < 0)
            return rc;
    st->header.attrs = l;
    return 0;
}

static int smz_open_reader(epsnet_reader *r)
{
    smz_reader *st = en_calloc(1, sizeof *st);
    if (!st)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    r->state = st;
    r->text = 0;
    st->dctx = ZSTD_createDCtx();
    if (!st->dctx)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    uint8_t hb[EN_SMZ_HEADER_BYTES];
    int rc = en_source_read(r->src, hb, sizeof hb, "the .smz header", &r->err);
    if (rc) {
        r->failed = 1;
        return rc;
    }
    char why[200];
    int bad = en_smz_header_decode(hb, &st->header, why, sizeof why);
    if (bad)
        return en_reader_fail_at(r, EPSNET_EFORMAT, bad < 0 ? 0 : (uint64_t)bad, "%s", why);
    if (st->header.version >= 2 && (rc = read_attr_table(r, st)))
        return rc;
    const en_smz_header *h = &st->header;
    if ((h->nverts != EPSNET_COUNT_UNKNOWN && (rc = en_reader_check_count(r, h->nverts, "vertex count"))) ||
        (h->nfaces != EPSNET_COUNT_UNKNOWN && (rc = en_reader_check_count(r, h->nfaces, "face count"))))
        return rc;
    r->info.encoding = "binary";
    r->info.streaming = 1;
    r->info.coord_type = h->coord_type;
    r->info.nverts = h->nverts;
    r->info.nfaces = h->nfaces;
    r->info.has_bbox = h->has_bbox;
    for (int k = 0; k < 3; k++) {
        r->info.bbox_min[k] = h->bbox[k];
        r->info.bbox_max[k] = h->bbox[k + 3];
        st->lo[k] = INFINITY;
        st->hi[k] = -INFINITY;
    }
    r->info.sorted_axis = h->sorted ? h->axis : -1;
    st->prev_axis = -INFINITY;
    static const uint8_t index_head[EN_SMZ_INDEX_HEAD_BYTES] = { 'S', 'M', 'Z', 'I', 0, 0, 0, 0 };
    st->index_crc = en_smz_crc32(0, index_head, sizeof index_head);
    return 0;
}

static int first_vertex_check(epsnet_reader *r, smz_reader *st, const en_smz_block_header *b)
{
    if (b->first_vertex != r->nverts)
        return en_reader_fail_at(r, EPSNET_EFORMAT, st->block_offset,
                                 "block %llu is corrupt: it says %llu vertices precede it, but %llu do",
                                 (unsigned long long)st->block_no, (unsigned long long)b->first_vertex,
                                 (unsigned long long)r->nverts);
    return 0;
}

/* The block's records are decoded into recs, its extent into bb: note its
 * index entry and make them the current block. */
static void block_decoded(epsnet_reader *r, smz_reader *st, const en_smz_block_header *b,
                          const epsnet_record *recs, const smz_bounds *bb)
{
    en_smz_index_entry e = {
        .offset = st->block_offset, .first_vertex = b->first_vertex, .first_triangle = r->ntris,
        .records = b->records, .compressed_bytes = b->compressed_bytes, .axis_min = bb->axis_min,
        .axis_max = bb->axis_max,
    };
    for (int k = 0; k < 3; k++) {
        st->lo[k] = bb->lo[k] < st->lo[k] ? bb->lo[k] : st->lo[k];
        st->hi[k] = bb->hi[k] > st->hi[k] ? bb->hi[k] : st->hi[k];
    }
    uint8_t eb[EN_SMZ_INDEX_ENTRY_BYTES];
    en_smz_index_entry_encode(&e, eb);
    st->index_crc = en_smz_crc32(st->index_crc, eb, sizeof eb);
    st->cur = recs;
    st->nrecs = b->records;
    st->pos = 0;
    st->ntris_before = r->ntris;
    st->block_no++;
}

/* Read, check and decode the block whose tag starts at st->block_offset. */
static int read_block(epsnet_reader *r, smz_reader *st)
{
    uint8_t bh[EN_SMZ_BLOCK_HEADER_BYTES];
    char what[64], why[200];
    snprintf(what, sizeof what, "block %llu", (unsigned long long)st->block_no);
    int rc = en_source_read(r->src, bh, sizeof bh, what, &r->err);
    if (rc) {
        r->failed = 1;
        return rc;
    }
    en_smz_block_header b;
    if (en_smz_block_header_decode(bh, &b, why, sizeof why))
        return en_reader_fail_at(r, EPSNET_EFORMAT, st->block_offset, "block %llu is corrupt: %s",
                                 (unsigned long long)st->block_no, why);
    if ((rc = first_vertex_check(r, st, &b)))
        return rc;
    if (en_smz_block_room(&st->header, &b, &st->payload, &st->payload_cap, &st->raw, &st->raw_cap, &st->recs,
                   &st->recs_cap, &st->attrs, &st->attrs_cap))
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    rc = en_source_read(r->src, st->payload, b.compressed_bytes, what, &r->err);
    if (rc) {
        r->failed = 1;
        return rc;
    }
    if (en_smz_unpack(st->dctx, st->payload, &b, st->raw, why, sizeof why) ||
        en_smz_decode_block_h(st->raw, &b, &st->header, st->attrs, &st->sc, st->recs, why, sizeof why))
        return en_reader_fail_at(r, EPSNET_EFORMAT, st->block_offset, "block %llu is corrupt: %s",
                                 (unsigned long long)st->block_no, why);
    smz_bounds bb;
    block_bounds(st->recs, b.records, st->header.axis >= 0 ? st->header.axis : 0, &bb);
    block_decoded(r, st, &b, st->recs, &bb);
    return 0;
}

/* One record's checks, in stream order, then into the reader's queue, or
 * only counted when queue is 0 (handed out in place: smz_next_in_place). */
static int push_one(epsnet_reader *r, smz_reader *st, const epsnet_record *rec, int queue)
{
    switch (rec->kind) {
    case EPSNET_REC_VERTEX:
        if (st->header.sorted) {
            double a = rec->xyz[st->header.axis];
            if (a < st->prev_axis)
                return en_reader_fail_at(r, EPSNET_EFORMAT, st->block_offset,
                                         "block %llu: vertex %llu goes back along %c (%.9g after %.9g) "
                                         "although the header says the stream is sorted",
                                         (unsigned long long)st->block_no - 1, (unsigned long long)r->nverts + 1,
                                         "xyz"[st->header.axis], a, st->prev_axis);
            st->prev_axis = a;
        }
        return queue ? en_reader_push_vertex_attr(r, rec->xyz[0], rec->xyz[1], rec->xyz[2], rec->attr)
                     : en_reader_check_vertex(r, rec->xyz[0], rec->xyz[1], rec->xyz[2]);
    case EPSNET_REC_TRIANGLE:
        return queue ? en_reader_push_triangle(r, rec->v[0], rec->v[1], rec->v[2])
                     : en_reader_check_triangle(r, rec->v[0], rec->v[1], rec->v[2]);
    default:
        st->nfinal++;
        return queue ? en_reader_push_finalize(r, rec->v[0]) : en_reader_check_finalize(r, rec->v[0]);
    }
}

/* The index and trailer after the last block: everything must agree with
 * what was read, and nothing may follow. */
static int read_index(epsnet_reader *r, smz_reader *st, uint64_t index_offset)
{
    uint8_t head[EN_SMZ_INDEX_HEAD_BYTES];
    int rc = en_source_read(r->src, head, sizeof head, "the index", &r->err);
    if (rc) {
        r->failed = 1;
        return rc;
    }
    uint32_t crc = en_smz_crc32(0, head, sizeof head);
    if (memcmp(head + 4, "\0\0\0\0", 4) != 0)
        return en_reader_fail_at(r, EPSNET_EFORMAT, index_offset + 4, "index is corrupt: reserved bytes are not 0");
    for (uint64_t i = 0; i < st->block_no; i++) {
        uint8_t eb[EN_SMZ_INDEX_ENTRY_BYTES];
        rc = en_source_read(r->src, eb, sizeof eb, "the index", &r->err);
        if (rc) {
            r->failed = 1;
            return rc;
        }
        crc = en_smz_crc32(crc, eb, sizeof eb);
    }
    uint64_t toff = en_source_offset(r->src);
    if (crc != st->index_crc)
        return en_reader_fail_at(r, EPSNET_EFORMAT, index_offset, "index is corrupt: it does not match the %llu blocks",
                                 (unsigned long long)st->block_no);
    uint8_t tb[EN_SMZ_TRAILER_BYTES];
    char why[200];
    rc = en_source_read(r->src, tb, sizeof tb, "the trailer", &r->err);
    if (rc) {
        r->failed = 1;
        return rc;
    }
    en_smz_trailer t;
    if (en_smz_trailer_decode(tb, &t, why, sizeof why))
        return en_reader_fail_at(r, EPSNET_EFORMAT, toff, "%s", why);
    if (t.index_crc != crc || t.index_offset != index_offset || t.blocks != st->block_no)
        return en_reader_fail_at(r, EPSNET_EFORMAT, toff, "trailer does not match the index");
    if (t.nverts != r->nverts || t.nfaces != r->ntris || t.nfinal != st->nfinal)
        return en_reader_fail_at(r, EPSNET_EFORMAT, toff,
                                 "trailer counts (%llu vertices, %llu triangles) do not match the blocks "
                                 "(%llu, %llu)",
                                 (unsigned long long)t.nverts, (unsigned long long)t.nfaces,
                                 (unsigned long long)r->nverts, (unsigned long long)r->ntris);
    for (int k = 0; t.has_bbox && k < 3; k++)
        if (t.bbox[k] != st->lo[k] || t.bbox[k + 3] != st->hi[k])
            return en_reader_fail_at(r, EPSNET_EFORMAT, toff, "trailer bounding box does not match the vertices");
    const en_smz_header *h = &st->header;
    if ((h->nverts != EPSNET_COUNT_UNKNOWN && h->nverts != r->nverts) ||
        (h->nfaces != EPSNET_COUNT_UNKNOWN && h->nfaces != r->ntris))
        return en_reader_fail_at(r, EPSNET_EFORMAT, 16,
                                 "header announces %llu vertices and %llu triangles, the file holds %llu and %llu",
                                 (unsigned long long)h->nverts, (unsigned long long)h->nfaces,
                                 (unsigned long long)r->nverts, (unsigned long long)r->ntris);
    size_t rest = en_source_fill(r->src, 1);
    if (r->src->failed)
        return source_failed(r);
    if (rest)
        return en_reader_fail(r, EPSNET_EFORMAT, "data after the .smz trailer");
    st->finished = 1;
    return 0;
}

/* @return 1 with a block decoded, 0 at the end of the file, or an error. */
static int next_block(epsnet_reader *r, smz_reader *st)
{
    en_source *s = r->src;
    r->here_set = 0; /* the one-thread path: the source stands where errors say */
    size_t n = en_source_fill(s, 4);
    if (s->failed)
        return source_failed(r);
    uint64_t off = en_source_offset(s);
    if (n == 0)
        return en_reader_fail_at(r, EPSNET_EFORMAT, off,
                                 "truncated file: the stream ends after %llu blocks without its index",
                                 (unsigned long long)st->block_no);
    if (n >= 4 && memcmp(s->cur, "SMZB", 4) == 0) {
        st->block_offset = off;
        int rc = read_block(r, st);
        return rc ? rc : 1;
    }
    if (n >= 4 && memcmp(s->cur, "SMZI", 4) == 0) {
        int rc = read_index(r, st, off);
        return rc ? rc : 0;
    }
    return en_reader_fail_at(r, EPSNET_EFORMAT, off, "expected block %llu or the index, found neither",
                             (unsigned long long)st->block_no);
}

/* ---- decoding on the pool ---- */

static int decode_job(void *job)
{
    smz_job *j = job;
    if (j->read_rc == 0)
        j->bad = en_smz_unpack(j->dctx, j->payload, &j->b, j->raw, j->why, sizeof j->why) ||
                 en_smz_decode_block_h(j->raw, &j->b, j->h, j->attrs, &j->sc, j->recs, j->why, sizeof j->why);
    if (j->read_rc == 0 && !j->bad)
        block_bounds(j->recs, j->b.records, j->h->axis >= 0 ? j->h->axis : 0, &j->bounds);
    return 0;
}

static size_t job_bytes(const smz_job *j)
{
    return j->payload_cap + j->raw_cap + j->recs_cap * sizeof *j->recs + j->attrs_cap + en_smz_scratch_bytes(&j->sc);
}

/* Whether the job slots may grow to hold `more` bytes more: the blocks read
 * ahead count with the reader's live vertices against the memory budget
 * (docs/architecture.md §12). Over it the reading ahead waits (it never
 * fails: an error there would not be the one-thread reader's), except with
 * nothing in flight, where one block is what the one-thread reader holds
 * too. */
static int ahead_fits(const epsnet_reader *r, const smz_reader *st, size_t more)
{
    uint64_t limit = r->settings.mem_limit;
    if (!limit || en_jobring_in_flight(st->ring) == 0)
        return 1;
    uint64_t live = r->live ? en_idmap_bytes(r->live) : 0;
    return live + st->ahead_bytes + more <= limit;
}

/*
 * Read blocks ahead while the ring has room, and submit each for decoding.
 * Anything but a well-formed block header (the index, the end, a corrupt
 * or truncated header, no memory) stops the reading ahead for good, before
 * that header is consumed: the one-thread path reaches it once the blocks
 * in flight are used up, and says what it says today. Called only between
 * blocks (st->block_no blocks given out), so the blocks in flight are the
 * next ones in order.
 */
static void read_ahead(epsnet_reader *r, smz_reader *st)
{
    en_source *s = r->src;
    while (!st->ahead_stop && !en_jobring_full(st->ring) && en_jobring_in_flight(st->ring) + 1 < st->njobs) {
        size_t n = en_source_fill(s, EN_SMZ_BLOCK_HEADER_BYTES);
        en_smz_block_header b;
        char why[200];
        if (s->failed || n < EN_SMZ_BLOCK_HEADER_BYTES || memcmp(s->cur, "SMZB", 4) != 0 ||
            en_smz_block_header_decode(s->cur, &b, why, sizeof why)) {
            st->ahead_stop = 1;
            break;
        }
        smz_job *j = &st->jobs[st->submitted % st->njobs];
        size_t before = job_bytes(j);
        /* note: what the slot will hold, estimated from the header's sizes
         * before growing (capacities double, so this is a lower bound). */
        size_t need = (size_t)b.compressed_bytes + b.raw_bytes + (size_t)b.records * sizeof *j->recs +
                      (size_t)b.nverts * st->header.attrs.size;
        if (need > before && !ahead_fits(r, st, need - before))
            break; /* waits for the blocks in flight to be used up */
        if (en_smz_block_room(&st->header, &b, &j->payload, &j->payload_cap, &j->raw, &j->raw_cap, &j->recs,
                       &j->recs_cap, &j->attrs, &j->attrs_cap) ||
            en_smz_scratch_reserve(&j->sc, &b, &st->header)) {
            st->ahead_bytes += job_bytes(j) - before;
            st->ahead_stop = 1;
            break;
        }
        st->ahead_bytes += job_bytes(j) - before;
        char what[64];
        j->block_no = st->block_no + en_jobring_in_flight(st->ring);
        snprintf(what, sizeof what, "block %llu", (unsigned long long)j->block_no);
        j->b = b;
        j->h = &st->header;
        j->offset = en_source_offset(s);
        j->bad = 0;
        uint8_t bh[EN_SMZ_BLOCK_HEADER_BYTES];
        j->read_rc = en_source_read(s, bh, sizeof bh, what, &j->read_err); /* in the window: cannot fail */
        if (j->read_rc == 0)
            j->read_rc = en_source_read(s, j->payload, b.compressed_bytes, what, &j->read_err);
        if (j->read_rc)
            st->ahead_stop = 1; /* raised at its turn (next_block_pooled) */
        if (en_jobring_submit(st->ring, decode_job, j)) {
            st->ahead_stop = 1; /* cannot happen: the ring had room */
            break;
        }
        st->submitted++;
    }
}

static int next_block(epsnet_reader *r, smz_reader *st);

/* next_block() with the blocks decoded on the pool: the oldest block read
 * ahead, checked in the order read_block() checks. */
static int next_block_pooled(epsnet_reader *r, smz_reader *st)
{
    read_ahead(r, st);
    void *job;
    int result;
    if (!en_jobring_retire(st->ring, &job, &result))
        return next_block(r, st);
    smz_job *j = job;
    r->here_set = 0;
    st->block_offset = j->offset;
    int rc = first_vertex_check(r, st, &j->b);
    if (rc)
        return rc;
    if (j->read_rc) {
        r->err = j->read_err;
        r->failed = 1;
        return j->read_rc;
    }
    if (j->bad)
        return en_reader_fail_at(r, EPSNET_EFORMAT, st->block_offset, "block %llu is corrupt: %s",
                                 (unsigned long long)st->block_no, j->why);
    block_decoded(r, st, &j->b, j->recs, &j->bounds);
    /* The source is past the blocks read ahead; errors while this block's
     * records are pushed name where the one-thread reader stands: its end. */
    r->here = j->offset + EN_SMZ_BLOCK_HEADER_BYTES + j->b.compressed_bytes;
    r->here_set = 1;
    read_ahead(r, st); /* decode the next ones while this one is pushed */
    return 1;
}

static void jobs_free(smz_reader *st)
{
    en_jobring_free(&st->ring, NULL);
    for (size_t i = 0; i < st->njobs; i++) {
        ZSTD_freeDCtx(st->jobs[i].dctx);
        en_free(st->jobs[i].payload);
        en_free(st->jobs[i].raw);
        en_free(st->jobs[i].recs);
        en_free(st->jobs[i].attrs);
        en_smz_scratch_free(&st->jobs[i].sc);
    }
    en_free(st->jobs);
    st->jobs = NULL;
    st->njobs = 0;
    st->ahead_bytes = 0;
}

/*
 * From now on decode blocks on pool (NULL, or a pool without workers: on
 * the caller's thread). Stopping waits for the blocks in flight; the
 * records already queued stay readable (they are copied), those handed
 * out in place (smz_next_in_place) do not: stop between batches.
 */
static int smz_use_pool(epsnet_reader *r, en_pool *pool)
{
    smz_reader *st = r->state;
    if (!pool || en_pool_threads(pool) == 0) {
        int lost = st->ring && en_jobring_in_flight(st->ring);
        if (st->ring && st->pos < st->nrecs && st->cur != st->recs)
            lost = 1; /* records of the current block live in a job slot */
        jobs_free(st); /* waits for the blocks in flight: the pool may go next */
        if (lost && !r->failed) /* read ahead and now dropped: this reader cannot go on */
            return en_reader_fail(r, EPSNET_EINTERNAL, "blocks read ahead were dropped (a bug)"), 0;
        return 0;
    }
    if (st->ring)
        return 0;
    /* one block in flight a worker: twice that held 20 MB more at 20M faces
     * and -j 2 and read no faster (bench/RESULTS.md, session 33) */
    size_t cap = (size_t)en_pool_threads(pool);
    if (en_jobring_new(&st->ring, pool, cap))
        return EPSNET_ENOMEM;
    st->njobs = cap + 1;
    st->jobs = en_calloc(st->njobs, sizeof *st->jobs);
    int rc = st->jobs ? 0 : EPSNET_ENOMEM;
    for (size_t i = 0; i < st->njobs && rc == 0; i++)
        if (!(st->jobs[i].dctx = ZSTD_createDCtx()))
            rc = EPSNET_ENOMEM;
    if (rc) {
        if (!st->jobs)
            st->njobs = 0;
        jobs_free(st);
        return rc;
    }
    st->ahead_stop = st->finished;
    return 0;
}

static int smz_fill(epsnet_reader *r)
{
    smz_reader *st = r->state;
    while (r->qlen < SMZ_FILL_BATCH) {
        if (st->pos == st->nrecs) {
            if (st->finished)
                break;
            int rc = st->ring ? next_block_pooled(r, st) : next_block(r, st);
            if (rc < 0)
                return rc;
            if (rc == 0)
                break;
            continue;
        }
        int rc = push_one(r, st, &st->cur[st->pos], 1);
        if (rc)
            return rc;
        st->pos++;
    }
    return r->qlen > 0;
}

/* The rest of the current block (the next one, when it is used up), checked
 * as smz_fill checks, in place: in st->recs or its job's slot, which stay
 * untouched until the next block is taken (en_format.next_in_place). */
static int smz_next_in_place(epsnet_reader *r, const epsnet_record **recs, size_t *n)
{
    smz_reader *st = r->state;
    while (st->pos == st->nrecs) {
        if (st->finished)
            return 0;
        int rc = st->ring ? next_block_pooled(r, st) : next_block(r, st);
        if (rc <= 0)
            return rc;
    }
    uint32_t from = st->pos;
    int rc = 0;
    while (st->pos < st->nrecs && (rc = push_one(r, st, &st->cur[st->pos], 0)) == 0)
        st->pos++;
    *recs = st->cur + from;
    *n = st->pos - from;
    return rc ? rc : 1;
}

static void smz_close_reader(epsnet_reader *r)
{
    smz_reader *st = r->state;
    if (!st)
        return;
    jobs_free(st); /* waits for the blocks in flight */
    ZSTD_freeDCtx(st->dctx);
    en_free(st->payload);
    en_free(st->raw);
    en_free(st->recs);
    en_free(st->attrs);
    en_smz_scratch_free(&st->sc);
    en_free(st);
    r->state = NULL;
}

static int smz_probe(const uint8_t *head, size_t n)
{
    return n >= 8 && memcmp(head, en_smz_magic, 8) == 0 ? 100 : 0;
}

/* ---- writer ---- */

/*
 * One block of the writer: its records gathered in enc, then encoded and
 * compressed into out, on the caller's thread or on a worker. The caller's
 * thread fills enc, first_vertex, first_triangle and the block's axis range
 * and submits; the worker writes out, out_cap, b and bad; the caller reads
 * them after its ring retires the job, in block order, and writes the
 * block. Between submit and retire only the worker touches the slot.
 */
typedef struct smz_wjob {
    en_smz_encoder *enc;
    ZSTD_CCtx *cctx;
    uint8_t *out;
    size_t out_cap;
    en_smz_block_header b;
    int bad;                       /* worker: the encoder or zstd failed (out of memory) */
    uint64_t first_vertex, first_triangle;
    double axis_min, axis_max;
} smz_wjob;

typedef struct smz_writer {
    smz_wjob *jobs;                /* njobs slots; jobs[cur] gathers the block being written */
    size_t njobs, cur;
    en_jobring *ring;              /* NULL: blocks are compressed on the caller's thread (njobs 1) */
    uint64_t submitted;            /* blocks handed to the ring */
    int level;
    en_smz_index_entry *index;
    size_t nindex, index_cap;
    en_smz_header announced;       /* as written at the start */
    uint64_t header_offset;
    uint64_t nverts, ntris, nfinal;
    double lo[3], hi[3];
    int axis;                      /* announced stream axis, -1 none */
    int sorted_ok;
    double prev_axis;
} smz_writer;

static int wfail_nomem(epsnet_writer *w)
{
    return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
}

/* A block slot's encoder and compression context. @return 0 or -1. */
static int wjob_init(const epsnet_writer *w, const smz_writer *st, smz_wjob *j)
{
    j->enc = en_smz_encoder_new_v2(w->coord_type, &w->attrs, st->axis);
    j->cctx = ZSTD_createCCtx();
    if (!j->enc || !j->cctx)
        return -1;
    ZSTD_CCtx_setParameter(j->cctx, ZSTD_c_compressionLevel, st->level);
    ZSTD_CCtx_setParameter(j->cctx, ZSTD_c_checksumFlag, 1);
    ZSTD_CCtx_setParameter(j->cctx, ZSTD_c_contentSizeFlag, 1);
    j->axis_min = INFINITY;
    j->axis_max = -INFINITY;
    return 0;
}

static void wjob_free(smz_wjob *j)
{
    en_smz_encoder_free(&j->enc);
    ZSTD_freeCCtx(j->cctx);
    en_free(j->out);
    memset(j, 0, sizeof *j);
}

static int smz_open_writer(epsnet_writer *w)
{
    smz_writer *st = en_calloc(1, sizeof *st);
    if (!st)
        return wfail_nomem(w);
    w->state = st;
    st->axis = w->info.sorted_axis >= 0 && w->info.sorted_axis < 3 ? w->info.sorted_axis : -1;
    st->level = w->settings.zstd_level > 0 ? w->settings.zstd_level : 3;
    st->jobs = en_calloc(1, sizeof *st->jobs);
    if (!st->jobs)
        return wfail_nomem(w);
    st->njobs = 1;
    if (wjob_init(w, st, &st->jobs[0]))
        return wfail_nomem(w);
    st->sorted_ok = 1;
    st->prev_axis = -INFINITY;
    for (int k = 0; k < 3; k++) {
        st->lo[k] = INFINITY;
        st->hi[k] = -INFINITY;
    }
    en_smz_header *h = &st->announced;
    h->version = EN_SMZ_VERSION;
    h->attrs = w->attrs;
    h->coord_type = w->coord_type;
    h->axis = st->axis;
    h->sorted = st->axis >= 0;
    h->nverts = w->info.nverts;
    h->nfaces = w->info.nfaces;
    /* note: an announced bbox is only a promise; it goes into the header
     * only where the real one can replace it at the end. */
    h->has_bbox = 0;
    st->header_offset = en_sink_offset(w->sink);
    uint8_t hb[EN_SMZ_HEADER_BYTES];
    en_smz_header_encode(h, hb);
    int rc = en_writer_bytes(w, hb, sizeof hb);
    if (rc == 0) {
        uint8_t tab[EN_SMZ_MAX_TABLE_BYTES];
        rc = en_writer_bytes(w, tab, en_smz_attr_table_encode(&h->attrs, tab));
    }
    return rc;
}

/* Encode and compress a block (a pool job, or inline). */
static int compress_job(void *job)
{
    smz_wjob *j = job;
    j->bad = en_smz_encoder_flush(j->enc, j->cctx, &j->out, &j->out_cap, &j->b) != 0;
    return 0;
}

/* Write a compressed block and its index entry, in block order. */
static int write_block(epsnet_writer *w, smz_writer *st, smz_wjob *j)
{
    if (j->bad)
        return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "cannot compress a block (out of memory)");
    en_smz_block_header b = j->b;
    b.first_vertex = j->first_vertex;
    if (st->nindex == st->index_cap &&
        en_grow((void **)&st->index, &st->index_cap, st->nindex + 1, sizeof *st->index))
        return wfail_nomem(w);
    st->index[st->nindex++] = (en_smz_index_entry){
        .offset = en_sink_offset(w->sink) - st->header_offset, .first_vertex = j->first_vertex,
        .first_triangle = j->first_triangle, .records = b.records, .compressed_bytes = b.compressed_bytes,
        .axis_min = j->axis_min, .axis_max = j->axis_max,
    };
    uint8_t bh[EN_SMZ_BLOCK_HEADER_BYTES];
    en_smz_block_header_encode(&b, bh);
    int rc = en_writer_bytes(w, bh, sizeof bh);
    if (rc == 0)
        rc = en_writer_bytes(w, j->out, b.compressed_bytes);
    return rc;
}

/* Write the oldest block on the pool. @return 0 when none is in flight. */
static int retire_block(epsnet_writer *w, smz_writer *st)
{
    void *job;
    int result;
    if (!st->ring || !en_jobring_retire(st->ring, &job, &result))
        return 0;
    return write_block(w, st, job);
}

/* The block gathered so far goes out: compressed here and written, or
 * handed to the pool, the next slot taking the records that follow. */
static int flush_block(epsnet_writer *w, smz_writer *st)
{
    smz_wjob *j = &st->jobs[st->cur];
    if (en_smz_encoder_records(j->enc) == 0)
        return 0;
    int rc = 0;
    if (!st->ring) {
        compress_job(j);
        rc = write_block(w, st, j);
    } else {
        /* the next slot must be free before this one goes (njobs = ring + 1) */
        while (rc == 0 && en_jobring_in_flight(st->ring) + 1 >= st->njobs)
            rc = retire_block(w, st);
        if (rc == 0 && en_jobring_submit(st->ring, compress_job, j))
            rc = en_error_set(&w->err, EPSNET_EINTERNAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                              "worker pool refused a block (a bug)");
        if (rc == 0) {
            st->submitted++;
            st->cur = (size_t)(st->submitted % st->njobs);
            j = &st->jobs[st->cur];
        }
    }
    j->first_vertex = st->nverts;
    j->first_triangle = st->ntris;
    j->axis_min = INFINITY;
    j->axis_max = -INFINITY;
    return rc;
}

static int smz_put(epsnet_writer *w, const epsnet_record *rec)
{
    smz_writer *st = w->state;
    epsnet_record r = *rec;
    if (rec->kind == EPSNET_REC_VERTEX) {
        for (int k = 0; k < 3; k++) {
            /* note: stored as the writer's coordinate type; bbox and the
             * sorted check must see the stored values. */
            if (w->coord_type == EPSNET_COORD_FLOAT32) {
                float f = (float)rec->xyz[k];
                if (isfinite(rec->xyz[k]) && !isfinite(f))
                    return en_error_set(&w->err, EPSNET_EUNSUPPORTED, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                        "vertex %llu: coordinate %g does not fit in float32",
                                        (unsigned long long)st->nverts + 1, rec->xyz[k]);
                r.xyz[k] = f;
            }
            if (r.xyz[k] < st->lo[k])
                st->lo[k] = r.xyz[k];
            if (r.xyz[k] > st->hi[k])
                st->hi[k] = r.xyz[k];
        }
        double a = r.xyz[st->axis >= 0 ? st->axis : 0];
        if (st->axis >= 0 && a < st->prev_axis)
            st->sorted_ok = 0;
        st->prev_axis = a;
        smz_wjob *j = &st->jobs[st->cur];
        if (a < j->axis_min)
            j->axis_min = a;
        if (a > j->axis_max)
            j->axis_max = a;
    }
    en_smz_encoder *enc = st->jobs[st->cur].enc;
    if (en_smz_encoder_add(enc, &r, st->nverts))
        return wfail_nomem(w);
    if (rec->kind == EPSNET_REC_VERTEX)
        st->nverts++;
    else if (rec->kind == EPSNET_REC_TRIANGLE)
        st->ntris++;
    else
        st->nfinal++;
    if (en_smz_encoder_raw_bytes(enc) >= EN_SMZ_TARGET_RAW_BYTES || en_smz_encoder_records(enc) >= EN_SMZ_MAX_RECORDS)
        return flush_block(w, st);
    return 0;
}

/* Stop using the pool: write the blocks in flight, in order. */
static int writer_jobs_drain(epsnet_writer *w, smz_writer *st)
{
    int rc = 0;
    while (st->ring && en_jobring_in_flight(st->ring))
        if ((rc = retire_block(w, st)) != 0)
            break;
    en_jobring_free(&st->ring, NULL); /* waits for any left after a failure */
    return rc;
}

/*
 * From now on compress blocks on pool (NULL, or a pool without workers: on
 * the caller's thread, after writing the blocks in flight). A failure to
 * write them is the writer's, reported by its next call.
 */
static int smz_writer_use_pool(epsnet_writer *w, en_pool *pool)
{
    smz_writer *st = w->state;
    if (!pool || en_pool_threads(pool) == 0) {
        int rc = writer_jobs_drain(w, st);
        if (rc && !w->failed)
            w->failed = 1;
        if (st->njobs > 1) {
            /* the block being gathered moves to slot 0, the only one left */
            smz_wjob keep = st->jobs[st->cur];
            st->jobs[st->cur] = st->jobs[0];
            st->jobs[0] = keep;
            for (size_t i = 1; i < st->njobs; i++)
                wjob_free(&st->jobs[i]);
            st->njobs = 1;
            st->cur = 0;
        }
        return 0;
    }
    if (st->ring)
        return 0;
    /* note: one block in flight while the next gathers: blocks come far
     * apart (the output is a tenth of the input or less), and each slot
     * holds an encoder and a zstd context, a few MB */
    size_t n = 1;
    smz_wjob *jobs = en_realloc(st->jobs, (n + 1) * sizeof *jobs);
    if (!jobs)
        return EPSNET_ENOMEM;
    st->jobs = jobs;
    memset(jobs + st->njobs, 0, (n + 1 - st->njobs) * sizeof *jobs);
    int rc = 0;
    for (size_t i = st->njobs; i < n + 1 && rc == 0; i++)
        rc = wjob_init(w, st, &jobs[i]) ? EPSNET_ENOMEM : 0;
    if (rc == 0)
        rc = en_jobring_new(&st->ring, pool, n);
    if (rc) {
        for (size_t i = st->njobs; i < n + 1; i++)
            wjob_free(&jobs[i]);
        return EPSNET_ENOMEM;
    }
    if (st->cur != 0) { /* slot 0 first: the ring's order starts there */
        smz_wjob keep = jobs[0];
        jobs[0] = jobs[st->cur];
        jobs[st->cur] = keep;
    }
    st->njobs = n + 1;
    st->cur = 0;
    st->submitted = 0;
    return 0;
}

static int write_index(epsnet_writer *w, smz_writer *st, int sorted, int has_bbox)
{
    uint64_t index_offset = en_sink_offset(w->sink) - st->header_offset;
    static const uint8_t head[EN_SMZ_INDEX_HEAD_BYTES] = { 'S', 'M', 'Z', 'I', 0, 0, 0, 0 };
    uint32_t crc = en_smz_crc32(0, head, sizeof head);
    int rc = en_writer_bytes(w, head, sizeof head);
    for (size_t i = 0; rc == 0 && i < st->nindex; i++) {
        uint8_t eb[EN_SMZ_INDEX_ENTRY_BYTES];
        en_smz_index_entry_encode(&st->index[i], eb);
        crc = en_smz_crc32(crc, eb, sizeof eb);
        rc = en_writer_bytes(w, eb, sizeof eb);
    }
    if (rc)
        return rc;
    en_smz_trailer t = {
        .index_offset = index_offset, .blocks = st->nindex, .nverts = st->nverts, .nfaces = st->ntris,
        .nfinal = st->nfinal, .has_bbox = has_bbox, .sorted = sorted, .axis = st->axis, .index_crc = crc,
    };
    for (int k = 0; k < 3; k++) {
        t.bbox[k] = st->lo[k];
        t.bbox[k + 3] = st->hi[k];
    }
    uint8_t tb[EN_SMZ_TRAILER_BYTES];
    en_smz_trailer_encode(&t, tb);
    return en_writer_bytes(w, tb, sizeof tb);
}

static int smz_finish(epsnet_writer *w)
{
    smz_writer *st = w->state;
    int rc = flush_block(w, st);
    if (rc == 0)
        rc = writer_jobs_drain(w, st);
    if (rc)
        return rc;
    int sorted = st->axis >= 0 && st->sorted_ok;
    int has_bbox = st->nverts > 0;
    if ((rc = write_index(w, st, sorted, has_bbox)))
        return rc;
    en_smz_header real = st->announced;
    real.nverts = st->nverts;
    real.nfaces = st->ntris;
    real.sorted = sorted;
    real.has_bbox = has_bbox;
    for (int k = 0; k < 3; k++) {
        real.bbox[k] = st->lo[k];
        real.bbox[k + 3] = st->hi[k];
    }
    if (en_sink_can_patch(w->sink)) {
        uint8_t hb[EN_SMZ_HEADER_BYTES];
        en_smz_header_encode(&real, hb);
        return en_sink_patch(w->sink, st->header_offset, hb, sizeof hb, &w->err);
    }
    const en_smz_header *a = &st->announced;
    if ((a->nverts != EPSNET_COUNT_UNKNOWN && a->nverts != st->nverts) ||
        (a->nfaces != EPSNET_COUNT_UNKNOWN && a->nfaces != st->ntris))
        return en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "%llu vertices and %llu triangles were announced but %llu and %llu written",
                            (unsigned long long)a->nverts, (unsigned long long)a->nfaces,
                            (unsigned long long)st->nverts, (unsigned long long)st->ntris);
    if (a->sorted && !sorted)
        return en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "the stream was announced sorted along %c but its vertices are not",
                            "xyz"[a->axis]);
    return 0;
}

static void smz_close_writer(epsnet_writer *w)
{
    smz_writer *st = w->state;
    if (!st)
        return;
    en_jobring_free(&st->ring, NULL); /* waits for the blocks in flight */
    for (size_t i = 0; st->jobs && i < st->njobs; i++)
        wjob_free(&st->jobs[i]);
    en_free(st->jobs);
    en_free(st->index);
    en_free(st);
    w->state = NULL;
}

const en_format en_format_smz = {
    .name = "smz",
    .extensions = "smz",
    .probe = smz_probe,
    .open_reader = smz_open_reader,
    .fill = smz_fill,
    .close_reader = smz_close_reader,
    .use_pool = smz_use_pool,
    .next_in_place = smz_next_in_place,
    .open_writer = smz_open_writer,
    .put = smz_put,
    .finish = smz_finish,
    .close_writer = smz_close_writer,
    .writer_use_pool = smz_writer_use_pool,
    .holds_attr = en_format_holds_every_attr,
};
