/*
 * Working objects handed from job to job (docs/architecture.md §10): a job
 * takes one that an earlier job gave back, or makes its own, and gives it
 * back when done, so a run holds about as many as ran at once, each kept
 * warm, rather than making and faulting in a fresh one per job. The slab
 * collapses' working arrays go round this way within a chain, and slab
 * works from one chain to the next (a target stage's rounds). Thread-safe.
 */
#ifndef EN_COMMON_CTXPOOL_H
#define EN_COMMON_CTXPOOL_H

#include <stddef.h>

typedef struct en_ctxpool en_ctxpool;

/* An empty pool; destroy(item) frees an item it still holds when the pool
 * goes (or when there is no room to keep one given back). @return 0 or
 * EPSNET_ENOMEM. */
int en_ctxpool_new(en_ctxpool **pool, void (*destroy)(void *item));
/* An item given back and not taken since, or NULL when there is none (the
 * caller then makes one). Accepts a NULL pool (NULL). */
void *en_ctxpool_take(en_ctxpool *pool);
/* Keep item for a later take; destroys it when the list cannot grow.
 * Never fails. */
void en_ctxpool_give(en_ctxpool *pool, void *item);
/* Destroy every item held (a caller that will not need them again soon). */
void en_ctxpool_trim(en_ctxpool *pool);
/* Destroy every item held and free the pool. Sets *pool to NULL. Accepts
 * NULL. */
void en_ctxpool_free(en_ctxpool **pool);

#endif
