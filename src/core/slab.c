#include "core/slab.h"

#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "common/error.h"
#include "common/hash64.h"

void en_slab_init(en_slab *s)
{
    memset(s, 0, sizeof *s);
}

void en_slab_free(en_slab *s)
{
    en_free(s->gid);
    en_free(s->pos);
    en_free(s->vflags);
    en_free(s->tri);
    en_free(s->star_start);
    en_free(s->star);
    en_free(s->star_fill);
    en_free(s->wedge);
    en_free(s->by_position);
    en_u64set_free(&s->positions);
    en_slab_init(s);
}

void en_slab_reset(en_slab *s)
{
    s->nv = s->nt = 0;
    s->has_welds = 0;
}

/* Room for `need` vertices (gid, pos, vflags share cap_v). */
static int grow_vertices(en_slab *s, size_t need)
{
    size_t cap = s->cap_v, c;
    c = cap;
    if (en_grow((void **)&s->gid, &c, need, sizeof *s->gid))
        return -1;
    c = cap;
    if (en_grow((void **)&s->pos, &c, need, 3 * sizeof *s->pos))
        return -1;
    c = cap;
    if (en_grow((void **)&s->vflags, &c, need, sizeof *s->vflags))
        return -1;
    if (c > UINT32_MAX - 1)
        c = UINT32_MAX - 1;
    s->cap_v = (uint32_t)c;
    return 0;
}

int64_t en_slab_add_vertex(en_slab *s, uint64_t gid, const double xyz[3], uint8_t flags)
{
    if (s->nv >= UINT32_MAX - 2)
        return -1;
    if (s->nv == s->cap_v && grow_vertices(s, (size_t)s->nv + 1))
        return -1;
    uint32_t v = s->nv++;
    s->gid[v] = gid;
    memcpy(s->pos + 3 * (size_t)v, xyz, 3 * sizeof *xyz);
    s->vflags[v] = flags;
    return v;
}

/* Room for `need` faces. */
static int grow_faces(en_slab *s, size_t need)
{
    size_t cap = s->cap_t;
    if (en_grow((void **)&s->tri, &cap, need, 3 * sizeof *s->tri))
        return -1;
    s->cap_t = (uint32_t)(cap < UINT32_MAX / 3 ? cap : UINT32_MAX / 3);
    return 0;
}

int en_slab_resize(en_slab *s, uint32_t nv, uint32_t nt)
{
    if (nv >= UINT32_MAX - 2 || nt >= UINT32_MAX / 3 - 1 || grow_vertices(s, nv) || grow_faces(s, nt))
        return -1;
    s->nv = nv;
    s->nt = nt;
    return 0;
}

int en_slab_add_face(en_slab *s, uint32_t a, uint32_t b, uint32_t c)
{
    if (s->nt >= UINT32_MAX / 3 - 1)
        return -1;
    if (s->nt == s->cap_t && grow_faces(s, (size_t)s->nt + 1))
        return -1;
    uint32_t *t = s->tri + 3 * (size_t)s->nt++;
    t[0] = a, t[1] = b, t[2] = c;
    return 0;
}

/* Corner of face f at vertex v, or -1 (a face repeating v uses the first). */
static int corner_of(const uint32_t *t, uint32_t v)
{
    return t[0] == v ? 0 : t[1] == v ? 1 : t[2] == v ? 2 : -1;
}

/* Scratch for ordering one star, sized once for the largest degree:
 * corner after v, corner before v, and both packed as (corner << 32 | i)
 * and sorted, to find a face by its corner in O(log deg). */
typedef struct star_scratch {
    uint32_t *nxt, *prv, *ordered;
    uint64_t *by_nxt, *by_prv;
} star_scratch;

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static void sort_packed(uint64_t *packed, const uint32_t *key, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++)
        packed[i] = (uint64_t)key[i] << 32 | i;
    qsort(packed, n, sizeof *packed, cmp_u64);
}

/* Index i whose key is want, from the sorted packed keys, or UINT32_MAX. */
static uint32_t find_key(const uint64_t *packed, uint32_t n, uint32_t want)
{
    uint32_t lo = 0, hi = n;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if ((uint32_t)(packed[mid] >> 32) < want)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < n && (uint32_t)(packed[lo] >> 32) == want ? (uint32_t)packed[lo] : UINT32_MAX;
}

/* Index i with key[i] == want: binary search when the star was sorted, a
 * scan otherwise. UINT32_MAX when absent. */
static uint32_t find_corner(int sorted, const uint32_t *key, const uint64_t *packed, uint32_t n, uint32_t want)
{
    if (sorted)
        return find_key(packed, n, want);
    for (uint32_t i = 0; i < n; i++)
        if (key[i] == want)
            return i;
    return UINT32_MAX;
}

/*
 * Order the faces around v counter-clockwise. Face (v, b, c) spans the angle
 * from edge v-b to edge v-c, so its counter-clockwise successor shares edge
 * v-c (its corner after v is c) and its predecessor shares edge v-b. One
 * closed cycle = interior manifold vertex; one open chain = boundary vertex;
 * anything else (two fans, an edge used twice in the same direction, a
 * repeated corner) = non-manifold. O(deg log deg).
 */
static uint8_t order_star(const en_slab *s, uint32_t v, uint32_t *faces, uint32_t deg, star_scratch *w)
{
    if (deg == 0)
        return EN_V_ISOLATED;
    uint32_t *nxt = w->nxt, *prv = w->prv;
    for (uint32_t i = 0; i < deg; i++) {
        const uint32_t *t = s->tri + 3 * (size_t)faces[i];
        int k = corner_of(t, v);
        nxt[i] = t[(k + 1) % 3];
        prv[i] = t[(k + 2) % 3];
        if (nxt[i] == v || prv[i] == v)
            return EN_V_NONMANIFOLD;
    }
    /* note: stars are small (degree 6 on average), and for those a linear
     * scan beats sorting; only large fans are sorted for O(log deg) lookups. */
    int sorted = deg > 16;
    if (sorted) {
        sort_packed(w->by_nxt, nxt, deg);
        sort_packed(w->by_prv, prv, deg);
    }
    /* An edge (v, x) may be used at most once as "next" and once as "prev";
     * then face i's successor, the face whose corner after v is i's corner
     * before v, is one face or none. */
    uint32_t start = 0, open = 0, succ[16];
    if (sorted) {
        for (uint32_t i = 1; i < deg; i++)
            if ((w->by_nxt[i] >> 32) == (w->by_nxt[i - 1] >> 32) ||
                (w->by_prv[i] >> 32) == (w->by_prv[i - 1] >> 32))
                return EN_V_NONMANIFOLD;
        for (uint32_t i = 0; i < deg; i++)
            if (find_corner(sorted, prv, w->by_prv, deg, nxt[i]) == UINT32_MAX) {
                open++;
                start = i;
            }
    } else {
        /* note: each pair once, for both checks and both successors, with
         * no branch on the data: a scan for each face's successor and for
         * its predecessor had been three passes over the pairs
         * (bench/RESULTS.md, session 22) */
        uint32_t dup = 0, has_pred = 0;
        for (uint32_t i = 0; i < deg; i++)
            succ[i] = nxt[i] == prv[i] ? i : UINT32_MAX;
        for (uint32_t i = 0; i < deg; i++)
            for (uint32_t j = i + 1; j < deg; j++) {
                dup |= (uint32_t)(nxt[i] == nxt[j]) | (uint32_t)(prv[i] == prv[j]);
                succ[i] = nxt[j] == prv[i] ? j : succ[i];
                succ[j] = nxt[i] == prv[j] ? i : succ[j];
            }
        if (dup)
            return EN_V_NONMANIFOLD;
        for (uint32_t i = 0; i < deg; i++)
            if (succ[i] != UINT32_MAX)
                has_pred |= 1u << succ[i];
        for (uint32_t i = 0; i < deg; i++)
            if (!(has_pred >> i & 1)) {
                open++;
                start = i;
            }
    }
    if (open > 1)
        return EN_V_NONMANIFOLD | EN_V_BOUNDARY;
    uint32_t cur = start;
    for (uint32_t n = 0; n < deg; n++) {
        w->ordered[n] = faces[cur];
        uint32_t j = sorted ? find_corner(sorted, nxt, w->by_nxt, deg, prv[cur]) : succ[cur];
        if (j == UINT32_MAX) {
            if (n + 1 != deg)
                return EN_V_NONMANIFOLD | (open ? EN_V_BOUNDARY : 0);
            break;
        }
        if (j == start && n + 1 != deg)
            return EN_V_NONMANIFOLD; /* closed early: more than one fan */
        cur = j;
    }
    memcpy(faces, w->ordered, deg * sizeof *faces);
    return open ? EN_V_BOUNDARY : 0;
}

/* The ends of a boundary vertex's open edges, from its ordered star: out,
 * the corner after v in its first face (the open edge v -> out), and in,
 * the corner before v in its last (in -> v). */
static void open_ends(const en_slab *s, uint32_t v, uint32_t *out, uint32_t *in)
{
    const uint32_t *first = s->tri + 3 * (size_t)s->star[s->star_start[v]];
    const uint32_t *last = s->tri + 3 * (size_t)s->star[s->star_start[v + 1] - 1];
    *out = first[(corner_of(first, v) + 1) % 3];
    *in = last[(corner_of(last, v) + 2) % 3];
}

static int same_position(const en_slab *s, uint32_t a, uint32_t b)
{
    return memcmp(s->pos + 3 * (size_t)a, s->pos + 3 * (size_t)b, 3 * sizeof *s->pos) == 0;
}

/* A vertex to sort by its coordinates' bits: they travel with it, since
 * C11's qsort passes the comparison no context. */
typedef struct en_by_position {
    const double *xyz;
    uint32_t v;
} by_position;

static int cmp_position(const void *a, const void *b)
{
    const by_position *x = a, *y = b;
    int c = memcmp(x->xyz, y->xyz, 3 * sizeof *x->xyz);
    return c ? c : (x->v > y->v) - (x->v < y->v);
}

/* May two of b's n vertices share a position's bits? 1 (perhaps: two
 * positions whose hashes meet answer yes too, and the exact search after
 * finds nothing), 0 (certainly not), or -1 (out of memory).
 * note: most slabs and seam meshes have none, and sorting every boundary
 * vertex by position to find out (a comparison through qsort and memcmp
 * each) was 4% of a target's rounds, whose seam meshes are mostly
 * boundary, and 1.6% of the whole run (bench/RESULTS.md, session 30): a
 * set of the positions' hashes answers in one pass, and only a yes sorts.
 * The set is the slab's, kept from job to job: one allocated per call was
 * fresh pages each time, which the kernel mapped to its zero page on the
 * first probe and copied on the first insert, each copy flushing every
 * core's TLB (2.5% of a size's samples, in the stitcher's takes; and a
 * table of whole keys, 32 bytes a slot, took the peak at 100M faces up
 * 9 MB; bench/RESULTS.md, session 31). */
static int any_shared_position(en_u64set **set, const by_position *b, uint32_t n)
{
    if (!*set && !(*set = en_u64set_new()))
        return -1;
    if (en_u64set_clear(*set, n))
        return -1;
    for (uint32_t i = 0; i < n; i++) {
        int added = en_u64set_add(*set, en_position_key(b[i].xyz));
        if (added <= 0)
            return added < 0 ? -1 : 1;
    }
    return 0;
}

/* May boundary vertices a and b, alone at their position, be the two sides
 * of one seam? One open fan each, and their open edges lead to the same
 * positions the other way round (the sides of an orientable surface cut
 * along the seam). */
static int seam_pair(const en_slab *s, uint32_t a, uint32_t b)
{
    uint8_t fa = s->vflags[a], fb = s->vflags[b];
    if ((fa | fb) & EN_V_NONMANIFOLD)
        return 0;
    uint32_t oa, ia, ob, ib;
    open_ends(s, a, &oa, &ia);
    open_ends(s, b, &ob, &ib);
    if (oa == b || ia == b || ob == a || ib == a || oa == ia || ob == ib)
        return 0;
    return same_position(s, oa, ib) && same_position(s, ia, ob);
}

/* The seams (see en_slab_build_stars): boundary vertices grouped by their
 * coordinates' bits into wedge[] cycles, and the pairs. */
static int find_seams(en_slab *s, uint32_t nboundary)
{
    s->has_welds = 0;
    if (nboundary < 2)
        return 0;
    if (en_grow((void **)&s->by_position, &s->cap_by_position, nboundary, sizeof *s->by_position))
        return -1;
    by_position *b = s->by_position;
    uint32_t n = 0;
    for (uint32_t v = 0; v < s->nv; v++)
        if ((s->vflags[v] & (EN_V_BOUNDARY | EN_V_OWNED)) == (EN_V_BOUNDARY | EN_V_OWNED))
            b[n++] = (by_position){ s->pos + 3 * (size_t)v, v };
    int shared = any_shared_position(&s->positions, b, n);
    if (shared <= 0)
        return shared; /* none (0), or out of memory (-1) */
    qsort(b, n, sizeof *b, cmp_position);
    if (en_grow((void **)&s->wedge, &s->cap_wedge, (size_t)s->nv + 1, sizeof *s->wedge))
        return -1;
    for (uint32_t v = 0; v < s->nv; v++)
        s->wedge[v] = v;
    for (uint32_t i = 0, j; i < n; i = j) {
        for (j = i + 1; j < n && memcmp(b[j].xyz, b[i].xyz, 3 * sizeof *b[i].xyz) == 0; j++)
            s->wedge[b[j - 1].v] = b[j].v;
        s->wedge[b[j - 1].v] = b[i].v;
        if (j - i == 2 && seam_pair(s, b[i].v, b[i + 1].v)) {
            uint32_t x = b[i].v, y = b[i + 1].v;
            s->vflags[x] = (uint8_t)((s->vflags[x] & ~EN_V_BOUNDARY) | EN_V_SEAM);
            s->vflags[y] = (uint8_t)((s->vflags[y] & ~EN_V_BOUNDARY) | EN_V_SEAM);
        }
    }
    s->has_welds = 1;
    return 0;
}

int en_slab_build_stars(en_slab *s)
{
    /* note: the arrays keep their capacity, so a slab reused for the next
     * job (docs/architecture.md §8) allocates nothing here. */
    if (en_grow((void **)&s->star_start, &s->cap_star_start, (size_t)s->nv + 1, sizeof *s->star_start) ||
        en_grow((void **)&s->star, &s->cap_star, (size_t)s->nt * 3 + 1, sizeof *s->star) ||
        en_grow((void **)&s->star_fill, &s->cap_star_fill, (size_t)s->nv + 1, sizeof *s->star_fill))
        return -1;
    memset(s->star_start, 0, ((size_t)s->nv + 1) * sizeof *s->star_start);
    for (uint32_t f = 0; f < s->nt; f++) {
        const uint32_t *t = s->tri + 3 * (size_t)f;
        for (int k = 0; k < 3; k++)
            if (corner_of(t, t[k]) == k) /* count a repeated corner once */
                s->star_start[t[k] + 1]++;
    }
    for (uint32_t v = 0; v < s->nv; v++)
        s->star_start[v + 1] += s->star_start[v];
    uint32_t *fill = s->star_fill;
    memcpy(fill, s->star_start, (size_t)s->nv * sizeof *fill);
    for (uint32_t f = 0; f < s->nt; f++) {
        const uint32_t *t = s->tri + 3 * (size_t)f;
        for (int k = 0; k < 3; k++)
            if (corner_of(t, t[k]) == k)
                s->star[fill[t[k]]++] = f;
    }
    uint32_t maxdeg = 1;
    for (uint32_t v = 0; v < s->nv; v++)
        if (en_slab_degree(s, v) > maxdeg)
            maxdeg = en_slab_degree(s, v);
    star_scratch w = { 0 };
    w.by_nxt = en_malloc(2 * (size_t)maxdeg * sizeof *w.by_nxt);
    w.nxt = en_malloc(3 * (size_t)maxdeg * sizeof *w.nxt);
    if (!w.by_nxt || !w.nxt) {
        en_free(w.by_nxt);
        en_free(w.nxt);
        return -1;
    }
    w.by_prv = w.by_nxt + maxdeg;
    w.prv = w.nxt + maxdeg;
    w.ordered = w.prv + maxdeg;
    uint32_t nboundary = 0;
    for (uint32_t v = 0; v < s->nv; v++) {
        uint8_t kind = order_star(s, v, s->star + s->star_start[v], en_slab_degree(s, v), &w);
        uint8_t kept = (uint8_t)(s->vflags[v] & ~(EN_V_BOUNDARY | EN_V_NONMANIFOLD | EN_V_ISOLATED | EN_V_SEAM));
        s->vflags[v] = (uint8_t)(kept | kind);
        /* note: owned ones only. A ghost's star is cut short where the
         * slab ends, so ghosts look like boundaries by the thousand; and no
         * collapse reads a ghost's copies (a collapse's v and u are owned
         * with every neighbour owned, architecture.md §8) */
        if (kind & EN_V_BOUNDARY)
            nboundary += (s->vflags[v] & EN_V_OWNED) != 0;
    }
    en_free(w.nxt);
    en_free(w.by_nxt);
    return find_seams(s, nboundary);
}

int en_slab_read(en_slab *s, epsnet_reader *r, const char *path, epsnet_error *err)
{
    epsnet_record rec;
    int rc;
    while ((rc = epsnet_reader_next(r, &rec, err)) > 0) {
        if (rec.kind == EPSNET_REC_VERTEX) {
            if (en_slab_add_vertex(s, s->nv, rec.xyz, EN_V_OWNED | EN_V_TARGET) < 0)
                return s->nv >= UINT32_MAX - 2
                           ? en_error_set(err, EPSNET_ELIMIT, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                          "more than %u vertices in one slab", s->nv)
                           : en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                          "out of memory holding the mesh (%u vertices)", s->nv);
        } else if (rec.kind == EPSNET_REC_TRIANGLE) {
            /* note: the reader checked every corner against the vertices read
             * so far, which fit in 32 bits. */
            if (en_slab_add_face(s, (uint32_t)rec.v[0], (uint32_t)rec.v[1], (uint32_t)rec.v[2]))
                return s->nt >= UINT32_MAX / 3 - 1
                           ? en_error_set(err, EPSNET_ELIMIT, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                          "more than %u faces in one slab", s->nt)
                           : en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                                          "out of memory holding the mesh (%u faces)", s->nt);
        }
    }
    return rc < 0 ? rc : 0;
}

int en_slab_read_all(en_slab *s, epsnet_reader *r, const char *path, epsnet_error *err)
{
    int rc = en_slab_read(s, r, path, err);
    if (rc == 0 && en_slab_build_stars(s))
        rc = en_error_set(err, EPSNET_ENOMEM, path, EPSNET_POS_NONE, EPSNET_POS_NONE,
                          "out of memory building vertex stars");
    return rc;
}

/* Corner order a file happens to use must not change a normal's rounding,
 * or the same mesh shuffled would give other samples (docs/method.md §11). */
static int less_xyz(const double *a, const double *b)
{
    if (a[0] != b[0])
        return a[0] < b[0];
    if (a[1] != b[1])
        return a[1] < b[1];
    return a[2] < b[2];
}

void en_triangle_normal(const double *pos, const uint32_t t[3], double n[3])
{
    const double *p[3] = { pos + 3 * (size_t)t[0], pos + 3 * (size_t)t[1], pos + 3 * (size_t)t[2] };
    int k = 0;
    if (less_xyz(p[1], p[k]))
        k = 1;
    if (less_xyz(p[2], p[k]))
        k = 2;
    const double *a = p[k], *b = p[(k + 1) % 3], *c = p[(k + 2) % 3];
    double u[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] };
    double w[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
    n[0] = u[1] * w[2] - u[2] * w[1];
    n[1] = u[2] * w[0] - u[0] * w[2];
    n[2] = u[0] * w[1] - u[1] * w[0];
}
