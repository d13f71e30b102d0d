#include <getopt.h>
#include <inttypes.h>
#include <string.h>

#include "cli.h"

static void hausdorff_help(void)
{
    printf("usage: epsnet hausdorff A B [options]\n"
           "\n"
           "Metro-style error between two meshes: every vertex, points along every edge\n"
           "and stratified points inside every face of each mesh are measured against\n"
           "the other surface with exact point-to-triangle distances. Prints max, mean\n"
           "and RMS distance each way and the symmetric Hausdorff distance, absolute and\n"
           "relative to the bounding-box diagonal of A, where the worst distance is,\n"
           "and the normal deviation (angle between the surface normals at a sample and\n"
           "at its closest point; paper §3.2). Mean and RMS are weighted by area.\n"
           "Zero-area faces are measured as the segments or points they are.\n"
           "\n"
           "      --samples-per-face N  points inside faces per face, spread by area\n"
           "                            (default 10, at most 100000)\n"
           "      --seed S              seed of the sample jitter (default 1)\n"
           "  -j, --threads N           worker threads (default: the processors it may use); the\n"
           "                            numbers do not depend on it\n"
           "      --json FILE           also write the results as JSON (- for stdout,\n"
           "                            instead of the table)\n"
           "  -q, --quiet               no table\n"
           "  -h, --help                this text\n");
}

static void print_side(const char *label, const epsnet_hausdorff_side *s, double diagonal)
{
    double scale = diagonal > 0 ? 1 / diagonal : 0;
    printf("  %-10s %-13.6g %-13.6g %-13.6g %-11.4e %-11.4e %-11.4e %" PRIu64 "\n", label, s->max, s->mean,
           s->rms, s->max * scale, s->mean * scale, s->rms * scale, s->samples);
}

static void print_table(const char *a, const char *b, const epsnet_hausdorff_result *r, double seconds)
{
    printf("A: %s (%" PRIu64 " vertices, %" PRIu64 " faces, %" PRIu64 " zero-area)\n", a, r->a_vertices,
           r->a_faces, r->a_zero_area_faces);
    printf("B: %s (%" PRIu64 " vertices, %" PRIu64 " faces, %" PRIu64 " zero-area)\n", b, r->b_vertices,
           r->b_faces, r->b_zero_area_faces);
    printf("bounding-box diagonal of A: %.9g\n\n", r->diagonal);
    printf("  %-10s %-13s %-13s %-13s %-11s %-11s %-11s %s\n", "distance", "max", "mean", "rms", "max/diag",
           "mean/diag", "rms/diag", "samples");
    print_side("A -> B", &r->a_to_b, r->diagonal);
    print_side("B -> A", &r->b_to_a, r->diagonal);
    printf("  %-10s %-13.6g %-13s %-13s %-11.4e\n", "symmetric", r->hausdorff, "", "",
           r->diagonal > 0 ? r->hausdorff / r->diagonal : 0);
    const epsnet_hausdorff_side *worst = r->b_to_a.max > r->a_to_b.max ? &r->b_to_a : &r->a_to_b;
    printf("  worst at (%.9g %.9g %.9g), on %s\n\n", worst->max_at[0], worst->max_at[1], worst->max_at[2],
           worst == &r->a_to_b ? "A" : "B");
    printf("  %-10s %-13s %-13s %s\n", "normals", "max (deg)", "mean (deg)", "samples");
    printf("  %-10s %-13.6g %-13.6g %" PRIu64 "\n", "A -> B", r->a_to_b.normal_max, r->a_to_b.normal_mean,
           r->a_to_b.normal_samples);
    printf("  %-10s %-13.6g %-13.6g %" PRIu64 "\n", "B -> A", r->b_to_a.normal_max, r->b_to_a.normal_mean,
           r->b_to_a.normal_samples);
    printf("\n%.2f s\n", seconds);
}

int cmd_hausdorff(int argc, char **argv)
{
    static const struct option opts[] = {
        { "samples-per-face", required_argument, NULL, 1000 },
        { "seed", required_argument, NULL, 1001 },
        { "threads", required_argument, NULL, 'j' },
        { "json", required_argument, NULL, 1002 },
        { "quiet", no_argument, NULL, 'q' },
        { "help", no_argument, NULL, 'h' },
        { 0, 0, 0, 0 },
    };
    epsnet_hausdorff_settings s;
    epsnet_hausdorff_default_settings(&s);
    const char *json = NULL;
    uint64_t v;
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "j:qh", opts, NULL)) != -1) {
        switch (c) {
        case 1000:
            if (cli_parse_u64("hausdorff", "--samples-per-face", optarg, &v))
                return EXIT_USAGE;
            if (v < 1 || v > 100000)
                return cli_usage_error("hausdorff", "--samples-per-face must be 1..100000");
            s.samples_per_face = (uint32_t)v;
            break;
        case 1001:
            if (cli_parse_u64("hausdorff", "--seed", optarg, &v))
                return EXIT_USAGE;
            s.seed = v;
            break;
        case 'j':
            if (cli_parse_u64("hausdorff", "--threads", optarg, &v))
                return EXIT_USAGE;
            if (v > 256)
                return cli_usage_error("hausdorff", "--threads must be 0..256");
            s.threads = (int)v;
            break;
        case 1002: json = optarg; break;
        case 'q': cli_quiet = 1; break;
        case 'h': hausdorff_help(); return EXIT_OK;
        default: return cli_usage_error("hausdorff", "bad option");
        }
    }
    if (optind != argc - 2)
        return cli_usage_error("hausdorff", "needs exactly two mesh files, A and B");
    const char *a = argv[optind], *b = argv[optind + 1];

    epsnet_error err;
    epsnet_hausdorff_result r;
    double t0 = cli_now();
    int rc = epsnet_hausdorff_files(a, b, &s, &r, &err);
    double seconds = cli_now() - t0;
    if (rc == 0 && json)
        rc = epsnet_hausdorff_write_json(&r, a, b, json, &err);
    if (rc < 0)
        return cli_fail(&err);
    if (!cli_quiet && !(json && strcmp(json, "-") == 0))
        print_table(a, b, &r, seconds);
    return EXIT_OK;
}
