/*
 * The shared I/O layer under every format: byte source (lines, zstd), sink
 * (atomic commit, abort leaves nothing), spill files, the live-vertex set,
 * size parsing and error messages.
 */
#include <dirent.h>
#include <zstd.h>

#include "common/pool.h"
#include "common/u64set.h"
#include "io/sink.h"
#include "io/format.h"
#include "io/source.h"
#include "common/alloc.h"
#include "testlib.h"

static int count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, ".."))
            n++;
    closedir(d);
    return n;
}

TEST(source_lines_handle_crlf_and_missing_final_newline)
{
    const char *p = tl_write_str("lines.txt", "alpha\r\nbeta\n\ngamma");
    en_source *s = NULL;
    epsnet_error err;
    CHECK_EQ_INT(en_source_open(&s, p, &err), 0);
    char *line;
    size_t len;
    const char *want[] = { "alpha", "beta", "", "gamma" };
    for (int i = 0; i < 4; i++) {
        CHECK_EQ_INT(en_source_line(s, &line, &len, 1 << 16, &err), 1);
        CHECK(strcmp(line, want[i]) == 0);
        CHECK_EQ_U64(len, strlen(want[i]));
    }
    CHECK_EQ_INT(en_source_line(s, &line, &len, 1 << 16, &err), 0);
    CHECK_EQ_U64(s->lineno, 4);
    en_source_close(&s);
    CHECK(s == NULL);
}

TEST(source_rejects_overlong_line_with_its_number)
{
    size_t n = 300000;
    char *big = malloc(n + 16);
    memcpy(big, "ok\n", 3);
    memset(big + 3, 'a', n);
    big[n + 3] = '\n';
    const char *p = tl_write("long.txt", big, n + 4);
    free(big);
    en_source *s = NULL;
    epsnet_error err;
    CHECK_EQ_INT(en_source_open(&s, p, &err), 0);
    char *line;
    size_t len;
    CHECK_EQ_INT(en_source_line(s, &line, &len, 1000, &err), 1);
    CHECK_EQ_INT(en_source_line(s, &line, &len, 1000, &err), EPSNET_EFORMAT);
    CHECK_EQ_U64(err.line, 2);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "long.txt:2: line longer than 1000 bytes");
    en_source_close(&s);
}

TEST(source_reads_zstd_transparently_whatever_the_name)
{
    char text[5000];
    for (int i = 0; i < 5000; i++)
        text[i] = (char)('a' + i % 26);
    size_t cap = ZSTD_compressBound(sizeof text);
    void *z = malloc(cap);
    size_t zn = ZSTD_compress(z, cap, text, sizeof text, 3);
    CHECK(!ZSTD_isError(zn));
    const char *p = tl_write("data.bin", z, zn); /* no .zst in the name */
    free(z);
    en_source *s = NULL;
    epsnet_error err;
    CHECK_EQ_INT(en_source_open(&s, p, &err), 0);
    char back[5000];
    CHECK_EQ_INT(en_source_read(s, back, sizeof back, "test data", &err), 0);
    CHECK(memcmp(back, text, sizeof text) == 0);
    char extra;
    CHECK_EQ_INT(en_source_read(s, &extra, 1, "one more byte", &err), EPSNET_EFORMAT);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "decompressed byte 5000: truncated file");
    en_source_close(&s);
}

TEST(source_reports_corrupt_zstd)
{
    char text[4096];
    memset(text, 'q', sizeof text);
    size_t cap = ZSTD_compressBound(sizeof text);
    unsigned char *z = malloc(cap);
    size_t zn = ZSTD_compress(z, cap, text, sizeof text, 1);
    z[zn / 2] ^= 0x5a;
    z[zn - 3] ^= 0xff; /* the checksum at least will not match */
    const char *p = tl_write("bad.zst", z, zn);
    free(z);
    en_source *s = NULL;
    epsnet_error err;
    CHECK_EQ_INT(en_source_open(&s, p, &err), 0);
    char back[4096];
    int rc = en_source_read(s, back, sizeof back, "data", &err);
    CHECK_EQ_INT(rc, EPSNET_EFORMAT);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "bad.zst");
    en_source_close(&s);
}

/* Every line of path, each with its number and the offset after it, into
 * a text log; read ahead on pool's workers from the `start`-th line on,
 * stopped again at the `stop`-th (0: never); the error, if any, at the end. */
static char *read_log(const char *path, en_pool *pool, int start, int stop, size_t *n)
{
    size_t cap = 1 << 16, len = 0;
    char *log = malloc(cap);
    en_source *s = NULL;
    epsnet_error err;
    int rc = en_source_open(&s, path, &err);
    for (int i = 0; rc == 0; i++) {
        if (pool && i == start)
            CHECK_EQ_INT(en_source_use_pool(s, pool), 0);
        if (pool && i == stop && stop)
            CHECK_EQ_INT(en_source_use_pool(s, NULL), 0);
        char *line;
        size_t ll;
        rc = en_source_line(s, &line, &ll, 1 << 19, &err);
        if (rc != 1)
            break;
        rc = 0;
        while (len + ll + 64 > cap)
            log = realloc(log, cap *= 2);
        len += (size_t)sprintf(log + len, "%llu %llu ", (unsigned long long)s->lineno,
                               (unsigned long long)en_source_offset(s));
        memcpy(log + len, line, ll);
        len += ll;
        log[len++] = '\n';
    }
    const char *msg = rc < 0 ? epsnet_error_message(&err) : "end";
    log = realloc(log, len + strlen(msg) + 64);
    len += (size_t)sprintf(log + len, "%s; %llu bytes read\n", msg,
                           (unsigned long long)(s ? s->raw_read : 0));
    en_source_close(&s);
    *n = len;
    return log;
}

TEST(source_read_ahead_gives_the_same_lines_offsets_and_errors)
{
    /* about 7 MiB of lines of 0 to 4,000 bytes: chunks of 1 MiB end inside lines */
    size_t cap = 8u << 20, n = 0;
    char *text = malloc(cap);
    uint64_t x = 88172645463325252ull;
    while (n + 4100 < (size_t)7 << 20) {
        x ^= x << 13, x ^= x >> 7, x ^= x << 17;
        size_t ll = (size_t)(x % 4001);
        for (size_t i = 0; i < ll; i++)
            text[n++] = (char)('a' + (x >> (i % 40)) % 26);
        text[n++] = '\n';
    }
    const char *plain = tl_write("ahead.txt", text, n);
    size_t zcap = ZSTD_compressBound(n);
    void *z = malloc(zcap);
    size_t zn = ZSTD_compress(z, zcap, text, n, 1);
    CHECK(!ZSTD_isError(zn));
    char *whole = strdup(tl_write("ahead.zst", z, zn));
    char *cut = strdup(tl_write("ahead_cut.zst", z, zn * 2 / 3)); /* a truncated frame */
    free(z);
    free(text);
    en_pool *pool = NULL;
    CHECK_EQ_INT(en_pool_new(&pool, 2), 0);
    en_pool *inline_pool = NULL;
    CHECK_EQ_INT(en_pool_new(&inline_pool, 0), 0);
    const char *paths[3] = { plain, whole, cut };
    for (int k = 0; k < 3; k++) {
        size_t n0, n1;
        char *alone = read_log(paths[k], NULL, 0, 0, &n0);
        CHECK(strstr(alone, k == 2 ? "truncated zstd stream" : "end; ") != NULL);
        /* from the start, after the first lines, stopped half way, with no workers */
        int shapes[4][2] = { { 0, 0 }, { 3, 0 }, { 1, 900 }, { 0, 0 } };
        for (int h = 0; h < 4; h++) {
            char *ahead = read_log(paths[k], h == 3 ? inline_pool : pool, shapes[h][0], shapes[h][1], &n1);
            CHECK_EQ_U64(n1, n0);
            CHECK(n1 == n0 && memcmp(alone, ahead, n0) == 0);
            free(ahead);
        }
        free(alone);
    }
    en_pool_free(&inline_pool);
    en_pool_free(&pool);
    free(whole);
    free(cut);
}

/* A folder of its own under the tests' temporary folder, whose entries
 * are counted (a sink or a spill must leave none behind). */
static void test_dir(char *dir, size_t cap, const char *name)
{
    snprintf(dir, cap, "%s/%s", tl_tmpdir(), name);
    mkdir(dir, 0777);
}

TEST(sink_commit_renames_and_abort_leaves_nothing)
{
    char dir[600];
    test_dir(dir, sizeof dir, "sinkdir");
    char dst[700];
    snprintf(dst, sizeof dst, "%s/out.bin", dir);
    epsnet_error err;
    en_sink *s = NULL;
    CHECK_EQ_INT(en_sink_open(&s, dst, 0, &err), 0);
    CHECK_EQ_INT(en_sink_write(s, "hello world", 11, &err), 0);
    CHECK(!tl_exists(dst));
    CHECK(en_sink_can_patch(s));
    CHECK_EQ_INT(en_sink_patch(s, 0, "J", 1, &err), 0);
    CHECK_EQ_INT(en_sink_commit(&s, &err), 0);
    CHECK(s == NULL);
    FILE *f = fopen(dst, "rb");
    char buf[32] = { 0 };
    CHECK(f && fread(buf, 1, sizeof buf, f) == 11);
    if (f)
        fclose(f);
    CHECK(strcmp(buf, "Jello world") == 0);

    char dst2[700];
    snprintf(dst2, sizeof dst2, "%s/aborted.bin", dir);
    CHECK_EQ_INT(en_sink_open(&s, dst2, 0, &err), 0);
    CHECK_EQ_INT(en_sink_write(s, "partial", 7, &err), 0);
    en_sink_abort(&s);
    CHECK(!tl_exists(dst2));
    CHECK_EQ_INT(count_entries(dir), 1); /* only out.bin */
}

TEST(sink_zstd_output_reads_back)
{
    const char *dst = tl_path("c.txt.zst");
    epsnet_error err;
    en_sink *s = NULL;
    CHECK_EQ_INT(en_sink_open(&s, dst, 3, &err), 0);
    CHECK(!en_sink_can_patch(s));
    for (int i = 0; i < 100000; i++)
        en_sink_write(s, "0123456789", 10, &err);
    CHECK_EQ_INT(en_sink_commit(&s, &err), 0);
    en_source *src = NULL;
    CHECK_EQ_INT(en_source_open(&src, dst, &err), 0);
    char buf[10];
    int ok = 1;
    for (int i = 0; i < 100000 && ok; i++)
        ok = en_source_read(src, buf, 10, "chunk", &err) == 0 && memcmp(buf, "0123456789", 10) == 0;
    CHECK(ok);
    CHECK_EQ_INT(en_source_fill(src, 1), 0);
    CHECK(src->eof && !src->failed);
    en_source_close(&src);
}

/* -o /dev/null must write into the device, never rename over it. */
TEST(sink_onto_a_device_writes_in_place)
{
    struct stat before, after;
    CHECK_EQ_INT(stat("/dev/null", &before), 0);
    epsnet_error err;
    en_sink *s = NULL;
    CHECK_EQ_INT(en_sink_open(&s, "/dev/null", 0, &err), 0);
    CHECK(!en_sink_can_patch(s));
    CHECK_EQ_INT(en_sink_write(s, "discard me", 10, &err), 0);
    CHECK_EQ_INT(en_sink_commit(&s, &err), 0);
    CHECK_EQ_INT(stat("/dev/null", &after), 0);
    CHECK(S_ISCHR(after.st_mode));
    CHECK(after.st_rdev == before.st_rdev);
}

TEST(sink_into_missing_directory_fails_cleanly)
{
    epsnet_error err;
    en_sink *s = NULL;
    CHECK_EQ_INT(en_sink_open(&s, "/nonexistent-dir-epsnet/x.ply", 0, &err), EPSNET_EIO);
    CHECK(s == NULL);
    CHECK_STR_CONTAINS(epsnet_error_message(&err), "/nonexistent-dir-epsnet/x.ply");
}

TEST(spill_round_trips_and_leaves_no_file)
{
    char dir[600];
    test_dir(dir, sizeof dir, "spilldir");
    epsnet_error err;
    en_spill *sp = NULL;
    CHECK_EQ_INT(en_spill_open(&sp, dir, "out.ply", &err), 0);
    CHECK_EQ_INT(count_entries(dir), 0); /* anonymous from the start */
    uint64_t sum = 0;
    for (uint64_t i = 0; i < 300000; i++) {
        en_spill_write(sp, &i, sizeof i, &err);
        sum += i;
    }
    CHECK_EQ_INT(en_spill_rewind(sp, &err), 0);
    uint64_t v, back = 0, n = 0;
    while (en_spill_read(sp, &v, sizeof v, &err) == (int64_t)sizeof v) {
        back += v;
        n++;
    }
    CHECK_EQ_U64(n, 300000);
    CHECK_EQ_U64(back, sum);
    CHECK(en_spill_disk_bytes(sp) < 300000 * 8 / 2); /* compressed */
    en_spill_close(&sp);
    CHECK_EQ_INT(count_entries(dir), 0);
}

/* A plain spill written 0, 1, ... next - 1 (uint64_t): rewound, it holds
 * those bytes, uncompressed, and reads them back in order. */
static void reads_back_counting(en_spill *sp, uint64_t next)
{
    epsnet_error err;
    CHECK_EQ_INT(en_spill_rewind(sp, &err), 0);
    CHECK_EQ_U64(en_spill_disk_bytes(sp), next * 8); /* not compressed */
    uint64_t v, n = 0;
    int ok = 1;
    while (en_spill_read(sp, &v, sizeof v, &err) == (int64_t)sizeof v)
        ok &= v == n++;
    CHECK(ok);
    CHECK_EQ_U64(n, next);
}

TEST(plain_spill_keeps_bytes_as_written_across_small_and_large_writes)
{
    char dir[600];
    test_dir(dir, sizeof dir, "plaindir");
    epsnet_error err;
    en_spill *sp = NULL;
    CHECK_EQ_INT(en_spill_open_plain(&sp, dir, "out.smz", &err), 0);
    CHECK_EQ_INT(count_entries(dir), 0);
    /* small writes are staged, a write larger than the staging goes
     * straight to the file: both in order */
    static uint64_t big[40000];
    uint64_t next = 0;
    for (int round = 0; round < 3; round++) {
        for (int i = 0; i < 1000; i++, next++)
            CHECK_EQ_INT(en_spill_write(sp, &next, sizeof next, &err), 0);
        for (size_t i = 0; i < sizeof big / sizeof *big; i++)
            big[i] = next++;
        CHECK_EQ_INT(en_spill_write(sp, big, sizeof big, &err), 0);
    }
    reads_back_counting(sp, next);
    uint64_t v;
    CHECK_EQ_INT(en_spill_rewind(sp, &err), 0); /* read again from the start */
    CHECK_EQ_INT((int)en_spill_read(sp, big, 16, &err), 16);
    CHECK_EQ_U64(big[1], 1);
    /* reads at an offset give the bytes there, across a staged and a
     * direct write, and leave the sequential place alone; past the end,
     * what there is */
    uint64_t at[3] = { 0 };
    CHECK_EQ_INT((int)en_spill_read_at(sp, at, sizeof at, 999 * 8, &err), (int)sizeof at);
    CHECK_EQ_U64(at[0], 999);
    CHECK_EQ_U64(at[2], 1001);
    CHECK_EQ_INT((int)en_spill_read_at(sp, at, sizeof at, (next - 1) * 8, &err), 8);
    CHECK_EQ_U64(at[0], next - 1);
    CHECK_EQ_INT((int)en_spill_read(sp, &v, sizeof v, &err), (int)sizeof v);
    CHECK_EQ_U64(v, 2);
    en_spill_close(&sp);
    CHECK_EQ_INT(count_entries(dir), 0);
    /* before its rewind, or compressed, a spill has no offsets to read at */
    CHECK_EQ_INT(en_spill_open_plain(&sp, dir, "out.smz", &err), 0);
    CHECK_EQ_INT(en_spill_write(sp, &next, sizeof next, &err), 0);
    CHECK((int)en_spill_read_at(sp, &v, sizeof v, 0, &err) < 0);
    en_spill_close(&sp);
    CHECK_EQ_INT(en_spill_open(&sp, dir, "out.smz", &err), 0);
    CHECK_EQ_INT(en_spill_write(sp, &next, sizeof next, &err), 0);
    CHECK_EQ_INT(en_spill_rewind(sp, &err), 0);
    CHECK((int)en_spill_read_at(sp, &v, sizeof v, 0, &err) < 0);
    en_spill_close(&sp);
}

/* Written behind on a pool's worker, a plain spill keeps its bytes in the
 * order written, whatever the sizes of the writes, counts them all, and
 * closes with a buffer still in flight. */
TEST(plain_spill_written_behind_keeps_bytes_in_order)
{
    char dir[600];
    test_dir(dir, sizeof dir, "behinddir");
    epsnet_error err;
    en_pool *pool = NULL;
    CHECK_EQ_INT(en_pool_new(&pool, 2), 0);
    for (int closing = 0; closing < 2; closing++) {
        en_spill *sp = NULL;
        CHECK_EQ_INT(en_spill_open_plain(&sp, dir, "out.smz", &err), 0);
        CHECK_EQ_INT(en_spill_write_behind(sp, pool), 0);
        static uint64_t big[50000];
        uint64_t next = 0;
        for (int round = 0; round < 4; round++) {
            for (int i = 0; i < 3000; i++, next++)
                CHECK_EQ_INT(en_spill_write(sp, &next, sizeof next, &err), 0);
            size_t n = round == 2 ? 5 : sizeof big / sizeof *big; /* many buffers' worth, then a few */
            for (size_t i = 0; i < n; i++)
                big[i] = next++;
            CHECK_EQ_INT(en_spill_write(sp, big, n * sizeof *big, &err), 0);
        }
        if (closing) {
            en_spill_close(&sp); /* with a buffer in flight */
            continue;
        }
        reads_back_counting(sp, next);
        en_spill_close(&sp);
    }
    CHECK_EQ_INT(count_entries(dir), 0);
    en_pool_free(&pool);
}

/* Blocks of a MiB and more are mapped (common/alloc.c): a block keeps its
 * bytes whichever side of that line it grows or shrinks to, calloc's are
 * zero on both sides, and every one goes back through en_free. */
TEST(allocations_keep_their_bytes_across_the_mapping_line)
{
    const size_t big = (size_t)3 << 20, small = 4000;
    uint8_t *p = en_malloc(small);
    CHECK(p != NULL);
    for (size_t i = 0; i < small; i++)
        p[i] = (uint8_t)(i * 7);
    p = en_realloc(p, big); /* malloc -> mapped */
    CHECK(p != NULL);
    p[big - 1] = 42;
    for (size_t i = 0; i < small; i++)
        CHECK_EQ_INT(p[i], (uint8_t)(i * 7));
    p = en_realloc(p, 2 * big); /* mapped -> mapped, moved or grown in place */
    CHECK(p != NULL);
    CHECK_EQ_INT(p[big - 1], 42);
    CHECK_EQ_INT(p[small - 1], (uint8_t)((small - 1) * 7));
    p = en_realloc(p, 100); /* mapped -> malloc */
    CHECK(p != NULL);
    for (size_t i = 0; i < 100; i++)
        CHECK_EQ_INT(p[i], (uint8_t)(i * 7));
    en_free(p);
    uint64_t *z = en_calloc(big / 8, 8);
    CHECK(z != NULL);
    uint64_t sum = 0;
    for (size_t i = 0; i < big / 8; i++)
        sum |= z[i];
    CHECK_EQ_U64(sum, 0);
    en_free(z);
    z = en_calloc(10, 8);
    CHECK(z != NULL && (z[0] | z[9]) == 0);
    en_free(z);
    CHECK(en_calloc(SIZE_MAX / 2, 4) == NULL); /* overflows */
    en_free(NULL);
}

TEST(u64set_add_remove_many)
{
    en_u64set *s = en_u64set_new();
    for (uint64_t i = 0; i < 100000; i++)
        CHECK_EQ_INT(en_u64set_add(s, i * 7919), 1);
    CHECK_EQ_INT(en_u64set_add(s, 7919), 0);
    CHECK_EQ_U64(en_u64set_count(s), 100000);
    for (uint64_t i = 0; i < 100000; i += 2)
        CHECK_EQ_INT(en_u64set_remove(s, i * 7919), 1);
    int ok = 1;
    for (uint64_t i = 0; i < 100000; i++)
        ok &= en_u64set_has(s, i * 7919) == (int)(i & 1);
    CHECK(ok);
    CHECK_EQ_INT(en_u64set_remove(s, 2), 0);
    CHECK_EQ_U64(en_u64set_count(s), 50000);
    en_u64set_free(&s);
    CHECK(s == NULL);
}

TEST(parse_size_accepts_binary_suffixes)
{
    uint64_t v;
    CHECK_EQ_INT(epsnet_parse_size("64M", &v), 0);
    CHECK_EQ_U64(v, 64ull << 20);
    CHECK_EQ_INT(epsnet_parse_size("2G", &v), 0);
    CHECK_EQ_U64(v, 2ull << 30);
    CHECK_EQ_INT(epsnet_parse_size("1.5k", &v), 0);
    CHECK_EQ_U64(v, 1536);
    CHECK_EQ_INT(epsnet_parse_size("512MiB", &v), 0);
    CHECK_EQ_U64(v, 512ull << 20);
    CHECK_EQ_INT(epsnet_parse_size("4096", &v), 0);
    CHECK_EQ_U64(v, 4096);
    CHECK_EQ_INT(epsnet_parse_size("-1M", &v), EPSNET_EINVAL);
    CHECK_EQ_INT(epsnet_parse_size("12Q", &v), EPSNET_EINVAL);
    CHECK_EQ_INT(epsnet_parse_size("", &v), EPSNET_EINVAL);
    CHECK_EQ_INT(epsnet_parse_size("1e30G", &v), EPSNET_EINVAL);
}

TEST(error_messages_name_file_and_position)
{
    epsnet_error e;
    en_error_set(&e, EPSNET_EFORMAT, "m.obj", 12, EPSNET_POS_NONE, "index %d out of range", 9);
    CHECK(strcmp(epsnet_error_message(&e), "m.obj:12: index 9 out of range") == 0);
    en_error_set(&e, EPSNET_EFORMAT, "m.ply", EPSNET_POS_NONE, 4096, "truncated\nfile");
    CHECK(strcmp(epsnet_error_message(&e), "m.ply: byte 4096: truncated file") == 0);
    CHECK(strcmp(epsnet_strerror(EPSNET_ELIMIT), "limit exceeded") == 0);
}

/* The front end delivers every record a driver pushed before it failed, and
 * only then the error (format.h's driver contract), for any format. */
TEST(records_before_a_bad_line_arrive_before_the_error)
{
    const char *cases[][2] = {
        { "before.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 1 x 0\n" },
        { "before.sma", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 1 x 0\n" },
    };
    for (int i = 0; i < 2; i++) {
        const char *p = tl_write_str(cases[i][0], cases[i][1]);
        epsnet_reader *r = NULL;
        epsnet_error err;
        CHECK_EQ_INT(epsnet_reader_open(&r, p, NULL, &err), 0);
        epsnet_record rec;
        int rc, n = 0, tris = 0;
        while ((rc = epsnet_reader_next(r, &rec, &err)) > 0) {
            n++;
            tris += rec.kind == EPSNET_REC_TRIANGLE;
        }
        CHECK_EQ_INT(n, 4);
        CHECK_EQ_INT(tris, 1);
        CHECK_EQ_INT(rc, EPSNET_EFORMAT);
        CHECK_STR_CONTAINS(epsnet_error_message(&err), ":5:");
        CHECK_EQ_INT(epsnet_reader_next(r, &rec, &err), EPSNET_EFORMAT); /* sticky */
        epsnet_reader_close(&r);
    }
}

TEST(format_coord_is_shortest_exact)
{
    char buf[32];
    en_format_coord(buf, (double)0.1f, EPSNET_COORD_FLOAT32);
    CHECK(strcmp(buf, "0.1") == 0);
    en_format_coord(buf, 0.1, EPSNET_COORD_FLOAT64);
    CHECK(strcmp(buf, "0.1") == 0);
    double hard = 1.0 / 3.0;
    en_format_coord(buf, hard, EPSNET_COORD_FLOAT64);
    CHECK(strtod(buf, NULL) == hard);
    float hf = 16777217.0f / 3.0f;
    en_format_coord(buf, (double)hf, EPSNET_COORD_FLOAT32);
    CHECK(strtof(buf, NULL) == hf);
}

/* epsnet.h §2: layouts are built and checked by the library; a writer
 * refuses a layout that does not add up, and a vertex without its bytes. */
TEST(attribute_layouts_are_built_and_checked)
{
    epsnet_attr_layout l;
    memset(&l, 0, sizeof l);
    CHECK_EQ_INT(epsnet_attr_layout_add(&l, "red", EPSNET_ATTR_UINT8), 0);
    CHECK_EQ_INT(epsnet_attr_layout_add(&l, "nx", EPSNET_ATTR_FLOAT32), 0);
    CHECK_EQ_INT(epsnet_attr_layout_add(&l, "conf", EPSNET_ATTR_FLOAT64), 0);
    CHECK_EQ_U64(l.size, 13);
    CHECK_EQ_U64(l.attr[2].offset, 5);
    CHECK_EQ_INT(epsnet_attr_layout_find(&l, "nx"), 1);
    CHECK_EQ_INT(epsnet_attr_layout_find(&l, "ny"), -1);
    CHECK_EQ_INT(epsnet_attr_layout_add(&l, "red", EPSNET_ATTR_UINT8), EPSNET_EINVAL);
    CHECK_EQ_INT(epsnet_attr_layout_add(&l, "", EPSNET_ATTR_UINT8), EPSNET_EINVAL);
    CHECK_EQ_INT(epsnet_attr_layout_add(&l, "a b", EPSNET_ATTR_UINT8), EPSNET_EINVAL);
    CHECK_EQ_INT(epsnet_attr_layout_add(&l, "t", (epsnet_attr_type)9), EPSNET_EINVAL);
    CHECK_EQ_U64(epsnet_attr_type_size(EPSNET_ATTR_INT16), 2);
    CHECK(strcmp(epsnet_attr_type_name(EPSNET_ATTR_UINT32), "uint") == 0);
    CHECK(epsnet_attr_type_name((epsnet_attr_type)0) == NULL);
    epsnet_attr_layout full;
    memset(&full, 0, sizeof full);
    char name[16];
    for (int i = 0; i < EPSNET_ATTR_MAX; i++) {
        snprintf(name, sizeof name, "a%d", i);
        CHECK_EQ_INT(epsnet_attr_layout_add(&full, name, EPSNET_ATTR_INT8), 0);
    }
    CHECK_EQ_INT(epsnet_attr_layout_add(&full, "one_more", EPSNET_ATTR_INT8), EPSNET_ELIMIT);

    epsnet_mesh_info info;
    memset(&info, 0, sizeof info);
    info.nverts = info.nfaces = EPSNET_COUNT_UNKNOWN;
    info.vertex_attrs = l;
    info.vertex_attrs.attr[1].offset = 2; /* not packed */
    epsnet_writer *w = NULL;
    epsnet_error err;
    const char *p = tl_path("bad_layout.ply");
    CHECK_EQ_INT(epsnet_writer_open(&w, p, NULL, &info, &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(err.reason, "offset");
    info.vertex_attrs = l;
    info.vertex_attrs.size = 12;
    CHECK_EQ_INT(epsnet_writer_open(&w, p, NULL, &info, &err), EPSNET_EINVAL);
    info.vertex_attrs = l;
    info.vertex_attrs.attr[0].of_face = 2; /* a flag: 0 or 1 */
    CHECK_EQ_INT(epsnet_writer_open(&w, p, NULL, &info, &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(err.reason, "of_face");
    epsnet_attr_layout faced = l;
    CHECK_EQ_INT(epsnet_attr_layout_add_of_face(&faced, "material_index", EPSNET_ATTR_UINT16), 0);
    CHECK_EQ_U64(faced.attr[3].of_face, 1);
    CHECK_EQ_U64(faced.attr[3].offset, 13);
    CHECK_EQ_U64(faced.attr[2].of_face, 0);
    CHECK_EQ_INT(epsnet_attr_layout_add_of_face(&faced, "nx", EPSNET_ATTR_UINT16), EPSNET_EINVAL);
    info.vertex_attrs = l;
    CHECK_EQ_INT(epsnet_writer_open(&w, p, NULL, &info, &err), 0);
    epsnet_record rec = { .kind = EPSNET_REC_VERTEX };
    CHECK_EQ_INT(epsnet_writer_put(w, &rec, &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(err.reason, "no attribute bytes");
    epsnet_writer_abort(&w);
    /* SMB holds none: it names them all */
    CHECK_EQ_INT(epsnet_writer_open(&w, tl_path("names.smb"), NULL, &info, &err), 0);
    uint64_t n = 0;
    const char *what = epsnet_writer_dropped(w, &n);
    CHECK(what && strcmp(what, "vertex property red, vertex property nx, vertex property conf") == 0);
    CHECK_EQ_U64(n, 3);
    epsnet_writer_abort(&w);
}

int main(void)
{
    RUN(source_lines_handle_crlf_and_missing_final_newline);
    RUN(source_rejects_overlong_line_with_its_number);
    RUN(source_reads_zstd_transparently_whatever_the_name);
    RUN(source_reports_corrupt_zstd);
    RUN(source_read_ahead_gives_the_same_lines_offsets_and_errors);
    RUN(sink_commit_renames_and_abort_leaves_nothing);
    RUN(sink_zstd_output_reads_back);
    RUN(sink_onto_a_device_writes_in_place);
    RUN(sink_into_missing_directory_fails_cleanly);
    RUN(spill_round_trips_and_leaves_no_file);
    RUN(plain_spill_keeps_bytes_as_written_across_small_and_large_writes);
    RUN(plain_spill_written_behind_keeps_bytes_in_order);
    RUN(allocations_keep_their_bytes_across_the_mapping_line);
    RUN(u64set_add_remove_many);
    RUN(parse_size_accepts_binary_suffixes);
    RUN(error_messages_name_file_and_position);
    RUN(records_before_a_bad_line_arrive_before_the_error);
    RUN(format_coord_is_shortest_exact);
    RUN(attribute_layouts_are_built_and_checked);
    tl_cleanup();
    return tl_finish();
}
