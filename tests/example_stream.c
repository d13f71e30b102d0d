/*
 * Example: the push/pull streaming API (epsnet.h §8b) with records from any
 * source to any sink. Here the source is a mesh file read record by record
 * and the sink a writer, so
 *
 *     example_stream IN OUT [SLAB_VERTICES [THREADS [PASSES]]]
 *
 * writes what `epsnet simplify IN -o OUT --slab N -j T --passes P` writes
 * (the test suite checks that byte for byte). Replace the reader loop with
 * your own producer, or the writer with your own consumer. Only the public
 * header is used.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "epsnet/epsnet.h"

/* Give every record waiting in s to w. @return 0 or a negative code. */
static int drain(epsnet_stream *s, epsnet_writer *w, epsnet_error *err)
{
    epsnet_record out;
    int rc;
    while ((rc = epsnet_stream_pull(s, &out, err)) == 1)
        if ((rc = epsnet_writer_put(w, &out, err)) != 0)
            return rc;
    return rc;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: example_stream IN OUT [SLAB_VERTICES [THREADS [PASSES]]]\n");
        return 1;
    }
    epsnet_settings set;
    epsnet_default_settings(&set);
    if (argc > 3)
        set.slab_vertices = (uint32_t)strtoul(argv[3], NULL, 10);
    if (argc > 4)
        set.threads = atoi(argv[4]);
    if (argc > 5)
        set.passes = atoi(argv[5]);

    epsnet_error err;
    epsnet_context *ctx = NULL;
    epsnet_reader *r = NULL;
    epsnet_writer *w = NULL;
    epsnet_stream *s = NULL;
    int rc = epsnet_context_new(&ctx, &set, &err);
    if (rc == 0)
        rc = epsnet_reader_open(&r, argv[1], NULL, &err);
    if (rc == 0) {
        /* The output is a finalized stream in the input's vertex order. */
        epsnet_mesh_info info;
        memset(&info, 0, sizeof info);
        info.nverts = info.nfaces = EPSNET_COUNT_UNKNOWN;
        info.coord_type = epsnet_reader_info(r)->coord_type;
        info.streaming = 1;
        info.sorted_axis = epsnet_reader_info(r)->sorted_axis;
        rc = epsnet_writer_open(&w, argv[2], NULL, &info, &err);
    }
    if (rc == 0)
        rc = epsnet_stream_open(&s, ctx, &err);
    epsnet_record in;
    while (rc == 0 && (rc = epsnet_reader_next(r, &in, &err)) == 1) {
        rc = epsnet_stream_push(s, &in, &err);
        if (rc == 0)
            rc = drain(s, w, &err);
    }
    if (rc == 0)
        rc = epsnet_stream_end(s, &err);
    if (rc == 0)
        rc = drain(s, w, &err);
    if (rc == 0)
        rc = epsnet_writer_commit(&w, &err);
    else
        epsnet_writer_abort(&w);
    epsnet_stream_close(&s);
    epsnet_reader_close(&r);
    if (rc == 0) {
        const epsnet_stats *st = epsnet_context_stats(ctx);
        printf("%llu faces in, %llu faces out, %llu slabs\n", (unsigned long long)st->faces,
               (unsigned long long)st->output_faces, (unsigned long long)st->slabs);
    } else {
        fprintf(stderr, "example_stream: %s\n", epsnet_error_message(&err));
    }
    epsnet_context_free(&ctx);
    return rc == 0 ? 0 : 2;
}
