"""Keyword options -> the option dict the extension reads (python/src/settings.c).

One place turns the Python names into the library's settings (epsnet.h §6),
so that simplify(), simplify_file() and sample() spell them the same way.
"""
from __future__ import annotations

import math
import numbers
import os
from typing import Any, Dict, Mapping, Optional, Union

_SUFFIX = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}


def _size(value: Union[int, str, None]) -> Optional[int]:
    """A byte count: an int, or a str such as "512M" (K, M, G, T are powers of 1024, as the CLI)."""
    if value is None:
        return None
    if isinstance(value, bool):
        raise ValueError("mem must be a size in bytes, not a bool")
    if isinstance(value, numbers.Integral):
        if value < 0:
            raise ValueError("mem must not be negative")
        return int(value)
    if isinstance(value, str):
        text = value.strip().upper().removesuffix("IB").removesuffix("B")
        unit = text[-1:] if text[-1:] in _SUFFIX else ""
        number = text[: len(text) - len(unit)]
        try:
            amount = float(number)
        except ValueError:
            amount = -1.0
        if not amount >= 0:
            raise ValueError(f"mem {value!r} is not a size such as 4096, 512M or 1.5G")
        return int(amount * _SUFFIX[unit])
    raise ValueError(f"mem must be an int or a str such as '512M', not {type(value).__name__}")


def _count(name: str, value: Any) -> Optional[int]:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise ValueError(f"{name} must be a positive integer, not {value!r}")
    return int(value)


def _number(name: str, value: Any) -> Optional[float]:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a number, not {value!r}")
    return float(value)


def method(
    *,
    level: Optional[int] = None,
    frequency: Optional[int] = None,
    rotation: Optional[str] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    mem: Union[int, str, None] = None,
    slab: Optional[int] = None,
) -> Dict[str, Any]:
    """The options every job shares (the CLI's method options)."""
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, numbers.Integral) or threads < 0):
        raise ValueError(f"threads must be 0 (the processors the process may use) or a positive integer, not {threads!r}")
    if seed is not None and rotation is not None:
        raise ValueError("give seed or rotation, not both")
    return {
        "level": level,
        "frequency": _count("frequency", frequency),
        "rotation": rotation,
        "seed": seed,
        "threads": threads,
        "mem": _size(mem),
        "slab_vertices": _count("slab", slab),
    }


def _weights(w: Union[float, str, Mapping[str, float], None]) -> Optional[str]:
    """attribute_weights as the CLI's --attribute-weight list: a number
    (texture coordinates and normals), a dict of name -> weight (names:
    "uv", "normal", or a per-vertex attribute), or the list itself."""
    if w is None or isinstance(w, str):
        return w
    if isinstance(w, Mapping):
        items = []
        for name, x in w.items():
            if not isinstance(name, str) or not name or "," in name or "=" in name:
                raise ValueError(f"attribute_weights: {name!r} is not an attribute name")
            items.append(f"{name}={_weight(name, x)!r}")
        return ",".join(items) or None
    return repr(_weight("attribute_weights", w))


def _weight(name: str, x: Any) -> float:
    if isinstance(x, bool) or not isinstance(x, numbers.Real) or not math.isfinite(float(x)) or x < 0:
        raise ValueError(f"attribute_weights: the weight of {name} must be a number, 0 or more, not {x!r}")
    return float(x)


def simplify(
    *,
    ratio: Optional[float] = None,
    face_count: Optional[int] = None,
    vertex_count: Optional[int] = None,
    error: Optional[float] = None,
    level: Optional[int] = None,
    lock: Optional[str] = None,
    passes: Optional[int] = None,
    max_normal_dev: Optional[float] = None,
    drop_normals: bool = False,
    attribute_weights: Union[float, str, Mapping[str, float], None] = None,
    tmpdir: Union[str, "os.PathLike[str]", None] = None,
    **method_options: Any,
) -> Dict[str, Any]:
    """simplify()'s options: a target (at most one count, with or without error) and the method."""
    given = [n for n, v in (("ratio", ratio), ("face_count", face_count), ("vertex_count", vertex_count)) if v is not None]
    if len(given) > 1:
        raise ValueError(f"give at most one of ratio, face_count and vertex_count, not {' and '.join(given)}")
    ratio = _number("ratio", ratio)
    if ratio is not None and not 0 < ratio <= 1:
        raise ValueError(f"ratio must be in (0, 1], not {ratio!r}")
    error = _number("error", error)
    if error is not None and not error > 0:
        raise ValueError(f"error must be positive, not {error!r}")
    target = bool(given) or error is not None
    options = method(level=level, **method_options)
    options.update(
        {
            "target_ratio": ratio,
            "target_faces": _count("face_count", face_count),
            "target_vertices": _count("vertex_count", vertex_count),
            "target_error": error,
            # note: with a target, a level given fixes the skeleton's density;
            # without one the run chooses it (epsnet.h §6), as the CLI's --level
            "target_level_given": 1 if target and (level is not None or options["frequency"] is not None) else None,
            "lock_property": lock,
            "passes": _count("passes", passes),
            "max_normal_dev": _number("max_normal_dev", max_normal_dev),
            "drop_normals": 1 if drop_normals else None,
            "attribute_weights": _weights(attribute_weights),
            "tmpdir": os.fspath(tmpdir) if tmpdir is not None else None,
        }
    )
    return options
