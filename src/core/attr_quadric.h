/*
 * Attribute quadrics (docs/method.md §9, "attribute weights"): the error a
 * collapse makes in a vertex attribute (texture coordinates, normals, any
 * numeric property the user weights), added to the geometric quadric error.
 *
 * Paper implemented: Hoppe. New quadric metric for simplifying meshes with
 * appearance attributes. IEEE Visualization 1999 (each face's attribute as
 * a linear field over its plane, squared and area-weighted, accumulated per
 * vertex like a plane quadric).
 *
 * A face with corner values a0, a1, a2 of one channel has the field
 * f(p) = g·p + d over its plane (f(pi) = ai). A vertex's attribute error at
 * position p with value a is the sum over the faces it stands for of
 * area · (g·p + d - a)². Expanded, the part without a, area · (g·p + d)²,
 * is a quadric in p of the plane quadric's form and is added to the
 * vertex's en_quadric; the rest needs, per channel, Σ area·g (3 numbers)
 * and Σ area·d (1), and, shared, Σ area (1). One more number, the trace
 * Σ area·|g|² that the fold added to the en_quadric, is kept so that the
 * area the geometric part carries (collapse.c: quadric_area) stays exact.
 *
 * Values come in already weighted (pipeline/attr_weights.h: the user's
 * weight times the mesh's diagonal), so a weight of 1 makes an attribute
 * error of 1 cost what a distance of one diagonal does.
 */
#ifndef EN_CORE_ATTR_QUADRIC_H
#define EN_CORE_ATTR_QUADRIC_H

#include <stddef.h>
#include <stdint.h>

#include "core/collapse.h"

#define EN_AQ_MAX_CHANNELS 8

/* Doubles per vertex of the attribute part for k channels (0: none):
 * [Σ area, Σ area·|g|², then per channel Σ area·g (3), Σ area·d]. */
static inline size_t en_aq_doubles(uint32_t k)
{
    return k ? 2 + 4 * (size_t)k : 0;
}

/* Face t's part: its folded quadric into *fold (zero for a zero-area
 * face) and its attribute part into aqf (en_aq_doubles(k)). value holds k
 * per vertex. */
void en_attr_face_quadric(const double *pos, const double *value, uint32_t k, const uint32_t t[3],
                          en_quadric *fold, double *aqf);

/* Every vertex's attribute part from the slab's faces: the folds added
 * to q (as en_quadrics_from_faces() left it), the rest into aq. */
void en_attr_quadrics_from_faces(const en_slab *s, const double *value, uint32_t k, en_quadric *q, double *aq);

/* The attribute part at position p and values a: Σ_c (a_c² Σ area -
 * 2 a_c (G_c·p + D_c)). With the fold in the en_quadric this makes the
 * whole Σ area·(g·p + d - a)². */
static inline double en_aq_eval(const double *aq, uint32_t k, const double p[3], const double *a)
{
    double e = 0;
    for (uint32_t c = 0; c < k; c++) {
        const double *gc = aq + 2 + 4 * (size_t)c;
        e += a[c] * (a[c] * aq[0] - 2 * (gc[0] * p[0] + gc[1] * p[1] + gc[2] * p[2] + gc[3]));
    }
    return e;
}

static inline void en_aq_add(double *a, const double *b, uint32_t k)
{
    size_t n = en_aq_doubles(k);
    for (size_t i = 0; i < n; i++)
        a[i] += b[i];
}

#endif /* EN_CORE_ATTR_QUADRIC_H */
