/*
 * One run's slabs shared among processes (docs/distributed.md,
 * epsnet.h section 8a): which rank works each slab, and the messages that
 * carry a slab's input out to it and its results back.
 *
 * Rank 0 alone reads the input, cuts the slabs, stitches and writes. Each
 * slab it cuts goes to a rank that has room for one (its WANT is in), or,
 * when none has, is worked on rank 0: the ranks take what they can, so no
 * share is fixed in advance and none waits for a turn. Rank 0 sends that
 * rank the slab's input (what its chunker cut, and the settings the slab
 * is worked at), receives the results into the slab work it cut, and
 * stitches them as if they were its own. The bytes are those of one
 * process because a slab work's results are a function of its input and
 * those settings only (the same property that makes them the same for
 * every -j), wherever it was worked. The other ranks read nothing and hold
 * a few slabs (pipeline/slab_server.h).
 *
 * Messages, always a header (en_peer_msg), then, for a slab, its head and
 * its arrays:
 *
 *   rank r -> 0:  WANT (room for a slab)   SLAB k (results)   END (status)
 *   rank 0 -> r:  in reply to a WANT: INPUT k (a slab), NONE (nothing
 *                 now: go on with the slabs held, rank 0 waits for one or
 *                 works the one it cut), DONE (the run is over), or
 *                 VERDICT (status: rank 0 failed);
 *                 in reply to END: VERDICT (status)
 *
 * Rank 0 sends only to a rank waiting for its reply, so a blocking send
 * cannot deadlock: a rank waits for rank 0 only after a WANT, which rank 0
 * answers before it waits for anything of that rank's; rank 0 waits only
 * for a rank's WANT or results, which that rank sends without waiting for
 * rank 0 (its slabs are worked on its own threads).
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

/* The slabs another rank holds at most: one on each of its workers and
 * two waiting, so that it works on while rank 0 works a slab of its own
 * (rank 0 keeps room for them in its ring). */
size_t en_peer_slabs_held(int workers);

/* ---- rank 0 ---- */

/* Where the slab rank 0 has just cut is to be worked: *rank, a rank that
 * waits for one, or 0, rank 0 itself. Takes every message the other ranks
 * have sent (results go into the slabs they are for), and waits for one to
 * want a slab when rank 0 is busier than they are (peers.c:
 * rank0_has_time). */
int en_peer_pick(en_peer_link *link, int *rank, epsnet_error *err);

/* Send slab work w's input, and the settings it is worked at (w->g,
 * w->plan, w->weights, ...), to `rank`, which en_peer_pick() named. w stays
 * rank 0's: en_peer_recv_slab() fills it. */
int en_peer_ship(en_peer_link *link, int rank, en_slab_work *w, epsnet_error *err);

/* The slabs shipped so far. */
uint64_t en_peer_slabs_shipped(const en_peer_link *link);

/* Receive the results of slab work w from the rank it was shipped to (a
 * slab rank 0 worked itself: nothing to do). A rank that ended instead
 * fails this with its error. */
int en_peer_recv_slab(en_peer_link *link, en_slab_work *w, epsnet_error *err);

/* ---- another rank ---- */

/* What a WANT brought. */
typedef enum en_peer_reply { EN_PEER_INPUT, EN_PEER_NONE, EN_PEER_DONE } en_peer_reply;

/* Where a shipped slab's settings are kept on the rank that works it. */
typedef struct en_peer_settings {
    gauss_sphere g;
    en_pass_plan plan;
    en_attr_weights weights;
} en_peer_settings;

/* Send WANT and take rank 0's reply: with EN_PEER_INPUT, w holds the
 * slab's input and points into *set for its settings. A VERDICT fails
 * this with rank 0's error. */
int en_peer_want(en_peer_link *link, en_slab_work *w, en_peer_settings *set, en_peer_reply *reply,
                 epsnet_error *err);

/* Send slab work w's results to rank 0. */
int en_peer_send_slab(en_peer_link *link, const en_slab_work *w, epsnet_error *err);

/*
 * The run's end on every rank, whatever happened before: rank r != 0 sends
 * END with (rc, err) and takes rank 0's VERDICT; rank 0 takes every rank's
 * END (passing over what else they sent, and answering a WANT with DONE,
 * or with its own failure), then sends each the VERDICT: rc when it
 * failed, else the first rank's failure, else 0. @return the verdict, err
 * filled when non-zero.
 */
int en_peer_agree(en_peer_link *link, int rc, epsnet_error *err);

#endif
