/*
 * Every real mesh in ../shared/data reads with the counts and topology its
 * README states (V, F, boundary edges, non-manifold edges, unused vertices).
 * Skips with a message when the folder is absent (a user's clone has none).
 */
#include "testlib.h"

typedef struct expect {
    const char *file;
    uint64_t nv, nt, boundary_edges, nonmanifold_edges, unused;
} expect;

/* From ../shared/data/README.md. */
static const expect meshes[] = {
    { "bun_zipper.ply.zst", 35947, 69451, 223, 0, 1113 },
    { "armadillo_decim100k.obj.zst", 49990, 99976, 0, 0, 0 },
    { "dragon_vrip_res2.ply.zst", 100250, 202520, EPSNET_COUNT_UNKNOWN, 2534, 43 },
    { "fandisk.obj.zst", 6475, 12946, 0, 0, 0 },
    { "rocker-arm.obj.zst", 10044, 20088, 0, 0, 0 },
};

static int cmp_edge(const void *a, const void *b)
{
    const uint64_t *x = a, *y = b;
    if (x[0] != y[0])
        return x[0] < y[0] ? -1 : 1;
    return (x[1] > y[1]) - (x[1] < y[1]);
}

static void edge_stats(const tl_mesh *m, uint64_t *boundary, uint64_t *nonmanifold, uint64_t *unused)
{
    uint64_t *e = malloc(m->nt * 3 * 2 * sizeof *e);
    char *used = calloc(m->nv ? m->nv : 1, 1);
    for (uint64_t t = 0; t < m->nt; t++)
        for (int k = 0; k < 3; k++) {
            uint64_t a = m->tri[3 * t + k], b = m->tri[3 * t + (k + 1) % 3];
            e[6 * t + 2 * k] = a < b ? a : b;
            e[6 * t + 2 * k + 1] = a < b ? b : a;
            used[a] = 1;
        }
    qsort(e, m->nt * 3, 2 * sizeof *e, cmp_edge);
    *boundary = *nonmanifold = *unused = 0;
    for (uint64_t i = 0; i < m->nt * 3;) {
        uint64_t j = i;
        while (j < m->nt * 3 && e[2 * j] == e[2 * i] && e[2 * j + 1] == e[2 * i + 1])
            j++;
        if (j - i == 1)
            (*boundary)++;
        else if (j - i > 2)
            (*nonmanifold)++;
        i = j;
    }
    for (uint64_t v = 0; v < m->nv; v++)
        *unused += !used[v];
    free(e);
    free(used);
}

TEST(shared_meshes_match_their_readme)
{
    const char *dir = tl_shared_data();
    for (size_t i = 0; i < sizeof meshes / sizeof *meshes; i++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, meshes[i].file);
        tl_mesh m;
        epsnet_error err;
        int rc = tl_read_mesh(path, &m, &err);
        CHECK_EQ_INT(rc, 0);
        if (rc) {
            fprintf(stderr, "  %s\n", epsnet_error_message(&err));
            continue;
        }
        CHECK_EQ_U64(m.nv, meshes[i].nv);
        CHECK_EQ_U64(m.nt, meshes[i].nt);
        uint64_t bnd, nm, unused;
        edge_stats(&m, &bnd, &nm, &unused);
        printf("  %-30s V %llu F %llu bnd %llu nm %llu unused %llu\n", meshes[i].file,
               (unsigned long long)m.nv, (unsigned long long)m.nt, (unsigned long long)bnd,
               (unsigned long long)nm, (unsigned long long)unused);
        if (meshes[i].boundary_edges != EPSNET_COUNT_UNKNOWN)
            CHECK_EQ_U64(bnd, meshes[i].boundary_edges);
        CHECK_EQ_U64(nm, meshes[i].nonmanifold_edges);
        CHECK_EQ_U64(unused, meshes[i].unused);
        tl_mesh_free(&m);
    }
}

int main(void)
{
    if (!tl_shared_data()) {
        printf("SKIP: ../shared/data not found (set EPSNET_SHARED_DATA); real-mesh tests skipped\n");
        return TL_SKIP;
    }
    RUN(shared_meshes_match_their_readme);
    return tl_finish();
}
