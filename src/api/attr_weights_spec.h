/*
 * settings.attribute_weights, read against the input's vertex properties
 * (docs/method.md §9): "W" weighs the texture coordinates and the normals
 * the input has; "uv=W", "normal=W" and "NAME=W" (any numeric vertex
 * property) one group each, comma-separated.
 */
#ifndef EN_API_ATTR_WEIGHTS_SPEC_H
#define EN_API_ATTR_WEIGHTS_SPEC_H

#include "epsnet/epsnet.h"
#include "pipeline/attr_weights.h"

/* Fill aw (no channels when spec is NULL or weighs nothing; then, for a
 * bare weight on an input with neither texture coordinates nor normals, a
 * warning through set). @return 0, or EPSNET_EINVAL with err filled: a
 * malformed spec, a property the input does not have, more than
 * EN_AQ_MAX_CHANNELS channels, or an input whose bounding box is not
 * known ahead (the weights scale with the mesh's diagonal). */
int en_attr_weights_from_spec(en_attr_weights *aw, const epsnet_settings *set, const epsnet_mesh_info *in,
                              const char *path, epsnet_error *err);

#endif /* EN_API_ATTR_WEIGHTS_SPEC_H */
