#!/usr/bin/env python3
"""OBJ texture coordinates and normals (docs/architecture.md §13): a vertex
record is one (position, vt, vn) of the faces, a position used with
different vt or vn (a seam) is split into one record per value, and
simplify keeps every corner's own values: the two copies along a seam move
together along it or stay (docs/method.md §6), never across it. Values are
compared as float32 bits."""
import json
import math
import os
import struct
import subprocess

from clitest import EPSNET, case, f32, finish, path, run


def bits(words):
    return tuple(f32(w) for w in words)


def read_obj(p):
    """Every triangle as three corners (xyz, vt or None, vn or None), in
    float32 bits; and the counts of v, vt, vn lines."""
    vs, vts, vns, tris = [], [], [], []
    with open(p) as f:
        for line in f:
            w = line.split()
            if not w:
                continue
            if w[0] == "v":
                vs.append(bits(w[1:4]))
            elif w[0] == "vt":
                vts.append(bits(w[1:3]))
            elif w[0] == "vn":
                vns.append(bits(w[1:4]))
            elif w[0] == "f":
                corners = []
                for c in w[1:]:
                    k = (c.split("/") + ["", ""])[:3]
                    corners.append((vs[int(k[0]) - 1], vts[int(k[1]) - 1] if k[1] else None,
                                    vns[int(k[2]) - 1] if k[2] else None))
                for i in range(1, len(corners) - 1):
                    tris.append((corners[0], corners[i], corners[i + 1]))
    return tris, (len(vs), len(vts), len(vns))


def read_ascii_ply(p):
    """The vertex properties' names, the vertices (dicts of text), the faces'
    corners, and the face properties' names (a face's values, after its
    corners, are not read)."""
    with open(p) as f:
        lines = f.read().split("\n")
    i, names, face_names, nv, nf = 0, [], [], 0, 0
    while lines[i] != "end_header":
        w = lines[i].split()
        if w[:2] == ["element", "vertex"]:
            nv, el = int(w[2]), "vertex"
        elif w[:2] == ["element", "face"]:
            nf, el = int(w[2]), "face"
        elif w and w[0] == "property" and w[1] != "list":
            (names if el == "vertex" else face_names).append(w[2])
        i += 1
    i += 1
    verts = [dict(zip(names, lines[i + k].split())) for k in range(nv)]
    rows = [lines[i + nv + k].split() for k in range(nf)]
    faces = [[int(x) for x in w[1:1 + int(w[0])]] for w in rows]
    return names, verts, faces, face_names


def rotated(t):
    """The same triangle whatever corner it starts from."""
    k = t.index(min(t))
    return t[k:] + t[:k]


def textured(name, seams, normals=True):
    """A generated bumpy sphere with vt from the longitude and latitude of
    each corner's position and vn its direction. seams: a face across the
    date line gets u + 1 on its corners west of it, as a sphere's UV map
    does, so the positions along that line have two vt (a UV seam)."""
    p = path(name)
    if os.path.exists(p):
        return p
    base = path("bumpy.obj")
    if not os.path.exists(base):
        rc, _, err = run("gen", "bumpy", "--faces", "20000", "-o", base, "-q")
        assert rc == 0, err
    vs, faces = [], []
    with open(base) as f:
        for line in f:
            w = line.split()
            if w and w[0] == "v":
                vs.append([float(x) for x in w[1:4]])
            elif w and w[0] == "f":
                faces.append([int(x) - 1 for x in w[1:]])
    vt, vt_index, vn = [], {}, []

    def vt_of(u, v):
        t = "%.7g %.7g" % (u, v)
        if t not in vt_index:
            vt_index[t] = len(vt)
            vt.append(t)
        return vt_index[t] + 1

    for x, y, z in vs:
        r = math.sqrt(x * x + y * y + z * z) or 1
        vn.append("%.7g %.7g %.7g" % (x / r, y / r, z / r))
    out = []
    for t in faces:
        us = [math.atan2(vs[i][1], vs[i][0]) / (2 * math.pi) + 0.5 for i in t]
        if seams and max(us) - min(us) > 0.5:
            us = [u + 1 if u < 0.5 else u for u in us]
        corners = []
        for i, u in zip(t, us):
            k = vt_of(u, vs[i][2] * 0.5 + 0.5)
            corners.append("%d/%d/%d" % (i + 1, k, i + 1) if normals else "%d/%d" % (i + 1, k))
        out.append("f " + " ".join(corners))
    with open(p, "w") as f:
        f.write("# textured\nmtllib bumpy.mtl\no bumpy\n")
        for x, y, z in vs:
            f.write("v %.9g %.9g %.9g\n" % (x, y, z))
        f.write("".join("vt %s\n" % t for t in vt))
        if normals:
            f.write("".join("vn %s\n" % n for n in vn))
        f.write("usemtl skin\ns 1\n" + "\n".join(out) + "\n")
    return p


@case
def without_seams_obj_and_ply_round_trip_every_corner():
    src = textured("smooth.obj", seams=False)
    tin, counts = read_obj(src)
    out = path("smooth_out.obj")
    rc, _, err = run("convert", src, "-o", out)
    assert rc == 0, err
    # vt, vn and the material are carried: only what no record holds is named
    assert err.splitlines() == [f"warning: {src}: dropped: o (1), s (1)"], err
    tout, counts_out = read_obj(out)
    assert sorted(map(rotated, tout)) == sorted(map(rotated, tin)), "OBJ -> OBJ changed a corner"
    # one record per position, welded back: the file's own shape
    assert counts_out == counts, (counts_out, counts)
    ply = path("smooth.ply")
    rc, _, err = run("convert", src, "-o", ply, "--ascii", "-q")
    assert rc == 0, err
    names, verts, faces, face_names = read_ascii_ply(ply)
    assert names == ["x", "y", "z", "texture_u", "texture_v", "nx", "ny", "nz"], names
    assert face_names == ["material_index"], face_names
    assert len(verts) == counts[0], (len(verts), counts)
    corner = lambda v: (bits([v["x"], v["y"], v["z"]]), bits([v["texture_u"], v["texture_v"]]),
                        bits([v["nx"], v["ny"], v["nz"]]))
    tply = [tuple(corner(verts[i]) for i in t) for t in faces]
    assert sorted(map(rotated, tply)) == sorted(map(rotated, tin)), "OBJ -> PLY changed a corner"
    back = path("smooth_back.obj")
    rc, _, err = run("convert", ply, "-o", back, "-q")
    assert rc == 0, err
    tback, counts_back = read_obj(back)
    assert sorted(map(rotated, tback)) == sorted(map(rotated, tin)), "PLY -> OBJ changed a corner"
    assert counts_back == counts, (counts_back, counts)


@case
def a_seam_splits_positions_and_converts_back_to_the_same_corners():
    src = textured("seams.obj", seams=True)
    tin, counts = read_obj(src)
    uv = {}
    for t in tin:
        for c in t:
            uv.setdefault(c[0], set()).add(c[1])
    seam = [p for p, s in uv.items() if len(s) > 1]
    assert len(seam) > 10, "the test mesh has no seam"
    rc, out, err = run("info", src)
    assert rc == 0 and "vertices:    %d" % (counts[0] + len(seam)) in out, out
    o = path("seams_out.obj")
    rc, _, err = run("convert", src, "-o", o, "-q")
    assert rc == 0, err
    tout, counts_out = read_obj(o)
    assert sorted(map(rotated, tout)) == sorted(map(rotated, tin))
    assert counts_out[0] == counts[0], "split copies are not welded back into one v line"


@case
def simplify_collapses_along_a_seam_and_keeps_every_corner():
    """The date line is a seam from pole to pole. simplify removes copies
    along it in pairs, so the seam is still two sides that meet (each
    position on it with two vt), no face stretches across the texture, every
    output corner is an input corner, and a size is met exactly."""
    src = textured("seams.obj", seams=True)
    tin, _ = read_obj(src)
    corners = {c for t in tin for c in t}
    pairs = {(c[0], c[1]) for c in corners}
    uv = {}
    for c in corners:
        uv.setdefault(c[0], set()).add(c[1])
    seam = {p for p, s in uv.items() if len(s) > 1}
    assert len(seam) > 20, "the test mesh has no seam"
    results = {}
    for tag, opts in (("j1", ["-j1"]), ("j2", ["-j2"]), ("slab", ["-j2", "--slab", "1024"]),
                      ("ratio", ["-j2", "--ratio", "0.1"]), ("ratio_slab", ["-j2", "--ratio", "0.1", "--slab", "1024"])):
        o = path("simp_%s.obj" % tag)
        rc, _, err = run("simplify", src, "-o", o, "-q", *opts)
        assert rc == 0, (tag, err)
        tout, counts = read_obj(o)
        assert 0 < len(tout) < len(tin), (tag, len(tout), len(tin))
        if "--ratio" in opts:
            goal = round(0.1 * len(tin))
            assert abs(len(tout) - goal) <= 0.005 * goal, f"{tag}: {len(tout)} faces for a target of {goal}"
        out_uv = {}
        for t in tout:
            for c in t:
                assert c[1] is not None and c[2] is not None, f"{tag}: a corner without vt or vn"
                assert (c[0], c[1]) in pairs, f"{tag}: corner {c[:2]} is not an input corner"
                assert c in corners, f"{tag}: corner {c} is not an input corner"
                out_uv.setdefault(c[0], set()).add(c[1])
            us = [struct.unpack("<f", c[1][0])[0] for c in t]
            # an input face spans at most half the texture (a pole's fan
            # exactly half); one that took a corner across the seam spans
            # nearly all of it
            assert max(us) - min(us) < 0.75, f"{tag}: a face stretches across the seam: u {us}"
        on_seam = {p for p in out_uv if p in seam}
        assert all(len(out_uv[p]) == 2 for p in on_seam if len(uv[p]) == 2), f"{tag}: a seam side was lost"
        assert seam - set(out_uv), f"{tag}: no seam position was removed"
        with open(o, "rb") as f:
            results[tag] = f.read()
    assert results["j1"] == results["j2"], "-j1 and -j2 differ"
    # the same run again gives the same bytes
    again = path("simp_again.obj")
    assert run("simplify", src, "-o", again, "-q", "-j2", "--slab", "1024")[0] == 0
    with open(again, "rb") as f:
        assert f.read() == results["slab"], "a second run differs"


@case
def texture_coordinates_alone_and_through_ply():
    src = textured("uv_only.obj", seams=True, normals=False)
    tin, _ = read_obj(src)
    pairs = {(c[0], c[1]) for t in tin for c in t}
    ply = path("uv_only.ply")
    rc, _, err = run("simplify", src, "-o", ply, "-q", "--ascii", "--ratio", "0.2")
    assert rc == 0, err
    names, verts, faces, face_names = read_ascii_ply(ply)
    assert names == ["x", "y", "z", "texture_u", "texture_v"] and face_names == ["material_index"], (names, face_names)
    for t in faces:
        for i in t:
            v = verts[i]
            assert (bits([v["x"], v["y"], v["z"]]), bits([v["texture_u"], v["texture_v"]])) in pairs
    o = path("uv_only_out.obj")
    rc, _, err = run("convert", ply, "-o", o, "-q")
    assert rc == 0, err
    tout, _ = read_obj(o)
    assert all(c[2] is None and (c[0], c[1]) in pairs for t in tout for c in t)


@case
def sort_and_smz_keep_the_corners():
    src = textured("seams.obj", seams=True)
    tin, counts = read_obj(src)
    smz = path("seams.smz")
    rc, _, err = run("sort", src, "-o", smz, "-q")
    assert rc == 0, err
    o = path("seams_smz.obj")
    rc, _, err = run("convert", smz, "-o", o, "-q")
    assert rc == 0, err
    tout, counts_out = read_obj(o)
    assert sorted(map(rotated, tout)) == sorted(map(rotated, tin)), "sort and .smz changed a corner"
    assert counts_out[0] == counts[0], (counts_out, counts)
    corners = {c for t in tin for c in t}
    s = path("seams_smz_simp.obj")
    rc, _, err = run("simplify", smz, "-o", s, "-q", "-j2", "--slab", "1024")
    assert rc == 0, err
    tout, _ = read_obj(s)
    assert tout and all(c in corners for t in tout for c in t), "simplify of the .smz changed a corner"


@case
def a_pipe_is_read_ahead_in_its_window():
    text = ("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0.5\nvn 0 0 1\n"
            "f 1/1/1 2/2/1 3/3/1\nf 1/5/1 3/3/1 4/4/1\n")
    o = path("pipe.obj")
    p = subprocess.run([EPSNET, "convert", "-", "-o", o, "-q"], input=text, capture_output=True, text=True,
                       timeout=60)
    assert p.returncode == 0, p.stderr
    src = path("pipe_in.obj")
    with open(src, "w") as f:
        f.write(text)
    tin, _ = read_obj(src)
    tout, counts = read_obj(o)
    assert sorted(map(rotated, tout)) == sorted(map(rotated, tin)), (tin, tout)
    assert counts == (4, 5, 1), counts


@case
def an_output_without_vt_and_vn_gets_the_mesh_uncut():
    """simplify to a format that holds neither: the positions are the
    vertices, so no seam copies (vertices at the same place) come out."""
    src = textured("seams.obj", seams=True)
    o = path("seams.sma")
    rc, _, err = run("simplify", src, "-o", o, "-j2", "--ratio", "0.2")
    assert rc == 0, err
    assert "vertex property texture_u" in err and "vertex property nz" in err, err
    with open(o) as f:
        xyz = [tuple(line.split()[1:4]) for line in f if line.startswith("v ")]
    assert xyz and len(set(xyz)) == len(xyz), f"{len(xyz) - len(set(xyz))} vertices share a place: a cut mesh"


def expect_bad(name, text, line, reason):
    src = path(name)
    with open(src, "w") as f:
        f.write(text)
    out = path("bad_out.ply")
    rc, _, err = run("convert", src, "-o", out, "-q")
    lines = err.strip().splitlines()
    assert rc == 2, f"{name}: exit {rc}; stderr={err!r}"
    assert len(lines) == 1, f"{name}: want one error line, got {lines!r}"
    assert f"{src}:{line}:" in lines[0], f"{name}: file and line not in {lines[0]!r}"
    assert reason in lines[0], f"{name}: {reason!r} not in {lines[0]!r}"
    assert not os.path.exists(out), f"{name}: output left behind"


@case
def malformed_vt_vn_and_corners_name_file_and_line():
    head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\n"
    expect_bad("vt9.obj", head + "f 1/1/1 2/2/1 3/9/1\n", 7, "vt index 9, but only 2 vt precede it")
    expect_bad("vn0.obj", head + "f 1/1/0 2/2/1 3/2/1\n", 7, "vn index 0")
    expect_bad("v9.obj", head + "f 1/1/1 2/2/1 9/2/1\n", 7, "vertex index 9")
    expect_bad("vtneg.obj", head + "f 1/-3/1 2/2/1 3/2/1\n", 7, "relative vt index -3")
    expect_bad("vtx.obj", head + "f 1/1/1 2/2/1 3/a/1\n", 7, "bad corner '3/a/1'")
    expect_bad("vt4.obj", "v 0 0 0\nvt 1 2 3 4\nf 1/1 1/1 1/1\n", 2, "more than 3 values")
    expect_bad("vn2.obj", "v 0 0 0\nvn 1 0\nf 1//1 1//1 1//1\n", 2, "vn 1 has 2 values")
    # a vt after the faces began is checked like the others
    expect_bad("late.obj", head + "f 1/1/1 2/2/1 3/2/1\nvt 0 x\n", 8, "'x' is not a number")


@case
def what_is_not_carried_is_named_and_vt_vn_are_not():
    src = path("named.obj")
    with open(src, "w") as f:
        f.write("mtllib m.mtl\ng one\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0 0\nvt 1 0\nvn 0 0 1\n"
                "usemtl red\nf 1/1/1 2/2/1 3/2/1\nl 1 2\n")
    rc, _, err = run("convert", src, "-o", path("named.ply"))
    assert rc == 0, err
    # (the names of the material and the group go in the PLY header's comments)
    assert err.splitlines() == [f"warning: {src}: dropped: vt w (1), l (1)"], err
    # an output without vt and vn says that it drops them
    smb = path("named.smb")
    rc, _, err = run("convert", src, "-o", smb)
    assert rc == 0, err
    assert "texture_u" in err and "nz" in err and "material_index" in err and "usemtl" in err, err


def texture_slide(tris):
    """The textured sphere's u is the longitude of a point (its v the
    height, linear): at points inside each face, the area-weighted RMS
    distance between the u, v the face interpolates and those of the point
    itself, the texture's slide over the surface. Away from the poles,
    where the longitude has no value."""
    total = weight = 0.0
    for t in tris:
        p = [[struct.unpack("<f", x)[0] for x in c[0]] for c in t]
        uv = [[struct.unpack("<f", x)[0] for x in c[1]] for c in t]
        e1 = [p[1][i] - p[0][i] for i in range(3)]
        e2 = [p[2][i] - p[0][i] for i in range(3)]
        n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
        area = 0.5 * math.sqrt(sum(x * x for x in n))
        for l0, l1 in ((1 / 3, 1 / 3), (2 / 3, 1 / 6), (1 / 6, 2 / 3), (1 / 6, 1 / 6)):
            l2 = 1 - l0 - l1
            q = [l0 * p[0][i] + l1 * p[1][i] + l2 * p[2][i] for i in range(3)]
            if q[0] * q[0] + q[1] * q[1] < 0.04:
                continue
            u = l0 * uv[0][0] + l1 * uv[1][0] + l2 * uv[2][0]
            v = l0 * uv[0][1] + l1 * uv[1][1] + l2 * uv[2][1]
            fu = math.atan2(q[1], q[0]) / (2 * math.pi) + 0.5
            fu += round(u - fu)  # the side of the seam the face is on
            total += area * ((u - fu) ** 2 + (v - (q[2] * 0.5 + 0.5)) ** 2)
            weight += area
    return math.sqrt(total / weight)


@case
def attribute_weights_keep_the_texture_in_place():
    """--attribute-weight prices a collapse by how far it slides the
    texture as well as by its distance (docs/method.md §9): on the sphere
    whose u is the longitude, the texture slides less at the same size, in
    one slab and on slabs, with every corner still an input corner and the
    same bytes for any thread count."""
    src = textured("seams.obj", seams=True)
    tin, _ = read_obj(src)
    corners = {c for t in tin for c in t}
    goal = round(0.1 * len(tin))
    slide = {}
    for tag, opts in (("plain", []), ("uv", ["--attribute-weight", "uv=1"]), ("plain_slab", ["--slab", "512"]),
                      ("uv_slab", ["--slab", "512", "--attribute-weight", "uv=1"])):
        o = path("weighed_%s.obj" % tag)
        rc, _, err = run("simplify", src, "-o", o, "-q", "--ratio", "0.1", "-j2", *opts)
        assert rc == 0, (tag, err)
        tout, _ = read_obj(o)
        assert abs(len(tout) - goal) <= 1, f"{tag}: {len(tout)} faces for a target of {goal}"
        assert all(c in corners for t in tout for c in t), f"{tag}: a corner that is not an input corner"
        slide[tag] = texture_slide(tout)
    assert slide["uv"] < 0.7 * slide["plain"], slide
    stats = path("weighed_stats.json")
    rc, _, err = run("simplify", src, "-o", path("weighed_stats.obj"), "--ratio", "0.1", "--attribute-weight", "1",
                     "--stats", stats)
    assert rc == 0 and "attributes weighed: 1 (5 values a vertex)" in err, err  # vt and vn
    with open(stats) as f:
        assert json.load(f)["attribute_channels"] == 5
    assert slide["uv_slab"] < 0.7 * slide["plain_slab"], slide
    o1, o2 = path("weighed_j1.obj"), path("weighed_j2.obj")
    for o, j in ((o1, "-j1"), (o2, "-j2")):
        assert run("simplify", src, "-o", o, "-q", "--ratio", "0.1", "--slab", "512", j,
                   "--attribute-weight", "uv=1")[0] == 0
    with open(o1, "rb") as a, open(o2, "rb") as b:
        assert a.read() == b.read(), "-j1 and -j2 differ with weights"


@case
def attribute_weights_name_what_they_cannot_weigh():
    src = textured("uv_only_w.obj", seams=True, normals=False)
    out = path("w_bad.obj")
    for spec, reason in (("foo=1", "no vertex property 'foo' to weigh"),
                         ("uv=-1", "a weight is a number, 0 or more: 'uv=-1'"),
                         ("uv=x", "a weight is a number, 0 or more: 'uv=x'"),
                         ("normal=1", "the input has no vertex normals"),
                         ("=1", "a name before '='"),
                         ("uv=1,texture_u=2", "a property weighed twice")):
        rc, _, err = run("simplify", src, "-o", out, "--attribute-weight", spec)
        assert rc == 1 and reason in err and src in err, (spec, rc, err)
        assert not os.path.exists(out), spec
    # a bare weight on a mesh with neither: a warning, and the plain run
    base = path("bumpy.obj")
    plain, weighed = path("w_plain.obj"), path("w_none.obj")
    assert run("simplify", base, "-o", plain, "-q", "--ratio", "0.2")[0] == 0
    rc, _, err = run("simplify", base, "-o", weighed, "--ratio", "0.2", "--attribute-weight", "1")
    assert rc == 0 and "weighs nothing" in err, err
    with open(plain, "rb") as a, open(weighed, "rb") as b:
        assert a.read() == b.read()


def charts_of(tris):
    """The charts of a textured mesh: faces joined across every edge whose
    two corners have the same vt on both faces. Returns each face's chart."""
    parent = list(range(len(tris)))

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    by_edge = {}
    for i, t in enumerate(tris):
        for k in range(3):
            a, b = t[k], t[(k + 1) % 3]
            by_edge.setdefault(frozenset((a[0], b[0])), []).append((i, {a[0]: a[1], b[0]: b[1]}))
    for uses in by_edge.values():
        if len(uses) == 2 and uses[0][1] == uses[1][1]:
            parent[find(uses[0][0])] = find(uses[1][0])
    return [find(i) for i in range(len(tris))]


@case
def gen_charts_cuts_a_photogrammetry_like_atlas():
    """Issue 25: gen --charts gives every shape a UV atlas: the same surface
    as without it, about the charts asked, each in its own part of the unit
    square (no two overlap, no face turned over in UV), a position where
    charts meet is one record per chart, and the stream is sorted and
    finalized, or shuffled with the same corners. Simplify then keeps every
    corner and meets the size."""
    u = lambda c: struct.unpack("<f", c)[0]
    for shape, faces, charts in (("sphere", 3000, 12), ("torus", 4000, 100), ("terrain", 5000, 30),
                                 ("cad", 6000, 40), ("bumpy", 20000, 400)):
        atlas, plain = path("atlas_%s.obj" % shape), path("plain_%s.obj" % shape)
        for out, extra in ((atlas, ["--charts", str(charts)]), (plain, [])):
            rc, _, err = run("gen", shape, "--faces", str(faces), "-o", out, "-q", *extra)
            assert rc == 0, err
        tris, (nv, nvt, _) = read_obj(atlas)
        ptris, (pnv, _, _) = read_obj(plain)
        assert nv == pnv and sorted(rotated([c[0] for c in t]) for t in tris) == \
            sorted(rotated([c[0] for c in t]) for t in ptris), shape
        chart = charts_of(tris)
        n = len(set(chart))
        assert 0.7 * charts <= n <= 1.5 * charts, (shape, n, charts)
        box = {}
        for t, c in zip(tris, chart):
            us, vs = [u(x[1][0]) for x in t], [u(x[1][1]) for x in t]
            assert all(0 < x < 1 for x in us + vs), (shape, us, vs)
            area = (us[1] - us[0]) * (vs[2] - vs[0]) - (us[2] - us[0]) * (vs[1] - vs[0])
            assert area > 0, (shape, t)
            b = box.get(c, (2, 2, -1, -1))
            box[c] = (min(b[0], *us), min(b[1], *vs), max(b[2], *us), max(b[3], *vs))
        bs = sorted(box.values())
        for i, a in enumerate(bs):
            for b in bs[i + 1:]:
                if b[0] >= a[2]:
                    break
                assert not (b[1] < a[3] and a[1] < b[3]), (shape, a, b)
        # a vt is one chart's: the records are the (position, chart) pairs
        assert nvt == len({(c[0], ch) for t, ch in zip(tris, chart) for c in t}), shape
        smz = path("atlas_%s.smz" % shape)
        rc, _, err = run("gen", shape, "--faces", str(faces), "--charts", str(charts), "-o", smz, "-q")
        assert rc == 0, err
        rc, out, err = run("check", smz)
        assert rc == 0 and "valid:       yes" in out, (shape, out, err)
        inputs = {c for t in tris for c in t}
        for ratio in ("0.05", "0.25"):
            o = path("atlas_out.obj")
            rc, _, err = run("simplify", smz, "-o", o, "--ratio", ratio, "-q")
            assert rc == 0, (shape, err)
            got, _ = read_obj(o)
            want = round(float(ratio) * len(tris))
            assert abs(len(got) - want) <= max(1, want // 200), (shape, ratio, len(got), want)
            assert all(c in inputs for t in got for c in t), (shape, ratio)
        # shuffled, like a scanner's file: the same corners, in another
        # order, and simplify (which sorts it) meets the size all the same
        shuffled = path("atlas_shuffled_%s.obj" % shape)
        rc, _, err = run("gen", shape, "--faces", str(faces), "--charts", str(charts), "--shuffle", "-o", shuffled,
                         "-q")
        assert rc == 0, err
        stris, (snv, snvt, _) = read_obj(shuffled)
        assert (snv, snvt) == (nv, nvt) and sorted(map(rotated, stris)) == sorted(map(rotated, tris)), shape
        assert stris != tris, (shape, "not shuffled")
        o = path("atlas_shuffled_out.obj")
        rc, _, err = run("simplify", shuffled, "-o", o, "--ratio", "0.25", "-q")
        assert rc == 0, (shape, err)
        got, _ = read_obj(o)
        want = round(0.25 * len(tris))
        assert abs(len(got) - want) <= max(1, want // 200), (shape, len(got), want)
        assert all(c in inputs for t in got for c in t), shape


@case
def a_seam_pairs_copies_are_cut_into_one_slab():
    """The chunker keeps a position's copies in one slab (a vertex waits for
    the next cut while a copy is live), so no cut leaves a seam pair as two
    lone boundaries: the samples and the locked ones are those of one slab,
    whatever the slab size (docs/method.md §11)."""
    src = path("cut_atlas.obj")
    rc, _, err = run("gen", "bumpy", "--faces", "20000", "--charts", "50", "-o", src, "-q")
    assert rc == 0, err
    seen = set()
    for slab in ("1000", "3000", "100000"):
        rc, out, err = run("simplify", src, "-o", path("cut_out.obj"), "--slab", slab, "-q", "--stats", "-")
        assert rc == 0, err
        d = json.loads(out)
        assert d["slabs"] > 1 or slab == "100000", d["slabs"]
        seen.add((d["samples"], d["locked"], d["cut_end_vertices"]))
    assert len(seen) == 1, seen


finish()
