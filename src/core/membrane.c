#include "core/membrane.h"

#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"

enum { SEEN = 1, MEMBRANE = 2 }; /* drop[] while searching */

static int has_corner(const uint32_t *t, uint32_t v)
{
    return t[0] == v || t[1] == v || t[2] == v;
}

static int repeats_corner(const uint32_t *t)
{
    return t[0] == t[1] || t[1] == t[2] || t[2] == t[0];
}

/* Is g a rotation of f (same orientation), given the same three corners? */
static int same_turn(const uint32_t *f, const uint32_t *g)
{
    int k = g[0] == f[0] ? 0 : g[1] == f[0] ? 1 : 2;
    return g[(k + 1) % 3] == f[1];
}

/*
 * Is v's whole star here and one fan? Then no face of v is in a sheet that
 * goes: a face g on the corners of a face f of v either turns the same way
 * (edge v-x twice in one direction) or makes a fan of two with f, which is
 * v's whole star only when v has no other face. So a group whose corners are
 * all such vertices is two faces alone, a closed pillow, which stays. note:
 * the test spares the search of a star for nearly every face; the search was
 * 1.2% of `gen bumpy` 20M at 10% (bench/RESULTS.md, session 22).
 */
static int is_manifold(const en_slab *s, uint32_t v)
{
    return (s->vflags[v] & (EN_V_OWNED | EN_V_NONMANIFOLD)) == EN_V_OWNED;
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static uint32_t find(uint32_t *parent, uint32_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

int64_t en_find_membranes(const en_slab *s, const uint8_t *fflags, uint8_t need, uint8_t *drop)
{
    memset(drop, 0, s->nt);
    uint32_t maxdeg = 1;
    for (uint32_t v = 0; v < s->nv; v++)
        if (en_slab_degree(s, v) > maxdeg)
            maxdeg = en_slab_degree(s, v);
    uint32_t *group = en_malloc(2 * (size_t)maxdeg * sizeof *group);
    if (!group)
        return -1;
    uint32_t *turn = group + maxdeg;
    uint64_t nmem = 0;
    /* The groups of faces on the same corners, each met first at its
     * lowest-numbered face (faces go in order), so each is sorted once. */
    for (uint32_t f = 0; f < s->nt; f++) {
        const uint32_t *t = s->tri + 3 * (size_t)f;
        if (drop[f] || repeats_corner(t) || (is_manifold(s, t[0]) && is_manifold(s, t[1]) && is_manifold(s, t[2])))
            continue;
        uint32_t n = 0;
        for (uint32_t i = s->star_start[t[0]]; i < s->star_start[t[0] + 1]; i++) {
            uint32_t g = s->star[i];
            const uint32_t *u = s->tri + 3 * (size_t)g;
            if (has_corner(u, t[1]) && has_corner(u, t[2]) && !repeats_corner(u))
                group[n++] = g;
        }
        if (n == 1) /* the common case: no other face on these corners */
            continue;
        qsort(group, n, sizeof *group, cmp_u32);
        uint32_t same = 0, other = 0;
        for (uint32_t i = 0; i < n; i++) {
            turn[i] = (uint32_t)same_turn(t, s->tri + 3 * (size_t)group[i]);
            same += turn[i], other += !turn[i];
            drop[group[i]] = SEEN;
        }
        uint32_t pairs = same < other ? same : other, took[2] = { 0, 0 };
        for (uint32_t i = 0; i < n; i++)
            if (took[turn[i]] < pairs) {
                took[turn[i]]++;
                drop[group[i]] = MEMBRANE;
                nmem++;
            }
    }
    en_free(group);
    if (nmem == 0) {
        memset(drop, 0, s->nt);
        return 0;
    }
    /* Sheets: membrane faces joined by edges. glued[]: bit 0, an edge of
     * the sheet has a face that is not of it; bit 1, the sheet stays: an
     * edge would be left with a single face (its faces are the surface's
     * too, as a face doubled by its reverse is), or the caller keeps a
     * face of it. Gathered on each face, then on the root of its sheet. */
    uint32_t *parent = en_malloc((size_t)s->nt * sizeof *parent);
    uint8_t *glued = en_calloc(s->nt, 1);
    if (!parent || !glued) {
        en_free(parent);
        en_free(glued);
        return -1;
    }
    for (uint32_t f = 0; f < s->nt; f++)
        parent[f] = f;
    for (uint32_t f = 0; f < s->nt; f++) {
        if (drop[f] != MEMBRANE)
            continue;
        const uint32_t *t = s->tri + 3 * (size_t)f;
        for (int k = 0; k < 3; k++) {
            uint32_t x = t[k], y = t[(k + 1) % 3], others = 0;
            for (uint32_t i = s->star_start[x]; i < s->star_start[x + 1]; i++) {
                uint32_t g = s->star[i];
                if (g == f || !has_corner(s->tri + 3 * (size_t)g, y))
                    continue;
                if (drop[g] == MEMBRANE) {
                    uint32_t a = find(parent, f), b = find(parent, g);
                    parent[a > b ? a : b] = a < b ? a : b;
                } else {
                    others++;
                }
            }
            glued[f] |= (uint8_t)((others > 0) | (others == 1) << 1);
        }
        if (fflags && (fflags[f] & need) != need)
            glued[f] |= 2;
    }
    for (uint32_t f = 0; f < s->nt; f++)
        if (drop[f] == MEMBRANE && glued[f])
            glued[find(parent, f)] |= glued[f];
    int64_t marked = 0;
    for (uint32_t f = 0; f < s->nt; f++) {
        int d = drop[f] == MEMBRANE && glued[find(parent, f)] == 1;
        drop[f] = (uint8_t)d;
        marked += d;
    }
    en_free(parent);
    en_free(glued);
    return marked;
}
