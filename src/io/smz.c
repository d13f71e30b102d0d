/*
 * The .smz codec; docs/smz.md describes every byte. Little-endian
 * throughout, whatever the host.
 */
#include "io/smz.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <zstd.h>
#include <zstd_errors.h>

#include "common/alloc.h"
#include "common/error.h"
#include "common/hash64.h"

const uint8_t en_smz_magic[8] = { 0x89, 'S', 'M', 'Z', '\r', '\n', 0x1a, '\n' };
const uint8_t en_smz_end_magic[8] = { 'S', 'M', 'Z', 'I', 'N', 'D', 'E', 'X' };
static const uint8_t block_tag[4] = { 'S', 'M', 'Z', 'B' };
static const uint8_t index_tag[4] = { 'S', 'M', 'Z', 'I' };

#define AXIS_NONE 255u
#define FLAG_SORTED 1u
#define FLAG_BBOX 2u
/* Three u32 section sizes open every raw payload. */
#define RAW_PREFIX_BYTES 12

/* ---- little-endian helpers ---- */

static void put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void put64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint64_t get64(const uint8_t *p)
{
    return (uint64_t)get32(p) | (uint64_t)get32(p + 4) << 32;
}

static void put_f64(uint8_t *p, double d)
{
    uint64_t u;
    memcpy(&u, &d, sizeof u);
    put64(p, u);
}

static double get_f64(const uint8_t *p)
{
    uint64_t u = get64(p);
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}

uint32_t en_smz_crc32(uint32_t crc, const void *data, size_t n)
{
    /* note: bitwise CRC-32 (IEEE, reflected 0xEDB88320). Only headers, the
     * index and the trailer are summed this way; block payloads rely on
     * zstd's XXH64 content checksum, which is far faster. */
    const uint8_t *p = data;
    crc = ~crc;
    while (n--) {
        crc ^= *p++;
        for (int k = 0; k < 8; k++)
            crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

static void set_why(char *why, size_t n, const char *text)
{
    if (why && n)
        snprintf(why, n, "%s", text);
}

/* ---- header ---- */

void en_smz_header_encode(const en_smz_header *h, uint8_t out[EN_SMZ_HEADER_BYTES])
{
    memset(out, 0, EN_SMZ_HEADER_BYTES);
    memcpy(out, en_smz_magic, 8);
    out[8] = (uint8_t)(h->version ? h->version : EN_SMZ_VERSION);
    out[9] = 0;
    out[10] = h->coord_type == EPSNET_COORD_FLOAT64 ? 1 : 0;
    out[11] = (uint8_t)((h->sorted && h->axis >= 0 ? FLAG_SORTED : 0) | (h->has_bbox ? FLAG_BBOX : 0));
    out[12] = h->axis >= 0 && h->axis < 3 ? (uint8_t)h->axis : (uint8_t)AXIS_NONE;
    put64(out + 16, h->nverts);
    put64(out + 24, h->nfaces);
    for (int k = 0; k < 6; k++)
        put_f64(out + 32 + 8 * k, h->has_bbox ? h->bbox[k] : 0.0);
    put32(out + 92, en_smz_crc32(0, out, 92));
}

int en_smz_header_decode(const uint8_t in[EN_SMZ_HEADER_BYTES], en_smz_header *h, char *why, size_t why_len)
{
    memset(h, 0, sizeof *h);
    if (memcmp(in, en_smz_magic, 8) != 0) {
        set_why(why, why_len, "not an .smz file (bad magic)");
        return -1;
    }
    unsigned version = (unsigned)in[8] | (unsigned)in[9] << 8;
    if (version < 1 || version > EN_SMZ_VERSION) {
        snprintf(why, why_len, "unsupported .smz version %u (this build reads 1 to %u)", version, EN_SMZ_VERSION);
        return 8;
    }
    if (get32(in + 92) != en_smz_crc32(0, in, 92)) {
        set_why(why, why_len, "header checksum mismatch (corrupt header)");
        return 92;
    }
    if (in[10] > 1) {
        snprintf(why, why_len, "coordinate type %u is not 0 (float32) or 1 (float64)", in[10]);
        return 10;
    }
    if (in[11] & ~(FLAG_SORTED | FLAG_BBOX)) {
        snprintf(why, why_len, "unknown header flags 0x%02x", in[11]);
        return 11;
    }
    if (in[12] > 2 && in[12] != AXIS_NONE) {
        snprintf(why, why_len, "stream axis %u is not 0, 1, 2 or 255", in[12]);
        return 12;
    }
    h->version = version;
    h->coord_type = in[10] ? EPSNET_COORD_FLOAT64 : EPSNET_COORD_FLOAT32;
    h->axis = in[12] == AXIS_NONE ? -1 : in[12];
    h->sorted = (in[11] & FLAG_SORTED) && h->axis >= 0;
    h->has_bbox = (in[11] & FLAG_BBOX) != 0;
    h->nverts = get64(in + 16);
    h->nfaces = get64(in + 24);
    for (int k = 0; k < 6; k++)
        h->bbox[k] = get_f64(in + 32 + 8 * k);
    if (h->has_bbox)
        for (int k = 0; k < 3; k++)
            if (!isfinite(h->bbox[k]) || !isfinite(h->bbox[k + 3]) || h->bbox[k] > h->bbox[k + 3]) {
                set_why(why, why_len, "bounding box is not finite or has min > max");
                return 32;
            }
    return 0;
}

/* ---- attribute table (version 2) ---- */

/* The type byte's top bit: a face's value (epsnet_attr.of_face). */
#define SMZ_ATTR_OF_FACE 0x80

size_t en_smz_attr_table_encode(const epsnet_attr_layout *l, uint8_t *out)
{
    size_t n = 8;
    put32(out + 4, l->count);
    for (uint32_t i = 0; i < l->count; i++) {
        size_t len = strlen(l->attr[i].name);
        out[n++] = (uint8_t)(l->attr[i].type | (l->attr[i].of_face ? SMZ_ATTR_OF_FACE : 0));
        out[n++] = (uint8_t)len;
        memcpy(out + n, l->attr[i].name, len);
        n += len;
    }
    put32(out, (uint32_t)(n - 4));
    put32(out + n, en_smz_crc32(0, out + 4, n - 4));
    return n + 4;
}

int en_smz_attr_table_decode(const uint8_t *body, uint32_t body_len, uint32_t crc, epsnet_attr_layout *l,
                             char *why, size_t why_len)
{
    memset(l, 0, sizeof *l);
    if (en_smz_crc32(0, body, body_len) != crc) {
        set_why(why, why_len, "attribute table checksum mismatch");
        return -1;
    }
    if (body_len < 4 || get32(body) > EPSNET_ATTR_MAX) {
        set_why(why, why_len, "attribute table has a bad attribute count");
        return -1;
    }
    uint32_t n = get32(body), at = 4;
    for (uint32_t i = 0; i < n; i++) {
        if (body_len - at < 2 || body[at + 1] == 0 || body[at + 1] >= EPSNET_ATTR_NAME_MAX ||
            body_len - at - 2 < body[at + 1]) {
            snprintf(why, why_len, "attribute %u of the table is cut short or has a bad name length", i + 1);
            return -1;
        }
        char name[EPSNET_ATTR_NAME_MAX];
        memcpy(name, body + at + 2, body[at + 1]);
        name[body[at + 1]] = '\0';
        if (strlen(name) != body[at + 1] ||
            epsnet_attr_layout_add(l, name, (epsnet_attr_type)(body[at] & ~SMZ_ATTR_OF_FACE)) != 0) {
            snprintf(why, why_len, "attribute %u of the table has a bad type (%u) or name", i + 1, body[at]);
            return -1;
        }
        l->attr[i].of_face = (body[at] & SMZ_ATTR_OF_FACE) != 0;
        at += 2u + body[at + 1];
    }
    if (at != body_len) {
        set_why(why, why_len, "attribute table has unused bytes");
        return -1;
    }
    return 0;
}

/* ---- block header ---- */

void en_smz_block_header_encode(const en_smz_block_header *b, uint8_t out[EN_SMZ_BLOCK_HEADER_BYTES])
{
    memcpy(out, block_tag, 4);
    put32(out + 4, b->compressed_bytes);
    put32(out + 8, b->raw_bytes);
    put32(out + 12, b->records);
    put32(out + 16, b->nverts);
    put32(out + 20, b->ntris);
    put32(out + 24, b->nfinal);
    put64(out + 28, b->first_vertex);
    put32(out + 36, en_smz_crc32(0, out, 36));
}

int en_smz_block_header_decode(const uint8_t in[EN_SMZ_BLOCK_HEADER_BYTES], en_smz_block_header *b,
                               char *why, size_t why_len)
{
    if (memcmp(in, block_tag, 4) != 0) {
        set_why(why, why_len, "bad block tag");
        return -1;
    }
    if (get32(in + 36) != en_smz_crc32(0, in, 36)) {
        set_why(why, why_len, "block header checksum mismatch");
        return -1;
    }
    b->compressed_bytes = get32(in + 4);
    b->raw_bytes = get32(in + 8);
    b->records = get32(in + 12);
    b->nverts = get32(in + 16);
    b->ntris = get32(in + 20);
    b->nfinal = get32(in + 24);
    b->first_vertex = get64(in + 28);
    if (b->raw_bytes > EN_SMZ_MAX_RAW_BYTES || b->records > EN_SMZ_MAX_RECORDS ||
        b->compressed_bytes > ZSTD_compressBound(EN_SMZ_MAX_RAW_BYTES)) {
        snprintf(why, why_len, "block sizes over the limits (%u raw bytes, %u records, %u compressed bytes)",
                 b->raw_bytes, b->records, b->compressed_bytes);
        return -1;
    }
    if ((uint64_t)b->nverts + b->ntris + b->nfinal != b->records || b->records == 0) {
        snprintf(why, why_len, "block counts disagree (%u records, %u vertices, %u triangles, %u finalizations)",
                 b->records, b->nverts, b->ntris, b->nfinal);
        return -1;
    }
    /* note: the smallest possible encoding of the announced records must fit
     * in the raw size, so a hostile header cannot make a decoder allocate
     * record arrays out of proportion to the data. */
    if (12 + 12 * (uint64_t)b->nverts + 3 * (uint64_t)b->ntris + b->nfinal + 1 > (uint64_t)b->raw_bytes) {
        snprintf(why, why_len, "block announces %u records, more than its %u raw bytes can hold", b->records,
                 b->raw_bytes);
        return -1;
    }
    return 0;
}

/* ---- index and trailer ---- */

void en_smz_index_entry_encode(const en_smz_index_entry *e, uint8_t out[EN_SMZ_INDEX_ENTRY_BYTES])
{
    put64(out, e->offset);
    put64(out + 8, e->first_vertex);
    put64(out + 16, e->first_triangle);
    put32(out + 24, e->records);
    put32(out + 28, e->compressed_bytes);
    put_f64(out + 32, e->axis_min);
    put_f64(out + 40, e->axis_max);
}

void en_smz_index_entry_decode(const uint8_t in[EN_SMZ_INDEX_ENTRY_BYTES], en_smz_index_entry *e)
{
    e->offset = get64(in);
    e->first_vertex = get64(in + 8);
    e->first_triangle = get64(in + 16);
    e->records = get32(in + 24);
    e->compressed_bytes = get32(in + 28);
    e->axis_min = get_f64(in + 32);
    e->axis_max = get_f64(in + 40);
}

void en_smz_trailer_encode(const en_smz_trailer *t, uint8_t out[EN_SMZ_TRAILER_BYTES])
{
    memset(out, 0, EN_SMZ_TRAILER_BYTES);
    put64(out, t->index_offset);
    put64(out + 8, t->blocks);
    put64(out + 16, t->nverts);
    put64(out + 24, t->nfaces);
    put64(out + 32, t->nfinal);
    for (int k = 0; k < 6; k++)
        put_f64(out + 40 + 8 * k, t->has_bbox ? t->bbox[k] : 0.0);
    out[88] = (uint8_t)((t->sorted && t->axis >= 0 ? FLAG_SORTED : 0) | (t->has_bbox ? FLAG_BBOX : 0));
    out[89] = t->axis >= 0 && t->axis < 3 ? (uint8_t)t->axis : (uint8_t)AXIS_NONE;
    put32(out + 92, t->index_crc);
    put32(out + 96, en_smz_crc32(0, out, 96));
    memcpy(out + 104, en_smz_end_magic, 8);
}

int en_smz_trailer_decode(const uint8_t in[EN_SMZ_TRAILER_BYTES], en_smz_trailer *t, char *why, size_t why_len)
{
    memset(t, 0, sizeof *t);
    if (memcmp(in + 104, en_smz_end_magic, 8) != 0) {
        set_why(why, why_len, "bad trailer magic (the file is truncated or was not finished)");
        return -1;
    }
    if (get32(in + 96) != en_smz_crc32(0, in, 96)) {
        set_why(why, why_len, "trailer checksum mismatch");
        return -1;
    }
    t->index_offset = get64(in);
    t->blocks = get64(in + 8);
    t->nverts = get64(in + 16);
    t->nfaces = get64(in + 24);
    t->nfinal = get64(in + 32);
    for (int k = 0; k < 6; k++)
        t->bbox[k] = get_f64(in + 40 + 8 * k);
    t->has_bbox = (in[88] & FLAG_BBOX) != 0;
    t->axis = in[89] == AXIS_NONE ? -1 : in[89];
    t->sorted = (in[88] & FLAG_SORTED) && t->axis >= 0;
    t->index_crc = get32(in + 92);
    return 0;
}

/* ---- varints ---- */

static size_t put_varint(uint8_t *p, uint64_t v)
{
    size_t n = 0;
    while (v >= 0x80) {
        p[n++] = (uint8_t)(v | 0x80);
        v >>= 7;
    }
    p[n++] = (uint8_t)v;
    return n;
}

/* @return bytes used, or 0 when the varint runs past end or is over-long. */
static inline size_t get_varint(const uint8_t *p, const uint8_t *end, uint64_t *v)
{
    if (p < end && p[0] < 0x80) {
        *v = p[0];
        return 1;
    }
    uint64_t x = 0;
    for (size_t i = 0; i < 10 && p + i < end; i++) {
        uint64_t b = p[i];
        if (i == 9 && b > 1)
            return 0;
        x |= (b & 0x7f) << (7 * i);
        if (!(b & 0x80)) {
            *v = x;
            return i + 1;
        }
    }
    return 0;
}

/* ---- triangle corners ----
 * note: a corner is coded against the stream's newest vertex (every
 * triangle of a sorted stream has it) and a move-to-front list of the
 * RECENT corners used last in the block (fan neighbours share edges), else
 * by its distance back from the newest (docs/smz.md "Triangles"). On a
 * sorted shuffled scan this is a third smaller than plain index deltas. */
#define RECENT 8
#define CODE_EXPLICIT RECENT    /* code = RECENT + distance back, distance >= 1 */

typedef struct recent_list {
    uint64_t v[RECENT];         /* UINT64_MAX = empty */
} recent_list;

static void recent_reset(recent_list *l)
{
    for (int i = 0; i < RECENT; i++)
        l->v[i] = UINT64_MAX;
}

static int recent_find(const recent_list *l, uint64_t v)
{
    for (int i = 0; i < RECENT; i++)
        if (l->v[i] == v)
            return i;
    return -1;
}

/* Move v to the front (from position at, or from beyond the end when -1). */
static void recent_touch(recent_list *l, uint64_t v, int at)
{
    for (int i = at >= 0 ? at : RECENT - 1; i > 0; i--)
        l->v[i] = l->v[i - 1];
    l->v[0] = v;
}

/* note: only a hit moves its entry; the newest vertex and explicit corners
 * are pushed in front without looking for an older copy, so the decoder
 * never searches the list (a search's branch misses cost a third of the
 * decoding time). */
static uint64_t corner_code(recent_list *l, uint64_t v, uint64_t n)
{
    if (v == n - 1) {
        recent_touch(l, v, -1);
        return 0;
    }
    int at = recent_find(l, v);
    recent_touch(l, v, at);
    return at >= 0 ? 1 + (uint64_t)at : CODE_EXPLICIT + (n - 1 - v);
}

/* @return 0, or -1 when the code names no vertex. */
static int corner_decode(recent_list *l, uint64_t code, uint64_t n, uint64_t *v)
{
    int at = -1;
    if (code == 0) {
        if (n == 0)
            return -1;
        *v = n - 1;
    } else if (code <= RECENT) {
        at = (int)code - 1;
        *v = l->v[at];
        if (*v == UINT64_MAX)
            return -1;
    } else {
        uint64_t back = code - CODE_EXPLICIT;
        if (back >= n)
            return -1;
        *v = n - 1 - back;
    }
    recent_touch(l, *v, at);
    return 0;
}

/* ---- block payload ---- */

static int coord_width(epsnet_coord_type ct)
{
    return ct == EPSNET_COORD_FLOAT64 ? 8 : 4;
}

static uint64_t coord_bits(double v, epsnet_coord_type ct)
{
    if (ct == EPSNET_COORD_FLOAT64) {
        uint64_t u;
        memcpy(&u, &v, sizeof u);
        return u;
    }
    float f = (float)v;
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static double bits_coord(uint64_t u, epsnet_coord_type ct)
{
    if (ct == EPSNET_COORD_FLOAT64) {
        double d;
        memcpy(&d, &u, sizeof d);
        return d;
    }
    uint32_t w = (uint32_t)u;
    float f;
    memcpy(&f, &w, sizeof f);
    return f;
}

int en_smz_unpack(void *dctx, const uint8_t *payload, const en_smz_block_header *b, uint8_t *raw,
                  char *why, size_t why_len)
{
    /* note: the frame header descriptor (RFC 8878 §3.1.1.1.1) is the byte
     * after the magic; bit 2 says the frame ends with an XXH64 checksum. */
    if (b->compressed_bytes < 6 || get32(payload) != ZSTD_MAGICNUMBER) {
        set_why(why, why_len, "payload is not a zstd frame");
        return -1;
    }
    if (!(payload[4] & 4)) {
        set_why(why, why_len, "payload has no content checksum");
        return -1;
    }
    unsigned long long content = ZSTD_getFrameContentSize(payload, b->compressed_bytes);
    if (content != b->raw_bytes) {
        set_why(why, why_len, "payload size disagrees with the block header");
        return -1;
    }
    if (ZSTD_findFrameCompressedSize(payload, b->compressed_bytes) != b->compressed_bytes) {
        set_why(why, why_len, "payload is not exactly one zstd frame");
        return -1;
    }
    size_t r = ZSTD_decompressDCtx(dctx, raw, b->raw_bytes, payload, b->compressed_bytes);
    if (ZSTD_isError(r)) {
        if (ZSTD_getErrorCode(r) == ZSTD_error_checksum_wrong)
            set_why(why, why_len, "checksum mismatch");
        else
            snprintf(why, why_len, "corrupt zstd data (%s)", ZSTD_getErrorName(r));
        return -1;
    }
    if (r != b->raw_bytes) {
        set_why(why, why_len, "payload decompresses to the wrong size");
        return -1;
    }
    return 0;
}

/* ---- coordinate prediction (version 2, docs/smz.md "Coordinates") ----
 *
 * note: in a sorted stream the previous vertex is close along the stream
 * axis only; across it consecutive vertices jump about the slab, so the
 * other two coordinates of version 1 hardly compress (docs/smz.md "Why").
 * Version 2 predicts them from the vertex's neighbours in the block, the
 * classic parallelogram rule (Touma & Gotsman; Isenburg & Lindstrom use it
 * for streaming meshes): a vertex's first triangle in the block whose other
 * two corners a, b come before it, and the vertex c across the edge ab in
 * an earlier triangle, give a + b - c. The connectivity is decoded first
 * (it needs no coordinate), so a decoder knows every prediction before it
 * reads a coordinate. */

/* Up to PRED_MAX parallelograms per vertex: averaging the predictions of
 * several of its triangles beats any one of them (Cohen-Or, Cohen & Irony's
 * multi-way prediction). */
#define PRED_MAX 4

typedef struct pred_ref {
    int32_t a, b;               /* first triangle's other corners (block-local), -1 none */
    int32_t n;                  /* parallelograms below */
    int32_t p[PRED_MAX][3];     /* a, b, c of each: predicts a + b - c */
} pred_ref;

/* bytes of room at *p (a scratch array), grown only when too small. */
static void *scratch(void **p, size_t *cap, size_t bytes)
{
    return en_grow(p, cap, bytes, 1) ? NULL : *p;
}

void en_smz_scratch_free(en_smz_scratch *sc)
{
    en_free(sc->vrec);
    en_free(sc->tri);
    en_free(sc->pos);
    en_free(sc->ref);
    en_free(sc->head);
    en_free(sc->edge);
    en_free(sc->raw);
    memset(sc, 0, sizeof *sc);
}

typedef struct pred_edge {
    int32_t next, nb, opp;
} pred_edge;

/* Room in sc for predicting a block of nverts vertices and ntris
 * triangles: positions, refs, and predict_refs' edge lists. */
static int reserve_predict(en_smz_scratch *sc, uint32_t nverts, size_t ntris)
{
    size_t nv = (size_t)nverts + 1;
    return !scratch(&sc->pos, &sc->pos_cap, 3 * nv * sizeof(double)) ||
           !scratch(&sc->ref, &sc->ref_cap, nv * sizeof(pred_ref)) ||
           !scratch(&sc->head, &sc->head_cap, nv * sizeof(int32_t)) ||
           !scratch(&sc->edge, &sc->edge_cap, (3 * ntris + 1) * sizeof(pred_edge));
}

/* refs of the block's nverts vertices from its triangles (global corners,
 * in stream order). @return 0 or -1 out of memory.
 * note: the edge table of docs/smz.md is kept as a list of edges per
 * vertex (each edge under its smaller end, newest first): the first match
 * is the edge's latest third corner, as a table that replaces would give,
 * and a sorted stream's lists are short and recently touched, which makes
 * this several times faster than hashing every edge. */
static int predict_refs(const uint64_t *tri, size_t ntris, uint64_t first, uint32_t nverts, pred_ref *ref,
                        en_smz_scratch *sc)
{
    for (uint32_t v = 0; v < nverts; v++) {
        ref[v].a = ref[v].b = -1;
        ref[v].n = 0;
    }
    if (reserve_predict(sc, nverts, ntris))
        return -1;
    int32_t *head = sc->head;
    pred_edge *edge = sc->edge;
    for (uint32_t v = 0; v < nverts; v++)
        head[v] = -1;
    int32_t nedge = 0;
    for (size_t t = 0; t < ntris; t++) {
        int32_t l[3];
        int inside = 1;
        for (int k = 0; k < 3; k++) {
            uint64_t g = tri[3 * t + (size_t)k];
            l[k] = g >= first && g - first < nverts ? (int32_t)(g - first) : -1;
            inside &= l[k] >= 0;
        }
        if (!inside || l[0] == l[1] || l[1] == l[2] || l[0] == l[2])
            continue;
        int m = l[0] > l[1] ? (l[0] > l[2] ? 0 : 2) : (l[1] > l[2] ? 1 : 2);
        int32_t v = l[m], a = l[(m + 1) % 3], b = l[(m + 2) % 3];
        pred_ref *r = &ref[v];
        if (r->a < 0) {
            r->a = a;
            r->b = b;
        }
        if (r->n < PRED_MAX) {
            int32_t lo = a < b ? a : b, hi = a < b ? b : a;
            for (int32_t e = head[lo]; e >= 0; e = edge[e].next)
                if (edge[e].nb == hi) {
                    if (edge[e].opp < v) {
                        r->p[r->n][0] = a;
                        r->p[r->n][1] = b;
                        r->p[r->n][2] = edge[e].opp;
                        r->n++;
                    }
                    break;
                }
        }
        for (int k = 0; k < 3; k++) {
            int32_t p = l[k], q = l[(k + 1) % 3];
            int32_t lo = p < q ? p : q;
            edge[nedge] = (pred_edge){ head[lo], p < q ? q : p, l[(k + 2) % 3] };
            head[lo] = nedge++;
        }
    }
    return 0;
}

/* Coordinate bits (width w bytes) to an integer in the order of the values,
 * and back: -0 and +0 stay apart, so the map is one to one. */
static uint64_t ord_bits(uint64_t u, int w)
{
    uint64_t sign = (uint64_t)1 << (8 * w - 1), mask = w == 8 ? UINT64_MAX : (sign << 1) - 1;
    return (u & sign) ? ~(u & ~sign) & mask : u;
}

static uint64_t unord_bits(uint64_t m, int w)
{
    uint64_t sign = (uint64_t)1 << (8 * w - 1), mask = w == 8 ? UINT64_MAX : (sign << 1) - 1;
    return (m & sign) ? (~m & mask) | sign : m;
}

/* The predicted value of coordinate k of local vertex v from the values
 * already known (pos: 3 per local vertex). axis: the stream axis, whose
 * coordinate the previous vertex predicts (it is close along it). */
static double predict_coord(const double *pos, const pred_ref *ref, uint32_t v, int k, int axis)
{
    const pred_ref *r = &ref[v];
    if (k != axis && r->n > 0) {
        double sum = 0;
        for (int i = 0; i < r->n; i++)
            sum += pos[3 * (size_t)r->p[i][0] + (size_t)k] + pos[3 * (size_t)r->p[i][1] + (size_t)k] -
                   pos[3 * (size_t)r->p[i][2] + (size_t)k];
        return sum / r->n;
    }
    if (k != axis && r->a >= 0)
        return (pos[3 * (size_t)r->a + (size_t)k] + pos[3 * (size_t)r->b + (size_t)k]) * 0.5;
    return v ? pos[3 * (size_t)(v - 1) + (size_t)k] : 0.0;
}

/* Residual of bits against the prediction, zigzagged so that small
 * differences of either sign have zero high bytes; and back. */
static uint64_t residual(uint64_t bits, uint64_t pred, int w)
{
    uint64_t mask = w == 8 ? UINT64_MAX : ((uint64_t)1 << (8 * w)) - 1;
    uint64_t r = (ord_bits(bits, w) - ord_bits(pred, w)) & mask;
    uint64_t neg = (r >> (8 * w - 1)) & 1;
    return ((r << 1) ^ (neg ? mask : 0)) & mask;
}

static uint64_t unresidual(uint64_t z, uint64_t pred, int w)
{
    uint64_t mask = w == 8 ? UINT64_MAX : ((uint64_t)1 << (8 * w)) - 1;
    uint64_t r = ((z >> 1) ^ ((z & 1) ? mask : 0)) & mask;
    return unord_bits((ord_bits(pred, w) + r) & mask, w);
}

/* Version 2 attributes: each value is predicted by the same attribute of
 * the vertex's first neighbour in the block (ref a), else of the previous
 * vertex; float values are compared in value order (ord_bits), integers as
 * they are. */
static int64_t attr_ref(const pred_ref *ref, uint32_t v)
{
    return ref[v].a >= 0 ? ref[v].a : (int64_t)v - 1;
}

static uint64_t attr_residual(uint64_t cur, uint64_t pred, size_t w, int is_float)
{
    uint64_t mask = w == 8 ? UINT64_MAX : ((uint64_t)1 << (8 * w)) - 1;
    uint64_t r = is_float ? (ord_bits(cur, (int)w) - ord_bits(pred, (int)w)) & mask : (cur - pred) & mask;
    uint64_t neg = (r >> (8 * w - 1)) & 1;
    return ((r << 1) ^ (neg ? mask : 0)) & mask;
}

static uint64_t attr_unresidual(uint64_t z, uint64_t pred, size_t w, int is_float)
{
    uint64_t mask = w == 8 ? UINT64_MAX : ((uint64_t)1 << (8 * w)) - 1;
    uint64_t r = ((z >> 1) ^ ((z & 1) ? mask : 0)) & mask;
    return is_float ? unord_bits((ord_bits(pred, (int)w) + r) & mask, (int)w) : (pred + r) & mask;
}

static int attr_is_float(epsnet_attr_type t)
{
    return t == EPSNET_ATTR_FLOAT32 || t == EPSNET_ATTR_FLOAT64;
}

/* Section layout of a raw payload, checked against the block header. */
typedef struct raw_sections {
    const uint8_t *kinds, *coords, *attrs, *tris, *fins, *end;
} raw_sections;

static int split_sections(const uint8_t *raw, const en_smz_block_header *b, int width, uint32_t asz,
                          raw_sections *s, char *why, size_t why_len)
{
    if (b->raw_bytes < RAW_PREFIX_BYTES) {
        set_why(why, why_len, "payload too short");
        return -1;
    }
    uint64_t kb = get32(raw), tb = get32(raw + 4), fb = get32(raw + 8);
    uint64_t cb = (uint64_t)b->nverts * 3 * (uint64_t)width;
    uint64_t ab = (uint64_t)b->nverts * asz;
    if (RAW_PREFIX_BYTES + kb + cb + ab + tb + fb != b->raw_bytes) {
        set_why(why, why_len, "payload section sizes do not add up");
        return -1;
    }
    s->kinds = raw + RAW_PREFIX_BYTES;
    s->coords = s->kinds + kb;
    s->attrs = s->coords + cb;
    s->tris = s->attrs + ab;
    s->fins = s->tris + tb;
    s->end = s->fins + fb;
    return 0;
}

/* An attribute value's bits as an unsigned integer of its width, from (and
 * to) the host-order bytes records carry (docs/smz.md "Attributes"). */
static uint64_t attr_load(const uint8_t *p, size_t w)
{
    switch (w) {
    case 1: return p[0];
    case 2: { uint16_t v; memcpy(&v, p, 2); return v; }
    case 4: { uint32_t v; memcpy(&v, p, 4); return v; }
    default: { uint64_t v; memcpy(&v, p, 8); return v; }
    }
}

static void attr_store(uint8_t *p, size_t w, uint64_t u)
{
    switch (w) {
    case 1: p[0] = (uint8_t)u; break;
    case 2: { uint16_t v = (uint16_t)u; memcpy(p, &v, 2); break; }
    case 4: { uint32_t v = (uint32_t)u; memcpy(p, &v, 4); break; }
    default: memcpy(p, &u, 8); break;
    }
}

/* The attribute section into attr_out (nverts * l->size bytes): per
 * attribute, the byte planes of the differences of its values. */
static void decode_attrs(const uint8_t *sec, uint32_t nverts, const epsnet_attr_layout *l, const pred_ref *ref,
                         uint8_t *attr_out)
{
    const uint8_t *p = sec;
    for (uint32_t a = 0; a < l->count; a++) {
        size_t w = epsnet_attr_type_size(l->attr[a].type), off = l->attr[a].offset;
        int fl = attr_is_float(l->attr[a].type);
        for (uint32_t i = 0; i < nverts; i++) {
            uint64_t z = 0;
            for (size_t j = 0; j < w; j++)
                z |= (uint64_t)p[j * nverts + i] << (8 * j);
            int64_t q = attr_ref(ref, i);
            uint64_t pred = q >= 0 ? attr_load(attr_out + (size_t)q * l->size + off, w) : 0;
            attr_store(attr_out + (size_t)i * l->size + off, w, attr_unresidual(z, pred, w, fl));
        }
        p += w * nverts;
    }
}

static int decode_block(const uint8_t *raw, const en_smz_block_header *b, epsnet_coord_type ct, int version,
                        int axis, const epsnet_attr_layout *l, uint8_t *attr_out, en_smz_scratch *sc,
                        epsnet_record *out, char *why, size_t why_len);

/* Room in sc for decoding block b as version 2 (a version 1 block needs
 * none): its vertices' records, its corners, and the predictions. */
static int reserve_decode(en_smz_scratch *sc, const en_smz_block_header *b)
{
    return !scratch(&sc->vrec, &sc->vrec_cap, ((size_t)b->nverts + 1) * sizeof(uint32_t)) ||
           !scratch(&sc->tri, &sc->tri_cap, ((size_t)b->ntris * 3 + 1) * sizeof(uint64_t)) ||
           reserve_predict(sc, b->nverts, b->ntris);
}

int en_smz_scratch_reserve(en_smz_scratch *sc, const en_smz_block_header *b, const en_smz_header *h)
{
    return h->version >= 2 && reserve_decode(sc, b) ? -1 : 0;
}

size_t en_smz_scratch_bytes(const en_smz_scratch *sc)
{
    return sc->vrec_cap + sc->tri_cap + sc->pos_cap + sc->ref_cap + sc->head_cap + sc->edge_cap + sc->raw_cap;
}

int en_smz_decode_block(const uint8_t *raw, const en_smz_block_header *b, epsnet_coord_type ct,
                        epsnet_record *out, char *why, size_t why_len)
{
    en_smz_scratch sc = { 0 };
    int rc = decode_block(raw, b, ct, 1, -1, NULL, NULL, &sc, out, why, why_len);
    en_smz_scratch_free(&sc);
    return rc;
}

int en_smz_decode_block_h(const uint8_t *raw, const en_smz_block_header *b, const en_smz_header *h,
                          uint8_t *attr_out, en_smz_scratch *sc, epsnet_record *out, char *why, size_t why_len)
{
    return decode_block(raw, b, h->coord_type, (int)h->version, h->axis, &h->attrs, attr_out, sc, out, why,
                        why_len);
}

/* Version 2: the coordinates of the block's vertices from their residuals
 * against the predictions (the triangles are decoded by now). */
static int decode_predicted(const raw_sections *s, const en_smz_block_header *b, epsnet_coord_type ct, int axis,
                            const epsnet_attr_layout *l, uint8_t *attr_out, const uint32_t *vrec,
                            const uint64_t *tri, en_smz_scratch *sc, epsnet_record *out, char *why,
                            size_t why_len)
{
    int w = coord_width(ct);
    uint32_t nv = b->nverts;
    if (reserve_predict(sc, nv, b->ntris)) {
        set_why(why, why_len, "out of memory");
        return -1;
    }
    double *pos = sc->pos;
    pred_ref *ref = sc->ref;
    if (predict_refs(tri, b->ntris, b->first_vertex, nv, ref, sc)) {
        set_why(why, why_len, "out of memory");
        return -1;
    }
    for (uint32_t v = 0; v < nv; v++)
        for (int k = 0; k < 3; k++) {
            const uint8_t *pl = s->coords + (size_t)k * (size_t)w * nv;
            uint64_t z = 0;
            for (int j = 0; j < w; j++)
                z |= (uint64_t)pl[(size_t)j * nv + v] << (8 * j);
            uint64_t pred = coord_bits(predict_coord(pos, ref, v, k, axis), ct);
            pos[3 * (size_t)v + (size_t)k] = bits_coord(unresidual(z, pred, w), ct);
        }
    for (uint32_t v = 0; v < nv; v++)
        memcpy(out[vrec[v]].xyz, pos + 3 * (size_t)v, sizeof out->xyz);
    if (l && l->size)
        decode_attrs(s->attrs, nv, l, ref, attr_out);
    return 0;
}

static int decode_block(const uint8_t *raw, const en_smz_block_header *b, epsnet_coord_type ct, int version,
                        int axis, const epsnet_attr_layout *l, uint8_t *attr_out, en_smz_scratch *sc,
                        epsnet_record *out, char *why, size_t why_len)
{
    int width = coord_width(ct);
    uint32_t asz = l ? l->size : 0;
    int predicted = version >= 2;
    if (predicted && reserve_decode(sc, b)) {
        set_why(why, why_len, "out of memory");
        return -1;
    }
    uint32_t *vrec = predicted ? sc->vrec : NULL;
    uint64_t *tri = predicted ? sc->tri : NULL;
    int rc = -1;
    raw_sections s;
    if (split_sections(raw, b, width, asz, &s, why, why_len))
        goto done;
    const uint8_t *kp = s.kinds, *tp = s.tris, *fp = s.fins;
    const uint8_t *plane[3][8];
    for (int k = 0; k < 3; k++)
        for (int j = 0; j < width; j++)
            plane[k][j] = s.coords + ((size_t)k * (size_t)width + (size_t)j) * b->nverts;
    uint64_t prev[3] = { 0, 0, 0 };
    uint64_t nv = b->first_vertex, vi = 0, nt = 0, nf = 0;
    recent_list recent;
    recent_reset(&recent);
    uint32_t rec = 0;
    while (rec < b->records) {
        uint64_t run;
        size_t used = get_varint(kp, s.coords, &run);
        if (!used || (run & 3) == 0) {
            set_why(why, why_len, "bad record-kind run");
            goto done;
        }
        kp += used;
        int kind = (int)(run & 3);
        uint64_t len = (run >> 2) + 1;
        if (len > b->records - rec) {
            set_why(why, why_len, "record-kind runs exceed the record count");
            goto done;
        }
        for (uint64_t i = 0; i < len; i++, rec++) {
            epsnet_record *r = out + rec;
            r->kind = (epsnet_record_kind)kind;
            r->attr = NULL;
            if (kind == EPSNET_REC_VERTEX) {
                if (vi == b->nverts)
                    goto counts;
                if (predicted)
                    vrec[vi] = rec;
                for (int k = 0; k < 3 && !predicted; k++) {
                    const uint8_t *const *pl = plane[k];
                    uint64_t d = (uint64_t)pl[0][vi] | (uint64_t)pl[1][vi] << 8 | (uint64_t)pl[2][vi] << 16 |
                                 (uint64_t)pl[3][vi] << 24;
                    if (width == 8)
                        d |= (uint64_t)pl[4][vi] << 32 | (uint64_t)pl[5][vi] << 40 | (uint64_t)pl[6][vi] << 48 |
                             (uint64_t)pl[7][vi] << 56;
                    prev[k] += d;
                    if (width == 4)
                        prev[k] &= 0xffffffffu;
                    r->xyz[k] = bits_coord(prev[k], ct);
                }
                r->attr = asz ? attr_out + vi * asz : NULL;
                vi++;
                nv++;
            } else if (kind == EPSNET_REC_TRIANGLE) {
                if (nt == b->ntris)
                    goto counts;
                for (int k = 0; k < 3; k++) {
                    uint64_t code;
                    size_t u = get_varint(tp, s.fins, &code);
                    if (!u) {
                        set_why(why, why_len, "triangle section ends early");
                        goto done;
                    }
                    tp += u;
                    if (corner_decode(&recent, code, nv, &r->v[k])) {
                        set_why(why, why_len, "a triangle references a vertex that does not exist yet");
                        goto done;
                    }
                    if (predicted)
                        tri[3 * nt + (uint64_t)k] = r->v[k];
                }
                nt++;
            } else {
                uint64_t d;
                size_t u = get_varint(fp, s.end, &d);
                if (!u || nf == b->nfinal) {
                    set_why(why, why_len, "finalization section ends early");
                    goto done;
                }
                fp += u;
                if (d >= nv) {
                    set_why(why, why_len, "a finalization names a vertex that does not exist yet");
                    goto done;
                }
                r->v[0] = nv - 1 - d;
                r->v[1] = r->v[2] = 0;
                nf++;
            }
        }
    }
    if (vi != b->nverts || nt != b->ntris || nf != b->nfinal)
        goto counts;
    if (kp != s.coords || tp != s.fins || fp != s.end) {
        set_why(why, why_len, "payload has unused bytes");
        goto done;
    }
    rc = predicted ? decode_predicted(&s, b, ct, axis, l, attr_out, vrec, tri, sc, out, why, why_len) : 0;
    goto done;
counts:
    set_why(why, why_len, "record kinds disagree with the block's counts");
done:
    return rc;
}

/* ---- encoder ---- */

typedef struct byte_buf {
    uint8_t *p;
    size_t len, cap;
} byte_buf;

static int buf_reserve(byte_buf *b, size_t more)
{
    return en_grow((void **)&b->p, &b->cap, b->len + more, 1);
}

struct en_smz_encoder {
    epsnet_coord_type ct;
    int version;             /* 2: predicted coordinates (and attributes) */
    int axis;                /* stream axis, -1 none */
    uint64_t first_vertex;   /* of the block: vertices before its first record */
    uint64_t *tri;           /* the block's triangles, 3 global corners each */
    size_t tri_cap;          /* in triangles */
    epsnet_attr_layout attrs;
    uint8_t *abytes;         /* attrs.size per vertex, bits_cap vertices */
    byte_buf kinds, tris, fins;
    uint64_t *bits;          /* 3 per vertex */
    size_t bits_cap;         /* in vertices */
    uint32_t nverts, ntris, nfinal;
    int run_kind;
    uint64_t run_len;
    recent_list recent;         /* of this block's triangles */
    en_smz_scratch sc;          /* flush's working arrays, kept from block to block */
};

en_smz_encoder *en_smz_encoder_new(epsnet_coord_type ct)
{
    return en_smz_encoder_new_v2(ct, NULL, -1);
}

en_smz_encoder *en_smz_encoder_new_v2(epsnet_coord_type ct, const epsnet_attr_layout *l, int axis)
{
    en_smz_encoder *e = en_calloc(1, sizeof *e);
    if (e) {
        e->ct = ct;
        e->version = 2;
        e->axis = axis >= 0 && axis < 3 ? axis : -1;
        if (l)
            e->attrs = *l;
        recent_reset(&e->recent);
    }
    return e;
}

void en_smz_encoder_free(en_smz_encoder **pe)
{
    en_smz_encoder *e = pe ? *pe : NULL;
    if (!e)
        return;
    en_free(e->kinds.p);
    en_free(e->tris.p);
    en_free(e->fins.p);
    en_free(e->bits);
    en_free(e->abytes);
    en_free(e->tri);
    en_smz_scratch_free(&e->sc);
    en_free(e);
    *pe = NULL;
}

static int close_run(en_smz_encoder *e)
{
    if (!e->run_len)
        return 0;
    if (buf_reserve(&e->kinds, 10))
        return -1;
    e->kinds.len += put_varint(e->kinds.p + e->kinds.len, (e->run_len - 1) << 2 | (uint64_t)e->run_kind);
    e->run_len = 0;
    return 0;
}

int en_smz_encoder_add(en_smz_encoder *e, const epsnet_record *rec, uint64_t nverts_before)
{
    int kind = (int)rec->kind;
    if (en_smz_encoder_records(e) == 0)
        e->first_vertex = nverts_before;
    if (kind != e->run_kind && close_run(e))
        return -1;
    if (kind == EPSNET_REC_VERTEX) {
        size_t cap = e->bits_cap;
        if (e->nverts == cap) {
            void *p = e->bits;
            if (en_grow(&p, &cap, (size_t)e->nverts + 1, 3 * sizeof *e->bits))
                return -1;
            e->bits = p;
            if (e->attrs.size) {
                uint8_t *a = en_realloc(e->abytes, cap * e->attrs.size);
                if (!a)
                    return -1;
                e->abytes = a;
            }
            e->bits_cap = cap;
        }
        if (e->attrs.size)
            memcpy(e->abytes + (size_t)e->nverts * e->attrs.size, rec->attr, e->attrs.size);
        for (int k = 0; k < 3; k++)
            e->bits[3 * (size_t)e->nverts + (size_t)k] = coord_bits(rec->xyz[k], e->ct);
        e->nverts++;
    } else if (kind == EPSNET_REC_TRIANGLE) {
        if (buf_reserve(&e->tris, 30))
            return -1;
        uint8_t *p = e->tris.p + e->tris.len;
        size_t n = 0;
        for (int k = 0; k < 3; k++)
            n += put_varint(p + n, corner_code(&e->recent, rec->v[k], nverts_before));
        e->tris.len += n;
        if (e->ntris == e->tri_cap && en_grow((void **)&e->tri, &e->tri_cap, (size_t)e->ntris + 1, 3 * sizeof *e->tri))
            return -1;
        memcpy(e->tri + 3 * (size_t)e->ntris, rec->v, 3 * sizeof *e->tri);
        e->ntris++;
    } else {
        if (buf_reserve(&e->fins, 10))
            return -1;
        e->fins.len += put_varint(e->fins.p + e->fins.len, nverts_before - 1 - rec->v[0]);
        e->nfinal++;
    }
    e->run_kind = kind;
    e->run_len++;
    return 0;
}

uint32_t en_smz_encoder_records(const en_smz_encoder *e)
{
    return e->nverts + e->ntris + e->nfinal;
}

size_t en_smz_encoder_raw_bytes(const en_smz_encoder *e)
{
    return RAW_PREFIX_BYTES + e->kinds.len + 10 +
           (size_t)e->nverts * (3 * (size_t)coord_width(e->ct) + e->attrs.size) + e->tris.len + e->fins.len;
}

int en_smz_encoder_flush(en_smz_encoder *e, void *cctx, uint8_t **out, size_t *out_cap,
                         en_smz_block_header *b)
{
    if (close_run(e))
        return -1;
    int width = coord_width(e->ct);
    size_t cb = (size_t)e->nverts * 3 * (size_t)width;
    size_t ab = (size_t)e->nverts * e->attrs.size;
    size_t raw_len = RAW_PREFIX_BYTES + e->kinds.len + cb + ab + e->tris.len + e->fins.len;
    uint8_t *raw = scratch(&e->sc.raw, &e->sc.raw_cap, raw_len);
    if (!raw)
        return -1;
    put32(raw, (uint32_t)e->kinds.len);
    put32(raw + 4, (uint32_t)e->tris.len);
    put32(raw + 8, (uint32_t)e->fins.len);
    uint8_t *p = raw + RAW_PREFIX_BYTES;
    if (e->kinds.len)
        memcpy(p, e->kinds.p, e->kinds.len);
    p += e->kinds.len;
    /* note: coordinates become per-axis differences of their bit patterns,
     * split into byte planes: along the stream axis the differences are
     * small, so their high planes are nearly all zero and zstd packs them
     * to almost nothing (docs/smz.md "Coordinates"). */
    pred_ref *ref = NULL;
    if (e->version >= 2) {
        /* version 2: residuals against the predictions (predict_coord) */
        if (reserve_predict(&e->sc, e->nverts, e->ntris))
            return -1;
        double *pos = e->sc.pos;
        ref = e->sc.ref;
        if (predict_refs(e->tri, e->ntris, e->first_vertex, e->nverts, ref, &e->sc))
            return -1;
        for (size_t i = 0; i < (size_t)e->nverts * 3; i++)
            pos[i] = bits_coord(e->bits[i], e->ct);
        for (uint32_t i = 0; i < e->nverts; i++)
            for (int k = 0; k < 3; k++) {
                uint64_t pred = coord_bits(predict_coord(pos, ref, i, k, e->axis), e->ct);
                uint64_t z = residual(e->bits[3 * (size_t)i + (size_t)k], pred, width);
                for (int j = 0; j < width; j++)
                    p[((size_t)k * (size_t)width + (size_t)j) * e->nverts + i] = (uint8_t)(z >> (8 * j));
            }
    } else {
        for (int k = 0; k < 3; k++) {
            uint64_t prev = 0;
            for (uint32_t i = 0; i < e->nverts; i++) {
                uint64_t cur = e->bits[3 * (size_t)i + (size_t)k];
                uint64_t d = cur - prev;
                prev = cur;
                for (int j = 0; j < width; j++)
                    p[((size_t)k * (size_t)width + (size_t)j) * e->nverts + i] = (uint8_t)(d >> (8 * j));
            }
        }
    }
    p += cb;
    /* note: attributes one at a time, each value against the same
     * attribute of a neighbour (attr_ref): neighbours on the surface tend
     * to share colours, normals and confidence, so most residuals are
     * small (docs/smz.md "Attributes"). Attributes exist in version 2
     * only, so ref is set whenever there are some. */
    for (uint32_t a = 0; a < e->attrs.count && ref; a++) {
        size_t w = epsnet_attr_type_size(e->attrs.attr[a].type), off = e->attrs.attr[a].offset;
        int fl = attr_is_float(e->attrs.attr[a].type);
        for (uint32_t i = 0; i < e->nverts; i++) {
            uint64_t cur = attr_load(e->abytes + (size_t)i * e->attrs.size + off, w);
            int64_t q = attr_ref(ref, i);
            uint64_t pred = q >= 0 ? attr_load(e->abytes + (size_t)q * e->attrs.size + off, w) : 0;
            uint64_t z = attr_residual(cur, pred, w, fl);
            for (size_t j = 0; j < w; j++)
                p[j * e->nverts + i] = (uint8_t)(z >> (8 * j));
        }
        p += w * e->nverts;
    }
    if (e->tris.len)
        memcpy(p, e->tris.p, e->tris.len);
    p += e->tris.len;
    if (e->fins.len)
        memcpy(p, e->fins.p, e->fins.len);
    size_t bound = ZSTD_compressBound(raw_len);
    if (bound > *out_cap) {
        uint8_t *n = en_realloc(*out, bound);
        if (!n)
            return -1;
        *out = n;
        *out_cap = bound;
    }
    size_t z = ZSTD_compress2(cctx, *out, *out_cap, raw, raw_len);
    if (ZSTD_isError(z))
        return -1;
    b->compressed_bytes = (uint32_t)z;
    b->raw_bytes = (uint32_t)raw_len;
    b->records = en_smz_encoder_records(e);
    b->nverts = e->nverts;
    b->ntris = e->ntris;
    b->nfinal = e->nfinal;
    e->kinds.len = e->tris.len = e->fins.len = 0;
    e->nverts = e->ntris = e->nfinal = 0;
    e->run_kind = 0;
    e->run_len = 0;
    recent_reset(&e->recent);
    return 0;
}

/* ---- random access ---- */

static int pread_all(int fd, void *buf, size_t n, uint64_t off)
{
    uint8_t *p = buf;
    while (n) {
        ssize_t k = pread(fd, p, n, (off_t)off);
        if (k < 0 && errno == EINTR)
            continue;
        if (k <= 0)
            return -1;
        p += k;
        n -= (size_t)k;
        off += (uint64_t)k;
    }
    return 0;
}

int en_smz_read_index(int fd, const char *path, uint64_t file_size, en_smz_index *idx, epsnet_error *err)
{
    memset(idx, 0, sizeof *idx);
    uint8_t hb[EN_SMZ_HEADER_BYTES], tb[EN_SMZ_TRAILER_BYTES];
    char why[200];
    if (file_size < EN_SMZ_HEADER_BYTES + EN_SMZ_INDEX_HEAD_BYTES + EN_SMZ_TRAILER_BYTES)
        return en_error_set(err, EPSNET_EFORMAT, path, EPSNET_POS_NONE, file_size,
                            "truncated file: too short for an .smz header, index and trailer");
    if (pread_all(fd, hb, sizeof hb, 0) || pread_all(fd, tb, sizeof tb, file_size - sizeof tb))
        return en_error_set(err, EPSNET_EIO, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "read failed: %s",
                            strerror(errno));
    int bad = en_smz_header_decode(hb, &idx->header, why, sizeof why);
    if (bad)
        return en_error_set(err, EPSNET_EFORMAT, path, EPSNET_POS_NONE, bad < 0 ? 0 : (uint64_t)bad, "%s", why);
    uint64_t toff = file_size - sizeof tb;
    if (en_smz_trailer_decode(tb, &idx->trailer, why, sizeof why))
        return en_error_set(err, EPSNET_EFORMAT, path, EPSNET_POS_NONE, toff, "%s", why);
    const en_smz_trailer *t = &idx->trailer;
    if (t->index_offset < EN_SMZ_HEADER_BYTES || t->index_offset > toff ||
        t->blocks > (toff - t->index_offset) / EN_SMZ_INDEX_ENTRY_BYTES ||
        t->index_offset + EN_SMZ_INDEX_HEAD_BYTES + t->blocks * EN_SMZ_INDEX_ENTRY_BYTES != toff)
        return en_error_set(err, EPSNET_EFORMAT, path, EPSNET_POS_NONE, toff,
                            "trailer's index position and block count do not fit the file");
    size_t n = (size_t)(toff - t->index_offset);
    uint8_t *ib = en_malloc(n);
    idx->entries = en_calloc(t->blocks ? (size_t)t->blocks : 1, sizeof *idx->entries);
    if (!ib || !idx->entries) {
        en_free(ib);
        en_smz_index_free(idx);
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    int rc = 0;
    if (pread_all(fd, ib, n, t->index_offset))
        rc = en_error_set(err, EPSNET_EIO, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "read failed");
    else if (memcmp(ib, index_tag, 4) != 0 || en_smz_crc32(0, ib, n) != t->index_crc)
        rc = en_error_set(err, EPSNET_EFORMAT, path, EPSNET_POS_NONE, t->index_offset,
                          "index is corrupt (bad tag or checksum)");
    uint64_t expect = EN_SMZ_HEADER_BYTES;
    if (rc == 0 && idx->header.version >= 2) {
        /* the attribute table sits between the header and block 0 */
        uint8_t tab[EN_SMZ_MAX_TABLE_BYTES];
        uint32_t body = 0;
        if (pread_all(fd, tab, 4, EN_SMZ_HEADER_BYTES) || (body = get32(tab)) > EN_SMZ_MAX_TABLE_BYTES - 8 ||
            EN_SMZ_HEADER_BYTES + 8 + (uint64_t)body > t->index_offset ||
            pread_all(fd, tab + 4, body + 4, EN_SMZ_HEADER_BYTES + 4))
            rc = en_error_set(err, EPSNET_EFORMAT, path, EPSNET_POS_NONE, EN_SMZ_HEADER_BYTES,
                              "attribute table is cut short or too long");
        else if (en_smz_attr_table_decode(tab + 4, body, get32(tab + 4 + body), &idx->header.attrs, why,
                                          sizeof why))
            rc = en_error_set(err, EPSNET_EFORMAT, path, EPSNET_POS_NONE, EN_SMZ_HEADER_BYTES, "%s", why);
        expect += 8 + (uint64_t)body;
    }
    for (uint64_t i = 0; rc == 0 && i < t->blocks; i++) {
        en_smz_index_entry *e = &idx->entries[i];
        en_smz_index_entry_decode(ib + EN_SMZ_INDEX_HEAD_BYTES + i * EN_SMZ_INDEX_ENTRY_BYTES, e);
        if (e->offset != expect)
            rc = en_error_set(err, EPSNET_EFORMAT, path, EPSNET_POS_NONE, t->index_offset,
                              "index entry %llu points at byte %llu, expected %llu", (unsigned long long)i,
                              (unsigned long long)e->offset, (unsigned long long)expect);
        expect = e->offset + EN_SMZ_BLOCK_HEADER_BYTES + e->compressed_bytes;
    }
    if (rc == 0 && expect != t->index_offset)
        rc = en_error_set(err, EPSNET_EFORMAT, path, EPSNET_POS_NONE, t->index_offset,
                          "index does not cover the blocks");
    en_free(ib);
    if (rc)
        en_smz_index_free(idx);
    return rc;
}

void en_smz_index_free(en_smz_index *idx)
{
    en_free(idx->entries);
    idx->entries = NULL;
}

int en_smz_block_room(const en_smz_header *h, const en_smz_block_header *b, uint8_t **payload, size_t *payload_cap,
                      uint8_t **raw, size_t *raw_cap, epsnet_record **recs, size_t *recs_cap, uint8_t **attrs,
                      size_t *attrs_cap)
{
    if (en_grow((void **)payload, payload_cap, b->compressed_bytes, 1) ||
        en_grow((void **)raw, raw_cap, b->raw_bytes, 1) || en_grow((void **)recs, recs_cap, b->records, sizeof **recs))
        return -1;
    return h->attrs.size && en_grow((void **)attrs, attrs_cap, (size_t)b->nverts * h->attrs.size, 1) ? -1 : 0;
}
