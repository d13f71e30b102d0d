/*
 * epsnet info: what a mesh file holds and whether it is a usable streaming
 * mesh (docs/architecture.md §6): vertices sorted along an axis, every vertex finalized, and
 * how wide the stream is (the most vertices live at once) and how far back a
 * triangle may reach (span).
 */
#include <float.h>
#include <getopt.h>
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "stream_window.h"

static void info_help(void)
{
    printf("usage: epsnet info FILE [options]\n"
           "\n"
           "Read the whole mesh once and report its format, vertex and triangle counts,\n"
           "bounding box, whether it is a valid streaming mesh, along which axes its\n"
           "vertices are sorted, and its stream width and span:\n"
           "  width  the largest number of vertices live at once (read, not finalized)\n"
           "  span   the largest index distance between the newest vertex and the\n"
           "         oldest live one, plus one\n"
           "A mesh without finalization (PLY, OBJ, OFF, STL) keeps every vertex live to\n"
           "the end, so its width is its vertex count; 'epsnet sort' makes it narrow.\n"
           "\n"
           "  -q, --quiet   no progress bar\n"
           "  -h, --help    this text\n");
}

int cmd_info(int argc, char **argv)
{
    static const struct option opts[] = {
        { "quiet", no_argument, NULL, 'q' }, { "help", no_argument, NULL, 'h' }, { 0, 0, 0, 0 },
    };
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "qh", opts, NULL)) != -1) {
        switch (c) {
        case 'q': cli_quiet = 1; break;
        case 'h': info_help(); return EXIT_OK;
        default: return cli_usage_error("info", "bad option");
        }
    }
    if (optind != argc - 1)
        return cli_usage_error("info", "needs exactly one FILE");
    const char *path = argv[optind];

    epsnet_error err;
    epsnet_reader *r = NULL;
    int rc = epsnet_reader_open(&r, path, NULL, &err);
    if (rc)
        return cli_fail(&err);
    const epsnet_mesh_info *hi = epsnet_reader_info(r);

    double lo[3] = { DBL_MAX, DBL_MAX, DBL_MAX }, hi_[3] = { -DBL_MAX, -DBL_MAX, -DBL_MAX };
    double prev[3] = { 0, 0, 0 };
    int sorted[3] = { 1, 1, 1 };
    uint64_t nv = 0, nt = 0, nfin = 0, degenerate = 0, width = 0, span = 0;
    stream_window lw = { 0 };
    cli_progress p;
    cli_progress_begin(&p, "info");
    epsnet_record rec;
    uint64_t n = 0;
    while ((rc = epsnet_reader_next(r, &rec, &err)) > 0) {
        if ((++n & 0xffff) == 0)
            cli_progress_update(&p, epsnet_reader_bytes_read(r), epsnet_reader_file_size(r), n);
        switch (rec.kind) {
        case EPSNET_REC_VERTEX:
            for (int k = 0; k < 3; k++) {
                if (nv && rec.xyz[k] < prev[k])
                    sorted[k] = 0;
                prev[k] = rec.xyz[k];
                if (rec.xyz[k] < lo[k])
                    lo[k] = rec.xyz[k];
                if (rec.xyz[k] > hi_[k])
                    hi_[k] = rec.xyz[k];
            }
            nv++;
            if (hi->streaming && sw_add_vertex(&lw)) {
                rc = EPSNET_ENOMEM;
                snprintf(err.reason, sizeof err.reason, "out of memory tracking the stream window");
                err.code = rc;
                err.file[0] = '\0';
                goto done;
            }
            break;
        case EPSNET_REC_TRIANGLE:
            nt++;
            if (rec.v[0] == rec.v[1] || rec.v[1] == rec.v[2] || rec.v[0] == rec.v[2])
                degenerate++;
            break;
        case EPSNET_REC_FINALIZE:
            nfin++;
            if (hi->streaming)
                sw_finalize(&lw, rec.v[0]);
            break;
        }
    }
done:
    cli_progress_end(&p);
    if (rc < 0) {
        epsnet_reader_close(&r);
        sw_free(&lw);
        return cli_fail(&err);
    }
    width = hi->streaming ? lw.width : nv;
    span = hi->streaming ? lw.span : nv;

    printf("file:        %s\n", path);
    printf("format:      %s %s%s\n", hi->format, hi->encoding ? hi->encoding : "",
           hi->compressed ? " (zstd)" : "");
    printf("coordinates: %s\n", hi->coord_type == EPSNET_COORD_FLOAT64 ? "float64" : "float32");
    printf("vertices:    %" PRIu64, nv);
    if (hi->nverts != EPSNET_COUNT_UNKNOWN && hi->nverts != nv)
        printf(" (header says %" PRIu64 ")", hi->nverts);
    printf("\ntriangles:   %" PRIu64 "\n", nt);
    if (degenerate)
        printf("degenerate:  %" PRIu64 " triangles repeat a corner\n", degenerate);
    const epsnet_attr_layout *al = &hi->vertex_attrs;
    if (al->count) {
        printf("attributes: ");
        for (uint32_t i = 0; i < al->count; i++)
            printf(" %s %s%s%s", epsnet_attr_type_name(al->attr[i].type), al->attr[i].name,
                   al->attr[i].of_face ? " (a face's)" : "", i + 1 < al->count ? "," : "");
        printf(" (%u bytes per vertex)\n", al->size);
    }
    /* the names a material_index and a group_index stand for (OBJ's usemtl and g, a PLY's header
     * comments: epsnet.h epsnet_face_names), the first few of them */
    const epsnet_face_names *names[2] = { hi->materials, hi->groups };
    for (int k = 0; k < 2; k++) {
        if (!names[k])
            continue;
        printf("%s %u", k ? "groups:     " : "materials:  ", names[k]->count);
        if (names[k]->library)
            printf(" (mtllib %s)", names[k]->library);
        for (uint32_t i = 0; i < names[k]->count && i < 8; i++)
            printf("%s'%s'", i ? ", " : ": ", names[k]->names[i]);
        printf("%s\n", names[k]->count > 8 ? ", ..." : "");
    }
    /* docs/architecture.md §5: what the records do not carry, which every other command drops */
    const char *dropped = epsnet_reader_dropped(r, NULL);
    if (dropped)
        printf("not read:    %s\n", dropped);
    if (epsnet_reader_note(r))
        printf("note:        %s\n", epsnet_reader_note(r));
    if (nv)
        printf("bbox:        [%.9g %.9g %.9g] - [%.9g %.9g %.9g]\n", lo[0], lo[1], lo[2], hi_[0], hi_[1],
               hi_[2]);
    else
        printf("bbox:        empty\n");
    const char *axes = "xyz";
    char sorted_txt[32] = "";
    for (int k = 0; k < 3; k++)
        if (sorted[k] && nv > 1) {
            size_t l = strlen(sorted_txt);
            snprintf(sorted_txt + l, sizeof sorted_txt - l, "%s%c", l ? " " : "", axes[k]);
        }
    printf("sorted:      %s\n", sorted_txt[0] ? sorted_txt : "no");
    if (hi->streaming)
        printf("stream:      valid streaming mesh, %" PRIu64 " of %" PRIu64
               " vertices finalized explicitly (the rest at the end)\n",
               nfin, nv);
    else
        printf("stream:      no finalization (ordinary mesh): every vertex stays live to the end\n");
    printf("width:       %" PRIu64 " vertices\n", width);
    printf("span:        %" PRIu64 " vertices\n", span);
    epsnet_reader_close(&r);
    sw_free(&lw);
    return EXIT_OK;
}
