/*
 * One run shared among processes (epsnet.h section 8a, docs/distributed.md),
 * with threads standing in for the processes: a transport of queues, one
 * per ordered pair of ranks, that either buffers every message or makes each
 * send wait until its receiver took it (MPI_Send at its strictest, which
 * finds a protocol that could deadlock). What must hold: the output bytes
 * of one process for every rank count and thread count, a default run and a
 * size alike; one verdict for every rank when any fails, its message naming
 * the rank, and no output.
 */
#include <pthread.h>

#include "testlib.h"

#define MAX_RANKS 4

typedef struct msg {
    void *data;
    size_t n;
    int taken;
    struct msg *next;
} msg;

typedef struct hub {
    pthread_mutex_t mu;
    pthread_cond_t cv;
    int sync;                     /* a send waits until its message is taken */
    msg *head[MAX_RANKS][MAX_RANKS], *tail[MAX_RANKS][MAX_RANKS]; /* [from][to] */
    uint64_t sent[MAX_RANKS];     /* messages each rank sent */
} hub;

typedef struct endpoint {
    hub *h;
    int rank;
} endpoint;

static int hub_send(void *opaque, int to, const void *buf, size_t n)
{
    endpoint *e = opaque;
    hub *h = e->h;
    msg *m = calloc(1, sizeof *m);
    if (!m || !(m->data = malloc(n ? n : 1)))
        return -1;
    memcpy(m->data, buf, n);
    m->n = n;
    pthread_mutex_lock(&h->mu);
    msg **tail = &h->tail[e->rank][to];
    if (*tail)
        (*tail)->next = m;
    else
        h->head[e->rank][to] = m;
    *tail = m;
    h->sent[e->rank]++;
    pthread_cond_broadcast(&h->cv);
    if (h->sync) {
        while (!m->taken)
            pthread_cond_wait(&h->cv, &h->mu);
        free(m->data);
        free(m);
    }
    pthread_mutex_unlock(&h->mu);
    return 0;
}

static int hub_poll(void *opaque, int from)
{
    endpoint *e = opaque;
    hub *h = e->h;
    pthread_mutex_lock(&h->mu);
    int there = h->head[from][e->rank] != NULL;
    pthread_mutex_unlock(&h->mu);
    return there;
}

static int hub_recv(void *opaque, int from, void *buf, size_t n)
{
    endpoint *e = opaque;
    hub *h = e->h;
    pthread_mutex_lock(&h->mu);
    while (!h->head[from][e->rank])
        pthread_cond_wait(&h->cv, &h->mu);
    msg *m = h->head[from][e->rank];
    h->head[from][e->rank] = m->next;
    if (!m->next)
        h->tail[from][e->rank] = NULL;
    int rc = m->n == n ? 0 : -1; /* each send is matched by one recv of its size */
    if (rc == 0)
        memcpy(buf, m->data, n);
    if (h->sync) {
        m->taken = 1; /* the sender frees it */
        pthread_cond_broadcast(&h->cv);
    } else {
        free(m->data);
        free(m);
    }
    pthread_mutex_unlock(&h->mu);
    return rc;
}

typedef struct rank_run {
    endpoint e;
    epsnet_peers peers;
    epsnet_settings set;
    const char *in, *out;
    int rc;
    epsnet_error err;
    epsnet_stats st;
} rank_run;

static void *rank_main(void *arg)
{
    rank_run *r = arg;
    epsnet_context *ctx = NULL;
    r->rc = epsnet_context_new(&ctx, &r->set, &r->err);
    if (r->rc == 0)
        r->rc = epsnet_simplify_file(ctx, r->in, r->out, &r->err);
    if (ctx)
        r->st = *epsnet_context_stats(ctx);
    epsnet_context_free(&ctx);
    return NULL;
}

/* Run `ranks` ranks on in -> out; in_of[r], when given, is rank r's input
 * instead, and mem_of[r], when not 0, its memory budget. Fills rc[] and
 * err[] per rank. */
static void shared_run(const epsnet_settings *set, int ranks, int sync, const char *in, const char *const *in_of,
                       const uint64_t *mem_of, const char *out, int *rc, epsnet_error *err, uint64_t *messages,
                       epsnet_stats *st0)
{
    hub h;
    memset(&h, 0, sizeof h);
    pthread_mutex_init(&h.mu, NULL);
    pthread_cond_init(&h.cv, NULL);
    h.sync = sync;
    rank_run runs[MAX_RANKS];
    pthread_t tid[MAX_RANKS];
    for (int r = 0; r < ranks; r++) {
        rank_run *x = &runs[r];
        memset(x, 0, sizeof *x);
        x->e = (endpoint){ &h, r };
        x->peers = (epsnet_peers){
            .rank = r, .size = ranks, .opaque = &x->e, .send = hub_send, .recv = hub_recv, .poll = hub_poll
        };
        x->set = *set;
        x->set.peers = &x->peers;
        if (mem_of && mem_of[r])
            x->set.mem = mem_of[r];
        x->in = in_of && in_of[r] ? in_of[r] : in;
        x->out = out;
        pthread_create(&tid[r], NULL, rank_main, x);
    }
    for (int r = 0; r < ranks; r++) {
        pthread_join(tid[r], NULL);
        rc[r] = runs[r].rc;
        err[r] = runs[r].err;
    }
    if (st0)
        *st0 = runs[0].st;
    if (messages) { /* the fewest any other rank sent */
        *messages = UINT64_MAX;
        for (int r = 1; r < ranks; r++)
            *messages = h.sent[r] < *messages ? h.sent[r] : *messages;
    }
    for (int a = 0; a < MAX_RANKS; a++) /* a failed run may leave messages unread */
        for (int b = 0; b < MAX_RANKS; b++)
            for (msg *m = h.head[a][b], *next; m; m = next) {
                next = m->next;
                free(m->data);
                free(m);
            }
    pthread_cond_destroy(&h.cv);
    pthread_mutex_destroy(&h.mu);
}

static epsnet_settings base_settings(uint32_t slab, int threads)
{
    epsnet_settings set;
    epsnet_default_settings(&set);
    set.slab_vertices = slab;
    set.threads = threads;
    return set;
}

static int one_process(const epsnet_settings *set, const char *in, const char *out, epsnet_stats *st)
{
    epsnet_context *ctx = NULL;
    epsnet_error err;
    int rc = epsnet_context_new(&ctx, set, &err);
    if (rc == 0)
        rc = epsnet_simplify_file(ctx, in, out, &err);
    if (rc)
        fprintf(stderr, "one process: %s\n", epsnet_error_message(&err));
    else if (st)
        *st = *epsnet_context_stats(ctx);
    epsnet_context_free(&ctx);
    return rc;
}

/* The shared run's output against one process's, for 1-4 ranks, 1 and 2
 * threads a rank, both transports. */
static void check_same_bytes(const char *label, const char *in, epsnet_settings set)
{
    char ref[512], out[512];
    snprintf(ref, sizeof ref, "%s", tl_path("ref.smz"));
    snprintf(out, sizeof out, "%s", tl_path("shared.smz"));
    epsnet_stats st;
    set.threads = 1;
    CHECK_EQ_INT(one_process(&set, in, ref, &st), 0);
    CHECK(st.slabs >= 8); /* enough slabs that every rank works some */
    size_t nref = 0;
    unsigned char *want = tl_read_file(ref, &nref);
    CHECK(want != NULL && nref > 0);
    for (int ranks = 1; ranks <= 4; ranks++) {
        uint64_t shipped = 0; /* over the four runs of this rank count */
        for (int threads = 1; threads <= 2; threads++)
            for (int sync = 0; sync <= 1; sync++) {
                int rc[MAX_RANKS];
                epsnet_error err[MAX_RANKS];
                epsnet_stats st0;
                memset(&st0, 0, sizeof st0);
                unlink(out);
                set.threads = threads;
                shared_run(&set, ranks, sync, in, NULL, NULL, out, rc, err, NULL, &st0);
                for (int r = 0; r < ranks; r++) {
                    CHECK_EQ_INT(rc[r], 0);
                    if (rc[r])
                        fprintf(stderr, "  %s: rank %d of %d: %s\n", label, r, ranks, epsnet_error_message(&err[r]));
                }
                /* rank 0 counts the slabs it sent: none in one process, and
                 * at most every slab (who works which follows the timing) */
                CHECK(st0.slabs_shipped <= st0.slabs);
                if (ranks == 1)
                    CHECK_EQ_U64(st0.slabs_shipped, 0);
                shipped += st0.slabs_shipped;
                size_t n = 0;
                unsigned char *got = tl_read_file(out, &n);
                int same = got && want && n == nref && memcmp(got, want, n) == 0;
                CHECK(same);
                if (!same)
                    fprintf(stderr, "  %s: %d ranks, %d threads, %s transport: bytes differ\n", label, ranks,
                            threads, sync ? "synchronous" : "buffered");
                free(got);
            }
        /* the work was shared: the other ranks want slabs from the start */
        if (ranks > 1)
            CHECK(shipped > 0);
    }
    free(want);
}

TEST(the_default_path_gives_one_process_bytes_for_1_to_4_ranks)
{
    char in[512];
    snprintf(in, sizeof in, "%s", tl_path("bumpy.smz"));
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 40000, NAN, 3, 0, &err), 0);
    check_same_bytes("default", in, base_settings(900, 1));
    epsnet_settings two = base_settings(900, 1);
    two.passes = 2; /* pass 2 takes rank 0's stitched stream, on rank 0 */
    check_same_bytes("two passes", in, two);
}

TEST(a_size_gives_one_process_bytes_for_1_to_4_ranks)
{
    char in[512];
    snprintf(in, sizeof in, "%s", tl_path("bumpy_t.smz"));
    epsnet_error err;
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 40000, NAN, 5, 0, &err), 0);
    /* streamed (over four slabs): the thinning's slabs shared, its density
     * chosen at the checkpoints from every slab's counts, rounds on rank 0 */
    epsnet_settings set = base_settings(1000, 1);
    set.target_ratio = 0.1;
    check_same_bytes("ratio 0.1", in, set);
    set.target_ratio = 0.02;
    check_same_bytes("ratio 0.02", in, set);
}

TEST(a_cad_part_with_seams_and_an_ordinary_mesh_give_one_process_bytes)
{
    char in[512];
    snprintf(in, sizeof in, "%s", tl_path("cad.ply"));
    epsnet_error err;
    /* a PLY: rank 0 sorts it; a CAD part: sharp features, many seams */
    CHECK_EQ_INT(tl_gen_file(in, "cad", 30000, NAN, 2, 1, &err), 0);
    check_same_bytes("cad ply", in, base_settings(600, 1));
}

/* A textured mesh, its texture coordinates weighed: the attribute
 * quadrics travel with the quadrics, packed to the vertices alive, and
 * rank 0's stitcher reads them packed (en_slab_work.packed). */
TEST(weighed_texture_coordinates_give_one_process_bytes)
{
    char in[512];
    snprintf(in, sizeof in, "%s", tl_path("atlas.smz"));
    epsnet_gen_settings gs;
    epsnet_gen_default_settings(&gs);
    gs.shape = "bumpy";
    gs.faces = 40000;
    gs.seed = 3;
    gs.charts = 8;
    epsnet_mesh_info info;
    epsnet_error err;
    CHECK_EQ_INT(epsnet_gen_info(&gs, &info, &err), 0);
    CHECK_EQ_INT(info.vertex_attrs.count, 2); /* texture_u, texture_v */
    CHECK_EQ_INT(tl_gen_settings_file(in, &gs, &err), 0);
    epsnet_settings set = base_settings(900, 1);
    set.attribute_weights = "1";
    check_same_bytes("weighed uv", in, set);
    set.target_ratio = 0.1;
    check_same_bytes("weighed uv, ratio 0.1", in, set);
}

/* One case of the above, for the thread sanitizer's build (CI time):
 * ranks and their workers at once. */
TEST(three_ranks_of_two_workers_give_one_process_bytes)
{
    char in[512], ref[512], out[512];
    snprintf(in, sizeof in, "%s", tl_path("small.smz"));
    snprintf(ref, sizeof ref, "%s", tl_path("small_ref.smz"));
    snprintf(out, sizeof out, "%s", tl_path("small_out.smz"));
    epsnet_error err[MAX_RANKS];
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 20000, NAN, 3, 0, &err[0]), 0);
    epsnet_settings set = base_settings(600, 2);
    set.target_ratio = 0.1;
    CHECK_EQ_INT(one_process(&set, in, ref, NULL), 0);
    int rc[MAX_RANKS];
    shared_run(&set, 3, 1, in, NULL, NULL, out, rc, err, NULL, NULL);
    for (int r = 0; r < 3; r++)
        CHECK_EQ_INT(rc[r], 0);
    CHECK(tl_same_file(ref, out));
}

/* Every rank's status is the same, and no output is left. */
static void check_all_failed(const int *rc, const epsnet_error *err, int ranks, const char *out, const char *words)
{
    for (int r = 0; r < ranks; r++) {
        CHECK(rc[r] < 0);
        CHECK_EQ_INT(rc[r], rc[0]);
        CHECK_STR_CONTAINS(epsnet_error_message(&err[r]), words);
    }
    CHECK(!tl_exists(out));
}

TEST(a_damaged_input_fails_every_rank_with_its_message_and_leaves_nothing)
{
    char in[512], out[512];
    snprintf(in, sizeof in, "%s", tl_path("good.smz"));
    snprintf(out, sizeof out, "%s", tl_path("nothing.smz"));
    epsnet_error err[MAX_RANKS];
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 200000, NAN, 3, 0, &err[0]), 0);
    size_t n = 0;
    unsigned char *b = tl_read_file(in, &n);
    CHECK(b && n > 4096);
    if (!b)
        return;
    /* the payload of a late block (docs/smz.md: each block's header starts
     * "SMZB"), so that every rank has worked and sent slabs before it */
    size_t last = 0, blocks = 0;
    for (size_t i = 0; i + 4 <= n; i++)
        if (memcmp(b + i, "SMZB", 4) == 0)
            last = i, blocks++;
    CHECK(blocks >= 3);
    for (size_t i = last + 100; i < last + 164 && i < n; i++)
        b[i] ^= 0x5a;
    const char *bad = tl_write("bad.smz", b, n);
    free(b);
    epsnet_settings set = base_settings(900, 1);
    int one = one_process(&set, bad, out, NULL);
    CHECK(one == EPSNET_EFORMAT);
    for (int sync = 0; sync <= 1; sync++) {
        int rc[MAX_RANKS];
        shared_run(&set, 3, sync, bad, NULL, NULL, out, rc, err, NULL, NULL);
        /* the error one process gives, met by rank 0, which reads */
        for (int r = 0; r < 3; r++)
            CHECK_EQ_INT(rc[r], one);
        CHECK(!tl_exists(out));
    }
}

TEST(rank_0_failing_alone_stops_every_rank_and_is_named)
{
    char in[512], out[512], missing[512];
    snprintf(in, sizeof in, "%s", tl_path("alone.smz"));
    snprintf(out, sizeof out, "%s", tl_path("alone_out.smz"));
    snprintf(missing, sizeof missing, "%s", tl_path("no_such_input.smz"));
    epsnet_error err[MAX_RANKS];
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 40000, NAN, 3, 0, &err[0]), 0);
    epsnet_settings plain = base_settings(900, 1);
    int one = one_process(&plain, missing, out, NULL);
    CHECK(one < 0);
    for (int sync = 0; sync <= 1; sync++) {
        /* rank 0, the one that reads, cannot open its input; the others
         * have theirs (which they never read) */
        const char *in_of[MAX_RANKS] = { missing, NULL, NULL, NULL };
        int rc[MAX_RANKS];
        epsnet_settings set = base_settings(900, 1 + sync);
        shared_run(&set, 3, sync, in, in_of, NULL, out, rc, err, NULL, NULL);
        for (int r = 0; r < 3; r++) {
            CHECK_EQ_INT(rc[r], one);
            if (r)
                CHECK_STR_CONTAINS(err[r].reason, "rank 0: ");
            CHECK_STR_CONTAINS(epsnet_error_message(&err[r]), "no_such_input");
        }
        CHECK(!tl_exists(out));
    }
}

TEST(a_rank_over_its_budget_stops_every_rank_and_is_named)
{
    char in[512], out[512];
    snprintf(in, sizeof in, "%s", tl_path("budget.smz"));
    snprintf(out, sizeof out, "%s", tl_path("budget_out.smz"));
    epsnet_error err[MAX_RANKS];
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 40000, NAN, 3, 0, &err[0]), 0);
    for (int who = 1; who < 3; who++)
        for (int sync = 0; sync <= 1; sync++) {
            /* rank `who` may hold less than one slab; rank 0 and the other
             * have the machine's default */
            uint64_t mem_of[MAX_RANKS] = { 0, 0, 0, 0 };
            mem_of[who] = 64 << 10;
            int rc[MAX_RANKS];
            epsnet_settings set = base_settings(900, 1 + sync);
            shared_run(&set, 3, sync, in, NULL, mem_of, out, rc, err, NULL, NULL);
            char words[32];
            snprintf(words, sizeof words, "rank %d: ", who);
            for (int r = 0; r < 3; r++) {
                CHECK_EQ_INT(rc[r], EPSNET_ELIMIT);
                if (r != who)
                    CHECK_STR_CONTAINS(err[r].reason, words);
                CHECK_STR_CONTAINS(err[r].reason, "memory budget");
            }
            CHECK(!tl_exists(out));
        }
}

TEST(rank_0_failing_to_open_the_output_stops_the_others_before_their_first_slab)
{
    char in[512], out[512];
    snprintf(in, sizeof in, "%s", tl_path("folder.smz"));
    snprintf(out, sizeof out, "%s", tl_path("no_such_folder/out.smz"));
    epsnet_error err[MAX_RANKS];
    CHECK_EQ_INT(tl_gen_file(in, "bumpy", 40000, NAN, 3, 0, &err[0]), 0);
    int rc[MAX_RANKS];
    uint64_t messages = 0;
    epsnet_settings set = base_settings(900, 1);
    shared_run(&set, 3, 1, in, NULL, NULL, out, rc, err, &messages, NULL);
    check_all_failed(rc, err, 3, out, "no_such_folder");
    CHECK_STR_CONTAINS(err[1].reason, "rank 0: ");
    /* each other rank sent its WANT, answered by the verdict, and its END: no slab */
    CHECK_EQ_U64(messages, 2);
}

TEST(peers_only_for_a_simplified_file_and_with_sane_ranks)
{
    epsnet_peers p = { .rank = 0, .size = 2, .send = hub_send, .recv = hub_recv, .poll = hub_poll };
    epsnet_settings set = base_settings(0, 1);
    set.peers = &p;
    epsnet_context *ctx = NULL;
    epsnet_error err;
    CHECK_EQ_INT(epsnet_context_new(&ctx, &set, &err), 0);
    epsnet_stream *s = NULL;
    CHECK_EQ_INT(epsnet_stream_open(&s, ctx, &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(err.reason, "settings.peers");
    epsnet_stream_close(&s);
    epsnet_context_free(&ctx);
    p.rank = 2;
    CHECK_EQ_INT(epsnet_context_new(&ctx, &set, &err), 0);
    CHECK_EQ_INT(epsnet_simplify_file(ctx, tl_path("any.smz"), tl_path("any_out.smz"), &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(err.reason, "rank 2 of 2");
    p.rank = 1;
    p.poll = NULL; /* rank 0 asks whether a rank wants a slab before it deals one */
    CHECK_EQ_INT(epsnet_simplify_file(ctx, tl_path("any.smz"), tl_path("any_out.smz"), &err), EPSNET_EINVAL);
    CHECK_STR_CONTAINS(err.reason, "poll");
    epsnet_context_free(&ctx);
}

/* EPSNET_PEERS_ONLY: the cases named (comma-separated), for the thread
 * sanitizer's build. */
static int wanted(const char *name)
{
    const char *only = getenv("EPSNET_PEERS_ONLY");
    if (!only)
        return 1;
    size_t n = strlen(name);
    for (const char *p = only; (p = strstr(p, name)) != NULL; p += n)
        if ((p == only || p[-1] == ',') && (p[n] == ',' || p[n] == 0))
            return 1;
    return 0;
}
#define RUN_IF(name)                                                                                                  \
    do {                                                                                                              \
        if (wanted(#name))                                                                                            \
            RUN(name);                                                                                                \
    } while (0)

int main(void)
{
    RUN_IF(the_default_path_gives_one_process_bytes_for_1_to_4_ranks);
    RUN_IF(a_size_gives_one_process_bytes_for_1_to_4_ranks);
    RUN_IF(a_cad_part_with_seams_and_an_ordinary_mesh_give_one_process_bytes);
    RUN_IF(weighed_texture_coordinates_give_one_process_bytes);
    RUN_IF(three_ranks_of_two_workers_give_one_process_bytes);
    RUN_IF(a_damaged_input_fails_every_rank_with_its_message_and_leaves_nothing);
    RUN_IF(rank_0_failing_alone_stops_every_rank_and_is_named);
    RUN_IF(a_rank_over_its_budget_stops_every_rank_and_is_named);
    RUN_IF(rank_0_failing_to_open_the_output_stops_the_others_before_their_first_slab);
    RUN_IF(peers_only_for_a_simplified_file_and_with_sane_ranks);
    tl_cleanup();
    return tl_finish();
}
