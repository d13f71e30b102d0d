/*
 * The .smz codec (docs/smz.md is the format description): fixed-size
 * header, block header, index entry and trailer, and the block payload
 * encoder/decoder. The format driver (fmt_smz.c) reads blocks in order
 * and, given a pool, decodes them on its workers;
 * anything that wants to decode blocks in parallel or seek to a slab uses
 * en_smz_read_index() and en_smz_decode_block() directly, one block per
 * thread (every function here is reentrant; no state outside its arguments).
 */
#ifndef EN_IO_SMZ_H
#define EN_IO_SMZ_H

#include <stddef.h>
#include <stdint.h>

#include "epsnet/epsnet.h"

#define EN_SMZ_HEADER_BYTES 96
#define EN_SMZ_BLOCK_HEADER_BYTES 40
#define EN_SMZ_INDEX_HEAD_BYTES 8
#define EN_SMZ_INDEX_ENTRY_BYTES 48
#define EN_SMZ_TRAILER_BYTES 112
/* Version 1: positions only. Version 2 adds the attribute table after the
 * header, an attribute section to every block and coordinates predicted
 * from decoded neighbours (docs/smz.md); the writer always writes version
 * 2, the reader reads both. */
#define EN_SMZ_VERSION 2
/* Largest attribute table: length, count, CRC, and each attribute's type,
 * name length and name. */
#define EN_SMZ_MAX_TABLE_BYTES (12 + EPSNET_ATTR_MAX * (2 + EPSNET_ATTR_NAME_MAX))

/* Limits a reader enforces before allocating (docs/smz.md "Limits"). */
#define EN_SMZ_MAX_RAW_BYTES ((uint32_t)4 << 20)
#define EN_SMZ_MAX_RECORDS ((uint32_t)1 << 20)
/* What the writer aims for: big enough to compress well, small enough to
 * seek finely and to hand one block to each thread. */
#define EN_SMZ_TARGET_RAW_BYTES ((uint32_t)512 << 10)

extern const uint8_t en_smz_magic[8];
extern const uint8_t en_smz_end_magic[8];

typedef struct en_smz_header {
    unsigned version;           /* 1 or 2; encode writes 2 exactly when attrs.count > 0 */
    epsnet_attr_layout attrs;   /* version 2: from the attribute table */
    epsnet_coord_type coord_type;
    int sorted;                 /* vertices non-decreasing along axis */
    int axis;                   /* 0..2, or -1 */
    int has_bbox;
    uint64_t nverts, nfaces;    /* EPSNET_COUNT_UNKNOWN when unknown */
    double bbox[6];             /* min xyz, max xyz */
} en_smz_header;

typedef struct en_smz_block_header {
    uint32_t compressed_bytes;
    uint32_t raw_bytes;
    uint32_t records;
    uint32_t nverts, ntris, nfinal;
    uint64_t first_vertex;      /* vertices in all earlier blocks */
} en_smz_block_header;

typedef struct en_smz_index_entry {
    uint64_t offset;            /* of the block's tag */
    uint64_t first_vertex;
    uint64_t first_triangle;
    uint32_t records;
    uint32_t compressed_bytes;
    double axis_min, axis_max;  /* along the header's axis (x when none);
                                 * +inf/-inf for a block without vertices */
} en_smz_index_entry;

typedef struct en_smz_trailer {
    uint64_t index_offset;
    uint64_t blocks;
    uint64_t nverts, nfaces, nfinal;
    int has_bbox;
    double bbox[6];
    int sorted;                 /* verified by the writer */
    int axis;
    uint32_t index_crc;
} en_smz_trailer;

uint32_t en_smz_crc32(uint32_t crc, const void *data, size_t n);

void en_smz_header_encode(const en_smz_header *h, uint8_t out[EN_SMZ_HEADER_BYTES]);
/* @return 0, or the byte offset (within the header) of the first bad field
 * with why filled. */
int en_smz_header_decode(const uint8_t in[EN_SMZ_HEADER_BYTES], en_smz_header *h, char *why,
                         size_t why_len);

/* The version 2 attribute table (docs/smz.md "Attribute table") into out
 * (EN_SMZ_MAX_TABLE_BYTES). @return its length. */
size_t en_smz_attr_table_encode(const epsnet_attr_layout *l, uint8_t *out);
/* Decode a table's body (the body_len bytes after its length field) and
 * check its CRC (crc, the u32 after the body). @return 0 or -1 with why. */
int en_smz_attr_table_decode(const uint8_t *body, uint32_t body_len, uint32_t crc, epsnet_attr_layout *l,
                             char *why, size_t why_len);

void en_smz_block_header_encode(const en_smz_block_header *b, uint8_t out[EN_SMZ_BLOCK_HEADER_BYTES]);
/* Checks the tag, the CRC and the limits. @return 0 or -1 with why filled. */
int en_smz_block_header_decode(const uint8_t in[EN_SMZ_BLOCK_HEADER_BYTES], en_smz_block_header *b,
                               char *why, size_t why_len);

void en_smz_index_entry_encode(const en_smz_index_entry *e, uint8_t out[EN_SMZ_INDEX_ENTRY_BYTES]);
void en_smz_index_entry_decode(const uint8_t in[EN_SMZ_INDEX_ENTRY_BYTES], en_smz_index_entry *e);

void en_smz_trailer_encode(const en_smz_trailer *t, uint8_t out[EN_SMZ_TRAILER_BYTES]);
int en_smz_trailer_decode(const uint8_t in[EN_SMZ_TRAILER_BYTES], en_smz_trailer *t, char *why,
                          size_t why_len);

/*
 * Decompress a block payload (one zstd frame, which must carry its content
 * checksum) into raw (b->raw_bytes bytes). dctx is a ZSTD_DCtx*.
 * @return 0 or -1 with why filled (corrupt data, checksum mismatch, size).
 */
int en_smz_unpack(void *dctx, const uint8_t *payload, const en_smz_block_header *b, uint8_t *raw,
                  char *why, size_t why_len);

/*
 * Decode a raw payload into b->records records with global indices. Checks
 * the payload's own consistency (section sizes, record kinds and counts,
 * corners and finalizations that stay within the vertices seen so far);
 * stream-level checks (finalized references, sortedness) are the caller's.
 * @return 0 or -1 with why filled.
 */
int en_smz_decode_block(const uint8_t *raw, const en_smz_block_header *b, epsnet_coord_type ct,
                        epsnet_record *out, char *why, size_t why_len);
/* Working arrays of a decoder or encoder, kept from block to block (one
 * per thread that decodes): fresh ones per block were faulted in anew each
 * time (bench/RESULTS.md, session 10). Zero-initialise. */
typedef struct en_smz_scratch {
    void *vrec, *tri, *pos, *ref, *head, *edge, *raw;
    size_t vrec_cap, tri_cap, pos_cap, ref_cap, head_cap, edge_cap, raw_cap;
} en_smz_scratch;

void en_smz_scratch_free(en_smz_scratch *sc);
/* Grow sc to what decoding block b of a file with header h needs, so that
 * the decoding itself allocates nothing (a reader sizes its jobs' memory
 * before they run). @return 0 or -1 out of memory. */
int en_smz_scratch_reserve(en_smz_scratch *sc, const en_smz_block_header *b, const en_smz_header *h);
/* The bytes sc holds. */
size_t en_smz_scratch_bytes(const en_smz_scratch *sc);

/* Room for block b of a file with header h in a reader's buffers: its
 * compressed payload, raw payload, records and (version 2) attribute
 * bytes, grown as needed and kept by the caller. @return 0 or -1 (out of
 * memory). */
int en_smz_block_room(const en_smz_header *h, const en_smz_block_header *b, uint8_t **payload, size_t *payload_cap,
                      uint8_t **raw, size_t *raw_cap, epsnet_record **recs, size_t *recs_cap, uint8_t **attrs,
                      size_t *attrs_cap);

/* en_smz_decode_block() decodes version 1 payloads only; this one any
 * version, by the file's header h (version, axis, attributes): each vertex
 * record's attr points into attr_out, which holds b->nverts *
 * h->attrs.size bytes (NULL when there are none). sc: working arrays, kept
 * by the caller. */
int en_smz_decode_block_h(const uint8_t *raw, const en_smz_block_header *b, const en_smz_header *h,
                          uint8_t *attr_out, en_smz_scratch *sc, epsnet_record *out, char *why, size_t why_len);

/* ---- encoder ---- */

typedef struct en_smz_encoder en_smz_encoder;

/* A version 2 encoder: coordinates predicted, the axis coordinate from
 * the previous vertex (axis -1: none), vertex attributes l (copied; NULL:
 * none). en_smz_encoder_new(ct) is en_smz_encoder_new_v2(ct, NULL, -1). */
en_smz_encoder *en_smz_encoder_new(epsnet_coord_type ct);
en_smz_encoder *en_smz_encoder_new_v2(epsnet_coord_type ct, const epsnet_attr_layout *l, int axis);
void en_smz_encoder_free(en_smz_encoder **e);
/* Append one record; nverts_before is the global vertex count before it.
 * @return 0, or -1 out of memory. */
int en_smz_encoder_add(en_smz_encoder *e, const epsnet_record *rec, uint64_t nverts_before);
uint32_t en_smz_encoder_records(const en_smz_encoder *e);
/* Raw payload size the block would have now. */
size_t en_smz_encoder_raw_bytes(const en_smz_encoder *e);
/*
 * Build the raw payload and compress it into *out (grown as needed, owned by
 * the caller), filling b (everything but first_vertex). The encoder is then
 * empty. cctx is a ZSTD_CCtx* set up by the caller with its level and the
 * content checksum on. @return 0 or -1 (out of memory / zstd failure).
 */
int en_smz_encoder_flush(en_smz_encoder *e, void *cctx, uint8_t **out, size_t *out_cap,
                         en_smz_block_header *b);

/* ---- random access (parallel decoding, seeking) ---- */

typedef struct en_smz_index {
    en_smz_header header;
    en_smz_trailer trailer;
    en_smz_index_entry *entries; /* trailer.blocks of them, owned */
} en_smz_index;

/*
 * Read the header, trailer and index of a plain (not .zst) .smz file with
 * pread(), checking every CRC. @return 0 or a negative code with err filled.
 */
int en_smz_read_index(int fd, const char *path, uint64_t file_size, en_smz_index *idx,
                      epsnet_error *err);
void en_smz_index_free(en_smz_index *idx);

#endif /* EN_IO_SMZ_H */
