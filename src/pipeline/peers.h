/*
 * One run's slabs shared among processes (docs/distributed.md,
 * epsnet.h section 8a): which rank works each slab, the messages between
 * the ranks, and a slab work's results sent array by array.
 *
 * Every rank reads the whole input and cuts the same slabs: the cuts
 * depend on the input and the settings only. Slab k's classification and
 * collapses run on rank en_peer_of_slab(k) alone; rank 0 receives every
 * other rank's results, in slab order, into the slab work its own chunker
 * cut, and stitches them as if they were its own. The bytes are those of
 * one process because a slab work's results are a function of its input
 * and the pass's settings only (the same property that makes them the same
 * for every -j).
 *
 * Messages, always a header (en_peer_msg), then, for a slab, its head and
 * its arrays:
 *
 *   rank r -> 0:  SLAB k (results)   WAIT k   END (status)
 *   rank 0 -> r:  GO k (frequency), in reply to WAIT k
 *                 VERDICT (status), in reply to END, or to a WAIT once
 *                 rank 0 has failed
 *
 * Rank 0 sends only to a rank waiting for it, so a blocking send cannot
 * deadlock: every other wait is rank 0's, on messages each rank sends in
 * slab order. A WAIT comes before the first slab (so that a rank 0 that
 * could not open the output stops the others early) and before each slab
 * at which a chosen skeleton's candidate frequency may fall (chain.c:
 * lower_candidate, which needs every earlier slab's counts).
 *
 * Threads: the calling thread only (the transport's contract).
 */
#ifndef EN_PIPELINE_PEERS_H
#define EN_PIPELINE_PEERS_H

#include <stdint.h>

#include "epsnet/epsnet.h"
#include "pipeline/slab_work.h"

typedef struct en_peer_link en_peer_link;

/* @return 0, or EPSNET_ENOMEM / EPSNET_EINVAL (a bad rank or size) with err. */
int en_peer_link_new(en_peer_link **link, const epsnet_peers *peers, const char *path, epsnet_error *err);
void en_peer_link_free(en_peer_link **link);

int en_peer_rank(const en_peer_link *link);
int en_peer_count(const en_peer_link *link);

/* The rank that classifies and collapses slab k of a pass shared among
 * `size` ranks. Slab 0 is rank 0's (a one-slab pass stays there). */
int en_peer_of_slab(uint64_t k, int size);

/* Rank r != 0: send slab work w's results to rank 0. */
int en_peer_send_slab(en_peer_link *link, const en_slab_work *w, epsnet_error *err);

/* Rank 0: receive slab work w's results from the rank that worked it. A
 * rank that ended instead fails this with its error. */
int en_peer_recv_slab(en_peer_link *link, en_slab_work *w, epsnet_error *err);

/* Before slab k. Rank r != 0: WAIT k, then *frequency from rank 0's GO (a
 * VERDICT instead fails with rank 0's error). Rank 0: every rank's WAIT k,
 * then GO k with *frequency. */
int en_peer_meet(en_peer_link *link, uint64_t k, uint32_t *frequency, epsnet_error *err);

/*
 * The run's end on every rank, whatever happened before: rank r != 0 sends
 * END with (rc, err) and takes rank 0's VERDICT; rank 0 takes every rank's
 * END (passing over what else they sent, and answering a WAIT with its own
 * failure), then sends each the VERDICT: rc when it failed, else the first
 * rank's failure, else 0. @return the verdict, err filled when non-zero.
 */
int en_peer_agree(en_peer_link *link, int rc, epsnet_error *err);

#endif
