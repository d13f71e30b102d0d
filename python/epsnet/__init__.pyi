# Type stubs of the public API (the manual is in the docstrings of __init__.py).
import os
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np

from ._epsnet import (
    ArgumentError as ArgumentError,
    Error as Error,
    FileError as FileError,
    FormatError as FormatError,
    InternalError as InternalError,
    LimitError as LimitError,
    UnsupportedError as UnsupportedError,
)

__version__: str
_Path = Union[str, "os.PathLike[str]"]
Progress = Union[Callable[[int, int], Any], Any]

class EpsnetWarning(UserWarning): ...

class SimplifyInfo:
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

class SampleInfo:
    samples: int
    gaussian_vertices: int
    stats: Dict[str, Any]

def library_version() -> str: ...
def simplify(
    vertices: Any,
    faces: Any,
    *,
    ratio: Optional[float] = ...,
    face_count: Optional[int] = ...,
    vertex_count: Optional[int] = ...,
    error: Optional[float] = ...,
    level: Optional[int] = ...,
    lock: Union[str, Any, None] = ...,
    attributes: Optional[Mapping[str, Any]] = ...,
    attribute_weights: Union[float, str, Mapping[str, float], None] = ...,
    threads: Optional[int] = ...,
    passes: Optional[int] = ...,
    max_normal_dev: Optional[float] = ...,
    seed: Optional[int] = ...,
    rotation: Optional[str] = ...,
    mem: Union[int, str, None] = ...,
    slab: Optional[int] = ...,
    tmpdir: Optional[_Path] = ...,
    progress: Optional[Progress] = ...,
    return_info: bool = ...,
) -> Tuple[Any, ...]: ...
def simplify_file(
    src: _Path,
    dst: _Path,
    *,
    ratio: Optional[float] = ...,
    face_count: Optional[int] = ...,
    vertex_count: Optional[int] = ...,
    error: Optional[float] = ...,
    level: Optional[int] = ...,
    lock: Optional[str] = ...,
    threads: Optional[int] = ...,
    passes: Optional[int] = ...,
    max_normal_dev: Optional[float] = ...,
    drop_normals: bool = ...,
    attribute_weights: Union[float, str, Mapping[str, float], None] = ...,
    seed: Optional[int] = ...,
    rotation: Optional[str] = ...,
    mem: Union[int, str, None] = ...,
    slab: Optional[int] = ...,
    tmpdir: Optional[_Path] = ...,
    progress: Optional[Progress] = ...,
) -> SimplifyInfo: ...
def sample(
    vertices: Any,
    faces: Any,
    *,
    level: Optional[int] = ...,
    frequency: Optional[int] = ...,
    seed: Optional[int] = ...,
    rotation: Optional[str] = ...,
    threads: Optional[int] = ...,
    return_info: bool = ...,
) -> Tuple[Any, ...]: ...
def hausdorff(
    a: Tuple[Any, Any], b: Tuple[Any, Any], *, samples_per_face: int = ..., seed: int = ..., threads: Optional[int] = ...
) -> Dict[str, Any]: ...
def read_mesh(path: _Path) -> Tuple[np.ndarray, np.ndarray, Dict[str, np.ndarray]]: ...
