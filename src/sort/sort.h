/*
 * Out-of-core spatial sort of any mesh into a sorted, finalized streaming
 * mesh (docs/architecture.md §13; epsnet_sort_file() in the public header is the
 * entry point and states the output order). The passes:
 *
 *   1. read        vertices -> a temporary file in input order (and the
 *                  bbox, for the automatic axis); faces -> another
 *   2. order       vertices -> sorter V by (axis coordinate, old id)
 *   3. rank        merge V: the sorted coordinates -> a temporary file, and
 *                  (old id, rank) -> sorter M
 *   4. relabel     each face corner -> sorter C as (old vertex, face, slot);
 *                  merge C against M (both by old id): (face, slot, rank)
 *                  -> sorter J
 *   5. faces       merge J: whole faces in ranks -> sorter F by (last
 *                  corner, face: a stable sort on the last corner of faces
 *                  added in input order); every corner -> sorter L as (rank, last
 *                  corner of its face)
 *   6. emit        walk the ranks once: a vertex no L item names is dropped;
 *                  otherwise it is written, then the faces whose last corner
 *                  it is, and each vertex is finalized after the last of the
 *                  faces of its largest L value that uses it
 *
 * Only the vertices live in the output stream (its width) and the faces
 * sharing one last corner are ever in memory together, beside the sorters'
 * bounded buffers. When a 32-bit rank and a 32-bit last use per vertex fit
 * in half of the budget, pass 3 fills an array of ranks, pass 5 relabels
 * the faces through it and fills an array of last uses, and pass 4 and
 * sorter L are skipped: the same output with a third of the temporary
 * traffic; pass 6 then also keeps new ids and finalizing faces in arrays
 * over the ranks when they fit. In pass 6 a worker merges sorter F a block
 * ahead of the walk (sort.c: face_feed), one block at a time.
 *
 * When the whole mesh and the arrays that sort it fit in half of the budget
 * (sort.c: whole_bytes), passes 1 to 5 run in memory instead: the read
 * keeps vertices and faces in arrays, the vertices are ranked by a radix
 * sort of (coordinate key, id), the faces relabelled and radix-sorted on
 * their last corner, in pieces on a worker pool. Both sorts are stable, so
 * the output is the external passes' to the byte, for any thread count. A
 * read that outgrows the budget moves what it holds to the spills of pass 1
 * and goes on with the external passes.
 */
#ifndef EN_SORT_SORT_H
#define EN_SORT_SORT_H

#include "common/pool.h"
#include "common/stage.h"
#include "epsnet/epsnet.h"

/*
 * The sort as a stage (docs/architecture.md §7): en_sort_open() runs
 * passes 1 to 5, after which the output's axis and coordinate type are
 * known (en_sort_info); en_sort_emit() runs pass 6 and hands every record of
 * the sorted, finalized stream to emit instead of writing a file, so a
 * consumer such as the first chunker takes them straight from the final
 * merge. Temporary files are only the anonymous spills and runs of the
 * passes (en_spill), in settings->tmpdir, else owner's folder.
 */
typedef struct en_sort en_sort;
/* n records at *recs, in order; their attr bytes are valid during the call
 * only. With cap not NULL, *recs is an en_malloc'ed array of *cap records
 * that the consumer may keep, putting another such array (of any contents)
 * in its place; with cap NULL it reads them only. */
typedef int (*en_sort_emit_fn)(void *opaque, epsnet_record **recs, size_t *cap, size_t n, epsnet_error *err);

/* owner: the output the sort serves, named in messages (and whose folder
 * holds the runs when settings->tmpdir is NULL). settings may be NULL.
 * pool: the workers to use (the run's one pool, docs/architecture.md §10;
 * it must outlive the sort), or NULL to start threads of its own as
 * settings->threads asks.
 * keep_attrs: EN_SORT_KEEP_FORMAT to carry the vertex attributes that
 * owner's format (settings->format, else owner's extension) holds,
 * EN_SORT_KEEP_ALL to carry all of them (the consumer names what its
 * output drops), 0 to carry none; with EN_SORT_DROP_NORMALS added, never
 * the normals (en_reader_keep_attrs); those left out are named in the
 * reader's dropped warning.
 * @return 0 or a negative code; *s is set in both cases (NULL only when
 * nothing was allocated) and en_sort_close() frees it. */
#define EN_SORT_KEEP_FORMAT 1
#define EN_SORT_KEEP_ALL 2
#define EN_SORT_DROP_NORMALS 4
/* The stretches of ranks a consumer will ask en_sort_window() for, given
 * how many ranks the stream has: fills up to EN_SORT_MAX_STRETCHES
 * [lo[i], hi[i]) (in any order; they may overlap) and returns how many. */
#define EN_SORT_MAX_STRETCHES 8
typedef uint32_t (*en_sort_stretches_fn)(uint64_t ranks, uint64_t *lo, uint64_t *hi);
/* stretches: NULL, or what an external sort keeps of the stream for
 * en_sort_window() (a sort in memory keeps everything). */
int en_sort_open(en_sort **s, const char *in_path, const char *owner, const epsnet_sort_settings *settings,
                 int keep_attrs, en_sort_stretches_fn stretches, en_pool *pool, epsnet_error *err);
/* en_sort_open() on a reader the caller opened and has not read from (one
 * over arrays, epsnet_reader_open_arrays): the sort takes it and closes it,
 * also on failure; name stands for in_path in messages. */
int en_sort_open_reader(en_sort **s, epsnet_reader *r, const char *name, const char *owner,
                        const epsnet_sort_settings *settings, int keep_attrs, en_sort_stretches_fn stretches,
                        en_pool *pool, epsnet_error *err);
/* What the output stream will be: coord_type, streaming, sorted_axis, nfaces,
 * vertex_attrs. */
void en_sort_info(const en_sort *s, epsnet_mesh_info *info);
/*
 * Windows of the sorted stream before pass 6 (a size's pricing pass,
 * docs/architecture.md §7), when the sort ran in memory (sort.c: whole) or
 * kept the stretches asked for at en_sort_open() (sort.c: stretch; then a
 * window must lie inside one of them, else EPSNET_EFORMAT with err set):
 * en_sort_windowed() says so. en_sort_window() pushes, as a stream of its
 * own in pass 6's order, the vertices of ranks [lo, hi) that faces use,
 * numbered from base in rank order, each followed by the faces whose last
 * corner it is among those whose corners are all in the window, and each
 * vertex's finalization after the last such face that uses it (into NULL:
 * counts only); *pushed gets how many vertices it pushed, and *cut (unless
 * NULL) adds those on a face it left out. The ranks are en_sort_info()'s
 * vertices, with the unused ones among them. @return 0, or what into
 * returned, or a negative code with err filled.
 */
int en_sort_windowed(const en_sort *s, uint64_t *ranks);
int en_sort_window(en_sort *s, uint64_t lo, uint64_t hi, uint64_t base, en_stage *into, uint64_t *pushed,
                   uint64_t *cut, epsnet_error *err);
/* Pass 6; once per en_sort. emit's non-zero return stops it and is returned. */
int en_sort_emit(en_sort *s, en_sort_emit_fn emit, void *opaque, epsnet_error *err);
/* Free everything (also after a failure), removing every temporary, and
 * give the stats; sets *s to NULL. stats may be NULL. */
void en_sort_close(en_sort **s, epsnet_sort_stats *stats);

/* The automatic axis: the longest side of [lo, hi], the earlier axis on a
 * tie. */
int en_sort_longest_axis(const double lo[3], const double hi[3]);

#endif /* EN_SORT_SORT_H */
