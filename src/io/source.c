#include "io/source.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include "common/alloc.h"
#include "common/error.h"
#include "common/pool.h"

/* The read window; fill() never asks for more than half. Fuzz builds shrink it
 * (meson.build): under ASan a 2 MiB buffer per input is mapped and unmapped
 * every time, which was 80% of the campaign's CPU. Fuzz inputs stay far below
 * 64 KiB, so no reachable path changes except refills at smaller offsets. */
#ifndef EN_SOURCE_CAP
#define EN_SOURCE_CAP (2u << 20)
#endif
#define EN_ZSTD_MAGIC 0xFD2FB528u

int en_path_has_zst(const char *path)
{
    size_t n = strlen(path);
    return n >= 4 && strcasecmp(path + n - 4, ".zst") == 0;
}

static int src_fail(en_source *s, int code, const char *fmt, const char *detail)
{
    if (!s->failed) {
        s->failed = 1;
        en_error_set(&s->err, code, s->path, EPSNET_POS_NONE, en_source_offset(s), fmt, detail);
        s->err.zst = s->zstd != NULL;
    }
    return code;
}

/* A failure met while reading, held until the caller's thread reaches it
 * (a chunk read ahead fails on a worker, but the window reports it where
 * the bytes run out, as the caller's own read would have). */
typedef struct read_failure {
    int code;              /* 0: none */
    const char *fmt;       /* one %s, for detail */
    const char *detail;    /* a static string, or NULL for strerror(errnum) */
    int errnum;
} read_failure;

static void note_failure(read_failure *f, int code, const char *fmt, const char *detail, int errnum)
{
    *f = (read_failure){ code, fmt, detail, errnum };
}

static int take_failure(en_source *s, const read_failure *f)
{
    return src_fail(s, f->code, f->fmt, f->detail ? f->detail : strerror(f->errnum));
}

/* Read raw bytes from the fd, counted in *raw; returns bytes read, 0 at
 * EOF, -1 on error (noted in f). */
static ssize_t raw_read(en_source *s, uint8_t *dst, size_t n, uint64_t *raw, read_failure *f)
{
    for (;;) {
        ssize_t k = read(s->fd, dst, n);
        if (k >= 0) {
            *raw += (uint64_t)k;
            return k;
        }
        if (errno != EINTR) {
            note_failure(f, EPSNET_EIO, "read failed: %s", NULL, errno);
            return -1;
        }
    }
}

/* Append up to room bytes of decompressed data at dst. */
static ssize_t produce(en_source *s, uint8_t *dst, size_t room, uint64_t *raw, read_failure *f)
{
    if (!s->zstd)
        return raw_read(s, dst, room, raw, f);
    ZSTD_outBuffer out = { dst, room, 0 };
    while (out.pos == 0) {
        if (s->zin_pos == s->zin_len) {
            ssize_t k = raw_read(s, s->zin, s->zin_cap, raw, f);
            if (k < 0)
                return -1;
            if (k == 0) {
                if (s->zframe_open) {
                    note_failure(f, EPSNET_EFORMAT, "%s", "truncated zstd stream", 0);
                    return -1;
                }
                return 0;
            }
            s->zin_len = (size_t)k;
            s->zin_pos = 0;
        }
        ZSTD_inBuffer in = { s->zin, s->zin_len, s->zin_pos };
        size_t r = ZSTD_decompressStream(s->zstd, &out, &in);
        s->zin_pos = in.pos;
        if (ZSTD_isError(r)) {
            note_failure(f, EPSNET_EFORMAT, "corrupt zstd data: %s", ZSTD_getErrorName(r), 0);
            return -1;
        }
        s->zframe_open = r != 0;
    }
    return (ssize_t)out.pos;
}

/* ---- reading ahead on a worker (en_source_use_pool) ----
 * note: two chunks, the one the window is taking bytes from and the one a
 * job fills meanwhile; the ring holds one job. A chunk's bytes are copied
 * into the window (a memcpy beside the read's own copy out of the kernel,
 * which is what moves off the caller's thread), so the window, its
 * offsets and its errors are those of reading on the caller's thread. */
#define AHEAD_CHUNK (EN_SOURCE_CAP / 2)

typedef struct ahead_chunk {
    en_source *s;
    uint8_t *data;
    /* The job's until retired: */
    size_t len;            /* bytes read into data */
    uint64_t raw;          /* bytes read from the fd for them */
    int end;               /* the input ended after them */
    read_failure failed;   /* or failed after them */
    /* The caller's: */
    size_t pos;            /* bytes handed to the window */
    int state;             /* CHUNK_* */
} ahead_chunk;

enum { CHUNK_FREE, CHUNK_FILLING, CHUNK_READY, CHUNK_TAKING };

struct en_source_ahead {
    en_jobring *ring;      /* NULL once stopped: what was read is still handed out */
    ahead_chunk c[2];
};

static int fill_chunk(void *job)
{
    ahead_chunk *c = job;
    c->len = 0;
    c->raw = 0;
    c->end = 0;
    c->failed.code = 0;
    while (c->len < AHEAD_CHUNK) {
        ssize_t k = produce(c->s, c->data + c->len, AHEAD_CHUNK - c->len, &c->raw, &c->failed);
        if (k < 0)
            break;
        if (k == 0) {
            c->end = 1;
            break;
        }
        c->len += (size_t)k;
    }
    return 0;
}

/* (A refused submit, which one slot retired before cannot meet, leaves c
 * free: the window then reads on the caller's thread.) */
static void chunk_submit(struct en_source_ahead *a, ahead_chunk *c)
{
    c->state = en_jobring_submit(a->ring, fill_chunk, c) == 0 ? CHUNK_FILLING : CHUNK_FREE;
}

/* The in-flight chunk, once read (the caller's thread waits for it). */
static void chunk_retire(en_source *s, struct en_source_ahead *a)
{
    void *job;
    int result;
    if (!a->ring || en_jobring_retire(a->ring, &job, &result) != 1)
        return;
    ahead_chunk *c = job;
    c->state = CHUNK_READY;
    c->pos = 0;
    s->raw_read += c->raw;
}

/* The chunk to take bytes from next, or NULL: the input has ended or
 * failed (s->eof or s->failed is then set), or, with reading ahead
 * stopped and nothing read ahead left, it goes on on the caller's thread
 * (*sync set). */
static ahead_chunk *ahead_take(en_source *s, int *sync)
{
    struct en_source_ahead *a = s->ahead;
    *sync = 0;
    for (int i = 0; i < 2; i++) {
        ahead_chunk *c = &a->c[i];
        if (c->state != CHUNK_TAKING)
            continue;
        if (c->pos < c->len)
            return c;
        if (c->end || c->failed.code) {
            if (c->failed.code)
                take_failure(s, &c->failed);
            else
                s->eof = 1;
            return NULL;
        }
        c->state = CHUNK_FREE;
    }
    chunk_retire(s, a);
    for (int i = 0; i < 2; i++) {
        ahead_chunk *c = &a->c[i], *other = &a->c[1 - i];
        if (c->state != CHUNK_READY)
            continue;
        c->state = CHUNK_TAKING;
        if (a->ring && !c->end && !c->failed.code && other->state == CHUNK_FREE)
            chunk_submit(a, other);
        return ahead_take(s, sync);
    }
    *sync = 1;
    return NULL;
}

static void ahead_stop(en_source *s)
{
    struct en_source_ahead *a = s->ahead;
    if (!a || !a->ring)
        return;
    chunk_retire(s, a);
    en_jobring_free(&a->ring, NULL);
}

static void ahead_free(en_source *s)
{
    struct en_source_ahead *a = s->ahead;
    if (!a)
        return;
    ahead_stop(s);
    en_free(a->c[0].data);
    en_free(a->c[1].data);
    en_free(a);
    s->ahead = NULL;
}

int en_source_use_pool(en_source *s, en_pool *pool)
{
    if (!pool || en_pool_threads(pool) == 0) {
        ahead_stop(s); /* its chunks' bytes still come first */
        return 0;
    }
    if (s->ahead || s->eof || s->failed)
        return 0; /* reading ahead already, or nothing left to read */
    struct en_source_ahead *a = en_calloc(1, sizeof *a);
    if (!a)
        return EPSNET_ENOMEM;
    a->c[0].data = en_malloc(AHEAD_CHUNK);
    a->c[1].data = en_malloc(AHEAD_CHUNK);
    if (!a->c[0].data || !a->c[1].data || en_jobring_new(&a->ring, pool, 1)) {
        en_free(a->c[0].data);
        en_free(a->c[1].data);
        en_free(a);
        return EPSNET_ENOMEM;
    }
    a->c[0].s = a->c[1].s = s;
    s->ahead = a;
    chunk_submit(a, &a->c[0]);
    return 0;
}

size_t en_source_fill(en_source *s, size_t want)
{
    size_t avail = (size_t)(s->end - s->cur);
    if (avail >= want || s->eof || s->failed)
        return avail;
    /* Slide the unconsumed tail to the front, then top up. */
    size_t off = (size_t)(s->cur - s->buf);
    if (off) {
        memmove(s->buf, s->cur, avail);
        s->base += off;
        s->cur = s->buf;
        s->end = s->buf + avail;
    }
    while (avail < want) {
        /* note: one byte stays spare so en_source_line() can always NUL-terminate
         * a last line that has no newline. */
        int sync = 1;
        if (s->ahead) {
            ahead_chunk *c = ahead_take(s, &sync);
            if (c) {
                size_t k = c->len - c->pos, room = s->cap - 1 - avail;
                k = k < room ? k : room;
                memcpy(s->buf + avail, c->data + c->pos, k);
                c->pos += k;
                avail += k;
                s->end = s->buf + avail;
                continue;
            }
            if (!sync)
                break; /* the end, or a failure, reached where the caller's read would */
        }
        read_failure f;
        ssize_t k = produce(s, s->buf + avail, s->cap - 1 - avail, &s->raw_read, &f);
        if (k < 0) {
            take_failure(s, &f);
            break;
        }
        if (k == 0) {
            s->eof = 1;
            break;
        }
        avail += (size_t)k;
        s->end = s->buf + avail;
    }
    return avail;
}

int en_source_open(en_source **out, const char *path, epsnet_error *err)
{
    *out = NULL;
    en_source *s = en_calloc(1, sizeof *s);
    if (!s)
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    s->fd = -1;
    s->path = en_strdup(path);
    s->cap = EN_SOURCE_CAP;
    s->buf = en_malloc(s->cap);
    if (!s->path || !s->buf) {
        en_source_close(&s);
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    s->cur = s->end = s->buf;
    if (strcmp(path, "-") == 0) {
        s->fd = 0;
    } else {
        s->fd = open(path, O_RDONLY | O_CLOEXEC);
        if (s->fd < 0) {
            int e = errno;
            en_source_close(&s);
            return en_error_set(err, EPSNET_EIO, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "cannot open: %s", strerror(e));
        }
        s->own_fd = 1;
        struct stat st;
        if (fstat(s->fd, &st) == 0) {
            if (S_ISDIR(st.st_mode)) {
                en_source_close(&s);
                return en_error_set(err, EPSNET_EIO, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                    "is a directory");
            }
            if (S_ISREG(st.st_mode))
                s->file_size = (uint64_t)st.st_size;
        }
#ifdef POSIX_FADV_SEQUENTIAL
        posix_fadvise(s->fd, 0, 0, POSIX_FADV_SEQUENTIAL);
#endif
    }
    /* Sniff the zstd magic on the raw bytes before any decoding. */
    read_failure f;
    ssize_t k = raw_read(s, s->buf, 4, &s->raw_read, &f);
    while (k > 0 && k < 4) {
        ssize_t more = raw_read(s, s->buf + k, (size_t)(4 - k), &s->raw_read, &f);
        if (more < 0)
            take_failure(s, &f); /* the reader reports it at its first fill */
        if (more <= 0)
            break;
        k += more;
    }
    if (k < 0) {
        take_failure(s, &f);
        int rc = en_source_error(s, err);
        en_source_close(&s);
        return rc;
    }
    uint32_t magic = 0;
    if (k == 4)
        magic = (uint32_t)s->buf[0] | (uint32_t)s->buf[1] << 8 |
                (uint32_t)s->buf[2] << 16 | (uint32_t)s->buf[3] << 24;
    if (magic == EN_ZSTD_MAGIC) {
        s->zstd = ZSTD_createDStream();
        s->zin_cap = ZSTD_DStreamInSize();
        s->zin = en_malloc(s->zin_cap > 4 ? s->zin_cap : 4);
        if (!s->zstd || !s->zin) {
            en_source_close(&s);
            return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
        }
        ZSTD_initDStream(s->zstd);
        memcpy(s->zin, s->buf, 4);
        s->zin_len = 4;
        s->zin_pos = 0;
        s->zframe_open = 1;
    } else if (en_path_has_zst(path)) {
        en_source_close(&s);
        return en_error_set(err, EPSNET_EFORMAT, path, EPSNET_POS_NONE, 0,
                            "name ends in .zst but the data is not zstd-compressed");
    } else {
        s->end = s->buf + (k > 0 ? k : 0);
    }
    *out = s;
    return 0;
}

void en_source_close(en_source **ps)
{
    en_source *s = ps ? *ps : NULL;
    if (!s)
        return;
    ahead_free(s); /* first: a chunk in flight reads the fd */
    if (s->own_fd && s->fd >= 0)
        close(s->fd);
    if (s->zstd)
        ZSTD_freeDStream(s->zstd);
    en_free(s->zin);
    en_free(s->buf);
    en_free(s->path);
    en_free(s);
    *ps = NULL;
}

int en_source_error(const en_source *s, epsnet_error *err)
{
    if (err)
        *err = s->err;
    return s->err.code ? s->err.code : EPSNET_EIO;
}

/* UTF-16 text: a byte-order mark, or ASCII with every other byte NUL (the
 * first 32 bytes of the line say so; binary data rarely alternates). */
static int looks_utf16(const uint8_t *p, size_t n)
{
    if (n >= 2 && ((p[0] == 0xff && p[1] == 0xfe) || (p[0] == 0xfe && p[1] == 0xff)))
        return 1;
    n = n < 32 ? n & ~(size_t)1 : 32;
    if (n < 8)
        return 0;
    int even = 1, odd = 1;
    for (size_t i = 0; i < n; i += 2) {
        even &= p[i] == 0 && p[i + 1] >= 0x09 && p[i + 1] < 0x7f;
        odd &= p[i + 1] == 0 && p[i] >= 0x09 && p[i] < 0x7f;
    }
    return even || odd;
}

/* The first line without a UTF-8 byte-order mark: kept, it made an OBJ's
 * first statement an unknown '???v', dropped, and every face index after
 * it named the wrong vertex. */
static void skip_utf8_bom(const en_source *s, char **p, size_t *n)
{
    size_t k = s->lineno == 0 ? en_source_utf8_bom((const uint8_t *)*p, *n) : 0;
    *p += k;
    *n -= k;
}

int en_source_line(en_source *s, char **line, size_t *len, size_t max_len,
                   epsnet_error *err)
{
    if (max_len > EN_SOURCE_CAP / 2)
        max_len = EN_SOURCE_CAP / 2;
    size_t scanned = 0;
    for (;;) {
        size_t avail = (size_t)(s->end - s->cur);
        uint8_t *nl = avail > scanned ? memchr(s->cur + scanned, '\n', avail - scanned) : NULL;
        if (nl) {
            size_t n = (size_t)(nl - s->cur);
            if (n > max_len)
                goto too_long;
            char *p = (char *)s->cur;
            if (memchr(p, '\0', n))
                goto nul_byte;
            *nl = '\0';
            if (n && p[n - 1] == '\r')
                p[--n] = '\0';
            s->cur = nl + 1;
            skip_utf8_bom(s, &p, &n);
            s->lineno++;
            *line = p;
            *len = n;
            return 1;
        }
        scanned = avail;
        if (avail > max_len)
            goto too_long;
        if (s->eof || s->failed) {
            if (s->failed)
                return en_source_error(s, err);
            if (avail == 0)
                return 0;
            /* Last line without a newline: terminate it in the spare room
             * (fill() keeps the window strictly smaller than the buffer). */
            char *p = (char *)s->cur;
            if (memchr(p, '\0', avail))
                goto nul_byte;
            size_t n = avail;
            p[n] = '\0';
            if (n && p[n - 1] == '\r')
                p[--n] = '\0';
            s->cur = s->end;
            skip_utf8_bom(s, &p, &n);
            s->lineno++;
            *line = p;
            *len = n;
            return 1;
        }
        size_t before = avail;
        /* fill() slides the window, so scanned offsets stay valid relative to cur */
        en_source_fill(s, before + 1);
        if ((size_t)(s->end - s->cur) == before && !s->eof && !s->failed)
            goto too_long;
    }
too_long:
    return en_error_set(err, EPSNET_EFORMAT, s->path, s->lineno + 1, EPSNET_POS_NONE,
                        "line longer than %zu bytes", max_len);
nul_byte:
    if (looks_utf16(s->cur, (size_t)(s->end - s->cur)))
        return en_error_set(err, EPSNET_EFORMAT, s->path, s->lineno + 1, EPSNET_POS_NONE,
                            "UTF-16 text: convert it to UTF-8 first "
                            "(iconv -f UTF-16 -t UTF-8)");
    return en_error_set(err, EPSNET_EFORMAT, s->path, s->lineno + 1, EPSNET_POS_NONE,
                        "NUL byte in a text file (binary data?)");
}

int en_source_read(en_source *s, void *dst, size_t n, const char *what,
                   epsnet_error *err)
{
    uint8_t *d = dst;
    while (n) {
        size_t want = n < EN_SOURCE_CAP / 2 ? n : EN_SOURCE_CAP / 2;
        size_t avail = en_source_fill(s, want);
        if (avail == 0) {
            if (s->failed)
                return en_source_error(s, err);
            int rc = en_error_set(err, EPSNET_EFORMAT, s->path, EPSNET_POS_NONE,
                                  en_source_offset(s), "truncated file: unexpected end of data in %s", what);
            if (err)
                err->zst = s->zstd != NULL;
            return rc;
        }
        size_t k = avail < n ? avail : n;
        memcpy(d, s->cur, k);
        s->cur += k;
        d += k;
        n -= k;
    }
    return 0;
}
