/* Attribute quadrics: see the header and docs/method.md §9. */
#include "core/attr_quadric.h"

#include <math.h>
#include <string.h>

void en_attr_face_quadric(const double *pos, const double *value, uint32_t k, const uint32_t t[3],
                          en_quadric *fold, double *aqf)
{
    size_t n = en_aq_doubles(k);
    memset(fold, 0, sizeof *fold);
    memset(aqf, 0, n * sizeof *aqf);
    const double *p0 = pos + 3 * (size_t)t[0], *p1 = pos + 3 * (size_t)t[1], *p2 = pos + 3 * (size_t)t[2];
    double e1[3] = { p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2] };
    double e2[3] = { p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2] };
    double nrm[3] = { e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0] };
    double n2 = nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2];
    if (!(n2 > 0) || !isfinite(n2))
        return; /* no plane, no field: as its plane quadric, nothing */
    double area = 0.5 * sqrt(n2);
    /* g = ((a1 - a0) (e2 × n) + (a2 - a0) (n × e1)) / |n|²: g·e1 = a1 - a0,
     * g·e2 = a2 - a0, and g lies in the plane. */
    double u[3] = { e2[1] * nrm[2] - e2[2] * nrm[1], e2[2] * nrm[0] - e2[0] * nrm[2], e2[0] * nrm[1] - e2[1] * nrm[0] };
    double w[3] = { nrm[1] * e1[2] - nrm[2] * e1[1], nrm[2] * e1[0] - nrm[0] * e1[2], nrm[0] * e1[1] - nrm[1] * e1[0] };
    aqf[0] = area;
    for (uint32_t c = 0; c < k; c++) {
        double a0 = value[(size_t)k * t[0] + c], a1 = value[(size_t)k * t[1] + c], a2 = value[(size_t)k * t[2] + c];
        double g[3];
        for (int i = 0; i < 3; i++)
            g[i] = ((a1 - a0) * u[i] + (a2 - a0) * w[i]) / n2;
        double d = a0 - (g[0] * p0[0] + g[1] * p0[1] + g[2] * p0[2]);
        fold->a2 += area * g[0] * g[0], fold->ab += area * g[0] * g[1], fold->ac += area * g[0] * g[2];
        fold->ad += area * g[0] * d, fold->b2 += area * g[1] * g[1], fold->bc += area * g[1] * g[2];
        fold->bd += area * g[1] * d, fold->c2 += area * g[2] * g[2], fold->cd += area * g[2] * d;
        fold->d2 += area * d * d;
        aqf[1] += area * (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        double *gc = aqf + 2 + 4 * (size_t)c;
        gc[0] = area * g[0], gc[1] = area * g[1], gc[2] = area * g[2], gc[3] = area * d;
    }
}

void en_attr_quadrics_from_faces(const en_slab *s, const double *value, uint32_t k, en_quadric *q, double *aq)
{
    size_t n = en_aq_doubles(k);
    memset(aq, 0, (size_t)s->nv * n * sizeof *aq);
    double aqf[2 + 4 * EN_AQ_MAX_CHANNELS];
    for (uint32_t f = 0; f < s->nt; f++) {
        const uint32_t *t = s->tri + 3 * (size_t)f;
        en_quadric fold;
        en_attr_face_quadric(s->pos, value, k, t, &fold, aqf);
        for (int i = 0; i < 3; i++) {
            en_quadric_add(&q[t[i]], &fold);
            en_aq_add(aq + n * t[i], aqf, k);
        }
    }
}
