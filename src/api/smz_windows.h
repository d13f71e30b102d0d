/*
 * A sorted .smz read in stretches through its block index, while the
 * stream itself has not been read: a backend of a size's pricing windows
 * (api/windows.h, docs/architecture.md §7).
 */
#ifndef EN_API_SMZ_WINDOWS_H
#define EN_API_SMZ_WINDOWS_H

#include <stdint.h>

#include "api/windows.h"
#include "common/pool.h"
#include "epsnet/epsnet.h"

typedef struct en_smz_windows en_smz_windows;

/*
 * A sorted .smz as a backend of a size's pricing windows (api/windows.h):
 * the plain file at path, read through its block index; its vertex records
 * carry the attributes of `kept` (the reader's choice of the file's, found
 * by name); its blocks are decoded on pool (NULL: inline). *sw is NULL, and b has no vertices, when the file is not a
 * plain sorted .smz with an index and those attributes (the target then
 * goes without a pricing pass; a bad file is the reader's to report).
 * @return 0, or EPSNET_ENOMEM with err filled.
 */
int en_smz_windows_open(en_smz_windows **sw, const char *path, const epsnet_attr_layout *kept, en_pool *pool,
                        en_window_backend *b, epsnet_error *err);
void en_smz_windows_close(en_smz_windows **sw);

#endif
