#include "api/budget.h"

#include <string.h>
#include <unistd.h>

/*
 * note: the shares (docs/architecture.md §12).
 * - A stream's reader holds its live vertex ids (a few bytes each) and the
 *   .smz blocks it reads ahead; the chain holds the same vertices again,
 *   with their stars and faces, at far more bytes each. A quarter for the
 *   reader leaves the chain three quarters: a stream that never finalizes
 *   fails in the chain first, where the message says which pass holds what.
 * - The sort runs passes 1 to 5 alone and pass 6 beside the chain; half
 *   each. Without --mem the sort keeps its working size of 512 MiB (more
 *   only moves meshes to its in-memory path, whose arrays raise the peak:
 *   84 MB more at 20M faces, bench/RESULTS.md), and the chain keeps the rest
 *   of half the physical memory, a limit that turns a runaway stream into a
 *   clear error before the OOM killer does.
 * - A target's one slab is 2/5 of the total, inside the chain's share in
 *   every shape (3/4 or 1/2 of the total), and the same whether the input
 *   was sorted first or not, so that both plan the same passes.
 */
#define SORT_DEFAULT_BYTES ((uint64_t)512 << 20)

uint64_t en_budget_total(const epsnet_settings *set)
{
    if (set->mem)
        return set->mem;
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0)
        return 0;
    return (uint64_t)pages * (uint64_t)page / 2;
}

uint32_t en_budget_slab_vertices(const epsnet_settings *set)
{
    if (set->slab_vertices)
        return set->slab_vertices;
    if (set->mem) {
        uint64_t n = set->mem / EN_BUDGET_BYTES_PER_SLAB_VERTEX;
        return n < 1024 ? 1024 : n > (1u << 24) ? (1u << 24) : (uint32_t)n;
    }
    return EN_BUDGET_DEFAULT_SLAB;
}

void en_budget_split(en_budget *b, const epsnet_settings *set, en_budget_input input)
{
    memset(b, 0, sizeof *b);
    b->total = en_budget_total(set);
    b->given = set->mem != 0;
    b->slab_vertices = en_budget_slab_vertices(set);
    b->slab_derived = set->slab_vertices == 0;
    uint64_t t = b->total;
    switch (input) {
    case EN_BUDGET_STREAM:
        b->reader = t / 4;
        break;
    case EN_BUDGET_SORTED:
        b->sort = t / 2;
        if (!b->given && b->sort > SORT_DEFAULT_BYTES)
            b->sort = SORT_DEFAULT_BYTES;
        break;
    case EN_BUDGET_PUSHED:
    case EN_BUDGET_SERVED:
        break;
    case EN_BUDGET_IN_CORE:
        b->reader = t;
        return; /* no chain */
    }
    b->chain = t - b->reader - b->sort;
    b->one_slab = t / 5 * 2;
}
