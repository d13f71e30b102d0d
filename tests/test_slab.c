/*
 * The per-slab mesh: rotational star order and the vertex kinds that lock a
 * vertex (boundary, non-manifold, isolated), on meshes drawn below.
 */
#include "core/slab.h"
#include "testlib.h"

static void add_vertices(en_slab *s, int n)
{
    for (int i = 0; i < n; i++) {
        double p[3] = { i, i * i, 0 };
        en_slab_add_vertex(s, (uint64_t)i + 100, p, EN_V_OWNED);
    }
}

/* Position of face f in the star of v, or -1. */
static int star_pos(const en_slab *s, uint32_t v, uint32_t f)
{
    for (uint32_t i = 0; i < en_slab_degree(s, v); i++)
        if (s->star[s->star_start[v] + i] == f)
            return (int)i;
    return -1;
}

/*
 *        2
 *      / | \          hexagon fan around 0, faces f0..f5 counter-clockwise:
 *    3 - 0 - 1        f_i = (0, i+1, i+2), wrapping 6 -> 1
 *      \ | /
 *   ...(4,5,6 around)
 */
TEST(interior_vertex_star_is_counter_clockwise_cycle)
{
    en_slab s;
    en_slab_init(&s);
    add_vertices(&s, 7);
    /* add faces in a scrambled order so the ordering has to do the work */
    int order[6] = { 3, 0, 5, 1, 4, 2 };
    for (int k = 0; k < 6; k++) {
        int i = order[k];
        en_slab_add_face(&s, 0, (uint32_t)(1 + i), (uint32_t)(1 + (i + 1) % 6));
    }
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    CHECK_EQ_U64(en_slab_degree(&s, 0), 6);
    CHECK_EQ_INT(s.vflags[0] & (EN_V_BOUNDARY | EN_V_NONMANIFOLD), 0);
    /* successive faces must be (0,i+1,i+2) then (0,i+2,i+3) */
    int ok = 1;
    for (uint32_t k = 0; k < 6; k++) {
        const uint32_t *a = s.tri + 3 * s.star[s.star_start[0] + k];
        const uint32_t *b = s.tri + 3 * s.star[s.star_start[0] + (k + 1) % 6];
        ok &= a[2] == b[1];
    }
    CHECK(ok);
    /* the rim vertices have 2 faces and are on the boundary */
    for (uint32_t v = 1; v <= 6; v++) {
        CHECK_EQ_U64(en_slab_degree(&s, v), 2);
        CHECK(s.vflags[v] & EN_V_BOUNDARY);
        CHECK(!(s.vflags[v] & EN_V_NONMANIFOLD));
    }
    CHECK_EQ_U64(s.gid[3], 103);
    en_slab_free(&s);
}

/*
 *   1---2
 *   | / |      open fan at 0 going f0=(0,1,2)? no: f0=(0,3,2), f1=(0,2,1)...
 *   0---3
 * Vertex 0 has faces (0,3,2) and (0,2,1): a boundary vertex whose star must
 * start at the face whose edge (0, next) is on the boundary: (0,3,2).
 */
TEST(boundary_vertex_star_starts_at_the_boundary_edge)
{
    en_slab s;
    en_slab_init(&s);
    add_vertices(&s, 4);
    en_slab_add_face(&s, 0, 2, 1);
    en_slab_add_face(&s, 0, 3, 2);
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    CHECK(s.vflags[0] & EN_V_BOUNDARY);
    CHECK_EQ_INT(star_pos(&s, 0, 1), 0);
    CHECK_EQ_INT(star_pos(&s, 0, 0), 1);
    en_slab_free(&s);
}

/*
 *  1       3
 *  | \   / |     bowtie: two triangles meet only at vertex 0
 *  |  0    |     -> 0 is non-manifold; 1..4 are ordinary boundary vertices
 *  | /   \ |
 *  2       4
 */
TEST(bowtie_vertex_is_nonmanifold)
{
    en_slab s;
    en_slab_init(&s);
    add_vertices(&s, 5);
    en_slab_add_face(&s, 0, 1, 2);
    en_slab_add_face(&s, 0, 4, 3);
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    CHECK(s.vflags[0] & EN_V_NONMANIFOLD);
    for (uint32_t v = 1; v <= 4; v++)
        CHECK(!(s.vflags[v] & EN_V_NONMANIFOLD));
    en_slab_free(&s);
}

/* Three faces on the edge 0-1 (a fin): both ends are non-manifold. */
TEST(edge_with_three_faces_makes_its_ends_nonmanifold)
{
    en_slab s;
    en_slab_init(&s);
    add_vertices(&s, 5);
    en_slab_add_face(&s, 0, 1, 2);
    en_slab_add_face(&s, 1, 0, 3);
    en_slab_add_face(&s, 1, 0, 4);
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    CHECK(s.vflags[0] & EN_V_NONMANIFOLD);
    CHECK(s.vflags[1] & EN_V_NONMANIFOLD);
    CHECK(!(s.vflags[2] & EN_V_NONMANIFOLD));
    en_slab_free(&s);
}

/* Two pillows on the edge 0-1 (four faces, two each way): every face of
 * 0 and of 1 has a neighbour across each edge, and their faces even link
 * up into one cycle, but the edge is used twice in each direction. */
TEST(an_edge_used_twice_each_way_makes_its_ends_nonmanifold)
{
    en_slab s;
    en_slab_init(&s);
    add_vertices(&s, 4);
    en_slab_add_face(&s, 0, 1, 2);
    en_slab_add_face(&s, 0, 2, 1);
    en_slab_add_face(&s, 0, 1, 3);
    en_slab_add_face(&s, 0, 3, 1);
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    CHECK(s.vflags[0] & EN_V_NONMANIFOLD);
    CHECK(s.vflags[1] & EN_V_NONMANIFOLD);
    CHECK_EQ_INT(s.vflags[2] & (EN_V_BOUNDARY | EN_V_NONMANIFOLD), 0);
    CHECK_EQ_INT(s.vflags[3] & (EN_V_BOUNDARY | EN_V_NONMANIFOLD), 0);
    en_slab_free(&s);
}

/* A closed tetrahedron: every vertex interior, degree 3; an unused vertex
 * is isolated. */
TEST(tetrahedron_is_closed_and_unused_vertex_isolated)
{
    en_slab s;
    en_slab_init(&s);
    add_vertices(&s, 5);
    en_slab_add_face(&s, 0, 2, 1);
    en_slab_add_face(&s, 0, 1, 3);
    en_slab_add_face(&s, 1, 2, 3);
    en_slab_add_face(&s, 2, 0, 3);
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    for (uint32_t v = 0; v < 4; v++) {
        CHECK_EQ_U64(en_slab_degree(&s, v), 3);
        CHECK_EQ_INT(s.vflags[v] & (EN_V_BOUNDARY | EN_V_NONMANIFOLD | EN_V_ISOLATED), 0);
    }
    CHECK(s.vflags[4] & EN_V_ISOLATED);
    en_slab_free(&s);
}

/* A face that repeats a corner (0,0,1) is legal input; it must not crash
 * and marks the vertex it folds on as non-manifold (locked, safe). */
TEST(face_repeating_a_corner_is_handled)
{
    en_slab s;
    en_slab_init(&s);
    add_vertices(&s, 3);
    en_slab_add_face(&s, 0, 0, 1);
    en_slab_add_face(&s, 0, 1, 2);
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    CHECK(s.vflags[0] & EN_V_NONMANIFOLD);
    CHECK_EQ_U64(en_slab_degree(&s, 0), 2);
    en_slab_free(&s);
}

/*
 * A 5 x 3 grid of points cut open along column 2 (a UV seam): the left
 * half's faces use records 0..8 (columns 0-2), the right half's its own
 * copies of column 2 and columns 3-4 (9..17).
 *
 *   row 2   6 - 7 - 8 | 15 - 16 - 17
 *   row 1   3 - 4 - 5 | 12 - 13 - 14
 *   row 0   0 - 1 - 2 |  9 - 10 - 11
 *
 * The middle copies (5, 12) are the two sides of one surface: a seam pair.
 * The copies at rows 0 and 2 also run along the outer boundary: a cut's
 * end, which stays a boundary. A third copy makes a position a boundary
 * too, and so does a side whose open edges lead the same way.
 */
static uint32_t cut_grid(en_slab *s, int third_copy, int flip_right)
{
    en_slab_init(s);
    uint32_t left[3][3], right[3][3];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            double p[3] = { c, r, 0.1 * ((c * 7 + r * 3) % 4) };
            left[r][c] = (uint32_t)en_slab_add_vertex(s, s->nv, p, EN_V_OWNED);
        }
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            double p[3] = { c + 2, r, 0.1 * (((c + 2) * 7 + r * 3) % 4) };
            right[r][c] = (uint32_t)en_slab_add_vertex(s, s->nv, p, EN_V_OWNED);
        }
    for (int r = 0; r < 2; r++)
        for (int c = 0; c < 2; c++) {
            uint32_t a = left[r][c], b = left[r][c + 1], d = left[r + 1][c], e = left[r + 1][c + 1];
            en_slab_add_face(s, a, b, e);
            en_slab_add_face(s, a, e, d);
            a = right[r][c], b = right[r][c + 1], d = right[r + 1][c], e = right[r + 1][c + 1];
            if (flip_right) {
                en_slab_add_face(s, a, e, b);
                en_slab_add_face(s, a, d, e);
            } else {
                en_slab_add_face(s, a, b, e);
                en_slab_add_face(s, a, e, d);
            }
        }
    if (third_copy) {
        /* a flap hanging off the seam's middle position: a third record there */
        double p[3] = { 2, 1, 0.1 * ((2 * 7 + 3) % 4) }, q[3] = { 2, 1, 5 }, u[3] = { 2, 2, 5 };
        uint32_t x = (uint32_t)en_slab_add_vertex(s, s->nv, p, EN_V_OWNED);
        uint32_t y = (uint32_t)en_slab_add_vertex(s, s->nv, q, EN_V_OWNED);
        uint32_t z = (uint32_t)en_slab_add_vertex(s, s->nv, u, EN_V_OWNED);
        en_slab_add_face(s, x, y, z);
    }
    return left[1][2];
}

TEST(seam_copies_pair_and_a_cut_end_stays_a_boundary)
{
    en_slab s;
    uint32_t mid = cut_grid(&s, 0, 0);
    uint32_t twin = mid + 9 - 2; /* right[1][0] */
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    CHECK(s.has_welds);
    CHECK(s.vflags[mid] & EN_V_SEAM);
    CHECK(s.vflags[twin] & EN_V_SEAM);
    CHECK(!(s.vflags[mid] & EN_V_BOUNDARY) && !(s.vflags[twin] & EN_V_BOUNDARY));
    CHECK_EQ_U64(s.wedge[mid], twin);
    CHECK_EQ_U64(s.wedge[twin], mid);
    /* the cut's ends, on the outer boundary: copies of one position, not a pair */
    uint32_t end_left = 2, end_right = 9;
    CHECK(s.vflags[end_left] & EN_V_BOUNDARY);
    CHECK(!(s.vflags[end_left] & EN_V_SEAM));
    CHECK_EQ_U64(s.wedge[end_left], end_right);
    CHECK_EQ_U64(s.wedge[end_right], end_left);
    /* a vertex of no seam is its own wedge */
    CHECK_EQ_U64(s.wedge[4], 4);
    en_slab_free(&s);

    /* a third copy: the position is a cut's end (three sides meet) */
    mid = cut_grid(&s, 1, 0);
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    CHECK(s.vflags[mid] & EN_V_BOUNDARY);
    CHECK(!(s.vflags[mid] & EN_V_SEAM));
    uint32_t n = 1;
    for (uint32_t c = s.wedge[mid]; c != mid; c = s.wedge[c])
        n++;
    CHECK_EQ_U64(n, 3);
    en_slab_free(&s);

    /* the right side turned over: its open edges run the same way as the
     * left's, so the two do not make one oriented surface */
    mid = cut_grid(&s, 0, 1);
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    CHECK(s.vflags[mid] & EN_V_BOUNDARY);
    CHECK(!(s.vflags[mid] & EN_V_SEAM));
    en_slab_free(&s);

    /* no copies at all: no wedges */
    mid = cut_grid(&s, 0, 0);
    s.pos[3 * (mid + 7) + 2] += 1; /* the right copy of the middle moves away */
    s.pos[3 * 9 + 2] += 1;
    s.pos[3 * 15 + 2] += 1;
    CHECK_EQ_INT(en_slab_build_stars(&s), 0);
    CHECK(s.vflags[mid] & EN_V_BOUNDARY);
    en_slab_free(&s);
}

int main(void)
{
    RUN(interior_vertex_star_is_counter_clockwise_cycle);
    RUN(boundary_vertex_star_starts_at_the_boundary_edge);
    RUN(bowtie_vertex_is_nonmanifold);
    RUN(edge_with_three_faces_makes_its_ends_nonmanifold);
    RUN(an_edge_used_twice_each_way_makes_its_ends_nonmanifold);
    RUN(tetrahedron_is_closed_and_unused_vertex_isolated);
    RUN(face_repeating_a_corner_is_handled);
    RUN(seam_copies_pair_and_a_cut_end_stays_a_boundary);
    return tl_finish();
}
