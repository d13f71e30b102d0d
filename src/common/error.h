/*
 * Internal side of the error convention (include/epsnet/epsnet.h §1).
 * Every layer fills an epsnet_error through these helpers so that the file,
 * the position and the reason reach the CLI message unchanged.
 */
#ifndef EN_COMMON_ERROR_H
#define EN_COMMON_ERROR_H

#include <stdarg.h>

#include "epsnet/epsnet.h"

#if defined(__GNUC__)
#define EN_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define EN_PRINTF(a, b)
#endif

/* Reset err to "no error". err may be NULL. */
void en_error_clear(epsnet_error *err);

/*
 * Fill err (may be NULL) and return code, so callers can write
 * `return en_error_set(err, EPSNET_EFORMAT, path, line, off, "...")`.
 * line/offset take EPSNET_POS_NONE when unknown. file may be NULL.
 */
int en_error_set(epsnet_error *err, int code, const char *file, uint64_t line,
                 uint64_t offset, const char *fmt, ...) EN_PRINTF(6, 7);

int en_error_vset(epsnet_error *err, int code, const char *file, uint64_t line,
                  uint64_t offset, const char *fmt, va_list ap);

/* errno value -> EPSNET_E* code (ENOMEM -> ENOMEM, others -> EIO). */
int en_error_from_errno(int e);

#endif /* EN_COMMON_ERROR_H */
