/* File runs of the streaming pipeline used by the public entry points. */
#ifndef EN_API_STREAM_FILES_H
#define EN_API_STREAM_FILES_H

#include "common/stage.h"
#include "io/format.h"
#include "epsnet/epsnet.h"

/* epsnet_sample_file() with EPSNET_SAMPLES_POINTS, streamed: the samples
 * are the one-slab run's, written in the same (input) order. */
int en_sample_points_streamed(epsnet_context *ctx, const char *in_path, const char *out_path, int ascii,
                              epsnet_error *err);

struct en_pool;

/* Where a streamed simplification goes, opened once the input is known.
 * pool: the run's workers, which the output may use (en_writer_use_pool)
 * until release_out is called. */
typedef int (*en_open_out_fn)(void *opaque, const epsnet_mesh_info *in, struct en_pool *pool, en_stage *out,
                              epsnet_error *err);
/* The output stops using the run's pool, which goes next. */
typedef void (*en_release_out_fn)(void *opaque);

/* Simplify in_path through the stage chain (sorting it first when it is not
 * a stream; temporaries go beside near_path or in ctx's tmpdir) into the
 * stage open_out gives. arrays: read them instead (epsnet_reader_open_arrays;
 * in_path then names them, temporaries go to ctx's tmpdir or $TMPDIR, and
 * every attribute is carried). keep: the format whose vertex attributes are
 * carried (NULL: none; the others are named as dropped). Fills ctx->stats but peak_rss. The output stage is
 * the caller's to commit or abort, also when this fails. release_out (may
 * be NULL) is called once, after the last record and on every failure
 * after open_out, before the pool goes. */
int en_simplify_streamed(epsnet_context *ctx, const char *in_path, const epsnet_arrays *arrays, const char *near_path,
                         const en_format *keep, en_open_out_fn open_out, en_release_out_fn release_out, void *opaque,
                         epsnet_error *err);

/* After a simplify whose output is there: name the input's vertices that no
 * face uses, which the output leaves out ("... are not <where>"). */
void en_warn_unreferenced(epsnet_context *ctx, const char *name, const char *where);

#endif
