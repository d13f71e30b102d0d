/* File runs of the streaming pipeline used by the public entry points. */
#ifndef EN_API_STREAM_FILES_H
#define EN_API_STREAM_FILES_H

#include "epsnet/epsnet.h"

/* epsnet_sample_file() with EPSNET_SAMPLES_POINTS, streamed: the samples
 * are the one-slab run's, written in the same (input) order. */
int en_sample_points_streamed(epsnet_context *ctx, const char *in_path, const char *out_path, int ascii,
                              epsnet_error *err);

#endif
