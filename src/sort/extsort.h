/*
 * External sort of fixed-size items in bounded memory: items are buffered,
 * radix-sorted and spilled as runs (en_spill_open_plain: anonymous
 * files that vanish on any exit), then merged. Items are arrays of uint64_t
 * words; the first key_words of them are the key, compared as unsigned
 * numbers, most significant word first. The sort is stable: items with
 * equal keys come out in the order they were added (runs are radix-sorted,
 * LSD, and merges break ties by run age).
 */
#ifndef EN_SORT_EXTSORT_H
#define EN_SORT_EXTSORT_H

#include <stddef.h>
#include <stdint.h>

#include "common/pool.h"

#include "epsnet/epsnet.h"

/* Memory the sort stages account for (buffers they allocate themselves). */
typedef struct en_mem_account {
    uint64_t used;
    uint64_t peak;
} en_mem_account;

void en_mem_take(en_mem_account *m, uint64_t bytes);
void en_mem_give(en_mem_account *m, uint64_t bytes);

/* Widest item: a vertex with its key, id, two coordinates and
 * EPSNET_ATTR_MAX * 8 bytes of attributes (sort.c pass_order). */
#define EN_EXTSORT_MAX_WORDS (4 + EPSNET_ATTR_MAX)

/* Runs a full buffer may be cut into, one a worker (en_extsort_config.threads). */
#define EN_EXTSORT_MAX_PARTS 4

typedef struct en_extsort_config {
    size_t item_words;        /* 1 .. EN_EXTSORT_MAX_WORDS */
    size_t key_words;         /* 1 .. item_words */
    uint64_t key_mask;        /* the bits of the first word that are key;
                                 0 = all (the others ride along) */
    uint64_t mem;             /* bytes for the run buffer and the merge */
    const char *tmpdir;       /* NULL = $TMPDIR or /tmp */
    const char *owner;        /* the output the runs serve, for messages */
    en_mem_account *account;  /* may be NULL */
    int threads;              /* > 0: full buffers are sorted and written as runs
                                 on workers while the next one fills (the
                                 budget is then cut in thirds, not halves),
                                 each cut in up to `threads` runs sorted side
                                 by side (at most EN_EXTSORT_MAX_PARTS); the
                                 items come out the same */
    en_pool *pool;            /* with threads: the workers to use (the run's
                                 one pool, docs/architecture.md §10); NULL:
                                 a thread of its own */
} en_extsort_config;

typedef struct en_extsort en_extsort;

int en_extsort_open(en_extsort **es, const en_extsort_config *cfg, epsnet_error *err);
/* Add one item (item_words words). */
int en_extsort_add(en_extsort *es, const uint64_t *item, epsnet_error *err);
/* Add n items, packed (n x item_words words): as n adds. */
int en_extsort_add_many(en_extsort *es, const uint64_t *items, size_t n, epsnet_error *err);
/* No more items: prepare to hand them out in order. */
int en_extsort_finish(en_extsort *es, epsnet_error *err);
/* @return 1 with item filled, 0 when done, or a negative code. */
int en_extsort_next(en_extsort *es, uint64_t *item, epsnet_error *err);
/* Look at the next item without taking it: @return a pointer valid until the
 * next call on es, or NULL when done or failed (check *rc). */
const uint64_t *en_extsort_peek(en_extsort *es, int *rc, epsnet_error *err);
uint64_t en_extsort_items(const en_extsort *es);
/* Runs written to disk, and their compressed bytes (also after close). */
uint64_t en_extsort_runs(const en_extsort *es);
uint64_t en_extsort_temp_bytes(const en_extsort *es);
void en_extsort_close(en_extsort **es);

#endif /* EN_SORT_EXTSORT_H */
