/*
 * epsnet: streaming surface sampling and simplification of triangle meshes
 * with Gaussian epsilon-nets (Diaz-Gutierrez, Bösch, Pajarola, Gopi).
 *
 * This header is the manual. It is organised in sections:
 *
 *   1. Errors       - one convention for every call, with file/offset/reason.
 *   2. Records      - the streaming-mesh record every reader and writer speaks.
 *   3. Reading      - open any supported mesh file (optionally .zst) and pull
 *                     records from it one by one, in constant memory.
 *   4. Writing      - push records into a mesh file; the file appears at its
 *                     path only when the writer is committed.
 *   5. Generating   - synthetic meshes of any size, written as a stream.
 *   6. Settings     - the job context and its settings, statistics.
 *   7. Sampling     - classify every vertex as sample or not (paper §4).
 *   8. Simplifying  - keep only the samples: the shape approximation;
 *                     8a: one run shared among processes (MPI ranks);
 *                     8b: the push/pull stream.
 *   9. Measuring    - Metro-style distance and normal deviation between two
 *                     meshes (epsnet hausdorff).
 *  10. Sorting      - any mesh, of any size, into a spatially sorted,
 *                     finalized streaming mesh (epsnet sort), out of core.
 *  11. Rendering    - pictures of a mesh, its samples and its simplification
 *                     as PNG (epsnet render), streaming, without a GPU.
 *  12. Utilities    - size parsing, version, signal-time cleanup.
 *  13. Arrays       - meshes held in the caller's memory (the Python package's
 *                     entry): a reader over them, and simplify, sample and
 *                     measure with the result in arrays.
 *
 * Conventions
 *   - Every function that can fail returns 0 (or a positive count) on success
 *     and a negative EPSNET_E* code on failure. When the caller passes an
 *     epsnet_error, it is filled with the file, the position and the reason.
 *   - Objects are opaque and created by _open()/_new(), destroyed by _close()/
 *     _free(), which take a pointer to the handle and set it to NULL.
 *   - Ownership is stated on every call, for success and for failure.
 *   - Vertex indices are 0-based and global: the n-th vertex record of a
 *     stream has index n-1, whatever format it came from.
 *
 * Worked example: convert any mesh to binary PLY.
 *
 *     epsnet_error err;
 *     epsnet_reader *r = NULL;
 *     epsnet_writer *w = NULL;
 *     epsnet_record rec;
 *     int rc = epsnet_reader_open(&r, "scan.ply.zst", NULL, &err);
 *     if (rc == 0) {
 *         epsnet_writer_settings ws;
 *         epsnet_writer_default_settings(&ws);
 *         rc = epsnet_writer_open(&w, "out.ply", &ws, epsnet_reader_info(r), &err);
 *     }
 *     while (rc == 0 && (rc = epsnet_reader_next(r, &rec, &err)) > 0)
 *         rc = epsnet_writer_put(w, &rec, &err);
 *     if (rc == 0)
 *         rc = epsnet_writer_commit(&w, &err);   // renames into place
 *     epsnet_writer_abort(&w);                    // no-op after a commit
 *     epsnet_reader_close(&r);
 *     if (rc < 0)
 *         fprintf(stderr, "epsnet: %s\n", epsnet_error_message(&err));
 */
#ifndef EPSNET_EPSNET_H
#define EPSNET_EPSNET_H

#include <stddef.h>
#include <stdint.h>

#include "version.h"

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32)
#define EPSNET_API
#elif defined(__GNUC__)
#define EPSNET_API __attribute__((visibility("default")))
#else
#define EPSNET_API
#endif

/* ------------------------------------------------------------------------
 * 1. Errors
 * ------------------------------------------------------------------------ */

enum {
    EPSNET_OK = 0,
    EPSNET_EINVAL = -1,      /* bad argument or option (caller's mistake) */
    EPSNET_EFORMAT = -2,     /* malformed or hostile input data */
    EPSNET_EIO = -3,         /* read/write/open failure, full disk, ... */
    EPSNET_ENOMEM = -4,      /* allocation failed */
    EPSNET_ELIMIT = -5,      /* a budget (--mem, sizes, counts) would be exceeded */
    EPSNET_EUNSUPPORTED = -6,/* valid input we do not handle (e.g. unknown format) */
    EPSNET_EINTR = -7,       /* interrupted by a signal or a progress callback */
    EPSNET_EINTERNAL = -8,   /* a bug: an invariant did not hold */
    EPSNET_EAGAIN = -9,      /* not now: pull the waiting output first (epsnet_stream_push) */
};

/* Unknown line or byte offset in an epsnet_error. */
#define EPSNET_POS_NONE UINT64_MAX

typedef struct epsnet_error {
    int code;            /* EPSNET_E* (negative), or 0 */
    char file[512];      /* file the error is about, "" if none */
    uint64_t line;       /* 1-based line for text input, else EPSNET_POS_NONE */
    uint64_t offset;     /* byte offset (of decompressed data for .zst input), else EPSNET_POS_NONE */
    int zst;             /* 1 when offset counts decompressed bytes of a .zst file */
    char reason[512];    /* what is wrong, one line, no trailing period */
} epsnet_error;

/* Short, static description of an EPSNET_E* code. Never NULL. */
EPSNET_API const char *epsnet_strerror(int code);

/*
 * One-line message "FILE:LINE: REASON", "FILE: byte N: REASON" or "REASON".
 * @return a pointer to thread-local storage, valid until the next call to
 * this function on the same thread. Never NULL.
 */
EPSNET_API const char *epsnet_error_message(const epsnet_error *err);

/* ------------------------------------------------------------------------
 * 2. Records
 *
 * A mesh is a stream of records. In a *streaming mesh* (Isenburg & Lindstrom
 * 2005) every triangle comes after its three vertices and a FINALIZE record
 * says that a vertex is used by no later triangle. Ordinary formats (PLY,
 * OBJ, OFF, STL) produce no FINALIZE records: every vertex stays live until
 * the end of the stream.
 * ------------------------------------------------------------------------ */

typedef enum epsnet_record_kind {
    EPSNET_REC_VERTEX = 1,   /* xyz; the vertex gets the next global index */
    EPSNET_REC_TRIANGLE = 2, /* v[0], v[1], v[2]: counter-clockwise corners */
    EPSNET_REC_FINALIZE = 3, /* v[0]: no later triangle references this vertex */
} epsnet_record_kind;

/*
 * Per-vertex attributes (colours, normals, texture coordinates, confidence,
 * any scalar a file gives each vertex). A stream announces them once, as an
 * epsnet_attr_layout in its epsnet_mesh_info (vertex_attrs); every vertex
 * record then points at its own packed bytes (epsnet_record.attr).
 *
 * The packed bytes of a vertex: every attribute of the layout, in layout
 * order, at its offset, with no padding; each value in the host's byte order
 * and unaligned (read it with memcpy). Values are copied bit for bit from
 * the file and written back bit for bit: nothing is converted, rounded or
 * renamed on the way (a PLY uchar red stays a uchar red).
 *
 * Names are the file's: PLY property names as they are ("red", "nx",
 * "texture_u", "quality", ...); OBJ vertex colours are "red", "green",
 * "blue" (float32). OBJ texture coordinates and normals (`vt`, `vn`, given
 * per face corner) are "texture_u", "texture_v" and "nx", "ny", "nz"
 * (float32; the PLY names MeshLab, Blender and trimesh read): an OBJ
 * vertex record is then one distinct (position, vt, vn) of the faces, and a
 * position with different values in different faces (a seam) is several
 * records at the same coordinates (docs/architecture.md §13). A PLY face
 * element's integer scalars ("material_index", "texnumber", a face colour;
 * not "flags") are carried the same way, after the vertex's own attributes:
 * a record is then one distinct (vertex, face values), in the order faces
 * first name them, and a vertex no face names is dropped and counted; such
 * attributes (and the OBJ materials below) are marked as a face's
 * (epsnet_attr.of_face), which a PLY writer puts back on its faces. Zero
 * attributes (count 0) is the stream of earlier versions: rec.attr is then
 * NULL and nothing else changes.
 */
typedef enum epsnet_attr_type {
    EPSNET_ATTR_INT8 = 1,
    EPSNET_ATTR_UINT8 = 2,
    EPSNET_ATTR_INT16 = 3,
    EPSNET_ATTR_UINT16 = 4,
    EPSNET_ATTR_INT32 = 5,
    EPSNET_ATTR_UINT32 = 6,
    EPSNET_ATTR_FLOAT32 = 7,
    EPSNET_ATTR_FLOAT64 = 8,
} epsnet_attr_type;

/* Most attributes a stream carries; a file with more keeps the first ones
 * and names the rest as dropped (epsnet_reader_dropped()). */
#define EPSNET_ATTR_MAX 32
/* Longest attribute name, with its terminating NUL. */
#define EPSNET_ATTR_NAME_MAX 48

typedef struct epsnet_attr {
    char name[EPSNET_ATTR_NAME_MAX]; /* NUL-terminated, non-empty, no white space */
    epsnet_attr_type type;
    uint32_t offset;                 /* byte offset in the vertex's packed bytes */
    /* 1: a face's value that its corners carry (a PLY face element's
     * integer scalar, an OBJ material or group), so that the records of
     * one vertex differ in it where faces with different values meet; a
     * writer with face properties (PLY) writes it once a face and welds
     * those records back into one vertex. 0: the vertex's own. */
    uint32_t of_face;
} epsnet_attr;

typedef struct epsnet_attr_layout {
    uint32_t count;                  /* attributes, 0 .. EPSNET_ATTR_MAX */
    uint32_t size;                   /* packed bytes per vertex: the sum of the types' sizes */
    epsnet_attr attr[EPSNET_ATTR_MAX];
} epsnet_attr_layout;

/* Bytes of one value of type t (1, 2, 4 or 8), or 0 for an unknown type. */
EPSNET_API size_t epsnet_attr_type_size(epsnet_attr_type t);
/* The PLY name of t ("uchar", "float", ...), or NULL for an unknown type. */
EPSNET_API const char *epsnet_attr_type_name(epsnet_attr_type t);
/*
 * Append an attribute to layout (offset = the current size). Start from a
 * zeroed layout.
 * @return 0, or EPSNET_EINVAL for a bad type or name (empty, too long, white
 * space, a name already in the layout) and EPSNET_ELIMIT past
 * EPSNET_ATTR_MAX.
 */
EPSNET_API int epsnet_attr_layout_add(epsnet_attr_layout *layout, const char *name, epsnet_attr_type type);
/* The same for a face's value its corners carry (epsnet_attr.of_face). */
EPSNET_API int epsnet_attr_layout_add_of_face(epsnet_attr_layout *layout, const char *name, epsnet_attr_type type);
/* Index of the attribute called name, or -1. */
EPSNET_API int epsnet_attr_layout_find(const epsnet_attr_layout *layout, const char *name);

typedef struct epsnet_record {
    epsnet_record_kind kind;
    uint64_t v[3];
    double xyz[3];
    /* Vertex records of a stream with attributes: the vertex's packed bytes
     * (vertex_attrs.size of them, see above). From a reader: valid until the
     * next call on that reader. Into a writer: read during the put only.
     * NULL for other records and for streams without attributes. */
    const uint8_t *attr;
} epsnet_record;

typedef enum epsnet_coord_type {
    EPSNET_COORD_FLOAT32 = 0, /* values came from (or will go to) float32 */
    EPSNET_COORD_FLOAT64 = 1,
} epsnet_coord_type;

/* What is known about a stream before or while reading it. */
#define EPSNET_COUNT_UNKNOWN UINT64_MAX

/*
 * Face labels: materials (OBJ `usemtl`, with `mtllib`) and groups (OBJ
 * `g`). A face's label travels with its corners: the vertex attribute
 * "material_index" or "group_index" (uint16) indexes `names`, and a
 * position whose faces have different labels is one vertex record per
 * label, as a UV seam is (epsnet_attr above), so every face keeps its
 * material and group through simplify and a boundary between two is never
 * smeared. A reader fills the table as it reads: names[i] exists before any
 * vertex record with index i. The name "" labels faces before the file's
 * first `usemtl` (or `g`).
 */
#define EPSNET_FACE_NAMES_MAX 65535
typedef struct epsnet_face_names {
    const char *library;         /* materials: the `mtllib` statement's file name(s), or NULL */
    uint32_t count;              /* names so far */
    const char *const *names;
} epsnet_face_names;

typedef struct epsnet_mesh_info {
    const char *format;          /* "ply", "obj", "off", "stl", "sma", "smb", ... */
    const char *encoding;        /* "ascii", "binary_le", "binary_be", ... */
    int compressed;              /* 1 when read through .zst */
    uint64_t nverts;             /* from the header, or EPSNET_COUNT_UNKNOWN */
    uint64_t nfaces;             /* triangles after triangulation if known, else EPSNET_COUNT_UNKNOWN */
    int has_bbox;                /* 1 when bbox_min/bbox_max come from the header */
    double bbox_min[3], bbox_max[3];
    epsnet_coord_type coord_type;
    int streaming;               /* 1 when the format carries finalization */
    int sorted_axis;             /* 0,1,2 when declared sorted along x,y,z; -1 otherwise */
    /* Per-vertex attributes of every vertex record (see epsnet_attr_layout);
     * all zero for none. A writer opened with a layout expects every vertex
     * record to carry those bytes (rec.attr) and writes the attributes its
     * format can hold (epsnet_writer_dropped() names the others). Zero the
     * whole structure (memset) before filling it by hand. */
    epsnet_attr_layout vertex_attrs;
    /* The stream's materials and groups (epsnet_face_names), NULL for
     * none; owned by the reader (valid until it is closed). A writer given
     * them reads the tables while records are put (so they must outlive
     * the writer's puts): OBJ writes `mtllib`, and `g` and `usemtl` where
     * a face's group or material changes; PLY writes them in its header's
     * comments ("comment epsnet material_index 0 NAME"), which its reader
     * takes back, when the indices are a face's uint16; other formats keep
     * the indices as vertex properties and name the names as dropped. */
    const epsnet_face_names *materials, *groups;
} epsnet_mesh_info;

/* ------------------------------------------------------------------------
 * 3. Reading
 * ------------------------------------------------------------------------ */

typedef struct epsnet_reader epsnet_reader;

typedef struct epsnet_reader_settings {
    /* Largest vertex or face count a header may announce before the file is
     * rejected as absurd. Default: 2^34. */
    uint64_t max_count;
    /* Memory a reader may use for its own state (STL welding, SMA/SMB index
     * maps). 0 = no limit. Default: 0. */
    uint64_t mem_limit;
    /* Format name to force ("ply", ...), or NULL to detect from the name and
     * the first bytes. Default: NULL. */
    const char *format;
    uint8_t reserved[64];
} epsnet_reader_settings;

EPSNET_API void epsnet_reader_default_settings(epsnet_reader_settings *s);

/*
 * Open a mesh file for reading. The format is chosen from the extension
 * (after stripping .zst), unless the content names another one, which then
 * wins (epsnet_reader_note() says so), or from the content when the
 * extension is unknown; zstd-compressed
 * data is detected by its magic number whatever the name. path "-" reads
 * standard input (format must then be given, or be detectable by content).
 *
 * @return 0, or a negative code with err filled. On failure *r is NULL.
 * Ownership: on success the caller owns *r and frees it with
 * epsnet_reader_close(). settings may be NULL for defaults; it is copied.
 */
EPSNET_API int epsnet_reader_open(epsnet_reader **r, const char *path,
                                  const epsnet_reader_settings *settings,
                                  epsnet_error *err);

/* Header information. Valid until the reader is closed. Never NULL. */
EPSNET_API const epsnet_mesh_info *epsnet_reader_info(const epsnet_reader *r);

/*
 * Pull the next record.
 * @return 1 with *rec filled, 0 at the end of the mesh, or a negative code
 * with err filled (after which the reader only returns that code again).
 * Triangle indices are checked: never >= the number of vertices read so far,
 * never a finalized vertex.
 */
EPSNET_API int epsnet_reader_next(epsnet_reader *r, epsnet_record *rec,
                                  epsnet_error *err);

/* Bytes consumed from the file so far (compressed bytes for .zst), for
 * progress reporting. */
EPSNET_API uint64_t epsnet_reader_bytes_read(const epsnet_reader *r);

/* Total size of the file, or 0 when unknown (pipes). */
EPSNET_API uint64_t epsnet_reader_file_size(const epsnet_reader *r);

/*
 * What the file holds that the records do not carry (docs/architecture.md §5, nothing is
 * dropped without a word), as one line of text, e.g.
 *   "element camera (1), vertex property confidence, vertex property red"
 * PLY names every element and property it skips (an element with its record
 * count), vertex list properties, vertex properties past EPSNET_ATTR_MAX,
 * and faces of fewer than 3 corners (scalar vertex properties are carried
 * as attributes, epsnet_mesh_info.vertex_attrs); OBJ every statement kind it
 * skips, with how many it met ("usemtl (3), g (2)"; vt and vn only when no
 * face names them, "vt w" for a third texture coordinate). Most of it is known
 * from the PLY header, the rest as the file is read: the text is complete
 * once epsnet_reader_next() has returned 0.
 * @return NULL when nothing is dropped, else the text (owned by the reader,
 * valid until the next call on r). *count, when count is not NULL, receives
 * the number of distinct items named (0 with NULL).
 */
EPSNET_API const char *epsnet_reader_dropped(epsnet_reader *r, uint64_t *count);

/*
 * A note the reader has for the user, one line, or NULL: when the file's
 * content names a format (the PLY magic line, the .smz or SMB header, a
 * binary STL whose face count gives its exact size) other than its
 * extension's, the content wins and this says so. Valid while r is open.
 */
EPSNET_API const char *epsnet_reader_note(const epsnet_reader *r);

/* Close the reader and set *r to NULL. Accepts NULL and *r == NULL. */
EPSNET_API void epsnet_reader_close(epsnet_reader **r);

/* ------------------------------------------------------------------------
 * 4. Writing
 *
 * Writers never leave a half-written file: data goes to a temporary file in
 * the destination directory, which is renamed over the destination only by
 * epsnet_writer_commit(). epsnet_writer_abort() removes it.
 * ------------------------------------------------------------------------ */

typedef struct epsnet_writer epsnet_writer;

typedef struct epsnet_writer_settings {
    /* Format name ("ply", "obj", "sma", "smb", ...) or NULL to choose from
     * the destination's extension. Default: NULL. */
    const char *format;
    /* 1 for ASCII PLY instead of binary. Default: 0 (binary little-endian). */
    int ascii;
    /* Coordinate type to write where the format offers a choice, or -1 to
     * follow the info passed to epsnet_writer_open(). Default: -1. */
    int coord_type;
    /* zstd level when the destination ends in .zst. Default: 3. */
    int zstd_level;
    /* Directory for spill files (PLY faces of a streaming input); NULL means
     * the destination's directory. Default: NULL. */
    const char *tmpdir;
    uint8_t reserved[64];
} epsnet_writer_settings;

EPSNET_API void epsnet_writer_default_settings(epsnet_writer_settings *s);

/*
 * Create a writer for path. info describes the stream to come (coordinate
 * type, counts if known); it may be NULL. path "-" writes standard output.
 *
 * @return 0, or a negative code with err filled. On failure *w is NULL and
 * nothing exists at path or in its directory.
 * Ownership: on success the caller owns *w and must end it with
 * epsnet_writer_commit() or epsnet_writer_abort().
 */
EPSNET_API int epsnet_writer_open(epsnet_writer **w, const char *path,
                                  const epsnet_writer_settings *settings,
                                  const epsnet_mesh_info *info,
                                  epsnet_error *err);

/*
 * Append one record. Triangles must reference vertices already written.
 * When info announced vertex attributes, every vertex record must carry its
 * packed bytes in rec->attr (EPSNET_EINVAL when it is NULL).
 * @return 0, or a negative code with err filled (the writer must then be
 * aborted).
 */
EPSNET_API int epsnet_writer_put(epsnet_writer *w, const epsnet_record *rec,
                                 epsnet_error *err);

/*
 * Finish the file, flush it and rename it into place. Frees the writer and
 * sets *w to NULL whether it succeeds or not; on failure nothing is left at
 * the destination.
 */
EPSNET_API int epsnet_writer_commit(epsnet_writer **w, epsnet_error *err);

/*
 * The vertex attributes announced at epsnet_writer_open() that the output
 * format cannot hold and that the writer therefore leaves out, as one line
 * in the style of epsnet_reader_dropped(): "vertex property red, vertex
 * property green". PLY and .smz hold every attribute. OBJ holds vertex
 * colours red, green, blue when all three are float32 (as its reader gives
 * them; integer colours would need a conversion, which would not read back
 * bit for bit, so they are left out and named), texture coordinates
 * texture_u, texture_v (else s, t, else u, v) and normals nx, ny, nz, all
 * float32 and each group only whole, as `vt`, `vn` and `f v/vt/vn`; SMA, SMB, STL and OFF hold
 * none. STL also holds float32 coordinates only, and names float64 ones as
 * rounded. Known from the open.
 * @return NULL when nothing is left out, else the text (owned by the
 * writer, valid until it is committed or aborted). *count, when count is
 * not NULL, receives the number of items named (0 with NULL).
 */
EPSNET_API const char *epsnet_writer_dropped(const epsnet_writer *w, uint64_t *count);

/* Discard everything written and free the writer; sets *w to NULL.
 * Accepts NULL and *w == NULL. */
EPSNET_API void epsnet_writer_abort(epsnet_writer **w);

/* Formats that can be read / written, as a space-separated list. */
EPSNET_API const char *epsnet_formats_readable(void);
EPSNET_API const char *epsnet_formats_writable(void);

/* ------------------------------------------------------------------------
 * 5. Generating synthetic meshes
 *
 * Every shape is written as a spatially sorted, finalized streaming mesh
 * along its stream axis (z; y for terrain): vertices in non-decreasing axis
 * order, each triangle right after its last vertex, each vertex finalized
 * right after its last triangle. Memory grows with the side of the grid
 * (about sqrt(faces)), never with the face count: a few hundred KB at 10M
 * faces. With shuffle set, vertices and faces come in a random order
 * instead (vertices first, no finalization), like a scanner's PLY, still in
 * constant memory.
 *
 * The shapes (all counter-clockwise seen from outside, coordinates float32):
 *   sphere     unit sphere, latitude/longitude grid with pole fans
 *   ellipsoid  semi-axes 1, 0.75, 0.5 along x, y, z
 *   roundcube  cube [-s,s]^3 swept by a ball of radius 1-s (s = param),
 *              with exactly planar faces and cylindrical edges
 *   torus      major radius 1 around z, minor radius = param (genus 1)
 *   dimple     unit sphere with six smooth dents: concave regions
 *   bumpy      unit sphere with fractal relief at every scale, like a scan
 *   terrain    open height field over [-1,1]^2, one boundary loop
 *   cad        stepped shaft with a through bore and a hexagonal flange:
 *              planar faces, cylinders, sharp creases; genus 1
 * sphere, ellipsoid and roundcube are convex polyhedra: every edge is convex
 * on the float coordinates as written (checked exactly by the tests), so
 * the sample count equals the Gaussian vertex count once the mesh is fine
 * enough. The same settings give the same records on every machine.
 * ------------------------------------------------------------------------ */

typedef struct epsnet_gen_settings {
    /* Shape name: "sphere", "ellipsoid", "roundcube", "torus", "dimple",
     * "bumpy", "terrain", "cad". Default: "sphere". */
    const char *shape;
    /* Approximate number of triangles wanted, 1 .. 2*10^10; the generator
     * picks the closest grid it can make (within a few percent from about
     * 2000 faces up; epsnet_gen_info() gives the exact counts).
     * Default: 20000. */
    uint64_t faces;
    /* Seed for random shapes (bumpy, dimple, terrain) and for shuffle.
     * Default: 1. */
    uint64_t seed;
    /* 1 to emit vertices and faces in random order. Default: 0. */
    int shuffle;
    /* Shape parameter, NaN for the shape's default:
     *   roundcube: 0 = sphere .. 1 = cube, in [0, 1] (default 0.5)
     *   torus:     minor/major radius ratio, in (0.01, 0.99) (default 0.4)
     *   ellipsoid, sphere, cad: unused
     *   dimple:    dent depth relative to the radius, in [0, 0.6] (default 0.3)
     *   bumpy:     displacement amplitude, in [0, 0.4] (default 0.05)
     *   terrain:   relief height relative to the half side, in [0, 10]
     *              (default 0.2)
     * Out of range: EPSNET_EINVAL. */
    double param;
    /* A UV atlas of about this many charts, like a photogrammetry texture:
     * every vertex carries texture_u and texture_v (float32); the grid is cut
     * into square charts, each with its own tile of the unit square (no two
     * overlap), and a vertex where charts meet is one record per chart, as
     * an OBJ reader makes them from `vt` (docs/architecture.md §13); with
     * shuffle, those records too come in a random order. 0: no texture
     * coordinates. Default: 0. */
    uint64_t charts;
    uint8_t reserved[56];
} epsnet_gen_settings;

EPSNET_API void epsnet_gen_default_settings(epsnet_gen_settings *s);

/* Names of the shapes, space-separated. */
EPSNET_API const char *epsnet_gen_shapes(void);

/*
 * Generate a mesh into an open writer (not committed by this call).
 * @return 0, or a negative code with err filled: EPSNET_EINVAL for bad
 * settings, or whatever epsnet_writer_put() returned (the writer must then
 * be aborted).
 * Ownership: w stays the caller's in every case.
 */
EPSNET_API int epsnet_gen(const epsnet_gen_settings *s, epsnet_writer *w,
                          epsnet_error *err);

/* Mesh info that epsnet_gen(s, ...) will produce: exact nverts and nfaces,
 * coord_type float32, streaming and sorted_axis (-1 when shuffled); pass it
 * to epsnet_writer_open(). Cheap: nothing is generated.
 * @return 0, or EPSNET_EINVAL with err filled. */
EPSNET_API int epsnet_gen_info(const epsnet_gen_settings *s,
                               epsnet_mesh_info *info, epsnet_error *err);

/* ------------------------------------------------------------------------
 * 6. Settings and the job context
 *
 * Sampling and simplification run inside an epsnet_context configured by an
 * epsnet_settings. Fill the settings with epsnet_default_settings() first,
 * then change what you need; the context copies them.
 * ------------------------------------------------------------------------ */

typedef enum epsnet_rotation_mode {
    EPSNET_ROTATION_DEFAULT = 0,  /* the fixed, documented default below */
    EPSNET_ROTATION_QUATERNION,   /* settings.rotation = (w, x, y, z), any length > 0 */
    EPSNET_ROTATION_SEED,         /* a uniformly random rotation from settings.seed */
    EPSNET_ROTATION_IDENTITY,     /* G's axes are the mesh's axes (tests, ties) */
} epsnet_rotation_mode;

typedef struct epsnet_settings {
    /* Gaussian sphere: octahedron subdivided `level` times (paper §3.3), i.e.
     * 4^(level+1)+2 Gaussian vertices. Default: 3 (258 vertices). */
    int level;
    /* Finer control: geodesic frequency n (4n^2+2 vertices); 0 = use level.
     * Default: 0. */
    uint32_t frequency;
    /* Orientation R of the Gaussian sphere. Default: EPSNET_ROTATION_DEFAULT,
     * a rotation by 41.4213562 degrees about the axis (0.2718281828,
     * 0.5772156649, 0.7853981634) (digits of sqrt 2, e, the Euler-Mascheroni
     * constant and pi/4): unrelated to the coordinate axes and to the
     * octahedron's symmetries, so axis-aligned and 45-degree planes of CAD
     * parts never put their normals on Gaussian vertices or edges. */
    epsnet_rotation_mode rotation_mode;
    double rotation[4];           /* quaternion (w, x, y, z) for QUATERNION */
    uint64_t seed;                /* for SEED, and for the rotations of ε-net passes. Default: 1 */
    /* Threads; 0 = every processor this process may run on (its CPU
     * affinity: taskset, a container, Slurm, mpirun's binding; no more
     * than its cgroup's CPU quota gives: a container's --cpus). 1 runs
     * everything on the calling thread; N > 1 starts N workers for the
     * slabs while the calling thread reads, cuts, stitches and writes; more
     * than the processors it may use gets a warning. The output never
     * depends on it. Default: 0. */
    int threads;
    /* Memory budget in bytes: a total for the whole run, split once among
     * its parts (epsnet_stats.budget_*, docs/architecture.md §12). A stream
     * (.smz, SMA, SMB) gives a quarter to the reader's live vertices and
     * the rest to the passes (slabs cut and waiting, output held back by a
     * vertex that stays open: output leaves in input id order); an input
     * sorted first gives half to the sort and half to the passes; a whole
     * mesh loaded in memory (sample with the mesh output, render with
     * samples) takes all of it. 2/5 of it is what a target's one slab may
     * hold. It also sets the slab size (see slab_vertices). Over a share, a
     * run stops with EPSNET_ELIMIT and a message that says what grew. 0 =
     * none given: slabs of 65536 vertices, the sort's 512 MiB, and half the
     * physical memory as the total (a clear error, never the OOM killer).
     * Default: 0. */
    uint64_t mem;
    /* Folder for temporary files; NULL = beside the output. Default: NULL. */
    const char *tmpdir;
    /* Progress callback, called from the calling thread at most ~10 times a
     * second with bytes consumed so far and the total (0 if unknown); return
     * non-zero to cancel (the run then fails with EPSNET_EINTR). When more
     * than the reading is to come (an input sorted first; a target whose
     * finish runs after the last record as one slab), done and total are
     * parts of one bar for the whole run, the reading its first part.
     * Default: NULL. */
    int (*progress)(void *opaque, uint64_t done, uint64_t total);
    void *progress_opaque;
    /* Simplification: this many ε-net passes (paper §4.2, §5); pass i > 1
     * re-samples the previous result under a rotation derived from seed and
     * removes what became a non-sample. The streamed run chains all of them
     * (the in-core one behind epsnet_render_file() stops early when a pass
     * removes nothing). 1 = one sampling, no re-sampling. Default: 1. */
    int passes;
    /* Simplification: a collapse is refused when it would leave any face
     * turned by more than this many degrees from its normal in the input
     * (so no face can fold over, however many collapses touch it). With
     * several passes, each pass measures against its own input (the pass
     * before's output): records carry no normals from pass to pass.
     * Default: 60 (measured: see bench/RESULTS.md). */
    double max_normal_dev;
    /* Write ASCII instead of binary where the output format offers both.
     * Default: 0. */
    int ascii;
    /* Streaming pipeline (docs/architecture.md §8): vertices owned by each slab. 0 = derive
     * it from mem (mem / 4800, at least 1024), or 65536 without a budget;
     * a streamed size target's slabs then hold that many in all, the
     * corners they borrow from their neighbours included (about two rows
     * of the stream's width), so that its memory does not grow with the
     * width. Slabs depend only on the input and this number, never on
     * threads, so the output does not either. Smaller slabs use less
     * memory; the samples are the same for every slab size. Default: 0. */
    uint32_t slab_vertices;
    /* Warnings that do not stop a run (docs/architecture.md §5): what the input holds that
     * the output does not carry ("in.ply: dropped: element camera (1)", see
     * epsnet_reader_dropped()), an input with vertices but no faces. One
     * line each, without a newline, from the calling thread. NULL: not
     * reported (epsnet_stats.dropped still counts). Default: NULL. */
    void (*warning)(void *opaque, const char *message);
    void *warning_opaque;
    /*
     * Simplification to a size or an error bound (docs/method.md §13). With
     * any of these, simplify keeps the samples of one ε-net pass as a
     * feature skeleton (every skeleton sample is in the output: the paper's
     * ε-cover at that density) and removes the other vertices by half-edge
     * collapses, smallest error first, until the target is met. Only when
     * the skeleton alone is over the target are samples removed too, by the
     * same order (epsnet_stats.samples_given_up counts them; non-manifold
     * vertices, kept as samples, go with them). The refusals are those of
     * the ε-net pass (topology, max_normal_dev, zero area, duplicates;
     * boundary vertices stay). Zero-volume double sheets glued to the
     * surface (two faces on the same corners, opposite orientations) are
     * removed first when their non-manifold corners would take more than
     * the skeleton's share of the target (epsnet_stats.membrane_faces).
     *
     * At most one of target_faces, target_ratio and target_vertices;
     * target_error may be given with one of them (both must then hold:
     * the run stops at whichever comes first) or alone. 0 = none, for
     * each. Without any of them simplify is the ε-net method (passes). A
     * target needs passes = 1.
     *
     * target_faces: keep at most N triangles. A collapse removes the two
     *   faces on its edge, so the output has N, or N - 1 when N is odd on a
     *   closed surface, or more when refusals stop it (then a warning says
     *   how many and why). Error (EPSNET_EINVAL) when over the input's faces.
     * target_ratio: keep round(R * input faces), 0 < R <= 1.
     * target_vertices: keep at most N vertices (exact unless refused).
     * target_error: no collapse whose error exceeds E times the diagonal of
     *   the mesh's bounding box. The error of a collapse is the root mean
     *   square distance of its new vertex to the input planes its quadric
     *   holds, weighted by their area: the measure of meshoptimizer's
     *   target_error, not a Hausdorff bound.
     *
     * The skeleton's density: with target_level_given = 0, the run chooses
     * the finest power-of-two geodesic frequency, up to 16, whose samples
     * take at most a quarter of the vertices the target keeps (measured:
     * bench/RESULTS.md), counted over the whole mesh, so that the same mesh
     * in any order and any slab size gets the same skeleton
     * (docs/method.md §13); it reports it in the stats' Gaussian sphere.
     * With 1, level/frequency as given. An error bound alone keeps
     * level/frequency as given.
     *
     * A mesh of at most four slabs (slab_vertices, or the one mem gives:
     * 262,144 vertices by default) is then one slab, and the target is met
     * exactly; a larger one is thinned on slabs, in parallel, kept in a
     * temporary file, taken towards the target by rounds on slabs under a
     * rising global ceiling on collapse cost (a long sorted .smz: the
     * thinning itself under a ceiling priced from a few windows of the
     * stream first, so that it ends near the target), and finished exactly: in one
     * slab when what is left fits a few slabs and mem's one-slab share
     * (2/5 of it, at about 640 bytes a vertex), else on slabs whose seams
     * end it at the target (docs/architecture.md §7). An error bound
     * alone is one slab while the mesh fits that share and slab_vertices (when
     * given); beyond, it is held by every collapse of a pass on slabs, on
     * the diagonal of the input's bounding box as its header or the sort
     * gives it (of every vertex listed). An error bound with a count over
     * that share is refused (EPSNET_ELIMIT).
     * Defaults: 0.
     */
    uint64_t target_faces;
    double target_ratio;
    uint64_t target_vertices;
    double target_error;
    int target_level_given;
    /* Simplification: keep every vertex whose per-vertex property of this
     * name (epsnet_mesh_info.vertex_attrs) is non-zero, e.g. a PLY uchar
     * "lock", or a selection MeshLab exported as vertex "quality". Such a
     * vertex is never removed, by the ε-net pass or a target (it may still
     * receive collapses). The property travels with its vertex; when the
     * output format cannot hold it, a warning names it. An input without
     * it is an error (EPSNET_EINVAL). NULL: none. Default: NULL. */
    const char *lock_property;
    /* Simplification: read no vertex normals (PLY nx, ny, nz; OBJ vn), so
     * that an OBJ whose corners differ only by their normal (flat shading,
     * hard edges) is one surface, not pieces whose every border stays;
     * the dropped warning says so. An output format that holds normals
     * (OBJ, PLY, .smz) gets vertex normals recomputed from the output's
     * faces (each the unit sum of its faces' area-weighted normals);
     * simplify_file only. Default: 0. */
    int drop_normals;
    /* Simplification: weigh vertex attributes in the collapses' error
     * (docs/method.md §9), so that a collapse that would slide the texture
     * or bend the shading costs more. A comma-separated list: "W" weighs
     * the texture coordinates and the normals the input has; "uv=W",
     * "normal=W" and "NAME=W" (any numeric vertex property) one group
     * each. Each face's attribute is a linear field over its plane, and a
     * collapse v -> u costs, besides its geometric quadric error, the
     * area-weighted squared difference between v's faces' fields at u and
     * u's own values (Hoppe 1999), times (W times the diagonal of the
     * mesh's bounding box) squared: at W = 1 an attribute error of 1 costs
     * what a distance of one diagonal does, as meshoptimizer's attribute
     * weights do for a mesh scaled to unit size. Values stay exactly the
     * input's (a collapse keeps u's); the weights change which collapses
     * are made and in what order. Needs the bounding box ahead (a header,
     * or an input the run sorts): else EPSNET_EINVAL, as for a property the
     * input does not have. NULL: none. Default: NULL. */
    const char *attribute_weights;
    /* epsnet_simplify_file() only: the processes that share this run's
     * slabs (section 8a). NULL: one process. Default: NULL. */
    const struct epsnet_peers *peers;
    uint8_t reserved[24]; /* (after drop_normals' padding: the structure keeps its size) */
} epsnet_settings;

EPSNET_API void epsnet_default_settings(epsnet_settings *s);

/*
 * Parse a rotation into s->rotation_mode / s->rotation: "default",
 * "identity", "AX,AY,AZ,DEG" (axis and angle in degrees, right-hand rule) or
 * "q:W,X,Y,Z" (a quaternion, normalised later).
 * @return 0, or EPSNET_EINVAL (s unchanged).
 */
EPSNET_API int epsnet_parse_rotation(const char *text, epsnet_settings *s);

/* Statistics of the last run of a context (paper Table 3 and docs/architecture.md §12). */
typedef struct epsnet_stats {
    uint64_t vertices;            /* input vertices */
    uint64_t faces;               /* input triangles; counts up during a streamed run
                                   * (progress callbacks may read it) */
    uint64_t zero_area_faces;     /* faces without a normal (skipped) */
    uint64_t gaussian_vertices;   /* vertices of G */
    uint64_t feature_edges;       /* edges whose faces lie in different G triangles */
    uint64_t candidates;          /* vertices on a feature edge (paper §4.2) */
    uint64_t samples;             /* samples, locked vertices included */
    uint64_t locked;              /* boundary and non-manifold vertices (kept as samples) */
    uint64_t boundary_vertices;
    uint64_t nonmanifold_vertices;
    uint64_t seam_vertices;       /* copies of a position along a seam, simplified in pairs along it
                                   * (docs/method.md §6) */
    uint64_t cut_end_vertices;    /* of the boundary vertices, the copies of a position where seams
                                   * end: three sides meet, or a seam meets a boundary (kept) */
    uint64_t needle_vertices;     /* normals not in an open hemisphere */
    uint64_t multi_cover_samples; /* samples enclosing more than one G vertex */
    uint64_t isolated_vertices;   /* referenced by no face: not on the surface */
    uint64_t output_vertices;     /* simplify: vertices written */
    uint64_t output_faces;        /* simplify: triangles written */
    uint64_t collapses;           /* simplify: half-edge collapses done, all passes */
    uint64_t passes;              /* simplify: ε-net passes run */
    uint64_t remaining_nonsamples;/* simplify: non-samples whose every collapse was refused */
    uint64_t refused_link;        /* ... of those, refused by the link condition (topology) */
    uint64_t refused_normal;      /* ... a face would flip or turn past max_normal_dev */
    uint64_t refused_zero_area;   /* ... a face would lose its area */
    uint64_t refused_duplicate;   /* ... a face would duplicate an existing one */
    uint64_t max_active;          /* largest active set: vertices + faces in memory */
    uint64_t slabs;               /* streaming pipeline: slabs cut, all passes */
    uint64_t seam_faces;          /* ... faces that went through the stitcher's seams */
    uint64_t seam_collapses;      /* ... collapses done there (included in collapses) */
    /* Seam quality (pass 1..passes summed): input non-samples within one ring
     * of a slab border ("band") and elsewhere ("inner"), and how many of each
     * are still in the output. Equal rates mean seams are simplified like
     * the rest. */
    uint64_t band_nonsamples, band_nonsamples_left;
    uint64_t inner_nonsamples, inner_nonsamples_left;
    uint64_t peak_rss;            /* bytes, 0 if unknown */
    double seconds_read;          /* per stage, wall clock */
    double seconds_normals;
    double seconds_classify;
    double seconds_write;
    double seconds_simplify;
    double seconds_sort;          /* sorting an input that was not a stream first (0: none) */
    /* CPU seconds of the run: cpu_workers is spent in slab jobs, on whichever
     * thread ran them (on the calling thread itself at threads = 1);
     * cpu_main is the calling thread's other work (reading, cutting slabs,
     * stitching seams, writing). cpu_main / (cpu_main + cpu_workers) is the
     * serial fraction that bounds the speed-up from more threads. */
    double cpu_main;
    double cpu_workers;
    uint64_t dropped;             /* distinct items of the input the output does not carry
                                   * (epsnet_reader_dropped()) */
    /* Simplification to a target (see epsnet_settings.target_faces): the
     * target in faces (0: none, or vertices/error only), skeleton samples
     * in the output, and samples removed because the skeleton alone was
     * over the target (non-manifold vertices, kept as samples, included).
     * membrane_faces: faces of zero-volume double sheets glued to the
     * surface (two faces on the same corners, opposite orientations),
     * removed before the classification; the classification counts above
     * (isolated_vertices, locked, ...) are then of the mesh without them
     * (docs/method.md §13). skeleton_finest_frequency: the finest density
     * the choice considered (16), or the one given (0 without a target). */
    uint64_t target_faces;
    uint64_t skeleton_vertices;
    uint64_t samples_given_up;
    uint64_t membrane_faces;
    uint32_t skeleton_finest_frequency;
    /* The memory budget (settings.mem, or half the physical memory without
     * it) as the run split it, once, among the parts that hold what grows
     * with the input (docs/architecture.md §12): the reader's held state (a
     * stream's live vertices; 0 when the sort reads the file), the sort's
     * buffers (0: the input was a stream), the passes' held state, and, of
     * that, what a target's one slab may take. reader + sort + chain <= total. */
    uint64_t budget_total, budget_reader, budget_sort, budget_chain, budget_one_slab;
    /* A streamed target (docs/architecture.md §7): the rounds its target
     * stage ran under a global cost ceiling before the last one (0: none). */
    uint32_t target_rounds;
    /* ... and how many of them it ran again because they passed the
     * target (docs/architecture.md §7: a round never passes it). */
    uint32_t target_round_retries;
    /* A streamed target over a long sorted .smz: the global ceiling on
     * collapse cost that its thinning pass held every slab and seam to,
     * priced before the pass from windows of the stream read through the
     * block index, and the vertices of those windows (0, 0: none;
     * docs/architecture.md §7). */
    double target_price_ceiling;
    uint64_t target_price_vertices;
    /* The values a vertex's attribute error weighs (settings.attribute_weights:
     * 2 for texture coordinates, 3 for normals; 0: none). */
    uint32_t attribute_channels;
    /* A run shared among processes (section 8a), on rank 0: the slabs it
     * sent to the other ranks to work (of `slabs`; 0 in one process). */
    uint64_t slabs_shipped;
} epsnet_stats;

typedef struct epsnet_context epsnet_context;

/*
 * Create a context. settings may be NULL for defaults; it is copied.
 * @return 0, or a negative code with err filled (bad settings: EINVAL).
 * Ownership: on success the caller owns *ctx and frees it with
 * epsnet_context_free(); on failure *ctx is NULL.
 */
EPSNET_API int epsnet_context_new(epsnet_context **ctx, const epsnet_settings *settings,
                                  epsnet_error *err);

/* Free the context and set *ctx to NULL. Accepts NULL and *ctx == NULL. */
EPSNET_API void epsnet_context_free(epsnet_context **ctx);

/* Statistics of the context's last run. Valid until the next run or free. */
EPSNET_API const epsnet_stats *epsnet_context_stats(const epsnet_context *ctx);

/* ------------------------------------------------------------------------
 * 7. Sampling (paper §4, docs/method.md §8)
 * ------------------------------------------------------------------------ */

typedef enum epsnet_sample_output {
    /* A PLY point set: one vertex per sample with x y z, `gvertex` (the id of
     * the Gaussian vertex it covers, -1 for locked vertices and needle tips)
     * and red green blue (a colour per Gaussian vertex id). */
    EPSNET_SAMPLES_POINTS = 0,
    /* The whole mesh as PLY, every vertex with `sample` (1/0), `gvertex` and a
     * colour (grey for non-samples): for viewing in MeshLab. */
    EPSNET_SAMPLES_MESH = 1,
} epsnet_sample_output;

/*
 * Classify every vertex of the mesh at in_path and write the samples to
 * out_path (PLY; binary unless out_path ends in .ply and ascii is set).
 * @return 0, or a negative code with err filled; nothing is left at out_path
 * on failure. Statistics are in epsnet_context_stats(ctx) afterwards.
 */
EPSNET_API int epsnet_sample_file(epsnet_context *ctx, const char *in_path, const char *out_path,
                                  epsnet_sample_output what, int ascii, epsnet_error *err);

/*
 * Write the statistics of the last run as a JSON object to path ("-" =
 * stdout). @return 0 or a negative code with err filled.
 */
EPSNET_API int epsnet_stats_write_json(const epsnet_context *ctx, const char *command,
                                       const char *path, epsnet_error *err);

/* ------------------------------------------------------------------------
 * 8. Simplifying (paper §4.2, §5; docs/method.md §9)
 * ------------------------------------------------------------------------ */

/*
 * Simplify the mesh at in_path so that (after settings.passes ε-net passes)
 * only samples, locked vertices and non-samples whose every collapse was
 * refused remain, or to the target settings.target_* ask for, and write it
 * to out_path (format from the extension; ASCII with settings.ascii).
 * Non-samples are removed by half-edge collapses onto a neighbour, cheapest
 * first by quadric error, so every output vertex is an input vertex with
 * bit-identical coordinates and, where the output format holds them, its
 * attributes bit for bit (epsnet_mesh_info.vertex_attrs; an OBJ's per-corner
 * vt/vn too: a vertex on a seam is kept); what the output cannot hold is
 * named in the one dropped warning. Unreferenced input vertices are dropped.
 * Closed manifold input stays closed manifold with the same genus.
 * @return 0, or a negative code with err filled; nothing is left at
 * out_path on failure. Statistics are in epsnet_context_stats(ctx).
 */
EPSNET_API int epsnet_simplify_file(epsnet_context *ctx, const char *in_path, const char *out_path,
                                    epsnet_error *err);

/* ------------------------------------------------------------------------
 * 8a. One run shared among processes (docs/distributed.md)
 *
 * settings.peers makes epsnet_simplify_file() one of `size` processes
 * (MPI ranks, or anything that can carry bytes between them) that run it
 * together, each with its own threads. Every process calls it with the same
 * input, output path and settings, peers.rank aside. Rank 0 reads the
 * input, cuts the slabs, stitches the seams, runs a size target's rounds
 * and writes the output; it sends each slab it does not work itself to a
 * rank that has room for one, and takes the results back. The other ranks
 * read and write nothing: they classify and simplify the slabs they are
 * sent, on their threads (at least one, besides the calling thread, which
 * carries the messages), and hold a few at most. The output bytes are
 * those of the one-process run, for every size and thread count, whichever
 * rank worked which slab.
 *
 * Every process returns the same status: 0 when every one succeeded, else
 * the first failure's code, with rank 0's own error or, when the failure
 * was elsewhere, that rank's, its reason prefixed with "rank R: " (rank 0
 * names the others' failures before its own only when they came first).
 * Rank 0 commits the output only when every rank succeeded.
 *
 * The transport. Each send is matched by exactly one recv of the same size
 * on the other side, in the order sent between that pair of ranks. Rank 0
 * sends only to a rank that is waiting for it, so a send may block until
 * the receiver takes it (MPI_Send semantics). poll tells, without waiting,
 * whether a message from `from` is there to be received (1) or not (0).
 * A non-zero return from send or recv, or a negative one from poll, fails
 * the run with EPSNET_EIO. All three are called from the thread that
 * called epsnet_simplify_file() only (MPI_THREAD_FUNNELED suffices).
 * ------------------------------------------------------------------------ */

typedef struct epsnet_peers {
    int rank;                     /* this process: 0 ... size - 1 */
    int size;                     /* processes in the run, at least 1 */
    void *opaque;
    int (*send)(void *opaque, int to, const void *buf, size_t n);
    int (*recv)(void *opaque, int from, void *buf, size_t n);
    int (*poll)(void *opaque, int from);
} epsnet_peers;

/* ------------------------------------------------------------------------
 * 8b. Streaming: push records in, pull records out (docs/architecture.md §7)
 *
 * The pipeline behind epsnet_simplify_file(), for callers who produce or
 * consume records themselves. A *chunker* cuts the input into slabs of
 * settings.slab_vertices finalized vertices, a pool of settings.threads
 * workers classifies and simplifies each slab on its own, and a *stitcher*
 * finishes the seams between slabs and emits one ordered stream. Chained
 * ε-net passes run in the same pipeline, one after the other, without
 * temporary files.
 *
 * Input is a streaming mesh (section 2): vertices get ids 0, 1, 2, ... in
 * push order, triangles name live vertices, FINALIZE says a vertex is used
 * by no later triangle. Finalization is what lets slabs be cut and memory
 * stay bounded (by the stream's width, not its length); vertices never
 * finalized are held until epsnet_stream_end() and go into one last slab.
 *
 * Output is the simplified mesh, itself a finalized streaming mesh: its
 * vertices in input id order (a sorted input stays sorted), each triangle
 * right after its last vertex, each vertex finalized right after its last
 * triangle; output ids are 0, 1, 2, ... in the order of VERTEX records.
 * The same input and settings give the same records for every thread
 * count. The samples (which vertices are kept as samples) are the same for
 * every slab size; the collapses around them may differ slightly.
 *
 * Records come out as slabs are finished. Pull after every push (and after
 * end) until pull returns 0: while output waits, push refuses with
 * EPSNET_EAGAIN and does not take the record (push it again after pulling).
 * That is the back-pressure that keeps the output queue to what one push
 * finished, whatever the length of the mesh.
 *
 *     epsnet_stream *s = NULL;
 *     epsnet_record in, out;
 *     int rc = epsnet_stream_open(&s, ctx, &err);
 *     while (rc == 0 && produce(&in)) {
 *         rc = epsnet_stream_push(s, &in, &err);
 *         while (rc == 0 && (rc = epsnet_stream_pull(s, &out, &err)) == 1)
 *             rc = consume(&out);
 *     }
 *     if (rc == 0)
 *         rc = epsnet_stream_end(s, &err);
 *     while (rc == 0 && (rc = epsnet_stream_pull(s, &out, &err)) == 1)
 *         rc = consume(&out);
 *     epsnet_stream_close(&s);
 *
 * tests/example_stream.c is a complete program built on it.
 * ------------------------------------------------------------------------ */

typedef struct epsnet_stream epsnet_stream;

/*
 * Start a simplification with ctx's settings. Worker threads start here.
 * @return 0, or a negative code with err filled (EPSNET_EIO when threads
 * cannot be started). ctx must outlive the stream; its statistics are
 * those of this run after epsnet_stream_end().
 */
EPSNET_API int epsnet_stream_open(epsnet_stream **s, epsnet_context *ctx, epsnet_error *err);

/* Give the next input record. @return 0; EPSNET_EAGAIN when output waits
 * to be pulled (the record was not taken; nothing failed); or a negative
 * code with err filled (bad record: EPSNET_EFORMAT; an error from a worker,
 * in slab order), after which every call returns it again. */
EPSNET_API int epsnet_stream_push(epsnet_stream *s, const epsnet_record *rec, epsnet_error *err);

/* End of input: finish every slab and seam. @return 0 or a negative code. */
EPSNET_API int epsnet_stream_end(epsnet_stream *s, epsnet_error *err);

/* @return 1 with *rec filled, 0 when no output record is waiting, or a
 * negative code. */
EPSNET_API int epsnet_stream_pull(epsnet_stream *s, epsnet_record *rec, epsnet_error *err);

/* Stop the workers and free everything; sets *s to NULL. Accepts NULL. */
EPSNET_API void epsnet_stream_close(epsnet_stream **s);

/* ------------------------------------------------------------------------
 * 9. Measuring
 *
 * A Metro-style comparison of two meshes A and B (the measure behind the
 * paper's Tables 1 and 2). Each mesh is sampled: every vertex used by a
 * face, points along every edge and stratified points inside every face;
 * each sample is measured against the other surface with an exact
 * point-to-triangle distance. Both directions are reported, since the
 * Hausdorff distance is the larger of two one-sided maxima.
 *
 * Sampling density: samples_per_face * (faces of the mesh) points inside
 * faces, spread in proportion to area (at least one per face with area);
 * edge points at twice that spacing (never more in total than the face
 * points); every used vertex once. Zero-area faces (collinear or coincident
 * corners) get no interior points but are sampled and measured as their
 * edges: a segment or a point, never "distance 0 to everything near them".
 *
 * Weights: max is over every sample. mean and rms are integrals over the
 * surface, estimated from the face points, each weighted by its face's area
 * divided by that face's point count (Metro's area weighting); a mesh with
 * no area at all falls back to equal weights over its vertex and edge
 * points.
 *
 * Normal deviation (the L2,1 measure of paper §3.2 that the method bounds):
 * for each face point, the angle between its face's normal and the normal
 * of the other surface at the closest point. Where that closest point is on
 * an edge or vertex shared by several faces (to within 1e-10 of the other
 * mesh's diagonal), the face whose normal is nearest to the sample's is
 * used: the normal cone there holds every direction in between. Normals are
 * oriented, so a face flipped against its neighbour shows as about 180
 * degrees. Reported as max and area-weighted mean, in degrees; samples whose
 * nearest faces are all zero-area have no normal to compare and are not
 * counted.
 *
 * The numbers depend only on the two meshes, samples_per_face and seed:
 * never on the thread count or on the machine's scheduling.
 *
 * Example: the error of a simplification, relative to the input's size.
 *
 *     epsnet_hausdorff_result r;
 *     epsnet_error err;
 *     if (epsnet_hausdorff_files("scan.ply", "small.ply", NULL, &r, &err) == 0)
 *         printf("max %g mean %g of the diagonal\n", r.hausdorff / r.diagonal,
 *                r.a_to_b.mean / r.diagonal);
 * ------------------------------------------------------------------------ */

typedef struct epsnet_hausdorff_settings {
    /* Interior points per face, on average (area-proportional), 1 .. 100000.
     * Default: 10. */
    uint32_t samples_per_face;
    /* Seed of the stratified jitter. Default: 1. */
    uint64_t seed;
    /* Threads; 0 = every processor this process may run on. Default: 0. */
    int threads;
    uint8_t reserved[64];
} epsnet_hausdorff_settings;

EPSNET_API void epsnet_hausdorff_default_settings(epsnet_hausdorff_settings *s);

/* One direction: the samples of one mesh measured against the other surface. */
typedef struct epsnet_hausdorff_side {
    double max;                /* largest distance, over every sample */
    double max_at[3];          /* where: the first sample found at max (the
                                * same for any thread count), to look there */
    double mean;               /* area-weighted mean distance */
    double rms;                /* area-weighted root mean square distance */
    uint64_t samples;          /* points measured: vertices + edge + face points */
    double normal_max;         /* largest normal deviation, degrees */
    double normal_mean;        /* area-weighted mean normal deviation, degrees */
    uint64_t normal_samples;   /* face points that had a normal to compare with */
    double area;               /* surface area of the sampled mesh */
} epsnet_hausdorff_side;

typedef struct epsnet_hausdorff_result {
    epsnet_hausdorff_side a_to_b;  /* samples of A, distances to B */
    epsnet_hausdorff_side b_to_a;  /* samples of B, distances to A */
    double hausdorff;              /* symmetric: max(a_to_b.max, b_to_a.max) */
    double diagonal;               /* diagonal of the bounding box of all of A's vertices */
    uint64_t a_vertices, a_faces, a_zero_area_faces;
    uint64_t b_vertices, b_faces, b_zero_area_faces;
    uint8_t reserved[64];
} epsnet_hausdorff_result;

/*
 * Read the meshes at a and b (any readable format, optionally .zst) and
 * measure them against each other. Both are held in memory with their
 * search hierarchies: about 150 bytes per face each, vertices included.
 * @return 0 with *out filled, or a negative code with err filled:
 * EPSNET_EINVAL when exactly one of the meshes has no faces (the distance to
 * an empty surface is undefined; two empty meshes measure 0), the reader's
 * codes for bad files, EPSNET_ELIMIT beyond 2^32-2 vertices or faces,
 * EPSNET_EUNSUPPORTED for coordinates beyond 1e75 in magnitude (powers of
 * their differences would overflow), EPSNET_ENOMEM.
 * Ownership: nothing is kept; s may be NULL for defaults.
 */
EPSNET_API int epsnet_hausdorff_files(const char *a, const char *b,
                                      const epsnet_hausdorff_settings *s,
                                      epsnet_hausdorff_result *out, epsnet_error *err);

/*
 * Write r as a JSON object to path ("-" = stdout), the values relative to
 * r->diagonal beside the absolute ones; a_name and b_name are recorded as
 * given (may be NULL). The file appears only when complete.
 * @return 0 or a negative code with err filled.
 */
EPSNET_API int epsnet_hausdorff_write_json(const epsnet_hausdorff_result *r, const char *a_name,
                                           const char *b_name, const char *path,
                                           epsnet_error *err);

/* ------------------------------------------------------------------------
 * 10. Sorting (docs/architecture.md §13)
 *
 * The pipeline needs a spatially sorted streaming mesh: vertices in
 * non-decreasing order along one axis, each triangle right after its last
 * vertex, each vertex finalized right after its last triangle. Sorting turns
 * any readable mesh into one, out of core: vertices and face corners are
 * external-sorted in temporary runs (anonymous, uncompressed files that
 * vanish on any exit), so memory stays near `mem` whatever the mesh size.
 *
 * The output, for the same input and settings, is the same bytes:
 *   - vertices ordered by their coordinate along the axis; equal coordinates
 *     keep their input order;
 *   - triangles ordered by their last corner in that order, then by input
 *     order, each with its corners (and so its orientation) as in the input;
 *   - each vertex finalized right after the last triangle that uses it;
 *   - vertices that no triangle uses are dropped (and counted);
 *   - every vertex keeps its attributes, bit for bit, when the output
 *     format holds them; those it cannot hold are named in the one
 *     dropped warning (settings.warning) and counted in stats.dropped.
 * Input finalization records are ignored; a streaming input is still read
 * under the memory budget (a stream that never finalizes hits it: ELIMIT).
 * ------------------------------------------------------------------------ */

typedef struct epsnet_sort_settings {
    /* Stream axis: 0, 1, 2 for x, y, z; -1 = the longest side of the
     * bounding box (ties go to the earlier axis). Default: -1. */
    int axis;
    /* Memory budget in bytes for the sort's buffers. Beyond it there is a
     * fixed overhead of a few MB (reader window, compressors), so budgets
     * below about 16M are honoured only approximately. The output's live
     * vertices (its width, about 64 bytes each) must fit in half of it, or
     * the sort fails with EPSNET_ELIMIT. When the whole mesh and the arrays
     * that sort it (about 68 bytes per vertex, plus twice the vertex's
     * attribute bytes, and 36 per face) fit in half of it, it is sorted in memory with no temporary file at all; else,
     * when 8 bytes per input vertex fit in half of it, ranks are looked up
     * in memory instead of joined externally. The output is the same.
     * Default: 512M. */
    uint64_t mem;
    /* Folder for the temporary runs; NULL = the output's folder.
     * Default: NULL. */
    const char *tmpdir;
    /* Output format name, or NULL to choose from the output's extension.
     * Default: NULL. */
    const char *format;
    /* Progress callback, as in epsnet_settings: done/total in arbitrary
     * units over the whole job; non-zero cancels (EPSNET_EINTR).
     * Default: NULL. */
    int (*progress)(void *opaque, uint64_t done, uint64_t total);
    void *progress_opaque;
    /* Warnings, as in epsnet_settings. Default: NULL. */
    void (*warning)(void *opaque, const char *message);
    void *warning_opaque;
    /* Threads for the in-memory sort (when the mesh and its arrays fit in
     * half of mem): 0 = all cores, 1 = the calling thread only. The output
     * never depends on it. Default: 0. */
    int threads;
    uint8_t reserved[44];
} epsnet_sort_settings;

EPSNET_API void epsnet_sort_default_settings(epsnet_sort_settings *s);

typedef struct epsnet_sort_stats {
    uint64_t vertices;            /* input vertices */
    uint64_t faces;               /* input (and output) triangles */
    uint64_t unreferenced;        /* input vertices no triangle uses: dropped */
    int axis;                     /* the axis used */
    uint64_t runs;                /* sorted runs written to temporary files */
    uint64_t temp_bytes;          /* compressed bytes written to them */
    uint64_t peak_memory;         /* largest total of the sort's own buffers */
    uint64_t peak_rss;            /* process high-water mark, 0 if unknown */
    uint64_t max_width;           /* most vertices live at once in the output */
    double seconds;
    uint64_t dropped;             /* distinct items of the input not carried (epsnet_reader_dropped()) */
    uint8_t reserved[56];
} epsnet_sort_stats;

/*
 * Sort the mesh at in_path into out_path (any writable format; .smz keeps
 * the finalization and the sorted flag). settings and stats may be NULL.
 * @return 0, or a negative code with err filled; on failure nothing is left
 * at out_path and every temporary file is gone.
 */
EPSNET_API int epsnet_sort_file(const char *in_path, const char *out_path,
                                const epsnet_sort_settings *settings,
                                epsnet_sort_stats *stats, epsnet_error *err);

/* ------------------------------------------------------------------------
 * 11. Rendering
 *
 * A picture of a mesh as a PNG, drawn by a software rasterizer (no GPU, no
 * display): orthographic camera, z-buffer, two-sided Lambert shading with a
 * little ambient light, on a white background. Optionally the samples as
 * dots coloured by the Gaussian vertex they cover (the colours of
 * `epsnet sample`'s PLY, as in the paper's figures), the edges as a
 * wireframe, and the simplified mesh beside the input.
 *
 * Camera: +y is up. The view direction is given by azimuth (degrees about
 * +y; 0 looks along -z with +x to the right, 90 looks along -x) and
 * elevation (degrees, positive looks down from above). The scale fits the
 * projection of the mesh's bounding box (the header's when the file has
 * one, else that of every vertex) into its panel with a 5% margin on every
 * side, centred.
 *
 * Memory: the plain picture streams. Triangles are drawn as they are read
 * (after a first pass for the bounding box when the header has none); only
 * the image and the vertices still referenced are held: for a streaming mesh
 * (.smz, .sma, .smb) the live vertices, for other formats every vertex
 * position (24 bytes each; run `epsnet sort` first for meshes whose vertices
 * do not fit). settings.mem of the context bounds that table (ELIMIT).
 * With samples, the classification holds the whole mesh in memory, as
 * epsnet_sample_file() with EPSNET_SAMPLES_MESH does. With simplified, the
 * simplification streams through the same chain as epsnet_simplify_file()
 * and only its output is held.
 *
 * The output bytes depend only on the input, the render settings and the
 * context's method settings (level, rotation, passes ...).
 * ------------------------------------------------------------------------ */

typedef struct epsnet_render_settings {
    /* Size of the whole image in pixels, each 1 .. 8192. With simplified,
     * it is split into two panels of width/2 (input on the left, the
     * simplified mesh on the right). Default: 640 x 480. */
    uint32_t width, height;
    /* View direction in degrees (see above). Default: 30, 20. */
    double azimuth, elevation;
    /* 1: draw the samples (paper §4) as dots on the input. Default: 0. */
    int samples;
    /* 1: two panels, the input and its simplification (paper §4.2, with the
     * context's passes and max_normal_dev). Default: 0. */
    int simplified;
    /* 1: darken the edges of every triangle. Default: 0. */
    int wire;
    /* Radius of a sample dot in pixels, 0 = automatic: the panel's smaller
     * side / 160, at least 2. Default: 0. */
    double dot_radius;
    uint8_t reserved[64];
} epsnet_render_settings;

EPSNET_API void epsnet_render_default_settings(epsnet_render_settings *s);

/*
 * Render the mesh at in (any readable format, optionally .zst) into the PNG
 * out_png, whose name must end in .png ("-" = stdout). ctx supplies the method settings for samples and
 * simplified, and the memory budget; its statistics afterwards hold the
 * input's vertex and face counts and, when they ran, those of the
 * classification and simplification.
 * in must be a file, not "-": it is read twice (bounding box, drawing).
 * @return 0, or a negative code with err filled: EPSNET_EINVAL for bad
 * settings, EPSNET_EUNSUPPORTED for in "-" or an out_png not named .png, the reader's codes for bad
 * input, EPSNET_ELIMIT over the memory budget, EPSNET_EIO, EPSNET_ENOMEM.
 * Nothing is left at out_png on failure.
 * Ownership: nothing is kept; rs may be NULL for defaults.
 */
EPSNET_API int epsnet_render_file(epsnet_context *ctx, const char *in, const char *out_png,
                                  const epsnet_render_settings *rs, epsnet_error *err);

/* ------------------------------------------------------------------------
 * 12. Utilities
 * ------------------------------------------------------------------------ */

/*
 * Parse a size such as "64M", "1.5G", "4096" (K, M, G, T are powers of 1024;
 * a trailing "B"/"iB" is accepted).
 * @return 0 with *out set, or EPSNET_EINVAL.
 */
EPSNET_API int epsnet_parse_size(const char *text, uint64_t *out);

/*
 * Remove the named temporary files this process still has open. Output files
 * are anonymous (O_TMPFILE) where the system allows, and those vanish by
 * themselves; this covers the fallback. Async-signal-safe: call it from a
 * SIGINT/SIGTERM handler, then _exit().
 */
EPSNET_API void epsnet_remove_temporaries(void);

/* "MAJOR.MINOR.PATCH" of the linked library. */
EPSNET_API const char *epsnet_version(void);

/* ------------------------------------------------------------------------
 * 13. Arrays (docs/architecture.md §14)
 *
 * A mesh already in memory, as a numpy user holds it: an (n, 3) array of
 * float32 or float64 coordinates, an (m, 3) array of int32 or int64 vertex
 * indices, both row-major and contiguous, and any number of per-vertex
 * attribute columns (n values of one epsnet_attr_type each). Nothing is
 * copied up front: the arrays are read in place, record by record, through
 * a reader (epsnet_reader_open_arrays) that speaks the stream every file
 * reader speaks. Its records are those a PLY of the same content gives: the
 * vertices in array order, then the faces in array order, no finalization.
 * So the simplification of arrays is the one the CLI makes of the file:
 * sorted (docs/architecture.md §13), then the same chain, and its output,
 * collected into arrays, is the output file's vertices and faces in the
 * file's order.
 *
 * Every value is checked before it becomes a record, and errors name the
 * array's row (0-based, as the caller indexes it): "faces[12, 1] = -3 is
 * not a vertex index (0 .. 99)", "vertices[5] is not finite (nan 0 1)"
 * (EPSNET_EFORMAT). The arrays must stay unchanged until the reader is
 * closed or the call returns.
 *
 *     epsnet_arrays in;
 *     epsnet_arrays_init(&in);
 *     in.nverts = nv; in.xyz = xyz; in.coord_type = EPSNET_COORD_FLOAT32;
 *     in.nfaces = nf; in.faces = tri; in.index_bytes = 4;
 *     epsnet_arrays_out out;
 *     int rc = epsnet_simplify_arrays(ctx, &in, &out, &err);
 *     if (rc == 0)
 *         use(out.nverts, out.xyz, out.nfaces, out.faces);
 *     epsnet_arrays_out_free(&out);
 * ------------------------------------------------------------------------ */

typedef struct epsnet_arrays {
    const char *name;               /* names the mesh in messages; NULL: "arrays" */
    uint64_t nverts;
    const void *xyz;                /* nverts x 3 values of coord_type, row-major */
    epsnet_coord_type coord_type;   /* float32 or float64 */
    uint64_t nfaces;
    const void *faces;              /* nfaces x 3 signed integers of index_bytes, row-major */
    int index_bytes;                /* 4 (int32) or 8 (int64) */
    /* Attribute columns: attrs names them and gives their types (fill it
     * with epsnet_attr_layout_add(); the offsets are those of the packed
     * bytes the records carry); attr[i] points at nverts values of
     * attrs.attr[i].type, in the host's byte order. */
    epsnet_attr_layout attrs;
    const void *attr[EPSNET_ATTR_MAX];
    uint8_t reserved[64];
} epsnet_arrays;

/* Zero a, as every field's default (no mesh, float32, int32 indices). */
EPSNET_API void epsnet_arrays_init(epsnet_arrays *a);

/*
 * Open a reader over a's arrays (format "arrays"): every vertex record,
 * with its attribute bytes packed from the columns, then every triangle.
 * epsnet_reader_bytes_read() and epsnet_reader_file_size() count the
 * arrays' bytes, for progress.
 * @return 0, or a negative code with err filled: EPSNET_EINVAL for a bad
 * description (NULL arrays with a non-zero count, a coordinate type or index
 * size not listed above, a layout epsnet_attr_layout_add() would not make).
 * Bad values are reported by epsnet_reader_next(), as for a file.
 * Ownership: the arrays stay the caller's and must outlive the reader; a is
 * copied. settings may be NULL.
 */
EPSNET_API int epsnet_reader_open_arrays(epsnet_reader **r, const epsnet_arrays *a,
                                         const epsnet_reader_settings *settings, epsnet_error *err);

/* A result in arrays the library allocated: the same shapes as
 * epsnet_arrays, coordinates of coord_type and faces of index_bytes (those
 * of the input), one column per attribute of attrs. */
typedef struct epsnet_arrays_out {
    uint64_t nverts;
    void *xyz;
    epsnet_coord_type coord_type;
    uint64_t nfaces;
    void *faces;
    int index_bytes;
    epsnet_attr_layout attrs;
    void *attr[EPSNET_ATTR_MAX];
    uint8_t reserved[64];
} epsnet_arrays_out;

/*
 * Free every buffer of out that is not NULL and zero it. A caller who keeps
 * a buffer sets its pointer to NULL first and frees it with epsnet_free().
 * Accepts a zeroed out.
 */
EPSNET_API void epsnet_arrays_out_free(epsnet_arrays_out *out);

/* Free a buffer the library allocated for the caller (see above). NULL is
 * accepted. */
EPSNET_API void epsnet_free(void *p);

/*
 * epsnet_simplify_file() on arrays: in is sorted and simplified with ctx's
 * settings exactly as the same mesh read from a file would be, and the
 * output is collected into out: its vertices in the output file's order,
 * with their coordinates and attribute columns bit for bit (every output
 * vertex is an input vertex), and its faces as indices into them. Every
 * attribute column travels (there is no output format to leave some out).
 * Statistics are in epsnet_context_stats(ctx); warnings and progress go
 * to ctx's callbacks (progress counts the arrays' bytes, then the run's
 * later parts, as for a file). Temporary files, if the sort or a streamed
 * target needs them, go to settings.tmpdir, else $TMPDIR, else /tmp.
 * @return 0 with out filled, or a negative code with err filled (out then
 * zeroed): the reader's EPSNET_EFORMAT for a bad value, and every code of
 * epsnet_simplify_file().
 * Ownership: in stays the caller's; out's buffers are the caller's, freed
 * with epsnet_arrays_out_free().
 */
EPSNET_API int epsnet_simplify_arrays(epsnet_context *ctx, const epsnet_arrays *in, epsnet_arrays_out *out,
                                      epsnet_error *err);

/*
 * The classification of `epsnet sample --mesh` on arrays, in memory (one
 * slab that owns every vertex, docs/architecture.md §14): is_sample[v] is 1
 * when input vertex v is a sample (paper §4.1; locked vertices included)
 * and 0 otherwise, gvertex[v] the Gaussian vertex it covers (-1 for none,
 * locked vertices and needle tips), for every v < in->nverts. Attributes
 * are not used. Statistics are in epsnet_context_stats(ctx).
 * @return 0, or a negative code with err filled.
 * Ownership: every array is the caller's; is_sample and gvertex hold
 * in->nverts values each.
 */
EPSNET_API int epsnet_sample_arrays(epsnet_context *ctx, const epsnet_arrays *in, uint8_t *is_sample,
                                    int32_t *gvertex, epsnet_error *err);

/*
 * epsnet_hausdorff_files() on two meshes in arrays (their attributes are
 * not used). @return and ownership as there.
 */
EPSNET_API int epsnet_hausdorff_arrays(const epsnet_arrays *a, const epsnet_arrays *b,
                                       const epsnet_hausdorff_settings *s, epsnet_hausdorff_result *out,
                                       epsnet_error *err);

#ifdef __cplusplus
}
#endif

#endif /* EPSNET_EPSNET_H */
