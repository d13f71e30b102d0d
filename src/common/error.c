#include "common/error.h"

#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <string.h>

void en_error_clear(epsnet_error *err)
{
    if (!err)
        return;
    err->code = 0;
    err->file[0] = '\0';
    err->line = EPSNET_POS_NONE;
    err->offset = EPSNET_POS_NONE;
    err->zst = 0;
    err->reason[0] = '\0';
}

int en_error_vset(epsnet_error *err, int code, const char *file, uint64_t line,
                  uint64_t offset, const char *fmt, va_list ap)
{
    if (!err)
        return code;
    en_error_clear(err);
    err->code = code;
    if (file)
        snprintf(err->file, sizeof err->file, "%s", file);
    err->line = line;
    err->offset = offset;
    vsnprintf(err->reason, sizeof err->reason, fmt, ap);
    /* note: one line only; a reason quoting input must not break the CLI's
     * one-line error contract (docs/architecture.md §5). */
    for (char *p = err->reason; *p; p++)
        if (*p == '\n' || *p == '\r')
            *p = ' ';
    return code;
}

int en_error_set(epsnet_error *err, int code, const char *file, uint64_t line,
                 uint64_t offset, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    en_error_vset(err, code, file, line, offset, fmt, ap);
    va_end(ap);
    return code;
}

int en_error_from_errno(int e)
{
    return e == ENOMEM ? EPSNET_ENOMEM : EPSNET_EIO;
}

const char *epsnet_strerror(int code)
{
    switch (code) {
    case EPSNET_OK: return "success";
    case EPSNET_EINVAL: return "invalid argument";
    case EPSNET_EFORMAT: return "malformed input";
    case EPSNET_EIO: return "input/output error";
    case EPSNET_ENOMEM: return "out of memory";
    case EPSNET_ELIMIT: return "limit exceeded";
    case EPSNET_EUNSUPPORTED: return "unsupported";
    case EPSNET_EINTR: return "interrupted";
    case EPSNET_EINTERNAL: return "internal error";
    case EPSNET_EAGAIN: return "pull the waiting output first";
    default: return "unknown error";
    }
}

/* note: thread-local so that workers can format their own errors while the
 * struct itself stays plain, copyable data. */
const char *epsnet_error_message(const epsnet_error *err)
{
    static _Thread_local char msg[1200];
    if (!err)
        return "unknown error";
    const char *reason = err->reason[0] ? err->reason : epsnet_strerror(err->code);
    if (err->file[0] && err->line != EPSNET_POS_NONE)
        snprintf(msg, sizeof msg, "%s:%" PRIu64 ": %s", err->file, err->line, reason);
    else if (err->file[0] && err->offset != EPSNET_POS_NONE)
        snprintf(msg, sizeof msg, "%s: %sbyte %" PRIu64 ": %s", err->file,
                 err->zst ? "decompressed " : "", err->offset, reason);
    else if (err->file[0])
        snprintf(msg, sizeof msg, "%s: %s", err->file, reason);
    else
        snprintf(msg, sizeof msg, "%s", reason);
    return msg;
}
