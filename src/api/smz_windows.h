/*
 * Windows of a sorted .smz for a size target's pricing pass
 * (pipeline/target_stage.h: en_window_source, docs/architecture.md §7):
 * a few stretches of the stream, spread evenly along it, read through the
 * block index while the stream itself has not been read.
 */
#ifndef EN_API_SMZ_WINDOWS_H
#define EN_API_SMZ_WINDOWS_H

#include <stdint.h>

#include "epsnet/epsnet.h"
#include "pipeline/target_stage.h"

typedef struct en_smz_windows en_smz_windows;

/*
 * Open the windows (EN_PRICE_WINDOWS of them, target_stage.h) over the
 * plain .smz at path, for slabs of slab_vertices and margins of at least
 * margin_widths times the stream's width at its middle. Their vertex
 * records carry the attributes of `kept` (the reader's choice of the
 * file's, found by name). *sw is NULL, and src has no windows, when the
 * file is not a plain sorted .smz with an index, or its stream is too wide
 * for its slabs or too short for the windows (target_stage.h: a
 * target then goes without a pricing pass; a bad file is the reader's to
 * report). @return 0, or EPSNET_ENOMEM with err filled.
 */
int en_smz_windows_open(en_smz_windows **sw, const char *path, const epsnet_attr_layout *kept,
                        uint64_t slab_vertices, double margin_widths, en_window_source *src, epsnet_error *err);
void en_smz_windows_close(en_smz_windows **sw);

#endif
