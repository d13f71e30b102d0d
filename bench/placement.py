#!/usr/bin/env python3
"""What vertex placement is worth: one simplifier with input vertices and with moved ones (issue 27).

    python3 bench/placement.py [--epsnet build-release/tools/epsnet] [--scans ../shared/data] [--faces 2M]
                               [--ratios 0.05,0.25]

epsnet keeps input vertices with their bit-identical coordinates (SPEC), where
Open3D's and MeshLab's quadric decimation move every kept vertex to its
quadric's best position. To see what that placement alone is worth, one
simplifier is run both ways at the same face count: meshoptimizer 1.x (npm,
under node: bench/meshopt1x_simplify.mjs) with simplify (input vertices) and
with simplifyWithUpdate (the same simplifier and flags, each kept vertex
moved to its quadric's best position, so that later costs follow it). Beside them,
epsnet (the CLI, at the ratio; the others get its face count) and Open3D
(Debian's python3-open3d under /usr/bin/python3, skipped when missing).

Per mesh and ratio: the mean error relative to the bounding box diagonal
(`epsnet hausdorff`, the larger of the two directions' area-weighted means,
as bench/python_peers.py reports it); then geometric means and each one's
ratio to Open3D's. Quality only: no timings.
"""
import argparse
import math
import pathlib
import re
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCANS = ["armadillo_decim100k.obj.zst", "bun_zipper.ply.zst", "dragon_vrip_res2.ply.zst"]
OPEN3D = ("import sys, open3d as o3d; m = o3d.io.read_triangle_mesh(sys.argv[1]); "
          "o3d.io.write_triangle_mesh(sys.argv[2], m.simplify_quadric_decimation(int(sys.argv[3])))")


def run(args, **kw):
    return subprocess.run([str(a) for a in args], check=True, capture_output=True, text=True, **kw).stdout


def mean_error(epsnet, ref, out):
    text = run([epsnet, "hausdorff", ref, out])
    means = [float(m.group(1)) for m in re.finditer(r"^[ \t]+[AB] -> [AB](?:[ \t]+\S+){4}[ \t]+(\S+)", text, re.M)]
    return max(means[:2])


def size(text):
    units = {"K": 1e3, "M": 1e6}
    return int(float(text[:-1]) * units[text[-1].upper()]) if text[-1].upper() in units else int(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--epsnet", default=str(ROOT / "build-release" / "tools" / "epsnet"))
    ap.add_argument("--scans", default=str(ROOT.parent / "shared" / "data"))
    ap.add_argument("--faces", default="2M", help="gen bumpy's size (0: none)")
    ap.add_argument("--ratios", default="0.05,0.25")
    a = ap.parse_args()
    mjs = ROOT / "bench" / "meshopt1x_simplify.mjs"
    if not (ROOT / "bench" / "node_modules" / "meshoptimizer").is_dir():
        sys.exit("placement: meshoptimizer 1.x is missing (`npm install` in bench/)")
    has_open3d = subprocess.run(["/usr/bin/python3", "-c", "import open3d"], capture_output=True).returncode == 0
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        meshes = []
        for name in SCANS:
            src = pathlib.Path(a.scans) / name
            if src.exists():
                ply = tmp / (name.split(".")[0] + ".ply")
                run([a.epsnet, "convert", src, "-o", ply, "--float32"])  # binary: every peer reads it
                meshes.append((name.split(".")[0], ply))
            else:
                print(f"placement: {src} missing, skipped", file=sys.stderr)
        if size(a.faces):
            ply = tmp / "bumpy.ply"
            run([a.epsnet, "gen", "bumpy", "--faces", size(a.faces), "-o", ply])
            meshes.append((f"gen bumpy {a.faces}", ply))
        for label, ply in meshes:
            for ratio in [float(r) for r in a.ratios.split(",")]:
                row = {"mesh": label, "ratio": ratio}
                out = tmp / "epsnet.ply"
                run([a.epsnet, "simplify", ply, "-o", out, "--ratio", ratio, "-q"])
                faces = int(re.search(r"^triangles:\s+(\d+)", run([a.epsnet, "info", out]), re.M).group(1))
                row["faces"] = faces
                row["epsnet"] = mean_error(a.epsnet, ply, out)
                for peer, extra in (("meshopt", []), ("meshopt moved", ["--update"])):
                    out = tmp / "meshopt.obj"
                    run(["node", mjs, ply, out, faces] + extra)
                    row[peer] = mean_error(a.epsnet, ply, out)
                if has_open3d:
                    out = tmp / "open3d.ply"
                    run(["/usr/bin/python3", "-c", OPEN3D, ply, out, faces])
                    row["open3d"] = mean_error(a.epsnet, ply, out)
                rows.append(row)
                print(f"placement: {label} {ratio}: " + ", ".join(f"{k} {v:.3g}" for k, v in row.items()
                                                                 if isinstance(v, float) and k != "ratio"),
                      file=sys.stderr)
    peers = ["epsnet", "meshopt", "meshopt moved"] + (["open3d"] if has_open3d else [])
    print("| mesh | ratio | faces | " + " | ".join(f"{p} mean error" for p in peers) + " |")
    print("|---|---|---|" + "---|" * len(peers))
    for r in rows:
        print(f"| {r['mesh']} | {r['ratio']} | {r['faces']} | " + " | ".join(f"{r[p]:.3g}" for p in peers) + " |")
    geo = {p: math.exp(sum(math.log(r[p]) for r in rows) / len(rows)) for p in peers}
    print("| geometric mean | | | " + " | ".join(f"{geo[p]:.3g}" for p in peers) + " |")
    if has_open3d:
        print("| against Open3D | | | " + " | ".join(f"{geo[p] / geo['open3d']:.3f}x" for p in peers) + " |")
    print(f"\nplacement alone (meshoptimizer, moved against input vertices): "
          f"{geo['meshopt moved'] / geo['meshopt']:.3f}x the mean error")


if __name__ == "__main__":
    main()
