#!/usr/bin/env python3
"""simplify keeps every output vertex's attributes bit for bit
(docs/architecture.md §7): a kept vertex is an input vertex, so its colour,
normal and any other per-vertex value come out exactly as they went in, for
any thread count, slab size and target, through PLY and OBJ."""
import json
import os

from clitest import TMP, case, f32, finish, path, read_ascii_ply, run
from meshes import tube_ply


def coloured_mesh():
    """A generated bumpy mesh with uchar colours, float normals and a float
    quality per vertex, all different."""
    p = path("coloured.ply")
    if os.path.exists(p):
        return p
    src = path("plain.ply")
    rc, _, err = run("gen", "bumpy", "--faces", "20000", "--shuffle", "--ascii", "-o", src, "-q")
    assert rc == 0, err
    _, verts, faces = read_ascii_ply(src)
    with open(p, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex %d\n" % len(verts))
        for a in "xyz":
            f.write("property float %s\n" % a)
        for a in ("red", "green", "blue"):
            f.write("property uchar %s\n" % a)
        for a in ("nx", "ny", "nz", "quality"):
            f.write("property float %s\n" % a)
        f.write("element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(faces))
        for i, v in enumerate(verts):
            f.write("%s %s %s %d %d %d %.7g %.7g %.7g %.7g\n" % (
                v["x"], v["y"], v["z"], i % 251, (i * 7) % 256, (i * 13) % 256,
                float(v["x"]), float(v["y"]), float(v["z"]), i * 0.001 + 0.5))
        for t in faces:
            f.write("3 %d %d %d\n" % tuple(t))
    return p


def key(v):
    return tuple(f32(v[a]) for a in "xyz")


def check_attributes_kept(src, out, names):
    _, vin, _ = read_ascii_ply(src)
    props, vout, fout = read_ascii_ply(out)
    got = [n for n, _ in props]
    for n in names:
        assert n in got, f"{out}: property {n} missing from {got}"
    by_pos = {}
    for v in vin:
        by_pos.setdefault(key(v), []).append(v)
    assert vout and fout, f"{out}: empty"
    for v in vout:
        cands = by_pos.get(key(v))
        assert cands, f"{out}: a vertex at {v['x']} {v['y']} {v['z']} is not an input vertex"
        want = [tuple(c[n] if c[n].lstrip("-").isdigit() else f32(c[n]) for n in names) for c in cands]
        have = tuple(v[n] if v[n].lstrip("-").isdigit() else f32(v[n]) for n in names)
        assert have in want, f"{out}: attributes {have} not those of its input vertex {want}"


@case
def coloured_ply_keeps_every_attribute_for_any_threads_and_slab():
    src = coloured_mesh()
    names = ("red", "green", "blue", "nx", "ny", "nz", "quality")
    outs = {}
    for opts in (("-j", "1"), ("-j", "2"), ("--slab", "1024", "-j", "2"), ("--slab", "4096", "-j", "1"),
                 ("--ratio", "0.2"), ("--ratio", "0.2", "--slab", "2048")):
        out = path("simplified_%s.ply" % "_".join(o.strip("-") for o in opts))
        rc, _, err = run("simplify", src, "-o", out, "--ascii", "-q", *opts)
        assert rc == 0, err
        assert "dropped" not in err, f"{opts}: {err}"
        check_attributes_kept(src, out, names)
        outs[opts] = open(out, "rb").read()
    assert outs[("-j", "1")] == outs[("-j", "2")], "-j1 and -j2 differ"


@case
def binary_ply_and_smz_in_between_keep_them_too():
    src = coloured_mesh()
    smz = path("coloured.smz")
    rc, _, err = run("sort", src, "-o", smz, "-q")
    assert rc == 0, err
    out_bin = path("from_smz.ply")
    rc, _, err = run("simplify", smz, "-o", out_bin, "-q")
    assert rc == 0, err
    out = path("from_smz_ascii.ply")
    rc, _, err = run("convert", out_bin, "-o", out, "--ascii", "-q")
    assert rc == 0, err
    check_attributes_kept(src, out, ("red", "green", "blue", "nx", "ny", "nz", "quality"))


@case
def a_format_without_attributes_names_them_once():
    src = coloured_mesh()
    out = path("plain.smb")
    rc, _, err = run("simplify", src, "-o", out)
    assert rc == 0, err
    lines = [l for l in err.splitlines() if "dropped" in l]
    assert len(lines) == 1 and "red" in lines[0] and "quality" in lines[0], lines


@case
def obj_vertex_colours_survive_simplify():
    src = coloured_mesh()
    obj = path("coloured.obj")
    # OBJ holds float colours: take the PLY's floats (normals) as colours
    _, verts, faces = read_ascii_ply(src)
    with open(obj, "w") as f:
        for v in verts:
            f.write("v %s %s %s %s %s %s\n" % (v["x"], v["y"], v["z"], v["nx"], v["ny"], v["nz"]))
        for t in faces:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))
    want = {}
    for v in verts:
        want[key(v)] = (f32(v["nx"]), f32(v["ny"]), f32(v["nz"]))
    for opts in (("-j", "1"), ("-j", "2", "--slab", "1024")):
        out = path("simplified.obj")
        rc, _, err = run("simplify", obj, "-o", out, "-q", *opts)
        assert rc == 0, err
        n = 0
        with open(out) as f:
            for line in f:
                w = line.split()
                if w and w[0] == "v":
                    assert len(w) == 7, f"{opts}: vertex without colour: {line!r}"
                    k = tuple(f32(x) for x in w[1:4])
                    assert want.get(k) == tuple(f32(x) for x in w[4:7]), f"{opts}: colour changed: {line!r}"
                    n += 1
        assert n > 0


@case
def locked_vertices_stay_under_a_priced_ceiling():
    """A long sorted .smz with a lock property: the pricing windows carry the
    lock as the stream does, and neither they nor the thinning under their
    ceiling, the rounds or the last round remove a locked vertex."""
    tube = tube_ply(TMP, "locked_tube.ply", 24, 5000, lock_every=50)
    _, verts, _ = read_ascii_ply(tube)
    locked = {key(v) for v in verts if v["lock"] == "1"}
    smz = path("locked_tube.smz")
    rc, _, err = run("sort", tube, "-o", smz, "-q")
    assert rc == 0, err
    for opts in (("--ratio", "0.1", "--slab", "256"), ("--ratio", "0.2", "--slab", "256", "-j", "2")):
        out, stats = path("locked_tube_out.ply"), path("locked_tube.json")
        rc, _, err = run("simplify", smz, "-o", out, "--ascii", "-q", "--lock", "lock", "--stats", stats, *opts)
        assert rc == 0, err
        s = json.load(open(stats))
        assert s["target"]["price_ceiling"] > 0, (opts, s["target"])
        _, vout, _ = read_ascii_ply(out)
        missing = locked - {key(v) for v in vout}
        assert not missing, f"{opts}: {len(missing)} of {len(locked)} locked vertices gone"


@case
def locked_vertices_stay_in_every_mode():
    """--lock PROPERTY keeps every vertex whose property is non-zero, in
    every shape of a run: the ε-net pass, with seams, a target in one slab
    (below the skeleton too), a streamed target whose last round is one slab
    or, over --mem, goes through rounds on slabs, and an error bound on
    slabs."""
    src = coloured_mesh()
    props, verts, faces = read_ascii_ply(src)
    p = path("locked.ply")
    with open(p, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex %d\n" % len(verts))
        for a in "xyz":
            f.write("property float %s\n" % a)
        f.write("property uchar lock\nproperty float quality\n")
        f.write("element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(faces))
        for i, v in enumerate(verts):
            f.write("%s %s %s %d %s\n" % (v["x"], v["y"], v["z"], 1 if i % 37 == 0 else 0,
                                          "1" if i % 53 == 0 else "0"))
        for t in faces:
            f.write("3 %d %d %d\n" % tuple(t))
    # the finish on slabs, in a budget that a sorted stream fits (an input
    # sorted first gives the sort half of --mem)
    smz = path("locked.smz")
    rc, _, err = run("sort", p, "-o", smz, "-q")
    assert rc == 0, err
    for prop, every in (("lock", 37), ("quality", 53)):
        locked = {key(v) for i, v in enumerate(verts) if i % every == 0}
        for opts, shape in (((), None), (("--slab", "1024", "-j", "2"), None), (("--ratio", "0.02"), None),
                            (("--faces", "200"), None), (("--ratio", "0.05", "--slab", "2048"), "one"),
                            (("--ratio", "0.02", "--slab", "256", "--mem", "1M", "-j", "2"), "slabs"),
                            (("--error", "0.002", "--slab", "1024"), "bound")):
            out = path("locked_out.ply")
            stats = path("locked_stats.json")
            src = smz if shape == "slabs" else p
            rc, _, err = run("simplify", src, "-o", out, "--ascii", "-q", "--lock", prop, "--stats", stats, *opts)
            assert rc == 0, err
            s = json.load(open(stats))
            if shape == "one":  # a streamed target: a thinning pass and a finish in one slab
                assert s["passes"] == 2, (opts, s["passes"])
            if shape == "slabs":  # ... and, over --mem's one slab, rounds and a last round on slabs of 256
                one = path("locked_one.json")
                rc, _, err = run("simplify", src, "-o", path("locked_one.ply"), "-q", "--lock", prop, "--stats", one,
                                 *opts[:4])
                assert rc == 0, err
                thin = json.load(open(one))["slabs"] - 1
                assert s["passes"] >= 3 and s["slabs"] > thin + 1, (opts, s["passes"], s["slabs"], thin)
            if shape == "bound":
                assert s["slabs"] > 1, (opts, s["slabs"])
            _, vout, _ = read_ascii_ply(out)
            have = {key(v) for v in vout}
            missing = locked - have
            assert not missing, f"--lock {prop} {opts}: {len(missing)} of {len(locked)} locked vertices gone"
    # a target below what the locks keep is missed, and the warning says the
    # locks hold it (not the slabs: the last round here is one slab)
    nlocked = sum(1 for i in range(len(verts)) if i % 37 == 0)
    rc, _, err = run("simplify", p, "-o", path("locked_few.ply"), "-q", "--lock", "lock", "--faces", str(nlocked),
                     "--slab", "1024")
    assert rc == 0 and "missed" in err and "--lock" in err and "on slabs" not in err, err
    # an output that cannot hold the lock names it; a missing property is one error line, exit 1
    rc, _, err = run("simplify", p, "-o", path("locked.smb"), "--lock", "lock")
    lines = [l for l in err.splitlines() if "dropped" in l]
    assert rc == 0 and len(lines) == 1 and "lock" in lines[0], err
    rc, _, err = run("simplify", p, "-o", path("nolock.ply"), "-q", "--lock", "selected")
    assert rc == 1 and len(err.strip().splitlines()) == 1 and "selected" in err, (rc, err)
    assert not os.path.exists(path("nolock.ply"))


finish()
