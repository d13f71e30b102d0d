"""epsnet: streaming surface sampling and simplification of triangle meshes.

Numpy in, numpy out, and file to file out of core, with the C library's
method (Gaussian ε-nets, paper §4; docs/method.md in the repository):

    import epsnet
    v, f = epsnet.simplify(vertices, faces, ratio=0.1)      # in memory
    epsnet.simplify_file("scan.ply.zst", "small.ply", ratio=0.1, progress=bar)
    idx, gv = epsnet.sample(vertices, faces)                 # the ε-net samples
    report = epsnet.hausdorff((vertices, faces), (v, f))     # Metro-style distances

Arrays
    vertices: (n, 3) float32 or float64; faces: (m, 3) int32 or int64,
    0-based indices into vertices (trimesh's and Open3D's conventions). Both
    are read in place when they are C-contiguous and in native byte order
    (a copy is made otherwise); other dtypes raise ValueError rather than
    being converted silently (use .astype()). Results come back in the
    input's dtypes, without a copy of the library's buffers.

What simplify() gives
    Every output vertex is an input vertex, its coordinates bit for bit
    (nothing is moved or interpolated: method §11), so per-vertex
    attributes travel bit for bit too. A closed manifold mesh stays closed
    with the same genus. Vertices no face uses are dropped. The output is
    the one `epsnet simplify` writes for the same mesh and options: the same
    vertices in the same order and the same faces, for any thread count.

Errors
    Every failure raises a subclass of epsnet.Error that is also the
    built-in kind: FormatError and ArgumentError are ValueErrors (a NaN
    coordinate, an index out of range or negative, a malformed file, a bad
    option), FileError is an OSError (a missing or unreadable file), and
    LimitError a MemoryError. The message is the library's: file, position
    and reason ("arrays: faces[12, 1] = -3 is not a vertex index (0 .. 99)").
    Ctrl-C during a call raises KeyboardInterrupt and leaves no output file.

Threads
    The GIL is released while the library works, so calls on several Python
    threads run at once. threads= sets the library's own worker threads per
    call (default: the processors the process may use).
"""
from __future__ import annotations

import dataclasses
import os
import warnings as _warnings
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np

from . import _epsnet, _options
from ._epsnet import (
    ArgumentError,
    Error,
    FileError,
    FormatError,
    InternalError,
    LimitError,
    UnsupportedError,
)

__version__ = "0.1.0"

__all__ = [
    "simplify",
    "simplify_file",
    "sample",
    "hausdorff",
    "read_mesh",
    "SimplifyInfo",
    "SampleInfo",
    "EpsnetWarning",
    "Error",
    "FormatError",
    "ArgumentError",
    "UnsupportedError",
    "FileError",
    "LimitError",
    "InternalError",
    "library_version",
]

Progress = Union[Callable[[int, int], Any], Any]


class EpsnetWarning(UserWarning):
    """What a run could not carry or did not do, said once (e.g. "3 vertices that no face uses are not in the output")."""


def library_version() -> str:
    """The version of the C library the extension links."""
    return _epsnet.version()


@dataclasses.dataclass(frozen=True)
class SimplifyInfo:
    """What a simplification did (the CLI's summary and --stats, as numbers).

    vertices_in, faces_in   the input's counts
    vertices, faces         the output's counts
    samples                 ε-net samples of the input (paper §4.1), locked vertices included
    skeleton_vertices       with a target: samples kept as the feature skeleton (docs/method.md §13)
    gaussian_vertices       the Gaussian sphere's vertices: the skeleton's density (4 f^2 + 2 at frequency f)
    skeleton_frequency      f, the sphere's geodesic frequency
    collapses               half-edge collapses done
    refused                 non-samples left because every collapse was refused, by rule:
                            {"link": topology, "normal": a face would turn past max_normal_dev,
                             "zero_area": ..., "duplicate": ...}
    samples_given_up        samples removed because the skeleton alone was over the target
    warnings                the run's warnings (also issued as EpsnetWarning)
    stats                   every statistic of the run (epsnet.h §6, epsnet_stats)
    """

    vertices_in: int
    faces_in: int
    vertices: int
    faces: int
    samples: int
    skeleton_vertices: int
    gaussian_vertices: int
    skeleton_frequency: int
    collapses: int
    refused: Dict[str, int]
    samples_given_up: int
    warnings: List[str]
    stats: Dict[str, Any]

    @classmethod
    def _from(cls, stats: Dict[str, Any], warnings: List[str]) -> "SimplifyInfo":
        g = stats["gaussian_vertices"]
        return cls(
            vertices_in=stats["vertices"],
            faces_in=stats["faces"],
            vertices=stats["output_vertices"],
            faces=stats["output_faces"],
            samples=stats["samples"],
            skeleton_vertices=stats["skeleton_vertices"],
            gaussian_vertices=g,
            skeleton_frequency=int(round(((g - 2) / 4) ** 0.5)) if g > 2 else 0,
            collapses=stats["collapses"],
            refused={
                "link": stats["refused_link"],
                "normal": stats["refused_normal"],
                "zero_area": stats["refused_zero_area"],
                "duplicate": stats["refused_duplicate"],
            },
            samples_given_up=stats["samples_given_up"],
            warnings=list(warnings),
            stats=dict(stats),
        )


@dataclasses.dataclass(frozen=True)
class SampleInfo:
    """What a classification found: samples, Gaussian vertices, and every statistic (stats)."""

    samples: int
    gaussian_vertices: int
    stats: Dict[str, Any]


# ---- arrays in ----

_ATTR_DTYPES = tuple(np.dtype(t) for t in (np.int8, np.uint8, np.int16, np.uint16, np.int32, np.uint32, np.float32, np.float64))


def _plain(a: np.ndarray) -> np.ndarray:
    """a as the extension reads it: native byte order, C-contiguous (a copy only when it is not)."""
    if not a.dtype.isnative:
        a = a.astype(a.dtype.newbyteorder("="))
    return np.ascontiguousarray(a)


def _vertices(vertices: Any, what: str = "vertices") -> np.ndarray:
    a = vertices if isinstance(vertices, np.ndarray) else np.asarray(vertices, dtype=np.float64)
    if a.dtype.kind != "f" or a.dtype.itemsize not in (4, 8):
        raise ValueError(f"{what} must be float32 or float64, not {a.dtype} (convert with .astype(np.float64))")
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{what} must have shape (n, 3), not {a.shape}")
    return _plain(a)


def _faces(faces: Any, what: str = "faces") -> np.ndarray:
    a = faces if isinstance(faces, np.ndarray) else np.asarray(faces, dtype=np.int64)
    if a.dtype.kind != "i" or a.dtype.itemsize not in (4, 8):
        raise ValueError(f"{what} must be int32 or int64, not {a.dtype} (convert with .astype(np.int64))")
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{what} must have shape (m, 3), not {a.shape}")
    return _plain(a)


def _surface(vertices: Any, faces: Any) -> Tuple[np.ndarray, np.ndarray]:
    v, f = _vertices(vertices), _faces(faces)
    if len(f) == 0:
        raise ValueError("faces is empty: there is no surface to work on")
    return v, f


def _attributes(attributes: Optional[Mapping[str, Any]], n: int) -> Tuple[Optional[Dict[str, np.ndarray]], List[str]]:
    """The columns as the extension takes them, and the names of those given as bool (returned as bool)."""
    if attributes is None:
        return None, []
    if not isinstance(attributes, Mapping):
        raise ValueError("attributes must be a dict of name -> (n,) array")
    columns: Dict[str, np.ndarray] = {}
    booleans = []
    for name, values in attributes.items():
        if not isinstance(name, str):
            raise ValueError(f"attribute names must be str, not {name!r}")
        a = np.asarray(values)
        if a.dtype == np.bool_:
            booleans.append(name)
            a = a.view(np.uint8)
        if a.dtype not in _ATTR_DTYPES:
            raise ValueError(
                f"attribute {name!r} is {a.dtype}; it must be bool, int8, uint8, int16, uint16, int32, uint32, "
                "float32 or float64 (the PLY types)"
            )
        if a.shape != (n,):
            raise ValueError(
                f"attribute {name!r} must have shape ({n},), one value per vertex, not {a.shape}"
                + (" (give each column its own name)" if a.ndim == 2 else "")
            )
        columns[name] = _plain(a)
    return columns, booleans


def _progress(progress: Optional[Progress]) -> Optional[Callable[[int, int], Any]]:
    """A callable(done, total), or a tqdm-like bar (update(), n, total) driven by one."""
    if progress is None:
        return None
    if hasattr(progress, "update") and hasattr(progress, "n"):
        bar = progress

        def report(done: int, total: int) -> None:
            if total and getattr(bar, "total", None) != total:
                bar.total = total
            if done > bar.n:
                bar.update(done - bar.n)

        return report
    if callable(progress):
        return progress
    raise ValueError("progress must be a callable(done, total) or a tqdm-like bar")


def _warn(messages: List[str]) -> None:
    for m in messages:
        _warnings.warn(m, EpsnetWarning, stacklevel=3)


# ---- the calls ----


def simplify(
    vertices: Any,
    faces: Any,
    *,
    ratio: Optional[float] = None,
    face_count: Optional[int] = None,
    vertex_count: Optional[int] = None,
    error: Optional[float] = None,
    level: Optional[int] = None,
    lock: Union[str, Any, None] = None,
    attributes: Optional[Mapping[str, Any]] = None,
    attribute_weights: Union[float, str, Mapping[str, float], None] = None,
    threads: Optional[int] = None,
    passes: Optional[int] = None,
    max_normal_dev: Optional[float] = None,
    seed: Optional[int] = None,
    rotation: Optional[str] = None,
    mem: Union[int, str, None] = None,
    slab: Optional[int] = None,
    tmpdir: Union[str, "os.PathLike[str]", None] = None,
    progress: Optional[Progress] = None,
    return_info: bool = False,
) -> Tuple[Any, ...]:
    """Simplify a triangle mesh held in arrays.

    Without a target, the ε-net method (paper §4.2): the samples of the
    Gaussian sphere at `level` are kept and every other vertex is removed by
    half-edge collapses, cheapest first by quadric error. With a target
    (`ratio`, `face_count` or `vertex_count`, and/or `error`), the samples
    are kept as a feature skeleton and collapses go on until the target is
    met (docs/method.md §13).

    vertices        (n, 3) float32 or float64
    faces           (m, 3) int32 or int64, counter-clockwise seen from outside
    ratio           keep round(ratio * m) faces, 0 < ratio <= 1
    face_count      keep at most this many faces (one less on a closed surface when odd)
    vertex_count    keep at most this many vertices
    error           no collapse whose error exceeds error * the bounding box diagonal
                    (area-weighted RMS distance to the input planes: meshoptimizer's target_error)
    level           the Gaussian sphere's subdivision (4^(level+1)+2 vertices; default 3).
                    With a target, giving it fixes the skeleton's density; otherwise the run
                    chooses it (a quarter of the vertices the target keeps)
    lock            vertices that must stay: the name of an attribute whose non-zero values
                    lock their vertex (as the CLI's --lock), or an (n,) bool array
    attributes      dict of name -> (n,) array (bool, int8 .. uint32, float32, float64):
                    per-vertex values that travel with their vertex, bit for bit
    attribute_weights  weigh attributes in the collapses' error (the CLI's
                    --attribute-weight, docs/method.md §9), so that a collapse that
                    slides the texture or bends the shading costs more: a dict of
                    attribute name -> weight, e.g. {"u": 1, "v": 1} ("uv" and "normal"
                    name texture_u/texture_v and nx/ny/nz), or one number for those.
                    At 1 an attribute error of 1 costs what a distance of the
                    bounding box diagonal does. Values stay the input's.
    threads         library worker threads, 0 or None = the processors the process may use; the output does not depend on it
    passes          ε-net passes without a target (default 1); max_normal_dev: refuse collapses
                    that turn a face by more than this many degrees (default 60)
    seed, rotation  the Gaussian sphere's orientation (a random one from seed, or
                    "identity", "AX,AY,AZ,DEG", "q:W,X,Y,Z"); default: the library's fixed one
    mem, slab       the memory budget ("2G" or bytes) and slab size, as the CLI's --mem, --slab
    tmpdir          folder for temporary files (large meshes, streamed targets); default $TMPDIR
    progress        callable(done, total) or a tqdm bar; raise in it to cancel
    return_info     also return a SimplifyInfo

    Returns (vertices, faces), then the attributes dict when `attributes` was
    given (the kept vertices' values, same dtypes), then the SimplifyInfo when
    `return_info` is set. Output dtypes are the input's.

    Raises ValueError (FormatError, ArgumentError) for bad arrays or options,
    including NaN coordinates and indices out of range; MemoryError
    (LimitError) when the budget is exceeded.
    """
    v, f = _surface(vertices, faces)
    columns, booleans = _attributes(attributes, len(v))
    lock_name: Optional[str] = None
    hidden: Optional[str] = None
    if isinstance(lock, str):
        if columns is None or lock not in columns:
            raise ValueError(f"lock {lock!r} is not one of the attributes given ({', '.join(columns or {}) or 'none'})")
        lock_name = lock
    elif lock is not None:
        mask = np.asarray(lock)
        if mask.shape != (len(v),):
            raise ValueError(f"lock must be an attribute name or an ({len(v)},) array, not shape {mask.shape}")
        columns = dict(columns or {})
        hidden = "lock"
        while hidden in columns:
            hidden = "_" + hidden
        columns[hidden] = _plain((mask != 0).astype(np.uint8))
        lock_name = hidden
    options = _options.simplify(
        ratio=ratio,
        face_count=face_count,
        vertex_count=vertex_count,
        error=error,
        level=level,
        lock=lock_name,
        passes=passes,
        max_normal_dev=max_normal_dev,
        attribute_weights=attribute_weights,
        tmpdir=tmpdir,
        threads=threads,
        seed=seed,
        rotation=rotation,
        mem=mem,
        slab=slab,
    )
    ov, of, oattrs, stats, messages = _epsnet.simplify(v, f, columns, options, _progress(progress))
    _warn(messages)
    result: Tuple[Any, ...] = (ov, of)
    if attributes is not None:
        oattrs.pop(hidden, None)
        for name in booleans:
            oattrs[name] = oattrs[name].view(np.bool_)
        result += ({name: oattrs[name] for name in attributes},)
    if return_info:
        result += (SimplifyInfo._from(stats, messages),)
    return result


def simplify_file(
    src: Union[str, "os.PathLike[str]"],
    dst: Union[str, "os.PathLike[str]"],
    *,
    ratio: Optional[float] = None,
    face_count: Optional[int] = None,
    vertex_count: Optional[int] = None,
    error: Optional[float] = None,
    level: Optional[int] = None,
    lock: Optional[str] = None,
    threads: Optional[int] = None,
    passes: Optional[int] = None,
    max_normal_dev: Optional[float] = None,
    drop_normals: bool = False,
    attribute_weights: Union[float, str, Mapping[str, float], None] = None,
    seed: Optional[int] = None,
    rotation: Optional[str] = None,
    mem: Union[int, str, None] = None,
    slab: Optional[int] = None,
    tmpdir: Union[str, "os.PathLike[str]", None] = None,
    progress: Optional[Progress] = None,
) -> SimplifyInfo:
    """Simplify the mesh file src into dst, out of core, exactly as `epsnet simplify src -o dst` does.

    Any readable format (PLY, OBJ, OFF, STL, SMA, SMB, .smz, each optionally
    .zst); dst's format follows its extension. The mesh is streamed: sorted
    in bounded memory when it is not a streaming mesh, then simplified slab
    by slab on every core, so memory stays near `mem` whatever the size.
    Per-vertex properties travel to dst bit for bit where its format holds
    them (a warning names those it cannot). dst appears only when complete:
    on any error, cancel or Ctrl-C nothing is left at dst.

    Options are simplify()'s, with lock naming a per-vertex property of the
    file, drop_normals as the CLI's --drop-normals (read no vertex
    normals, so a flat-shaded OBJ is one surface; dst gets normals
    recomputed from its faces when its format holds them) and
    attribute_weights naming the file's properties.

    progress: callable(done, total), called from the calling thread about
    ten times a second with the fraction of one bar for the whole run (the
    sort, the passes, a target's rounds); or a tqdm bar, e.g.

        with tqdm(total=1, unit_scale=True) as bar:
            epsnet.simplify_file("scan.ply", "small.ply", ratio=0.1, progress=bar)

    An exception raised in it cancels the run and propagates.

    Returns a SimplifyInfo. Raises FileError (an OSError) when src cannot be
    read or dst written, FormatError (a ValueError) for a malformed file.
    """
    options = _options.simplify(
        ratio=ratio,
        face_count=face_count,
        vertex_count=vertex_count,
        error=error,
        level=level,
        lock=lock,
        passes=passes,
        max_normal_dev=max_normal_dev,
        drop_normals=drop_normals,
        attribute_weights=attribute_weights,
        tmpdir=tmpdir,
        threads=threads,
        seed=seed,
        rotation=rotation,
        mem=mem,
        slab=slab,
    )
    stats, messages = _epsnet.simplify_file(os.fspath(src), os.fspath(dst), options, _progress(progress))
    _warn(messages)
    return SimplifyInfo._from(stats, messages)


def sample(
    vertices: Any,
    faces: Any,
    *,
    level: Optional[int] = None,
    frequency: Optional[int] = None,
    seed: Optional[int] = None,
    rotation: Optional[str] = None,
    threads: Optional[int] = None,
    return_info: bool = False,
) -> Tuple[Any, ...]:
    """The ε-net samples of a mesh (paper §4.1): the vertices a simplification keeps.

    A vertex is a sample when the spherical polygon of its face normals winds
    around a vertex of the Gaussian sphere (level: 4^(level+1)+2 vertices,
    default 3; or frequency f: 4 f^2 + 2). Boundary and non-manifold
    vertices are samples too (locked).

    Returns (indices, gaussian_vertex): the samples' indices into vertices
    (int64, increasing) and, for each, the Gaussian vertex it covers (int32,
    -1 for locked vertices and needle tips); then a SampleInfo with
    return_info. The whole mesh is classified in memory (one slab).
    """
    v, f = _surface(vertices, faces)
    options = _options.method(level=level, frequency=frequency, seed=seed, rotation=rotation, threads=threads)
    flags, gvertex, stats = _epsnet.sample(v, f, options)
    indices = np.flatnonzero(flags)
    result: Tuple[Any, ...] = (indices, gvertex[indices])
    if return_info:
        result += (SampleInfo(samples=stats["samples"], gaussian_vertices=stats["gaussian_vertices"], stats=stats),)
    return result


def hausdorff(
    a: Tuple[Any, Any],
    b: Tuple[Any, Any],
    *,
    samples_per_face: int = 10,
    seed: int = 1,
    threads: Optional[int] = None,
) -> Dict[str, Any]:
    """The Metro-style distance between meshes a and b, each a (vertices, faces) pair (`epsnet hausdorff`).

    Each mesh is sampled (its vertices, points along its edges, and
    samples_per_face stratified points per face on average, by area) and
    every sample measured against the other surface exactly. Returns a dict:

        hausdorff, hausdorff_relative   the symmetric distance, and over the diagonal
        diagonal                        of a's bounding box
        a_to_b, b_to_a                  each side: max, mean, rms (area-weighted), their
                                        *_relative, samples, normal_max_deg, normal_mean_deg
                                        (normal deviation, paper §3.2), normal_samples, area
        a, b                            vertices, faces, zero_area_faces

    The numbers depend only on the meshes, samples_per_face and seed, never
    on threads.
    """
    if not (isinstance(a, tuple) and isinstance(b, tuple) and len(a) == 2 and len(b) == 2):
        raise ValueError("a and b must each be a (vertices, faces) pair")
    if isinstance(samples_per_face, bool) or not isinstance(samples_per_face, int) or not 1 <= samples_per_face <= 100000:
        raise ValueError(f"samples_per_face must be an integer in 1 .. 100000, not {samples_per_face!r}")
    if threads is not None and (not isinstance(threads, int) or threads < 0):
        raise ValueError(f"threads must be 0 (the processors the process may use) or a positive integer, not {threads!r}")
    va, fa = _vertices(a[0], "a's vertices"), _faces(a[1], "a's faces")
    vb, fb = _vertices(b[0], "b's vertices"), _faces(b[1], "b's faces")
    return _epsnet.hausdorff(va, fa, vb, fb, samples_per_face, int(seed), threads or 0)


def read_mesh(path: Union[str, "os.PathLike[str]"]) -> Tuple[np.ndarray, np.ndarray, Dict[str, np.ndarray]]:
    """Read a mesh file with the library's reader: (vertices, faces, attributes).

    Any readable format, optionally .zst. vertices are float32 when the file
    stores float32 (bit for bit), else float64; faces int64 (polygons
    triangulated as the library does); attributes the per-vertex properties
    as (n,) arrays of their file types. An OBJ with vt/vn gives one vertex
    per distinct corner (docs/architecture.md §13), as every epsnet command
    reads it.
    """
    return _epsnet.read_mesh(os.fspath(path))
