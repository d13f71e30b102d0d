/*
 * The in-memory call from C, as the Python binding makes it: the C side of
 * bench/python_overhead.py's memory comparison (issue 27). The CLI streams
 * its output to a file, where epsnet_simplify_arrays() and the binding hand
 * the kept mesh back in arrays, so only this program does the binding's work.
 *
 *   bench_arrays V.npy F.npy [RATIO]
 *
 * V.npy: float32 or float64 (n, 3); F.npy: int32 or int64 (m, 3), both
 * C-ordered little-endian, as numpy.save writes them. Loads them with one
 * fread each (no reader's heap stays behind), resets the process's peak RSS
 * (Linux: /proc/self/clear_refs), calls epsnet_simplify_arrays() with the
 * default settings (and target_ratio RATIO), keeps the result until the peak
 * is read, and prints one JSON line: the resident set before loading
 * ("base"), after ("loaded"), the peak during the call ("call_peak",
 * bytes), the library's own seconds and the faces kept.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "epsnet/epsnet.h"

static void die(const char *what, const char *why)
{
    fprintf(stderr, "bench_arrays: %s: %s\n", what, why);
    exit(1);
}

/* Current resident set in bytes (/proc/self/statm's second field, pages). */
static long long rss_now(void)
{
    long long size = 0, resident = 0;
    FILE *f = fopen("/proc/self/statm", "r");
    if (!f || fscanf(f, "%lld %lld", &size, &resident) != 2)
        die("/proc/self/statm", "cannot read");
    fclose(f);
    return resident * 4096;
}

/* Peak resident set since the last reset (VmHWM), bytes. */
static long long rss_peak(void)
{
    char line[256];
    long long kb = -1;
    FILE *f = fopen("/proc/self/status", "r");
    if (!f)
        die("/proc/self/status", "cannot open");
    while (fgets(line, sizeof line, f))
        if (sscanf(line, "VmHWM: %lld kB", &kb) == 1)
            break;
    fclose(f);
    if (kb < 0)
        die("/proc/self/status", "no VmHWM line");
    return kb * 1024;
}

/* One .npy array of shape (n, 3): its element type from the header's descr
 * ('<f4', '<f8', '<i4', '<i8'), its rows, and its data in one buffer. */
static void *load_npy(const char *path, char *kind, int *bytes, unsigned long long *rows)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        die(path, "cannot open");
    unsigned char pre[10];
    if (fread(pre, 1, 10, f) != 10 || memcmp(pre, "\x93NUMPY", 6) != 0)
        die(path, "not a .npy file");
    size_t hlen = pre[6] == 1 ? (size_t)pre[8] | (size_t)pre[9] << 8 : 0;
    if (pre[6] != 1) { /* version 2 and 3: a four-byte header length */
        unsigned char more[2];
        if (fread(more, 1, 2, f) != 2)
            die(path, "short header");
        hlen = (size_t)pre[8] | (size_t)pre[9] << 8 | (size_t)more[0] << 16 | (size_t)more[1] << 24;
    }
    char *h = calloc(hlen + 1, 1);
    if (!h || fread(h, 1, hlen, f) != hlen)
        die(path, "short header");
    const char *d = strstr(h, "'descr': '<");
    const char *s = strstr(h, "'shape': (");
    if (!d || !s || strstr(h, "'fortran_order': True"))
        die(path, "not a little-endian C-ordered array");
    *kind = d[11];
    *bytes = d[12] - '0';
    unsigned long long cols = 0;
    if (sscanf(s + 10, "%llu, %llu)", rows, &cols) != 2 || cols != 3)
        die(path, "not of shape (n, 3)");
    free(h);
    size_t n = (size_t)(*rows * 3 * (unsigned long long)*bytes);
    void *data = malloc(n ? n : 1);
    if (!data || fread(data, 1, n, f) != n)
        die(path, "short data");
    fclose(f);
    return data;
}

int main(int argc, char **argv)
{
    if (argc < 3 || argc > 4) {
        fprintf(stderr, "usage: bench_arrays V.npy F.npy [RATIO]\n");
        return 1;
    }
    long long base = rss_now();
    epsnet_arrays in;
    epsnet_arrays_init(&in);
    char vk, fk;
    int vb, fb;
    unsigned long long nv, nf;
    in.xyz = load_npy(argv[1], &vk, &vb, &nv);
    in.faces = load_npy(argv[2], &fk, &fb, &nf);
    if (vk != 'f' || (vb != 4 && vb != 8) || fk != 'i' || (fb != 4 && fb != 8))
        die(argv[1], "vertices must be float32/64 and faces int32/64");
    in.nverts = nv;
    in.coord_type = vb == 4 ? EPSNET_COORD_FLOAT32 : EPSNET_COORD_FLOAT64;
    in.nfaces = nf;
    in.index_bytes = fb;
    long long loaded = rss_now();
    FILE *refs = fopen("/proc/self/clear_refs", "w");
    if (!refs || fputs("5", refs) < 0 || fclose(refs) != 0)
        die("/proc/self/clear_refs", "cannot reset the peak");

    epsnet_settings s;
    epsnet_default_settings(&s);
    if (argc == 4)
        s.target_ratio = atof(argv[3]);
    epsnet_context *ctx = NULL;
    epsnet_error err;
    epsnet_arrays_out out;
    if (epsnet_context_new(&ctx, &s, &err) || epsnet_simplify_arrays(ctx, &in, &out, &err))
        die("epsnet_simplify_arrays", epsnet_error_message(&err));
    long long call_peak = rss_peak(); /* the result still held, as the binding's caller holds it */
    const epsnet_stats *st = epsnet_context_stats(ctx);
    printf("{\"base\": %lld, \"loaded\": %lld, \"call_peak\": %lld, \"c_seconds\": %.6f, \"faces\": %llu}\n",
           base, loaded, call_peak, st->seconds_simplify, (unsigned long long)out.nfaces);
    epsnet_arrays_out_free(&out);
    epsnet_context_free(&ctx);
    free((void *)in.xyz);
    free((void *)in.faces);
    return 0;
}
