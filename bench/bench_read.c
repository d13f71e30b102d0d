/*
 * Read throughput of a mesh file through the public reader API: every record
 * is decoded and validated, nothing else. Prints one line:
 *   FILE BYTES SECONDS MB/s faces/s vertices faces
 * Usage: bench_read FILE [repetitions]   (best of the repetitions)
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "epsnet/epsnet.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: bench_read FILE [repetitions]\n");
        return 1;
    }
    int reps = argc > 2 ? atoi(argv[2]) : 3;
    double best = 1e30;
    unsigned long long nv = 0, nt = 0, bytes = 0;
    for (int rep = 0; rep < reps; rep++) {
        epsnet_error err;
        epsnet_reader *r = NULL;
        double t0 = now();
        if (epsnet_reader_open(&r, argv[1], NULL, &err)) {
            fprintf(stderr, "bench_read: %s\n", epsnet_error_message(&err));
            return 1;
        }
        epsnet_record rec;
        int rc;
        nv = nt = 0;
        while ((rc = epsnet_reader_next(r, &rec, &err)) > 0) {
            nv += rec.kind == EPSNET_REC_VERTEX;
            nt += rec.kind == EPSNET_REC_TRIANGLE;
        }
        double t = now() - t0;
        bytes = epsnet_reader_bytes_read(r);
        epsnet_reader_close(&r);
        if (rc < 0) {
            fprintf(stderr, "bench_read: %s\n", epsnet_error_message(&err));
            return 1;
        }
        if (t < best)
            best = t;
    }
    printf("%s %llu %.3f %.1f %.3g %llu %llu\n", argv[1], bytes, best, (double)bytes / best / 1e6,
           (double)nt / best, nv, nt);
    return 0;
}
