/*
 * Fuzz target for one reader (issue 8): the input bytes become a file (an
 * in-memory memfd, so the real path-based reader runs unchanged) read to the
 * end through the public API with the format forced. Any crash, hang,
 * sanitizer report or unbounded allocation is a finding; an error return is
 * the expected answer to garbage. FUZZ_FORMAT is set per target by meson.
 *
 * Built as a libFuzzer target (meson -Dfuzz=true, clang) and, always, linked
 * with run_corpus.c so CI replays the corpus without libFuzzer.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <unistd.h>

#include "epsnet/epsnet.h"
#include "fuzz_memfd.h"

#ifndef FUZZ_FORMAT
#error "FUZZ_FORMAT must name the reader under test"
#endif

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char path[64];
    int fd = fuzz_memfd(data, size, path);
    if (fd < 0)
        return 0;
    epsnet_reader_settings rs;
    epsnet_reader_default_settings(&rs);
    rs.format = FUZZ_FORMAT;
    rs.max_count = 1u << 20;          /* absurd counts must be refused, not allocated */
    rs.mem_limit = 64u << 20;
    epsnet_reader *r = NULL;
    epsnet_error err;
    if (epsnet_reader_open(&r, path, &rs, &err) == 0) {
        epsnet_record rec;
        uint64_t n = 0;
        while (epsnet_reader_next(r, &rec, &err) > 0 && ++n < (1u << 24))
            ;
        uint64_t dropped;
        const char *what = epsnet_reader_dropped(r, &dropped);
        if ((what == NULL) != (dropped == 0))
            __builtin_trap();
        epsnet_reader_close(&r);
    }
    close(fd);
    return 0;
}
