/*
 * Face association throughput (issue 3, "Measure"): rotation into G's frame
 * plus exact point location, per face normal, on one thread.
 *
 * Normals are the cross products of random triangles' edges (not unit, as
 * in the classifier), generated up front so only gauss_to_frame() and
 * gauss_locate() are timed. Prints one table row per level.
 *
 *   gauss_locate_bench [normals (default 4000000)] [repeats (default 5)]
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "core/gauss.h"

static uint64_t bench_rng = 0x5eed5eed5eed5eedull;

static double bench_uniform(void)
{
    uint64_t z = (bench_rng += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1p-53 * 2.0 - 1.0;
}

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(int argc, char **argv)
{
    size_t count = argc > 1 ? (size_t)strtoull(argv[1], NULL, 10) : 4000000;
    int repeats = argc > 2 ? atoi(argv[2]) : 5;
    if (count == 0 || repeats < 1)
        return 2;
    double(*normals)[3] = malloc(count * sizeof *normals);
    if (!normals)
        return 2;
    for (size_t i = 0; i < count; i++) {
        double a[3], b[3], c[3];
        for (int k = 0; k < 3; k++) {
            a[k] = bench_uniform();
            b[k] = bench_uniform();
            c[k] = bench_uniform();
        }
        double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        normals[i][0] = u[1] * v[2] - u[2] * v[1];
        normals[i][1] = u[2] * v[0] - u[0] * v[2];
        normals[i][2] = u[0] * v[1] - u[1] * v[0];
    }
    gauss_rotation rot;
    gauss_rotation_default(&rot);
    printf("%-6s %-8s %12s %14s %12s\n", "level", "N", "ns/normal", "Mnormals/s", "checksum");
    for (int level = 0; level <= 10; level++) {
        gauss_sphere g;
        if (gauss_init_level(&g, level, &rot) != 0)
            return 2;
        double best = 1e30;
        uint64_t checksum = 0;
        for (int r = 0; r < repeats; r++) {
            uint64_t sum = 0;
            double t0 = now_seconds();
            for (size_t i = 0; i < count; i++) {
                double nf[3];
                if (gauss_to_frame(&g, normals[i], nf) == 1)
                    sum += (uint64_t)gauss_locate(&g, nf);
            }
            double dt = now_seconds() - t0;
            if (dt < best)
                best = dt;
            checksum = sum;
        }
        double ns = best * 1e9 / (double)count;
        printf("%-6d %-8u %12.2f %14.1f %12llu\n", level, g.n, ns, 1e3 / ns,
               (unsigned long long)(checksum % 1000000007ull));
    }
    free(normals);
    return 0;
}
