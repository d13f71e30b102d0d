/* Small process-level helpers. */
#ifndef EN_COMMON_UTIL_H
#define EN_COMMON_UTIL_H

#include <stdint.h>

/* Peak resident set size of this process (VmHWM), 0 when unknown. */
uint64_t en_peak_rss_bytes(void);

/* Monotonic clock in seconds. */
double en_now(void);

/* CPU seconds the calling thread has used (0 when unknown). */
double en_thread_cpu_seconds(void);
/* ... and the whole process, every thread (0 when unknown). */
double en_process_cpu_seconds(void);

#endif
