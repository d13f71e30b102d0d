/*
 * epsnet sort: any mesh into a spatially sorted, finalized streaming mesh,
 * out of core (docs/architecture.md §13; epsnet_sort_file() in the public header).
 */
#include <getopt.h>
#include <string.h>

#include "cli.h"

static void sort_help(void)
{
    printf("usage: epsnet sort IN -o OUT.smz [options]\n"
           "\n"
           "Turn any readable mesh (PLY, OBJ, OFF, STL, SMA, SMB, SMZ, any of them in .zst),\n"
           "of any size, into a spatially sorted, finalized streaming mesh: vertices in\n"
           "order along the axis, each triangle right after its last vertex, each vertex\n"
           "finalized right after its last triangle. Vertices no triangle uses are\n"
           "dropped. Temporary runs are uncompressed anonymous files that vanish on\n"
           "any exit. The same input and options give the same bytes.\n"
           "\n"
           "  -o, --output FILE   destination (required); .smz keeps the finalization\n"
           "      --axis A        x, y, z or auto: the longest side of the bounding box\n"
           "                      (default auto)\n"
           "      --mem SIZE      memory budget, e.g. 256M, 4G (default 512M)\n"
           "      --tmpdir DIR    folder for the temporary runs (default: beside OUT)\n"
           "  -j, --threads N     threads when the mesh fits in half of --mem and is\n"
           "                      sorted in memory (default 0: the processors it may use); the output\n"
           "                      is the same for any N\n"
           "      --format NAME   output format instead of OUT's extension\n"
           "  -q, --quiet         no progress bar, no summary\n"
           "  -h, --help          this text\n");
}

static int sort_progress(void *opaque, uint64_t done, uint64_t total)
{
    cli_progress_update(opaque, done, total, 0);
    return 0;
}

static int parse_axis(const char *text, int *axis)
{
    static const char *const names[] = { "x", "y", "z" };
    if (strcmp(text, "auto") == 0) {
        *axis = -1;
        return 0;
    }
    for (int k = 0; k < 3; k++)
        if (strcmp(text, names[k]) == 0) {
            *axis = k;
            return 0;
        }
    return cli_usage_error("sort", "--axis: '%s' is not x, y, z or auto", text);
}

int cmd_sort(int argc, char **argv)
{
    static const struct option opts[] = {
        { "output", required_argument, NULL, 'o' }, { "axis", required_argument, NULL, 'A' },
        { "mem", required_argument, NULL, 'm' },    { "tmpdir", required_argument, NULL, 't' },
        { "format", required_argument, NULL, 'f' }, { "quiet", no_argument, NULL, 'q' },
        { "help", no_argument, NULL, 'h' },         { "threads", required_argument, NULL, 'j' },
        { 0, 0, 0, 0 },
    };
    epsnet_sort_settings ss;
    epsnet_sort_default_settings(&ss);
    const char *out = NULL;
    int c, rc;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:j:qh", opts, NULL)) != -1) {
        switch (c) {
        case 'o': out = optarg; break;
        case 'A':
            if ((rc = parse_axis(optarg, &ss.axis)))
                return rc;
            break;
        case 'm':
            if ((rc = cli_parse_size("sort", "--mem", optarg, &ss.mem)))
                return rc;
            if (ss.mem == 0)
                return cli_usage_error("sort", "--mem must be more than 0");
            break;
        case 't': ss.tmpdir = optarg; break;
        case 'j': {
            uint64_t v;
            if ((rc = cli_parse_u64("sort", "--threads", optarg, &v)))
                return rc;
            if (v > 1024)
                return cli_usage_error("sort", "--threads must be at most 1024");
            ss.threads = (int)v;
            break;
        }
        case 'f': ss.format = optarg; break;
        case 'q': cli_quiet = 1; break;
        case 'h': sort_help(); return EXIT_OK;
        default: return cli_usage_error("sort", "bad option");
        }
    }
    if (optind != argc - 1)
        return cli_usage_error("sort", "needs exactly one input file");
    if (!out)
        return cli_usage_error("sort", "needs -o OUT");
    cli_progress p;
    cli_progress_begin(&p, "sort");
    ss.progress = sort_progress;
    ss.progress_opaque = &p;
    ss.warning = cli_warning;
    ss.warning_opaque = &p;
    epsnet_error err;
    epsnet_sort_stats st;
    rc = epsnet_sort_file(argv[optind], out, &ss, &st, &err);
    cli_progress_end(&p);
    if (rc < 0)
        return cli_fail(&err);
    if (!cli_quiet)
        fprintf(stderr,
                "epsnet sort: %llu vertices (%llu unreferenced, dropped), %llu triangles, along %c -> %s\n"
                "  %.2f s, %llu runs, %.1f MB temporary, peak %.1f MB buffers / %.1f MB RSS, width %llu\n",
                (unsigned long long)st.vertices, (unsigned long long)st.unreferenced,
                (unsigned long long)st.faces, "xyz"[st.axis], out, st.seconds, (unsigned long long)st.runs,
                (double)st.temp_bytes / 1e6, (double)st.peak_memory / 1e6, (double)st.peak_rss / 1e6,
                (unsigned long long)st.max_width);
    return EXIT_OK;
}
