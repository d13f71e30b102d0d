#include "cli.h"

#include <errno.h>
#include <malloc.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

int cli_quiet;

int cli_exit_code(int code)
{
    switch (code) {
    case EPSNET_OK: return EXIT_OK;
    case EPSNET_EINVAL: return EXIT_USAGE;
    case EPSNET_EFORMAT: return EXIT_BAD_INPUT;
    case EPSNET_EIO: return EXIT_IO;
    case EPSNET_ENOMEM:
    case EPSNET_ELIMIT: return EXIT_RESOURCES;
    case EPSNET_EUNSUPPORTED: return EXIT_UNSUPPORTED;
    case EPSNET_EINTR: return EXIT_INTERRUPTED;
    default: return EXIT_INTERNAL;
    }
}

const epsnet_peers *cli_peers;

static void on_signal(int sig)
{
    epsnet_remove_temporaries();
    signal(sig, SIG_DFL);
    _exit(EXIT_INTERRUPTED);
}

void cli_process_setup(void)
{
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    signal(SIGHUP, on_signal);
    signal(SIGPIPE, SIG_IGN); /* a closed pipe becomes an ordinary EIO/EPIPE error */
    signal(SIGXFSZ, SIG_IGN); /* over `ulimit -f`: a clear EFBIG error, not a core dump */
    /* Slabs are allocated on one thread and freed on another; with glibc's
     * default sliding mmap threshold, their freed arrays stay in the heap
     * arenas and peak RSS creeps up with the slab count (measured: 357 MB
     * instead of 279 MB on 20M faces at -j2 --mem 1G). The library maps its
     * own large blocks (src/common/alloc.c); this fixes the threshold for
     * the rest of the process (zstd's buffers, the C library's). */
    mallopt(M_MMAP_THRESHOLD, 1 << 20);
}

int cli_follower(void)
{
    return cli_peers && cli_peers->rank != 0;
}

int cli_fail(const epsnet_error *err)
{
    if (!cli_follower())
        fprintf(stderr, "epsnet: %s\n", epsnet_error_message(err));
    return cli_exit_code(err->code);
}

int cli_usage_error(const char *cmd, const char *fmt, ...)
{
    if (cli_follower())
        return EXIT_USAGE;
    va_list ap;
    fprintf(stderr, "epsnet %s: ", cmd);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, " (see 'epsnet %s --help')\n", cmd);
    return EXIT_USAGE;
}

int cli_parse_u64(const char *cmd, const char *opt, const char *text, uint64_t *out)
{
    char *end;
    errno = 0;
    if (!text || !*text || *text == '-')
        return cli_usage_error(cmd, "%s needs a non-negative integer", opt);
    unsigned long long v = strtoull(text, &end, 10);
    if (errno || *end)
        return cli_usage_error(cmd, "%s: '%s' is not a non-negative integer", opt, text);
    *out = v;
    return 0;
}

int cli_parse_double(const char *cmd, const char *opt, const char *text, double *out)
{
    char *end;
    errno = 0;
    double v = text ? strtod(text, &end) : 0;
    if (!text || !*text || errno || *end || !isfinite(v))
        return cli_usage_error(cmd, "%s: '%s' is not a number", opt, text ? text : "");
    *out = v;
    return 0;
}

int cli_parse_size(const char *cmd, const char *opt, const char *text, uint64_t *out)
{
    if (epsnet_parse_size(text, out))
        return cli_usage_error(cmd, "%s: '%s' is not a size (e.g. 512M, 2G)", opt, text ? text : "");
    return 0;
}

double cli_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

void cli_progress_begin(cli_progress *p, const char *label)
{
    p->enabled = !cli_quiet && isatty(2);
    p->label = label;
    p->start = p->last = cli_now();
}

static void human(char *buf, size_t n, double v)
{
    const char *unit = "";
    if (v >= 1e9) { v /= 1e9; unit = "G"; }
    else if (v >= 1e6) { v /= 1e6; unit = "M"; }
    else if (v >= 1e3) { v /= 1e3; unit = "k"; }
    snprintf(buf, n, "%.1f%s", v, unit);
}

void cli_progress_update(cli_progress *p, uint64_t done, uint64_t total, uint64_t items)
{
    if (!p->enabled)
        return;
    double now = cli_now();
    if (now - p->last < 0.1)
        return;
    p->last = now;
    double el = now - p->start;
    char rate[32], count[32];
    human(count, sizeof count, (double)items);
    human(rate, sizeof rate, el > 0 ? (double)items / el : 0);
    if (total) {
        double f = (double)done / (double)total;
        if (f > 1)
            f = 1;
        int w = 30, fill = (int)(f * w);
        char bar[32];
        for (int i = 0; i < w; i++)
            bar[i] = i < fill ? '#' : '.';
        bar[w] = '\0';
        double eta = f > 0 ? el / f - el : 0;
        fprintf(stderr, "\r%s [%s] %5.1f%% %s (%s/s) ETA %.0fs   ", p->label, bar, 100 * f, count, rate, eta);
    } else {
        fprintf(stderr, "\r%s %s (%s/s)   ", p->label, count, rate);
    }
}

int cli_run_progress_cb(void *opaque, uint64_t done, uint64_t total)
{
    cli_run_progress *rp = opaque;
    uint64_t faces = rp->ctx ? epsnet_context_stats(rp->ctx)->faces : 0;
    cli_progress_update(&rp->bar, done, total, faces);
    return 0;
}

void cli_warning(void *opaque, const char *message)
{
    if (cli_follower())
        return;
    const cli_progress *p = opaque;
    if (p && p->enabled)
        fprintf(stderr, "\r%*s\r", 100, "");
    fprintf(stderr, "warning: %s\n", message);
}

void cli_progress_end(cli_progress *p)
{
    if (p->enabled)
        fprintf(stderr, "\r%*s\r", 100, "");
}

const char cli_method_help[] =
    "      --level L       Gaussian sphere: octahedron split L times, 4^(L+1)+2\n"
    "                      Gaussian vertices (default 3: 258)\n"
    "      --frequency N   finer control: geodesic frequency N, 4N^2+2 vertices\n"
    "      --rotation R    orientation of the sphere: default, identity,\n"
    "                      AX,AY,AZ,DEG (axis, angle) or q:W,X,Y,Z (quaternion)\n"
    "      --seed S        a random orientation from seed S (instead of --rotation)\n"
    "  -j, --threads N     worker threads (default: the processors it may use)\n"
    "      --mem SIZE      memory budget, e.g. 512M, 4G; over it a run stops with\n"
    "                      a clear error (default: half the RAM); when given, it\n"
    "                      also sets the slab size\n"
    "      --slab N        vertices each slab of the streaming pipeline owns (default:\n"
    "                      from --mem, else 65536; a size's slabs hold that many in\n"
    "                      all); the output depends on it, never on --threads\n"
    "      --tmpdir DIR    folder for temporary files\n"
    "      --stats FILE    write statistics as JSON (- for stdout)\n";

void cli_method_init(cli_method *m)
{
    memset(m, 0, sizeof *m);
    epsnet_default_settings(&m->settings);
}

/* Print a usage error and return -1, the method-option failure value. */
static int method_usage(const char *cmd, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static int method_usage(const char *cmd, const char *fmt, ...)
{
    char msg[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    cli_usage_error(cmd, "%s", msg);
    return -1;
}

int cli_method_option(const char *cmd, int code, const char *arg, cli_method *m)
{
    uint64_t v = 0;
    switch (code) {
    case 1000:
        if (cli_parse_u64(cmd, "--level", arg, &v))
            return -1;
        if (v > 14)
            return method_usage(cmd, "--level must be between 0 and 14");
        m->settings.level = (int)v;
        m->settings.target_level_given = 1;
        return 1;
    case 1001:
        if (cli_parse_u64(cmd, "--frequency", arg, &v))
            return -1;
        if (v < 1 || v > 16384)
            return method_usage(cmd, "--frequency must be between 1 and 16384");
        m->settings.frequency = (uint32_t)v;
        m->settings.target_level_given = 1;
        return 1;
    case 1002:
        if (cli_parse_u64(cmd, "--seed", arg, &m->settings.seed))
            return -1;
        if (m->rotation_given)
            return method_usage(cmd, "give --seed or --rotation, not both");
        m->seed_given = 1;
        m->settings.rotation_mode = EPSNET_ROTATION_SEED;
        return 1;
    case 1003:
        if (m->seed_given)
            return method_usage(cmd, "give --seed or --rotation, not both");
        if (epsnet_parse_rotation(arg, &m->settings))
            return method_usage(cmd, "--rotation: '%s' is not default, identity, AX,AY,AZ,DEG or q:W,X,Y,Z",
                                   arg);
        m->rotation_given = 1;
        return 1;
    case 'j':
        if (cli_parse_u64(cmd, "--threads", arg, &v))
            return -1;
        if (v > 1024)
            return method_usage(cmd, "--threads must be at most 1024");
        m->settings.threads = (int)v;
        return 1;
    case 1004:
        if (cli_parse_size(cmd, "--mem", arg, &m->settings.mem))
            return -1;
        return 1;
    case 1005:
        m->settings.tmpdir = arg;
        return 1;
    case 1006:
        m->stats_path = arg;
        return 1;
    case 1007:
        if (cli_parse_u64(cmd, "--slab", arg, &v))
            return -1;
        if (v < 1 || v > (1u << 30))
            return method_usage(cmd, "--slab must be between 1 and 2^30 vertices");
        m->settings.slab_vertices = (uint32_t)v;
        return 1;
    default:
        return 0;
    }
}
