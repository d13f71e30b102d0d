/*
 * The attributes a simplification weighs (settings.attribute_weights,
 * docs/method.md §9): which bytes of a vertex record hold each weighted
 * channel, of what type, and its weight. Every holder of part of the mesh
 * (a slab, the stitcher's W) turns its vertices' bytes into the weighted
 * values the collapse core takes (core/attr_quadric.h), with the same
 * factors, so that the same collapse costs the same wherever it runs.
 */
#ifndef EN_PIPELINE_ATTR_WEIGHTS_H
#define EN_PIPELINE_ATTR_WEIGHTS_H

#include <stdint.h>

#include "core/attr_quadric.h"

typedef struct en_attr_weights {
    uint32_t channels;            /* 0: no attribute is weighed */
    /* The whole mesh's diagonal, by which every weight is multiplied (a
     * value's error then costs what a distance of weight × value does):
     * from the input's header or the sort; 0 when the one slab that is
     * the whole mesh measures its own (slab_work.c). */
    double diagonal;
    struct {
        uint32_t offset;          /* in a vertex's attribute bytes */
        int type;                 /* epsnet_attr_type */
        double weight;
    } ch[EN_AQ_MAX_CHANNELS];
} en_attr_weights;

/* The value of an attribute of type `type` (epsnet_attr_type) at p, as a
 * double (exact for every type: 32-bit integers fit); 0 for an unknown type. */
double en_attr_value(const uint8_t *p, int type);

/* The weighted values of one vertex (its attribute bytes) into out
 * (aw->channels doubles); diagonal as en_attr_weights.diagonal, or the
 * slab's own. A value that is not finite counts as 0. */
void en_attr_weights_values(const en_attr_weights *aw, double diagonal, const uint8_t *bytes, double *out);

#endif /* EN_PIPELINE_ATTR_WEIGHTS_H */
