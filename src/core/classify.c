#include "core/classify.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/alloc.h"
#include "epsnet/epsnet.h"

int en_classify_faces(const gauss_sphere *g, const en_slab *s, uint32_t f0, uint32_t f1,
                      double *fnormal, int32_t *ftri, en_classify_counts *counts, uint32_t *bad_face)
{
    for (uint32_t f = f0; f < f1; f++) {
        double n[3], *out = fnormal + 3 * (size_t)f;
        en_triangle_normal(s->pos, s->tri + 3 * (size_t)f, n);
        int ok = gauss_to_frame(g, n, out);
        if (ok < 0) {
            *bad_face = f;
            return EPSNET_EFORMAT;
        }
        if (ok == 0) {
            out[0] = out[1] = out[2] = 0;
            ftri[f] = -1;
            counts->zero_area_faces++;
            continue;
        }
        int64_t t = gauss_locate(g, out);
        if (t < 0) {
            *bad_face = f;
            return EPSNET_EINTERNAL;
        }
        ftri[f] = (int32_t)t;
    }
    return 0;
}

/* The faces around v in rotational order: its star, or, for one of a seam
 * pair, its open fan and then its twin's, which together close around the
 * position (en_slab_build_stars: the first face of each fan is across the
 * seam from the other's last), copied into scratch (room for them all).
 * *n gets their count. */
static const uint32_t *ring_of(const en_slab *s, uint32_t v, uint32_t *scratch, uint32_t *n)
{
    *n = en_slab_degree(s, v);
    if (!(s->vflags[v] & EN_V_SEAM))
        return s->star + s->star_start[v];
    uint32_t t = s->wedge[v];
    memcpy(scratch, s->star + s->star_start[v], *n * sizeof *scratch);
    memcpy(scratch + *n, s->star + s->star_start[t], en_slab_degree(s, t) * sizeof *scratch);
    *n += en_slab_degree(s, t);
    return scratch;
}

/* Feature edges are counted once: at the endpoint with the smaller global id,
 * or at v when the other endpoint is locked (locked stars are not walked).
 * A seam vertex counts those inside its own fan (closed 0); the edges
 * along the seam, between its fan and its twin's, are not counted (a
 * statistic only). */
static uint64_t feature_edges_at(const en_slab *s, uint32_t v, const int32_t *ftri, int closed)
{
    const uint32_t *star = s->star + s->star_start[v];
    uint32_t deg = en_slab_degree(s, v);
    uint64_t n = 0;
    for (uint32_t i = 0; i + 1 < deg + (closed ? 1u : 0u); i++) {
        uint32_t f = star[i], h = star[i + 1 == deg ? 0 : i + 1];
        /* note: the Gaussian triangles first; most pairs share one, and the
         * shared corner's record is then never read */
        if (ftri[f] < 0 || ftri[h] < 0 || ftri[f] == ftri[h])
            continue;
        const uint32_t *t = s->tri + 3 * (size_t)f;
        uint32_t x = t[0] == v ? t[2] : t[1] == v ? t[0] : t[1]; /* corner before v: shared with h */
        n += s->gid[v] < s->gid[x] || (s->vflags[x] & (EN_V_BOUNDARY | EN_V_NONMANIFOLD));
    }
    return n;
}

/* The halvings of G that keep the Gaussian vertex at lattice point c: the
 * largest j with 2^j dividing n and each of its coordinates (see
 * en_classify_vertices_levels). */
static uint8_t halvings_kept(const gauss_sphere *g, const int32_t c[3])
{
    uint32_t all = g->n | (uint32_t)abs(c[0]) | (uint32_t)abs(c[1]) | (uint32_t)abs(c[2]);
    uint8_t j = 0;
    while (!(all & 1u)) {
        all >>= 1;
        j++;
    }
    return j;
}

/* The Gaussian vertices the polygon winds about, into *near (grown as
 * needed), their number into *covered (bench/RESULTS.md, session 21). */
static int enclosed(const gauss_sphere *g, const double (*normals)[3], uint32_t m, int signs, const double centre[3],
                    double (*chart)[2], int32_t (**near)[3], size_t *near_cap, size_t *covered)
{
    size_t nn = gauss_vertices_enclosed(g, normals, m, signs, centre, chart, *near, *near_cap);
    while (nn > *near_cap) {
        if (en_grow((void **)near, near_cap, nn, sizeof **near))
            return EPSNET_ENOMEM;
        nn = gauss_vertices_enclosed(g, normals, m, signs, centre, chart, *near, *near_cap);
    }
    *covered = nn;
    return 0;
}

int en_classify_vertices(const gauss_sphere *g, const en_slab *s, const double *fnormal,
                         const int32_t *ftri, uint32_t v0, uint32_t v1, uint8_t *vclass,
                         int32_t *vgvertex, en_classify_counts *counts)
{
    return en_classify_vertices_levels(g, s, fnormal, ftri, v0, v1, vclass, vgvertex, NULL, counts);
}

int en_classify_vertices_levels(const gauss_sphere *g, const en_slab *s, const double *fnormal,
                                const int32_t *ftri, uint32_t v0, uint32_t v1, uint8_t *vclass,
                                int32_t *vgvertex, uint8_t *vlevel, en_classify_counts *counts)
{
    uint32_t maxdeg = 1;
    for (uint32_t v = v0; v < v1; v++) {
        uint32_t d = en_slab_degree(s, v) + ((s->vflags[v] & EN_V_SEAM) ? en_slab_degree(s, s->wedge[v]) : 0);
        maxdeg = d > maxdeg ? d : maxdeg;
    }
    double (*normals)[3] = en_malloc((size_t)maxdeg * sizeof *normals);
    double (*chart)[2] = en_malloc((size_t)maxdeg * sizeof *chart);
    uint32_t *ring = en_malloc((size_t)maxdeg * sizeof *ring);
    size_t near_cap = 256;
    int32_t (*near)[3] = en_malloc(near_cap * sizeof *near);
    int rc = normals && chart && ring && near ? 0 : EPSNET_ENOMEM;
    for (uint32_t v = v0; v < v1 && rc == 0; v++) {
        if (!(s->vflags[v] & EN_V_OWNED))
            continue;
        vclass[v] = 0;
        vgvertex[v] = -1;
        uint8_t vf = s->vflags[v];
        if (vf & EN_V_ISOLATED) {
            counts->isolated++; /* not on the surface: neither a sample nor removable */
            continue;
        }
        if (vf & (EN_V_BOUNDARY | EN_V_NONMANIFOLD)) {
            vclass[v] = EN_C_LOCKED | EN_C_SAMPLE;
            if (vlevel)
                vlevel[v] = EN_LEVEL_ALL;
            counts->locked++;
            counts->samples++;
            counts->boundary += (vf & EN_V_BOUNDARY) && !(vf & EN_V_NONMANIFOLD);
            counts->nonmanifold += (vf & EN_V_NONMANIFOLD) != 0;
            counts->cut_ends += (vf & EN_V_BOUNDARY) && !(vf & EN_V_NONMANIFOLD) && s->has_welds && s->wedge[v] != v;
            continue;
        }
        counts->seam += (vf & EN_V_SEAM) != 0;
        counts->feature_edges += feature_edges_at(s, v, ftri, !(vf & EN_V_SEAM));

        /* The normal polygon P(v): ring order, zero-area faces skipped. */
        uint32_t deg, m = 0;
        const uint32_t *star = ring_of(s, v, ring, &deg);
        int32_t first_tri = -1;
        int candidate = 0;
        for (uint32_t i = 0; i < deg; i++) {
            uint32_t f = star[i];
            if (ftri[f] < 0)
                continue;
            if (first_tri < 0)
                first_tri = ftri[f];
            else if (ftri[f] != first_tri)
                candidate = 1;
            memcpy(normals[m++], fnormal + 3 * (size_t)f, sizeof normals[0]);
        }
        /* note: "candidate" means the non-zero faces around v do not all lie
         * in one Gaussian triangle. Without zero-area faces that is exactly
         * "touches a feature edge" (§4.2); with them it still guarantees that
         * a non-candidate's polygon lies in one (convex) triangle and so
         * encloses no Gaussian vertex. */
        if (!candidate)
            continue;
        vclass[v] |= EN_C_CANDIDATE;
        counts->candidates++;

        /* note: a polygon in one octant is in an open hemisphere (its
         * octant's), so only the others need the hemisphere search */
        double centre[3];
        int signs;
        if (!gauss_in_one_octant((const double(*)[3])normals, m, centre, &signs)) {
            int hemi = gauss_in_open_hemisphere((const double(*)[3])normals, m, centre);
            if (hemi != GAUSS_HEMI_CENTRE) {
                vclass[v] |= EN_C_SAMPLE | EN_C_NEEDLE;
                if (vlevel)
                    vlevel[v] = EN_LEVEL_ALL;
                counts->samples++;
                counts->needles++;
                counts->unverified_hemisphere += hemi == GAUSS_HEMI_UNVERIFIED;
                continue;
            }
        }
        size_t covered;
        rc = enclosed(g, (const double(*)[3])normals, m, signs, centre, chart, &near, &near_cap, &covered);
        if (rc)
            break;
        uint8_t kept = 0;
        for (size_t i = 0; i < covered; i++) {
            int32_t id = (int32_t)gauss_vertex_id(g, near[i][0], near[i][1], near[i][2]);
            if (i == 0 || id < vgvertex[v])
                vgvertex[v] = id;
            if (vlevel) {
                uint8_t j = halvings_kept(g, near[i]);
                kept = j > kept ? j : kept;
            }
        }
        if (vlevel && covered)
            vlevel[v] = kept;
        if (covered) {
            vclass[v] |= EN_C_SAMPLE;
            counts->samples++;
            if (covered > 1) {
                vclass[v] |= EN_C_MULTI;
                counts->multi_cover++;
            }
        }
    }
    en_free(normals);
    en_free(chart);
    en_free(ring);
    en_free(near);
    return rc;
}

void en_classify_counts_add(en_classify_counts *into, const en_classify_counts *c)
{
    into->zero_area_faces += c->zero_area_faces;
    into->feature_edges += c->feature_edges;
    into->candidates += c->candidates;
    into->samples += c->samples;
    into->locked += c->locked;
    into->boundary += c->boundary;
    into->nonmanifold += c->nonmanifold;
    into->seam += c->seam;
    into->cut_ends += c->cut_ends;
    into->needles += c->needles;
    into->multi_cover += c->multi_cover;
    into->unverified_hemisphere += c->unverified_hemisphere;
    into->isolated += c->isolated;
}
