/*
 * The one owner of the memory budget (docs/architecture.md §12).
 *
 * --mem (epsnet_settings.mem) is a total for the whole process. It is split
 * here, once per run, among the parts that hold memory that grows with the
 * input: the reader, the sort, the chain of passes (in which a target's one
 * slab has a share of its own). Every other file asks this one for its share
 * and never divides --mem again; the sort alone divides its own share among
 * its sorters (src/sort/sort.c), as the chain divides its share among its
 * passes by checking their sum.
 *
 * Slab sizes come from the total, never from a share, so that a run on a
 * sorted file and the same run on the file sorted first cut the same slabs
 * and write the same bytes (docs/architecture.md §11).
 */
#ifndef EN_API_BUDGET_H
#define EN_API_BUDGET_H

#include <stdint.h>

#include "epsnet/epsnet.h"

/* What the run reads, which decides who shares the total. */
typedef enum en_budget_input {
    EN_BUDGET_STREAM,   /* a finalized stream (.smz, SMA, SMB): the reader's live set beside the chain */
    EN_BUDGET_SORTED,   /* an ordinary mesh sorted first: the sort beside the chain (the sort reads the file) */
    EN_BUDGET_PUSHED,   /* records pushed by the caller (epsnet_stream_*): the chain alone */
    EN_BUDGET_SERVED,   /* slabs sent by rank 0 of a shared run (pipeline/slab_server.h): those held, alone */
    EN_BUDGET_IN_CORE,  /* a whole mesh loaded in memory (sample --mesh, render --samples): the reader alone */
} en_budget_input;

typedef struct en_budget {
    uint64_t total;         /* settings.mem, or half the physical memory (0: unknown, nothing checked) */
    int given;              /* settings.mem was given */
    uint64_t reader;        /* the reader's held state: a stream's live vertices and the .smz blocks read
                             * ahead, an OBJ's tables, or (in core) the whole mesh; 0: no reader of its own */
    uint64_t sort;          /* the sort's buffers and arrays; 0: no sort */
    uint64_t chain;         /* what the passes hold: chunkers, stitchers, a target's one slab */
    uint64_t one_slab;      /* part of chain: what a target's one slab, or one-slab finish, may hold */
    uint32_t slab_vertices; /* the slabs' size: settings.slab_vertices, else from the total */
    int slab_derived;       /* slab_vertices comes from the total, not settings.slab_vertices:
                             * a streamed size's slabs then hold it in all, ghosts included
                             * (pipeline/chunker.h), since memory goes by all of them */
} en_budget;

/* Bytes a vertex costs in the pipeline at the default slab size, all
 * passes' slabs in flight counted: the budget over this is the slab size
 * when --mem is given (measured, bench/RESULTS.md). */
#define EN_BUDGET_BYTES_PER_SLAB_VERTEX 4800
/* The slabs' size without --mem or --slab. */
#define EN_BUDGET_DEFAULT_SLAB 65536u

/* The split of settings.mem (see en_budget) for a run reading `input`. */
void en_budget_split(en_budget *b, const epsnet_settings *set, en_budget_input input);

/* The slabs' size alone (the same as en_budget_split's, for any input). */
uint32_t en_budget_slab_vertices(const epsnet_settings *set);

/* The total alone: settings.mem, or half the physical memory. */
uint64_t en_budget_total(const epsnet_settings *set);

#endif
