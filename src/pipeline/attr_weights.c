/* Weighted attribute values from vertex bytes: see the header. */
#include "pipeline/attr_weights.h"

#include <math.h>
#include <string.h>

#include "epsnet/epsnet.h"

double en_attr_value(const uint8_t *p, int type)
{
    switch (type) {
    case EPSNET_ATTR_INT8: return (int8_t)p[0];
    case EPSNET_ATTR_UINT8: return p[0];
    case EPSNET_ATTR_INT16: { int16_t x; memcpy(&x, p, 2); return x; }
    case EPSNET_ATTR_UINT16: { uint16_t x; memcpy(&x, p, 2); return x; }
    case EPSNET_ATTR_INT32: { int32_t x; memcpy(&x, p, 4); return x; }
    case EPSNET_ATTR_UINT32: { uint32_t x; memcpy(&x, p, 4); return x; }
    case EPSNET_ATTR_FLOAT32: { float x; memcpy(&x, p, 4); return x; }
    case EPSNET_ATTR_FLOAT64: { double x; memcpy(&x, p, 8); return x; }
    default: return 0;
    }
}

void en_attr_weights_values(const en_attr_weights *aw, double diagonal, const uint8_t *bytes, double *out)
{
    for (uint32_t c = 0; c < aw->channels; c++) {
        double x = en_attr_value(bytes + aw->ch[c].offset, aw->ch[c].type);
        /* note: a NaN texture coordinate would make every cost around it
         * NaN, which the queue sends last; 0 keeps the collapse's other
         * terms meaningful */
        out[c] = isfinite(x) ? x * aw->ch[c].weight * diagonal : 0;
    }
}
