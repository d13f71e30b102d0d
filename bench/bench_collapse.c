/*
 * The collapse core on its own (issue "One stage chain"): the mesh is read
 * into one slab and classified once at a level, then every non-sample is
 * collapsed as simplify would (paper §4.2), REPS times from the same start.
 * Prints the collapses, the best time, collapses/s and nanoseconds per
 * collapse, and a checksum of the result so two builds can be compared.
 * A whole-mesh slab is larger than the pipeline's slabs: the per-collapse
 * work is the same, the cache behaviour is that of the largest slab.
 * Usage: bench_collapse FILE [level] [repetitions]
 */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "common/util.h"
#include "core/classify.h"
#include "core/collapse.h"
#include "core/gauss.h"
#include "core/slab.h"

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: bench_collapse FILE [level] [repetitions]\n");
        return 1;
    }
    int level = argc > 2 ? atoi(argv[2]) : 3, reps = argc > 3 ? atoi(argv[3]) : 3;
    epsnet_error err;
    epsnet_reader *r = NULL;
    en_slab s;
    en_slab_init(&s);
    if (epsnet_reader_open(&r, argv[1], NULL, &err) || en_slab_read_all(&s, r, argv[1], &err)) {
        fprintf(stderr, "bench_collapse: %s\n", epsnet_error_message(&err));
        return 1;
    }
    epsnet_reader_close(&r);
    size_t nv = (size_t)s.nv + 1, nt = (size_t)s.nt + 1;
    double *fn = en_malloc(3 * sizeof *fn * nt);
    int32_t *ft = en_malloc(sizeof *ft * nt);
    uint8_t *vc = en_calloc(nv, 1), *removable = en_calloc(nv, 1), *va = en_malloc(nv), *fa = en_malloc(nt);
    int32_t *vg = en_malloc(sizeof *vg * nv);
    en_quadric *q = en_malloc(sizeof *q * nv);
    double *ref = en_malloc(3 * sizeof *ref * nt);
    uint32_t *tri = en_malloc(3 * sizeof *tri * nt);
    if (!fn || !ft || !vc || !removable || !va || !fa || !vg || !q || !ref || !tri) {
        fprintf(stderr, "bench_collapse: out of memory\n");
        return 1;
    }
    gauss_rotation rot;
    gauss_rotation_default(&rot);
    gauss_sphere g;
    gauss_init_level(&g, level, &rot);
    en_classify_counts cc = { 0 };
    uint32_t bad;
    if (en_classify_faces(&g, &s, 0, s.nt, fn, ft, &cc, &bad) ||
        en_classify_vertices(&g, &s, fn, ft, 0, s.nv, vc, vg, &cc)) {
        fprintf(stderr, "bench_collapse: classification failed\n");
        return 1;
    }
    uint64_t nremovable = 0;
    for (uint32_t v = 0; v < s.nv; v++) {
        removable[v] = !(vc[v] & EN_C_SAMPLE) && !(s.vflags[v] & (EN_V_BOUNDARY | EN_V_NONMANIFOLD | EN_V_ISOLATED));
        nremovable += removable[v];
    }
    en_collapse_settings cs = { .max_normal_dev_deg = 60 };
    en_collapse_counts counts = { 0 };
    double best = 1e30;
    for (int k = 0; k < reps; k++) {
        double t0 = en_now();
        en_quadrics_from_faces(&s, q, ref);
        if (en_collapse_slab(&s, removable, q, ref, &cs, fa, va, tri, &counts, NULL)) {
            fprintf(stderr, "bench_collapse: out of memory\n");
            return 1;
        }
        double t = en_now() - t0;
        if (t < best)
            best = t;
    }
    /* FNV-1a over the surviving faces' corners: equal for equal results */
    uint64_t h = 0xcbf29ce484222325ull;
    for (uint32_t f = 0; f < s.nt; f++)
        for (int k = 0; k < 3 && fa[f]; k++) {
            h ^= tri[3 * (size_t)f + (size_t)k];
            h *= 0x100000001b3ull;
        }
    printf("# %s: %u vertices, %u faces, level %d, %" PRIu64 " removable\n", argv[1], s.nv, s.nt, level,
           nremovable);
    printf("%10s %10s %9s %12s %10s %18s\n", "collapses", "remaining", "seconds", "collapses/s", "ns/collapse",
           "checksum");
    printf("%10" PRIu64 " %10" PRIu64 " %9.3f %12.4g %10.1f %18" PRIx64 "\n", counts.collapses, counts.remaining,
           best, counts.collapses / best, 1e9 * best / (double)(counts.collapses ? counts.collapses : 1), h);
    en_free(fn);
    en_free(ft);
    en_free(vc);
    en_free(removable);
    en_free(va);
    en_free(fa);
    en_free(vg);
    en_free(q);
    en_free(ref);
    en_free(tri);
    en_slab_free(&s);
    return 0;
}
