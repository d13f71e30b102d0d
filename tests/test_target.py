#!/usr/bin/env python3
"""simplify to a size or an error bound (docs/method.md §13): the target is
met, the skeleton of ε-net samples is in the output, topology is kept, the
bytes do not depend on threads, --error is monotone, and contradictory
options get one error line and exit 1. Real meshes from ../shared/data are
used when present and skipped cleanly when not."""
import json
import os

from clitest import case, finish, path, read_ascii_ply, run


DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data")





def ascii_ply(p):
    """Vertices as (x, y, z) texts (as the writer's text, so equal strings are
    equal bits) and faces as tuples, of an ASCII PLY."""
    _, verts, faces = read_ascii_ply(p)
    return [tuple(v[a] for a in "xyz") for v in verts], [tuple(f) for f in faces]


def simplify(src, out, *opts):
    stats = out + ".json"
    rc, _, err = run("simplify", src, "-o", out, "-q", "--stats", stats, *opts)
    assert rc == 0, f"simplify {opts}: exit {rc}: {err}"
    with open(stats) as f:
        return json.load(f), err


def gen(shape, faces, name, *opts):
    p = path(name)
    if not os.path.exists(p):
        rc, _, err = run("gen", shape, "--faces", str(faces), "-o", p, "-q", *opts)
        assert rc == 0, err
    return p


def real_meshes():
    names = ("bun_zipper.ply.zst", "armadillo_decim100k.obj.zst", "fandisk.obj.zst")
    found = [os.path.join(DATA, n) for n in names if os.path.exists(os.path.join(DATA, n))]
    if not found:
        print("skip real meshes: ../shared/data is absent")
    return found


def euler_and_closed(verts, faces):
    edges = {}
    for f in faces:
        for k in range(3):
            a, b = f[k], f[(k + 1) % 3]
            key = (min(a, b), max(a, b))
            edges[key] = edges.get(key, 0) + 1
    used = {v for f in faces for v in f}
    closed = all(c == 2 for c in edges.values())
    return len(used) - len(edges) + len(faces), closed


@case
def face_target_is_met_on_generated_meshes_for_any_threads():
    for shape in ("bumpy", "cad", "torus"):
        src = gen(shape, 30000, shape + ".ply", "--shuffle")
        for ratio in ("0.05", "0.25", "0.5"):
            outs = []
            for j in ("1", "2"):
                out = path(f"{shape}_{ratio}_j{j}.ply")
                s, _ = simplify(src, out, "--ratio", ratio, "-j", j)
                want = round(float(ratio) * s["faces"])
                assert s["target"]["faces"] == want, (shape, ratio, s["target"], want)
                got = s["output_faces"]
                assert want - 1 <= got <= want, f"{shape} --ratio {ratio}: {got} faces, target {want}"
                outs.append(open(out, "rb").read())
            assert outs[0] == outs[1], f"{shape} --ratio {ratio}: -j1 and -j2 differ"


@case
def faces_and_vertices_targets_are_exact():
    src = gen("bumpy", 20000, "bumpy20k.ply")
    s, _ = simplify(src, path("f.ply"), "--faces", "3001")
    assert s["output_faces"] in (3000, 3001), s["output_faces"]
    s, _ = simplify(src, path("v.ply"), "--vertices", "1234")
    assert s["output_vertices"] == 1234, s["output_vertices"]


@case
def streamed_target_is_exact_for_any_slab_size_and_threads():
    """A mesh over the slab size asked for is streamed: a thinning pass on
    slabs, then one slab to the target (docs/architecture.md §7)."""
    src = gen("bumpy", 30000, "bumpy30k_shuf.ply", "--shuffle")
    for slab in ("1024", "2048", "4096"):
        outs = []
        for j in ("1", "2"):
            out = path(f"streamed_{slab}_{j}.ply")
            s, _ = simplify(src, out, "--ratio", "0.1", "--slab", slab, "-j", j)
            want = s["target"]["faces"]
            assert s["passes"] == 2 and s["slabs"] > 2, (slab, s["passes"], s["slabs"])
            assert want - 1 <= s["output_faces"] <= want, (slab, s["output_faces"], want)
            outs.append(open(out, "rb").read())
        assert outs[0] == outs[1], f"--slab {slab}: -j1 and -j2 differ"


@case
def a_target_within_one_slab_does_not_depend_on_the_default_slab_size():
    """Without --slab, a mesh that fits the budget is one slab: --mem (which
    sets the ε-net pass's slabs) does not change the bytes."""
    src = gen("bumpy", 20000, "bumpy20k.ply")
    a = path("slab_a.ply")
    b = path("slab_b.ply")
    simplify(src, a, "--ratio", "0.2")
    simplify(src, b, "--ratio", "0.2", "--mem", "64M")
    assert open(a, "rb").read() == open(b, "rb").read()


@case
def targets_on_real_meshes():
    for src in real_meshes():
        for ratio in ("0.1", "0.5"):
            out = path("real.ply")
            s, err = simplify(src, out, "--ratio", ratio, "-j", "2")
            want = s["target"]["faces"]
            got = s["output_faces"]
            tol = max(1, want // 200)
            assert abs(got - want) <= tol or "missed" in err, f"{src} {ratio}: {got} faces, target {want}; {err}"


@case
def every_skeleton_sample_is_in_the_output():
    meshes = [gen("cad", 20000, "cad20k.ply"), gen("bumpy", 20000, "bumpy20k.ply")] + real_meshes()[:1]
    for src, opts in [(m, ()) for m in meshes] + [(meshes[1], ("--slab", "4096"))]:
        for ratio in ("0.1", "0.3"):
            out = path("skel.ply")
            s, _ = simplify(src, out, "--ratio", ratio, "--ascii", *opts)
            if s["target"]["samples_given_up"]:
                continue  # below the skeleton: samples go by design
            n = s["gaussian_sphere"]["frequency"]
            pts = path("skel_samples.ply")
            rc, _, err = run("sample", src, "-o", pts, "--frequency", str(n), "--ascii", "-q")
            assert rc == 0, err
            samples, _ = ascii_ply(pts)
            verts, _ = ascii_ply(out)
            have = set(verts)
            missing = [p for p in samples if p not in have]
            assert not missing, f"{src} {ratio}: {len(missing)} of {len(samples)} samples at frequency {n} missing"
            assert s["target"]["skeleton_vertices"] == len(samples), (s["target"], len(samples))


# The frequencies a skeleton's density is chosen from (slab_work.c: freq).
FREQUENCIES = (1, 2, 3, 4, 6, 8, 11, 16, 23, 32, 45, 64, 91, 128)


@case
def a_streamed_skeleton_coarsens_in_slabs_over_their_share():
    """A sorted bumpy sphere's first slab is a cap with few normals: the
    density it chooses is too fine for the slabs across the middle, whose
    normals go all around. Those slabs take a coarser sphere; the run
    reports the coarsest (the ε every part keeps) and the finest, and every
    skeleton vertex in the output is a sample at a frequency between them."""
    src = gen("bumpy", 50000, "bumpy50k_seed7.smz", "--seed", "7")
    out = path("coarsen.ply")
    s, err = simplify(src, out, "--ratio", "0.3", "--slab", "2048", "--ascii")
    n, finest = s["gaussian_sphere"]["frequency"], s["target"]["finest_frequency"]
    assert finest > n, (n, finest, "the premise: a slab coarsened")
    assert s["target"]["samples_given_up"] == 0, s["target"]
    assert s["output_faces"] == s["target"]["faces"], (s["output_faces"], s["target"])
    union = set()
    for f in FREQUENCIES:
        if n <= f <= finest:
            pts = path("coarsen_samples.ply")
            rc, _, e = run("sample", src, "-o", pts, "--frequency", str(f), "--ascii", "-q")
            assert rc == 0, e
            union |= set(ascii_ply(pts)[0])
    verts = set(ascii_ply(out)[0])
    skeleton = s["target"]["skeleton_vertices"]
    assert len(verts & union) >= skeleton, (len(verts & union), skeleton)
    # near its share (a quarter of the output), not most of it
    assert skeleton <= 0.5 * len(verts), (skeleton, len(verts))
    # the same run with the density given keeps it in every slab
    s2, _ = simplify(src, path("coarsen_given.ply"), "--ratio", "0.3", "--slab", "2048", "--frequency", str(finest))
    assert s2["target"]["finest_frequency"] == s2["gaussian_sphere"]["frequency"] == finest, s2["target"]


@case
def a_closed_manifold_stays_closed_with_its_genus():
    for shape in ("torus", "sphere", "bumpy"):
        src = gen(shape, 20000, shape + "_asc.ply", "--ascii")
        v0, f0 = ascii_ply(src)
        chi0, closed0 = euler_and_closed(v0, f0)
        assert closed0, shape
        for ratio in ("0.02", "0.2"):
            out = path(shape + "_closed.ply")
            simplify(src, out, "--ratio", ratio, "--ascii")
            v, f = ascii_ply(out)
            chi, closed = euler_and_closed(v, f)
            assert closed and chi == chi0, f"{shape} {ratio}: closed {closed}, chi {chi} (input {chi0})"


@case
def a_larger_error_bound_never_gives_more_faces():
    meshes = [gen("bumpy", 20000, "bumpy20k.ply"), gen("cad", 20000, "cad20k.ply")] + real_meshes()[:1]
    for src in meshes:
        last = None
        for e in ("0.00001", "0.0001", "0.001", "0.01", "0.1"):
            s, _ = simplify(src, path("err.ply"), "--error", e)
            faces = s["output_faces"]
            assert last is None or faces <= last, f"{src}: --error {e} gave {faces} faces, more than {last}"
            last = faces
        # with a face target too, whichever stops first
        s, err = simplify(src, path("err2.ply"), "--error", "0.00001", "--ratio", "0.05")
        assert s["output_faces"] > s["target"]["faces"] and "error bound" in err, (s["output_faces"], err)


@case
def below_the_skeleton_samples_are_given_up_and_counted():
    src = gen("cad", 20000, "cad20k.ply")
    s, err = simplify(src, path("tiny.ply"), "--faces", "40", "--level", "3")
    assert s["target"]["samples_given_up"] > 0, s["target"]
    assert s["output_faces"] <= 40 or "missed" in err, (s["output_faces"], err)


@case
def no_option_no_change():
    """Without a target simplify is the ε-net method: same bytes as --level 3."""
    src = gen("bumpy", 20000, "bumpy20k.ply")
    a, b = path("plain_a.ply"), path("plain_b.ply")
    simplify(src, a)
    simplify(src, b, "--level", "3")
    assert open(a, "rb").read() == open(b, "rb").read()


@case
def contradictory_or_impossible_options_exit_1_with_one_line():
    src = gen("bumpy", 20000, "bumpy20k.ply")
    out = path("bad.ply")
    for opts in (("--faces", "10", "--ratio", "0.5"), ("--ratio", "0"), ("--ratio", "1.5"), ("--ratio", "-0.1"),
                 ("--error", "-1"), ("--vertices", "10", "--faces", "10"), ("--faces", "10", "--passes", "2"),
                 ("--faces", "100000000")):
        rc, _, err = run("simplify", src, "-o", out, "-q", *opts)
        lines = err.strip().splitlines()
        assert rc == 1, f"{opts}: exit {rc}, stderr {err!r}"
        assert len(lines) == 1, f"{opts}: want one line, got {lines!r}"
        assert not os.path.exists(out), f"{opts}: output left behind"


finish()
