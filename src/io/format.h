/*
 * Format drivers (a small reader/writer table, one file per
 * format). A driver parses bytes from an en_source and pushes records through
 * en_reader_push_*(), which validate them the same way for every format; a
 * writer driver turns records into bytes on an en_sink.
 *
 * Driver contract
 *   reader: open() parses the header and fills r->info; fill() pushes at
 *   least one record, or returns 0 at the end of the mesh; both return a
 *   negative code with r->err filled on failure (use en_reader_fail()).
 *   Records a fill() pushed before it failed are still delivered, and the
 *   error follows them, so a driver just returns the code.
 *   writer: open() may write a header; put() gets validated records; finish()
 *   completes the file (it does not commit the sink). Drivers keep their
 *   private state in r->state / w->state and free it in close().
 */
#ifndef EN_IO_FORMAT_H
#define EN_IO_FORMAT_H

#include <stdint.h>

#include "common/error.h"
#include "epsnet/epsnet.h"
#include "io/sink.h"
#include "io/source.h"

typedef struct en_format en_format;
struct en_pool;

/* Distinct dropped items a reader names; beyond them it only counts. */
#define EN_DROP_MAX 64
#define EN_DROP_NAME 144

typedef struct en_dropped {
    char name[EN_DROP_NAME];         /* "element camera", "vertex property red", "usemtl" */
    uint64_t count;                  /* records or statements, shown when counted */
    int counted;
} en_dropped;

struct epsnet_reader {
    en_source *src;
    const en_format *fmt;
    void *state;                     /* driver-private */
    epsnet_reader_settings settings;
    epsnet_mesh_info info;
    char *path;
    int text;                        /* 1: positions are lines, 0: byte offsets */

    /* Records pushed by the driver and not yet returned; the vertex
     * attributes of queue[i] are qattr[i * info.vertex_attrs.size ...]
     * (epsnet_reader_next() points rec->attr there). */
    epsnet_record *queue;
    size_t qlen, qpos, qcap;
    uint8_t *qattr;
    size_t qattr_cap;                /* records qattr has room for */

    /* Vertex attributes: the driver declares every attribute the file has
     * in file_attrs (en_reader_add_attr) and pushes their packed bytes;
     * info.vertex_attrs is what the records carry: the same, unless
     * en_reader_keep_attrs() left some out (attr_from[i] is the offset in
     * the driver's bytes of info.vertex_attrs.attr[i]). */
    epsnet_attr_layout file_attrs;
    uint32_t attr_from[EPSNET_ATTR_MAX];
    int attrs_subset;                /* info.vertex_attrs != file_attrs */

    uint64_t nverts;                 /* vertex records pushed so far */
    uint64_t ntris;                  /* triangle records pushed so far */
    struct en_idmap *live;           /* streaming formats: pushed, not finalized (values unused) */
    uint64_t live_peak;

    int done;
    int failed;
    epsnet_error err;
    /* A driver that has read past the records it is pushing (.smz decoded
     * on the pool) sets here to the byte offset the one-thread reader would
     * stand at, so that en_reader_fail() names the same offset whatever the
     * thread count. here_set 0: the source's offset. */
    int here_set;
    uint64_t here;

    /* A reader over memory (no src): the bytes its driver has turned into
     * records so far, of mem_size, for epsnet_reader_bytes_read() and
     * epsnet_reader_file_size(). */
    uint64_t mem_read, mem_size;

    /* A note for the user, one line (epsnet_reader_note(): the content chose
     * another format than the name); empty: none. */
    char note[512];

    /* What the records do not carry (docs/architecture.md §5), for epsnet_reader_dropped(). */
    en_dropped drop[EN_DROP_MAX];
    size_t ndrop;
    uint64_t drop_more;              /* distinct items beyond EN_DROP_MAX */
    char *drop_text;
};

struct epsnet_writer {
    en_sink *sink;
    const en_format *fmt;
    void *state;                     /* driver-private */
    epsnet_writer_settings settings;
    epsnet_mesh_info info;           /* what the caller announced */
    epsnet_coord_type coord_type;    /* resolved */
    char *path;
    char *tmpdir;
    uint64_t nverts;                 /* vertex records accepted so far */
    uint64_t ntris;
    int failed;
    epsnet_error err;

    /* Vertex attributes: info.vertex_attrs is what the caller announced,
     * attrs what the driver writes (those its format holds, see
     * en_format.holds_attr); attr_from[i] is the offset of attrs.attr[i] in
     * the caller's bytes, abuf the repacked bytes of one vertex. */
    epsnet_attr_layout attrs;
    uint32_t attr_from[EPSNET_ATTR_MAX];
    int attrs_subset;
    uint8_t abuf[EPSNET_ATTR_MAX * 8];
    char *drop_text;                 /* epsnet_writer_dropped() */
    uint64_t ndrop;
};

struct en_format {
    const char *name;                /* "ply" */
    const char *extensions;          /* space-separated, lower case: "ply" */
    /* Score 0..100 of how much head[0..n) looks like this format. */
    int (*probe)(const uint8_t *head, size_t n);

    int (*open_reader)(epsnet_reader *r);
    int (*fill)(epsnet_reader *r);
    void (*close_reader)(epsnet_reader *r);
    /* NULL when the driver decodes only on the caller's thread. Otherwise:
     * decode on pool's workers from now on (pool NULL: stop, waiting for
     * what is in flight). @return 0 or EPSNET_ENOMEM (then it decodes
     * alone, as before). */
    int (*use_pool)(epsnet_reader *r, struct en_pool *pool);
    /* NULL, or the next records in the driver's own memory, each checked
     * and counted by en_reader_check_*() (as a push would, without the
     * queue), valid until the next call on r. en_reader_next_batch() takes
     * them when the queue is empty and the records carry the file's
     * attributes unchanged (no en_reader_keep_attrs() subset).
     * @return 1 with *n > 0; 1 with *n = 0: none in place now, the queue
     * (fill()) goes on; 0 at the end; or a negative code with r->err
     * filled, after *n records that passed (handed out first). */
    int (*next_in_place)(epsnet_reader *r, const epsnet_record **recs, size_t *n);

    /* NULL for read-only formats. */
    int (*open_writer)(epsnet_writer *w);
    int (*put)(epsnet_writer *w, const epsnet_record *rec);
    int (*finish)(epsnet_writer *w);
    void (*close_writer)(epsnet_writer *w);
    /* NULL when the writer encodes only on the caller's thread. Otherwise
     * as use_pool, for the writer: encode on pool's workers from now on
     * (NULL: stop, writing what is in flight). @return 0 or EPSNET_ENOMEM
     * (then it encodes alone, as before). */
    int (*writer_use_pool)(epsnet_writer *w, struct en_pool *pool);
    /* Whether the writer holds attribute i of layout l (it then gets it in
     * w->attrs); NULL: it holds none. */
    int (*holds_attr)(const epsnet_attr_layout *l, uint32_t i);
    /* Whether the writer writes the names of face label k (0: materials,
     * 1: groups; epsnet.h epsnet_face_names) when it holds layout l (its
     * w->attrs); NULL: it writes none, and they are named as dropped. */
    int (*holds_names)(const epsnet_attr_layout *l, int k);
};

/* holds_attr of formats that keep every attribute (PLY, .smz). */
int en_format_holds_every_attr(const epsnet_attr_layout *l, uint32_t i);

/* Check a layout a caller built (epsnet_writer_open, the push API):
 * types, names, offsets and size agree. @return 0 or -1 with why filled. */
int en_attr_layout_check(const epsnet_attr_layout *l, char *why, size_t why_len);
/* epsnet_attr_layout_add, or _add_of_face when of_face (a copy of another
 * layout's attribute keeps its mark). */
int en_attr_layout_add_as(epsnet_attr_layout *l, const char *name, epsnet_attr_type type, int of_face);

/* The attributes a face's labels travel as (epsnet.h epsnet_face_names):
 * [0] the material's index, [1] the group's; uint16, a face's. */
extern const char *const en_face_label_attr[2];

/* A copy of a stream's face labels (epsnet.h epsnet_face_names) that
 * outlives its reader, in one allocation: a sort closes the reader before
 * the writer reads the names. from NULL: an empty copy whose `of` is NULL.
 * @return 0 or EPSNET_ENOMEM. */
typedef struct en_face_names_copy {
    epsnet_face_names names;
    const epsnet_face_names *of;     /* &names, or NULL when there were none */
    void *storage;
} en_face_names_copy;
int en_face_names_copy_of(en_face_names_copy *to, const epsnet_face_names *from);
void en_face_names_copy_free(en_face_names_copy *c);

/* The table (src/io/formats.c). */
extern const en_format *const en_formats[];
const en_format *en_format_by_name(const char *name);
/* Match the extension of path (ignoring a trailing .zst). */
const en_format *en_format_by_path(const char *path);

/* ---- for reader drivers ---- */

/* Record an error at the reader's current position (line for text formats,
 * byte offset otherwise) and return code. */
int en_reader_fail(epsnet_reader *r, int code, const char *fmt, ...) EN_PRINTF(3, 4);
/* Same, at an explicit byte offset (binary formats pointing at a record). */
int en_reader_fail_at(epsnet_reader *r, int code, uint64_t offset, const char *fmt, ...) EN_PRINTF(4, 5);

/* Push a vertex: rejects NaN/Inf. A file with attributes gives them as
 * attr (file_attrs.size packed bytes); NULL gives zeros. */
int en_reader_push_vertex(epsnet_reader *r, double x, double y, double z);
int en_reader_push_vertex_attr(epsnet_reader *r, double x, double y, double z, const uint8_t *attr);
/* Grow a table the driver holds to the end of its file (an OBJ's corner
 * tables, a PLY's vertex block) to need elements of elem bytes, doubling
 * from 1024, keeping *held (the bytes of all such tables) within
 * settings.mem_limit. @return 0; EPSNET_ELIMIT with *over the bytes the
 * tables would take and nothing reported (the driver says what it holds,
 * with en_reader_fail); or a failure (EPSNET_ENOMEM) reported. */
int en_reader_grow_held(epsnet_reader *r, size_t *held, void **buf, size_t *cap, size_t need, size_t elem,
                        size_t *over);
/* Declare the file's next vertex attribute (open_reader only). @return 1
 * when it is carried, 0 when it is not (past EPSNET_ATTR_MAX: then it is
 * named as dropped, "vertex property NAME"), or a negative code for a name
 * the layout refuses. */
int en_reader_add_attr(epsnet_reader *r, const char *name, epsnet_attr_type type);
/* ... a face's value its corners carry when of_face (epsnet_attr.of_face). */
int en_reader_add_attr_of(epsnet_reader *r, const char *name, epsnet_attr_type type, int of_face);

/*
 * Open a reader whose driver fmt reads memory, not a file (no en_source;
 * errors name no position unless the driver sets r->here): name is named in
 * messages, state becomes r->state (fmt->close_reader frees it; when this
 * fails before the reader exists, en_free does). Used by epsnet_reader_open_arrays().
 */
int en_reader_open_memory(epsnet_reader **r, const char *name, const en_format *fmt, void *state,
                          const epsnet_reader_settings *settings, epsnet_error *err);

/* ---- for library stages that read a user's file ---- */

/*
 * Before the first epsnet_reader_next(): keep only the attributes that a
 * writer of format out (NULL: no format, so none) holds, or all with
 * keep_all, naming the others as dropped ("vertex property red"), so that
 * one warning line tells every loss (docs/architecture.md §5); and never the
 * vertex normals (nx, ny, nz) with drop_normals, named once as such. An
 * OBJ's corners then differ by position and vt only (no normal seams).
 * info.vertex_attrs changes accordingly.
 */
void en_reader_keep_attrs(epsnet_reader *r, const en_format *out, int keep_all, int drop_normals);
/* Push a triangle of 0-based global indices: rejects out-of-range and
 * finalized references. */
int en_reader_push_triangle(epsnet_reader *r, uint64_t a, uint64_t b, uint64_t c);
/* Push a finalization: rejects unknown and already finalized vertices. */
int en_reader_push_finalize(epsnet_reader *r, uint64_t v);
/* The checks and counts of the pushes above, for records a driver hands
 * out in place (en_format.next_in_place): nothing is queued. */
int en_reader_check_vertex(epsnet_reader *r, double x, double y, double z);
int en_reader_check_triangle(epsnet_reader *r, uint64_t a, uint64_t b, uint64_t c);
int en_reader_check_finalize(epsnet_reader *r, uint64_t v);
/* Count records of a format without a live set (not streaming) that the
 * driver checked itself, as the pushes would (indices in range, finite
 * coordinates). */
void en_reader_count_checked(epsnet_reader *r, uint64_t vertices, uint64_t triangles);
/* Check a header count against settings.max_count; what = "vertex count". */
int en_reader_check_count(epsnet_reader *r, uint64_t n, const char *what);
/* Name an item of the file that the records do not carry. A name seen
 * before adds n to its count; counted = 0 shows no count ("vertex property
 * red"), 1 shows it ("element camera (1)"). Never fails: past EN_DROP_MAX
 * distinct names the rest are only counted. */
void en_reader_drop(epsnet_reader *r, const char *name, uint64_t n, int counted);

/* ---- for library stages that read a user's file ---- */

/* The records epsnet_reader_next() would give next, all those the driver
 * has queued, without copying them: *recs points into the reader's queue
 * (attr set), valid until the next call on r. @return 1 with *n > 0, 0 at
 * the end, or a negative code with err filled (records before an error
 * come first, as with epsnet_reader_next()). */
int en_reader_next_batch(epsnet_reader *r, const epsnet_record **recs, size_t *n, epsnet_error *err);

/* Let r's driver decode on pool's workers, if it can (en_format.use_pool),
 * or else read its bytes ahead there (en_source_use_pool); the caller's
 * thread stays the ring's owner and the records come in the same order.
 * Call with NULL before the pool is freed. @return 0 or EPSNET_ENOMEM (r
 * still reads, on the caller's thread). */
int en_reader_use_pool(epsnet_reader *r, struct en_pool *pool);

/* Let w's driver encode on pool's workers, if it can (en_format.
 * writer_use_pool); the bytes are the same. Call with NULL before the pool
 * is freed: that writes what is in flight (a failure there is the writer's,
 * reported by its next call). @return 0 or EPSNET_ENOMEM (w still writes,
 * on the caller's thread). */
int en_writer_use_pool(epsnet_writer *w, struct en_pool *pool);

/* The output complete in its temporary file (the driver's finish, then
 * en_sink_settle): what can fail fails here, and epsnet_writer_commit then
 * only moves it into place. @return 0 or a negative code with err. */
int en_writer_settle(epsnet_writer *w, epsnet_error *err);

/* Pass r's note (epsnet_reader_note()) as one line, then what r dropped
 * (epsnet_reader_dropped()) as one line "PATH: dropped: ...", to a warning
 * callback: nothing when there is neither or warning is NULL. Call it once the mesh has been read to its end.
 * @return the number of distinct items dropped. */
uint64_t en_reader_warn_dropped(epsnet_reader *r, void (*warning)(void *opaque, const char *message),
                                void *opaque);

/* ---- for writer drivers ---- */

static inline int en_writer_bytes(epsnet_writer *w, const void *p, size_t n)
{
    return en_sink_write(w->sink, p, n, &w->err);
}
int en_writer_printf(epsnet_writer *w, const char *fmt, ...) EN_PRINTF(2, 3);
/* Open *sp, when it is not open yet, as an anonymous temporary file where
 * the caller asked (settings.tmpdir), else beside the destination: a
 * format that wants what the stream gives late (faces before vertices'
 * ends, counts in a header) keeps it there. @return 0 or a code, w->err
 * filled. */
int en_writer_open_spill(epsnet_writer *w, en_spill **sp);
/* Name a loss of the writer's own (not an attribute), once, for
 * epsnet_writer_dropped(): "float64 coordinates (as float32)".
 * @return 0 or -1 out of memory. */
int en_writer_drop(epsnet_writer *w, const char *what);
/* Shortest decimal text that reads back to exactly v (as float32 when the
 * writer's coord_type is FLOAT32). Returns the length written into buf
 * (buf must hold 32 bytes). */
int en_format_coord(char *buf, double v, epsnet_coord_type t);

#endif /* EN_IO_FORMAT_H */
