/*
 * SMB, the binary streaming mesh of Isenburg & Lindstrom, "Streaming Meshes"
 * (2005):
 *
 *   byte 0     version, 0
 *   byte 1     byte order of everything after: 0 little, 1 big endian
 *   bytes 2-3  unused
 *   int32      comment count, then per comment an int32 length and the bytes
 *   int32      nverts, int32 nfaces (-1 = unknown)
 *   byte       bbox flag; when set, 6 float32 (min xyz, max xyz)
 *   blocks     uint32 bitmask (bit i set = record i is a vertex) followed by
 *              up to 32 records of 12 bytes: 3 float32, or 3 int32 corners
 *              encoded as in SMA (positive = 1-based absolute, negative =
 *              relative to the newest vertex and finalizing it)
 *
 * The stream ends once nverts vertices and nfaces triangles have been read
 * when the header gives both; otherwise at the end of the data, where a
 * partial last block is normal. After the announced records only an empty
 * block word may follow: the authors' writer appends one when the last block
 * was full.
 *
 * note: byte order. The authors' writer is known to have produced files that
 * say big-endian but hold little-endian data. So the header (and the first
 * block) are decoded in both byte orders. A reading is broken when the
 * comment count or lengths are negative or exceed SMB_MAX_COMMENT_BYTES in
 * total, a count is below -1, or the header runs past the data. Otherwise it
 * scores one point for each soft check it passes: counts within the
 * reader's max_count; a bbox (if any) finite with min <= max; the announced
 * records fit in the file (plain files only); a consistent first block
 * (corners non-zero, naming vertices before them). The declared order is
 * used unless the other one scores higher; a broken declared reading is the
 * error unless the other passes every soft check. A truncated file thus
 * keeps its declared order and is reported where its data ends. The order
 * is chosen once and applied through a function pointer (after rply's
 * drivers), not tested per value.
 *
 * note: the authors' writer (smwriter_smb.cpp) writes the rest of the header
 * only with the first record, so an empty mesh is the version byte followed
 * by the empty block word of its final flush: five zero bytes. That whole
 * file is read as a valid empty mesh (docs/architecture.md §5).
 *
 * Writer: little-endian, version 0, no comments. Counts come from the
 * announced info (-1 when unknown) and are patched with the real ones on
 * seekable outputs; on compressed or piped outputs an announced count that
 * turns out wrong is an error. The last triangle is held back so that
 * FINALIZE records right after it become negative corners. Any other
 * finalization cannot be expressed in SMB and is not written: the vertex is
 * then finalized implicitly at the end of the stream. Coordinates are
 * float32 whatever the writer's coordinate type.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "common/alloc.h"
#include "io/format.h"

#define SMB_RECORD_BYTES 12
#define SMB_BLOCK_RECORDS 32
/* note: a little under 1 MiB, so that the header and the first block always
 * fit in the one look-ahead window used to choose the byte order. */
#define SMB_MAX_COMMENT_BYTES (((size_t)1 << 20) - 4096)
#define SMB_PEEK_BYTES ((size_t)1 << 20)
#define SMB_FILL_BATCH 4096
/* Version byte and one empty block word: the authors' empty mesh. */
#define SMB_EMPTY_FILE_BYTES 5

typedef uint32_t (*smb_get32)(const uint8_t *p);

static uint32_t get32_le(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint32_t get32_be(const uint8_t *p)
{
    return (uint32_t)p[3] | (uint32_t)p[2] << 8 | (uint32_t)p[1] << 16 | (uint32_t)p[0] << 24;
}

static float bits_to_float(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* ---- header ---- */

typedef struct smb_header {
    int64_t nverts, nfaces;          /* -1 unknown */
    int has_bbox;
    float bbox[6];
    size_t size;                     /* bytes up to the first block */
    int over_limit;                  /* a count exceeds the reader's max_count */
    size_t counts_at;                /* offset of nverts */
} smb_header;

/* A reading of the header in one byte order: broken, or how many of the
 * SMB_SOFT_CHECKS it passes (see the file comment). */
enum { SMB_BROKEN = -1, SMB_SOFT_CHECKS = 4 };

typedef struct smb_verdict {
    uint64_t offset;                 /* of the fault, when broken */
    char reason[200];
} smb_verdict;

static int broken(smb_verdict *v, uint64_t offset, const char *reason)
{
    v->offset = offset;
    snprintf(v->reason, sizeof v->reason, "%s", reason);
    return SMB_BROKEN;
}

/* Decode the header from the look-ahead window [p, p+n). */
static int parse_header(const uint8_t *p, size_t n, smb_get32 get32, uint64_t max_count,
                        smb_header *h, smb_verdict *v)
{
    char why[200];
    size_t pos = 4;
    h->over_limit = 0;
    if (n < 8)
        return broken(v, n, "truncated file: the header ends early");
    uint32_t ncomments = get32(p + pos);
    if (ncomments > SMB_MAX_COMMENT_BYTES / 4) {
        snprintf(why, sizeof why, "comment count %d is absurd (at most %zu bytes of comments)",
                 (int)(int32_t)ncomments, SMB_MAX_COMMENT_BYTES);
        return broken(v, pos, why);
    }
    pos += 4;
    size_t comment_bytes = 4 * (size_t)ncomments;
    for (uint32_t i = 0; i < ncomments; i++) {
        if (n < pos + 4)
            return broken(v, n, "truncated file: the header ends inside the comments");
        uint32_t len = get32(p + pos);
        if (len > SMB_MAX_COMMENT_BYTES - comment_bytes) {
            snprintf(why, sizeof why, "comment %u has length %d, over the %zu bytes allowed for comments",
                     i + 1, (int)(int32_t)len, SMB_MAX_COMMENT_BYTES);
            return broken(v, pos, why);
        }
        comment_bytes += len;
        pos += 4 + (size_t)len;
    }
    if (n < pos + 9)
        return broken(v, n, "truncated file: the header ends early");
    h->counts_at = pos;
    h->nverts = (int32_t)get32(p + pos);
    h->nfaces = (int32_t)get32(p + pos + 4);
    for (int k = 0; k < 2; k++) {
        int64_t c = k ? h->nfaces : h->nverts;
        if (c < -1) {
            snprintf(why, sizeof why, "%s %lld is negative", k ? "face count" : "vertex count", (long long)c);
            return broken(v, pos + 4 * (size_t)k, why);
        }
        /* note: over the limit is only implausible here; once the order is
         * chosen, en_reader_check_count() reports it as a limit. */
        if (c > 0 && (uint64_t)c > max_count)
            h->over_limit = 1;
    }
    pos += 8;
    h->has_bbox = p[pos++] != 0;
    if (h->has_bbox) {
        if (n < pos + 24)
            return broken(v, n, "truncated file: the header ends inside the bounding box");
        for (int k = 0; k < 6; k++)
            h->bbox[k] = bits_to_float(get32(p + pos + 4 * (size_t)k));
        pos += 24;
    }
    h->size = pos;
    return 0;
}

/* First block: corners are non-zero and name vertices that precede them. */
static int first_block_consistent(const uint8_t *p, size_t n, smb_get32 get32, const smb_header *h)
{
    int counts_known = h->nverts >= 0 && h->nfaces >= 0;
    uint64_t records = counts_known ? (uint64_t)h->nverts + (uint64_t)h->nfaces : UINT64_MAX;
    size_t pos = h->size;
    if (n < pos + 4)
        return 1;
    uint32_t mask = get32(p + pos);
    pos += 4;
    uint64_t nv = 0;
    for (int i = 0; i < SMB_BLOCK_RECORDS && (uint64_t)i < records && pos + SMB_RECORD_BYTES <= n;
         i++, pos += SMB_RECORD_BYTES) {
        if (mask >> i & 1) {
            nv++;
            continue;
        }
        for (int k = 0; k < 3; k++) {
            int32_t c = (int32_t)get32(p + pos + 4 * (size_t)k);
            uint64_t mag = c < 0 ? (uint64_t)(-(int64_t)c) : (uint64_t)c;
            if (c == 0 || mag > nv)
                return 0;
        }
    }
    return 1;
}

/* The soft checks that tell a right byte order from a wrong one. */
static int soft_checks(const uint8_t *p, size_t n, smb_get32 get32, const smb_header *h,
                       uint64_t file_size)
{
    int passed = !h->over_limit;
    int bbox_ok = 1;
    for (int k = 0; h->has_bbox && k < 3; k++)
        if (!isfinite(h->bbox[k]) || !isfinite(h->bbox[k + 3]) || h->bbox[k] > h->bbox[k + 3])
            bbox_ok = 0;
    passed += bbox_ok;
    int fits = 1;
    if (file_size && h->nverts >= 0 && h->nfaces >= 0) {
        uint64_t records = (uint64_t)h->nverts + (uint64_t)h->nfaces;
        uint64_t need = records * SMB_RECORD_BYTES + (records + SMB_BLOCK_RECORDS - 1) / SMB_BLOCK_RECORDS * 4;
        fits = h->size + need <= file_size;
    }
    passed += fits;
    passed += first_block_consistent(p, n, get32, h);
    return passed;
}

static int read_verdict(const uint8_t *p, size_t n, smb_get32 get32, uint64_t max_count,
                        uint64_t file_size, smb_header *h, smb_verdict *v)
{
    if (parse_header(p, n, get32, max_count, h, v) == SMB_BROKEN)
        return SMB_BROKEN;
    return soft_checks(p, n, get32, h, file_size);
}

/* ---- reader ---- */

typedef struct smb_reader {
    smb_get32 get32;
    int64_t nverts, nfaces;          /* announced, -1 unknown */
    uint32_t mask;
    int in_block;                    /* records left in the current block */
    int record_in_block;
} smb_reader;

/* The authors' empty mesh (file comment): no header beyond the version. */
static int open_empty(epsnet_reader *r, smb_reader *st)
{
    st->get32 = get32_le;
    st->nverts = st->nfaces = 0;
    r->info.encoding = "binary_le";
    r->info.nverts = r->info.nfaces = 0;
    r->src->cur += SMB_EMPTY_FILE_BYTES;
    return 0;
}

static int smb_open_reader(epsnet_reader *r)
{
    en_source *s = r->src;
    smb_reader *st = en_calloc(1, sizeof *st);
    if (!st)
        return en_reader_fail(r, EPSNET_ENOMEM, "out of memory");
    r->state = st;
    r->text = 0;
    r->info.streaming = 1;
    r->info.coord_type = EPSNET_COORD_FLOAT32;
    size_t n = en_source_fill(s, SMB_PEEK_BYTES);
    if (s->failed) {
        r->failed = 1;
        return en_source_error(s, &r->err);
    }
    const uint8_t *p = s->cur;
    if (n == SMB_EMPTY_FILE_BYTES && p[0] == 0 && get32_le(p + 1) == 0)
        return open_empty(r, st);
    if (n < 2)
        return en_reader_fail_at(r, EPSNET_EFORMAT, n, "truncated file: no SMB header");
    if (p[0] != 0)
        return en_reader_fail_at(r, EPSNET_EFORMAT, 0, "SMB version byte is %u, expected 0", p[0]);
    if (p[1] > 1)
        return en_reader_fail_at(r, EPSNET_EFORMAT, 1, "SMB byte order flag is %u, expected 0 or 1", p[1]);
    uint64_t file_size = s->zstd ? 0 : s->file_size;
    smb_get32 declared = p[1] ? get32_be : get32_le, other = p[1] ? get32_le : get32_be;
    smb_header hd, ho;
    smb_verdict vd, vo;
    int rc;
    int ld = read_verdict(p, n, declared, r->settings.max_count, file_size, &hd, &vd);
    int lo = read_verdict(p, n, other, r->settings.max_count, file_size, &ho, &vo);
    const smb_header *h = &hd;
    st->get32 = declared;
    if (ld == SMB_BROKEN && lo < SMB_SOFT_CHECKS)
        return en_reader_fail_at(r, EPSNET_EFORMAT, vd.offset, "%s", vd.reason);
    if (lo > ld) {
        h = &ho;
        st->get32 = other;
    }
    r->info.encoding = st->get32 == get32_be ? "binary_be" : "binary_le";
    if ((h->nverts > 0 && (rc = en_reader_check_count(r, (uint64_t)h->nverts, "vertex count"))) ||
        (h->nfaces > 0 && (rc = en_reader_check_count(r, (uint64_t)h->nfaces, "face count"))))
        return rc;
    st->nverts = h->nverts;
    st->nfaces = h->nfaces;
    if (h->nverts >= 0)
        r->info.nverts = (uint64_t)h->nverts;
    if (h->nfaces >= 0)
        r->info.nfaces = (uint64_t)h->nfaces;
    r->info.has_bbox = h->has_bbox;
    for (int k = 0; k < 3; k++) {
        r->info.bbox_min[k] = h->bbox[k];
        r->info.bbox_max[k] = h->bbox[k + 3];
    }
    s->cur += h->size;
    return 0;
}

static int counts_known(const smb_reader *st)
{
    return st->nverts >= 0 && st->nfaces >= 0;
}

static int counts_reached(const epsnet_reader *r, const smb_reader *st)
{
    return counts_known(st) && r->nverts == (uint64_t)st->nverts && r->ntris == (uint64_t)st->nfaces;
}

/* End of data: fine unless a count says more records were promised. */
static int end_of_data(epsnet_reader *r, const smb_reader *st)
{
    if (st->nverts >= 0 && r->nverts != (uint64_t)st->nverts)
        return en_reader_fail(r, EPSNET_EFORMAT, "truncated file: %llu of the %lld announced vertices present",
                              (unsigned long long)r->nverts, (long long)st->nverts);
    if (st->nfaces >= 0 && r->ntris != (uint64_t)st->nfaces)
        return en_reader_fail(r, EPSNET_EFORMAT, "truncated file: %llu of the %lld announced triangles present",
                              (unsigned long long)r->ntris, (long long)st->nfaces);
    return 0;
}

/* After the announced records only an empty block word may follow. */
static int check_trailing(epsnet_reader *r, const smb_reader *st)
{
    size_t rest = en_source_fill(r->src, 8);
    if (r->src->failed) {
        r->failed = 1;
        return en_source_error(r->src, &r->err);
    }
    if (rest == 0 || (rest == 4 && get32_le(r->src->cur) == 0))
        return 0;
    return en_reader_fail(r, EPSNET_EFORMAT, "data after the last announced record (%lld vertices, %lld triangles)",
                          (long long)st->nverts, (long long)st->nfaces);
}

/* @return 1 with a block started, 0 at the end of data, or an error. */
static int start_block(epsnet_reader *r, smb_reader *st)
{
    en_source *s = r->src;
    size_t n = en_source_fill(s, 4);
    if (s->failed) {
        r->failed = 1;
        return en_source_error(s, &r->err);
    }
    if (n == 0)
        return 0;
    if (n < 4)
        return en_reader_fail(r, EPSNET_EFORMAT, "truncated file: a block header is cut short (%zu of 4 bytes)", n);
    st->mask = st->get32(s->cur);
    s->cur += 4;
    st->in_block = SMB_BLOCK_RECORDS;
    st->record_in_block = 0;
    return 1;
}

static int decode_triangle(epsnet_reader *r, const smb_reader *st, const uint8_t *p)
{
    int32_t c[3];
    uint64_t v[3];
    for (int k = 0; k < 3; k++) {
        c[k] = (int32_t)st->get32(p + 4 * k);
        if (c[k] > 0) {
            v[k] = (uint64_t)c[k] - 1;
        } else if (c[k] < 0 && (uint64_t)(-(int64_t)c[k]) <= r->nverts) {
            v[k] = r->nverts - (uint64_t)(-(int64_t)c[k]);
        } else {
            return en_reader_fail(r, EPSNET_EFORMAT, "triangle %llu: corner index %d is %s",
                                  (unsigned long long)r->ntris + 1, c[k],
                                  c[k] == 0 ? "0 (SMB indices start at 1)" : "before the first vertex");
        }
    }
    int rc = en_reader_push_triangle(r, v[0], v[1], v[2]);
    for (int k = 0; k < 3 && rc == 0; k++) {
        int first = c[k] < 0;
        for (int j = 0; j < k; j++)
            if (c[j] < 0 && v[j] == v[k])
                first = 0;
        if (first)
            rc = en_reader_push_finalize(r, v[k]);
    }
    return rc;
}

/* One record at s->cur; the source advances only after it is accepted, so
 * errors point at the record's first byte. */
static int read_record(epsnet_reader *r, smb_reader *st)
{
    en_source *s = r->src;
    size_t n = en_source_fill(s, SMB_RECORD_BYTES);
    if (s->failed) {
        r->failed = 1;
        return en_source_error(s, &r->err);
    }
    if (n == 0)
        return 0;
    int is_vertex = st->mask >> st->record_in_block & 1;
    if (n < SMB_RECORD_BYTES)
        return en_reader_fail(r, EPSNET_EFORMAT, "truncated file: a %s record is cut short (%zu of %d bytes)",
                              is_vertex ? "vertex" : "triangle", n, SMB_RECORD_BYTES);
    const uint8_t *p = s->cur;
    int rc;
    if (is_vertex) {
        if (st->nverts >= 0 && r->nverts == (uint64_t)st->nverts)
            return en_reader_fail(r, EPSNET_EFORMAT, "more vertices than the %lld announced", (long long)st->nverts);
        rc = en_reader_push_vertex(r, bits_to_float(st->get32(p)), bits_to_float(st->get32(p + 4)),
                                   bits_to_float(st->get32(p + 8)));
    } else {
        if (st->nfaces >= 0 && r->ntris == (uint64_t)st->nfaces)
            return en_reader_fail(r, EPSNET_EFORMAT, "more triangles than the %lld announced", (long long)st->nfaces);
        rc = decode_triangle(r, st, p);
    }
    if (rc)
        return rc;
    s->cur += SMB_RECORD_BYTES;
    st->record_in_block++;
    st->in_block--;
    return 1;
}

static int smb_fill(epsnet_reader *r)
{
    smb_reader *st = r->state;
    while (r->qlen < SMB_FILL_BATCH) {
        int rc;
        if (counts_reached(r, st)) {
            rc = check_trailing(r, st);
        } else {
            rc = st->in_block ? 1 : start_block(r, st);
            if (rc == 1)
                rc = read_record(r, st);
            if (rc == 0)
                rc = end_of_data(r, st);
            if (rc > 0)
                continue;
        }
        if (rc < 0)
            return rc;
        return r->qlen > 0;
    }
    return 1;
}

static void smb_close_reader(epsnet_reader *r)
{
    en_free(r->state);
    r->state = NULL;
}

static int smb_probe(const uint8_t *head, size_t n)
{
    if (n < 17 || head[0] != 0 || head[1] > 1 || head[2] != 0 || head[3] != 0)
        return 0;
    smb_header h;
    smb_verdict v;
    if (read_verdict(head, n, head[1] ? get32_be : get32_le, (uint64_t)1 << 34, 0, &h, &v) == SMB_SOFT_CHECKS ||
        read_verdict(head, n, head[1] ? get32_le : get32_be, (uint64_t)1 << 34, 0, &h, &v) == SMB_SOFT_CHECKS)
        return 55;
    return 0;
}

/* ---- writer ---- */

typedef struct smb_pending {
    int active;
    uint64_t v[3];
    uint64_t nverts_then;
    int negative[3];
    int last_absorbed;
} smb_pending;

typedef struct smb_writer {
    uint8_t block[SMB_BLOCK_RECORDS * SMB_RECORD_BYTES];
    uint32_t mask;
    int nrec;
    uint64_t nverts, ntris;
    smb_pending tri;
    uint64_t counts_offset;
    int64_t header_nverts, header_nfaces;
} smb_writer;

static void put32_le(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

static uint32_t float_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

/* A count as the header can hold it: -1 when unknown or beyond int32. */
static int64_t header_count(uint64_t n)
{
    return n == EPSNET_COUNT_UNKNOWN || n > INT32_MAX ? -1 : (int64_t)n;
}

static int smb_open_writer(epsnet_writer *w)
{
    smb_writer *st = en_calloc(1, sizeof *st);
    if (!st)
        return en_error_set(&w->err, EPSNET_ENOMEM, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "out of memory");
    w->state = st;
    st->header_nverts = header_count(w->info.nverts);
    st->header_nfaces = header_count(w->info.nfaces);
    uint8_t h[4 + 4 + 8 + 1 + 24] = { 0, 0, 0, 0 };
    size_t n = 8;                                      /* version, order, unused, 0 comments */
    st->counts_offset = en_sink_offset(w->sink) + n;
    put32_le(h + n, (uint32_t)(int32_t)st->header_nverts);
    put32_le(h + n + 4, (uint32_t)(int32_t)st->header_nfaces);
    n += 8;
    h[n++] = w->info.has_bbox ? 1 : 0;
    if (w->info.has_bbox) {
        for (int k = 0; k < 3; k++) {
            put32_le(h + n + 4 * (size_t)k, float_bits((float)w->info.bbox_min[k]));
            put32_le(h + n + 12 + 4 * (size_t)k, float_bits((float)w->info.bbox_max[k]));
        }
        n += 24;
    }
    return en_writer_bytes(w, h, n);
}

static int write_block(epsnet_writer *w, smb_writer *st)
{
    if (st->nrec == 0)
        return 0;
    uint8_t mask[4];
    put32_le(mask, st->mask);
    int rc = en_writer_bytes(w, mask, 4);
    if (rc == 0)
        rc = en_writer_bytes(w, st->block, (size_t)st->nrec * SMB_RECORD_BYTES);
    st->nrec = 0;
    st->mask = 0;
    return rc;
}

static int append_record(epsnet_writer *w, smb_writer *st, int is_vertex, const uint32_t word[3])
{
    uint8_t *p = st->block + (size_t)st->nrec * SMB_RECORD_BYTES;
    for (int k = 0; k < 3; k++)
        put32_le(p + 4 * k, word[k]);
    if (is_vertex)
        st->mask |= (uint32_t)1 << st->nrec;
    st->nrec++;
    return st->nrec == SMB_BLOCK_RECORDS ? write_block(w, st) : 0;
}

static int flush_pending(epsnet_writer *w, smb_writer *st)
{
    smb_pending *t = &st->tri;
    if (!t->active)
        return 0;
    t->active = 0;
    uint32_t word[3];
    for (int k = 0; k < 3; k++) {
        int64_t c = t->negative[k] ? (int64_t)t->v[k] - (int64_t)t->nverts_then : (int64_t)t->v[k] + 1;
        if (c > INT32_MAX || c < INT32_MIN)
            return en_error_set(&w->err, EPSNET_EUNSUPPORTED, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "vertex index %llu does not fit in SMB's 32-bit indices",
                                (unsigned long long)t->v[k] + 1);
        word[k] = (uint32_t)(int32_t)c;
    }
    return append_record(w, st, 0, word);
}

/* Same rule as the SMA writer: fold a FINALIZE into the held triangle only
 * where the reader will give it back in the same place. */
static int absorb_finalize(smb_pending *t, uint64_t v)
{
    if (!t->active)
        return 0;
    int pos = -1;
    for (int k = 2; k >= 0; k--)
        if (t->v[k] == v)
            pos = k;
    if (pos < 0 || pos <= t->last_absorbed || t->negative[pos])
        return 0;
    for (int k = pos; k < 3; k++)
        if (t->v[k] == v)
            t->negative[k] = 1;
    t->last_absorbed = pos;
    return 1;
}

static int smb_put(epsnet_writer *w, const epsnet_record *rec)
{
    smb_writer *st = w->state;
    if (rec->kind == EPSNET_REC_FINALIZE && absorb_finalize(&st->tri, rec->v[0]))
        return 0;
    int rc = flush_pending(w, st);
    if (rc)
        return rc;
    if (rec->kind == EPSNET_REC_VERTEX) {
        uint32_t word[3];
        for (int k = 0; k < 3; k++) {
            float f = (float)rec->xyz[k];
            if (isfinite(rec->xyz[k]) && !isfinite(f))
                return en_error_set(&w->err, EPSNET_EUNSUPPORTED, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                    "vertex %llu: coordinate %g does not fit in SMB's float32",
                                    (unsigned long long)st->nverts + 1, rec->xyz[k]);
            word[k] = float_bits(f);
        }
        st->nverts++;
        return append_record(w, st, 1, word);
    }
    if (rec->kind == EPSNET_REC_TRIANGLE) {
        st->tri = (smb_pending){ .active = 1, .v = { rec->v[0], rec->v[1], rec->v[2] },
                                 .nverts_then = st->nverts, .last_absorbed = -1 };
        st->ntris++;
    }
    /* A FINALIZE that could not be folded in has no SMB form (file comment). */
    return 0;
}

static int smb_finish(epsnet_writer *w)
{
    smb_writer *st = w->state;
    int rc = flush_pending(w, st);
    if (rc == 0)
        rc = write_block(w, st);
    if (rc)
        return rc;
    int64_t real_v = header_count(st->nverts), real_f = header_count(st->ntris);
    if (real_v == st->header_nverts && real_f == st->header_nfaces)
        return 0;
    if (en_sink_can_patch(w->sink)) {
        uint8_t counts[8];
        put32_le(counts, (uint32_t)(int32_t)real_v);
        put32_le(counts + 4, (uint32_t)(int32_t)real_f);
        return en_sink_patch(w->sink, st->counts_offset, counts, sizeof counts, &w->err);
    }
    if ((st->header_nverts < 0 || st->header_nverts == real_v) &&
        (st->header_nfaces < 0 || st->header_nfaces == real_f))
        return 0;
    return en_error_set(&w->err, EPSNET_EINVAL, w->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "%lld vertices and %lld triangles were announced but %llu and %llu written",
                        (long long)st->header_nverts, (long long)st->header_nfaces,
                        (unsigned long long)st->nverts, (unsigned long long)st->ntris);
}

static void smb_close_writer(epsnet_writer *w)
{
    en_free(w->state);
    w->state = NULL;
}

const en_format en_format_smb = {
    .name = "smb",
    .extensions = "smb",
    .probe = smb_probe,
    .open_reader = smb_open_reader,
    .fill = smb_fill,
    .close_reader = smb_close_reader,
    .open_writer = smb_open_writer,
    .put = smb_put,
    .finish = smb_finish,
    .close_writer = smb_close_writer,
};
