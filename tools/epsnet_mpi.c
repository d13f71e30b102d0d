/*
 * epsnet-mpi: `mpirun -n R epsnet-mpi simplify IN -o OUT [options]`, the
 * simplify command with its slabs shared among MPI ranks (epsnet.h section
 * 8a, docs/distributed.md). Every rank reads IN; rank 0 stitches and writes
 * OUT, prints the summary, the warnings and any error; every rank exits
 * with the run's one status. Built with `meson setup -Dmpi=enabled`.
 *
 * The transport: one MPI message per send, tag 0 on MPI_COMM_WORLD, whose
 * order between two ranks MPI keeps. A send is posted without waiting
 * (MPI_Isend of a copy), so that a rank goes on with its next slab while
 * rank 0 is busy, up to PENDING_BYTES in flight; past that it waits for the
 * oldest: the back-pressure that bounds a rank's memory.
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
 * size (some 12 MB each at 65,536 vertices). Measured on `gen bumpy` 20M
 * at two ranks, -j 1 (bench/RESULTS.md, session 24): at 64 MB the other
 * rank ran far enough ahead to peak 32 MB higher, at no gain in time; at
 * 16 MB it waited for rank 0 and the run took 10% longer. */
#define PENDING_BYTES ((size_t)32 << 20)

typedef struct pending {
    MPI_Request req;
    void *copy;
    size_t n;
} pending;

typedef struct mpi_link {
    pending *q;
    size_t head, len, cap, bytes;
} mpi_link;

/*
 * Wait for req without spinning: MPI_Wait polls at full speed, and on a
 * machine whose ranks share cores (two ranks and their workers on two
 * cores, as in CI) that time is taken from the rank being waited for. So
 * a few quick tests, then tests a tenth of a millisecond apart (a slab's
 * results take tens of milliseconds to come).
 */
static int wait_for(MPI_Request *req, MPI_Status *st)
{
    int done = 0;
    for (int i = 0; !done; i++) {
        if (MPI_Test(req, &done, st) != MPI_SUCCESS)
            return -1;
        if (!done && i >= 16)
            nanosleep(&(struct timespec){ 0, 100000 }, NULL);
    }
    return 0;
}

static void wait_oldest(mpi_link *l)
{
    pending *p = &l->q[l->head];
    wait_for(&p->req, MPI_STATUS_IGNORE);
    free(p->copy);
    l->bytes -= p->n;
    l->head = (l->head + 1) % l->cap;
    l->len--;
}

static int post(mpi_link *l, int to, const void *buf, size_t n)
{
    while (l->len && l->bytes + n > PENDING_BYTES)
        wait_oldest(l);
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
    if (!(p->copy = malloc(n ? n : 1)))
        return -1;
    memcpy(p->copy, buf, n);
    p->n = n;
    if (MPI_Isend(p->copy, (int)n, MPI_BYTE, to, 0, MPI_COMM_WORLD, &p->req) != MPI_SUCCESS) {
        free(p->copy);
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

static int mpi_recv(void *opaque, int from, void *buf, size_t n)
{
    (void)opaque;
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

static void usage(FILE *f)
{
    fprintf(f, "usage: mpirun -n R epsnet-mpi simplify IN -o OUT [options]\n"
               "\n"
               "epsnet simplify with its slabs shared among R MPI ranks, each with its own\n"
               "-j threads: every rank reads IN, rank 0 stitches the seams and writes OUT.\n"
               "The output is the bytes one process writes. 'epsnet simplify --help' lists\n"
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
        epsnet_peers peers = { .rank = rank, .size = size, .opaque = &link, .send = mpi_send, .recv = mpi_recv };
        cli_peers = &peers;
        rc = cmd_simplify(argc - 1, argv + 1);
        while (link.len)
            wait_oldest(&link);
        free(link.q);
    }
    /* mpirun ends every rank once one exits non-zero: none exits before all
     * are done, rank 0's output committed or its temporary file removed */
    MPI_Barrier(MPI_COMM_WORLD);
    MPI_Finalize();
    return rc;
}
