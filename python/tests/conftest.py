"""Shared fixtures: the CLI and the shared scans, found as the meson tests find them.

EPSNET_BIN is the built `epsnet` program (meson sets it; else build-*/tools/epsnet
beside the checkout), EPSNET_SHARED_DATA the folder of real scans (else
../shared/data beside the checkout). Tests that need either skip without it.
"""
import glob
import os
import pathlib

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _cli():
    path = os.environ.get("EPSNET_BIN")
    if path and os.access(path, os.X_OK):
        return path
    for path in sorted(glob.glob(str(ROOT / "build*" / "tools" / "epsnet"))):
        if os.access(path, os.X_OK):
            return path
    return None


@pytest.fixture(scope="session")
def cli():
    path = _cli()
    if not path:
        pytest.skip("the epsnet program is not built (EPSNET_BIN)")
    return path


def shared_data():
    d = os.environ.get("EPSNET_SHARED_DATA") or str(ROOT.parent / "shared" / "data")
    return d if os.path.isdir(d) else None


@pytest.fixture(scope="session")
def gen_mesh(tmp_path_factory, cli):
    """gen_mesh(shape, faces, shuffle=True) -> the path of a generated PLY (cached)."""
    import subprocess

    made = {}
    folder = tmp_path_factory.mktemp("gen")

    def make(shape="bumpy", faces=20000, shuffle=True, seed=7):
        key = (shape, faces, shuffle, seed)
        if key not in made:
            path = folder / f"{shape}_{faces}_{int(shuffle)}_{seed}.ply"
            args = [cli, "gen", shape, "--faces", str(faces), "--seed", str(seed), "-o", str(path)]
            subprocess.run(args + (["--shuffle"] if shuffle else []), check=True, capture_output=True)
            made[key] = path
        return made[key]

    return make


def square():
    """Two triangles:

        3 ---- 2
        | \\    |
        |   \\  |
        0 ---- 1
    """
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float64)
    f = np.array([[0, 1, 3], [1, 2, 3]], dtype=np.int64)
    return v, f
