#!/usr/bin/env python3
"""epsnet against the Python user's simplifiers at equal face counts (issue 27).

    build-venv/bin/python bench/python_peers.py [--faces 2M] [--ratios 0.05,0.25] [--runs 3] [--scans DIR | --no-scans]
                          [--only bun_zipper,armadillo_decim100k,dragon_vrip_res2] [--epsnet build-release/tools/epsnet]

Peers, each skipped with a note when it is not installed (Debian packages):
  open3d   python3-open3d: TriangleMesh.simplify_quadric_decimation
  meshlab  meshlab: meshlabserver with the quadric edge collapse filter (it needs
           an X display for its GL context even without a window: with no
           $DISPLAY the bench starts one Xvfb, package xvfb, for the whole run;
           the server's memory is not counted in MeshLab's peak)
epsnet runs as a user would: epsnet.simplify() on numpy arrays. Each peer
is given the face count epsnet produced.

Every run is a process of its own that reads the mesh, simplifies and
writes a PLY, so "time" is the whole process and "peak" its peak RSS
(medians of --runs runs, peers alternating). Then, with `epsnet hausdorff`
(the CLI) on the input and the last run's output: Hausdorff and mean error
relative to the bounding box diagonal (the mean is the larger of the two
directions' area-weighted means); and topology: non-manifold edges created (edges of more than two
faces, output minus input), boundary edges, and the Euler characteristic.
A geometric mean row per peer closes the table, then the issue's verdicts. Run it on an idle machine;
smoke-test with --faces 20000 --runs 1 --no-scans.
"""
import argparse
import json
import math
import os
import pathlib
import shutil
import statistics
import subprocess
import sys
import tempfile

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]

# Each worker reads src, keeps `target` faces, writes dst, prints nothing.
WORKERS = {
    "epsnet": r"""
import sys, numpy as np, epsnet
src, dst, target = sys.argv[1], sys.argv[2], int(sys.argv[3])
v, f, _ = epsnet.read_mesh(src)
kw = {"ratio": float(sys.argv[4])} if target == 0 else {"face_count": target}
sv, sf = epsnet.simplify(v, f, **kw)
with open(dst, "wb") as out:
    out.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty %s x\nproperty %s y\nproperty %s z\n"
               "element face %d\nproperty list uchar int vertex_indices\nend_header\n"
               % ((len(sv),) + (("float",) * 3 if sv.dtype == np.float32 else ("double",) * 3) + (len(sf),))).encode())
    out.write(sv.astype(sv.dtype.newbyteorder("<")).tobytes())
    rows = np.empty(len(sf), dtype=[("n", "u1"), ("i", "<i4", 3)])
    rows["n"], rows["i"] = 3, sf
    out.write(rows.tobytes())
""",
    "open3d": r"""
import sys, open3d as o3d
src, dst, target = sys.argv[1], sys.argv[2], int(sys.argv[3])
m = o3d.io.read_triangle_mesh(src)
o3d.io.write_triangle_mesh(dst, m.simplify_quadric_decimation(target_number_of_triangles=target))
""",
}

MESHLAB_SCRIPT = """<!DOCTYPE FilterScript>
<FilterScript>
 <filter name="Simplification: Quadric Edge Collapse Decimation">
  <Param type="RichInt" value="{target}" name="TargetFaceNum"/>
  <Param type="RichFloat" value="0" name="TargetPerc"/>
  <Param type="RichFloat" value="0.3" name="QualityThr"/>
  <Param type="RichBool" value="false" name="PreserveBoundary"/>
  <Param type="RichFloat" value="1" name="BoundaryWeight"/>
  <Param type="RichBool" value="true" name="PreserveNormal"/>
  <Param type="RichBool" value="true" name="PreserveTopology"/>
  <Param type="RichBool" value="true" name="OptimalPlacement"/>
  <Param type="RichBool" value="true" name="PlanarQuadric"/>
  <Param type="RichFloat" value="0.001" name="PlanarWeight"/>
  <Param type="RichBool" value="false" name="QualityWeight"/>
  <Param type="RichBool" value="true" name="AutoClean"/>
  <Param type="RichBool" value="false" name="Selected"/>
 </filter>
</FilterScript>
"""


def size(text):
    units = {"K": 1e3, "M": 1e6, "G": 1e9}
    return int(float(text[:-1]) * units[text[-1].upper()]) if text[-1].upper() in units else int(text)


def measured(args, cwd, env=None):
    """(seconds, peak bytes) of one process, through a parent of its own."""
    code = ("import resource, subprocess, sys, time; t = time.perf_counter(); "
            "subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL); "
            "print(time.perf_counter() - t, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024)")
    out = subprocess.run([sys.executable, "-c", code] + args, check=True, capture_output=True, text=True, cwd=cwd,
                         env=env)
    seconds, peak = out.stdout.split()
    return float(seconds), int(peak)


def display():
    """An X display for meshlabserver: $DISPLAY's, else an Xvfb of our own (the Popen, to stop at the end)."""
    if os.environ.get("DISPLAY"):
        return os.environ["DISPLAY"], None
    if not shutil.which("Xvfb"):
        sys.exit("python_peers: meshlabserver needs an X display for its GL context: set DISPLAY or "
                 "apt-get install xvfb")
    r, w = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(w), "-screen", "0", "640x480x24", "-nolisten", "tcp"],
                              pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(w)
    with os.fdopen(r) as f:
        number = f.readline().strip()
    if not number:
        server.kill()
        sys.exit("python_peers: Xvfb did not start")
    return ":" + number, server


def available(python):
    peers = ["epsnet"]
    if subprocess.run([python, "-c", "import open3d"], capture_output=True).returncode == 0:
        peers.append("open3d")
    else:
        print("python_peers: open3d is not installed (apt-get install python3-open3d): skipped", file=sys.stderr)
    if shutil.which("meshlabserver"):
        peers.append("meshlab")
    else:
        print("python_peers: meshlabserver is not installed (apt-get install meshlab): skipped", file=sys.stderr)
    return peers


def command(peer, python, src, dst, target, ratio, tmp):
    if peer == "meshlab":
        script = pathlib.Path(tmp) / f"qec_{target}.mlx"
        script.write_text(MESHLAB_SCRIPT.format(target=target))
        return ["meshlabserver", "-i", str(src), "-o", str(dst), "-s", str(script)]
    return [python, "-c", WORKERS[peer], str(src), str(dst), str(target), str(ratio)]


def edges(f):
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]).astype(np.int64), axis=1)
    _, counts = np.unique(e[:, 0] * (int(f.max()) + 1) + e[:, 1], return_counts=True)  # one key per edge
    return counts


def metro(epsnet_cli, a, b, threads, tmp):
    """(Hausdorff, mean error) relative to a's diagonal, from `epsnet hausdorff A B --json`."""
    out = pathlib.Path(tmp) / "hausdorff.json"
    subprocess.run([epsnet_cli, "hausdorff", str(a), str(b), "--json", str(out), "-q", "-j", str(threads)],
                   check=True, capture_output=True)
    h = json.loads(out.read_text())
    return h["hausdorff_relative"], max(h["a_to_b"]["mean_relative"], h["b_to_a"]["mean_relative"])


def topology(v, f):
    counts = edges(f)
    used = len(np.unique(f))
    return {"nonmanifold": int((counts > 2).sum()), "boundary": int((counts == 1).sum()),
            "euler": used - len(counts) + len(f)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--faces", default="2M")
    ap.add_argument("--ratios", default="0.05,0.25")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--scans", default=str(ROOT.parent / "shared" / "data"))
    ap.add_argument("--no-scans", action="store_true")
    ap.add_argument("--only", default="bun_zipper,armadillo_decim100k,dragon_vrip_res2",
                    help="the scans of --scans to use, by name without extension (empty: all)")
    ap.add_argument("--hausdorff-threads", type=int, default=2)
    ap.add_argument("--epsnet", default=str(ROOT / "build-release" / "tools" / "epsnet"))
    ap.add_argument("--python", default=sys.executable, help="the interpreter with epsnet installed (default: this one)")
    a = ap.parse_args()
    import epsnet

    peers = available(a.python)
    env, server = None, None
    if "meshlab" in peers:
        env = dict(os.environ)
        env["DISPLAY"], server = display()
    only = set(filter(None, a.only.split(",")))
    rows, ratios_by_peer = [], {p: {"hausdorff": [], "mean": []} for p in peers}
    try:
        with tempfile.TemporaryDirectory() as tmp:
            meshes = []
            if not a.no_scans and os.path.isdir(a.scans):
                for name in sorted(os.listdir(a.scans)):
                    if name.endswith((".ply.zst", ".obj.zst")) and (not only or name.split(".")[0] in only):
                        # peers read plain PLY: the scan as the library reads it, written once
                        plain = pathlib.Path(tmp) / (name.split(".")[0] + ".ply")
                        subprocess.run([a.epsnet, "convert", os.path.join(a.scans, name), "-o", str(plain)],
                                       check=True, capture_output=True)
                        meshes.append((name.split(".")[0], plain))
            bumpy = pathlib.Path(tmp) / "bumpy.ply"
            subprocess.run([a.epsnet, "gen", "bumpy", "--faces", str(size(a.faces)), "--seed", "7", "--shuffle", "-o",
                            str(bumpy)], check=True, capture_output=True)
            meshes.append((f"gen bumpy {a.faces}", bumpy))
            for label, src in meshes:
                v, f, _ = epsnet.read_mesh(src)
                before = topology(v, f)
                for ratio in (float(r) for r in a.ratios.split(",")):
                    target = 0
                    results = {}
                    for run in range(a.runs):
                        for peer in peers:  # alternating, so that a slow spell hits every peer alike
                            dst = pathlib.Path(tmp) / f"{peer}.ply"
                            t = target if peer != "epsnet" else 0
                            sec, peak = measured(command(peer, a.python, src, dst, t, ratio, tmp), tmp, env)
                            results.setdefault(peer, []).append((sec, peak))
                            print(f"python_peers: {label} {ratio:g} {peer} run {run + 1}: {sec:.2f} s {peak / 2**20:.0f} MB",
                                  file=sys.stderr, flush=True)
                            if peer == "epsnet" and target == 0:
                                target = len(epsnet.read_mesh(dst)[1])
                    for peer in peers:  # every peer is deterministic: its last timed run's output is the one measured
                        dst = pathlib.Path(tmp) / f"{peer}.ply"
                        sv, sf, _ = epsnet.read_mesh(dst)
                        hd, mean = metro(a.epsnet, src, dst, a.hausdorff_threads, tmp)
                        after = topology(sv, sf)
                        ratios_by_peer[peer]["hausdorff"].append(hd)
                        ratios_by_peer[peer]["mean"].append(mean)
                        sec = statistics.median(r[0] for r in results[peer])
                        peak = statistics.median(r[1] for r in results[peer])
                        rows.append((label, f"{ratio:g}", peer, len(sf), sec, peak / 2**20, hd, mean,
                                     after["nonmanifold"] - before["nonmanifold"], f"{before['boundary']} -> {after['boundary']}",
                                     f"{before['euler']} -> {after['euler']}"))
    finally:
        if server:
            server.terminate()
            server.wait()
    print("| mesh | ratio | peer | faces | whole process | peak | Hausdorff | mean error | non-manifold edges created | boundary edges | Euler |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]:.2f} s | {r[5]:.0f} MB | {r[6]:.3g} | {r[7]:.3g} | {r[8]} | {r[9]} | {r[10]} |")
    for peer, m in ratios_by_peer.items():
        if m["hausdorff"]:
            g = lambda xs: math.exp(sum(math.log(max(x, 1e-300)) for x in xs) / len(xs))
            print(f"| geometric mean | | {peer} | | | | {g(m['hausdorff']):.3g} | {g(m['mean']):.3g} | | | |")
    # the issue's goals: quality at most every peer's (geometric means), no topology change, and
    # whole-process time and peak below every peer's (row by row)
    g = lambda xs: math.exp(sum(math.log(max(x, 1e-300)) for x in xs) / len(xs))
    ours = {(r[0], r[1]): r for r in rows if r[2] == "epsnet"}
    changed = [f"{r[0]} {r[1]}" for r in ours.values() if r[8] > 0 or r[9].split(" -> ")[0] != r[9].split(" -> ")[1]
               or r[10].split(" -> ")[0] != r[10].split(" -> ")[1]]
    print(f"\nepsnet topology change: {'none' if not changed else 'in ' + ', '.join(changed)}")
    for peer in peers:
        if peer == "epsnet" or not ratios_by_peer[peer]["hausdorff"]:
            continue
        theirs = [r for r in rows if r[2] == peer]
        for i, what in ((6, "hausdorff"), (7, "mean")):
            e, o = g(ratios_by_peer["epsnet"][what]), g(ratios_by_peer[peer][what])
            print(f"{what} vs {peer}: epsnet {e:.3g}, {peer} {o:.3g} (geometric means): "
                  f"{'at most' if e <= o else 'OVER'}")
        for i, what in ((4, "time"), (5, "peak")):
            worse = [f"{r[0]} {r[1]}" for r in theirs if ours[(r[0], r[1])][i] >= r[i]]
            print(f"{what} vs {peer}: epsnet below in {len(theirs) - len(worse)} of {len(theirs)} rows"
                  + (f" (not in {', '.join(worse)})" if worse else ""))


if __name__ == "__main__":
    main()
