#include <getopt.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"

static void convert_help(void)
{
    printf("usage: epsnet convert IN -o OUT [options]\n"
           "\n"
           "Convert any readable mesh to any writable format, chosen by OUT's extension\n"
           "(add .zst to compress). Coordinates are copied bit for bit.\n"
           "\n"
           "  -o, --output FILE   destination (required); written atomically\n"
           "      --format NAME   output format instead of the extension's\n"
           "      --ascii         ASCII instead of binary PLY\n"
           "      --float64       write double coordinates (default: as the input)\n"
           "      --float32       write float coordinates\n"
           "      --tmpdir DIR    folder for temporary files (default: beside OUT)\n"
           "  -q, --quiet         no progress bar\n"
           "  -h, --help          this text\n");
}

int cmd_convert(int argc, char **argv)
{
    static const struct option opts[] = {
        { "output", required_argument, NULL, 'o' }, { "format", required_argument, NULL, 'f' },
        { "ascii", no_argument, NULL, 'a' },        { "float64", no_argument, NULL, 'D' },
        { "float32", no_argument, NULL, 'F' },      { "tmpdir", required_argument, NULL, 't' },
        { "quiet", no_argument, NULL, 'q' },        { "help", no_argument, NULL, 'h' },
        { 0, 0, 0, 0 },
    };
    epsnet_writer_settings ws;
    epsnet_writer_default_settings(&ws);
    const char *out = NULL;
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:qh", opts, NULL)) != -1) {
        switch (c) {
        case 'o': out = optarg; break;
        case 'f': ws.format = optarg; break;
        case 'a': ws.ascii = 1; break;
        case 'D': ws.coord_type = EPSNET_COORD_FLOAT64; break;
        case 'F': ws.coord_type = EPSNET_COORD_FLOAT32; break;
        case 't': ws.tmpdir = optarg; break;
        case 'q': cli_quiet = 1; break;
        case 'h': convert_help(); return EXIT_OK;
        default: return cli_usage_error("convert", "bad option");
        }
    }
    if (optind != argc - 1)
        return cli_usage_error("convert", "needs exactly one input file");
    if (!out)
        return cli_usage_error("convert", "needs -o OUT");
    const char *in = argv[optind];

    epsnet_error err;
    epsnet_reader *r = NULL;
    epsnet_writer *w = NULL;
    int rc = epsnet_reader_open(&r, in, NULL, &err);
    if (rc == 0)
        rc = epsnet_writer_open(&w, out, &ws, epsnet_reader_info(r), &err);
    cli_progress p;
    cli_progress_begin(&p, "convert");
    epsnet_record rec;
    uint64_t n = 0;
    while (rc == 0 && (rc = epsnet_reader_next(r, &rec, &err)) > 0) {
        rc = epsnet_writer_put(w, &rec, &err);
        if ((++n & 0xffff) == 0)
            cli_progress_update(&p, epsnet_reader_bytes_read(r), epsnet_reader_file_size(r), n);
    }
    /* the writer's text goes with the writer: keep a copy past the commit */
    char *wdropped = NULL;
    if (w && epsnet_writer_dropped(w, NULL)) {
        const char *t = epsnet_writer_dropped(w, NULL);
        if ((wdropped = malloc(strlen(t) + 1)))
            memcpy(wdropped, t, strlen(t) + 1);
    }
    if (rc == 0)
        rc = epsnet_writer_commit(&w, &err);
    cli_progress_end(&p);
    /* One line for everything lost: what the reader did not carry, then
     * the attributes the output format cannot hold (docs/architecture.md §5). */
    if (rc == 0 && epsnet_reader_note(r))
        cli_warning(NULL, epsnet_reader_note(r));
    const char *dropped = rc == 0 ? epsnet_reader_dropped(r, NULL) : NULL;
    const char *unheld = rc == 0 ? wdropped : NULL;
    if (dropped || unheld) {
        size_t cap = strlen(in) + strlen(out) + (dropped ? strlen(dropped) : 0) + (unheld ? strlen(unheld) : 0) + 64;
        char *msg = malloc(cap);
        if (msg) {
            int len = snprintf(msg, cap, "%s: dropped: %s", in, dropped ? dropped : "");
            if (unheld && len > 0 && (size_t)len < cap)
                snprintf(msg + len, cap - (size_t)len, "%s%s (%s cannot hold them)", dropped ? ", " : "", unheld,
                         out);
        }
        cli_warning(NULL, msg ? msg : dropped ? dropped : unheld);
        free(msg);
    }
    free(wdropped);
    epsnet_writer_abort(&w);
    epsnet_reader_close(&r);
    return rc < 0 ? cli_fail(&err) : EXIT_OK;
}
