"""trimesh interop: epsnet on trimesh.Trimesh objects, when trimesh is installed.

epsnet never needs trimesh; these functions import it when they are called
and raise ImportError with a clear message when it is absent.

    import trimesh, epsnet.trimesh
    small = epsnet.trimesh.simplify(trimesh.load("scan.ply"), ratio=0.1)

Vertex colours (mesh.visual.vertex_colors, when the visual is per vertex)
travel bit for bit, as the columns red, green, blue, alpha.
"""
from __future__ import annotations

from typing import Any, Dict

import numpy as np

import epsnet

_COLOURS = ("red", "green", "blue", "alpha")


def _trimesh() -> Any:
    try:
        import trimesh
    except ImportError as e:
        raise ImportError("epsnet.trimesh needs the trimesh package; epsnet itself does not") from e
    return trimesh


def simplify(mesh: Any, **options: Any) -> Any:
    """epsnet.simplify() on a trimesh.Trimesh; returns a new Trimesh (the input is not changed).

    options are epsnet.simplify()'s (ratio, face_count, error, level, ...);
    return_info is not one of them: use epsnet.simplify() for the info.
    """
    trimesh = _trimesh()
    if options.pop("return_info", False):
        raise ValueError("epsnet.trimesh.simplify returns a Trimesh; call epsnet.simplify for the info")
    attributes: Dict[str, np.ndarray] = dict(options.pop("attributes", None) or {})
    coloured = getattr(mesh.visual, "kind", None) == "vertex"
    if coloured:
        colours = np.asarray(mesh.visual.vertex_colors, dtype=np.uint8)
        for k, name in enumerate(_COLOURS[: colours.shape[1]]):
            attributes[name] = colours[:, k]
    result = epsnet.simplify(
        np.asarray(mesh.vertices), np.asarray(mesh.faces), attributes=attributes or None, **options
    )
    v, f = result[0], result[1]
    out = trimesh.Trimesh(vertices=v, faces=f, process=False)
    if coloured:
        kept = result[2]
        out.visual.vertex_colors = np.stack([kept[n] for n in _COLOURS if n in kept], axis=1)
    return out


def hausdorff(a: Any, b: Any, **options: Any) -> Dict[str, Any]:
    """epsnet.hausdorff() between two trimesh.Trimesh objects."""
    _trimesh()
    return epsnet.hausdorff(
        (np.asarray(a.vertices), np.asarray(a.faces)), (np.asarray(b.vertices), np.asarray(b.faces)), **options
    )
