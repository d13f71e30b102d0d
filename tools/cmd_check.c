/*
 * epsnet check: is FILE a valid streaming mesh (docs/architecture.md §6)? It must
 * read without error (every triangle after its corners, no reference to a
 * finalized vertex, every .smz block checksum right), finalize every vertex
 * it reads, and be sorted along the axis it declares or --axis names. The
 * report gives the stream's width and span (as `epsnet info` defines them),
 * the axes it is sorted along, and how many vertices are finalized late
 * (not right after their last triangle) or never used.
 */
#include <getopt.h>
#include <inttypes.h>
#include <stdarg.h>
#include <string.h>

#include "cli.h"
#include "stream_window.h"

static void check_help(void)
{
    printf("usage: epsnet check FILE [options]\n"
           "\n"
           "Validate a streaming mesh: readable without error (order, references,\n"
           "checksums of .smz blocks), every vertex finalized, sorted along its\n"
           "declared axis. Prints counts, the sorted axes, width and span; exits 0 when\n"
           "valid and 2 (with one line naming the file and the fault) when not.\n"
           "\n"
           "      --axis A      also require vertices sorted along x, y or z\n"
           "      --strict      also require every vertex finalized right after its\n"
           "                    last triangle (what 'epsnet sort' writes)\n"
           "      --mem SIZE    memory for the live window (default 1G)\n"
           "  -q, --quiet       no progress bar; print only errors\n"
           "  -h, --help        this text\n");
}

static int invalid(const char *path, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static int invalid(const char *path, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "epsnet: %s: not a valid streaming mesh: ", path);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return EXIT_BAD_INPUT;
}

static int over_window(const char *path, const stream_window *w)
{
    fprintf(stderr, "epsnet: %s: the live window of %" PRIu64 " vertices exceeds --mem (%" PRIu64
                    " bytes); does the stream finalize its vertices?\n",
            path, w->next - w->base, w->max_bytes);
    return EXIT_RESOURCES;
}

int cmd_check(int argc, char **argv)
{
    static const struct option opts[] = {
        { "axis", required_argument, NULL, 'A' }, { "strict", no_argument, NULL, 's' },
        { "mem", required_argument, NULL, 'm' },  { "quiet", no_argument, NULL, 'q' },
        { "help", no_argument, NULL, 'h' },       { 0, 0, 0, 0 },
    };
    int axis = -1, strict = 0, c, rc;
    uint64_t mem = (uint64_t)1 << 30;
    optind = 1;
    while ((c = getopt_long(argc, argv, "qh", opts, NULL)) != -1) {
        switch (c) {
        case 'A':
            if (strlen(optarg) != 1 || !strchr("xyz", optarg[0]))
                return cli_usage_error("check", "--axis: '%s' is not x, y or z", optarg);
            axis = optarg[0] - 'x';
            break;
        case 's': strict = 1; break;
        case 'm':
            if ((rc = cli_parse_size("check", "--mem", optarg, &mem)))
                return rc;
            break;
        case 'q': cli_quiet = 1; break;
        case 'h': check_help(); return EXIT_OK;
        default: return cli_usage_error("check", "bad option");
        }
    }
    if (optind != argc - 1)
        return cli_usage_error("check", "needs exactly one FILE");
    const char *path = argv[optind];

    epsnet_error err;
    epsnet_reader *r = NULL;
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    rs.mem_limit = mem;
    if ((rc = epsnet_reader_open(&r, path, &rs, &err)))
        return cli_fail(&err);
    /* note: a copy, so the report can use it after the reader is closed */
    epsnet_mesh_info info_copy = *epsnet_reader_info(r);
    const epsnet_mesh_info *info = &info_copy;
    stream_check k = { .sorted = { 1, 1, 1 } };
    stream_window w = { .max_bytes = mem };
    cli_progress p;
    cli_progress_begin(&p, "check");
    epsnet_record rec;
    int exit_code = EXIT_OK;
    while ((rc = epsnet_reader_next(r, &rec, &err)) > 0) {
        uint64_t n = k.nv + k.nt + k.nfin;
        if ((n & 0xffff) == 0)
            cli_progress_update(&p, epsnet_reader_bytes_read(r), epsnet_reader_file_size(r), n);
        if (sc_record(&k, &w, info->streaming, &rec)) {
            exit_code = over_window(path, &w);
            break;
        }
    }
    cli_progress_end(&p);
    epsnet_reader_close(&r);
    sw_free(&w);
    if (exit_code)
        return exit_code;
    if (rc < 0)
        return cli_fail(&err);
    int declared = info->sorted_axis;
    if (!info->streaming)
        return invalid(path, "the %s format has no finalization: every vertex stays live to the end "
                             "(width %" PRIu64 "); 'epsnet sort' makes a streaming mesh",
                       info->format, k.nv);
    if (k.nv > k.nfin)
        return invalid(path, "%" PRIu64 " of %" PRIu64 " vertices are never finalized", k.nv - k.nfin, k.nv);
    if (declared >= 0 && !k.sorted[declared])
        return invalid(path, "declared sorted along %c but it is not", "xyz"[declared]);
    if (axis >= 0 && !k.sorted[axis])
        return invalid(path, "vertices are not sorted along %c", "xyz"[axis]);
    if (strict && k.late)
        return invalid(path, "%" PRIu64 " vertices are finalized late (not right after their last triangle)",
                       k.late);
    if (cli_quiet)
        return EXIT_OK;
    char sorted_txt[16] = "";
    for (int a = 0; a < 3; a++)
        if (k.sorted[a] && k.nv > 1) {
            size_t l = strlen(sorted_txt);
            snprintf(sorted_txt + l, sizeof sorted_txt - l, "%s%c", l ? " " : "", "xyz"[a]);
        }
    printf("file:        %s\n", path);
    printf("format:      %s %s%s\n", info->format, info->encoding ? info->encoding : "",
           info->compressed ? " (zstd)" : "");
    printf("vertices:    %" PRIu64 "\n", k.nv);
    printf("triangles:   %" PRIu64 "\n", k.nt);
    printf("sorted:      %s%s%c%s\n", sorted_txt[0] ? sorted_txt : "no", declared >= 0 ? " (declared " : "",
           declared >= 0 ? "xyz"[declared] : ' ', declared >= 0 ? ")" : "");
    printf("finalized:   all %" PRIu64 " vertices, %" PRIu64 " late, %" PRIu64 " never used\n", k.nfin, k.late,
           k.unused_finalized);
    if (strcmp(info->format, "smz") == 0)
        printf("checksums:   every block verified\n");
    printf("width:       %" PRIu64 " vertices\n", w.width);
    printf("span:        %" PRIu64 " vertices\n", w.span);
    printf("valid:       yes\n");
    return EXIT_OK;
}
