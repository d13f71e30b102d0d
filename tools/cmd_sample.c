#include <getopt.h>
#include <string.h>

#include "cli.h"

static void sample_help(void)
{
    printf("usage: epsnet sample IN -o OUT.ply [options]\n"
           "\n"
           "Find the feature-sensitive samples of a mesh (paper §4): the vertices whose\n"
           "face normals wind around a vertex of the Gaussian sphere. OUT is a PLY point\n"
           "set, one point per sample with the id of the Gaussian vertex it covers\n"
           "(`gvertex`, -1 for locked boundary/non-manifold vertices) and a colour per id.\n"
           "\n"
           "  -o, --output FILE   destination PLY (required)\n"
           "      --mesh          write the whole mesh instead, with a per-vertex\n"
           "                      `sample` flag and colour (for MeshLab)\n"
           "      --ascii         ASCII PLY\n"
           "%s"
           "  -q, --quiet         no summary\n"
           "  -h, --help          this text\n",
           cli_method_help);
}

int cmd_sample(int argc, char **argv)
{
    static const struct option opts[] = {
        { "output", required_argument, NULL, 'o' }, { "mesh", no_argument, NULL, 'm' },
        { "ascii", no_argument, NULL, 'a' },        { "quiet", no_argument, NULL, 'q' },
        { "help", no_argument, NULL, 'h' },         CLI_METHOD_OPTIONS,
        { 0, 0, 0, 0 },
    };
    cli_method m;
    cli_method_init(&m);
    const char *out = NULL;
    int mesh = 0, ascii = 0, c, rc;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:j:qh", opts, NULL)) != -1) {
        if ((rc = cli_method_option("sample", c, optarg, &m)) != 0) {
            if (rc < 0)
                return EXIT_USAGE;
            continue;
        }
        switch (c) {
        case 'o': out = optarg; break;
        case 'm': mesh = 1; break;
        case 'a': ascii = 1; break;
        case 'q': cli_quiet = 1; break;
        case 'h': sample_help(); return EXIT_OK;
        default: return cli_usage_error("sample", "bad option");
        }
    }
    if (optind != argc - 1)
        return cli_usage_error("sample", "needs exactly one input file");
    if (!out)
        return cli_usage_error("sample", "needs -o OUT.ply");

    epsnet_error err;
    epsnet_context *ctx = NULL;
    cli_run_progress prog = { 0 };
    cli_progress_begin(&prog.bar, "sample faces");
    m.settings.progress = cli_run_progress_cb;
    m.settings.progress_opaque = &prog;
    m.settings.warning = cli_warning;
    m.settings.warning_opaque = &prog.bar;
    rc = epsnet_context_new(&ctx, &m.settings, &err);
    prog.ctx = ctx;
    if (rc == 0)
        rc = epsnet_sample_file(ctx, argv[optind], out, mesh ? EPSNET_SAMPLES_MESH : EPSNET_SAMPLES_POINTS,
                                ascii, &err);
    cli_progress_end(&prog.bar);
    if (rc == 0 && m.stats_path)
        rc = epsnet_stats_write_json(ctx, "sample", m.stats_path, &err);
    if (rc == 0 && !cli_quiet) {
        const epsnet_stats *s = epsnet_context_stats(ctx);
        fprintf(stderr,
                "epsnet sample: %llu vertices, %llu faces -> %llu samples (%llu locked, %llu needles) "
                "of %llu Gaussian vertices; %llu candidates, %llu feature edges; %.2f s\n",
                (unsigned long long)s->vertices, (unsigned long long)s->faces,
                (unsigned long long)s->samples, (unsigned long long)s->locked,
                (unsigned long long)s->needle_vertices, (unsigned long long)s->gaussian_vertices,
                (unsigned long long)s->candidates, (unsigned long long)s->feature_edges,
                s->seconds_read + s->seconds_normals + s->seconds_classify + s->seconds_write);
    }
    epsnet_context_free(&ctx);
    return rc < 0 ? cli_fail(&err) : EXIT_OK;
}
