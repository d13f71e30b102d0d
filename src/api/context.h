/* The job context behind the public epsnet_context handle. */
#ifndef EN_API_CONTEXT_H
#define EN_API_CONTEXT_H

#include "core/gauss.h"
#include "pipeline/peers.h"
#include "epsnet/epsnet.h"

struct epsnet_context {
    epsnet_settings settings;   /* copied; tmpdir points at our own copy */
    char *tmpdir;
    char *lock_property;        /* our own copy */
    gauss_sphere sphere;        /* G with the settings' level and rotation */
    gauss_sphere run_sphere;    /* G of the last run: the skeleton's, when a target chose it */
    epsnet_stats stats;         /* of the last run */
    char command[32];           /* name of the last run, for the JSON stats */
    en_peer_link *peers;        /* during epsnet_simplify_file() with settings.peers: its ranks' link */
};

#endif
