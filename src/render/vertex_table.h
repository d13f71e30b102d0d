/*
 * Positions of the vertices a streamed renderer may still be asked for, by
 * global index. For a streaming mesh (docs/architecture.md §6: every vertex finalized after
 * its last triangle) only the live vertices are kept, in a hash table, so
 * memory follows the stream's width; for an ordinary format, where any
 * triangle may use any earlier vertex, every position is kept in a dense
 * array. Either way faces are never stored.
 */
#ifndef EN_RENDER_VERTEX_TABLE_H
#define EN_RENDER_VERTEX_TABLE_H

#include <stddef.h>
#include <stdint.h>

typedef struct en_vertex_table {
    int hashed;          /* 1: live vertices by key, 0: dense by index */
    double *pos;         /* 3 per vertex (dense) or per slot (hashed) */
    uint64_t *key;       /* hashed: global index per slot, UINT64_MAX = empty */
    size_t cap;          /* vertices (dense) or slots, a power of two (hashed) */
    size_t count;        /* vertices held */
    uint64_t max_bytes;  /* 0 = no limit */
} en_vertex_table;

enum { EN_VT_NOMEM = -1, EN_VT_LIMIT = -2 };

/* An empty table; hashed for streaming input. max_bytes 0 = no limit. */
void en_vertex_table_init(en_vertex_table *t, int hashed, uint64_t max_bytes);
void en_vertex_table_free(en_vertex_table *t);

/* Add vertex gid (dense tables: gid must be the number added so far).
 * @return 0, EN_VT_NOMEM, or EN_VT_LIMIT when the table would outgrow
 * max_bytes. */
int en_vertex_table_add(en_vertex_table *t, uint64_t gid, const double xyz[3]);

/* Position of gid, or NULL when it is not held. */
const double *en_vertex_table_get(const en_vertex_table *t, uint64_t gid);

/* Forget a finalized vertex (hashed tables; dense tables keep it). */
void en_vertex_table_remove(en_vertex_table *t, uint64_t gid);

/* Bytes the table holds now. */
uint64_t en_vertex_table_bytes(const en_vertex_table *t);

#endif /* EN_RENDER_VERTEX_TABLE_H */
