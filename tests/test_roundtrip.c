/*
 * Exact round trips for every pair of formats: a mesh written in format A,
 * read, written in format B and read again keeps its counts, its coordinates
 * bit for bit and its triangles (docs/architecture.md §13; docs/method.md §11: output vertices are
 * input vertices with bit-identical coordinates).
 *
 * The test mesh is a closed torus grid with irregular float coordinates, so
 * no format can pass by luck of round numbers:
 *
 *      j+1  o----o
 *           | \  |     each grid quad -> two triangles
 *      j    o----o
 *           i    i+1
 */
#include "testlib.h"

#define NU 13
#define NV 7

static void make_torus(tl_mesh *m, int float64)
{
    memset(m, 0, sizeof *m);
    m->nv = NU * NV;
    m->nt = 2 * NU * NV;
    m->xyz = malloc(m->nv * 3 * sizeof *m->xyz);
    m->tri = malloc(m->nt * 3 * sizeof *m->tri);
    for (int i = 0; i < NU; i++)
        for (int j = 0; j < NV; j++) {
            double u = 2 * M_PI * i / NU, v = 2 * M_PI * j / NV;
            double r = 1.0 + 0.3 * cos(v) + 1e-3 * sin(7.1 * u + j);
            double p[3] = { r * cos(u) * 1234.5678, r * sin(u) * 0.000123, 0.3 * sin(v) - 17.25 };
            for (int k = 0; k < 3; k++)
                m->xyz[3 * (i * NV + j) + k] = float64 ? p[k] * (1 + 1e-12) : (double)(float)p[k];
        }
    uint64_t t = 0;
    for (int i = 0; i < NU; i++)
        for (int j = 0; j < NV; j++) {
            uint64_t a = (uint64_t)(i * NV + j), b = (uint64_t)(((i + 1) % NU) * NV + j);
            uint64_t c = (uint64_t)(((i + 1) % NU) * NV + (j + 1) % NV), d = (uint64_t)(i * NV + (j + 1) % NV);
            uint64_t *q = m->tri + 3 * t;
            q[0] = a, q[1] = b, q[2] = c, q[3] = a, q[4] = c, q[5] = d;
            t += 2;
        }
    m->info.coord_type = float64 ? EPSNET_COORD_FLOAT64 : EPSNET_COORD_FLOAT32;
    m->info.sorted_axis = -1;
}

static int same_mesh(const tl_mesh *a, const tl_mesh *b)
{
    return a->nv == b->nv && a->nt == b->nt &&
           memcmp(a->xyz, b->xyz, a->nv * 3 * sizeof *a->xyz) == 0 &&
           memcmp(a->tri, b->tri, a->nt * 3 * sizeof *a->tri) == 0;
}

typedef struct fmt_case {
    const char *ext;
    int ascii;
    int float64_ok; /* keeps double coordinates */
} fmt_case;

static const fmt_case formats[] = {
    { "ply", 0, 1 }, { "ply", 1, 1 }, { "obj", 0, 1 }, { "sma", 0, 1 },
    { "smb", 0, 0 }, { "ply.zst", 0, 1 }, { "obj.zst", 0, 1 }, { "smb.zst", 0, 0 },
};
#define NFMT (sizeof formats / sizeof *formats)

static int write_as(const tl_mesh *m, const fmt_case *f, const char *name, epsnet_error *err)
{
    epsnet_writer_settings ws;
    epsnet_writer_default_settings(&ws);
    ws.ascii = f->ascii;
    return tl_write_mesh(tl_path(name), m, &ws, err);
}

static void pairs(int float64)
{
    tl_mesh orig;
    make_torus(&orig, float64);
    for (size_t a = 0; a < NFMT; a++) {
        if (float64 && !formats[a].float64_ok)
            continue;
        char name_a[64];
        snprintf(name_a, sizeof name_a, "a%zu_%d.%s", a, float64, formats[a].ext);
        epsnet_error err;
        int rc = write_as(&orig, &formats[a], name_a, &err);
        CHECK_EQ_INT(rc, 0);
        if (rc) {
            fprintf(stderr, "  write %s: %s\n", name_a, epsnet_error_message(&err));
            continue;
        }
        tl_mesh ma;
        rc = tl_read_mesh(tl_path(name_a), &ma, &err);
        CHECK_EQ_INT(rc, 0);
        if (rc)
            fprintf(stderr, "  read %s: %s\n", name_a, epsnet_error_message(&err));
        CHECK(same_mesh(&orig, &ma));
        for (size_t b = 0; b < NFMT; b++) {
            if (float64 && !formats[b].float64_ok)
                continue;
            char name_b[64];
            snprintf(name_b, sizeof name_b, "b%zu_%zu_%d.%s", a, b, float64, formats[b].ext);
            ma.info.coord_type = orig.info.coord_type;
            rc = write_as(&ma, &formats[b], name_b, &err);
            CHECK_EQ_INT(rc, 0);
            tl_mesh mb;
            rc = tl_read_mesh(tl_path(name_b), &mb, &err);
            CHECK_EQ_INT(rc, 0);
            if (!same_mesh(&orig, &mb)) {
                CHECK(!"mesh changed");
                fprintf(stderr, "  %s -> %s changed the mesh\n", name_a, name_b);
            }
            tl_mesh_free(&mb);
            remove(tl_path(name_b));
        }
        tl_mesh_free(&ma);
    }
    tl_mesh_free(&orig);
}

TEST(every_format_pair_round_trips_float32_exactly)
{
    pairs(0);
}

TEST(double_capable_formats_round_trip_float64_exactly)
{
    pairs(1);
}

/* STL has no indices: a binary STL written from the mesh must weld back to
 * the same vertices (in first-use order) and the same triangles. */
TEST(stl_welds_back_to_the_indexed_mesh)
{
    tl_mesh orig;
    make_torus(&orig, 0);
    size_t n = 84 + 50 * orig.nt;
    unsigned char *buf = calloc(1, n);
    memcpy(buf, "binary stl written by test_roundtrip", 36);
    uint32_t nt = (uint32_t)orig.nt;
    memcpy(buf + 80, &nt, 4);
    for (uint64_t t = 0; t < orig.nt; t++) {
        unsigned char *rec = buf + 84 + 50 * t + 12;
        for (int k = 0; k < 3; k++)
            for (int c = 0; c < 3; c++) {
                float f = (float)orig.xyz[3 * orig.tri[3 * t + k] + c];
                memcpy(rec + 12 * k + 4 * c, &f, 4);
            }
    }
    const char *p = tl_write("torus.stl", buf, n);
    free(buf);
    tl_mesh got;
    epsnet_error err;
    CHECK_EQ_INT(tl_read_mesh(p, &got, &err), 0);
    CHECK_EQ_U64(got.nv, orig.nv);
    CHECK_EQ_U64(got.nt, orig.nt);
    int ok = got.nt == orig.nt;
    for (uint64_t t = 0; ok && t < orig.nt; t++)
        for (int k = 0; k < 3; k++)
            ok &= memcmp(got.xyz + 3 * got.tri[3 * t + k], orig.xyz + 3 * orig.tri[3 * t + k],
                         3 * sizeof(double)) == 0;
    CHECK(ok);
    tl_mesh_free(&got);
    tl_mesh_free(&orig);
}

int main(void)
{
    RUN(every_format_pair_round_trips_float32_exactly);
    RUN(double_capable_formats_round_trip_float64_exactly);
    RUN(stl_welds_back_to_the_indexed_mesh);
    tl_cleanup();
    return tl_finish();
}
