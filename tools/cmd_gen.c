#include <getopt.h>
#include <math.h>
#include <string.h>

#include "cli.h"

static void gen_help(void)
{
    printf("usage: epsnet gen SHAPE --faces N -o FILE [options]\n"
           "\n"
           "Generate a synthetic mesh of any size in bounded memory. By default it is\n"
           "written as a spatially sorted, finalized streaming mesh (in SMA/SMB the\n"
           "finalization is explicit; in PLY/OBJ only the order remains).\n"
           "\n"
           "shapes: %s\n"
           "\n"
           "  -n, --faces N       about N triangles (default 20000; K/M/G suffixes allowed)\n"
           "  -o, --output FILE   destination (required)\n"
           "      --seed S        seed for random shapes and --shuffle (default 1)\n"
           "      --param P       shape parameter (roundcube: 0 sphere .. 1 cube; torus:\n"
           "                      minor/major radius; dimple: dent depth; bumpy:\n"
           "                      amplitude; terrain: relief)\n"
           "      --shuffle       vertices and faces in random order, like a scanner PLY\n"
           "      --charts K      a UV atlas of about K charts, like a photogrammetry\n"
           "                      texture: texture_u/texture_v per vertex, one vertex\n"
           "                      per chart where charts meet\n"
           "      --ascii         ASCII instead of binary PLY\n"
           "  -q, --quiet         no progress or summary\n"
           "  -h, --help          this text\n",
           epsnet_gen_shapes());
}

int cmd_gen(int argc, char **argv)
{
    static const struct option opts[] = {
        { "faces", required_argument, NULL, 'n' }, { "output", required_argument, NULL, 'o' },
        { "seed", required_argument, NULL, 's' },  { "param", required_argument, NULL, 'p' },
        { "shuffle", no_argument, NULL, 'S' },     { "ascii", no_argument, NULL, 'a' },
        { "charts", required_argument, NULL, 'C' },
        { "quiet", no_argument, NULL, 'q' },       { "help", no_argument, NULL, 'h' },
        { 0, 0, 0, 0 },
    };
    epsnet_gen_settings gs;
    epsnet_gen_default_settings(&gs);
    epsnet_writer_settings ws;
    epsnet_writer_default_settings(&ws);
    const char *out = NULL;
    int c, rc;
    optind = 1;
    while ((c = getopt_long(argc, argv, "n:o:qh", opts, NULL)) != -1) {
        switch (c) {
        case 'n':
            if ((rc = cli_parse_size("gen", "--faces", optarg, &gs.faces)))
                return rc;
            break;
        case 'o': out = optarg; break;
        case 's':
            if ((rc = cli_parse_u64("gen", "--seed", optarg, &gs.seed)))
                return rc;
            break;
        case 'p':
            if ((rc = cli_parse_double("gen", "--param", optarg, &gs.param)))
                return rc;
            break;
        case 'S': gs.shuffle = 1; break;
        case 'C':
            if ((rc = cli_parse_size("gen", "--charts", optarg, &gs.charts)))
                return rc;
            break;
        case 'a': ws.ascii = 1; break;
        case 'q': cli_quiet = 1; break;
        case 'h': gen_help(); return EXIT_OK;
        default: return cli_usage_error("gen", "bad option");
        }
    }
    if (optind != argc - 1)
        return cli_usage_error("gen", "needs exactly one SHAPE (%s)", epsnet_gen_shapes());
    if (!out)
        return cli_usage_error("gen", "needs -o FILE");
    gs.shape = argv[optind];

    epsnet_error err;
    epsnet_mesh_info info;
    epsnet_writer *w = NULL;
    double t0 = cli_now();
    rc = epsnet_gen_info(&gs, &info, &err);
    if (rc == 0)
        rc = epsnet_writer_open(&w, out, &ws, &info, &err);
    if (rc == 0)
        rc = epsnet_gen(&gs, w, &err);
    if (rc == 0)
        rc = epsnet_writer_commit(&w, &err);
    epsnet_writer_abort(&w);
    if (rc < 0)
        return cli_fail(&err);
    if (!cli_quiet)
        fprintf(stderr, "epsnet gen: %s, %llu vertices, %llu triangles -> %s (%.2f s)\n", gs.shape,
                (unsigned long long)info.nverts, (unsigned long long)info.nfaces, out, cli_now() - t0);
    return EXIT_OK;
}
