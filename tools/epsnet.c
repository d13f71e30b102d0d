/*
 * epsnet command line: `epsnet <command> [options]`.
 */
#include <stdio.h>
#include <string.h>

#include "cli.h"

static const cli_command commands[] = {
    { "convert", "convert a mesh between formats", cmd_convert },
    { "info", "counts, bbox, format, sortedness and stream width of a mesh", cmd_info },
    { "gen", "generate a synthetic mesh of any size", cmd_gen },
    { "sample", "find the feature-sensitive samples of a mesh (paper §4)", cmd_sample },
    { "simplify", "keep only the samples: feature-preserving simplification", cmd_simplify },
    { "hausdorff", "Metro-style distance and normal deviation between two meshes", cmd_hausdorff },
    { "sort", "any mesh into a spatially sorted streaming mesh, out of core", cmd_sort },
    { "check", "validate a streaming mesh: order, references, finalization, checksums", cmd_check },
    { "render", "draw a mesh, its samples or its simplification into a PNG", cmd_render },
};

static void usage(FILE *f)
{
    fprintf(f,
            "usage: epsnet <command> [options]\n"
            "\n"
            "Samples and simplifies triangle meshes of any size with Gaussian epsilon-nets.\n"
            "\n"
            "commands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof *commands; i++)
        fprintf(f, "  %-10s %s\n", commands[i].name, commands[i].summary);
    fprintf(f,
            "\n"
            "'epsnet <command> --help' describes a command's options.\n"
            "Readable formats: %s (any of them inside .zst)\n"
            "Writable formats: %s (any of them inside .zst)\n"
            "\n"
            "exit status:\n"
            "  0    success\n"
            "  1    bad command line\n"
            "  2    malformed input data (the message names the file, line or byte, and reason)\n"
            "  3    a file could not be read or written (missing, permissions, disk full)\n"
            "  4    out of memory or over a budget (--mem, header limits)\n"
            "  5    unsupported format or feature\n"
            "  6    internal error (a bug: please report it)\n"
            "  130  interrupted (SIGINT/SIGTERM); no partial output is left\n",
            epsnet_formats_readable(), epsnet_formats_writable());
}

int main(int argc, char **argv)
{
    cli_process_setup();

    if (argc < 2) {
        usage(stderr);
        return EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (!strcmp(cmd, "--help") || !strcmp(cmd, "-h") || !strcmp(cmd, "help")) {
        usage(stdout);
        return EXIT_OK;
    }
    if (!strcmp(cmd, "--version") || !strcmp(cmd, "-V")) {
        printf("epsnet %s\n", epsnet_version());
        return EXIT_OK;
    }
    for (size_t i = 0; i < sizeof commands / sizeof *commands; i++)
        if (!strcmp(cmd, commands[i].name))
            return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "epsnet: unknown command '%s' (see 'epsnet --help')\n", cmd);
    return EXIT_USAGE;
}
