/*
 * Another rank's part of a run shared among processes (pipeline/peers.h,
 * docs/distributed.md): slabs in from rank 0, worked on this rank's
 * threads, results back, until rank 0 says the run is over.
 *
 * It reads no input and holds a few slab works at most
 * (en_peer_slabs_held): one on each worker and two waiting, so that its
 * workers never wait for rank 0 while rank 0 cuts the next one.
 */
#ifndef EN_PIPELINE_SLAB_SERVER_H
#define EN_PIPELINE_SLAB_SERVER_H

#include <stdint.h>

#include "common/pool.h"
#include "pipeline/peers.h"

/* Serve rank 0 on pool's workers (at least one: the calling thread only
 * carries messages). mem_budget: the most the slab works held may take
 * (0: no check); over it the run fails with EPSNET_ELIMIT. @return 0 once
 * rank 0 says DONE, else a negative code with err filled (the run's end,
 * en_peer_agree, is the caller's). */
int en_slab_serve(en_peer_link *link, en_pool *pool, uint64_t mem_budget, const char *path, epsnet_error *err);

#endif
