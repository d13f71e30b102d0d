#!/usr/bin/env python3
"""Files as users bring them (docs/architecture.md §13): STL and OFF are
written as well as read, bit for bit where the format allows; content that
names its format wins over a wrong extension, with a note; a file that holds
no mesh statement, or UTF-16 text, is a clear error; a UTF-8 byte-order mark
is skipped; a PLY header's free-text line is skipped and named."""
import math
import os
import shutil
import struct
import subprocess

from clitest import EPSNET, case, f32, finish, path, read_ascii_ply, read_ascii_ply_faced, run


def gen(name, faces=3000):
    p = path(name)
    if not os.path.exists(p):
        rc, _, err = run("gen", "bumpy", "--faces", str(faces), "-o", p, "-q")
        assert rc == 0, err
    return p


def triangles(p, *fmt):
    """The triangles of a mesh file as sorted triples of float32 corner bits
    (ASCII PLY in between: every writer's output is compared by geometry)."""
    out = path("tri_%s.ply" % os.path.basename(p))
    rc, _, err = run("convert", p, "-o", out, "--ascii", "-q", *fmt)
    assert rc == 0, (p, err)
    _, verts, faces = read_ascii_ply(out)
    pos = [tuple(f32(v[a]) for a in "xyz") for v in verts]
    # a triangle up to rotation of its corners
    tris = []
    for t in faces:
        c = [pos[i] for i in t]
        k = c.index(min(c))
        tris.append(tuple(c[k:] + c[:k]))
    return sorted(tris)


@case
def stl_and_off_are_written_and_read_back_bit_for_bit():
    src = gen("rt.smz")
    want = triangles(src)
    outs = {}
    for name, opts in (("rt.off", ()), ("rt.stl", ()), ("rt_ascii.stl", ("--ascii",)), ("rt.off.zst", ()),
                       ("rt.stl.zst", ())):
        out = path(name)
        rc, _, err = run("convert", src, "-o", out, "-q", *opts)
        assert rc == 0, (name, err)
        assert triangles(out) == want, f"{name}: not the input's triangles"
        outs[name] = open(out, "rb").read()
    # a second trip through the same format gives the same bytes
    for name, opts in (("rt.off", ()), ("rt.stl", ()), ("rt_ascii.stl", ("--ascii",))):
        again = path("again_" + name)
        rc, _, err = run("convert", path(name), "-o", again, "-q", *opts)
        assert rc == 0, err
        assert open(again, "rb").read() == outs[name], f"{name}: a second round trip changed the bytes"
    # ascii STL to binary is the binary writer's file; a pipe gets the same bytes
    rc, _, err = run("convert", path("rt_ascii.stl"), "-o", path("from_ascii.stl"), "-q")
    assert rc == 0 and open(path("from_ascii.stl"), "rb").read() == outs["rt.stl"], err
    # (an OFF file pads its counts line to patch it at the end; a pipe's
    # is written last, unpadded)
    for fmt, name in (("stl", "rt.stl"), ("off", "rt.off")):
        p = subprocess.run([EPSNET, "convert", src, "-o", "-", "--format", fmt, "-q"], capture_output=True,
                           timeout=120)
        piped = path("piped." + fmt)
        with open(piped, "wb") as f:
            f.write(p.stdout)
        assert p.returncode == 0 and triangles(piped) == want, f"{fmt} to a pipe: not the mesh"
        assert fmt != "stl" or p.stdout == outs[name], "binary STL to a pipe differs from the file"
    # binary STL: 80-byte title, the count, 50 bytes a facet
    b = outs["rt.stl"]
    n = struct.unpack("<I", b[80:84])[0]
    assert not b.startswith(b"solid") and n == len(want) and len(b) == 84 + 50 * n, (b[:8], n, len(b))


@case
def simplify_writes_stl_and_off():
    for name in ("part.stl", "part.off"):
        src = path(name)
        rc, _, err = run("convert", gen("rt.smz"), "-o", src, "-q")
        assert rc == 0, err
        out = path("small_" + name)
        rc, _, err = run("simplify", src, "-o", out, "--faces", "600", "-q")
        assert rc == 0, (name, err)
        assert len(triangles(out)) == 600, name


@case
def stl_names_float64_coordinates_as_rounded():
    src = path("double.obj")
    with open(src, "w") as f:
        f.write("v 0.1234567890123 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    rc, _, err = run("convert", src, "-o", path("double.stl"))
    assert rc == 0 and "float64 coordinates" in err, (rc, err)
    # OFF is text: the double comes back exactly
    rc, _, err = run("convert", src, "-o", path("double.off"))
    assert rc == 0 and "float64" not in err, err
    rc, _, err = run("convert", path("double.off"), "-o", path("double.ply"), "--ascii", "-q")
    _, verts, _ = read_ascii_ply(path("double.ply"))
    assert rc == 0 and verts[0]["x"] == "0.1234567890123", (err, verts[0])


@case
def content_that_names_its_format_wins_over_the_extension():
    smz = gen("named.smz")
    want = triangles(smz)
    cases = []
    for fmt, opts in (("ply", ("--ascii",)), ("ply", ()), ("stl", ()), ("smz", ())):
        real = path("real_%s%s.%s" % (fmt, "_ascii" if opts else "", fmt))
        rc, _, err = run("convert", smz, "-o", real, "-q", *opts)
        assert rc == 0, err
        cases.append((fmt, real))
    for fmt, real in cases:
        for wrong in ("obj", "off", "ply"):
            if wrong == fmt:
                continue
            p = path(os.path.basename(real) + "." + wrong)
            shutil.copy(real, p)
            out = path("fixed.smz")
            rc, _, err = run("simplify", p, "-o", out, "-q")
            lines = err.strip().splitlines()
            assert rc == 0 and len(lines) == 1, (p, rc, err)
            assert "named as %s but its content is %s" % (wrong, fmt) in lines[0], lines[0]
            assert triangles(p) == want, f"{p}: not the mesh"


@case
def a_file_with_no_mesh_statement_is_an_error():
    p = path("notes.obj")
    with open(p, "w") as f:
        f.write("these are my notes\nnothing here is a mesh\n")
    out = path("notes_out.ply")
    rc, _, err = run("simplify", p, "-o", out)
    assert rc == 2 and "not an OBJ file" in err and "'these'" in err and len(err.strip().splitlines()) == 1, (rc, err)
    assert not os.path.exists(out)
    # OBJ statements that give no vertex (texture coordinates alone, groups
    # and materials alone) are an OBJ without its geometry: an error that
    # names the first of them, not "none of OBJ's", not an empty mesh
    for name, text, first in (("vt_only.obj", "# uv\nvt 0 0\nvt 1 0\n", "'vt' first, on line 2"),
                              ("groups_only.obj", "mtllib m.mtl\ng left\nusemtl red\n", "'mtllib' first, on line 1")):
        p = path(name)
        with open(p, "w") as f:
            f.write(text)
        rc, _, err = run("simplify", p, "-o", out)
        assert rc == 2 and "no vertex: the file has OBJ statements" in err and first in err, (name, rc, err)
        assert "none of OBJ's" not in err and len(err.strip().splitlines()) == 1, (name, err)
        assert not os.path.exists(out)
    # comments alone are an empty mesh, which is valid
    p = path("comments.obj")
    with open(p, "w") as f:
        f.write("# exported by hand\n\n# nothing yet\n")
    rc, _, err = run("convert", p, "-o", path("comments.ply"), "-q")
    assert rc == 0, err


@case
def a_utf8_byte_order_mark_is_skipped():
    # Windows editors start a UTF-8 text with EF BB BF: it is no part of the
    # first line. Before, an OBJ lost its first vertex (every face then named
    # the wrong one, with exit 0), and OFF, ASCII STL and ASCII PLY were refused.
    src = gen("bom.smz", faces=200)
    for ext, fmt in (("obj", ()), ("off", ()), ("stl", ("--ascii",)), ("ply", ("--ascii",))):
        plain = path("bom_plain." + ext)
        rc, _, err = run("convert", src, "-o", plain, "-q", *fmt)
        assert rc == 0, err
        marked = path("bom_marked." + ext)
        with open(plain, "rb") as f, open(marked, "wb") as g:
            g.write(b"\xef\xbb\xbf" + f.read())
        rc, _, err = run("convert", marked, "-o", path("bom_out.ply"))
        assert rc == 0 and "warning" not in err, (ext, rc, err)
        assert triangles(marked) == triangles(plain), ext + ": not the same mesh"


@case
def utf16_text_is_named():
    for enc in ("utf-16", "utf-16-le", "utf-16-be"):
        p = path("wide_%s.obj" % enc)
        with open(p, "wb") as f:
            f.write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".encode(enc))
        rc, _, err = run("convert", p, "-o", path("wide.ply"))
        assert rc == 2 and "UTF-16" in err and "NUL byte" not in err, (enc, rc, err)


@case
def a_ply_header_line_of_free_text_is_skipped_and_named():
    smz = gen("created.smz")
    plain = path("created_plain.ply")
    rc, _, err = run("convert", smz, "-o", plain, "--ascii", "-q")
    assert rc == 0, err
    text = open(plain).read().replace("format ascii 1.0\n", "format ascii 1.0\nCreated by SomeScanner v2\n", 1)
    p = path("created_by.ply")
    with open(p, "w") as f:
        f.write(text)
    rc, _, err = run("simplify", p, "-o", path("created_out.ply"))
    assert rc == 0 and "dropped: header line 'Created' (1)" in err, (rc, err)
    assert triangles(p) == triangles(plain)



@case
def render_refuses_a_name_that_is_not_png():
    src = gen("rt.smz")
    for name in ("pic.jpg", "pic", "pic.png.bak"):
        rc, _, err = run("render", src, "-o", path(name))
        assert rc == 5 and "PNG" in err and not os.path.exists(path(name)), (name, rc, err)
    rc, _, err = run("render", src, "-o", path("pic.PNG"), "-q")
    assert rc == 0 and open(path("pic.PNG"), "rb").read(8) == b"\x89PNG\r\n\x1a\n", err


@case
def a_missing_output_folder_is_named():
    missing = path("no_such_folder")
    for src in (gen("rt.smz"), path("rt.stl")):  # a stream, and a file sorted first (in the output's folder)
        rc, _, err = run("simplify", src, "-o", os.path.join(missing, "out.ply"))
        assert rc == 3 and missing in err and "does not exist" in err, (src, rc, err)


@case
def unreferenced_vertices_are_counted_and_named():
    """The output is a surface: a vertex no face uses is not written, and
    the run says so and counts it (docs/architecture.md §5)."""
    import json
    src = path("lonely.obj")
    with open(src, "w") as f:
        f.write("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nv 6 6 6\nf 1 2 3\n")
    smz = path("lonely.smz")
    rc, _, err = run("convert", src, "-o", smz, "-q")
    assert rc == 0, err
    for p in (src, smz):  # sorted first, and read as a stream
        stats = path("lonely.json")
        rc, _, err = run("simplify", p, "-o", path("lonely_out.ply"), "--stats", stats)
        s = json.load(open(stats))
        assert rc == 0 and "2 vertices that no face uses are not written" in err, (p, err)
        assert s["vertices"] == 5 and s["isolated_vertices"] == 2 and s["output_vertices"] == 3, (p, s)


def flat_shaded_obj(name, faces=6000):
    """A closed bumpy surface written as a flat-shaded OBJ: one vn per face,
    so that no two faces share a corner (every vertex is split by its
    normals)."""
    src = path(name + "_src.obj")
    rc, _, err = run("gen", "bumpy", "--faces", str(faces), "-o", src, "-q")
    assert rc == 0, err
    vs, fs = [], []
    for line in open(src):
        if line.startswith("v "):
            vs.append(tuple(float(x) for x in line.split()[1:4]))
        elif line.startswith("f "):
            fs.append(tuple(int(t.split("/")[0]) for t in line.split()[1:4]))
    p = path(name + ".obj")
    with open(p, "w") as f:
        for v in vs:
            f.write("v %r %r %r\n" % v)
        for a, b, c in fs:
            A, B, C = vs[a - 1], vs[b - 1], vs[c - 1]
            u = [B[k] - A[k] for k in range(3)]
            w = [C[k] - A[k] for k in range(3)]
            n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
            norm = sum(x * x for x in n) ** 0.5 or 1.0
            f.write("vn %.6f %.6f %.6f\n" % tuple(x / norm for x in n))
        for i, (a, b, c) in enumerate(fs):
            f.write("f %d//%d %d//%d %d//%d\n" % (a, i + 1, b, i + 1, c, i + 1))
    return p, vs, len(fs)


def recomputed_normals(verts, faces):
    """Each vertex's unit normal from the faces around its position (around
    every copy of it), area-weighted: what an output gets after
    --drop-normals."""
    acc = {tuple(v): [0.0, 0.0, 0.0] for v in verts}
    for t in faces:
        a, b, c = (verts[i] for i in t)
        e1 = [b[k] - a[k] for k in range(3)]
        e2 = [c[k] - a[k] for k in range(3)]
        n = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
        for i in t:
            for k in range(3):
                acc[tuple(verts[i])][k] += n[k]
    out = []
    for v in verts:
        n = acc[tuple(v)]
        length = math.sqrt(sum(x * x for x in n))
        out.append([x / length for x in n] if length else [0.0, 0.0, 0.0])
    return out


@case
def a_flat_shaded_obj_simplifies_with_drop_normals():
    """Issue 25: an OBJ whose corners differ by their normal is all seams;
    --drop-normals reads it as one surface and meets --ratio 0.1, and the
    output's vertex normals are recomputed from its own faces (one vn per
    vertex); without it, the miss names the way out."""
    p, vs, nf = flat_shaded_obj("flat")
    want = round(0.1 * nf)
    for name, opts in (("flat_out.obj", []), ("flat_slabs.obj", ["--slab", "500", "-j2"])):
        out = path(name)
        rc, _, err = run("simplify", p, "-o", out, "--ratio", "0.1", "--drop-normals", *opts)
        assert rc == 0, err
        assert "vertex normals (--drop-normals: not read; an output that holds normals gets them recomputed" in err, err
        verts, normals, faces = [], [], []
        for l in open(out).read().splitlines():
            w = l.split()
            if w and w[0] == "v":
                verts.append([float(x) for x in w[1:4]])
            elif w and w[0] == "vn":
                normals.append([float(x) for x in w[1:4]])
            elif w and w[0] == "f":
                corners = [c.split("/") for c in w[1:]]
                assert all(c[0] == c[2] for c in corners), f"{name}: a corner's vn is not its vertex's: {l}"
                faces.append([int(c[0]) - 1 for c in corners])
        assert abs(len(faces) - want) <= max(1, want // 200), (name, len(faces), want)
        assert len(normals) == len(verts), (name, len(normals), len(verts))
        inputs = {tuple(f32(repr(x)) for x in v) for v in vs}
        assert all(tuple(f32(repr(x)) for x in v) in inputs for v in verts), name
        for got, exp in zip(normals, recomputed_normals(verts, faces)):
            assert all(abs(g - e) < 1e-5 for g, e in zip(got, exp)), (name, got, exp)
    # the same mesh without the option: nothing to remove, and the warning says why
    rc, _, err = run("simplify", p, "-o", path("flat_kept.obj"), "--ratio", "0.1")
    assert rc == 0 and "--drop-normals" in err, err
    # a PLY's normals go the same way, and come back recomputed; a .smz
    # output is a valid stream with them; OFF holds none, and has none
    ply = path("normals.ply")
    rc, _, err = run("convert", p, "-o", ply, "--ascii", "-q")
    assert rc == 0, err
    props, _, _ = read_ascii_ply(ply)
    assert "nx" in [n for n, _ in props], props
    rc, _, err = run("simplify", ply, "-o", path("normals_out.ply"), "--ascii", "--ratio", "0.5", "--drop-normals")
    assert rc == 0 and "vertex normals" in err, err
    props, pv, pf = read_ascii_ply(path("normals_out.ply"))
    names = [n for n, _ in props]
    assert names[-3:] == ["nx", "ny", "nz"], names
    pos = [[float(v[a]) for a in ("x", "y", "z")] for v in pv]
    for v, exp in zip(pv, recomputed_normals(pos, [list(f) for f in pf])):
        assert all(abs(float(v[a]) - e) < 1e-5 for a, e in zip(("nx", "ny", "nz"), exp)), (v, exp)
    smz = path("normals_out.smz")
    rc, _, err = run("simplify", p, "-o", smz, "--ratio", "0.2", "--drop-normals", "--slab", "500", "-q")
    assert rc == 0, err
    rc, out, err = run("check", smz)
    assert rc == 0 and "valid:       yes" in out, out + err
    rc, out, _ = run("info", smz)
    assert "nx, float ny, float nz" in out, out
    rc, _, err = run("simplify", p, "-o", path("normals_out.off"), "--ratio", "0.2", "--drop-normals", "-q")
    assert rc == 0 and "nx" not in open(path("normals_out.off")).read(), err


@case
def copies_of_a_position_get_one_recomputed_normal():
    """Issue 25: after --drop-normals, the copies of a position (a material
    border, a UV seam) get the normal of the whole surface around it, so a
    PLY welds a material border back into one vertex a position (it was cut
    along it: 258 vertices for 241 positions) and no seam shows in the
    shading."""
    n = 20
    verts = [(i / n, j / n, 0.02 * ((i * 7 + j * 3) % 5)) for j in range(n + 1) for i in range(n + 1)]
    faces = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            m = 0 if i < n // 2 else 1
            faces += [(a, a + 1, a + n + 2, m), (a, a + n + 2, a + n + 1, m)]
    p = path("labelled_normals.ply")
    with open(p, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
                "property float nx\nproperty float ny\nproperty float nz\nelement face %d\n"
                "property list uchar int vertex_indices\nproperty uchar material_index\nend_header\n"
                % (len(verts), len(faces)))
        for v in verts:
            f.write("%r %r %r 0 0 1\n" % v)
        for t in faces:
            f.write("3 %d %d %d %d\n" % t)
    for opts in ([], ["--slab", "60", "-j", "2"]):
        out = path("labelled_normals_out.ply")
        rc, _, err = run("simplify", p, "-o", out, "--ascii", "--ratio", "0.5", "--drop-normals", "-q", *opts)
        assert rc == 0, err
        props, pv, pf = read_ascii_ply(out)
        pos = [tuple(float(v[a]) for a in ("x", "y", "z")) for v in pv]
        assert len(set(pos)) == len(pos), (opts, len(pos), len(set(pos)))
        for v, exp in zip(pv, recomputed_normals([list(q) for q in pos], [list(f) for f in pf])):
            assert all(abs(float(v[a]) - e) < 1e-5 for a, e in zip(("nx", "ny", "nz"), exp)), (opts, v, exp)
    # an OBJ's UV seam: its two sides' copies get one normal
    obj = path("uv_seam_normals.obj")
    with open(obj, "w") as f:
        for v in verts:
            f.write("v %r %r %r\nvn 0 0 1\n" % v)
        for v in verts:
            f.write("vt %r %r\n" % (v[0], v[1]))
        for v in verts:
            f.write("vt %r %r\n" % (v[0] + 2.0, v[1]))  # the right half's chart
        nv = len(verts)
        for a, b, c, m in faces:
            off = nv if m else 0
            f.write("f %s\n" % " ".join("%d/%d/%d" % (i + 1, i + 1 + off, i + 1) for i in (a, b, c)))
    out = path("uv_seam_normals_out.obj")
    rc, _, err = run("simplify", obj, "-o", out, "--ratio", "0.5", "--drop-normals", "-q")
    assert rc == 0, err
    ov, on, normal_of = [], [], {}
    for l in open(out).read().splitlines():
        w = l.split()
        if w and w[0] == "v":
            ov.append(tuple(float(x) for x in w[1:4]))
        elif w and w[0] == "vn":
            on.append(tuple(float(x) for x in w[1:4]))
        elif w and w[0] == "f":
            for c in w[1:]:
                vi, _, ni = c.split("/")
                normal_of.setdefault(ov[int(vi) - 1], set()).add(on[int(ni) - 1])
    assert any(abs(q[0] - 0.5) < 1e-9 for q in normal_of), "the seam is gone"
    split = {q: ns for q, ns in normal_of.items() if len(ns) > 1}
    assert not split, list(split.items())[:3]


def two_material_obj(name, n=40):
    """A bumpy grid in an OBJ with vt, a mtllib, two materials and two
    groups: the faces left of x = 0.5 use matA, the others matB (the usemtl
    runs switch row by row); the rows below y = 0.5 are group low, the
    others high."""
    p = path(name + ".obj")
    with open(p, "w") as f:
        f.write("mtllib %s.mtl\n" % name)
        for j in range(n + 1):
            for i in range(n + 1):
                f.write("v %r %r %r\n" % (i / n, j / n, 0.01 * ((i * 7 + j * 3) % 5)))
        for j in range(n + 1):
            for i in range(n + 1):
                f.write("vt %r %r\n" % (i / n, j / n))
        cur = None
        for j in range(n):
            if j in (0, n // 2):
                f.write("g %s\n" % ("low" if j == 0 else "high"))
                cur = None
            for i in range(n):
                m = "matA" if i < n // 2 else "matB"
                if m != cur:
                    f.write("usemtl %s\n" % m)
                    cur = m
                a, b = j * (n + 1) + i + 1, j * (n + 1) + i + 2
                c, d = b + n + 1, a + n + 1
                f.write("f %d/%d %d/%d %d/%d\n" % (a, a, b, b, c, c))
                f.write("f %d/%d %d/%d %d/%d\n" % (a, a, c, c, d, d))
    with open(path(name + ".mtl"), "w") as f:
        f.write("newmtl matA\nKd 1 0 0\nnewmtl matB\nKd 0 0 1\n")
    return p, 2 * n * n


def obj_faces_by_material(p):
    """[(material, [x of the three corners], group, [y of the corners])] of
    an OBJ, and its mtllib lines."""
    xs, ys, faces, libs, cur, group = [], [], [], [], None, None
    for line in open(p):
        t = line.split()
        if not t:
            continue
        if t[0] == "v":
            xs.append(float(t[1]))
            ys.append(float(t[2]))
        elif t[0] == "usemtl":
            cur = t[1] if len(t) > 1 else ""
        elif t[0] == "g":
            group = t[1] if len(t) > 1 else ""
        elif t[0] == "mtllib":
            libs.append(" ".join(t[1:]))
        elif t[0] == "f":
            c = [int(c.split("/")[0]) - 1 for c in t[1:4]]
            faces.append((cur, [xs[i] for i in c], group, [ys[i] for i in c]))
    return faces, libs


@case
def materials_and_groups_travel_with_their_faces():
    """Issue 25: an OBJ's mtllib, usemtl and g survive simplify and convert;
    no face changes material or group (every face keeps to its side of each
    boundary), the boundaries are not smeared, and a format that cannot
    hold the names says so."""
    p, nf = two_material_obj("mat")
    for args in (["--ratio", "0.25"], ["--ratio", "0.25", "--slab", "300"], []):
        out = path("mat_out.obj")
        rc, _, err = run("simplify", p, "-o", out, "-q", *args)
        assert rc == 0, (args, err)
        faces, libs = obj_faces_by_material(out)
        assert libs == ["mat.mtl"], (args, libs)
        assert {f[0] for f in faces} == {"matA", "matB"} and {f[2] for f in faces} == {"low", "high"}, args
        for m, xs, g, ys in faces:
            # a sliver standing on a boundary belongs to either side
            if not min(xs) == max(xs) == 0.5:
                side = "matA" if max(xs) <= 0.5 else "matB" if min(xs) >= 0.5 else None
                assert side == m, (args, m, xs)
            if not min(ys) == max(ys) == 0.5:
                side = "low" if max(ys) <= 0.5 else "high" if min(ys) >= 0.5 else None
                assert side == g, (args, g, ys)
        if args[:1] == ["--ratio"]:
            want = round(0.25 * nf)
            assert abs(len(faces) - want) <= max(1, want // 200), (args, len(faces), want)
            # the material boundary is a seam: its positions go in pairs
            # along it (41 in the input; its ends and the crossing stay)
            on = {y for _, xs, _, ys in faces for x, y in zip(xs, ys) if x == 0.5}
            assert 3 <= len(on) < 41, (args, sorted(on))
    # convert keeps every face's material and the runs
    rc, _, err = run("convert", p, "-o", path("mat_copy.obj"), "-q")
    assert rc == 0, err
    faces, libs = obj_faces_by_material(path("mat_copy.obj"))
    assert libs == ["mat.mtl"] and len(faces) == nf
    assert [f[0] for f in faces] == ["matA" if (i // 2) % 40 < 20 else "matB" for i in range(nf)]
    assert [f[2] for f in faces] == ["low" if i < nf // 2 else "high" for i in range(nf)]
    # PLY keeps the indices as face properties, one vertex at each position,
    # and the names as header comments, which its reader takes back: the
    # PLY converts to the OBJ that simplify writes directly (ascii, binary)
    rc, _, err = run("simplify", p, "-o", path("mat_direct.obj"), "-q", "--ratio", "0.25")
    assert rc == 0 and err == "", err
    direct, libs = obj_faces_by_material(path("mat_direct.obj"))
    for ascii in (["--ascii"], []):
        rc, _, err = run("simplify", p, "-o", path("mat_out.ply"), "-q", "--ratio", "0.25", *ascii)
        assert rc == 0 and err == "", err
        with open(path("mat_out.ply"), "rb") as f:
            head = f.read().split(b"end_header")[0].decode()
        assert ("comment epsnet mtllib mat.mtl\ncomment epsnet material_index 0 matA\n"
                "comment epsnet material_index 1 matB\n") in head, head
        rc, _, err = run("convert", path("mat_out.ply"), "-o", path("mat_back.obj"), "-q")
        assert rc == 0 and err == "", err
        back, back_libs = obj_faces_by_material(path("mat_back.obj"))
        assert back == direct and back_libs == libs == ["mat.mtl"], (ascii, len(back), len(direct))
    rc, _, err = run("convert", path("mat_out.ply"), "-o", path("mat_out_a.ply"), "--ascii", "-q")
    assert rc == 0 and err == "", err
    vprops, fprops, verts, _, _ = read_ascii_ply_faced(path("mat_out_a.ply"))
    assert ("material_index", "ushort") in fprops and ("group_index", "ushort") in fprops, fprops
    assert "material_index" not in dict(vprops), vprops
    xyz = [(v["x"], v["y"], v["z"]) for v in verts]
    assert len(set(xyz)) == len(xyz), "a position written twice"
    # STL holds neither: usemtl and g are named as dropped
    rc, _, err = run("simplify", p, "-o", path("mat_out.stl"), "--ratio", "0.25")
    assert rc == 0 and "usemtl" in err and "g (2)" in err, err


def face_labelled_ply(name, n=40, binary=False, label_first=False):
    """A bumpy grid as a PLY whose faces carry an int material_index (0 left
    of x = 0.5, 1 right of it) and a float quality, and one vertex no face
    uses; binary or ascii, the label before or after the index list."""
    verts = [(i / n, j / n, 0.01 * ((i * 7 + j * 3) % 5)) for j in range(n + 1) for i in range(n + 1)]
    verts.append((5.0, 5.0, 5.0))
    faces = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            b, c, d = a + 1, a + n + 2, a + n + 1
            m = 0 if i < n // 2 else 1
            faces += [(m, (a, b, c)), (m, (a, c, d))]
    lst, lab = "property list uchar int vertex_indices\n", "property int material_index\n"
    head = ("ply\nformat %s 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
            "element face %d\n%sproperty float quality\nend_header\n"
            % ("binary_little_endian" if binary else "ascii", len(verts), len(faces),
               lab + lst if label_first else lst + lab))
    p = path(name)
    with open(p, "wb") as f:
        f.write(head.encode())
        for v in verts:
            f.write(struct.pack("<3f", *v) if binary else ("%r %r %r\n" % v).encode())
        for m, t in faces:
            if binary:
                idx = struct.pack("<B3i", 3, *t)
                lb = struct.pack("<i", m)
                f.write((lb + idx if label_first else idx + lb) + struct.pack("<f", 0.5))
            else:
                idx, lb = "3 %d %d %d" % t, "%d" % m
                f.write(("%s %s 0.5\n" % ((lb, idx) if label_first else (idx, lb))).encode())
    return p, len(faces)


@case
def a_ply_face_material_index_travels_with_its_faces():
    """Issue 25: a PLY face property such as material_index is carried by the
    face's corners, as an OBJ's usemtl is: no face changes material, the
    boundary collapses along its length, and what is not carried (a float
    face property, a vertex no face uses) is named. The output PLY has it on
    its faces again, and one vertex at each position: the boundary is not a
    cut."""
    for binary in (False, True):
        for label_first in (False, True):
            p, nf = face_labelled_ply("fl_%d%d.ply" % (binary, label_first), binary=binary, label_first=label_first)
            rc, out, err = run("info", p)
            assert rc == 0 and "int material_index (a face's)" in out, (p, out, err)
            assert "face property quality" in out and "vertices no face uses (1)" in out, out
            for args in (["--ratio", "0.25"], ["--ratio", "0.25", "--slab", "300", "-j", "2"]):
                o = path("fl_out.ply")
                rc, _, err = run("simplify", p, "-o", o, "--ascii", *args)
                assert rc == 0, (p, args, err)
                assert "face property quality" in err and "vertices no face uses (1)" in err, err
                vprops, fprops, verts, faces, values = read_ascii_ply_faced(o)
                assert ("material_index", "int") in fprops and "material_index" not in dict(vprops), (vprops, fprops)
                want = round(0.25 * nf)
                assert abs(len(faces) - want) <= max(1, want // 200), (p, args, len(faces), want)
                xyz = [(v["x"], v["y"], v["z"]) for v in verts]
                assert len(set(xyz)) == len(xyz), (p, args, "a position written twice")
                on = set()
                for t, val in zip(faces, values):
                    m = val["material_index"]
                    xs = [float(verts[i]["x"]) for i in t]
                    if not min(xs) == max(xs) == 0.5:
                        side = "0" if max(xs) <= 0.5 else "1" if min(xs) >= 0.5 else None
                        assert side == m, (p, args, xs, m)
                    on |= {float(verts[i]["y"]) for i in t if float(verts[i]["x"]) == 0.5}
                # the boundary is a seam: it loses positions along its length
                assert 2 <= len(on) < 41, (p, args, sorted(on))
    # converted, the file comes back as it was: each face its material, each
    # position one vertex, and converting that again changes no byte
    a, b = path("fl_rt_a.ply"), path("fl_rt_b.ply")
    rc, _, err = run("convert", path("fl_10.ply"), "-o", a, "--ascii", "-q")
    assert rc == 0, err
    rc, _, err = run("convert", a, "-o", b, "--ascii", "-q")
    assert rc == 0, err
    assert open(a, "rb").read() == open(b, "rb").read(), "a second conversion changed the file"
    # .smz keeps the values a face's (its attribute table's mark)
    c, d = path("fl_rt.smz"), path("fl_rt_d.ply")
    rc, _, err = run("convert", a, "-o", c, "-q")
    assert rc == 0, err
    rc, _, err = run("convert", c, "-o", d, "--ascii", "-q")
    assert rc == 0, err
    assert open(d, "rb").read() == open(a, "rb").read(), "PLY -> .smz -> PLY changed the file"
    _, _, verts, faces, values = read_ascii_ply_faced(a)
    assert len(verts) == 41 * 41 and len(faces) == nf, (len(verts), len(faces))
    assert sorted(v["material_index"] for v in values) == ["0"] * (nf // 2) + ["1"] * (nf // 2), values[:4]
    for t, val in zip(faces, values):
        xs = [float(verts[i]["x"]) for i in t]
        assert val["material_index"] == ("0" if max(xs) <= 0.5 else "1"), (t, xs, val)
    # the labels are the same records whichever encoding and order
    outs = []
    for binary in (False, True):
        for label_first in (False, True):
            o = path("fl_conv_%d%d.ply" % (binary, label_first))
            rc, _, err = run("convert", path("fl_%d%d.ply" % (binary, label_first)), "-o", o, "-q")
            assert rc == 0, err
            outs.append(open(o, "rb").read())
    assert all(o == outs[0] for o in outs), "the four encodings read as different records"
    # an index past the vertex block is an error naming the face
    bad = path("fl_bad.ply")
    text = open(path("fl_00.ply")).read().replace("\n3 0 1 42 0", "\n3 0 1 9999 0", 1)
    open(bad, "w").write(text)
    rc, _, err = run("convert", bad, "-o", path("fl_bad_out.ply"), "-q")
    assert rc != 0 and "vertex index 9999 is out of range" in err, err
    assert not os.path.exists(path("fl_bad_out.ply"))


def named_ply(name, comments, label_type="ushort", labels=(0, 1)):
    """Two triangles of an ASCII PLY whose faces carry material_index (the
    given values) and whose header has the given comment lines."""
    with open(path(name), "w") as f:
        f.write("ply\nformat ascii 1.0\n" + "".join("comment %s\n" % c for c in comments) +
                "element vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 2\n"
                "property list uchar int vertex_indices\nproperty %s material_index\nend_header\n"
                "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2 %d\n3 0 2 3 %d\n" % (label_type, labels[0], labels[1]))
    return path(name)


@case
def material_names_ride_in_a_ply_header():
    """Issue 25: a PLY keeps the names of its faces' materials and groups in
    header comments (src/io/fmt_ply.c, ply_names), so OBJ -> PLY -> OBJ
    keeps usemtl, g and mtllib, whatever the names (spaces, the unnamed
    faces before the first usemtl), and PLY -> PLY keeps the comments;
    comments that do not fit the faces are named or refused."""
    obj = path("names.obj")
    with open(obj, "w") as f:
        f.write("mtllib my lib.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\nusemtl\ng part one\n"
                "f 1 2 3\nusemtl oak  wood\nf 1 3 4\nusemtl steel\nf 2 5 6\ng\nf 2 6 3\n")
    want, libs = obj_faces_by_material(obj)
    want = [(m, g) for m, _, g, _ in want]
    for ascii in (["--ascii"], []):
        for out in ("names.ply", "names.ply.zst"):
            rc, _, err = run("convert", obj, "-o", path(out), "-q", *ascii)
            assert rc == 0 and err == "", err
            rc, _, err = run("convert", path(out), "-o", path("names_back.obj"), "-q")
            assert rc == 0 and err == "", (out, err)
            back, back_libs = obj_faces_by_material(path("names_back.obj"))
            assert [(m, g) for m, _, g, _ in back] == want and back_libs == libs == ["my lib.mtl"], (out, back)
    with open(path("names.ply"), "rb") as f:
        head = f.read().split(b"end_header")[0].decode()
    assert ("comment epsnet mtllib my lib.mtl\ncomment epsnet material_index 0\n"
            "comment epsnet material_index 1 oak  wood\ncomment epsnet material_index 2 steel\n"
            "comment epsnet group_index 0 part one\ncomment epsnet group_index 1\n") in head, head
    for p in (obj, path("names.ply")):
        rc, out, err = run("info", p)
        assert rc == 0 and "materials:   3 (mtllib my lib.mtl): '', 'oak  wood', 'steel'\n" in out, out
        assert "groups:      2: 'part one', ''\n" in out, out
    rc, _, err = run("convert", path("names.ply"), "-o", path("names_again.ply"), "-q")
    assert rc == 0 and err == "", err
    assert open(path("names_again.ply"), "rb").read() == open(path("names.ply"), "rb").read()
    # comments out of order, or for a property that is not a face's ushort,
    # are named as dropped; the values still travel
    good = ["epsnet material_index 0 a", "epsnet material_index 1 b"]
    for comments, ty, why in ((good[::-1], "ushort", "not numbered 0, 1, 2, ... in order"),
                              (["epsnet material_index 0 a", "epsnet material_index 2 b"], "ushort",
                               "not numbered 0, 1, 2, ... in order"),
                              (good, "int", "no face property ushort of that name")):
        p = named_ply("names_odd.ply", comments, ty)
        rc, _, err = run("convert", p, "-o", path("names_odd.obj"), "-q")
        assert rc == 0 and "header comments naming material_index (%s)" % why in err, err
        assert "usemtl" not in open(path("names_odd.obj")).read()
    # free-text comments are no names
    p = named_ply("names_free.ply", ["written by someone", "epsnet says hello"])
    rc, _, err = run("convert", p, "-o", path("names_free_out.obj"), "-q")
    assert rc == 0 and "header comments" not in err, err
    # a face's value beyond the names is an error at that face, and nothing is written
    p = named_ply("names_short.ply", good[:1])
    for cmd in ("convert", "simplify"):
        rc, _, err = run(cmd, p, "-o", path("names_short_out.obj"), "-q")
        assert rc != 0 and "names_short.ply:17: face 2: material_index 1 has no name (the header's comments name 1)" \
            in err, err
        assert not os.path.exists(path("names_short_out.obj"))


def texcoord_ply(name, n=20, binary=False, vertex_uv=False):
    """A bumpy grid as MeshLab and Metashape write a textured PLY: a face list
    `texcoord` (u, v of each corner), two UV charts meeting at x = 0.5 (a
    seam), and the texture's name in a comment. Returns the path, the face
    count and the set of (position, uv) corners as float32 bits."""
    verts = [(i / n, j / n, 0.01 * ((i * 7 + j * 3) % 5)) for j in range(n + 1) for i in range(n + 1)]
    faces, corners = [], set()
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            left = i < n // 2
            for t in ((a, a + 1, a + n + 2), (a, a + n + 2, a + n + 1)):
                uv = []
                for v in t:
                    x, y = (v % (n + 1)) / n, (v // (n + 1)) / n
                    uv.append((0.5 * x if left else 0.1 + 0.5 * x, y))
                    corners.add((tuple(f32(repr(c)) for c in verts[v]), tuple(f32(repr(c)) for c in uv[-1])))
                faces.append((t, uv))
    head = ("ply\nformat %s 1.0\ncomment TextureFile tex.png\nelement vertex %d\nproperty float x\n"
            "property float y\nproperty float z\n%selement face %d\nproperty list uchar int vertex_indices\n"
            "property list uchar float texcoord\nend_header\n" %
            ("binary_little_endian" if binary else "ascii", len(verts),
             "property float texture_u\nproperty float texture_v\n" if vertex_uv else "", len(faces)))
    with open(path(name), "wb") as f:
        f.write(head.encode())
        for v in verts:
            extra = (0.0, 0.0) if vertex_uv else ()
            f.write(struct.pack("<%df" % (3 + len(extra)), *v, *extra) if binary else
                    (" ".join(repr(c) for c in v + extra) + "\n").encode())
        for t, uv in faces:
            flat = [c for p in uv for c in p]
            f.write(struct.pack("<B3iB6f", 3, *t, 6, *flat) if binary else
                    ("3 %d %d %d 6 %s\n" % (*t, " ".join(repr(c) for c in flat))).encode())
    return path(name), len(faces), corners


def obj_corners(p):
    """The (position, uv) of every face corner of an OBJ, as float32 bits."""
    v, vt, out = [], [], []
    for line in open(p):
        w = line.split()
        if w and w[0] == "v":
            v.append(tuple(f32(c) for c in w[1:4]))
        elif w and w[0] == "vt":
            vt.append(tuple(f32(c) for c in w[1:3]))
        elif w and w[0] == "f":
            for c in w[1:]:
                i, t = c.split("/")[:2]
                out.append((v[int(i) - 1], vt[int(t) - 1]))
    return out


@case
def a_ply_with_per_face_texcoord_simplifies_across_its_seams():
    """Issue 25: a textured PLY from MeshLab or Metashape keeps its texture
    coordinates in a face list, one u, v per corner. They travel as
    texture_u and texture_v of the corners, as an OBJ's vt do: the UV seam
    is a seam, collapsed along, and every output corner is an input corner;
    the texture's file name, which no output can take, is named."""
    for binary in (False, True):
        p, nf, corners = texcoord_ply("tc_%d.ply" % binary, binary=binary)
        rc, out, err = run("info", p)
        assert rc == 0 and "attributes:  float texture_u, float texture_v" in out, out
        assert "texture file tex.png (comment TextureFile)" in out, out
        for args in (["--ratio", "0.25"], ["--ratio", "0.3", "--slab", "120", "-j", "2"]):
            o = path("tc_out.obj")
            rc, _, err = run("simplify", p, "-o", o, *args)
            assert rc == 0 and "texture file tex.png (comment TextureFile)" in err, err
            got = obj_corners(o)
            want = round(float(args[1]) * nf)
            assert abs(len(got) // 3 - want) <= max(1, want // 200), (binary, args, len(got) // 3, want)
            assert got and all(c in corners for c in got), (binary, args, "a corner that is not an input corner")
        # the seam moved: the copies at x = 0.5 are fewer than the input's 21 pairs
        seam = {c[0] for c in got if c[0][0] == f32("0.5")}
        assert len(seam) < 21, len(seam)
        # a PLY output carries them as vertex properties, a copy of the position on each side of the seam
        rc, _, err = run("simplify", p, "-o", path("tc_out.ply"), "--ascii", "-q", "--ratio", "0.25")
        assert rc == 0, err
        vprops, _, verts, faces, _ = read_ascii_ply_faced(path("tc_out.ply"))
        assert [n for n, _ in vprops] == ["x", "y", "z", "texture_u", "texture_v"], vprops
        for t in faces:
            for i in t:
                c = verts[i]
                key = (tuple(f32(c[a]) for a in "xyz"), (f32(c["texture_u"]), f32(c["texture_v"])))
                assert key in corners, key
    # a list that does not give u and v for each corner is an error at its face
    p = path("tc_short.ply")
    with open(path("tc_0.ply")) as f, open(p, "w") as g:
        text = f.read()
        at = text.index("end_header\n") + len("end_header\n")
        lines = text[at:].split("\n")
        lines[441 + 2] = " ".join(lines[441 + 2].split()[:-2]).replace(" 6 ", " 4 ")
        g.write(text[:at] + "\n".join(lines))
    rc, _, err = run("simplify", p, "-o", path("tc_short.obj"), "-q")
    assert rc != 0 and "tc_short.ply:%d: face 3: texcoord has 4 values for 3 corners" % (11 + 441 + 3) in err, err
    assert not os.path.exists(path("tc_short.obj"))
    # texture coordinates of the vertices win; the list is named as dropped
    p, _, _ = texcoord_ply("tc_vertex.ply", vertex_uv=True)
    rc, out, err = run("info", p)
    assert rc == 0 and "face property texcoord" in out, out


finish()
