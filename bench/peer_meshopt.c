/*
 * The peer to beat (issue 4): meshoptimizer's meshopt_simplify on
 * the same mesh, to the same output face count. Reads and writes through
 * epsnet's public API, so both tools see identical input and the output is
 * compacted the same way (unreferenced vertices dropped).
 *   peer_meshopt IN OUT TARGET_FACES
 * Prints: faces_in faces_out seconds peak_rss_bytes
 * note: borders are locked (meshopt_SimplifyLockBorder), as epsnet locks
 * boundary vertices; target_error 1 means "no error limit", so the face
 * count alone stops it.
 */
#include <meshoptimizer.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "epsnet/epsnet.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static unsigned long long peak_rss(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    unsigned long long kb = 0;
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, "VmHWM:", 6))
            kb = strtoull(line + 6, NULL, 10);
    if (f)
        fclose(f);
    return kb * 1024;
}

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: peer_meshopt IN OUT TARGET_FACES\n");
        return 1;
    }
    size_t target = strtoull(argv[3], NULL, 10);
    epsnet_error err;
    epsnet_reader *r = NULL;
    double t0 = now();
    if (epsnet_reader_open(&r, argv[1], NULL, &err)) {
        fprintf(stderr, "peer_meshopt: %s\n", epsnet_error_message(&err));
        return 1;
    }
    size_t nv = 0, nt = 0, vcap = 1024, tcap = 1024;
    float *pos = malloc(vcap * 3 * sizeof *pos);
    unsigned *idx = malloc(tcap * 3 * sizeof *idx);
    epsnet_record rec;
    int rc;
    while ((rc = epsnet_reader_next(r, &rec, &err)) > 0) {
        if (rec.kind == EPSNET_REC_VERTEX) {
            if (nv == vcap)
                pos = realloc(pos, (vcap *= 2) * 3 * sizeof *pos);
            for (int k = 0; k < 3; k++)
                pos[3 * nv + k] = (float)rec.xyz[k];
            nv++;
        } else if (rec.kind == EPSNET_REC_TRIANGLE) {
            if (nt == tcap)
                idx = realloc(idx, (tcap *= 2) * 3 * sizeof *idx);
            for (int k = 0; k < 3; k++)
                idx[3 * nt + k] = (unsigned)rec.v[k];
            nt++;
        }
    }
    epsnet_reader_close(&r);
    if (rc < 0) {
        fprintf(stderr, "peer_meshopt: %s\n", epsnet_error_message(&err));
        return 1;
    }
    double t1 = now();
    unsigned *out = malloc(nt * 3 * sizeof *out + 4);
    float result_error = 0;
    size_t n = meshopt_simplify(out, idx, nt * 3, pos, nv, 3 * sizeof(float), target * 3, 1.0f,
                                meshopt_SimplifyLockBorder, &result_error);
    double t2 = now();
    /* compact: keep referenced vertices in their old order */
    long *map = malloc(nv * sizeof *map + 8);
    for (size_t v = 0; v < nv; v++)
        map[v] = -1;
    for (size_t i = 0; i < n; i++)
        map[out[i]] = 0;
    epsnet_mesh_info info;
    memset(&info, 0, sizeof info);
    info.nverts = info.nfaces = EPSNET_COUNT_UNKNOWN;
    info.coord_type = EPSNET_COORD_FLOAT32;
    info.sorted_axis = -1;
    epsnet_writer *w = NULL;
    rc = epsnet_writer_open(&w, argv[2], NULL, &info, &err);
    long next = 0;
    for (size_t v = 0; v < nv && rc == 0; v++)
        if (map[v] == 0) {
            map[v] = next++;
            rec.kind = EPSNET_REC_VERTEX;
            for (int k = 0; k < 3; k++)
                rec.xyz[k] = pos[3 * v + k];
            rc = epsnet_writer_put(w, &rec, &err);
        }
    for (size_t i = 0; i + 2 < n && rc == 0; i += 3) {
        rec.kind = EPSNET_REC_TRIANGLE;
        for (int k = 0; k < 3; k++)
            rec.v[k] = (uint64_t)map[out[i + k]];
        rc = epsnet_writer_put(w, &rec, &err);
    }
    if (rc == 0)
        rc = epsnet_writer_commit(&w, &err);
    epsnet_writer_abort(&w);
    if (rc) {
        fprintf(stderr, "peer_meshopt: %s\n", epsnet_error_message(&err));
        return 1;
    }
    /* seconds: simplification alone (reading and writing excluded, as
     * epsnet's own stats separate its stages) */
    printf("%zu %zu %.4f %llu %.4f\n", nt, n / 3, t2 - t1, peak_rss(), t1 - t0);
    free(pos);
    free(idx);
    free(out);
    free(map);
    return 0;
}
