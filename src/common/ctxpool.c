#include "common/ctxpool.h"

#include <pthread.h>

#include "common/alloc.h"
#include "common/error.h"

struct en_ctxpool {
    pthread_mutex_t lock;
    void **items;                 /* given back, under lock */
    size_t n, cap;
    void (*destroy)(void *item);
};

int en_ctxpool_new(en_ctxpool **pool, void (*destroy)(void *item))
{
    en_ctxpool *p = en_calloc(1, sizeof *p);
    if (!p || pthread_mutex_init(&p->lock, NULL)) {
        en_free(p);
        *pool = NULL;
        return EPSNET_ENOMEM;
    }
    p->destroy = destroy;
    *pool = p;
    return 0;
}

void *en_ctxpool_take(en_ctxpool *pool)
{
    if (!pool)
        return NULL;
    pthread_mutex_lock(&pool->lock);
    void *item = pool->n ? pool->items[--pool->n] : NULL;
    pthread_mutex_unlock(&pool->lock);
    return item;
}

void en_ctxpool_give(en_ctxpool *pool, void *item)
{
    pthread_mutex_lock(&pool->lock);
    int kept = en_grow((void **)&pool->items, &pool->cap, pool->n + 1, sizeof *pool->items) == 0;
    if (kept)
        pool->items[pool->n++] = item;
    pthread_mutex_unlock(&pool->lock);
    if (!kept)
        pool->destroy(item);
}

void en_ctxpool_trim(en_ctxpool *pool)
{
    pthread_mutex_lock(&pool->lock);
    for (size_t i = 0; i < pool->n; i++)
        pool->destroy(pool->items[i]);
    pool->n = 0;
    pthread_mutex_unlock(&pool->lock);
}

void en_ctxpool_free(en_ctxpool **pool)
{
    en_ctxpool *p = pool ? *pool : NULL;
    if (!p)
        return;
    for (size_t i = 0; i < p->n; i++)
        p->destroy(p->items[i]);
    en_free(p->items);
    pthread_mutex_destroy(&p->lock);
    en_free(p);
    *pool = NULL;
}
