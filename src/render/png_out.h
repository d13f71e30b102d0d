/*
 * PNG output for `epsnet render`, through libpng (encoding PNG is a solved
 * problem; see README "Dependencies"). The file appears at its path only when
 * complete, like every epsnet output (docs/architecture.md §5).
 */
#ifndef EN_RENDER_PNG_OUT_H
#define EN_RENDER_PNG_OUT_H

#include <stdint.h>

#include "epsnet/epsnet.h"

/*
 * Write an 8-bit RGB image (3 bytes per pixel, rows top to bottom) to path
 * ("-" = stdout). The bytes depend only on the pixels: no time stamp, fixed
 * compression settings.
 * @return 0, or a negative code with err filled; nothing is left at path on
 * failure.
 */
int en_png_write(const char *path, const uint8_t *rgb, uint32_t width, uint32_t height, epsnet_error *err);

#endif /* EN_RENDER_PNG_OUT_H */
