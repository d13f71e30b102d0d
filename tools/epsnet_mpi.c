/*
 * epsnet-mpi: `mpirun -n R epsnet-mpi simplify IN -o OUT [options]`, the
 * simplify command with its slabs shared among MPI ranks (epsnet.h section
 * 8a, docs/distributed.md). Rank 0 reads IN, deals the slabs, stitches and
 * writes OUT, prints the summary, the warnings and any error; the other
 * ranks work the slabs they are sent; every rank exits with the run's one
 * status. Built with `meson setup -Dmpi=enabled`.
 *
 * The transport: one MPI message per send, tag 0 on MPI_COMM_WORLD, whose
 * order between two ranks MPI keeps. A send is posted without waiting
 * (MPI_Isend of a copy), so that a rank goes on while rank 0, which takes
 * the others' messages each time it deals a slab, is busy, up to
 * PENDING_BYTES in flight; past that it waits for the oldest: the
 * back-pressure that bounds a rank's memory. The copies are kept for the
 * next sends: a fresh one each time (megabytes: a slab's input or
 * results) was a fresh mapping, and the two ranks of a run took 380,000
 * page faults more than one process (bench/RESULTS.md, session 32).
 */
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cli.h"

/* A message larger than an int's count goes in pieces of this size, on
 * both sides alike. */
#define PIECE ((size_t)1 << 30)
/* Sends in flight at most: about two slabs' results at the default slab
 * size (some 12 MB each at 65,536 vertices). */
#define PENDING_BYTES ((size_t)32 << 20)
/* Copies kept for later sends, at most. */
#define SPARES 32

typedef struct pending {
    MPI_Request req;
    void *copy;
    size_t n, cap;
} pending;

typedef struct mpi_link {
    pending *q;                   /* sends in flight, oldest first (a ring) */
    size_t head, len, cap, bytes;
    void *spare[SPARES];          /* copies whose sends are done */
    size_t spare_cap[SPARES];
    int nspare;
} mpi_link;

/*
 * Wait for req without spinning: MPI_Wait polls at full speed, and on a
 * machine whose ranks share cores (two ranks and their workers on two
 * cores, as in CI) that time is taken from the rank being waited for. So
 * a few quick tests, then tests further and further apart, from a tenth
 * of a millisecond up to four: a rank that waits for its next slab waits
 * for most of a slab's time (tens of milliseconds), and each wake-up
 * takes a core from a worker for a moment (at a tenth of a millisecond
 * throughout, the workers of a two-rank run on two cores ran about a
 * fifth slower than one process's; bench/RESULTS.md, session 32).
 */
static int wait_for(MPI_Request *req, MPI_Status *st)
{
    int done = 0;
    long nap = 100000;
    for (int i = 0; !done; i++) {
        if (MPI_Test(req, &done, st) != MPI_SUCCESS)
            return -1;
        if (!done && i >= 16) {
            nanosleep(&(struct timespec){ 0, nap }, NULL);
            if (nap < 4000000)
                nap += nap / 4;
        }
    }
    return 0;
}

/* A copy of at least n bytes: the smallest spare that fits, or a new one. */
static void *copy_of(mpi_link *l, size_t n, size_t *cap)
{
    int best = -1;
    for (int i = 0; i < l->nspare; i++)
        if (l->spare_cap[i] >= n && (best < 0 || l->spare_cap[i] < l->spare_cap[best]))
            best = i;
    if (best < 0) {
        *cap = n ? n : 1;
        return malloc(*cap);
    }
    void *p = l->spare[best];
    *cap = l->spare_cap[best];
    l->nspare--;
    l->spare[best] = l->spare[l->nspare];
    l->spare_cap[best] = l->spare_cap[l->nspare];
    return p;
}

/* A copy whose send is done: kept, in place of the smallest when full. */
static void keep_copy(mpi_link *l, void *p, size_t cap)
{
    int at = l->nspare;
    if (at == SPARES) {
        at = 0;
        for (int i = 1; i < SPARES; i++)
            if (l->spare_cap[i] < l->spare_cap[at])
                at = i;
        if (l->spare_cap[at] >= cap) {
            free(p);
            return;
        }
        free(l->spare[at]);
    } else {
        l->nspare++;
    }
    l->spare[at] = p;
    l->spare_cap[at] = cap;
}

static void retire_oldest(mpi_link *l)
{
    pending *p = &l->q[l->head];
    keep_copy(l, p->copy, p->cap);
    l->bytes -= p->n;
    l->head = (l->head + 1) % l->cap;
    l->len--;
}

/* Retire the sends that are done, oldest first, without waiting. */
static int reap(mpi_link *l)
{
    while (l->len) {
        int done = 0;
        if (MPI_Test(&l->q[l->head].req, &done, MPI_STATUS_IGNORE) != MPI_SUCCESS)
            return -1;
        if (!done)
            break;
        retire_oldest(l);
    }
    return 0;
}

static int post(mpi_link *l, int to, const void *buf, size_t n)
{
    if (reap(l))
        return -1;
    while (l->len && l->bytes + n > PENDING_BYTES) {
        if (wait_for(&l->q[l->head].req, MPI_STATUS_IGNORE))
            return -1;
        retire_oldest(l);
    }
    if (l->len == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 16;
        pending *q = malloc(cap * sizeof *q);
        if (!q)
            return -1;
        for (size_t i = 0; i < l->len; i++)
            q[i] = l->q[(l->head + i) % l->cap];
        free(l->q);
        l->q = q;
        l->head = 0;
        l->cap = cap;
    }
    pending *p = &l->q[(l->head + l->len) % l->cap];
    if (!(p->copy = copy_of(l, n, &p->cap)))
        return -1;
    memcpy(p->copy, buf, n);
    p->n = n;
    if (MPI_Isend(p->copy, (int)n, MPI_BYTE, to, 0, MPI_COMM_WORLD, &p->req) != MPI_SUCCESS) {
        keep_copy(l, p->copy, p->cap);
        return -1;
    }
    l->len++;
    l->bytes += n;
    return 0;
}

static int mpi_send(void *opaque, int to, const void *buf, size_t n)
{
    mpi_link *l = opaque;
    const char *b = buf;
    do {
        size_t piece = n < PIECE ? n : PIECE;
        if (post(l, to, b, piece))
            return -1;
        b += piece;
        n -= piece;
    } while (n);
    return 0;
}

/* Every send done, and the copies freed (the run's end). */
static void drain(mpi_link *l)
{
    while (l->len) {
        wait_for(&l->q[l->head].req, MPI_STATUS_IGNORE);
        retire_oldest(l);
    }
    for (int i = 0; i < l->nspare; i++)
        free(l->spare[i]);
    free(l->q);
}

static int mpi_recv(void *opaque, int from, void *buf, size_t n)
{
    if (reap(opaque))
        return -1;
    char *b = buf;
    do {
        size_t piece = n < PIECE ? n : PIECE;
        MPI_Status st;
        MPI_Request req;
        int count = -1;
        if (MPI_Irecv(b, (int)piece, MPI_BYTE, from, 0, MPI_COMM_WORLD, &req) != MPI_SUCCESS ||
            wait_for(&req, &st) || MPI_Get_count(&st, MPI_BYTE, &count) != MPI_SUCCESS || (size_t)count != piece)
            return -1;
        b += piece;
        n -= piece;
    } while (n);
    return 0;
}

/* Whether a message from `from` waits (rank 0 asks before it deals a slab). */
static int mpi_poll(void *opaque, int from)
{
    if (reap(opaque))
        return -1;
    int flag = 0;
    return MPI_Iprobe(from, 0, MPI_COMM_WORLD, &flag, MPI_STATUS_IGNORE) == MPI_SUCCESS ? flag != 0 : -1;
}

static void usage(FILE *f)
{
    fprintf(f, "usage: mpirun -n R epsnet-mpi simplify IN -o OUT [options]\n"
               "\n"
               "epsnet simplify with its slabs shared among R MPI ranks, each with its own\n"
               "-j threads: rank 0 reads IN, sends the slabs out, stitches the seams and\n"
               "writes OUT; the others work the slabs. The output is the bytes one process\n"
               "writes. 'epsnet simplify --help' lists\n"
               "the options; docs/distributed.md says how to run it under Slurm.\n");
}

int main(int argc, char **argv)
{
    cli_process_setup();
    int provided = 0, rank = 0, size = 1;
    if (MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
        fprintf(stderr, "epsnet-mpi: MPI_Init_thread failed\n");
        return EXIT_INTERNAL;
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    int rc;
    if (provided < MPI_THREAD_FUNNELED) {
        /* the library calls MPI from the thread that called it, while its
         * own threads run */
        if (rank == 0)
            fprintf(stderr, "epsnet-mpi: this MPI does not allow threads beside its calls (FUNNELED)\n");
        rc = EXIT_UNSUPPORTED;
    } else if (argc < 2 || strcmp(argv[1], "simplify") != 0) {
        if (rank == 0)
            usage(argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) ? stdout : stderr);
        rc = argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) ? EXIT_OK : EXIT_USAGE;
    } else {
        mpi_link link = { 0 };
        epsnet_peers peers = { .rank = rank, .size = size, .opaque = &link, .send = mpi_send, .recv = mpi_recv,
                               .poll = mpi_poll };
        cli_peers = &peers;
        rc = cmd_simplify(argc - 1, argv + 1);
        drain(&link);
    }
    /* mpirun ends every rank once one exits non-zero: none exits before all
     * are done, rank 0's output committed or its temporary file removed */
    MPI_Barrier(MPI_COMM_WORLD);
    MPI_Finalize();
    return rc;
}
