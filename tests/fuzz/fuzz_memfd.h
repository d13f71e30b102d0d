/* The fuzz input as a file: an in-memory memfd, so the real path-based
 * readers run unchanged (shared by the fuzz targets). */
#ifndef EPSNET_FUZZ_MEMFD_H
#define EPSNET_FUZZ_MEMFD_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <sys/mman.h>
#include <unistd.h>

/* Write data[0..size) to a new memfd and its /proc path into path.
 * @return the descriptor (close it), or -1. */
static inline int fuzz_memfd(const uint8_t *data, size_t size, char path[64])
{
    int fd = memfd_create("epsnet-fuzz", MFD_CLOEXEC);
    if (fd < 0)
        return -1;
    size_t done = 0;
    while (done < size) {
        ssize_t k = write(fd, data + done, size - done);
        if (k <= 0) {
            close(fd);
            return -1;
        }
        done += (size_t)k;
    }
    snprintf(path, 64, "/proc/self/fd/%d", fd);
    return fd;
}

#endif
