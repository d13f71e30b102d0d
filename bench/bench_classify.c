/*
 * Classification throughput on one thread (issue 3): the mesh is read once
 * into a one-slab slab, then for each level the two stages are timed apart:
 *   faces:    normal -> G's frame -> Gaussian triangle (target 20 M faces/s)
 *   vertices: candidates and the exact winding test
 * Prints one row per level: level, G vertices, samples, candidates,
 * faces/s of the face stage, vertices/s of the vertex stage, faces/s overall.
 * Usage: bench_classify FILE [min_level max_level] [repetitions]
 */
#include <stdio.h>
#include <stdlib.h>

#include "common/alloc.h"
#include "common/util.h"
#include "core/classify.h"
#include "core/gauss.h"
#include "core/slab.h"

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: bench_classify FILE [min_level max_level] [repetitions]\n");
        return 1;
    }
    int lo = argc > 3 ? atoi(argv[2]) : 1, hi = argc > 3 ? atoi(argv[3]) : 5;
    int reps = argc > 4 ? atoi(argv[4]) : 3;
    epsnet_error err;
    epsnet_reader *r = NULL;
    en_slab s;
    en_slab_init(&s);
    double t0 = en_now();
    if (epsnet_reader_open(&r, argv[1], NULL, &err) || en_slab_read_all(&s, r, argv[1], &err)) {
        fprintf(stderr, "bench_classify: %s\n", epsnet_error_message(&err));
        return 1;
    }
    epsnet_reader_close(&r);
    double tread = en_now() - t0;
    double *fn = en_malloc(3 * sizeof *fn * s.nt + 8);
    int32_t *ft = en_malloc(sizeof *ft * s.nt + 8);
    uint8_t *vc = en_calloc(s.nv + 1, 1);
    int32_t *vg = en_malloc(sizeof *vg * s.nv + 8);
    printf("# %s: %u vertices, %u faces, read+stars %.2f s\n", argv[1], s.nv, s.nt, tread);
    printf("%5s %8s %9s %10s %12s %12s %12s\n", "level", "G_verts", "samples", "candidates", "face_stage/s",
           "vert_stage/s", "faces/s_all");
    for (int level = lo; level <= hi; level++) {
        gauss_rotation rot;
        gauss_rotation_default(&rot);
        gauss_sphere g;
        gauss_init_level(&g, level, &rot);
        double bf = 1e30, bv = 1e30;
        en_classify_counts c = { 0 };
        for (int k = 0; k < reps; k++) {
            en_classify_counts cc = { 0 };
            uint32_t bad;
            double a = en_now();
            en_classify_faces(&g, &s, 0, s.nt, fn, ft, &cc, &bad);
            double b = en_now();
            en_classify_vertices(&g, &s, fn, ft, 0, s.nv, vc, vg, &cc);
            double e = en_now();
            if (b - a < bf)
                bf = b - a;
            if (e - b < bv)
                bv = e - b;
            c = cc;
        }
        printf("%5d %8u %9llu %10llu %12.3g %12.3g %12.3g\n", level, g.nverts, (unsigned long long)c.samples,
               (unsigned long long)c.candidates, s.nt / bf, s.nv / bv, s.nt / (bf + bv));
    }
    en_free(fn);
    en_free(ft);
    en_free(vc);
    en_free(vg);
    en_slab_free(&s);
    return 0;
}
