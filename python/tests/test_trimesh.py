"""epsnet.trimesh works with trimesh when it is installed, and epsnet never needs it."""
import importlib.util
import subprocess
import sys

import numpy as np
import pytest

import epsnet
import epsnet.trimesh

from conftest import square


def test_epsnet_imports_and_works_without_trimesh():
    code = ("import sys; sys.modules['trimesh'] = None\n"
            "import epsnet, epsnet.trimesh, numpy as np\n"
            "v = np.array([[0,0,0],[1,0,0],[0,1,0],[0,0,1]], float); f = np.array([[0,2,1],[0,1,3],[0,3,2],[1,2,3]])\n"
            "assert len(epsnet.simplify(v, f)[1]) == 4\n"
            "try:\n    epsnet.trimesh.simplify(None)\nexcept ImportError as e:\n    print(e)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert "needs the trimesh package" in out


@pytest.mark.skipif(importlib.util.find_spec("trimesh") is None, reason="trimesh is not installed")
def test_a_trimesh_in_gives_a_trimesh_out_with_its_colours(gen_mesh):
    import trimesh

    v, f, _ = epsnet.read_mesh(gen_mesh("bumpy", 8000))
    colours = np.random.default_rng(1).integers(0, 256, (len(v), 4), dtype=np.uint8)
    mesh = trimesh.Trimesh(vertices=v.astype(np.float64), faces=f, vertex_colors=colours, process=False)
    small = epsnet.trimesh.simplify(mesh, ratio=0.1)
    ref_v, ref_f = epsnet.simplify(v.astype(np.float64), f, ratio=0.1)
    assert isinstance(small, trimesh.Trimesh)
    assert np.array_equal(small.vertices, ref_v) and np.array_equal(small.faces, ref_f)
    assert epsnet.trimesh.hausdorff(mesh, small)["hausdorff"] > 0
