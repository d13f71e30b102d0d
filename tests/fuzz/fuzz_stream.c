/*
 * Fuzz target for the stream validator (issue 8): the bytes are read as a
 * streaming mesh and every record goes through the bookkeeping of
 * `epsnet check` (tools/cmd_check.c): sortedness per axis, the live window
 * of tools/stream_window.c (width, span, late and unused finalizations) and
 * the final verdict. The first byte picks the reader, so all three stream
 * formats and the content probe are reached from one corpus:
 *
 *   byte0 % 4 == 0  SMA      1  SMB      2  SMZ
 *               3   no format forced: detected from the content, as
 *                   `epsnet check` does for a name without a known suffix
 *
 * Beyond "no crash", the target asserts what `epsnet check` silently
 * relies on (docs/architecture.md §6): the reader never hands over a triangle corner or a
 * finalization outside the live window, never finalizes a vertex twice, and
 * the window's counters agree with the record counts. A violation aborts,
 * so libFuzzer reports it like a crash.
 *
 * The counting is `epsnet check`'s own (sc_record() in tools/stream_window.c);
 * the assertions are made before each record reaches it.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "epsnet/epsnet.h"
#include "fuzz_memfd.h"
#include "stream_window.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Same budget as the reader targets: absurd counts and windows are refused. */
#define FUZZ_MEM_LIMIT ((uint64_t)64 << 20)

static void violated(const char *what, uint64_t v, const stream_window *w)
{
    fprintf(stderr, "fuzz_stream: %s (vertex %llu, window [%llu, %llu), live %llu)\n", what,
            (unsigned long long)v, (unsigned long long)w->base, (unsigned long long)w->next,
            (unsigned long long)w->live);
    abort();
}

/* A reference the reader accepted must name a live vertex of the window. */
static void require_live(const stream_window *w, uint64_t v, const char *what)
{
    if (v < w->base || v >= w->next)
        violated(what, v, w);
    if (w->slot[v & (w->cap - 1)] == SW_FINALIZED)
        violated(what, v, w);
}

/* @return 1 to go on, 0 when the window is over its budget (check stops). */
static int check_record(stream_check *k, stream_window *w, int streaming, const epsnet_record *rec)
{
    if (rec->kind == EPSNET_REC_TRIANGLE) {
        for (int s = 0; s < 3 && streaming; s++)
            require_live(w, rec->v[s], "triangle corner outside the live window");
    } else if (rec->kind == EPSNET_REC_FINALIZE) {
        if (!streaming)
            violated("finalization from a non-streaming format", rec->v[0], w);
        require_live(w, rec->v[0], "finalization outside the live window");
    } else if (rec->kind != EPSNET_REC_VERTEX) {
        violated("record of unknown kind", (uint64_t)rec->kind, w);
    }
    return sc_record(k, w, streaming, rec) == 0;
}

static void check_totals(const stream_check *k, const stream_window *w, int streaming, int read_all)
{
    if (!streaming)
        return;
    if (w->live != k->nv - k->nfin)
        violated("live count differs from vertices minus finalizations", k->nv, w);
    if (w->width < w->live || w->span < w->next - w->base || w->next != k->nv)
        violated("width/span below the window", k->nv, w);
    /* a stream that read to the end with every vertex finalized closes its window */
    if (read_all && k->nv == k->nfin && w->base != w->next)
        violated("all vertices finalized but the window is not empty", k->nv, w);
}

static void run_check(const char *path, const char *format)
{
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    rs.format = format;
    rs.max_count = (uint64_t)1 << 20;
    rs.mem_limit = FUZZ_MEM_LIMIT;
    epsnet_reader *r = NULL;
    epsnet_error err;
    if (epsnet_reader_open(&r, path, &rs, &err) != 0)
        return;
    const epsnet_mesh_info info = *epsnet_reader_info(r);
    stream_check k = { .sorted = { 1, 1, 1 } };
    stream_window w = { .max_bytes = FUZZ_MEM_LIMIT };
    epsnet_record rec;
    int rc, within = 1;
    uint64_t records = 0;
    while (within && (rc = epsnet_reader_next(r, &rec, &err)) > 0 && ++records < ((uint64_t)1 << 24))
        within = check_record(&k, &w, info.streaming, &rec);
    epsnet_reader_close(&r);
    /* over budget, `epsnet check` stops with the last vertex uncounted in the window */
    if (within)
        check_totals(&k, &w, info.streaming, rc == 0);
    if (info.sorted_axis < -1 || info.sorted_axis > 2)
        violated("declared sort axis out of range", (uint64_t)info.sorted_axis, &w);
    sw_free(&w);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const formats[4] = { "sma", "smb", "smz", NULL };
    if (size == 0)
        return 0;
    const char *format = formats[data[0] & 3];
    char path[64];
    int fd = fuzz_memfd(data + 1, size - 1, path); /* byte 0 chose the reader */
    if (fd < 0)
        return 0;
    run_check(path, format);
    close(fd);
    return 0;
}
