/*
 * Byte source: a buffered window over a file or stdin, with zstd frames
 * decompressed transparently (detected by magic, whatever the name). Format
 * readers parse straight out of the window; offsets are those of the
 * decompressed bytes, which is what an error message must point at.
 */
#ifndef EN_IO_SOURCE_H
#define EN_IO_SOURCE_H

#include <stddef.h>
#include <stdint.h>

#include "epsnet/epsnet.h"

typedef struct en_source {
    /* Window of bytes not consumed yet: parsers advance cur up to end. */
    const uint8_t *cur;
    const uint8_t *end;

    uint8_t *buf;          /* owned; window lives inside */
    size_t cap;
    uint64_t base;         /* decompressed offset of buf[0] */
    uint64_t lineno;       /* lines returned by en_source_line() so far */
    int eof;               /* no more bytes beyond end */
    int failed;            /* a read or decode error was recorded in err */

    int fd;
    int own_fd;
    uint64_t file_size;    /* 0 if unknown */
    uint64_t raw_read;     /* bytes read from fd */

    void *zstd;            /* ZSTD_DStream*, NULL for plain input */
    uint8_t *zin;
    size_t zin_len, zin_pos, zin_cap;
    int zframe_open;       /* inside a zstd frame that has not ended */

    char *path;            /* for messages */
    epsnet_error err;      /* first failure */

    /* Reading ahead on a pool's worker (en_source_use_pool), NULL when not:
     * then the fd and the zstd fields above are the job's while one runs. */
    struct en_source_ahead *ahead;
} en_source;

/* Open path ("-" = stdin). @return 0 or a negative code with err filled;
 * on failure *s is NULL. */
int en_source_open(en_source **s, const char *path, epsnet_error *err);
void en_source_close(en_source **s);

/*
 * Make at least want bytes available in [cur, end) unless the input ends
 * first. @return the number of bytes available (< want only at end of input
 * or on error; check s->failed). want must be <= 1 MiB.
 */
size_t en_source_fill(en_source *s, size_t want);

struct en_pool;

/*
 * Read (and decompress) the next chunk on one of pool's workers while the
 * caller parses the window, from the bytes after those read so far; the
 * window's contents and every offset and error are the same as without.
 * pool NULL, or one that runs jobs inline: stop, waiting for the chunk in
 * flight, whose bytes are still handed out, before reading goes on on the
 * caller's thread. Call with NULL before the pool is freed (closing the
 * source stops it too). @return 0 or EPSNET_ENOMEM (it reads on the
 * caller's thread, as before).
 */
int en_source_use_pool(en_source *s, struct en_pool *pool);

/* Offset of cur in the decompressed stream. */
static inline uint64_t en_source_offset(const en_source *s)
{
    return s->base + (uint64_t)(s->cur - s->buf);
}

/* The bytes of a UTF-8 byte-order mark at p (3), or 0. Windows editors
 * start a text with one; it is no part of the first line, which
 * en_source_line() returns without it, and a reader that sniffs the first
 * bytes for a word looks past it. */
static inline size_t en_source_utf8_bom(const uint8_t *p, size_t n)
{
    return n >= 3 && p[0] == 0xef && p[1] == 0xbb && p[2] == 0xbf ? 3 : 0;
}

/*
 * Next text line, without its '\n' or "\r\n" (nor the first line its
 * UTF-8 byte-order mark), NUL-terminated in place.
 * @return 1 with line and len set, 0 at end of input, or a negative code with
 * err filled (a line longer than max_len, a read error, a NUL byte).
 */
int en_source_line(en_source *s, char **line, size_t *len, size_t max_len,
                   epsnet_error *err);

/*
 * Copy exactly n bytes into dst. @return 0, or EPSNET_EFORMAT (truncated:
 * the message says what was expected, from what) / EPSNET_EIO with err
 * filled. what names the item being read, e.g. "vertex 12".
 */
int en_source_read(en_source *s, void *dst, size_t n, const char *what,
                   epsnet_error *err);

/* Copy the source's own failure (I/O or zstd) into err and return its code. */
int en_source_error(const en_source *s, epsnet_error *err);

/* True when the file name ends with ".zst" (case-insensitive). */
int en_path_has_zst(const char *path);

#endif /* EN_IO_SOURCE_H */
