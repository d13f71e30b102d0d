"""simplify() gives the CLI's output, keeps attributes bit for bit, respects locks, and runs in threads."""
import json
import os
import subprocess
import threading

import numpy as np
import pytest

import epsnet

from conftest import shared_data

SCANS = sorted(f for f in os.listdir(shared_data()) if f.endswith((".ply.zst", ".obj.zst"))) if shared_data() else []


def cli_simplify(cli, src, dst, *options):
    subprocess.run([cli, "simplify", str(src), "-o", str(dst), "-q", *options], check=True, capture_output=True)
    return epsnet.read_mesh(dst)


def check_same_as_cli(cli, src, tmp_path, options, kwargs):
    v, f, attrs = epsnet.read_mesh(src)
    ref_v, ref_f, ref_attrs = cli_simplify(cli, src, tmp_path / "cli.ply", *options)
    got_v, got_f, got_attrs = epsnet.simplify(v, f, attributes=attrs, **kwargs)
    assert got_v.dtype == v.dtype and got_f.dtype == f.dtype
    assert got_v.shape == ref_v.shape and got_f.shape == ref_f.shape
    assert np.array_equal(got_v, ref_v), "the same vertices in the same order"
    assert np.array_equal(got_f, ref_f), "the same faces"
    assert sorted(got_attrs) == sorted(ref_attrs)
    for name in ref_attrs:
        assert got_attrs[name].tobytes() == ref_attrs[name].tobytes()
    # without the attribute columns the mesh is the same
    plain_v, plain_f = epsnet.simplify(v, f, **kwargs)
    assert np.array_equal(plain_v, ref_v) and np.array_equal(plain_f, ref_f)


@pytest.mark.parametrize("scan", SCANS or [pytest.param(None, marks=pytest.mark.skip("no shared data"))])
@pytest.mark.parametrize("mode", ["default", "ratio_0.1"])
def test_arrays_give_the_clis_output_mesh_on_the_shared_scans(cli, scan, mode, tmp_path):
    options, kwargs = ([], {}) if mode == "default" else (["--ratio", "0.1"], {"ratio": 0.1})
    check_same_as_cli(cli, os.path.join(shared_data(), scan), tmp_path, options, kwargs)


@pytest.mark.parametrize(
    "options,kwargs",
    [([], {}), (["--ratio", "0.1"], {"ratio": 0.1}), (["--faces", "3000", "--slab", "1024"], {"face_count": 3000, "slab": 1024}),
     (["--error", "0.002", "--level", "2"], {"error": 0.002, "level": 2}), (["--passes", "2", "--seed", "5"], {"passes": 2, "seed": 5})],
    ids=["default", "ratio", "faces_on_slabs", "error_level", "passes_seed"],
)
def test_arrays_give_the_clis_output_mesh_on_a_generated_scan(cli, gen_mesh, tmp_path, options, kwargs):
    check_same_as_cli(cli, gen_mesh("bumpy", 20000), tmp_path, options, kwargs)


def test_float64_and_int32_inputs_give_the_same_mesh_in_their_dtypes(gen_mesh):
    v, f, _ = epsnet.read_mesh(gen_mesh("bumpy", 6000))
    v32, f64 = epsnet.simplify(v, f, ratio=0.2)
    v64, f32 = epsnet.simplify(v.astype(np.float64), f.astype(np.int32), ratio=0.2)
    assert v64.dtype == np.float64 and f32.dtype == np.int32
    assert np.array_equal(v64, v32.astype(np.float64)) and np.array_equal(f32, f64)


def test_attributes_travel_bit_for_bit_with_their_vertex(gen_mesh):
    v, f, _ = epsnet.read_mesh(gen_mesh("bumpy", 8000))
    n = len(v)
    rng = np.random.default_rng(3)
    bits = rng.integers(0, 2**63, n, dtype=np.uint64)
    bits[::7] = 0x7FF8DEADBEEF0001  # NaNs with payloads must keep them
    attrs = {
        "id": np.arange(n, dtype=np.uint32),
        "q": bits.view(np.float64),
        "flag": rng.integers(0, 2, n).astype(bool),
        "small": rng.integers(-128, 128, n).astype(np.int8),
    }
    ov, of, oa = epsnet.simplify(v, f, attributes=attrs, ratio=0.1)
    assert list(oa) == list(attrs)
    idx = oa["id"].astype(np.int64)
    assert len(np.unique(idx)) == len(idx) and len(idx) == len(ov)
    assert np.array_equal(ov, v[idx]), "every output vertex is its input vertex"
    assert oa["q"].view(np.uint64).tobytes() == bits[idx].tobytes()
    assert oa["flag"].dtype == np.bool_ and np.array_equal(oa["flag"], attrs["flag"][idx])
    assert np.array_equal(oa["small"], attrs["small"][idx])


def seam_sphere(gen_mesh):
    """A bumpy sphere whose u is the longitude and v the height, split as
    trimesh splits a textured mesh: a face across the date line takes u + 1
    on its corners west of it, and a vertex used that way gets a copy.
    Returns the arrays and each vertex's key (input vertex * 2 + shifted)."""
    v, f, _ = epsnet.read_mesh(gen_mesh("bumpy", 8000, shuffle=False))
    lon = np.arctan2(v[:, 1], v[:, 0]) / (2 * np.pi) + 0.5
    u_corner = lon[f]
    across = u_corner.max(axis=1) - u_corner.min(axis=1) > 0.5
    shifted = across[:, None] & (u_corner < 0.5)
    key = f.astype(np.int64) * 2 + shifted
    uniq, inverse = np.unique(key.ravel(), return_inverse=True)
    src = uniq // 2
    uu = (lon[src] + (uniq % 2)).astype(np.float32)
    vv = (v[src, 2] * 0.5 + 0.5).astype(np.float32)
    return v[src], inverse.reshape(f.shape).astype(np.int64), uu, vv, uniq


def test_a_uv_seam_split_as_trimesh_splits_it_simplifies_along_its_length(gen_mesh):
    """Arrays from a textured mesh (trimesh, a glTF loader) repeat a vertex
    for each texture coordinate it has: two copies along a seam. They
    collapse along the seam together, so the size is met, every output
    vertex is an input vertex with its own (u, v), and no face stretches
    across the texture (docs/method.md §6)."""
    vs, fs, uu, vv, uniq = seam_sphere(gen_mesh)
    seam = int((uniq % 2).sum())
    assert seam > 20, "the test mesh has no seam"
    goal = round(0.1 * len(fs))
    ov, of, oa = epsnet.simplify(vs, fs, attributes={"texture_u": uu, "texture_v": vv}, ratio=0.1)
    assert abs(len(of) - goal) <= max(1, goal // 200), (len(of), goal)
    record = {(tuple(p), a, b): i for i, (p, a, b) in enumerate(zip(vs.tolist(), uu.tolist(), vv.tolist()))}
    kept_copies = 0
    for p, a, b in zip(ov.tolist(), oa["texture_u"].tolist(), oa["texture_v"].tolist()):
        i = record.get((tuple(p), a, b))
        assert i is not None, "an output vertex that is no input vertex"
        kept_copies += int(uniq[i] % 2)
    spread = oa["texture_u"][of].max(axis=1) - oa["texture_u"][of].min(axis=1)
    assert spread.max() < 0.75, "a face stretches across the seam"
    assert 0 < kept_copies < seam, (kept_copies, seam)


def texture_slide(v, f, u, w):
    """Area-weighted RMS distance, at points inside each face, between the
    (u, v) the face interpolates and the longitude and height of the point
    itself: how far the texture slid. Away from the poles."""
    bary = np.array([[1 / 3, 1 / 3, 1 / 3], [2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]])
    p = v[f].astype(np.float64)
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    q = np.einsum("kc,fcd->fkd", bary, p)
    iu = bary @ u[f].T.astype(np.float64)
    iv = bary @ w[f].T.astype(np.float64)
    lon = np.arctan2(q[..., 1], q[..., 0]) / (2 * np.pi) + 0.5
    lon += np.round(iu.T - lon)
    d2 = (iu.T - lon) ** 2 + (iv.T - (q[..., 2] * 0.5 + 0.5)) ** 2
    keep = q[..., 0] ** 2 + q[..., 1] ** 2 > 0.04
    wgt = np.broadcast_to(area[:, None], d2.shape) * keep
    return float(np.sqrt((d2 * wgt).sum() / wgt.sum()))


def test_attribute_weights_keep_the_texture_in_place(gen_mesh):
    """attribute_weights (the CLI's --attribute-weight): at the same size
    the texture slides less over the surface, every output vertex is still
    an input vertex, and a dict, a number and the CLI's list agree."""
    vs, fs, uu, vv, _ = seam_sphere(gen_mesh)
    attrs = {"texture_u": uu, "texture_v": vv}
    goal = round(0.1 * len(fs))
    ov, of, oa = epsnet.simplify(vs, fs, attributes=attrs, ratio=0.1)
    plain = texture_slide(ov, of, oa["texture_u"], oa["texture_v"])
    runs = [epsnet.simplify(vs, fs, attributes=attrs, ratio=0.1, attribute_weights=w)
            for w in ({"texture_u": 1, "texture_v": 1}, 1, "uv=1", {"uv": 1.0})]
    for wv, wf, wa in runs[1:]:
        assert np.array_equal(wv, runs[0][0]) and np.array_equal(wf, runs[0][1])
    wv, wf, wa = runs[0]
    assert abs(len(wf) - goal) <= 1, (len(wf), goal)
    record = {(tuple(p), a, b) for p, a, b in zip(vs.tolist(), uu.tolist(), vv.tolist())}
    assert all((tuple(p), a, b) in record for p, a, b in zip(wv.tolist(), wa["texture_u"].tolist(), wa["texture_v"].tolist()))
    weighed = texture_slide(wv, wf, wa["texture_u"], wa["texture_v"])
    assert weighed < 0.7 * plain, (weighed, plain)
    for bad in ({"nosuch": 1}, {"texture_u": -1}, {"uv": float("nan")}, "uv=x", -2, {"": 1}):
        with pytest.raises(ValueError):
            epsnet.simplify(vs, fs, attributes=attrs, ratio=0.1, attribute_weights=bad)


def test_locked_vertices_all_stay(gen_mesh):
    v, f, _ = epsnet.read_mesh(gen_mesh("bumpy", 8000))
    n = len(v)
    locked = np.zeros(n, dtype=bool)
    locked[np.random.default_rng(5).choice(n, 200, replace=False)] = True
    ids = {"id": np.arange(n, dtype=np.uint32)}
    _, _, oa = epsnet.simplify(v, f, attributes=ids, ratio=0.05, lock=locked)
    assert list(oa) == ["id"], "the mask's column is not returned"
    kept = np.zeros(n, dtype=bool)
    kept[oa["id"]] = True
    assert kept[locked].all()
    _, _, free = epsnet.simplify(v, f, attributes=ids, ratio=0.05)
    assert not np.isin(np.flatnonzero(locked), free["id"]).all(), "without the lock some of them go"
    # by name, as the CLI's --lock: the same vertices stay
    named = dict(ids, keep=locked.astype(np.uint8))
    _, _, by_name = epsnet.simplify(v, f, attributes=named, ratio=0.05, lock="keep")
    assert set(np.flatnonzero(locked)) <= set(by_name["id"].tolist())


def test_two_python_threads_simplifying_at_once_give_what_one_gives(gen_mesh):
    a = epsnet.read_mesh(gen_mesh("bumpy", 30000, seed=1))[:2]
    b = epsnet.read_mesh(gen_mesh("bumpy", 30000, seed=2))[:2]
    alone = [epsnet.simplify(*a, ratio=0.1, threads=1), epsnet.simplify(*b)]
    results = [None, None]
    started = threading.Barrier(2)

    def run(i, mesh, kwargs):
        started.wait()
        for _ in range(3):
            results[i] = epsnet.simplify(*mesh, **kwargs)

    threads = [threading.Thread(target=run, args=(0, a, {"ratio": 0.1, "threads": 2})),
               threading.Thread(target=run, args=(1, b, {"threads": 2}))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for got, ref in zip(results, alone):
        assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])


def test_info_reports_the_run(gen_mesh):
    v, f, _ = epsnet.read_mesh(gen_mesh("bumpy", 8000))
    ov, of, info = epsnet.simplify(v, f, ratio=0.1, return_info=True)
    assert isinstance(info, epsnet.SimplifyInfo)
    assert (info.vertices_in, info.faces_in, info.vertices, info.faces) == (len(v), len(f), len(ov), len(of))
    assert info.faces == round(0.1 * len(f)) or info.faces == round(0.1 * len(f)) - 1
    assert 0 < info.skeleton_vertices <= info.vertices
    assert info.gaussian_vertices == 4 * info.skeleton_frequency**2 + 2
    assert set(info.refused) == {"link", "normal", "zero_area", "duplicate"}
    assert info.collapses == len(v) - len(ov)
    _, _, fixed = epsnet.simplify(v, f, ratio=0.1, level=2, return_info=True)
    assert fixed.gaussian_vertices == 66, "a level given fixes the skeleton's density"


def test_a_warning_is_issued_and_kept_in_the_info():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [5, 5, 5]], dtype=np.float64)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)
    with pytest.warns(epsnet.EpsnetWarning, match="1 vertices that no face uses"):
        ov, of, info = epsnet.simplify(v, f, return_info=True)
    assert len(ov) == 4 and len(of) == 4 and len(info.warnings) == 1


def test_read_mesh_gives_the_files_arrays(cli, tmp_path):
    path = tmp_path / "t.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    v, f, attrs = epsnet.read_mesh(path)
    assert v.dtype == np.float32 and v.tolist() == [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    assert f.dtype == np.int64 and f.shape == (2, 3) and attrs == {}
    assert epsnet.library_version() == epsnet.__version__
    out = subprocess.run([cli, "--version"], capture_output=True, text=True).stdout
    assert epsnet.__version__ in out
