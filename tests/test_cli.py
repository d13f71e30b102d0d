#!/usr/bin/env python3
"""Command-line behaviour that users and scripts rely on (docs/architecture.md §4, §5):
exit codes per failure class, one error line naming file, position and
reason, and nothing left at the -o path (or beside it) after a failure."""
import os
import resource
import signal
import struct
import subprocess
import sys
import tempfile
import time

EPSNET = sys.argv[1] if len(sys.argv) > 1 else os.environ["EPSNET_BIN"]
TMP = tempfile.mkdtemp(prefix="epsnet-cli-")
failures = 0


def run(*args, preexec=None, timeout=120, env=None):
    p = subprocess.run([EPSNET, *args], capture_output=True, text=True,
                       preexec_fn=preexec, timeout=timeout, env={**os.environ, **env} if env else None)
    return p.returncode, p.stdout, p.stderr


def path(name):
    return os.path.join(TMP, name)


def write(name, data):
    p = path(name)
    with open(p, "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())
    return p


def leftovers(folder):
    return [f for f in os.listdir(folder) if ".epsnet-" in f]


def case(fn):
    global failures
    try:
        fn()
        print("ok  ", fn.__name__)
    except AssertionError as e:
        failures += 1
        print("FAIL", fn.__name__, "-", e)
    return fn


def expect_bad_input(name, data, position, code=2, reason=None):
    """convert must fail with one stderr line naming the file and position."""
    src = write(name, data)
    out = path("out_" + name.replace(".", "_") + ".ply")
    rc, _, err = run("convert", src, "-o", out, "-q")
    lines = err.strip().splitlines()
    assert rc == code, f"{name}: exit {rc}, want {code}; stderr={err!r}"
    assert len(lines) == 1, f"{name}: want one error line, got {lines!r}"
    assert src in lines[0], f"{name}: file not named in {lines[0]!r}"
    assert position in lines[0], f"{name}: position {position!r} not in {lines[0]!r}"
    if reason:
        assert reason in lines[0], f"{name}: reason {reason!r} not in {lines[0]!r}"
    assert not os.path.exists(out), f"{name}: output left behind"
    assert not leftovers(TMP), f"{name}: temporaries left: {leftovers(TMP)}"


@case
def version_and_help():
    rc, out, _ = run("--version")
    assert rc == 0 and out.startswith("epsnet "), out
    rc, out, _ = run("--help")
    assert rc == 0 and "convert" in out and "exit status" in out, out
    for cmd in ("convert", "info", "gen"):
        rc, out, _ = run(cmd, "--help")
        assert rc == 0 and out.startswith("usage: epsnet " + cmd), (cmd, out)


@case
def usage_errors_exit_1():
    assert run()[0] == 1
    assert run("frobnicate")[0] == 1
    assert run("convert", "x.ply")[0] == 1          # no -o
    assert run("gen", "sphere", "-o", path("a.ply"), "--faces", "lots")[0] == 1


@case
def missing_input_is_io_error():
    rc, _, err = run("convert", path("nope.ply"), "-o", path("o.ply"))
    assert rc == 3, (rc, err)
    assert "nope.ply" in err and "cannot open" in err, err


@case
def unwritable_output_is_io_error():
    src = write("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    rc, _, err = run("convert", src, "-o", path("no/such/dir/out.ply"))
    assert rc == 3, (rc, err)


@case
def unknown_format_exit_5():
    src = write("mesh.xyz", "hello\n")
    rc, _, err = run("convert", src, "-o", path("o.ply"))
    assert rc == 5, (rc, err)
    src = write("tri2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    rc, _, err = run("convert", src, "-o", path("o.unknownext"))
    assert rc == 5, (rc, err)
    assert not os.path.exists(path("o.unknownext"))


@case
def zst_that_is_not_zstd():
    expect_bad_input("fake.ply.zst", "ply\nformat ascii 1.0\n", "byte 0", reason="not zstd")


@case
def truncated_zstd():
    import shutil
    if not shutil.which("zstd"):
        return
    src = write("t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n" * 2000)
    subprocess.run(["zstd", "-q", "-f", src, "-o", src + ".zst"], check=True)
    data = open(src + ".zst", "rb").read()
    expect_bad_input("trunc.obj.zst", data[: len(data) // 2], "byte", reason="zstd")


@case
def obj_bad_inputs():
    base = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
    expect_bad_input("zero.obj", base + "f 0 1 2\n", ":4:")
    expect_bad_input("range.obj", base + "f 1 2 9\n", ":4:")
    expect_bad_input("nan.obj", base + "v nan 0 0\n", ":4:")
    expect_bad_input("inf.obj", "v 0 inf 0\n" + base, ":1:")
    expect_bad_input("garbage.obj", base + "f 1 2 x3\n", ":4:")


@case
def ply_bad_inputs():
    hdr = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n" \
          "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
    good = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
    expect_bad_input("trunc.ply", hdr + good[:12], ":", reason="")
    expect_bad_input("range.ply", hdr + "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", ":13:")
    huge = hdr.replace("element vertex 3", "element vertex 1099511627776")
    src = write("huge.ply", huge + good)
    rc, _, err = run("convert", src, "-o", path("h.ply"), "-q")
    assert rc == 4, (rc, err)
    bin_hdr = hdr.replace("format ascii", "format binary_little_endian").encode()
    body = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<B3i", 3, 0, 1, 2)
    expect_bad_input("trunc_bin.ply", bin_hdr + body[:-5], "byte")


@case
def sma_finalized_reference():
    expect_bad_input("fin.sma", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 -1\nf 2 4 3\n", ":6:",
                     reason="finalized")


@case
def empty_mesh_is_valid():
    src = write("empty.obj", "# nothing here\n")
    out = path("empty_out.ply")
    rc, _, err = run("convert", src, "-o", out, "-q")
    assert rc == 0, (rc, err)
    rc, out_text, err = run("info", out)
    assert rc == 0 and "vertices:    0" in out_text and "triangles:   0" in out_text, (out_text, err)


@case
def gen_convert_info_roundtrip():
    ply = path("s.ply")
    rc, _, err = run("gen", "sphere", "--faces", "2000", "-o", ply, "-q")
    assert rc == 0, err
    rc, info1, err = run("info", ply)
    assert rc == 0, err
    for ext in ("obj", "sma", "smb", "ply.zst"):
        o = path("s." + ext)
        rc, _, err = run("convert", ply, "-o", o, "-q")
        assert rc == 0, (ext, err)
        rc, info2, err = run("info", o)
        assert rc == 0, (ext, err)
        for key in ("vertices:", "triangles:", "bbox:"):
            l1 = [l for l in info1.splitlines() if l.startswith(key)]
            l2 = [l for l in info2.splitlines() if l.startswith(key)]
            assert l1 == l2, (ext, l1, l2)


@case
def gen_sorted_stream_reports_sorted_and_narrow():
    sma = path("g.sma")
    rc, _, err = run("gen", "sphere", "--faces", "20000", "-o", sma, "-q")
    assert rc == 0, err
    rc, out, err = run("info", sma)
    assert rc == 0, err
    assert "sorted:      " in out and "z" in [l for l in out.splitlines() if l.startswith("sorted:")][0], out
    width = int([l for l in out.splitlines() if l.startswith("width:")][0].split()[1])
    nv = int([l for l in out.splitlines() if l.startswith("vertices:")][0].split()[1])
    assert width < nv // 4, (width, nv)


@case
def file_size_limit_leaves_nothing():
    out = path("big.ply")

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))

    rc, _, err = run("gen", "bumpy", "--faces", "200000", "-o", out, "-q", preexec=limit)
    assert rc == 3, (rc, err)
    assert "big.ply" in err, err
    assert not os.path.exists(out)
    assert not leftovers(TMP), leftovers(TMP)


@case
def sigint_leaves_nothing():
    out = path("interrupted.ply")
    p = subprocess.Popen([EPSNET, "gen", "bumpy", "--faces", "20000000", "-o", out, "-q"],
                         stderr=subprocess.PIPE)
    time.sleep(0.5)
    p.send_signal(signal.SIGINT)
    p.wait(timeout=60)
    assert p.returncode == 130, p.returncode
    assert not os.path.exists(out)
    assert not leftovers(TMP), leftovers(TMP)


@case
def file_size_limit_in_every_writing_command():
    """`ulimit -f` hit by the output (also of simplify fed by the sort of an
    unsorted mesh) and by the sort's spilled runs (of sort and of simplify):
    exit 3 naming the output, nothing left beside it."""
    src = path("fsz.ply")
    assert run("gen", "bumpy", "--faces", "100000", "--shuffle", "-o", src, "-q")[0] == 0
    smz = path("fsz.smz")
    assert run("sort", src, "-o", smz, "-q")[0] == 0

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (30_000, 30_000))

    for cmd, inp, out, extra in (("simplify", src, "fsz_a.smz", []),     # the output, fed by the sort
                                 ("simplify", src, "fsz_f.smz", ["--mem", "2M", "--tmpdir", TMP]),  # its runs
                                 ("simplify", smz, "fsz_b.ply", []),     # the output
                                 ("sample", smz, "fsz_c.ply", []),
                                 ("sort", src, "fsz_d.smz", ["--mem", "1M", "--tmpdir", TMP]),  # spilled runs
                                 ("convert", smz, "fsz_e.obj", [])):
        rc, _, err = run(cmd, inp, "-o", path(out), "-q", *extra, preexec=limit)
        lines = err.strip().splitlines()
        assert rc == 3 and len(lines) == 1 and path(out) in lines[0], (cmd, out, rc, err)
        assert "too large" in lines[0], lines[0]
        assert not os.path.exists(path(out)), out
        assert not leftovers(TMP), (cmd, leftovers(TMP))


@case
def sigterm_during_sorting_leaves_nothing():
    """SIGTERM while simplify sorts an unsorted mesh on its way into the
    pipeline, and while sort spills runs into --tmpdir: exit 130, no output,
    no temporary file in either folder."""
    src = path("term.ply")
    assert run("gen", "bumpy", "--faces", "2000000", "--shuffle", "-o", src, "-q")[0] == 0
    spill = path("term_spill")
    os.mkdir(spill)
    for args, out in ((["simplify", src, "--mem", "8M", "--tmpdir", spill], "term_s.smz"),
                      (["sort", src, "--mem", "4M", "--tmpdir", spill], "term_sorted.smz")):
        p = subprocess.Popen([EPSNET, *args, "-o", path(out), "-q"], stderr=subprocess.PIPE)
        deadline = time.time() + 60

        # the runs are anonymous files: wait until the process has some open
        # in spill, so that the signal lands while there is something to clean up
        def spilled():
            try:
                return any(os.readlink(f"/proc/{p.pid}/fd/{fd}").startswith(spill)
                           for fd in os.listdir(f"/proc/{p.pid}/fd"))
            except OSError:
                return False
        while not spilled() and p.poll() is None and time.time() < deadline:
            time.sleep(0.01)
        assert p.poll() is None, (args, "finished before the signal")
        p.send_signal(signal.SIGTERM)
        p.wait(timeout=60)
        assert p.returncode == 130, (args, p.returncode, p.stderr.read())
        assert not os.path.exists(path(out)), out
        assert not leftovers(TMP) and not os.listdir(spill), (leftovers(TMP), os.listdir(spill))
    os.remove(src)


@case
def a_stream_that_never_finalizes_hits_the_budget_in_every_command():
    """docs/architecture.md §12: a streaming input whose active set outgrows --mem (it never
    finalizes, or piles faces on vertices it never finalizes) is a clear
    budget error in sample and simplify too, not unbounded memory."""
    lines = ["v %d %d 0" % (i % 700, i // 700) for i in range(150000)]
    lines += ["f %d %d %d" % (i, i + 1, i + 2) for i in range(1, 149998, 3)]
    nofin = write("nofin2.sma", "\n".join(lines) + "\n")
    # Three live vertices and one face repeated forever: the reader's live
    # set stays tiny, the faces waiting on those vertices do not.
    dup = write("dupfaces.sma", "v 0 0 0\nv 1 0 0\nv 0 1 0\n" + "f 1 2 3\n" * 300000)
    for src, mem, what in ((nofin, "1M", "finalize"), (dup, "2M", "3 vertices and")):
        for cmd in ("simplify", "sample"):
            out = path(os.path.basename(src) + "_" + cmd + ".ply")
            rc, _, err = run(cmd, src, "-o", out, "--mem", mem, "-q")
            lines_ = err.strip().splitlines()
            assert rc == 4 and len(lines_) == 1, (cmd, src, rc, err)
            assert src in lines_[0] and "memory budget" in lines_[0] and what in lines_[0], lines_[0]
            assert not os.path.exists(out) and not leftovers(TMP), (out, leftovers(TMP))


@case
def one_vertex_used_again_at_the_end_hits_the_budget():
    """A narrow, finalized strip whose first vertex is used again by the very
    last triangle: output leaves in id order, so everything waits for it.
    Over --mem that is a clear budget error, not unbounded memory; within
    the budget the output is a valid stream."""
    W, rows = 10, 10000
    out = ["v 0 0 -1"]
    for r in range(rows):
        for c in range(W):
            out.append(f"v {c} {r} 0")
            if r > 0 and c > 0:
                a = 1 + (r - 1) * W + c
                out += [f"f {a} {a + 1} {a + W + 1}", f"f {a} {a + W + 1} {a + W}"]
        if r > 0:
            out += [f"x {1 + (r - 1) * W + c + 1}" for c in range(W)]
    last = 1 + (rows - 1) * W
    out.append(f"f 1 {last + 1} {last + 2}")
    out += [f"x {last + c + 1}" for c in range(W)] + ["x 1"]
    src = write("longlived.sma", "\n".join(out) + "\n")
    dst = path("longlived_s.smz")
    rc, _, err = run("simplify", src, "-o", dst, "--mem", "2M", "-q")
    lines = err.strip().splitlines()
    assert rc == 4 and len(lines) == 1, (rc, err)
    assert src in lines[0] and "waits for vertex 0" in lines[0] and "memory budget" in lines[0], lines[0]
    assert not os.path.exists(dst) and not leftovers(TMP), leftovers(TMP)
    rc, _, err = run("simplify", src, "-o", dst, "--mem", "64M", "-q")
    assert rc == 0, err
    rc, text, err = run("check", dst)
    assert rc == 0 and "valid:       yes" in text, (text, err)


@case
def mem_is_one_total_split_once_among_the_parts():
    """--mem is a total (docs/architecture.md §12): a stream gives a quarter
    to the reader and the rest to the passes, an input sorted first half to
    the sort and half to the passes, 2/5 is a target's one slab; --stats
    reports the split, and the parts add up to no more than the total."""
    import json
    ply = path("split_in.ply")
    smz = path("split_in.smz")
    assert run("gen", "bumpy", "--faces", "4000", "--shuffle", "-o", ply, "-q")[0] == 0
    assert run("sort", ply, "-o", smz, "-q")[0] == 0
    mem = 24 << 20
    for src, reader, sort in ((smz, mem // 4, 0), (ply, 0, mem // 2)):
        stats = path("split.json")
        rc, _, err = run("simplify", src, "-o", path("split_out.smz"), "--mem", "24M", "--stats", stats, "-q")
        assert rc == 0, err
        b = json.load(open(stats))["budget"]
        assert b["total"] == mem and b["reader"] == reader and b["sort"] == sort, (src, b)
        assert b["chain"] == mem - reader - sort and b["one_slab"] == mem // 5 * 2, (src, b)
    # without --mem the total is half the memory, and the sort keeps its 512M
    rc, _, err = run("simplify", ply, "-o", path("split_out.smz"), "--stats", stats, "-q")
    b = json.load(open(stats))["budget"]
    phys = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") // 2
    assert rc == 0 and b["total"] == phys and b["sort"] == min(phys // 2, 512 << 20), (b, err)
    assert b["reader"] + b["sort"] + b["chain"] <= b["total"], b


def obj_faces(p):
    """Triangles of an OBJ file as coordinate triples (rounded: a float32
    stream prints 1.1 as 1.10000002)."""
    vs, fs = [], []
    with open(p) as f:
        for line in f:
            t = line.split()
            if t and t[0] == "v":
                vs.append(tuple(round(float(x), 5) for x in t[1:4]))
            elif t and t[0] == "f":
                fs.append([int(x.split("/")[0]) for x in t[1:]])
    return vs, [tuple(vs[i - 1] for i in f) for f in fs]


def edges_with_three_or_more_faces(vs, faces):
    count = {}
    for f in faces:
        for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0])):
            e = (min(a, b), max(a, b))
            count[e] = count.get(e, 0) + 1
    return sorted(e for e, n in count.items() if n >= 3)


@case
def cad_assembly_with_thousands_of_nonmanifold_edges():
    """A motorBike-like part: a wavy sheet with fins standing on thousands of
    its edges (three faces on each, four where two fins share one), run through
    the slab pipeline with seams across the fins. Every non-manifold edge and
    every fin must come out untouched, the output must be a valid sorted
    stream, and the bytes must not depend on the thread count."""
    import math
    W, H = 120, 60
    lines = [f"v {i} {j} {0.3 * math.sin(i * 0.4) * math.cos(j * 0.3):.6f}" for j in range(H) for i in range(W)]
    faces, nv = [], W * H
    for j in range(H - 1):
        for i in range(W - 1):
            a = j * W + i + 1
            faces += [(a, a + 1, a + W + 1), (a, a + W + 1, a + W)]
    fins = 0
    for j in range(1, H - 1, 3):
        for i in range(W - 1):
            a = j * W + i + 1
            for k in range(2 if i % 5 == 0 else 1):   # two fins: an edge with four faces
                lines.append(f"v {i + 0.5} {j + 0.1 + 0.2 * k} {1.5 + k}")
                nv += 1
                faces.append((a, a + 1, nv))
                fins += 1
    lines += [f"f {a} {b} {c}" for a, b, c in faces]
    src = write("cad.obj", "\n".join(lines) + "\n")
    vs_in, tri_in = obj_faces(src)
    nm_in = edges_with_three_or_more_faces(vs_in, tri_in)
    assert len(nm_in) > 1500, len(nm_in)
    outs = []
    for j in ("1", "2"):
        out = path(f"cad_j{j}.smz")
        rc, _, err = run("simplify", src, "-o", out, "--slab", "300", "-j", j, "--passes", "2", "-q")
        assert rc == 0, err
        outs.append(open(out, "rb").read())
    assert outs[0] == outs[1], "output depends on the thread count"
    rc, out_text, err = run("check", path("cad_j2.smz"), "--strict")
    assert rc == 0, (out_text, err)
    assert run("convert", path("cad_j2.smz"), "-o", path("cad_out.obj"), "-q")[0] == 0
    vs_out, tri_out = obj_faces(path("cad_out.obj"))
    assert len(tri_out) < len(tri_in), (len(tri_out), len(tri_in))
    assert edges_with_three_or_more_faces(vs_out, tri_out) == nm_in, "non-manifold edges changed"
    fin_in = {tuple(sorted(t)) for t in tri_in[len(tri_in) - fins:]}
    fin_out = {tuple(sorted(t)) for t in tri_out}
    assert fin_in <= fin_out, f"{len(fin_in - fin_out)} fins lost"


@case
def sample_writes_one_point_per_sample_and_stats():
    src = path("smp.ply")
    rc, _, err = run("gen", "sphere", "--faces", "20000", "-o", src, "-q")
    assert rc == 0, err
    out, stats = path("smp_out.ply"), path("smp.json")
    rc, _, err = run("sample", src, "-o", out, "--level", "2", "--stats", stats, "-q")
    assert rc == 0, err
    import json
    st = json.load(open(stats))
    assert st["gaussian_vertices"] == 66 and st["samples"] == 66, st
    head = open(out, "rb").read(400).decode("latin1")
    assert "element vertex 66\n" in head and "property int gvertex" in head, head
    rc, _, err = run("sample", src, "-o", path("smp_mesh.ply"), "--mesh", "--level", "2", "-q")
    assert rc == 0, err
    head = open(path("smp_mesh.ply"), "rb").read(400).decode("latin1")
    assert "property uchar sample" in head and "element face" in head, head


@case
def sample_and_simplify_reject_bad_options():
    src = write("t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    for args in (["--level", "15"], ["--frequency", "0"], ["--rotation", "1,2"], ["--seed", "1", "--rotation",
                 "identity"], ["--threads", "x"]):
        rc, _, err = run("sample", src, "-o", path("x.ply"), *args)
        assert rc == 1, (args, rc, err)
    for args in (["--passes", "0"], ["--max-normal-dev", "0"], ["--max-normal-dev", "200"]):
        rc, _, err = run("simplify", src, "-o", path("x.ply"), *args)
        assert rc == 1, (args, rc, err)
    assert not os.path.exists(path("x.ply"))


@case
def simplify_keeps_samples_and_reports():
    src = path("simp_in.ply")
    rc, _, err = run("gen", "torus", "--faces", "20000", "-o", src, "-q")
    assert rc == 0, err
    out, stats = path("simp_out.obj"), path("simp.json")
    rc, _, err = run("simplify", src, "-o", out, "--level", "2", "--stats", stats)
    assert rc == 0, err
    assert "epsnet simplify:" in err and "non-samples left" in err, err
    import json
    st = json.load(open(stats))
    assert st["output_vertices"] == st["samples"] + st["remaining_nonsamples"], st
    assert st["output_faces"] < st["faces"], st
    rc, info, err = run("info", out)
    assert rc == 0, err
    assert f"vertices:    {st['output_vertices']}" in info, info


@case
def example_stream_matches_simplify():
    """tests/example_stream.c (the push/pull API) writes the same bytes as
    `epsnet simplify` with the same slab size, threads and passes."""
    example = os.environ.get("EPSNET_EXAMPLE_STREAM")
    assert example and os.path.exists(example), example
    src = path("ex_in.smz")
    rc, _, err = run("gen", "bumpy", "--faces", "40000", "-o", src, "-q")
    assert rc == 0, err
    for slab, threads, passes in (("300", "2", "1"), ("5000", "1", "2")):
        mine, ref = path("ex_mine.smz"), path("ex_ref.smz")
        p = subprocess.run([example, src, mine, slab, threads, passes], capture_output=True, text=True, timeout=120)
        assert p.returncode == 0 and "slabs" in p.stdout, (p.returncode, p.stderr)
        rc, _, err = run("simplify", src, "-o", ref, "--slab", slab, "-j", threads, "--passes", passes, "-q")
        assert rc == 0, err
        assert open(mine, "rb").read() == open(ref, "rb").read(), (slab, threads, passes)


@case
def simplify_bad_input_leaves_nothing():
    expect_bad_input("bad_simp.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n", ":3:")
    src = path("bad_simp.obj")
    out = path("bad_simp_out.ply")
    rc, _, err = run("simplify", src, "-o", out)
    assert rc == 2 and ":3:" in err and not os.path.exists(out), (rc, err)


@case
def sort_then_check_strict():
    src = path("sort_in.ply")
    rc, _, err = run("gen", "bumpy", "--faces", "30000", "--shuffle", "-o", src, "-q")
    assert rc == 0, err
    out = path("sorted.smz")
    rc, _, err = run("sort", src, "-o", out, "--mem", "1M")
    assert rc == 0, err
    assert "epsnet sort:" in err and "runs" in err, err
    rc, text, err = run("check", out, "--strict")
    assert rc == 0, (rc, err)
    assert "valid:       yes" in text and "checksums:   every block verified" in text, text
    rc, text2, err = run("check", out, "--strict", "--axis", "x")
    sorted_line = [l for l in text.splitlines() if l.startswith("sorted:")][0]
    assert (rc == 0) == ("x" in sorted_line.split("(")[0]), (rc, sorted_line, err)
    rc, _, err = run("check", src)
    assert rc == 2 and "no finalization" in err and src in err, (rc, err)
    assert len(err.strip().splitlines()) == 1, err
    assert not leftovers(TMP), leftovers(TMP)


@case
def check_names_the_corrupt_block_and_offset():
    src = path("ck_in.ply")
    rc, _, err = run("gen", "sphere", "--faces", "20000", "-o", src, "-q")
    assert rc == 0, err
    good = path("ck.smz")
    rc, _, err = run("sort", src, "-o", good, "-q")
    assert rc == 0, err
    data = bytearray(open(good, "rb").read())
    assert data[108:112] == b"SMZB", data[108:112]    # after the header and the attribute table
    data[108 + 40 + 20] ^= 0x40          # inside block 0's payload
    bad = write("ck_bad.smz", bytes(data))
    rc, _, err = run("check", bad)
    lines = err.strip().splitlines()
    assert rc == 2 and len(lines) == 1, (rc, err)
    assert bad in lines[0] and "byte 108" in lines[0] and "block 0 is corrupt" in lines[0], lines[0]


@case
def sort_usage_and_io_errors():
    src = write("sort_tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert run("sort", src, "-o", path("a.smz"), "--axis", "w")[0] == 1
    assert run("sort", src)[0] == 1
    assert run("sort", src, "-o", path("a.smz"), "--mem", "lots")[0] == 1
    rc, _, err = run("sort", path("missing.ply"), "-o", path("a.smz"))
    assert rc == 3 and "missing.ply" in err, (rc, err)
    rc, _, err = run("sort", src, "-o", path("one.smz"), "-q")
    assert rc == 0 and err == "", (rc, err)
    rc, text, err = run("check", path("one.smz"), "--strict")
    assert rc == 0 and "vertices:    3" in text, (rc, text, err)


@case
def sort_of_a_never_finalizing_stream_hits_the_budget():
    lines = ["v %d %d 0" % (i % 700, i // 700) for i in range(150000)]
    lines += ["f %d %d %d" % (i, i + 1, i + 2) for i in range(1, 149998, 3)]
    src = write("nofin.sma", "\n".join(lines) + "\n")
    out = path("nofin.smz")
    rc, _, err = run("sort", src, "-o", out, "--mem", "1M", "-q")
    assert rc == 4, (rc, err)
    assert "memory budget" in err and src in err, err
    assert len(err.strip().splitlines()) == 1, err
    assert not os.path.exists(out)
    assert not leftovers(TMP), leftovers(TMP)


@case
def render_writes_a_png_and_leaves_nothing_on_failure():
    src = path("render_sphere.ply")
    assert run("gen", "sphere", "--faces", "2000", "-o", src, "-q")[0] == 0
    out = path("render.png")
    rc, _, err = run("render", src, "-o", out, "--size", "96x64", "--view", "10,-20", "--wire", "-q")
    assert rc == 0 and err == "", (rc, err)
    with open(out, "rb") as f:
        data = f.read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", data[:8]
    assert data[12:16] == b"IHDR", data[12:16]
    assert struct.unpack(">II", data[16:24]) == (96, 64), data[16:24]
    assert data[24:26] == bytes([8, 2]), data[24:26]          # 8-bit RGB
    rc, _, err = run("render", src, "-o", path("render2.png"), "--size", "96x64", "--view", "10,-20",
                     "--wire", "-q")
    with open(path("render2.png"), "rb") as f:
        assert f.read() == data, "same command, different bytes"
    for bad in (["--size", "0x10"], ["--size", "64"], ["--view", "0,91"], ["--view", "x"]):
        rc, _, err = run("render", src, "-o", path("never.png"), *bad)
        assert rc == 1 and len(err.strip().splitlines()) == 1, (bad, rc, err)
    broken = write("render_bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    rc, _, err = run("render", broken, "-o", path("never.png"), "--samples")
    lines = err.strip().splitlines()
    assert rc == 2 and len(lines) == 1 and broken in lines[0] and ":4:" in lines[0], (rc, err)
    rc, _, err = run("render", path("render_missing.ply"), "-o", path("never.png"))
    assert rc == 3, (rc, err)
    assert not os.path.exists(path("never.png")), "output left behind"
    assert not leftovers(TMP), leftovers(TMP)

@case
def deeply_nonmanifold_and_huge_fans_are_handled():
    """A 3000-page 'book' (one edge shared by 3000 faces, like a CAD assembly)
    and a 10000-face fan: handled, locked as docs/method.md §6 says, no hang."""
    import math
    lines = ["v 0 0 0", "v 0 0 1"]
    n = 3000
    lines += [f"v {math.cos(2 * math.pi * i / n)} {math.sin(2 * math.pi * i / n)} 0.5" for i in range(n)]
    lines += [f"f 1 2 {i + 3}" for i in range(n)]
    book = write("book.obj", "\n".join(lines) + "\n")
    import json
    rc, _, err = run("simplify", book, "-o", path("book_s.ply"), "--stats", path("book.json"), "-q")
    assert rc == 0, err
    st = json.load(open(path("book.json")))
    assert st["nonmanifold_vertices"] == 2 and st["locked"] == n + 2, st
    assert st["output_faces"] == n, st
    m = 10000
    lines = ["v 0 0 0.1"] + [f"v {math.cos(2 * math.pi * i / m)} {math.sin(2 * math.pi * i / m)} 0" for i in range(m)]
    lines += [f"f 1 {i + 2} {(i + 1) % m + 2}" for i in range(m)]
    fan = write("fan.obj", "\n".join(lines) + "\n")
    rc, _, err = run("simplify", fan, "-o", path("fan_s.ply"), "--stats", path("fan.json"), "-q")
    assert rc == 0, err
    st = json.load(open(path("fan.json")))
    assert st["boundary_vertices"] == m and st["collapses"] == 1 and st["output_faces"] == m - 2, st


@case
def off_and_stl_extras_are_named():
    """OFF colours, normals, texture values and face colours, and STL facet
    attribute bytes are not carried: one warning line names them."""
    off = write("extras.off", "COFF\n4 2 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n"
                              "1 1 1 9 9 9 255\n3 0 1 2\n3 1 3 2 200 0 0\n")
    rc, _, err = run("convert", off, "-o", path("extras_off.ply"))
    assert rc == 0, err
    assert err.splitlines() == [f"warning: {off}: dropped: vertex values past x y z (colour, normal, texture) (4), "
                                "face colour (1)"], err
    plain = write("plain.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    rc, _, err = run("convert", plain, "-o", path("plain_off.ply"))
    assert rc == 0 and err == "", err
    facet = struct.pack("<12fH", 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0x7c00)
    stl = write("coloured.stl", b"\0" * 80 + struct.pack("<I", 2) + facet + facet[:-2] + b"\0\0")
    rc, _, err = run("convert", stl, "-o", path("coloured_stl.ply"))
    assert rc == 0, err
    assert err.splitlines() == [f"warning: {stl}: dropped: facet attribute (colour) bytes (1)"], err


@case
def what_an_input_holds_beyond_the_mesh_is_named_in_one_warning_line():
    """docs/architecture.md §5: every element, property or statement the output does not carry
    is named in one warning line per run, and counted in the stats."""
    import json
    ply = write("extras.ply",
                "ply\nformat ascii 1.0\nelement camera 1\nproperty float view_px\n"
                "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                "property float confidence\nproperty short intensity\n"
                "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                "0.5\n0 0 0 1 7\n1 0 0 1 7\n0 1 0 1 7\n1 1 1 1 7\n3 0 1 2\n3 1 3 2\n")
    # vertex attributes travel where the output holds them (PLY, .smz), simplify included
    camera = f"warning: {ply}: dropped: element camera (1)"
    for cmd, extra, want in (("simplify", ["--stats", path("extras.json")], camera), ("sort", [], camera),
                             ("convert", [], camera)):
        out = path(f"extras_{cmd}.ply" if cmd != "sort" else "extras_sort.smz")
        rc, _, err = run(cmd, ply, "-o", out, "-q", *extra)
        assert rc == 0, (cmd, err)
        assert err.splitlines() == [want], (cmd, err)
    st = json.load(open(path("extras.json")))
    assert st["dropped"] == 1 and st["faces"] == 2, st
    rc, text, err = run("info", ply)
    assert rc == 0 and "not read:    element camera (1)\n" in text, text
    assert "attributes:  float confidence, short intensity (6 bytes per vertex)" in text, text
    # an output that cannot hold them says so in the same one line
    for fmt in ("smb", "sma"):
        rc, _, err = run("convert", ply, "-o", path(f"extras_c.{fmt}"))
        assert rc == 0, err
        assert err.splitlines() == [camera + ", vertex property confidence, vertex property intensity "
                                    f"({path(f'extras_c.{fmt}')} cannot hold them)"], (fmt, err)
    obj = write("extras.obj", "mtllib m.mtl\ng a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n"
                              "usemtl red\nf 1/1 2/1 3/1\ng b\n")
    rc, _, err = run("simplify", obj, "-o", path("extras_obj.ply"), "-q", "--stats", path("extras_obj.json"))
    assert rc == 0, err
    # the faces name the vt: it is carried (texture_u, texture_v), through simplify too, and so
    # are each face's material and group (material_index, group_index), whose names a PLY holds
    # in its header's comments
    assert err == "", err
    with open(path("extras_obj.ply"), "rb") as f:
        head = f.read().split(b"end_header")[0].decode()
    assert ("comment epsnet mtllib m.mtl\ncomment epsnet material_index 0 red\n"
            "comment epsnet group_index 0 a\n") in head, head
    # a format without a place for the names says so
    rc, _, err = run("convert", obj, "-o", path("extras_obj.smz"))
    assert rc == 0, err
    assert err.splitlines() == [f"warning: {obj}: dropped: material names (usemtl, mtllib), group names (g) "
                                f"({path('extras_obj.smz')} cannot hold them)"], err
    # a mesh that carries nothing more says nothing
    plain = write("plain.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    rc, _, err = run("simplify", plain, "-o", path("plain_s.ply"), "-q", "--stats", path("plain.json"))
    assert rc == 0 and err == "", err
    assert json.load(open(path("plain.json")))["dropped"] == 0


@case
def simplify_of_vertices_without_faces_warns_that_the_output_is_empty():
    src = write("points.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                              "property float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n")
    out = path("points_s.ply")
    rc, _, err = run("simplify", src, "-o", out, "-q")
    assert rc == 0, err
    assert err.splitlines() == [f"warning: {src}: 3 vertices but no faces: nothing to simplify, "
                                "the output is empty"], err
    rc, text, _ = run("info", out)
    assert "vertices:    0" in text and "triangles:   0" in text, text
    # a stream is not sorted first: the same word
    sma = write("points.sma", "v 0 0 0\nv 1 0 0\n")
    rc, _, err = run("simplify", sma, "-o", path("points_sma.ply"), "-q")
    assert rc == 0 and err.splitlines() == [f"warning: {sma}: 2 vertices but no faces: nothing to simplify, "
                                            "the output is empty"], err
    # an empty file is valid and empty: nothing to warn about
    empty = write("nothing.obj", "# empty\n")
    rc, _, err = run("simplify", empty, "-o", path("nothing_s.ply"), "-q")
    assert rc == 0 and err == "", err


@case
def tristrips_simplify_like_their_triangle_list():
    """A PLY whose faces are `tristrips` (here pairs of triangles sharing an
    edge, as strips of four, and single triangles; -1 between strips) gives
    the same output as its twin with `element face` listing the strips'
    triangles: (a b c) and, odd, (c b d) for the strip a b c d."""
    ply = path("strip_src.ply")
    assert run("gen", "sphere", "--faces", "2000", "-o", ply, "-q")[0] == 0
    asc = path("strip_src_ascii.ply")
    assert run("convert", ply, "-o", asc, "--ascii", "-q")[0] == 0
    lines = open(asc).read().splitlines()
    end = lines.index("end_header")
    nv = int(next(l for l in lines if l.startswith("element vertex")).split()[2])
    verts = lines[end + 1:end + 1 + nv]
    faces = [list(map(int, l.split()[1:])) for l in lines[end + 1 + nv:] if l.strip()]
    strips, tris = [], []
    i = 0
    while i < len(faces):
        a, b, c = faces[i]
        if i + 1 < len(faces):
            nxt = faces[i + 1]
            # the next face shares edge (c, b) as (b', a') with a new corner d:
            # the strip a b c d gives (a b c), then (c b d) for odd i
            for r in range(3):
                x, y, z = nxt[r:] + nxt[:r]
                if (x, y) == (c, b):
                    strips += [a, b, c, z, -1]
                    tris += [(a, b, c), (c, b, z)]
                    i += 2
                    break
            else:
                strips += [a, b, c, -1]
                tris.append((a, b, c))
                i += 1
        else:
            strips += [a, b, c, -1]
            tris.append((a, b, c))
            i += 1
    header = ["ply", "format ascii 1.0", f"element vertex {nv}", "property float x", "property float y",
              "property float z", "element tristrips 1", "property list int int vertex_indices", "end_header"]
    src = write("strips.ply", "\n".join(header + verts + [" ".join(map(str, [len(strips)] + strips))]) + "\n")
    header[6:8] = [f"element face {len(tris)}", "property list uchar int vertex_indices"]
    twin = write("strips_twin.ply", "\n".join(header + verts + [f"3 {a} {b} {c}" for a, b, c in tris]) + "\n")
    rc, text, err = run("info", src)
    assert rc == 0 and f"triangles:   {len(faces)}" in text, (text, err)
    a, b = path("strips_s.ply"), path("faces_s.ply")
    rc, _, err = run("simplify", src, "-o", a, "-q")
    assert rc == 0 and err == "", err
    rc, _, err = run("simplify", twin, "-o", b, "-q")
    assert rc == 0 and err == "", err
    assert open(a, "rb").read() == open(b, "rb").read(), "strips and faces simplify differently"
    assert strips.count(-1) < len(faces), "no strip of two triangles: the test tests nothing"


# ---- per-vertex attributes (issue 16): bit for bit through every format that holds them ----

PLY_TYPES = {"char": "b", "uchar": "B", "short": "h", "ushort": "H", "int": "i", "uint": "I",
             "float": "f", "double": "d"}


def read_ply(p):
    """(property names and types, vertex records as byte strings of the whole record in a canonical
    little-endian layout, faces) of a PLY, ascii or binary little-endian, scalar vertex properties."""
    data = open(p, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    lines = data[:end].decode().splitlines()
    fmt = lines[1].split()[1]
    props, elems, cur = [], [], None
    for ln in lines:
        t = ln.split()
        if t[0] == "element":
            elems.append((t[1], int(t[2])))
            cur = t[1]
        elif t[0] == "property" and cur == "vertex":
            props.append((t[2], t[1]))
    nv = dict(elems)["vertex"]
    nf = dict(elems).get("face", 0)
    rec = "<" + "".join(PLY_TYPES[ty] for _, ty in props)
    verts, faces = [], []
    if fmt == "ascii":
        toks = data[end:].decode().split("\n")
        for i in range(nv):
            vals = toks[i].split()
            conv = [float(v) if PLY_TYPES[ty] in "fd" else int(v) for v, (_, ty) in zip(vals, props)]
            verts.append(struct.pack(rec, *conv))
        for i in range(nf):
            faces.append(tuple(int(v) for v in toks[nv + i].split()[1:]))
    else:
        assert fmt == "binary_little_endian", fmt
        size = struct.calcsize(rec)
        at = end
        for i in range(nv):
            verts.append(data[at:at + size])
            at += size
        for i in range(nf):
            n = data[at]
            faces.append(struct.unpack_from(f"<{n}i", data, at + 1))
            at += 1 + 4 * n
    return props, verts, faces


def attributed_ply(name, faces=3000, shuffle=True):
    """A generated bumpy PLY with one attribute of every type, values made to test every bit."""
    base = path(name + ".base.ply")
    args = ["gen", "bumpy", "--faces", str(faces), "--seed", "3", "-o", base, "-q"]
    rc, _, err = run(*(args + ["--shuffle"] if shuffle else args))
    assert rc == 0, err
    _, verts, faces_ = read_ply(base)
    extra = [("red", "uchar"), ("green", "uchar"), ("blue", "uchar"), ("nx", "float"), ("ny", "float"),
             ("nz", "float"), ("s", "float"), ("t", "float"), ("confidence", "double"), ("label", "short"),
             ("flags", "ushort"), ("id", "int"), ("stamp", "uint"), ("tilt", "char")]
    head = ["ply", "format binary_little_endian 1.0", f"element vertex {len(verts)}", "property float x",
            "property float y", "property float z"]
    head += [f"property {ty} {n}" for n, ty in extra]
    head += [f"element face {len(faces_)}", "property list uchar int vertex_indices", "end_header"]
    body = bytearray()
    for i, v in enumerate(verts):
        body += v
        body += struct.pack("<3B", i % 256, (7 * i) % 256, 255 - i % 256)
        body += struct.pack("<5f", i * 1e-3, -0.5, 1 / (i + 1), 0.1 * i, float("-0.0") if i % 2 else 3.5)
        body += struct.pack("<dhHiIb", i * 1.0000000001e-7, -i % 30000, 65535 - i % 65536, -i * 999, i * 77777,
                            -(i % 128))
    for f in faces_:
        body += struct.pack("<B3i", 3, *f)
    return write(name, ("\n".join(head) + "\n").encode() + bytes(body))


@case
def attributes_round_trip_bit_for_bit():
    src = attributed_ply("attr.ply", faces=20000)
    props, verts, faces = read_ply(src)
    want = sorted(verts)
    # convert: binary -> ascii -> binary and through .smz, the same records
    a, b, z, zb = path("attr_a.ply"), path("attr_b.ply"), path("attr.smz"), path("attr_z.ply")
    for args in (("convert", src, "-o", a, "--ascii"), ("convert", a, "-o", b), ("convert", src, "-o", z),
                 ("convert", z, "-o", zb)):
        rc, _, err = run(*args, "-q")
        assert rc == 0 and err == "", (args, err)
    for p in (a, b, zb):
        got = read_ply(p)
        assert got[0] == props and got[1] == verts and got[2] == faces, p
    assert open(b, "rb").read() == open(zb, "rb").read()
    # sort, in memory and through the external passes: every vertex keeps its own attributes,
    # and both give the same bytes; .smz then PLY gives them again
    s1, s2, s3, s3p = path("attr_s1.ply"), path("attr_s2.ply"), path("attr_s3.smz"), path("attr_s3.ply")
    s4 = path("attr_s4.ply")
    # 1M: runs with ranks in memory; 100K: the fully external join (src/sort/sort.h)
    for args in (("sort", src, "-o", s1), ("sort", src, "-o", s2, "--mem", "1M"), ("sort", src, "-o", s3),
                 ("convert", s3, "-o", s3p), ("sort", src, "-o", s4, "--mem", "100K", "-j", "1")):
        rc, _, err = run(*args, "-q")
        assert rc == 0 and err == "", (args, err)
    got = read_ply(s1)
    assert got[0] == props and sorted(got[1]) == want, "sort changed some vertex's attributes"
    assert open(s1, "rb").read() == open(s2, "rb").read(), "external sort differs from the in-memory one"
    assert open(s1, "rb").read() == open(s4, "rb").read(), "external join differs from the in-memory sort"
    assert open(s1, "rb").read() == open(s3p, "rb").read(), "sort through .smz differs"
    rc, text, _ = run("info", s3)
    assert rc == 0 and "uchar red, uchar green" in text and "(44 bytes per vertex)" in text, text
    # simplify carries them (tests/test_simplify_attrs.py checks the values); into SMB,
    # which holds none, it names every one of them in its one warning line
    rc, _, err = run("simplify", src, "-o", path("attr_simp.ply"), "-q")
    assert rc == 0 and err == "", err
    rc, _, err = run("simplify", src, "-o", path("attr_simp.smb"), "-q")
    assert rc == 0, err
    names = ", ".join(f"vertex property {n}" for n, _ in props[3:])
    assert err.splitlines() == [f"warning: {src}: dropped: {names}"], err


@case
def spilled_faces_keep_their_bytes_past_two_to_the_32_vertices():
    # the sort's temporary faces are 3 x 4 bytes while every vertex id fits in 32 bits and 3 x 8
    # after (src/sort/sort.c: put_faces); EPSNET_FAIL_SORT_WIDE=N takes the N-th spilled face and
    # those after it as past 2^32 vertices: both layouts and the switch between them, in the
    # external passes with ranks in memory (1M) and in the fully external join (100K)
    src = attributed_ply("wide.ply", faces=3000)
    ref = path("wide_ref.ply")
    assert run("sort", src, "-o", ref, "-q")[0] == 0
    want = open(ref, "rb").read()
    for mem in ("1M", "100K"):
        for at in ("1", "1500", "2999"):
            out = path(f"wide_{mem}_{at}.ply")
            rc, _, err = run("sort", src, "-o", out, "--mem", mem, "-q", env={"EPSNET_FAIL_SORT_WIDE": at})
            assert rc == 0 and err == "", (mem, at, err)
            assert open(out, "rb").read() == want, f"--mem {mem}, wide from face {at}: other bytes"


@case
def bad_attribute_tables_are_errors_not_crashes():
    src = attributed_ply("attr_bad.ply", faces=200)
    z = path("attr_bad.smz")
    rc, _, err = run("convert", src, "-o", z, "-q")
    assert rc == 0, err
    data = bytearray(open(z, "rb").read())
    assert data[8] == 2, "a stream with attributes is .smz version 2"
    body = struct.unpack_from("<I", data, 96)[0]
    for at, val in ((96, 0xff), (96 + 3, 0x7f), (100, 33), (104, 0), (104, 9), (105, 0), (105, 200),
                    (106, ord(" ")), (96 + 4 + body, 0)):
        bad = bytearray(data)
        bad[at] = val if bad[at] != val else (val + 1) % 256
        p = write("attr_bad_%d.smz" % at, bytes(bad))
        rc, _, err = run("convert", p, "-o", path("attr_bad_out.ply"), "-q")
        assert rc == 2 and p in err and len(err.splitlines()) == 1, (at, rc, err)
    # a PLY vertex property list is still dropped and named; a property twice is an error
    expect_bad_input("attr_twice.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                     "property float y\nproperty float z\nproperty uchar red\nproperty uchar red\n"
                     "end_header\n0 0 0 1 2\n", ":8:")
    expect_bad_input("attr_value.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                     "property float y\nproperty float z\nproperty uchar red\nend_header\n0 0 0 256\n", ":9:")


@case
def obj_colours_round_trip_through_ply_sort_and_smz():
    verts = ["v 0 0 0 1 0 0.5", "v 1 0 0 0.1 0.2 0.3", "v 0 1 0 0.33333334 0.001 0", "v 0 0 1 1 1 1",
             "v 1 1 1 0.7 0.25 1e-08"]
    faces = ["f 1 3 2", "f 1 2 4", "f 1 4 3", "f 2 3 4", "f 2 5 3"]
    src = write("col.obj", "\n".join(verts + faces) + "\n")
    a, b = path("col_a.ply"), path("col_b.obj")
    for args in (("convert", src, "-o", a), ("convert", a, "-o", b)):
        rc, _, err = run(*args, "-q")
        assert rc == 0 and err == "", (args, err)
    assert open(b).read() == open(src).read(), open(b).read()
    props, _, _ = read_ply(a)
    assert props[3:] == [("red", "float"), ("green", "float"), ("blue", "float")], props
    z, zo = path("col_s.smz"), path("col_s.obj")
    for args in (("sort", src, "-o", z), ("convert", z, "-o", zo)):
        rc, _, err = run(*args, "-q")
        assert rc == 0 and err == "", (args, err)
    got = [ln for ln in open(zo).read().splitlines() if ln.startswith("v ")]
    assert sorted(got) == sorted(verts[:2] + ["v 0 1 0 0.33333334 0.001 0"] + verts[3:4] +
                                 ["v 1 1 1 0.7 0.25 1e-08"]), got
    # OBJ holds only float colours: integer colours are named as dropped, in the same line
    ply = write("col_u8.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
                "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1 2 3\n"
                "1 0 0 4 5 6\n0 1 0 7 8 9\n3 0 1 2\n")
    o = path("col_u8.obj")
    rc, _, err = run("convert", ply, "-o", o, "-q")
    assert rc == 0 and err.splitlines() == [
        f"warning: {ply}: dropped: vertex property red, vertex property green, vertex property blue "
        f"({o} cannot hold them)"], err
    # a vertex without colours in a coloured OBJ gets zeros and is counted
    mixed = write("col_mixed.obj", "v 0 0 0 1 1 1\nv 1 0 0\nv 0 1 0 0.5 0.5 0.5\nf 1 2 3\n")
    rc, _, err = run("convert", mixed, "-o", path("col_mixed.ply"), "-q")
    assert rc == 0 and err.splitlines() == [f"warning: {mixed}: dropped: vertex without colour (1)"], err


@case
def obj_vt_and_vn_of_one_per_position_round_trip():
    """OBJ vt/vn when each position has exactly one: carried as texture_u, texture_v, nx, ny, nz
    through PLY, sort and .smz, and written back as vt/vn with f v/vt/vn; a seam splits its
    position (tests/test_obj_corners.py has the rest)."""
    text = ("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 1 1\n"
            "vt 0 0\nvt 1 0\nvt 0 1\nvt 0.5 0.5\nvt 0.25 0.75\n"
            "vn 0 0 1\nvn 1 0 0\nvn 0 1 0\nvn 0.57735026 0.57735026 0.57735026\nvn 0 -1 0\n"
            "f 1/1/1 3/3/3 2/2/2\nf 1/1/1 2/2/2 4/4/4\nf -5/-5/-5 -2/-2/-2 -3/-3/-3\nf 2/2/2 3/3/3 4/4/4\n"
            "f 2/2/2 5/5/5 3/3/3\n")
    src = write("uv.obj", text)
    rc, info, err = run("info", src)
    assert rc == 0 and "attributes:  float texture_u, float texture_v, float nx, float ny, float nz" in info, info
    assert "not read" not in info, info
    a, b = path("uv_a.ply"), path("uv_b.obj")
    for args in (("convert", src, "-o", a), ("convert", a, "-o", b)):
        rc, _, err = run(*args, "-q")
        assert rc == 0 and err == "", (args, err)
    out = open(b).read()
    vs = [ln for ln in out.splitlines() if ln[:2] in ("v ", "vt", "vn")]
    assert vs[:3] == ["v 0 0 0", "vt 0 0", "vn 0 0 1"] and len(vs) == 15, out
    # records come in the order the faces first name them: 1 3 2 4 5
    assert "f 1/1/1 2/2/2 3/3/3" in out, out
    z, zo = path("uv.smz"), path("uv_z.obj")
    for args in (("sort", src, "-o", z), ("convert", z, "-o", zo)):
        rc, _, err = run(*args, "-q")
        assert rc == 0 and err == "", (args, err)
    # every vertex keeps its own vt and vn through the sort: (v, vt, vn) triples are the same
    def triples(t):
        ls = [ln for ln in t.splitlines() if ln[:2] in ("v ", "vt", "vn")]
        return sorted(tuple(ls[i:i + 3]) for i in range(0, len(ls), 3))
    assert triples(open(zo).read()) == triples(out), open(zo).read()
    # an OBJ has no counts: the in-memory sort starts, outgrows a small budget and moves what it
    # holds (attributes included) to the spills; the bytes are those of the roomy run
    base = path("uv_big.ply")
    rc, _, err = run("gen", "bumpy", "--faces", "20000", "--seed", "5", "--shuffle", "-o", base, "-q")
    assert rc == 0, err
    _, verts, faces = read_ply(base)
    lines = []
    for i, v in enumerate(verts):
        x, y, zz = struct.unpack("<3f", v)
        lines.append(f"v {x!r} {y!r} {zz!r} {i % 7 / 7!r} 0.5 {1 - i % 3 / 3!r}")
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    big = write("uv_big.obj", "\n".join(lines) + "\n")
    s1, s2 = path("uv_big1.ply"), path("uv_big2.ply")
    for args in (("sort", big, "-o", s1), ("sort", big, "-o", s2, "--mem", "1M")):
        rc, _, err = run(*args, "-q")
        assert rc == 0 and err == "", (args, err)
    assert open(s1, "rb").read() == open(s2, "rb").read(), "a sort that spills mid-read differs"
    assert read_ply(s1)[0][3:] == [("red", "float"), ("green", "float"), ("blue", "float")]
    # a position with two different vt is a seam: it becomes one vertex per vt
    seam = write("uv_seam.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\nvt 0.5 0.5\n"
                 "f 1/1 3/3 2/2\nf 1/4 2/2 4/4\n")
    rc, _, err = run("convert", seam, "-o", path("uv_seam.ply"), "-q")
    assert rc == 0 and err == "", err
    assert len(read_ply(path("uv_seam.ply"))[1]) == 5
    # a vt index out of range is an error naming the file and line; a corner without vt gets zeros
    odd = write("uv_odd.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 1 1\nf 1/9 2/1 3\n")
    rc, _, err = run("convert", odd, "-o", path("uv_odd.ply"), "-q")
    assert rc == 2 and f"{odd}:5:" in err and "vt index 9" in err, err
    odd = write("uv_odd2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 1 1\nf 1/1 2/1 3\n")
    rc, _, err = run("convert", odd, "-o", path("uv_odd2.ply"), "-q")
    assert rc == 0 and err.splitlines() == [f"warning: {odd}: dropped: face corner without vt (1)"], err



@case
def threads_follow_the_processors_this_process_may_use():
    """The default -j is the processors of the process's CPU affinity (taskset,
    a container, Slurm, mpirun's binding), not all the machine's; more
    threads than those asked for explicitly get one warning line; the bytes
    never change."""
    one = {min(os.sched_getaffinity(0))}
    pin = lambda: os.sched_setaffinity(0, one)
    src = path("aff.ply")
    rc, _, err = run("gen", "bumpy", "--faces", "20000", "-o", src, "-q")
    assert rc == 0, err
    rc, _, err = run("simplify", src, "-o", path("aff1.ply"), "-j", "1", "-q")
    assert rc == 0 and err == "", err
    rc, _, err = run("simplify", src, "-o", path("aff_default.ply"), "-q", preexec=pin)
    assert rc == 0 and err == "", f"the default -j on one processor warned: {err!r}"
    rc, _, err = run("simplify", src, "-o", path("aff3.ply"), "-j", "3", "-q", preexec=pin)
    lines = err.splitlines()
    assert rc == 0 and len(lines) == 1, (rc, err)
    assert lines[0].startswith("warning: -j 3 starts 3 worker threads, but this process may run on 1 processor "
                               "only"), lines[0]
    want = open(path("aff1.ply"), "rb").read()
    for name in ("aff_default.ply", "aff3.ply"):
        assert open(path(name), "rb").read() == want, f"{name} differs from -j 1"


subprocess.run(["rm", "-rf", TMP])
print(f"{failures} failed")
sys.exit(1 if failures else 0)
