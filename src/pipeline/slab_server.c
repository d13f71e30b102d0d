/*
 * Another rank's loop: WANT while there is room, work what comes, send
 * the results back oldest first (pipeline/slab_server.h).
 */
#include "pipeline/slab_server.h"

#include <string.h>

#include "common/alloc.h"
#include "common/error.h"
#include "core/collapse.h"

typedef struct served {
    en_slab_work w;
    en_peer_settings set;         /* what w->g, w->plan and w->weights point to */
    /* w's bytes as last seen where no worker held it: when its input came
     * and when it was retired (a worker grows its arrays as it goes) */
    uint64_t bytes;
} served;

static int over_budget(const served *held, size_t n, uint64_t budget, const char *path, epsnet_error *err)
{
    uint64_t bytes = 0;
    for (size_t i = 0; i < n; i++)
        bytes += held[i].bytes;
    if (!budget || bytes <= budget)
        return 0;
    return en_error_set(err, EPSNET_ELIMIT, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "the slabs held for rank 0 take about %llu bytes, over the memory budget of %llu bytes "
                        "(give more --mem)",
                        (unsigned long long)bytes, (unsigned long long)budget);
}

int en_slab_serve(en_peer_link *l, en_pool *pool, uint64_t mem_budget, const char *path, epsnet_error *err)
{
    size_t hold = en_peer_slabs_held(en_pool_threads(pool));
    served *held = en_calloc(hold, sizeof *held);
    size_t *free_list = en_malloc(hold * sizeof *free_list), nfree = hold;
    en_jobring *ring = NULL;
    en_ctxpool *arrays = NULL, *scratch = NULL;
    int rc = 0;
    if (!held || !free_list || en_jobring_new(&ring, pool, hold) || en_collapse_arrays_new(&arrays) ||
        en_slab_scratch_pool_new(&scratch))
        rc = en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    for (size_t i = 0; rc == 0 && i < hold; i++) {
        en_slab_work_init(&held[i].w);
        free_list[i] = hold - 1 - i;
    }
    /* asked: the last WANT got NONE (rank 0 waits for the oldest slab held) */
    int asked = 0, done = 0;
    while (rc == 0 && (!done || en_jobring_in_flight(ring))) {
        if (!done && !asked && nfree) {
            served *x = &held[free_list[nfree - 1]];
            en_peer_reply reply;
            if ((rc = en_peer_want(l, &x->w, &x->set, &reply, err)) != 0)
                break;
            if (reply == EN_PEER_NONE) {
                asked = 1;
            } else if (reply == EN_PEER_DONE) {
                done = 1;
            } else {
                nfree--;
                x->w.collapse_arrays = arrays;
                x->w.scratch = scratch;
                x->bytes = en_slab_work_bytes(&x->w);
                if ((rc = over_budget(held, hold, mem_budget, path, err)) == 0 &&
                    (rc = en_jobring_submit(ring, en_slab_work_run, &x->w)) != 0)
                    en_error_set(err, rc, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "worker pool refused a slab");
            }
            continue;
        }
        void *job;
        int result;
        if (!en_jobring_retire(ring, &job, &result)) { /* nothing held, and rank 0 waits for it: a bug */
            rc = en_error_set(err, EPSNET_EINTERNAL, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                              "rank 0 waits for a slab this rank does not hold (a bug)");
            break;
        }
        en_slab_work *w = job;
        if (result) {
            *err = w->err;
            rc = result;
            break;
        }
        served *x = (served *)w;
        x->bytes = en_slab_work_bytes(w);
        rc = en_peer_send_slab(l, w, err);
        free_list[nfree++] = (size_t)(x - held);
        asked = 0;
    }
    en_jobring_free(&ring, NULL); /* waits for what is left */
    en_ctxpool_free(&arrays);
    en_ctxpool_free(&scratch);
    for (size_t i = 0; held && i < hold; i++)
        en_slab_work_free(&held[i].w);
    en_free(held);
    en_free(free_list);
    return rc;
}
