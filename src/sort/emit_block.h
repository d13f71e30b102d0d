/*
 * Pass 6 of the sort in blocks of ranks, each block's records built by a
 * job on any worker (docs/architecture.md §13, "Pass 6 in blocks").
 *
 * When the last uses of the ranks are in memory, a block's records depend
 * on nothing another block writes: a vertex's output id is its rank less
 * the unreferenced ranks before it (en_rank_ids, filled in rank order by
 * the owner before it submits the block that reaches them), and a vertex is
 * finalized in the group of its last use, which one block holds whole. So
 * the blocks are built in any order on any thread and handed on in rank
 * order: the records, hence the output, are the same for every -j.
 */
#ifndef EN_SORT_EMIT_BLOCK_H
#define EN_SORT_EMIT_BLOCK_H

#include <stddef.h>
#include <stdint.h>

#include "epsnet/epsnet.h"

/* Rank -> output id, the unreferenced ranks skipped: a bit a rank and a
 * count before each 64-bit word. Written by the owner in rank order
 * (en_rank_ids_fill), read by jobs only below what was filled before they
 * were submitted. */
typedef struct en_rank_ids {
    uint64_t *unref;             /* bit r % 64 of word r / 64: rank r is used by no face */
    uint64_t *before;            /* unreferenced ranks before word w */
    uint64_t words;
    uint64_t count;              /* unreferenced ranks filled so far */
} en_rank_ids;

/* @return 0 or -1 (out of memory). */
int en_rank_ids_init(en_rank_ids *ids, uint64_t ranks);
void en_rank_ids_free(en_rank_ids *ids);
/* Bytes held for ranks. */
uint64_t en_rank_ids_bytes(uint64_t ranks);

/* Fill ranks [lo, lo + n) from last_of (UINT32_MAX: unused); lo is a
 * multiple of 64 and the ranks before it are filled. @return how many of
 * them are unreferenced. */
uint64_t en_rank_ids_fill(en_rank_ids *ids, const uint32_t *last_of, uint64_t lo, size_t n);

static inline uint64_t en_rank_id(const en_rank_ids *ids, uint64_t rank)
{
    uint64_t w = rank >> 6, below = ids->unref[w] & ((UINT64_C(1) << (rank & 63)) - 1);
    /* note: most words hold no unused rank, and a build for any x86-64
     * counts bits by a call (4% of the workers' samples in `epsnet sort`'s
     * pass 6, session 38), so only a word with one pays for it */
    return rank - ids->before[w] - (below ? (uint64_t)__builtin_popcountll(below) : 0);
}

/* One block's job. */
typedef struct en_emit_block {
    /* Written by the owner before submit, read by the job. */
    uint64_t rank0;              /* the block's ranks: [rank0, rank0 + nranks) */
    size_t nranks;
    const uint32_t *last_of;     /* the sort's: rank -> its last use, UINT32_MAX none */
    const en_rank_ids *ids;      /* filled up to the block's end */
    const uint64_t *items;       /* the faces whose last corner is in the block, by last corner
                                    and then input order: (last | first << 32, second | third << 32) */
    size_t nitems;
    const uint8_t *xyz;          /* rank rank0 + i's coordinates at xyz + i * xyz_stride */
    size_t xyz_stride;
    int xyz_float;               /* three floats (a float32 input's), else three doubles */
    const uint8_t *attr;         /* its attribute bytes at attr + i * attr_stride; NULL: none */
    size_t attr_stride;

    /* Written by the job, read by the owner after retire. */
    epsnet_record *recs;         /* the block's records, in pass 6's order */
    size_t nrecs;
    int64_t live_delta;          /* vertices it emits less those it finalizes */
    int64_t live_peak;           /* the largest running delta, just after a vertex */

    /* The job's own, kept from block to block. */
    size_t recs_cap;
    uint32_t *fin;               /* a group's table: corner, group stamp, last face using it */
    size_t fin_cap;              /* slots (3 words each), a power of two */
    uint32_t stamp;
} en_emit_block;

/* en_job_fn: build the block's records. @return 0, EPSNET_ENOMEM, or
 * EPSNET_EINTERNAL when an item's last corner is not one of the block's ranks. */
int en_emit_block_run(void *block);

/* The bytes a block holds now (its records and its table). */
uint64_t en_emit_block_bytes(const en_emit_block *b);

void en_emit_block_free(en_emit_block *b);

#endif /* EN_SORT_EMIT_BLOCK_H */
