/*
 * Fuzz target for the whole streaming pipeline (issue 8, beyond the
 * readers): a small SMA mesh, hostile topology included (non-manifold
 * edges, bowties, duplicate and degenerate faces, vertices never used or
 * never finalized), goes through epsnet_stream_* with tiny slabs so that
 * every seam path of the chunker, slab worker and stitcher is reached.
 *
 * Byte 0 picks the settings: bits 0-2 the slab size (2 .. 1000 finalized
 * vertices), bit 3 one or two ε-net passes, bits 4-5 the level (1..4). The
 * rest is the .sma file. An error return is a fine answer; a crash, a
 * sanitizer report, a hang, or output that is not a valid finalized stream
 * no larger than the input is a finding (abort()).
 */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "epsnet/epsnet.h"
#include "fuzz_memfd.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

enum { MAX_OUT = 1 << 16 };

typedef struct out_check {
    uint64_t vertices, faces;
    uint8_t state[MAX_OUT];   /* 0 unseen, 1 live, 2 finalized */
} out_check;

static void fail(const char *what)
{
    fprintf(stderr, "fuzz_simplify: %s\n", what);
    abort();
}

/* The output contract of epsnet.h §8b: ids in VERTEX order, triangles on
 * live vertices, each vertex finalized once. */
static void check_record(out_check *c, const epsnet_record *r)
{
    switch (r->kind) {
    case EPSNET_REC_VERTEX:
        if (c->vertices >= MAX_OUT)
            fail("more output vertices than input vertices");
        c->state[c->vertices++] = 1;
        break;
    case EPSNET_REC_TRIANGLE:
        for (int k = 0; k < 3; k++)
            if (r->v[k] >= c->vertices || c->state[r->v[k]] != 1)
                fail("output triangle names a vertex that is not live");
        c->faces++;
        break;
    case EPSNET_REC_FINALIZE:
        if (r->v[0] >= c->vertices || c->state[r->v[0]] != 1)
            fail("output finalizes a vertex that is not live");
        c->state[r->v[0]] = 2;
        break;
    default:
        fail("unknown output record kind");
    }
}

static int drain(epsnet_stream *s, out_check *c, epsnet_error *err)
{
    epsnet_record out;
    int rc;
    while ((rc = epsnet_stream_pull(s, &out, err)) == 1)
        check_record(c, &out);
    return rc;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const uint32_t slabs[8] = { 2, 3, 5, 8, 13, 40, 150, 1000 };
    if (size < 1)
        return 0;
    uint8_t pick = data[0];
    char path[64];
    int fd = fuzz_memfd(data + 1, size - 1, path);
    if (fd < 0)
        return 0;
    epsnet_settings set;
    epsnet_default_settings(&set);
    set.slab_vertices = slabs[pick & 7];
    set.passes = 1 + ((pick >> 3) & 1);
    set.level = 1 + ((pick >> 4) & 3);
    set.threads = 1;
    set.mem = 64u << 20;
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    rs.format = "sma";
    rs.max_count = MAX_OUT;
    rs.mem_limit = 64u << 20;

    static out_check c;
    c.vertices = c.faces = 0;
    epsnet_error err;
    epsnet_context *ctx = NULL;
    epsnet_reader *r = NULL;
    epsnet_stream *s = NULL;
    uint64_t in_vertices = 0, in_faces = 0;
    int rc = epsnet_context_new(&ctx, &set, &err);
    if (rc == 0)
        rc = epsnet_reader_open(&r, path, &rs, &err);
    if (rc == 0)
        rc = epsnet_stream_open(&s, ctx, &err);
    epsnet_record in;
    while (rc == 0 && (rc = epsnet_reader_next(r, &in, &err)) == 1) {
        in_vertices += in.kind == EPSNET_REC_VERTEX;
        in_faces += in.kind == EPSNET_REC_TRIANGLE;
        rc = epsnet_stream_push(s, &in, &err);
        if (rc == 0)
            rc = drain(s, &c, &err);
    }
    if (rc == 0)
        rc = epsnet_stream_end(s, &err);
    if (rc == 0)
        rc = drain(s, &c, &err);
    if (rc == 0) {
        if (c.vertices > in_vertices || c.faces > in_faces)
            fail("the output is larger than the input");
        for (uint64_t v = 0; v < c.vertices; v++)
            if (c.state[v] != 2)
                fail("an output vertex is never finalized");
    }
    epsnet_stream_close(&s);
    epsnet_reader_close(&r);
    epsnet_context_free(&ctx);
    close(fd);
    return 0;
}
