#include "io/sink.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include "common/alloc.h"
#include "common/error.h"
#include "common/fault.h"
#include "common/pool.h"

#define EN_SINK_BUF (1u << 20)
#define SPILL_PLAIN_BUF ((size_t)128 << 10)

/* Full-disk injection (tests/test_fault_injection.py): with EPSNET_FAIL_WRITE=N
 * the N-th write to an output or temporary file and every later one fail
 * with ENOSPC, so each write error path is walked like a full disk. */
static en_fault en_write_fault = EN_FAULT_INIT("EPSNET_FAIL_WRITE");

static ssize_t disk_write(int fd, const void *p, size_t n)
{
    if (en_fault_hit(&en_write_fault)) {
        errno = ENOSPC;
        return -1;
    }
    return write(fd, p, n);
}

static ssize_t disk_pwrite(int fd, const void *p, size_t n, off_t offset)
{
    if (en_fault_hit(&en_write_fault)) {
        errno = ENOSPC;
        return -1;
    }
    return pwrite(fd, p, n, offset);
}

/* ---- registry of named temporaries, for signal-time cleanup ----
 * note: used when O_TMPFILE is unavailable (anonymous files need no cleanup
 * at all, which is why they are tried first). Slots are claimed with
 * atomics so a handler never sees a half-written path. */
#define EN_TEMP_SLOTS 64
static char en_temp_paths[EN_TEMP_SLOTS][PATH_MAX];
static volatile sig_atomic_t en_temp_used[EN_TEMP_SLOTS];

int en_temp_register(const char *path)
{
    for (int i = 0; i < EN_TEMP_SLOTS; i++) {
        sig_atomic_t expected = 0;
        if (__atomic_compare_exchange_n(&en_temp_used[i], &expected, 2, 0,
                                        __ATOMIC_ACQ_REL, __ATOMIC_RELAXED)) {
            snprintf(en_temp_paths[i], PATH_MAX, "%s", path);
            __atomic_store_n(&en_temp_used[i], 1, __ATOMIC_RELEASE);
            return i;
        }
    }
    return -1;
}

void en_temp_unregister(int slot)
{
    if (slot >= 0)
        __atomic_store_n(&en_temp_used[slot], 0, __ATOMIC_RELEASE);
}

int en_temp_create(const char *dir, const char *prefix, const char *suffix, mode_t mode,
                   char *path, size_t cap, int *slot)
{
    static unsigned serial;
    for (unsigned attempt = 0; attempt < 1000; attempt++) {
        unsigned k = __atomic_fetch_add(&serial, 1, __ATOMIC_RELAXED);
        int len = snprintf(path, cap, "%s/%s%ld-%u%s", dir, prefix, (long)getpid(), k, suffix);
        if (len < 0 || (size_t)len >= cap) {
            errno = ENAMETOOLONG;
            break;
        }
        *slot = en_temp_register(path);
        int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
        if (fd >= 0)
            return fd;
        int e = errno;
        en_temp_unregister(*slot);
        *slot = -1;
        errno = e;
        if (e != EEXIST)
            break;
    }
    *slot = -1;
    return -1;
}

void en_tempfiles_cleanup_signal_safe(void)
{
    for (int i = 0; i < EN_TEMP_SLOTS; i++)
        if (__atomic_load_n(&en_temp_used[i], __ATOMIC_ACQUIRE) == 1)
            unlink(en_temp_paths[i]);
}

void epsnet_remove_temporaries(void)
{
    en_tempfiles_cleanup_signal_safe();
}

/* ---- the sink ---- */

struct en_sink {
    int fd;
    int is_stdout;
    int anonymous;           /* O_TMPFILE: linked into place at commit */
    int in_place;            /* an existing device or pipe, written directly */
    int temp_slot;           /* registry slot of a named temporary, or -1 */
    char *path;              /* destination */
    char *dir;               /* destination directory */
    char *tmp_path;          /* named temporary, NULL when anonymous */
    uint8_t *buf;
    size_t len;
    uint64_t offset;         /* bytes accepted (uncompressed) */
    ZSTD_CStream *zc;
    uint8_t *zout;
    size_t zout_cap;
    int failed;
    int settled;             /* en_sink_settle flushed everything: commit only moves it */
    epsnet_error err;
};

const char *en_sink_path(const en_sink *s)
{
    return s->path;
}

static int sink_fail_errno(en_sink *s, int e, const char *what, epsnet_error *err)
{
    if (!s->failed) {
        s->failed = 1;
        en_error_set(&s->err, en_error_from_errno(e), s->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                     "%s: %s", what, strerror(e));
    }
    if (err)
        *err = s->err;
    return s->err.code;
}

static int write_all(en_sink *s, const uint8_t *p, size_t n, epsnet_error *err)
{
    while (n) {
        ssize_t k = disk_write(s->fd, p, n);
        if (k < 0) {
            if (errno == EINTR)
                continue;
            return sink_fail_errno(s, errno, "write failed", err);
        }
        if (k == 0)
            return sink_fail_errno(s, ENOSPC, "write failed", err);
        p += k;
        n -= (size_t)k;
    }
    return 0;
}

static int flush_buf(en_sink *s, ZSTD_EndDirective mode, epsnet_error *err)
{
    if (!s->zc) {
        int rc = write_all(s, s->buf, s->len, err);
        s->len = 0;
        return rc;
    }
    ZSTD_inBuffer in = { s->buf, s->len, 0 };
    for (;;) {
        ZSTD_outBuffer out = { s->zout, s->zout_cap, 0 };
        size_t r = ZSTD_compressStream2(s->zc, &out, &in, mode);
        if (ZSTD_isError(r)) {
            s->failed = 1;
            en_error_set(&s->err, EPSNET_EIO, s->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                         "zstd compression failed: %s", ZSTD_getErrorName(r));
            if (err)
                *err = s->err;
            return s->err.code;
        }
        if (out.pos && write_all(s, s->zout, out.pos, err))
            return s->err.code;
        if (mode == ZSTD_e_end ? r == 0 : in.pos == in.size)
            break;
    }
    s->len = 0;
    return 0;
}

static char *dir_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        return en_strdup(".");
    if (slash == path)
        return en_strdup("/");
    size_t n = (size_t)(slash - path);
    char *d = en_malloc(n + 1);
    if (d) {
        memcpy(d, path, n);
        d[n] = '\0';
    }
    return d;
}

int en_sink_open(en_sink **out, const char *path, int zstd_level, epsnet_error *err)
{
    *out = NULL;
    en_sink *s = en_calloc(1, sizeof *s);
    if (!s)
        return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    s->fd = -1;
    s->temp_slot = -1;
    s->path = en_strdup(path);
    s->dir = s->path ? dir_of(path) : NULL;
    s->buf = en_malloc(EN_SINK_BUF);
    if (!s->path || !s->dir || !s->buf)
        goto nomem;
    if (zstd_level > 0) {
        s->zc = ZSTD_createCStream();
        s->zout_cap = ZSTD_CStreamOutSize();
        s->zout = en_malloc(s->zout_cap);
        if (!s->zc || !s->zout)
            goto nomem;
        ZSTD_CCtx_setParameter(s->zc, ZSTD_c_compressionLevel, zstd_level);
        ZSTD_CCtx_setParameter(s->zc, ZSTD_c_checksumFlag, 1);
    }
    if (strcmp(path, "-") == 0) {
        s->fd = 1;
        s->is_stdout = 1;
        *out = s;
        return 0;
    }
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode)) {
        en_sink_abort(&s);
        return en_error_set(err, EPSNET_EIO, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "output path is a directory");
    }
    if (stat(s->dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
        int rc = en_error_set(err, EPSNET_EIO, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                              "the output's folder %s does not exist", s->dir);
        en_sink_abort(&s);
        return rc;
    }
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
        /* note: a device or pipe (-o /dev/null, a FIFO) is written in place;
         * renaming a temporary over it would replace the device itself. */
        s->fd = open(path, O_WRONLY | O_CLOEXEC);
        if (s->fd < 0) {
            int e = errno;
            en_sink_abort(&s);
            return en_error_set(err, en_error_from_errno(e), path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "cannot open output: %s", strerror(e));
        }
        s->in_place = 1;
        *out = s;
        return 0;
    }
#ifdef O_TMPFILE
    /* Anonymous until commit, so a crash or SIGKILL leaves nothing behind;
     * linking it later needs /proc. */
    if (access("/proc/self/fd", X_OK) == 0)
        s->fd = open(s->dir, O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
    if (s->fd >= 0) {
        /* O_TMPFILE ignores the umask-derived mode of a linked name on
         * some kernels; give the final file ordinary permissions. */
        mode_t um = umask(0);
        umask(um);
        fchmod(s->fd, 0666 & ~um);
        s->anonymous = 1;
    }
#endif
    if (s->fd < 0) {
        const char *base = strrchr(path, '/');
        base = base ? base + 1 : path;
        size_t n = strlen(s->dir) + strlen(base) + 48;
        s->tmp_path = en_malloc(n);
        if (!s->tmp_path)
            goto nomem;
        char prefix[PATH_MAX];
        snprintf(prefix, sizeof prefix, ".%s.epsnet-", base);
        s->fd = en_temp_create(s->dir, prefix, "", 0666, s->tmp_path, n, &s->temp_slot);
        if (s->fd < 0) {
            int e = errno;
            en_free(s->tmp_path);
            s->tmp_path = NULL;
            en_sink_abort(&s);
            return en_error_set(err, en_error_from_errno(e), path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "cannot create output: %s", strerror(e));
        }
    }
    *out = s;
    return 0;
nomem:
    en_sink_abort(&s);
    return en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
}

int en_sink_write(en_sink *s, const void *data, size_t n, epsnet_error *err)
{
    if (s->failed) {
        if (err)
            *err = s->err;
        return s->err.code;
    }
    const uint8_t *p = data;
    s->offset += n;
    while (n) {
        size_t room = EN_SINK_BUF - s->len;
        size_t k = n < room ? n : room;
        memcpy(s->buf + s->len, p, k);
        s->len += k;
        p += k;
        n -= k;
        if (s->len == EN_SINK_BUF && flush_buf(s, ZSTD_e_continue, err))
            return s->err.code;
    }
    return 0;
}

uint64_t en_sink_offset(const en_sink *s)
{
    return s->offset;
}

int en_sink_can_patch(const en_sink *s)
{
    return !s->zc && !s->is_stdout && !s->in_place;
}

int en_sink_patch(en_sink *s, uint64_t offset, const void *data, size_t n, epsnet_error *err)
{
    if (!en_sink_can_patch(s))
        return en_error_set(err, EPSNET_EUNSUPPORTED, s->path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "cannot rewrite a compressed or piped output");
    if (flush_buf(s, ZSTD_e_continue, err))
        return s->err.code;
    const uint8_t *p = data;
    while (n) {
        ssize_t k = disk_pwrite(s->fd, p, n, (off_t)offset);
        if (k < 0) {
            if (errno == EINTR)
                continue;
            return sink_fail_errno(s, errno, "write failed", err);
        }
        p += k;
        offset += (uint64_t)k;
        n -= (size_t)k;
    }
    return 0;
}

static void sink_free(en_sink *s)
{
    if (s->zc)
        ZSTD_freeCStream(s->zc);
    en_free(s->zout);
    en_free(s->buf);
    en_free(s->tmp_path);
    en_free(s->dir);
    en_free(s->path);
    en_free(s);
}

void en_sink_abort(en_sink **ps)
{
    en_sink *s = ps ? *ps : NULL;
    if (!s)
        return;
    if (s->fd >= 0 && !s->is_stdout)
        close(s->fd);
    if (s->tmp_path) {
        unlink(s->tmp_path);
        en_temp_unregister(s->temp_slot);
    }
    sink_free(s);
    *ps = NULL;
}

int en_sink_settle(en_sink *s, epsnet_error *err)
{
    if (s->failed) {
        if (err)
            *err = s->err;
        return s->err.code;
    }
    int rc = s->settled ? 0 : flush_buf(s, s->zc ? ZSTD_e_end : ZSTD_e_continue, err);
    s->settled = rc == 0;
    return rc;
}

int en_sink_commit(en_sink **ps, epsnet_error *err)
{
    en_sink *s = *ps;
    int rc = 0;
    if (s->failed) {
        rc = s->err.code;
        if (err)
            *err = s->err;
        goto fail;
    }
    if ((rc = en_sink_settle(s, err)))
        goto fail;
    if (s->is_stdout) {
        sink_free(s);
        *ps = NULL;
        return 0;
    }
    if (s->in_place) {
        int bad = close(s->fd) != 0;
        int e = errno;
        s->fd = -1;
        if (bad) {
            rc = sink_fail_errno(s, e, "close failed", err);
            goto fail;
        }
        sink_free(s);
        *ps = NULL;
        return 0;
    }
    if (s->anonymous) {
        /* note: linkat() cannot replace an existing file, so the anonymous
         * file gets a unique name first and is then renamed over the
         * destination, which is atomic. */
        char fdpath[64];
        snprintf(fdpath, sizeof fdpath, "/proc/self/fd/%d", s->fd);
        const char *base = strrchr(s->path, '/');
        base = base ? base + 1 : s->path;
        size_t n = strlen(s->dir) + strlen(base) + 48;
        s->tmp_path = en_malloc(n);
        if (!s->tmp_path) {
            rc = sink_fail_errno(s, ENOMEM, "cannot move output into place", err);
            goto fail;
        }
        for (unsigned attempt = 0;; attempt++) {
            snprintf(s->tmp_path, n, "%s/.%s.epsnet-%ld-%u", s->dir, base, (long)getpid(), attempt);
            s->temp_slot = en_temp_register(s->tmp_path);
            if (linkat(AT_FDCWD, fdpath, AT_FDCWD, s->tmp_path, AT_SYMLINK_FOLLOW) == 0)
                break;
            int e = errno;
            en_temp_unregister(s->temp_slot);
            s->temp_slot = -1;
            if (e != EEXIST || attempt > 100) {
                en_free(s->tmp_path);
                s->tmp_path = NULL;
                rc = sink_fail_errno(s, e, "cannot move output into place", err);
                goto fail;
            }
        }
    }
    if (close(s->fd) != 0) {
        int e = errno;
        s->fd = -1;
        rc = sink_fail_errno(s, e, "close failed", err);
        goto fail;
    }
    s->fd = -1;
    if (s->tmp_path) {
        if (rename(s->tmp_path, s->path) != 0) {
            rc = sink_fail_errno(s, errno, "cannot move output into place", err);
            goto fail;
        }
        en_temp_unregister(s->temp_slot);
        en_free(s->tmp_path);
        s->tmp_path = NULL;
    }
    sink_free(s);
    *ps = NULL;
    return 0;
fail:
    en_sink_abort(ps);
    return rc;
}

/* ---- spill files ---- */

/* A staged buffer of a plain spill, written on a worker (en_spill_write_behind). */
typedef struct spill_job {
    en_spill *sp;
    uint8_t *buf;
    size_t len;
    uint64_t written;       /* the worker's, read after retire */
    epsnet_error err;       /* the same */
} spill_job;

struct en_spill {
    int fd;
    char *owner;            /* for messages */
    int reading;
    int plain;              /* no zstd: zbuf stages the bytes themselves */
    ZSTD_CStream *zc;
    ZSTD_DStream *zd;
    uint8_t *zbuf;          /* compressed staging, both directions; plain: the
                               write staging (freed at rewind) */
    size_t zcap, zlen, zpos;
    int eof;
    uint64_t disk;
    /* write behind (plain, writing): zbuf is filled while job writes the
     * buffer before it; job.buf is the spare when ring holds nothing */
    en_jobring *ring;
    spill_job job;
    int busy;
};

static int spill_open(en_spill **out, const char *dir, const char *owner, int plain, epsnet_error *err)
{
    *out = NULL;
    if (!dir || !*dir)
        dir = getenv("TMPDIR");
    if (!dir || !*dir)
        dir = "/tmp";
    en_spill *sp = en_calloc(1, sizeof *sp);
    if (!sp)
        return en_error_set(err, EPSNET_ENOMEM, dir, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    sp->fd = -1;
    sp->owner = en_strdup(owner ? owner : dir);
    if (!sp->owner) {
        en_free(sp);
        return en_error_set(err, EPSNET_ENOMEM, dir, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
#ifdef O_TMPFILE
    sp->fd = open(dir, O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
#endif
    if (sp->fd < 0) {
        /* note: unlinked right away, so nothing can be left behind. */
        size_t n = strlen(dir) + 32;
        char *path = en_malloc(n);
        if (path) {
            snprintf(path, n, "%s/.epsnet-spill-XXXXXX", dir);
            sp->fd = mkostemp(path, O_CLOEXEC);
            if (sp->fd >= 0)
                unlink(path);
            en_free(path);
        }
    }
    if (sp->fd < 0) {
        int e = errno;
        en_spill_close(&sp);
        if (e == ENOENT || e == ENOTDIR)
            return en_error_set(err, EPSNET_EIO, dir, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "cannot create a temporary file: the folder %s does not exist", dir);
        return en_error_set(err, en_error_from_errno(e), dir, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "cannot create a temporary file: %s", strerror(e));
    }
    sp->plain = plain;
    sp->zc = plain ? NULL : ZSTD_createCStream();
    sp->zcap = plain ? SPILL_PLAIN_BUF : ZSTD_CStreamOutSize();
    sp->zbuf = en_malloc(sp->zcap);
    if ((!plain && !sp->zc) || !sp->zbuf) {
        en_spill_close(&sp);
        return en_error_set(err, EPSNET_ENOMEM, dir, EPSNET_POS_NONE, EPSNET_POS_NONE, "out of memory");
    }
    /* note: a fast level. A spill is read back once or twice: at level 1
     * compressing the sort's spills was a third of its time; at -7 it
     * needed 28% less CPU (2M faces, --mem 64M) for 40% more temporary
     * bytes. The sort now writes plain spills (docs/architecture.md §13):
     * even -7 cost more time than the bytes it saved. */
    if (!plain)
        ZSTD_CCtx_setParameter(sp->zc, ZSTD_c_compressionLevel, -7);
    *out = sp;
    return 0;
}

int en_spill_open(en_spill **out, const char *dir, const char *owner, epsnet_error *err)
{
    return spill_open(out, dir, owner, 0, err);
}

int en_spill_open_plain(en_spill **out, const char *dir, const char *owner, epsnet_error *err)
{
    return spill_open(out, dir, owner, 1, err);
}

static int spill_io_fail(const en_spill *sp, int e, epsnet_error *err)
{
    return en_error_set(err, en_error_from_errno(e), sp->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                        "temporary file: %s", strerror(e));
}

/* n bytes to sp's file, counting into *written what went (on whichever
 * thread writes: the caller's, or a worker's when written behind). */
static int spill_write_all(const en_spill *sp, const uint8_t *p, size_t n, uint64_t *written, epsnet_error *err)
{
    while (n) {
        ssize_t k = disk_write(sp->fd, p, n);
        if (k < 0) {
            if (errno == EINTR)
                continue;
            return spill_io_fail(sp, errno, err);
        }
        if (k == 0)
            return spill_io_fail(sp, ENOSPC, err);
        p += k;
        n -= (size_t)k;
        *written += (uint64_t)k;
    }
    return 0;
}

static int spill_write_raw(en_spill *sp, const uint8_t *p, size_t n, epsnet_error *err)
{
    return spill_write_all(sp, p, n, &sp->disk, err);
}

static int spill_compress(en_spill *sp, const void *data, size_t n, ZSTD_EndDirective mode,
                          epsnet_error *err)
{
    ZSTD_inBuffer in = { data, n, 0 };
    for (;;) {
        ZSTD_outBuffer out = { sp->zbuf, sp->zcap, 0 };
        size_t r = ZSTD_compressStream2(sp->zc, &out, &in, mode);
        if (ZSTD_isError(r))
            return en_error_set(err, EPSNET_EIO, sp->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "temporary file: zstd: %s", ZSTD_getErrorName(r));
        if (out.pos && spill_write_raw(sp, sp->zbuf, out.pos, err))
            return EPSNET_EIO;
        if (mode == ZSTD_e_end ? r == 0 : in.pos == in.size)
            return 0;
    }
}

static int spill_job_run(void *arg)
{
    spill_job *j = arg;
    j->written = 0;
    return spill_write_all(j->sp, j->buf, j->len, &j->written, &j->err);
}

/* Wait for the buffer in flight; its failure is this call's. */
static int spill_drain(en_spill *sp, epsnet_error *err)
{
    if (!sp->busy)
        return 0;
    void *job;
    int rc = 0;
    en_jobring_retire(sp->ring, &job, &rc);
    sp->busy = 0;
    sp->disk += sp->job.written;
    if (rc && err)
        *err = sp->job.err;
    return rc ? EPSNET_EIO : 0;
}

/* Written behind: zbuf's staged bytes go to a worker, which writes them
 * while the caller fills the spare buffer. */
static int spill_flush(en_spill *sp, epsnet_error *err)
{
    if (spill_drain(sp, err))
        return EPSNET_EIO;
    uint8_t *spare = sp->job.buf;
    sp->job.buf = sp->zbuf;
    sp->job.len = sp->zlen;
    sp->zbuf = spare;
    sp->zlen = 0;
    /* the ring holds one job and was drained: it has room */
    if (en_jobring_submit(sp->ring, spill_job_run, &sp->job))
        return en_error_set(err, EPSNET_EINTERNAL, sp->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "temporary file: no room to write behind (a bug)");
    sp->busy = 1;
    return 0;
}

int en_spill_write_behind(en_spill *sp, en_pool *pool)
{
    if (!sp->plain || sp->reading || sp->ring || !pool || en_pool_threads(pool) == 0)
        return 0;
    if (!(sp->job.buf = en_malloc(sp->zcap)))
        return EPSNET_ENOMEM;
    if (en_jobring_new(&sp->ring, pool, 1)) {
        en_free(sp->job.buf);
        sp->job.buf = NULL;
        return EPSNET_ENOMEM;
    }
    /* the caller waits for it at its next flush: ahead of work that does not gate anything */
    en_jobring_set_order(sp->ring, 1, 1);
    sp->job.sp = sp;
    return 0;
}

/* A plain spill stages small writes in zbuf and passes large ones (half
 * of zbuf or more: a batch of records) straight to the file, without the
 * copy; written behind (en_spill_write_behind), everything is staged, so
 * that the caller only copies. */
static int spill_put_plain(en_spill *sp, const void *data, size_t n, epsnet_error *err)
{
    if (sp->ring) {
        const uint8_t *p = data;
        while (n) {
            if (sp->zlen == sp->zcap && spill_flush(sp, err))
                return EPSNET_EIO;
            size_t k = sp->zcap - sp->zlen < n ? sp->zcap - sp->zlen : n;
            memcpy(sp->zbuf + sp->zlen, p, k);
            sp->zlen += k;
            p += k;
            n -= k;
        }
        return 0;
    }
    if ((sp->zlen + n > sp->zcap || n >= sp->zcap / 2) && sp->zlen) {
        if (spill_write_raw(sp, sp->zbuf, sp->zlen, err))
            return EPSNET_EIO;
        sp->zlen = 0;
    }
    if (n >= sp->zcap / 2)
        return spill_write_raw(sp, data, n, err) ? EPSNET_EIO : 0;
    memcpy(sp->zbuf + sp->zlen, data, n);
    sp->zlen += n;
    return 0;
}

int en_spill_write(en_spill *sp, const void *data, size_t n, epsnet_error *err)
{
    if (sp->reading)
        return en_error_set(err, EPSNET_EINTERNAL, sp->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "temporary file: write after rewind");
    if (sp->plain)
        return spill_put_plain(sp, data, n, err);
    return spill_compress(sp, data, n, ZSTD_e_continue, err);
}

/* Stop writing behind: what is in flight is written (its failure is
 * this call's), and the ring and the spare buffer go. */
static int spill_behind_end(en_spill *sp, epsnet_error *err)
{
    int rc = spill_drain(sp, err);
    en_jobring_free(&sp->ring, NULL);
    en_free(sp->job.buf);
    sp->job.buf = NULL;
    return rc;
}

int en_spill_rewind(en_spill *sp, epsnet_error *err)
{
    if (!sp->reading && sp->plain) {
        if (spill_behind_end(sp, err))
            return EPSNET_EIO;
        if (sp->zlen && spill_write_raw(sp, sp->zbuf, sp->zlen, err))
            return EPSNET_EIO;
        en_free(sp->zbuf);
        sp->zbuf = NULL;
        sp->reading = 1;
    }
    if (!sp->reading) {
        int rc = spill_compress(sp, NULL, 0, ZSTD_e_end, err);
        if (rc)
            return rc;
        ZSTD_freeCStream(sp->zc);
        sp->zc = NULL;
        en_free(sp->zbuf);
        sp->zcap = ZSTD_DStreamInSize();
        sp->zbuf = en_malloc(sp->zcap);
        sp->zd = ZSTD_createDStream();
        if (!sp->zbuf || !sp->zd)
            return en_error_set(err, EPSNET_ENOMEM, sp->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "out of memory");
        sp->reading = 1;
    }
    if (!sp->plain)
        ZSTD_initDStream(sp->zd);
    sp->zlen = sp->zpos = 0;
    sp->eof = 0;
    if (lseek(sp->fd, 0, SEEK_SET) < 0)
        return spill_io_fail(sp, errno, err);
    return 0;
}

/* Up to n bytes of a plain spill: from byte offset, or, with offset
 * negative, from the file's place; *eof set at the end. note: straight
 * into data: the caller's buffer is the only copy. */
static int64_t spill_read_full(const en_spill *sp, uint8_t *data, size_t n, int64_t offset, int *eof,
                               epsnet_error *err)
{
    size_t got = 0;
    while (got < n && !*eof) {
        ssize_t k = offset < 0 ? read(sp->fd, data + got, n - got)
                               : pread(sp->fd, data + got, n - got, (off_t)offset + (off_t)got);
        if (k < 0) {
            if (errno == EINTR)
                continue;
            return spill_io_fail(sp, errno, err);
        }
        if (k == 0)
            *eof = 1;
        got += (size_t)k;
    }
    return (int64_t)got;
}

static int64_t spill_read_plain(en_spill *sp, uint8_t *data, size_t n, epsnet_error *err)
{
    return spill_read_full(sp, data, n, -1, &sp->eof, err);
}

int64_t en_spill_read_at(const en_spill *sp, void *data, size_t n, uint64_t offset, epsnet_error *err)
{
    if (!sp->plain || !sp->reading)
        return en_error_set(err, EPSNET_EINTERNAL, sp->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                            "temporary file: read at an offset before it is rewound, or compressed");
    int eof = 0;
    return spill_read_full(sp, data, n, (int64_t)offset, &eof, err);
}

int64_t en_spill_read(en_spill *sp, void *data, size_t n, epsnet_error *err)
{
    if (sp->plain)
        return spill_read_plain(sp, data, n, err);
    ZSTD_outBuffer out = { data, n, 0 };
    while (out.pos < out.size) {
        if (sp->zpos == sp->zlen) {
            if (sp->eof)
                break;
            ssize_t k = read(sp->fd, sp->zbuf, sp->zcap);
            if (k < 0) {
                if (errno == EINTR)
                    continue;
                return spill_io_fail(sp, errno, err);
            }
            if (k == 0) {
                sp->eof = 1;
                break;
            }
            sp->zlen = (size_t)k;
            sp->zpos = 0;
        }
        ZSTD_inBuffer in = { sp->zbuf, sp->zlen, sp->zpos };
        size_t r = ZSTD_decompressStream(sp->zd, &out, &in);
        sp->zpos = in.pos;
        if (ZSTD_isError(r))
            return en_error_set(err, EPSNET_EIO, sp->owner, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                "temporary file: zstd: %s", ZSTD_getErrorName(r));
    }
    return (int64_t)out.pos;
}

uint64_t en_spill_disk_bytes(const en_spill *sp)
{
    return sp->disk;
}

void en_spill_close(en_spill **psp)
{
    en_spill *sp = psp ? *psp : NULL;
    if (!sp)
        return;
    (void)spill_behind_end(sp, NULL); /* before the file goes */
    if (sp->fd >= 0)
        close(sp->fd);
    if (sp->zc)
        ZSTD_freeCStream(sp->zc);
    if (sp->zd)
        ZSTD_freeDStream(sp->zd);
    en_free(sp->zbuf);
    en_free(sp->owner);
    en_free(sp);
    *psp = NULL;
}
