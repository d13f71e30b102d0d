#include <getopt.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"

static void render_help(void)
{
    printf("usage: epsnet render IN -o OUT.png [options]\n"
           "\n"
           "Draw a mesh into a PNG with a software rasterizer (no GPU, no display):\n"
           "orthographic camera framed from the bounding box, z-buffer, two-sided\n"
           "Lambert shading, white background; +y is up. The plain picture streams:\n"
           "triangles are drawn as they are read, so meshes larger than memory render\n"
           "(streaming meshes in memory that follows their width; other formats keep\n"
           "24 bytes per vertex). --samples and --simplified hold the mesh in memory.\n"
           "The same command gives the same bytes.\n"
           "\n"
           "  -o, --output FILE   destination PNG (required)\n"
           "      --size WxH      image size in pixels, each 1..8192 (default 640x480)\n"
           "      --view AZ,EL    azimuth about +y and elevation, degrees (default 30,20);\n"
           "                      0,0 looks along -z with +x to the right\n"
           "      --samples       draw the samples (paper §4) as dots coloured by the\n"
           "                      Gaussian vertex they cover, as `epsnet sample` does\n"
           "      --simplified    two panels: the input and its simplification\n"
           "                      (each half of the width)\n"
           "      --passes K      ε-net passes of the simplification (default 1)\n"
           "      --wire          draw the triangles' edges\n"
           "      --dot-radius R  sample dot radius in pixels (default: automatic)\n"
           "%s"
           "  -q, --quiet         no summary\n"
           "  -h, --help          this text\n",
           cli_method_help);
}

static int parse_size(const char *text, epsnet_render_settings *rs)
{
    char *end;
    unsigned long w = strtoul(text, &end, 10);
    if (end == text || (*end != 'x' && *end != 'X') || text[0] == '-')
        return cli_usage_error("render", "--size: '%s' is not WxH, e.g. 640x480", text);
    const char *h_text = end + 1;
    unsigned long h = strtoul(h_text, &end, 10);
    if (end == h_text || *end || h_text[0] == '-')
        return cli_usage_error("render", "--size: '%s' is not WxH, e.g. 640x480", text);
    if (w < 1 || w > 8192 || h < 1 || h > 8192)
        return cli_usage_error("render", "--size: each side must be between 1 and 8192");
    rs->width = (uint32_t)w;
    rs->height = (uint32_t)h;
    return 0;
}

static int parse_view(const char *text, epsnet_render_settings *rs)
{
    char az[64];
    const char *comma = strchr(text, ',');
    if (!comma || (size_t)(comma - text) >= sizeof az)
        return cli_usage_error("render", "--view: '%s' is not AZ,EL (degrees)", text);
    memcpy(az, text, (size_t)(comma - text));
    az[comma - text] = '\0';
    if (cli_parse_double("render", "--view azimuth", az, &rs->azimuth) ||
        cli_parse_double("render", "--view elevation", comma + 1, &rs->elevation))
        return EXIT_USAGE;
    if (rs->elevation < -90 || rs->elevation > 90)
        return cli_usage_error("render", "--view: elevation must be between -90 and 90 degrees");
    return 0;
}

int cmd_render(int argc, char **argv)
{
    static const struct option opts[] = {
        { "output", required_argument, NULL, 'o' },     { "size", required_argument, NULL, 's' },
        { "view", required_argument, NULL, 'v' },       { "samples", no_argument, NULL, 'S' },
        { "simplified", no_argument, NULL, 'L' },       { "wire", no_argument, NULL, 'w' },
        { "passes", required_argument, NULL, 'p' },     { "dot-radius", required_argument, NULL, 'r' },
        { "quiet", no_argument, NULL, 'q' },            { "help", no_argument, NULL, 'h' },
        CLI_METHOD_OPTIONS,                             { 0, 0, 0, 0 },
    };
    cli_method m;
    cli_method_init(&m);
    epsnet_render_settings rs;
    epsnet_render_default_settings(&rs);
    const char *out = NULL;
    uint64_t passes;
    int c, rc;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:j:qh", opts, NULL)) != -1) {
        if ((rc = cli_method_option("render", c, optarg, &m)) != 0) {
            if (rc < 0)
                return EXIT_USAGE;
            continue;
        }
        switch (c) {
        case 'o': out = optarg; break;
        case 's':
            if ((rc = parse_size(optarg, &rs)))
                return rc;
            break;
        case 'v':
            if ((rc = parse_view(optarg, &rs)))
                return rc;
            break;
        case 'S': rs.samples = 1; break;
        case 'L': rs.simplified = 1; break;
        case 'w': rs.wire = 1; break;
        case 'p':
            if ((rc = cli_parse_u64("render", "--passes", optarg, &passes)))
                return rc;
            if (passes < 1 || passes > 1000)
                return cli_usage_error("render", "--passes must be between 1 and 1000");
            m.settings.passes = (int)passes;
            break;
        case 'r':
            if ((rc = cli_parse_double("render", "--dot-radius", optarg, &rs.dot_radius)))
                return rc;
            if (rs.dot_radius < 0 || rs.dot_radius > 1000)
                return cli_usage_error("render", "--dot-radius must be between 0 and 1000 pixels");
            break;
        case 'q': cli_quiet = 1; break;
        case 'h': render_help(); return EXIT_OK;
        default: return cli_usage_error("render", "bad option");
        }
    }
    if (optind != argc - 1)
        return cli_usage_error("render", "needs exactly one input file");
    if (!out)
        return cli_usage_error("render", "needs -o OUT.png");
    if (rs.simplified && rs.width < 2)
        return cli_usage_error("render", "--simplified needs an image at least 2 pixels wide");

    epsnet_error err;
    epsnet_context *ctx = NULL;
    rc = epsnet_context_new(&ctx, &m.settings, &err);
    if (rc == 0)
        rc = epsnet_render_file(ctx, argv[optind], out, &rs, &err);
    if (rc == 0 && m.stats_path)
        rc = epsnet_stats_write_json(ctx, "render", m.stats_path, &err);
    if (rc == 0 && !cli_quiet) {
        const epsnet_stats *s = epsnet_context_stats(ctx);
        fprintf(stderr, "epsnet render: %llu vertices, %llu faces -> %s (%ux%u)", (unsigned long long)s->vertices,
                (unsigned long long)s->faces, out, rs.width, rs.height);
        if (rs.samples)
            fprintf(stderr, "; %llu samples", (unsigned long long)s->samples);
        if (rs.simplified)
            fprintf(stderr, "; simplified to %llu faces", (unsigned long long)s->output_faces);
        fprintf(stderr, "\n");
    }
    epsnet_context_free(&ctx);
    return rc < 0 ? cli_fail(&err) : EXIT_OK;
}
