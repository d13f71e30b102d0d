/*
 * The public header stands alone (after dav1d's header_test) and every
 * entry point is exported by the shared library: this file includes only
 * <epsnet/epsnet.h>, is built against the public include folder only, and
 * links the shared libepsnet, so a missing EPSNET_API fails the build.
 */
#include <epsnet/epsnet.h>
#include <stdio.h>
#include <string.h>

static int failures;

static void check(int ok, const char *what)
{
    if (!ok) {
        failures++;
        fprintf(stderr, "FAIL %s\n", what);
    }
}

int main(void)
{
    uint64_t v;
    check(epsnet_parse_size("2K", &v) == 0 && v == 2048, "parse_size");
    check(strcmp(epsnet_version(), "") != 0, "version");
    check(EPSNET_VERSION_NUMBER >= 100, "version number");
    check(strcmp(epsnet_strerror(EPSNET_EFORMAT), "malformed input") == 0, "strerror");

    epsnet_settings s;
    epsnet_default_settings(&s);
    check(epsnet_parse_rotation("identity", &s) == 0, "parse_rotation");
    epsnet_error err;
    epsnet_context *ctx = NULL;
    check(epsnet_context_new(&ctx, &s, &err) == 0 && ctx, "context_new");
    check(epsnet_context_stats(ctx) != NULL, "context_stats");
    check(epsnet_sample_file(ctx, "/nonexistent.ply", "/tmp/x.ply", EPSNET_SAMPLES_POINTS, 0, &err) ==
              EPSNET_EIO, "sample_file error");
    check(epsnet_simplify_file(ctx, "/nonexistent.ply", "/tmp/x.ply", &err) == EPSNET_EIO, "simplify_file error");
    check(strstr(epsnet_error_message(&err), "/nonexistent.ply") != NULL, "error_message");
    {
        /* the arrays entry points (section 13): a face naming a vertex
         * that does not exist, refused by each of them */
        float xyz[9] = { 0, 0, 0, 1, 0, 0, 0, 1, 0 };
        int32_t tri[3] = { 0, 1, 3 };
        epsnet_arrays a;
        epsnet_arrays_init(&a);
        a.nverts = 3, a.xyz = xyz, a.nfaces = 1, a.faces = tri;
        epsnet_arrays_out out;
        uint8_t is_sample[3];
        int32_t gv[3];
        epsnet_hausdorff_result hr;
        epsnet_reader *r = NULL;
        check(epsnet_reader_open_arrays(&r, &a, NULL, &err) == 0, "reader_open_arrays");
        epsnet_reader_close(&r);
        check(epsnet_simplify_arrays(ctx, &a, &out, &err) == EPSNET_EFORMAT, "simplify_arrays error");
        check(epsnet_sample_arrays(ctx, &a, is_sample, gv, &err) == EPSNET_EFORMAT, "sample_arrays error");
        check(epsnet_hausdorff_arrays(&a, &a, NULL, &hr, &err) == EPSNET_EFORMAT, "hausdorff_arrays error");
        epsnet_arrays_out_free(&out);
        epsnet_free(NULL);
    }
    epsnet_context_free(&ctx);
    check(ctx == NULL, "context_free sets NULL");

    epsnet_reader *r = NULL;
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    check(epsnet_reader_open(&r, "/nonexistent.obj", &rs, &err) == EPSNET_EIO && r == NULL, "reader_open");
    epsnet_reader_close(&r);
    epsnet_writer_settings ws;
    epsnet_writer_default_settings(&ws);
    epsnet_writer *w = NULL;
    check(epsnet_writer_open(&w, "/nonexistent-dir/x.ply", &ws, NULL, &err) == EPSNET_EIO && w == NULL,
          "writer_open");
    epsnet_writer_abort(&w);
    epsnet_gen_settings gs;
    epsnet_gen_default_settings(&gs);
    check(strstr(epsnet_gen_shapes(), "bumpy") != NULL, "gen_shapes");
    check(strstr(epsnet_formats_readable(), "ply") != NULL, "formats_readable");
    check(strstr(epsnet_formats_writable(), "smz") != NULL, "formats_writable");
    epsnet_hausdorff_settings hs;
    epsnet_hausdorff_default_settings(&hs);
    epsnet_sort_settings ss;
    epsnet_sort_default_settings(&ss);
    epsnet_render_settings rds;
    epsnet_render_default_settings(&rds);
    epsnet_remove_temporaries();
    printf("%s header_stands_alone_and_every_entry_point_is_exported\n", failures ? "FAIL" : "ok  ");
    return failures ? 1 : 0;
}
