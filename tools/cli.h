/*
 * Shared pieces of the epsnet command line: exit codes, error printing,
 * option values, the progress bar. The CLI uses only the public API.
 */
#ifndef EPSNET_TOOLS_CLI_H
#define EPSNET_TOOLS_CLI_H

#include <stdint.h>
#include <stdio.h>

#include "epsnet/epsnet.h"

/* Exit codes, one per failure class (documented in `epsnet --help`). */
enum {
    EXIT_OK = 0,
    EXIT_USAGE = 1,       /* bad command line */
    EXIT_BAD_INPUT = 2,   /* malformed input data */
    EXIT_IO = 3,          /* cannot read or write a file, disk full */
    EXIT_RESOURCES = 4,   /* out of memory or over a budget (--mem, limits) */
    EXIT_UNSUPPORTED = 5, /* unknown format or feature */
    EXIT_INTERNAL = 6,    /* a bug in epsnet */
    EXIT_INTERRUPTED = 130,
};

typedef struct cli_command {
    const char *name;
    const char *summary;
    int (*run)(int argc, char **argv);
} cli_command;

/* The commands, one file each. */
int cmd_convert(int argc, char **argv);
int cmd_info(int argc, char **argv);
int cmd_gen(int argc, char **argv);
int cmd_sample(int argc, char **argv);
int cmd_simplify(int argc, char **argv);
int cmd_hausdorff(int argc, char **argv);
int cmd_sort(int argc, char **argv);
int cmd_check(int argc, char **argv);
int cmd_render(int argc, char **argv);

extern int cli_quiet;        /* -q: no progress, no summaries */
/* The ranks of a shared run (epsnet-mpi, tools/epsnet_mpi.c), or NULL.
 * Only rank 0 prints: the others' errors, usage errors and warnings are
 * rank 0's too, and they exit with the same status. */
extern const epsnet_peers *cli_peers;
/* 1 on a rank other than 0 of a shared run: it says nothing, rank 0
 * speaks for the run, which gives every rank the same status (epsnet.h
 * section 8a). */
int cli_follower(void);

/* What both programs set up first: signals that remove the temporary
 * files and exit 130, SIGPIPE and SIGXFSZ as errors, glibc's mmap
 * threshold. */
void cli_process_setup(void);

/* Print "epsnet: MESSAGE" for err and return the exit code for its class. */
int cli_fail(const epsnet_error *err);
/* Print "epsnet CMD: MESSAGE" for a usage problem and return EXIT_USAGE. */
int cli_usage_error(const char *cmd, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
int cli_exit_code(int epsnet_code);

/* Option values: return 0 or print a usage error and return EXIT_USAGE. */
int cli_parse_u64(const char *cmd, const char *opt, const char *text, uint64_t *out);
int cli_parse_double(const char *cmd, const char *opt, const char *text, double *out);
int cli_parse_size(const char *cmd, const char *opt, const char *text, uint64_t *out);

/* Progress bar on stderr, only when stderr is a terminal and not quiet. */
typedef struct cli_progress {
    int enabled;
    const char *label;
    double start, last;
} cli_progress;

void cli_progress_begin(cli_progress *p, const char *label);
/* done/total in bytes (total 0 = unknown); items = records or faces so far. */
void cli_progress_update(cli_progress *p, uint64_t done, uint64_t total, uint64_t items);
void cli_progress_end(cli_progress *p);

/* Progress of a method run (sample, simplify): bytes read for the bar and
 * ETA, faces read so far (from the context's live stats) for the count and
 * rate. Set ctx once the context exists. */
typedef struct cli_run_progress {
    cli_progress bar;
    const epsnet_context *ctx;
} cli_run_progress;

/* An epsnet_settings.progress callback; opaque is a cli_run_progress. */
int cli_run_progress_cb(void *opaque, uint64_t done, uint64_t total);

double cli_now(void);

/* Print "warning: MESSAGE" on stderr (docs/architecture.md §5, nothing is dropped without a
 * word), even with -q: a warning is not a summary. An epsnet_settings /
 * epsnet_sort_settings warning callback; opaque is the cli_progress whose
 * bar the line must not run into, or NULL. */
void cli_warning(void *opaque, const char *message);

/*
 * Options shared by the commands that run the method (sample, simplify):
 * --level, --frequency, --seed, --rotation, -j/--threads, --mem, --tmpdir,
 * --stats, --slab. CLI_METHOD_OPTIONS goes into a getopt_long table; the codes are
 * >= 1000 except -j. cli_method_option() handles one; it returns 1 when it
 * took the option, 0 when the code is not a method option, or -1 after
 * printing a usage error.
 */
#define CLI_METHOD_OPTIONS                                          \
    { "level", required_argument, NULL, 1000 },                     \
    { "frequency", required_argument, NULL, 1001 },                 \
    { "seed", required_argument, NULL, 1002 },                      \
    { "rotation", required_argument, NULL, 1003 },                  \
    { "threads", required_argument, NULL, 'j' },                    \
    { "mem", required_argument, NULL, 1004 },                       \
    { "tmpdir", required_argument, NULL, 1005 },                    \
    { "stats", required_argument, NULL, 1006 },                     \
    { "slab", required_argument, NULL, 1007 }

typedef struct cli_method {
    epsnet_settings settings;
    const char *stats_path;
    int rotation_given, seed_given;
} cli_method;

void cli_method_init(cli_method *m);
int cli_method_option(const char *cmd, int code, const char *arg, cli_method *m);
/* Text for --help describing the method options. */
extern const char cli_method_help[];

#endif
