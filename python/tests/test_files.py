"""simplify_file() is the CLI's run: same bytes; progress fits tqdm; a cancel or Ctrl-C leaves nothing."""
import os
import signal
import subprocess

import numpy as np
import pytest

import epsnet


class Bar:
    """The part of tqdm's protocol simplify_file drives: n, total, update()."""

    def __init__(self):
        self.n, self.total, self.updates = 0, None, 0

    def update(self, k):
        assert k > 0
        self.n += k
        self.updates += 1


def test_the_output_file_is_the_clis_to_the_byte(cli, gen_mesh, tmp_path):
    src = gen_mesh("bumpy", 20000)
    subprocess.run([cli, "simplify", str(src), "-o", str(tmp_path / "cli.ply"), "--ratio", "0.1", "-q"], check=True)
    info = epsnet.simplify_file(src, tmp_path / "py.ply", ratio=0.1, threads=1)
    assert (tmp_path / "cli.ply").read_bytes() == (tmp_path / "py.ply").read_bytes()
    assert isinstance(info, epsnet.SimplifyInfo) and info.faces in (round(0.1 * info.faces_in), round(0.1 * info.faces_in) - 1)


def test_progress_moves_forward_to_the_end_as_a_callable_and_as_a_tqdm_bar(gen_mesh, tmp_path):
    src = gen_mesh("bumpy", 200000)
    seen = []
    epsnet.simplify_file(src, tmp_path / "a.ply", ratio=0.1, slab=4096, progress=lambda d, t: seen.append((d, t)))
    assert len(seen) >= 2
    assert all(0 <= d <= t for d, t in seen)
    done = [d / t for d, t in seen]
    assert done == sorted(done), "the bar never moves back"
    bar = Bar()
    epsnet.simplify_file(src, tmp_path / "b.ply", progress=bar)
    assert bar.updates >= 1 and bar.total and 0 < bar.n <= bar.total


def test_an_exception_in_progress_cancels_and_leaves_no_file(gen_mesh, tmp_path):
    src = gen_mesh("bumpy", 200000)

    class Stop(Exception):
        pass

    def stop(done, total):
        raise Stop(f"at {done} of {total}")

    before = set(os.listdir(tmp_path))
    with pytest.raises(Stop):
        epsnet.simplify_file(src, tmp_path / "out.ply", ratio=0.1, slab=4096, tmpdir=tmp_path, progress=stop)
    assert set(os.listdir(tmp_path)) == before, "no output and no temporary file"


def test_ctrl_c_raises_keyboard_interrupt_and_leaves_no_file(gen_mesh, tmp_path):
    src = gen_mesh("bumpy", 200000)
    sent = []

    def interrupt(done, total):
        if not sent:
            sent.append(done)
            os.kill(os.getpid(), signal.SIGINT)  # as Ctrl-C in a terminal

    with pytest.raises(KeyboardInterrupt):
        epsnet.simplify_file(src, tmp_path / "out.ply", progress=interrupt)
    assert sent and not (tmp_path / "out.ply").exists()
    assert os.listdir(tmp_path) == []
    v, f, _ = epsnet.read_mesh(src)
    sent.clear()
    with pytest.raises(KeyboardInterrupt):
        epsnet.simplify(v, f, progress=interrupt)


def test_hausdorff_is_the_clis_report(cli, gen_mesh, tmp_path):
    src = gen_mesh("bumpy", 8000)
    v, f, _ = epsnet.read_mesh(src)
    sv, sf = epsnet.simplify(v, f, ratio=0.1)
    epsnet.simplify_file(src, tmp_path / "s.ply", ratio=0.1)
    subprocess.run([cli, "hausdorff", str(src), str(tmp_path / "s.ply"), "--json", str(tmp_path / "h.json")],
                   check=True, capture_output=True)
    import json

    ref = json.loads((tmp_path / "h.json").read_text())
    got = epsnet.hausdorff((v, f), (sv, sf))
    assert got["hausdorff"] == ref["hausdorff"] and got["diagonal"] == ref["diagonal"]
    assert got["a_to_b"]["mean"] == ref["a_to_b"]["mean"] and got["b_to_a"]["rms"] == ref["b_to_a"]["rms"]
    assert got["b"]["faces"] == len(sf) and got["a"]["faces"] == len(f)
    assert 0 < got["hausdorff_relative"] < 0.05
    same = epsnet.hausdorff((v, f), (v, f), threads=1)
    assert same["hausdorff_relative"] < 1e-12 and same["a_to_b"]["normal_max_deg"] < 1e-6


def test_sample_gives_the_clis_flags(cli, gen_mesh, tmp_path):
    src = gen_mesh("bumpy", 8000)
    subprocess.run([cli, "sample", "--mesh", str(src), "-o", str(tmp_path / "m.ply"), "-q"], check=True)
    _, _, flags = epsnet.read_mesh(tmp_path / "m.ply")
    v, f, _ = epsnet.read_mesh(src)
    idx, gv, info = epsnet.sample(v, f, return_info=True)
    assert np.array_equal(idx, np.flatnonzero(flags["sample"]))
    assert np.array_equal(gv, flags["gvertex"][idx])
    assert info.samples == len(idx) and info.gaussian_vertices == 258
    assert (gv >= -1).all() and (gv < 258).all()
    coarse, _ = epsnet.sample(v, f, level=1)
    assert len(coarse) < len(idx)
