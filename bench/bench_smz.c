/*
 * .smz decode throughput (issue 5 target: >= 500 MB/s of raw records per
 * core). usage: bench_smz FILE.smz [threads]
 *
 * Two measurements:
 *   reader   the public reader, one thread: every record through
 *            epsnet_reader_next(), with the front end's reference and
 *            finalization checks (what every command pays);
 *   blocks   the codec alone: every block unpacked and decoded to records
 *            through the index, blocks shared out over the threads (what a
 *            parallel chunker pays).
 * Rates are per core: records over CPU time (thread CPU clocks), so a busy
 * machine does not deflate them; wall-clock rates are printed beside.
 * "Raw records" are counted as SMB-sized records (12 bytes each: three
 * float32 or three int32), the plain binary stream the format replaces; the
 * decompressed payload size and the in-memory epsnet_record size are shown
 * beside it.
 */
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include <zstd.h>

#include "io/smz.h"

static double clock_s(clockid_t c)
{
    struct timespec ts;
    clock_gettime(c, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static double now(void)
{
    return clock_s(CLOCK_MONOTONIC);
}

typedef struct job {
    const uint8_t *file;
    const en_smz_index *idx;
    uint64_t first, step;     /* blocks first, first+step, ... */
    uint64_t records, raw_bytes;
    double cpu;
    int failed;
} job;

static void *decode_blocks(void *arg)
{
    job *j = arg;
    ZSTD_DCtx *dctx = ZSTD_createDCtx();
    uint8_t *raw = malloc(EN_SMZ_MAX_RAW_BYTES);
    epsnet_record *recs = malloc(EN_SMZ_MAX_RECORDS * sizeof *recs);
    en_smz_scratch sc = { 0 };
    char why[200];
    double c0 = clock_s(CLOCK_THREAD_CPUTIME_ID);
    for (uint64_t b = j->first; b < j->idx->trailer.blocks; b += j->step) {
        const en_smz_index_entry *e = &j->idx->entries[b];
        en_smz_block_header bh;
        if (en_smz_block_header_decode(j->file + e->offset, &bh, why, sizeof why) ||
            en_smz_unpack(dctx, j->file + e->offset + EN_SMZ_BLOCK_HEADER_BYTES, &bh, raw, why, sizeof why) ||
            en_smz_decode_block_h(raw, &bh, &j->idx->header, NULL, &sc, recs, why, sizeof why)) {
            fprintf(stderr, "block %llu: %s\n", (unsigned long long)b, why);
            j->failed = 1;
            break;
        }
        j->records += bh.records;
        j->raw_bytes += bh.raw_bytes;
    }
    j->cpu = clock_s(CLOCK_THREAD_CPUTIME_ID) - c0;
    free(raw);
    free(recs);
    en_smz_scratch_free(&sc);
    ZSTD_freeDCtx(dctx);
    return NULL;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: bench_smz FILE.smz [threads]\n");
        return 1;
    }
    int threads = argc > 2 ? atoi(argv[2]) : 1;
    if (threads < 1 || threads > 256)
        threads = 1;

    epsnet_error err;
    epsnet_reader *r = NULL;
    if (epsnet_reader_open(&r, argv[1], NULL, &err)) {
        fprintf(stderr, "%s\n", epsnet_error_message(&err));
        return 1;
    }
    epsnet_record rec;
    uint64_t n = 0;
    double t0 = now(), c0 = clock_s(CLOCK_THREAD_CPUTIME_ID);
    int rc;
    while ((rc = epsnet_reader_next(r, &rec, &err)) > 0)
        n++;
    double t_reader = now() - t0, c_reader = clock_s(CLOCK_THREAD_CPUTIME_ID) - c0;
    epsnet_reader_close(&r);
    if (rc < 0) {
        fprintf(stderr, "%s\n", epsnet_error_message(&err));
        return 1;
    }

    int fd = open(argv[1], O_RDONLY);
    struct stat st;
    fstat(fd, &st);
    uint8_t *file = malloc((size_t)st.st_size);
    if (pread(fd, file, (size_t)st.st_size, 0) != st.st_size)
        return 1;
    en_smz_index idx;
    if (en_smz_read_index(fd, argv[1], (uint64_t)st.st_size, &idx, &err)) {
        fprintf(stderr, "%s\n", epsnet_error_message(&err));
        return 1;
    }
    close(fd);
    job *jobs = calloc((size_t)threads, sizeof *jobs);
    pthread_t *tid = calloc((size_t)threads, sizeof *tid);
    t0 = now();
    for (int i = 0; i < threads; i++) {
        jobs[i] = (job){ .file = file, .idx = &idx, .first = (uint64_t)i, .step = (uint64_t)threads };
        pthread_create(&tid[i], NULL, decode_blocks, &jobs[i]);
    }
    uint64_t records = 0, raw = 0;
    double cpu = 0;
    int failed = 0;
    for (int i = 0; i < threads; i++) {
        pthread_join(tid[i], NULL);
        records += jobs[i].records;
        raw += jobs[i].raw_bytes;
        cpu += jobs[i].cpu;
        failed |= jobs[i].failed;
    }
    double t_blocks = now() - t0;

    printf("file %s: %lld bytes, %llu blocks, %llu records, %llu raw payload bytes\n", argv[1],
           (long long)st.st_size, (unsigned long long)idx.trailer.blocks, (unsigned long long)n,
           (unsigned long long)raw);
    printf("%-8s %8s %12s %16s %14s %16s %12s\n", "path", "threads", "Mrec/s/core", "MB/s/core (12B)",
           "payload MB/s", "epsnet_rec MB/s", "wall Mrec/s");
    printf("%-8s %8d %12.1f %16.0f %14.0f %16.0f %12.1f\n", "reader", 1, n / c_reader / 1e6,
           12.0 * n / c_reader / 1e6, raw / c_reader / 1e6, (double)sizeof rec * n / c_reader / 1e6,
           n / t_reader / 1e6);
    printf("%-8s %8d %12.1f %16.0f %14.0f %16.0f %12.1f\n", "blocks", threads, records / cpu / 1e6,
           12.0 * records / cpu / 1e6, raw / cpu / 1e6, (double)sizeof rec * records / cpu / 1e6,
           records / t_blocks / 1e6);
    en_smz_index_free(&idx);
    free(file);
    free(jobs);
    free(tid);
    return failed;
}
