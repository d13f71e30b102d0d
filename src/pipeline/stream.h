/* Internal side of the streaming pipeline (public: epsnet.h §8b). */
#ifndef EN_PIPELINE_STREAM_H
#define EN_PIPELINE_STREAM_H

#include "epsnet/epsnet.h"
#include "pipeline/slab_work.h"
#include "pipeline/stitcher.h"

/* A sample found by a SAMPLE-mode stream, in slab order (ids increase
 * within a slab, not across slabs). */
typedef int (*en_sample_fn)(void *opaque, uint64_t gid, const double xyz[3], int32_t gvertex, epsnet_error *err);

/* Slab size and worker count the settings ask for (see epsnet_settings). */
uint32_t en_stream_slab_vertices(const epsnet_settings *set);
/* The bytes live vertices and held output may take: settings.mem, or half
 * the physical memory when no budget is given (SPEC §5: a clear error, never
 * the OOM killer). */
uint64_t en_stream_mem_budget(const epsnet_settings *set);
int en_stream_workers(const epsnet_settings *set);

/* A stream in either mode; path names the input in messages (may be NULL).
 * Output goes to the queue unless a sink is set. */
int en_stream_new(epsnet_stream **s, epsnet_context *ctx, en_slab_mode mode, const char *path, epsnet_error *err);
void en_stream_set_sink(epsnet_stream *s, en_emit_fn sink, void *opaque);
void en_stream_set_sample_sink(epsnet_stream *s, en_sample_fn fn, void *opaque);
int en_stream_put(epsnet_stream *s, const epsnet_record *rec, epsnet_error *err);
/* End of input; fills ctx->stats (all but peak_rss and times). */
int en_stream_finish(epsnet_stream *s, epsnet_error *err);

#endif
