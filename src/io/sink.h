/*
 * Byte sink: buffered output that becomes visible at its path only on commit
 * (docs/architecture.md §5: nothing half-written at the -o path), with optional zstd
 * compression. Also the spill file: an anonymous temporary file that
 * disappears when closed or when the process dies, used for data that must be
 * written once and read back (PLY faces of a streaming input, sort runs).
 */
#ifndef EN_IO_SINK_H
#define EN_IO_SINK_H

#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "epsnet/epsnet.h"

typedef struct en_sink en_sink;

/*
 * Create a sink for path ("-" = stdout). zstd_level > 0 compresses; 0 writes
 * plain bytes. @return 0 or a negative code with err filled; on failure *s is
 * NULL and nothing was created.
 */
int en_sink_open(en_sink **s, const char *path, int zstd_level, epsnet_error *err);

/* Append bytes. @return 0 or a negative code with err filled (sticky). */
int en_sink_write(en_sink *s, const void *data, size_t n, epsnet_error *err);

/* Bytes written so far (before compression). */
uint64_t en_sink_offset(const en_sink *s);

/*
 * Overwrite n bytes at offset, already written. Only for plain (uncompressed)
 * seekable sinks; @return EPSNET_EUNSUPPORTED otherwise (callers then fall
 * back to spilling).
 */
int en_sink_patch(en_sink *s, uint64_t offset, const void *data, size_t n,
                  epsnet_error *err);
int en_sink_can_patch(const en_sink *s);

/* Flush, close and move into place; frees s and sets *s to NULL. On failure
 * nothing is left at the path. */
int en_sink_commit(en_sink **s, epsnet_error *err);

/* Everything written so far into the temporary file (a compressed sink's
 * frame ended), so that what can fail for lack of room fails here; then
 * only en_sink_commit (the move into place) or en_sink_abort. For an output
 * that other processes must agree to first (epsnet.h section 8a). */
int en_sink_settle(en_sink *s, epsnet_error *err);

/* Discard; frees s and sets *s to NULL. Accepts NULL. */
void en_sink_abort(en_sink **s);

/* The path the sink will commit to, for messages. */
const char *en_sink_path(const en_sink *s);

/* ---- spill files ---- */

struct en_pool;
typedef struct en_spill en_spill;

/* Anonymous zstd-compressed temporary file in dir (NULL = $TMPDIR or /tmp).
 * owner names the file the spill serves (the output path), so that a failure
 * such as a full disk is reported against what the user asked for. */
int en_spill_open(en_spill **sp, const char *dir, const char *owner, epsnet_error *err);
/* The same, stored as written, without compression: for data that does not
 * compress well enough to pay for zstd's time. */
int en_spill_open_plain(en_spill **sp, const char *dir, const char *owner, epsnet_error *err);
int en_spill_write(en_spill *sp, const void *data, size_t n, epsnet_error *err);
/* A plain spill's staged bytes are written on pool's workers, a buffer at
 * a time and in order, while the caller fills the next one; a failure is
 * reported by the write or rewind that meets it. Before the first write.
 * @return 0, or EPSNET_ENOMEM (the spill then writes on the caller's
 * thread, as it would without). */
int en_spill_write_behind(en_spill *sp, struct en_pool *pool);
/* Switch from writing to reading from the start. */
int en_spill_rewind(en_spill *sp, epsnet_error *err);
/* Read up to n bytes; @return bytes read (0 at end) or a negative code. */
int64_t en_spill_read(en_spill *sp, void *data, size_t n, epsnet_error *err);
/* A plain spill switched to reading: up to n bytes from byte offset,
 * leaving en_spill_read()'s place alone, so that several threads may read
 * parts side by side. @return bytes read or a negative code. */
int64_t en_spill_read_at(const en_spill *sp, void *data, size_t n, uint64_t offset, epsnet_error *err);
/* Compressed bytes on disk. */
uint64_t en_spill_disk_bytes(const en_spill *sp);
void en_spill_close(en_spill **sp);

/* ---- signal safety for named temporaries ---- */

/*
 * Remove every named temporary file this process still has open. Safe to
 * call from a signal handler (it only calls unlink). The CLI calls it from
 * its SIGINT/SIGTERM handler.
 */
void en_tempfiles_cleanup_signal_safe(void);

/* Have path removed by en_tempfiles_cleanup_signal_safe() until
 * unregistered. @return a slot for en_temp_unregister(), or -1 when all
 * slots are taken (then nothing removes it on a signal). */
int en_temp_register(const char *path);
void en_temp_unregister(int slot);

/*
 * Create a new empty file "DIR/PREFIX<pid>-<n>SUFFIX" (O_EXCL) with mode,
 * registered *before* it exists, so no signal can leave it behind between
 * creation and registration (mkstemp's random name comes too late for that).
 * @return the descriptor with the name in path and the slot in *slot
 * (unregister it when done), or -1 with errno set.
 */
int en_temp_create(const char *dir, const char *prefix, const char *suffix, mode_t mode,
                   char *path, size_t cap, int *slot);

#endif /* EN_IO_SINK_H */
