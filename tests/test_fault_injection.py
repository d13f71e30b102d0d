#!/usr/bin/env python3
"""Allocation failure at every point of real runs (after dav1d's
alloc_fail; issue 8): with EPSNET_FAIL_ALLOC=N the N-th allocation and every
later one fail; EPSNET_FAIL_THREAD does the same to thread creation and
EPSNET_FAIL_WRITE to file writes (ENOSPC: a disk that fills up mid-run). For every N until the run no longer notices, the command
must exit with a clear error (never crash: no signal, no sanitizer report),
leave nothing at the output path and no temporary files beside it. Under the
address sanitizer build this also proves every failure path frees what it
allocated (LeakSanitizer fails the run otherwise)."""
import json
import os
import subprocess
import sys
import tempfile

from meshes import tube_ply

EPSNET = sys.argv[1] if len(sys.argv) > 1 else os.environ["EPSNET_BIN"]
TMP = tempfile.mkdtemp(prefix="epsnet-fault-")
failures = 0


def run(args, fail_at=None, what="EPSNET_FAIL_ALLOC"):
    env = dict(os.environ)
    if fail_at is not None:
        env[what] = str(fail_at)
    return subprocess.run([EPSNET, *args], capture_output=True, text=True, env=env, timeout=120)


def leftovers():
    return [f for f in os.listdir(TMP) if ".epsnet-" in f]


def clear_message(stderr):
    """One error line, last; before it only warnings (what the reading
    dropped is named as it is read, before a later failure)."""
    lines = stderr.strip().splitlines()
    return bool(lines) and lines[-1].startswith("epsnet") and all(l.startswith("warning: ") for l in lines[:-1])


def walk(name, make_args, max_points=400, stride=1, what="EPSNET_FAIL_ALLOC"):
    """Fail allocation (or thread creation) N for N = 1, 1+stride, ... until
    a run succeeds."""
    global failures
    args = make_args(os.path.join(TMP, "out_" + name))
    out = args[args.index("-o") + 1] if "-o" in args else args[args.index("--json") + 1]
    problems = []
    n = 1
    points = 0
    while points < max_points:
        if os.path.exists(out):
            os.remove(out)
        p = run(args, n, what)
        points += 1
        if p.returncode == 0:
            if n == 1:
                problems.append(f"succeeded with {what}=1: injection is not active")
            break
        if p.returncode < 0 or p.returncode not in (2, 3, 4, 6):
            problems.append(f"N={n}: exit {p.returncode}: {p.stderr.strip()[-300:]}")
        elif "AddressSanitizer" in p.stderr or "LeakSanitizer" in p.stderr or "runtime error" in p.stderr:
            problems.append(f"N={n}: sanitizer: {p.stderr.strip()[-300:]}")
        elif not clear_message(p.stderr):
            problems.append(f"N={n}: no clear message: {p.stderr!r}")
        elif os.path.exists(out):
            problems.append(f"N={n}: output left at {out}")
        elif leftovers():
            problems.append(f"N={n}: temporaries left: {leftovers()}")
        n += stride
    else:
        problems.append(f"still failing after {points} points (raise max_points?)")
    if problems:
        failures += 1
        print("FAIL", name, "-", len(problems), "problems; first:", problems[0])
    else:
        print(f"ok   {name} ({points} failure points)")


def hausdorff_without_threads(a, b):
    """hausdorff shares its work among the threads that did start (the
    caller is one of them): same numbers when none can be created."""
    global failures
    ref, got = os.path.join(TMP, "h_ref.json"), os.path.join(TMP, "h_got.json")
    p = run(["hausdorff", a, b, "-j", "3", "-q", "--json", ref])
    q = run(["hausdorff", a, b, "-j", "3", "-q", "--json", got], 1, "EPSNET_FAIL_THREAD")
    if p.returncode or q.returncode or open(ref).read().replace(ref, "") != open(got).read().replace(got, ""):
        failures += 1
        print("FAIL hausdorff_without_threads", p.returncode, q.returncode, q.stderr[-300:])
    else:
        print("ok   hausdorff_without_threads")


def sort_without_threads(src):
    """The sort's workers (in-memory pieces, runs formed on a worker) leave
    the work to the calling thread when they cannot start: same bytes."""
    global failures
    bad = []
    for mem in ("1M", "256M"):
        ref, got = os.path.join(TMP, "t_ref.smz"), os.path.join(TMP, "t_got.smz")
        p = run(["sort", src, "-o", ref, "--mem", mem, "--tmpdir", TMP, "-j", "3", "-q"])
        q = run(["sort", src, "-o", got, "--mem", mem, "--tmpdir", TMP, "-j", "3", "-q"], 1, "EPSNET_FAIL_THREAD")
        if p.returncode or q.returncode or open(ref, "rb").read() != open(got, "rb").read() or leftovers():
            bad.append((mem, p.returncode, q.returncode, q.stderr[-300:]))
    if bad:
        failures += 1
        print("FAIL sort_without_threads", bad[0])
    else:
        print("ok   sort_without_threads")


def main():
    src = os.path.join(TMP, "in.ply")
    p = run(["gen", "bumpy", "--faces", "3000", "--shuffle", "-o", src, "-q"])
    assert p.returncode == 0, p.stderr
    sma = os.path.join(TMP, "in.sma")
    p = run(["gen", "torus", "--faces", "3000", "-o", sma, "-q"])
    assert p.returncode == 0, p.stderr
    walk("convert_ply_to_smb", lambda o: ["convert", src, "-o", o + ".smb", "-q"])
    walk("convert_sma_to_ply_zst", lambda o: ["convert", sma, "-o", o + ".ply.zst", "-q"])
    # (every third point: the walks below cover the same code again, and CI's 15 minutes are shared)
    walk("sample", lambda o: ["sample", src, "-o", o + ".ply", "--level", "2", "-q"], stride=3)
    walk("simplify_two_passes", lambda o: ["simplify", src, "-o", o + ".ply", "--level", "2", "--passes", "2",
                                           "-q"], max_points=600, stride=3)
    # OBJ vt/vn: the reader's corner tables and read-ahead, the writer's weld.
    plain_obj = os.path.join(TMP, "in_plain.obj")
    p = run(["gen", "bumpy", "--faces", "2000", "-o", plain_obj, "-q"])
    assert p.returncode == 0, p.stderr
    tex = os.path.join(TMP, "in_tex.obj")
    with open(plain_obj) as f, open(tex, "w") as g:
        lines = f.read().split("\n")
        nv = sum(1 for x in lines if x.startswith("v "))
        g.write("\n".join(x for x in lines if x.startswith("v ")) + "\n")
        g.write("".join("vt %d 0.5\n" % (i % 7) for i in range(2 * nv)) + "vn 0 0 1\nvn 0 1 0\n")
        for k, x in enumerate(x for x in lines if x.startswith("f ")):
            a, b, c = x.split()[1:]
            # every fifth face gives its first corner a second vt: seams
            g.write("f %s/%d/1 %s/%s/2 %s/%s/1\n" % (a, int(a) + (nv if k % 5 == 0 else 0), b, b, c, c))
    walk("convert_obj_corners", lambda o: ["convert", tex, "-o", o + ".obj", "-q"], max_points=600)
    walk("simplify_obj_corners", lambda o: ["simplify", tex, "-o", o + ".obj", "--level", "1", "-q"],
         max_points=900, stride=5)
    # ... with its texture coordinates weighed, on slabs (the values and
    # the attribute quadrics in each slab and in W: method §9), and its
    # normals not read but recomputed from the output's faces
    walk("simplify_attribute_weights", lambda o: ["simplify", tex, "-o", o + ".obj", "--attribute-weight", "1",
                                                  "--drop-normals", "--slab", "300", "-j", "3", "-q"],
         max_points=900, stride=11)
    # The streaming pipeline with many slabs, seams and worker threads.
    smz = os.path.join(TMP, "in.smz")
    p = run(["gen", "bumpy", "--faces", "6000", "-o", smz, "-q"])
    assert p.returncode == 0, p.stderr
    walk("simplify_pipeline_threads", lambda o: ["simplify", smz, "-o", o + ".smz", "--slab", "200", "-j", "3",
                                                 "--passes", "2", "-q"], max_points=600, stride=7)
    # Threads that cannot start: every one of the 3 x 2 pool threads in turn.
    walk("simplify_thread_creation", lambda o: ["simplify", smz, "-o", o + ".smz", "--slab", "200", "-j", "3",
                                                "--passes", "2", "-q"], what="EPSNET_FAIL_THREAD")
    # Targets: one slab, and streamed (a thinning pass, then one slab) ...
    walk("simplify_target_one_slab", lambda o: ["simplify", smz, "-o", o + ".smz", "--ratio", "0.1", "-q"],
         max_points=600, stride=5)
    walk("simplify_target_streamed", lambda o: ["simplify", smz, "-o", o + ".smz", "--ratio", "0.1", "--slab", "300",
                                                "-j", "3", "-q"], max_points=600, stride=7)
    # ... whose thinned mesh is over --mem's one slab: the target stage's
    # rounds under a global cost ceiling and its last round on slabs, its
    # seams paced to the target (a full disk too: the stage keeps the
    # thinned stream in a temporary file); and an error bound alone on slabs.
    walk("simplify_target_rounds", lambda o: ["simplify", smz, "-o", o + ".smz", "--ratio", "0.1", "--slab",
                                                       "300", "--mem", "600K", "-j", "3", "-q"],
         max_points=600, stride=7)
    walk("full_disk_simplify_target_rounds", lambda o: ["simplify", smz, "-o", o + ".smz", "--ratio", "0.1",
                                                        "--slab", "300", "--mem", "600K", "-j", "3", "-q"],
         what="EPSNET_FAIL_WRITE")
    # ... and a stream long enough for a size's pricing windows: they are
    # read through the block index (.smz), the sort's arrays (a shuffled
    # PLY) or the stretches an external sort kept (the same under --mem),
    # thinned twice over, and the thinning held to the ceiling they price
    # (docs/architecture.md §7). Each is checked to be priced first.
    long_tube = tube_ply(TMP, "long_tube_shuffled.ply", 24, 5000, shuffle=True)
    tube = os.path.join(TMP, "tube.smz")
    p = run(["sort", long_tube, "-o", tube, "-q"])
    assert p.returncode == 0, p.stderr
    priced = ["--ratio", "0.1", "--slab", "256", "--tmpdir", TMP, "-q"]
    for name, src, extra in (("simplify_target_priced", tube, []), ("simplify_target_priced_sorted", long_tube, []),
                             ("simplify_target_priced_sort_spilling", long_tube, ["--mem", "1M"])):
        stats = os.path.join(TMP, "priced.json")
        p = run(["simplify", src, "-o", os.path.join(TMP, "priced.smz"), *priced, *extra, "--stats", stats])
        assert p.returncode == 0, p.stderr
        with open(stats) as f:
            assert json.load(f)["target"]["price_ceiling"] > 0, name
        os.remove(stats)
        os.remove(os.path.join(TMP, "priced.smz"))
        walk(name, lambda o, src=src, extra=extra: ["simplify", src, "-o", o + ".smz", "-j", "3", *priced, *extra],
             max_points=300, stride=331)
    walk("full_disk_simplify_target_priced_sort_spilling",
         lambda o: ["simplify", long_tube, "-o", o + ".smz", *priced, "--mem", "1M"], stride=211,
         what="EPSNET_FAIL_WRITE")
    walk("simplify_error_bound_on_slabs", lambda o: ["simplify", smz, "-o", o + ".smz", "--error", "0.001", "--slab",
                                                     "300", "-j", "3", "-q"], max_points=600, stride=7)
    # A glued double sheet (a fin on edge 0-1 of a tetrahedron), which a
    # target drops first (docs/method.md §13): its search and compaction.
    fin = os.path.join(TMP, "fin.ply")
    with open(fin, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
                "property float z\nelement face 6\nproperty list uchar int vertex_indices\nend_header\n"
                "0 0 0\n1 0 0\n0 1 0\n0 0 1\n0.5 -0.5 0.5\n"
                "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n3 0 1 4\n3 1 0 4\n")
    walk("simplify_target_membrane", lambda o: ["simplify", fin, "-o", o + ".ply", "--faces", "4", "-q"])
    # Vertex attributes through the chain, and a lock by one of them.
    coloured = os.path.join(TMP, "coloured.ply")
    plain = os.path.join(TMP, "plain_ascii.ply")
    p = run(["gen", "bumpy", "--faces", "3000", "--ascii", "-o", plain, "-q"])
    assert p.returncode == 0, p.stderr
    lines = open(plain).read().split("\n")
    end = lines.index("end_header")
    nv = int([l for l in lines if l.startswith("element vertex")][0].split()[2])
    head = [l for l in lines[:end] if not l.startswith("element face") and "vertex_indices" not in l]
    head += ["property uchar red", "property uchar lock", "element face %d" % (len(lines) - end - 2 - nv),
             "property list uchar int vertex_indices", "end_header"]
    body = ["%s %d %d" % (l, i % 256, i % 9 == 0) for i, l in enumerate(lines[end + 1:end + 1 + nv])]
    open(coloured, "w").write("\n".join(head + body + lines[end + 1 + nv:]))
    walk("simplify_attributes_locked", lambda o: ["simplify", coloured, "-o", o + ".ply", "--slab", "200", "-j", "3",
                                                  "--lock", "lock", "-q"], max_points=600, stride=7)
    # A PLY whose faces carry material_index: the vertex block is held and
    # a record pushed per (vertex, material) (src/io/fmt_ply.c); the
    # materials' names in the header's comments, read and written again.
    labelled = os.path.join(TMP, "labelled.ply")
    n = 12
    with open(labelled, "w") as f:
        f.write("ply\nformat ascii 1.0\ncomment epsnet mtllib m.mtl\ncomment epsnet material_index 0 left\n"
                "comment epsnet material_index 1 right side\nelement vertex %d\nproperty float x\n"
                "property float y\nproperty float z\nelement face %d\nproperty ushort material_index\n"
                "property list uchar int vertex_indices\nend_header\n" % ((n + 1) ** 2, 2 * n * n))
        for j in range(n + 1):
            for i in range(n + 1):
                f.write("%r %r %r\n" % (i / n, j / n, 0.02 * ((i * 7 + j * 3) % 5)))
        for j in range(n):
            for i in range(n):
                a = j * (n + 1) + i
                f.write("%d 3 %d %d %d\n%d 3 %d %d %d\n" % (i * 2 // n, a, a + 1, a + n + 2, i * 2 // n, a, a + n + 2,
                                                            a + n + 1))
    walk("simplify_ply_face_labels", lambda o: ["simplify", labelled, "-o", o + ".ply", "--ratio", "0.3", "-q"],
         max_points=300, stride=3)
    # ... and per-corner texture coordinates in a face list (MeshLab's texcoord)
    tc = os.path.join(TMP, "texcoord.ply")
    with open(labelled) as f, open(tc, "w") as g:
        text = f.read()
        g.write(text.replace("property list uchar int vertex_indices\n",
                             "property list uchar int vertex_indices\nproperty list uchar float texcoord\n"))
    with open(tc) as f:
        lines = f.read().split("\n")
    at = lines.index("end_header") + 1 + (n + 1) ** 2
    for k in range(at, at + 2 * n * n):
        w = lines[k].split()
        lines[k] = " ".join(w + ["6"] + ["%d" % (int(c) % 2) for c in w[2:5] for _ in (0, 1)])
    open(tc, "w").write("\n".join(lines))
    walk("simplify_ply_texcoord", lambda o: ["simplify", tc, "-o", o + ".obj", "--ratio", "0.3", "-q"],
         max_points=300, stride=3)
    walk("full_disk_simplify_ply_face_labels", lambda o: ["simplify", labelled, "-o", o + ".ply", "--ratio", "0.3",
                                                          "-q"], what="EPSNET_FAIL_WRITE")
    # The same materials in an OBJ: the reader's mtllib/usemtl/g (a record
    # per (vertex, material), src/io/fmt_obj.c) and the writer's runs of
    # usemtl, a name with a space among them.
    mtl_obj = os.path.join(TMP, "materials.obj")
    p = run(["convert", labelled, "-o", mtl_obj, "-q"])
    assert p.returncode == 0 and "usemtl right side" in open(mtl_obj).read(), p.stderr
    walk("simplify_obj_materials", lambda o: ["simplify", mtl_obj, "-o", o + ".obj", "--ratio", "0.3", "-q"],
         max_points=300, stride=3)
    walk("full_disk_simplify_obj_materials", lambda o: ["simplify", mtl_obj, "-o", o + ".obj", "--ratio", "0.3",
                                                        "-q"], what="EPSNET_FAIL_WRITE")
    hausdorff_without_threads(smz, sma)
    # sort with a budget small enough to spill sorted runs to temporary
    # files (src/sort/extsort.c), then merge them.
    big = os.path.join(TMP, "big.ply")
    p = run(["gen", "bumpy", "--faces", "40000", "--shuffle", "-o", big, "-q"])
    assert p.returncode == 0, p.stderr
    sort_without_threads(big)
    walk("sort_spilling", lambda o: ["sort", big, "-o", o + ".smz", "--mem", "1M", "--tmpdir", TMP, "-q"],
         max_points=900, stride=3)
    # simplify fed straight by that sort (no sorted copy), spilling too.
    walk("simplify_sort_spilling", lambda o: ["simplify", big, "-o", o + ".smz", "--mem", "2M", "--tmpdir", TMP,
                                              "-j", "2", "-q"], max_points=900, stride=13)
    # A full disk at every write: the output of simplify fed by the sort of
    # an unsorted PLY, the runs both sorts spill and the PLY writer's spill.
    walk("full_disk_simplify_unsorted", lambda o: ["simplify", src, "-o", o + ".smz", "-q"],
         what="EPSNET_FAIL_WRITE")
    walk("full_disk_sort_spilling", lambda o: ["sort", big, "-o", o + ".smz", "--mem", "1M", "--tmpdir", TMP,
                                               "-q"], what="EPSNET_FAIL_WRITE")
    walk("full_disk_simplify_sort_spilling", lambda o: ["simplify", big, "-o", o + ".smz", "--mem", "2M",
                                                        "--tmpdir", TMP, "-q"], what="EPSNET_FAIL_WRITE")
    walk("full_disk_convert_to_ply", lambda o: ["convert", sma, "-o", o + ".ply", "-q"],
         what="EPSNET_FAIL_WRITE")
    walk("full_disk_sample_points", lambda o: ["sample", smz, "-o", o + ".ply", "-q"],
         what="EPSNET_FAIL_WRITE")
    # The STL and OFF writers: their position table, the facets or faces
    # they keep in a temporary file, and the header patched at the end.
    # (every third allocation: the four walks share most of their points)
    for ext in ("stl", "off", "off.zst", "stl.zst"):
        walk("convert_to_" + ext, lambda o, ext=ext: ["convert", sma, "-o", o + "." + ext, "-q"], stride=3)
        walk("full_disk_convert_to_" + ext, lambda o, ext=ext: ["convert", sma, "-o", o + "." + ext, "-q"],
             what="EPSNET_FAIL_WRITE")
    subprocess.run(["rm", "-rf", TMP])
    print(f"{failures} failed")
    sys.exit(1 if failures else 0)


main()
