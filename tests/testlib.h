/*
 * Minimal test harness: each test program defines TEST() functions, lists
 * them in main() with RUN(), and exits non-zero if any check failed. Checks
 * print file:line and the values, then continue with the next check.
 *
 * Helpers to write input files into a private temporary folder and to read a
 * whole mesh through the public API are included, header-only.
 */
#ifndef EPSNET_TESTLIB_H
#define EPSNET_TESTLIB_H

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "epsnet/epsnet.h"

static int tl_failures;
static int tl_checks;
static const char *tl_current;

#define TEST(name) static void name(void)

#define RUN(name)                                                          \
    do {                                                                   \
        int before_ = tl_failures;                                         \
        tl_current = #name;                                                \
        name();                                                            \
        printf("%s %s\n", tl_failures == before_ ? "ok  " : "FAIL", #name); \
        fflush(stdout);                                                    \
    } while (0)

#define CHECK(cond)                                                              \
    do {                                                                         \
        tl_checks++;                                                             \
        if (!(cond)) {                                                           \
            tl_failures++;                                                       \
            fprintf(stderr, "%s:%d: [%s] CHECK(%s) failed\n", __FILE__, __LINE__, \
                    tl_current, #cond);                                          \
        }                                                                        \
    } while (0)

#define CHECK_EQ_INT(a, b)                                                           \
    do {                                                                             \
        long long a_ = (long long)(a), b_ = (long long)(b);                          \
        tl_checks++;                                                                 \
        if (a_ != b_) {                                                              \
            tl_failures++;                                                           \
            fprintf(stderr, "%s:%d: [%s] %s == %s failed: %lld != %lld\n", __FILE__, \
                    __LINE__, tl_current, #a, #b, a_, b_);                           \
        }                                                                            \
    } while (0)

#define CHECK_EQ_U64(a, b)                                                                \
    do {                                                                                  \
        uint64_t a_ = (uint64_t)(a), b_ = (uint64_t)(b);                                  \
        tl_checks++;                                                                      \
        if (a_ != b_) {                                                                   \
            tl_failures++;                                                                \
            fprintf(stderr, "%s:%d: [%s] %s == %s failed: %" PRIu64 " != %" PRIu64 "\n", \
                    __FILE__, __LINE__, tl_current, #a, #b, a_, b_);                      \
        }                                                                                 \
    } while (0)

#define CHECK_STR_CONTAINS(hay, needle)                                                  \
    do {                                                                                 \
        const char *h_ = (hay), *n_ = (needle);                                          \
        tl_checks++;                                                                     \
        if (!h_ || !strstr(h_, n_)) {                                                    \
            tl_failures++;                                                               \
            fprintf(stderr, "%s:%d: [%s] \"%s\" does not contain \"%s\"\n", __FILE__,   \
                    __LINE__, tl_current, h_ ? h_ : "(null)", n_);                       \
        }                                                                                \
    } while (0)

/* Exit status for main(): 0 when every check passed. */
static inline int tl_finish(void)
{
    printf("%d checks, %d failed\n", tl_checks, tl_failures);
    return tl_failures ? 1 : 0;
}

/* ---- temporary files ---- */

static char tl_dir[256];

/* Private folder for this test program, created on first use. */
static inline const char *tl_tmpdir(void)
{
    if (!tl_dir[0]) {
        const char *base = getenv("TMPDIR");
        snprintf(tl_dir, sizeof tl_dir, "%s/epsnet-test-XXXXXX", base && *base ? base : "/tmp");
        if (!mkdtemp(tl_dir)) {
            perror("mkdtemp");
            exit(2);
        }
    }
    return tl_dir;
}

/* Path of name inside the private folder (static buffer, rotated 8 ways). */
static inline const char *tl_path(const char *name)
{
    static char buf[8][512];
    static int k;
    char *p = buf[k++ & 7];
    snprintf(p, 512, "%s/%s", tl_tmpdir(), name);
    return p;
}

/* Write bytes to name in the private folder; returns the path. */
static inline const char *tl_write(const char *name, const void *data, size_t n)
{
    const char *path = tl_path(name);
    FILE *f = fopen(path, "wb");
    if (!f || (n && fwrite(data, 1, n, f) != n)) {
        perror(path);
        exit(2);
    }
    fclose(f);
    return path;
}

static inline const char *tl_write_str(const char *name, const char *text)
{
    return tl_write(name, text, strlen(text));
}

static inline int tl_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* Remove the private folder and everything in it. */
static inline void tl_cleanup(void)
{
    if (tl_dir[0]) {
        char cmd[600];
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", tl_dir);
        if (system(cmd) != 0)
            fprintf(stderr, "could not remove %s\n", tl_dir);
    }
}

/* The whole file, malloc'ed (free it), *n bytes; NULL when unreadable. */
static inline unsigned char *tl_read_file(const char *path, size_t *n)
{
    *n = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = len >= 0 ? malloc((size_t)len + 1) : NULL;
    if (b && fread(b, 1, (size_t)len, f) == (size_t)len)
        *n = (size_t)len;
    fclose(f);
    return b;
}

/* 1 when both files exist, are not empty and hold the same bytes. */
static inline int tl_same_file(const char *a, const char *b)
{
    size_t na, nb;
    unsigned char *da = tl_read_file(a, &na), *db = tl_read_file(b, &nb);
    int same = da && db && na == nb && na > 0 && memcmp(da, db, na) == 0;
    free(da);
    free(db);
    return same;
}

/* ---- whole meshes ---- */

typedef struct tl_mesh {
    double *xyz;        /* 3 per vertex */
    uint64_t *tri;      /* 3 per triangle */
    uint64_t nv, nt, nfin;
    epsnet_mesh_info info;
} tl_mesh;

static inline void tl_mesh_free(tl_mesh *m)
{
    free(m->xyz);
    free(m->tri);
    memset(m, 0, sizeof *m);
}

/* Read every record of path. @return 0 or the reader's negative code with
 * err filled; m holds what was read before a failure. */
static inline int tl_read_mesh(const char *path, tl_mesh *m, epsnet_error *err)
{
    memset(m, 0, sizeof *m);
    epsnet_reader *r = NULL;
    int rc = epsnet_reader_open(&r, path, NULL, err);
    if (rc)
        return rc;
    m->info = *epsnet_reader_info(r);
    size_t vcap = 0, tcap = 0;
    epsnet_record rec;
    while ((rc = epsnet_reader_next(r, &rec, err)) > 0) {
        if (rec.kind == EPSNET_REC_VERTEX) {
            if (m->nv == vcap) {
                vcap = vcap ? vcap * 2 : 64;
                m->xyz = realloc(m->xyz, vcap * 3 * sizeof *m->xyz);
            }
            memcpy(m->xyz + 3 * m->nv++, rec.xyz, sizeof rec.xyz);
        } else if (rec.kind == EPSNET_REC_TRIANGLE) {
            if (m->nt == tcap) {
                tcap = tcap ? tcap * 2 : 64;
                m->tri = realloc(m->tri, tcap * 3 * sizeof *m->tri);
            }
            memcpy(m->tri + 3 * m->nt++, rec.v, sizeof rec.v);
        } else {
            m->nfin++;
        }
    }
    /* info strings point into the reader's static tables; keep them */
    epsnet_reader_close(&r);
    return rc < 0 ? rc : 0;
}

/* Write m to path (format from the extension). */
static inline int tl_write_mesh(const char *path, const tl_mesh *m,
                                const epsnet_writer_settings *ws, epsnet_error *err)
{
    epsnet_writer *w = NULL;
    epsnet_mesh_info info = m->info;
    info.nverts = m->nv;
    info.nfaces = m->nt;
    /* a tl_mesh holds positions only */
    memset(&info.vertex_attrs, 0, sizeof info.vertex_attrs);
    int rc = epsnet_writer_open(&w, path, ws, &info, err);
    if (rc)
        return rc;
    epsnet_record rec = { 0 };
    for (uint64_t i = 0; i < m->nv && rc == 0; i++) {
        rec.kind = EPSNET_REC_VERTEX;
        memcpy(rec.xyz, m->xyz + 3 * i, sizeof rec.xyz);
        rc = epsnet_writer_put(w, &rec, err);
    }
    for (uint64_t i = 0; i < m->nt && rc == 0; i++) {
        rec.kind = EPSNET_REC_TRIANGLE;
        memcpy(rec.v, m->tri + 3 * i, sizeof rec.v);
        rc = epsnet_writer_put(w, &rec, err);
    }
    if (rc == 0)
        return epsnet_writer_commit(&w, err);
    epsnet_writer_abort(&w);
    return rc;
}

/* Generate the synthetic mesh gs describes into path (format from the
 * extension). @return 0 or a negative code with err filled. */
static inline int tl_gen_settings_file(const char *path, const epsnet_gen_settings *gs, epsnet_error *err)
{
    epsnet_mesh_info info;
    epsnet_writer *w = NULL;
    int rc = epsnet_gen_info(gs, &info, err);
    if (rc == 0)
        rc = epsnet_writer_open(&w, path, NULL, &info, err);
    if (rc == 0)
        rc = epsnet_gen(gs, w, err);
    if (rc == 0)
        return epsnet_writer_commit(&w, err);
    epsnet_writer_abort(&w);
    return rc;
}

/* Gen settings for a shape, a size, a parameter (NAN: the shape's
 * default), a seed and an order. */
static inline epsnet_gen_settings tl_gen_settings(const char *shape, uint64_t faces, double param, uint64_t seed,
                                                  int shuffle)
{
    epsnet_gen_settings gs;
    epsnet_gen_default_settings(&gs);
    gs.shape = shape;
    gs.faces = faces;
    gs.param = param;
    gs.seed = seed;
    gs.shuffle = shuffle;
    return gs;
}

/* tl_gen_settings_file() of tl_gen_settings(). */
static inline int tl_gen_file(const char *path, const char *shape, uint64_t faces, double param, uint64_t seed,
                              int shuffle, epsnet_error *err)
{
    epsnet_gen_settings gs = tl_gen_settings(shape, faces, param, seed, shuffle);
    return tl_gen_settings_file(path, &gs, err);
}

/* Folder of the real meshes, or NULL (tests then skip with a message). */
static inline const char *tl_shared_data(void)
{
    const char *d = getenv("EPSNET_SHARED_DATA");
    if (d && *d && tl_exists(d))
        return d;
    return NULL;
}

/* meson treats exit code 77 as "skipped". */
#define TL_SKIP 77

#endif /* EPSNET_TESTLIB_H */
