#include <getopt.h>
#include <math.h>
#include <string.h>

#include "cli.h"

static void simplify_help(void)
{
    printf("usage: epsnet simplify IN -o OUT [options]\n"
           "\n"
           "Keep the feature-sensitive samples of a mesh and remove every other vertex by\n"
           "half-edge collapses, cheapest first by quadric error (paper §4.2). Every output\n"
           "vertex is an input vertex with bit-identical coordinates; a closed manifold\n"
           "stays closed with the same genus. OUT's format follows its extension.\n"
           "\n"
           "  -o, --output FILE       destination (required)\n"
           "      --passes K          up to K ε-net passes: re-sample under a new rotation\n"
           "                          derived from --seed and remove what became a\n"
           "                          non-sample; the passes are chained in one\n"
           "                          streaming run (default 1)\n"
           "      --max-normal-dev D  refuse collapses that turn a face normal by more\n"
           "                          than D degrees (default 60)\n"
           "      --ascii             ASCII output where the format has both\n"
           "      --lock PROPERTY     keep every vertex whose per-vertex PROPERTY is\n"
           "                          non-zero (a PLY uchar 'lock', MeshLab's exported\n"
           "                          'quality' selection); by every mode\n"
           "      --drop-normals      read no vertex normals, so that an OBJ split by\n"
           "                          them (flat shading, hard edges) simplifies as one\n"
           "                          surface; the output's normals are recomputed\n"
           "                          from its faces\n"
           "      --attribute-weight [NAME=]W[,...]\n"
           "                          weigh vertex attributes in the error, so that\n"
           "                          collapses that slide the texture or bend the\n"
           "                          shading cost more: W alone weighs the texture\n"
           "                          coordinates and normals; NAME is uv, normal or\n"
           "                          any numeric vertex property. At W = 1 an\n"
           "                          attribute error of 1 costs what a distance of the\n"
           "                          bounding box diagonal does (try 0.5 to 2)\n"
           "\n"
           "To a size or an error bound (docs/method.md §13): the samples of one ε-net\n"
           "pass are kept as a feature skeleton, every other vertex may go, smallest\n"
           "error first, until the target is met; samples go only when the skeleton\n"
           "alone is over it (non-manifold vertices, kept as samples, go with them).\n"
           "Zero-volume double sheets glued to the surface (two faces on the same\n"
           "corners, opposite orientations) are removed first. The skeleton's density\n"
           "is chosen from the target (a quarter of the vertices it keeps) unless\n"
           "--level or --frequency is given.\n"
           "      --faces N           keep N faces (N - 1 when a closed surface needs an\n"
           "                          even count)\n"
           "      --ratio R           keep round(R x input faces), 0 < R <= 1\n"
           "      --vertices N        keep N vertices\n"
           "      --error E           no collapse with an error over E x the bounding\n"
           "                          box diagonal (error: area-weighted RMS distance to\n"
           "                          the input planes its quadric holds, as\n"
           "                          meshoptimizer's target_error); alone or with one\n"
           "                          of the above, whichever stops first\n"
           "%s"
           "  -q, --quiet             no summary\n"
           "  -h, --help              this text\n",
           cli_method_help);
}

int cmd_simplify(int argc, char **argv)
{
    static const struct option opts[] = {
        { "output", required_argument, NULL, 'o' },  { "passes", required_argument, NULL, 'p' },
        { "max-normal-dev", required_argument, NULL, 'd' }, { "ascii", no_argument, NULL, 'a' },
        { "quiet", no_argument, NULL, 'q' },         { "help", no_argument, NULL, 'h' },
        { "faces", required_argument, NULL, 'F' },   { "ratio", required_argument, NULL, 'R' },
        { "vertices", required_argument, NULL, 'V' }, { "error", required_argument, NULL, 'E' },
        { "lock", required_argument, NULL, 'L' },
        { "drop-normals", no_argument, NULL, 'N' },
        { "attribute-weight", required_argument, NULL, 'W' },
        CLI_METHOD_OPTIONS,                          { 0, 0, 0, 0 },
    };
    cli_method m;
    cli_method_init(&m);
    const char *out = NULL;
    int c, rc;
    uint64_t passes, count;
    double dev, x;
    int targets = 0;
    char weights[512] = "";
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:j:qh", opts, NULL)) != -1) {
        if ((rc = cli_method_option("simplify", c, optarg, &m)) != 0) {
            if (rc < 0)
                return EXIT_USAGE;
            continue;
        }
        switch (c) {
        case 'o': out = optarg; break;
        case 'p':
            if ((rc = cli_parse_u64("simplify", "--passes", optarg, &passes)))
                return rc;
            if (passes < 1 || passes > 1000)
                return cli_usage_error("simplify", "--passes must be between 1 and 1000");
            m.settings.passes = (int)passes;
            break;
        case 'd':
            if ((rc = cli_parse_double("simplify", "--max-normal-dev", optarg, &dev)))
                return rc;
            if (!(dev > 0 && dev <= 180))
                return cli_usage_error("simplify", "--max-normal-dev must be in (0, 180] degrees");
            m.settings.max_normal_dev = dev;
            break;
        case 'F':
        case 'V':
            if ((rc = cli_parse_u64("simplify", c == 'F' ? "--faces" : "--vertices", optarg, &count)))
                return rc;
            if (count == 0)
                return cli_usage_error("simplify", c == 'F' ? "--faces must be 1 or more" : "--vertices must be 1 or more");
            *(c == 'F' ? &m.settings.target_faces : &m.settings.target_vertices) = count;
            targets++;
            break;
        case 'R':
            if ((rc = cli_parse_double("simplify", "--ratio", optarg, &x)))
                return rc;
            if (!(x > 0 && x <= 1))
                return cli_usage_error("simplify", "--ratio must be in (0, 1]");
            m.settings.target_ratio = x;
            targets++;
            break;
        case 'E':
            if ((rc = cli_parse_double("simplify", "--error", optarg, &x)))
                return rc;
            if (!(x > 0 && x < 1e300))
                return cli_usage_error("simplify", "--error must be a positive number");
            m.settings.target_error = x;
            break;
        case 'L':
            if (!*optarg)
                return cli_usage_error("simplify", "--lock needs a property name");
            m.settings.lock_property = optarg;
            break;
        case 'N':
            m.settings.drop_normals = 1;
            break;
        case 'W': {
            /* repeated: one list */
            size_t have = strlen(weights);
            if (!*optarg || have + strlen(optarg) + 2 > sizeof weights)
                return cli_usage_error("simplify", "--attribute-weight needs [NAME=]W[,...] (at most 500 characters)");
            snprintf(weights + have, sizeof weights - have, "%s%s", have ? "," : "", optarg);
            m.settings.attribute_weights = weights;
            break;
        }
        case 'a': m.settings.ascii = 1; break;
        case 'q': cli_quiet = 1; break;
        case 'h':
            if (!cli_follower()) /* once for all ranks */
                simplify_help();
            return EXIT_OK;
        default: return cli_usage_error("simplify", "bad option");
        }
    }
    if (optind != argc - 1)
        return cli_usage_error("simplify", "needs exactly one input file");
    if (!out)
        return cli_usage_error("simplify", "needs -o OUT");
    if (targets > 1)
        return cli_usage_error("simplify", "give one of --faces, --ratio and --vertices");
    if ((targets || m.settings.target_error > 0) && m.settings.passes > 1)
        return cli_usage_error("simplify", "--passes cannot be combined with a target (--faces, --ratio, --vertices, --error)");

    epsnet_error err;
    epsnet_context *ctx = NULL;
    m.settings.peers = cli_peers;
    if (cli_follower())
        cli_quiet = 1; /* rank 0 reports for the run */
    cli_run_progress prog = { 0 };
    cli_progress_begin(&prog.bar, "simplify faces");
    m.settings.progress = cli_run_progress_cb;
    m.settings.progress_opaque = &prog;
    m.settings.warning = cli_warning;
    m.settings.warning_opaque = &prog.bar;
    rc = epsnet_context_new(&ctx, &m.settings, &err);
    prog.ctx = ctx;
    if (rc == 0)
        rc = epsnet_simplify_file(ctx, argv[optind], out, &err);
    cli_progress_end(&prog.bar);
    if (rc == 0 && m.stats_path && !cli_follower())
        rc = epsnet_stats_write_json(ctx, "simplify", m.stats_path, &err);
    if (rc == 0 && !cli_quiet) {
        const epsnet_stats *s = epsnet_context_stats(ctx);
        double secs = s->seconds_read + s->seconds_normals + s->seconds_classify + s->seconds_simplify +
                      s->seconds_write;
        fprintf(stderr,
                "epsnet simplify: %llu vertices, %llu faces -> %llu vertices, %llu faces (%.1f%%)\n"
                "  samples %llu of %llu Gaussian vertices (%llu locked), %llu collapses in %llu pass%s\n"
                "  non-samples left: %llu (refused: link %llu, normal %llu, zero-area %llu, duplicate %llu)\n"
                "  %llu slabs, seams: %llu faces, %llu collapses; largest active set %llu\n"
                "  %.2f s, %.2f M faces/s, peak RSS %.1f MB; CPU: main %.2f s, workers %.2f s (%.1f%% serial)\n",
                (unsigned long long)s->vertices, (unsigned long long)s->faces,
                (unsigned long long)s->output_vertices, (unsigned long long)s->output_faces,
                s->faces ? 100.0 * (double)s->output_faces / (double)s->faces : 0.0,
                (unsigned long long)s->samples, (unsigned long long)s->gaussian_vertices,
                (unsigned long long)s->locked, (unsigned long long)s->collapses, (unsigned long long)s->passes,
                s->passes == 1 ? "" : "es", (unsigned long long)s->remaining_nonsamples,
                (unsigned long long)s->refused_link, (unsigned long long)s->refused_normal,
                (unsigned long long)s->refused_zero_area, (unsigned long long)s->refused_duplicate,
                (unsigned long long)s->slabs, (unsigned long long)s->seam_faces,
                (unsigned long long)s->seam_collapses, (unsigned long long)s->max_active, secs,
                secs > 0 ? (double)s->faces / secs / 1e6 : 0.0, (double)s->peak_rss / (1 << 20), s->cpu_main,
                s->cpu_workers,
                s->cpu_main + s->cpu_workers > 0 ? 100.0 * s->cpu_main / (s->cpu_main + s->cpu_workers) : 0.0);
        if (cli_peers)
            fprintf(stderr, "  shared among %d ranks: the CPU above is rank 0's, which stitched and wrote\n",
                    cli_peers->size);
        if (s->attribute_channels)
            fprintf(stderr, "  attributes weighed: %s (%u values a vertex)\n", m.settings.attribute_weights,
                    (unsigned)s->attribute_channels);
        if (s->seam_vertices || s->cut_end_vertices)
            fprintf(stderr,
                    "  attribute seams (UV, normals, materials): %llu copies in pairs along them, %llu where "
                    "they end (kept)\n",
                    (unsigned long long)s->seam_vertices, (unsigned long long)s->cut_end_vertices);
        if (targets || m.settings.target_error > 0) {
            /* G has 4 n^2 + 2 vertices at frequency n */
            unsigned n = (unsigned)(sqrt((double)(s->gaussian_vertices - 2) / 4) + 0.5);
            fprintf(stderr,
                    "  target: %llu %s; skeleton at frequency %u: %llu vertices (%.1f%% of the output), "
                    "%llu samples given up, %llu membrane faces removed\n",
                    (unsigned long long)(s->target_faces ? s->target_faces : m.settings.target_vertices),
                    s->target_faces || !m.settings.target_vertices ? "faces" : "vertices", n,
                    (unsigned long long)s->skeleton_vertices,
                    s->output_vertices ? 100.0 * (double)s->skeleton_vertices / (double)s->output_vertices : 0.0,
                    (unsigned long long)s->samples_given_up, (unsigned long long)s->membrane_faces);
        }
    }
    epsnet_context_free(&ctx);
    return rc < 0 ? cli_fail(&err) : EXIT_OK;
}
