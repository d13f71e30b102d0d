#!/usr/bin/env python3
"""Simplifying across UV seams (issue 25): a textured mesh at the same face
count as the same mesh without UVs, and as meshoptimizer 1.x's
simplifyWithAttributes.

The textured meshes are `epsnet gen` shapes with the generator's own atlas
(--gen-atlas: `gen --charts`, square charts of the shape's grid whose UVs
follow the surface), and the shared scans and `epsnet gen` shapes (--gen),
given a UV atlas here:
faces are put in charts by the cell of a C x C x C grid over the bounding box
their centroid falls in (connected pieces of surface, as an atlas's charts
are), and each chart is projected on the xy plane into its own tile of the
texture. So every chart boundary is a UV seam (two vertex records per
position), and where three or more charts meet the position has as many
records (a cut's end, which stays).

For every mesh, grid size and ratio R, at round(R * faces):
  plain        epsnet simplify --ratio R of the mesh without UVs
  uv           epsnet simplify --ratio R of the textured OBJ
  uv slab      the same, forced through --slab 4096 (seams between slabs),
               compared with the plain mesh through the same slabs
  meshopt w    node bench/meshopt1x_attributes.mjs, UV weight w (1 and 0.01)
  meshopt plain  node bench/meshopt1x_simplify.mjs of the mesh without UVs:
               with the meshopt w rows, what the seams cost meshoptimizer
Each output is measured against the mesh without UVs (`epsnet hausdorff`):
Hausdorff and mean distance relative to the diagonal. A Hausdorff distance is
one point's, and at 5% of a 35K-vertex scan which vertices the skeleton holds
moves it by up to 1.6x (bench/RESULTS.md, session 24): --seeds N repeats
the epsnet rows (plain and uv, one slab and --slab 4096) under N more
orientations of the Gaussian sphere (--seed 1..N) and prints, per case, the
uv/plain Hausdorff ratio under each and their median. The uv rows also check
that every output corner (position, vt, as float32) is an input corner, and
that no face has corners of two charts (a seam smeared).

  python3 bench/seams.py [--epsnet BIN] [--data DIR] [--gen bumpy:200K] [--cells 4,8]
                         [--gen-atlas bumpy:200K:1000] [--ratios 0.05,0.25] [--out DIR] [--seeds N]

Python 3 standard library, node with bench/node_modules (npm install in
bench/). See bench/README.md.
"""
import argparse
import json
import math
import os
import shutil
import statistics
import struct
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
SCANS = (("bunny", "bun_zipper.ply.zst"), ("armadillo", "armadillo_decim100k.obj.zst"),
         ("dragon", "dragon_vrip_res2.ply.zst"))


def sh(*args):
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode:
        raise SystemExit("failed: %s\n%s" % (" ".join(args), r.stderr))
    return r.stdout


def read_obj(path):
    v, vt, faces = [], [], []
    with open(path) as f:
        for line in f:
            w = line.split()
            if not w:
                continue
            if w[0] == "v":
                v.append(tuple(float(x) for x in w[1:4]))
            elif w[0] == "vt":
                vt.append((float(w[1]), float(w[2])))
            elif w[0] == "f":
                corners = [c.split("/") for c in w[1:]]
                pos = [int(c[0]) - 1 for c in corners]
                tex = [int(c[1]) - 1 if len(c) > 1 and c[1] else -1 for c in corners]
                for i in range(1, len(pos) - 1):
                    faces.append(((pos[0], pos[i], pos[i + 1]), (tex[0], tex[i], tex[i + 1])))
    return v, vt, faces


def fchart_of(src, cells):
    """Each face's chart: the grid cell its centroid is in, numbered in
    order of first use."""
    v, _, faces = read_obj(src)
    lo = [min(p[i] for p in v) for i in range(3)]
    ext = max(max(p[i] for p in v) - lo[i] for i in range(3))
    chart_of, fchart = {}, []
    for pos, _ in faces:
        c = tuple(min(cells - 1, int((sum(v[k][i] for k in pos) / 3 - lo[i]) / ext * cells)) for i in range(3))
        fchart.append(chart_of.setdefault(c, len(chart_of)))
    return fchart


def atlas(src, dst, cells):
    """src (OBJ without vt) with a UV atlas of grid-cell charts into dst;
    returns (charts, tiles per row)."""
    v, _, faces = read_obj(src)
    lo = [min(p[i] for p in v) for i in range(3)]
    ext = max(max(p[i] for p in v) - lo[i] for i in range(3))
    fchart = fchart_of(src, cells)
    ncol = math.ceil(math.sqrt(max(fchart) + 1))
    vt_of, vts = {}, []
    with open(dst, "w") as out:
        for p in v:
            out.write("v %r %r %r\n" % p)
        lines = []
        for (pos, _), c in zip(faces, fchart):
            ids = []
            for k in pos:
                if (k, c) not in vt_of:
                    vt_of[(k, c)] = len(vts) + 1
                    u = ((v[k][0] - lo[0]) / ext + c % ncol) / ncol
                    w = ((v[k][1] - lo[1]) / ext + c // ncol) / ncol
                    vts.append("vt %.9g %.9g\n" % (u, w))
                ids.append("%d/%d" % (k + 1, vt_of[(k, c)]))
            lines.append("f %s\n" % " ".join(ids))
        out.write("".join(vts))
        out.write("".join(lines))
    return max(fchart) + 1, ncol


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def corners_of(path):
    """Every corner's (position, vt) in float32 values, and each face's."""
    v, vt, faces = read_obj(path)
    v = [tuple(f32(x) for x in p) for p in v]
    vt = [tuple(f32(x) for x in t) for t in vt]
    tris = [[(v[p], vt[t]) for p, t in zip(pos, tex)] for pos, tex in faces]
    return {c for t in tris for c in t}, tris


def charts_by_edges(path):
    """Each corner's chart in a textured OBJ: faces joined across every edge
    whose two ends have the same vt on both faces."""
    _, tris = corners_of(path)
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
    chart = {}
    for i, t in enumerate(tris):
        for c in t:
            chart[c] = find(i)
    return len({find(i) for i in range(len(tris))}), chart


def measure(epsnet, ref, out):
    j = os.path.join(os.path.dirname(out), "h.json")
    sh(epsnet, "hausdorff", ref, out, "--json", j)
    with open(j) as f:
        d = json.load(f)
    mean = (d["a_to_b"]["mean_relative"] + d["b_to_a"]["mean_relative"]) / 2
    return d["b"]["faces"], d["hausdorff_relative"], mean


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--epsnet", default=os.path.join(REPO, "build-release", "tools", "epsnet"))
    ap.add_argument("--data", default=os.path.join(REPO, "..", "shared", "data"))
    ap.add_argument("--cells", default="4,8")
    ap.add_argument("--ratios", default="0.05,0.25")
    ap.add_argument("--gen", default="bumpy:200K", help="generated meshes, SHAPE:FACES,... ('' for none)")
    ap.add_argument("--gen-atlas", default="", help="generated meshes with gen --charts, SHAPE:FACES:CHARTS,...")
    ap.add_argument("--scans", default="1", help="0: leave out the shared scans")
    ap.add_argument("--out", default=None)
    ap.add_argument("--seeds", type=int, default=0, help="N more sphere orientations for the epsnet rows")
    a = ap.parse_args()
    tmp = a.out or tempfile.mkdtemp(prefix="epsnet_seams_")
    os.makedirs(tmp, exist_ok=True)
    node = os.path.join(HERE, "meshopt1x_attributes.mjs")
    have_peer = shutil.which("node") and os.path.isdir(os.path.join(HERE, "node_modules", "meshoptimizer"))
    if not have_peer:
        print("no meshoptimizer rows: node or bench/node_modules/meshoptimizer is missing (npm install in bench/)",
              file=sys.stderr)
    rows, ratios = [], [float(x) for x in a.ratios.split(",")]
    rotations = []  # (mesh, charts, ratio, slab, [uv/plain Hausdorff under each orientation])
    print("| mesh | charts | ratio | target | tool | faces | Hausdorff | mean | vs plain (H, mean) |")
    print("|---|---|---|---|---|---|---|---|---|")
    meshes = [(name, os.path.join(a.data, file)) for name, file in SCANS] if a.scans != "0" else []
    own_atlas = {}
    for spec in filter(None, a.gen_atlas.split(",")):
        shape, faces, charts = spec.split(":")
        name = "%s %s atlas" % (shape, faces)
        src = os.path.join(tmp, "%s_%s_plain.ply" % (shape, faces))
        uv = os.path.join(tmp, "%s_%s_k%s.obj" % (shape, faces, charts))
        sh(a.epsnet, "gen", shape, "--faces", faces, "-o", src, "-q")
        sh(a.epsnet, "gen", shape, "--faces", faces, "--charts", charts, "-o", uv, "-q")
        own_atlas[name] = uv
        meshes.append((name, src))
    for spec in filter(None, a.gen.split(",")):
        shape, faces = spec.split(":")
        src = os.path.join(tmp, "%s_%s.ply" % (shape, faces))
        sh(a.epsnet, "gen", shape, "--faces", faces, "-o", src, "-q")
        meshes.append(("%s %s" % (shape, faces), src))
    for name, src in meshes:
        if not os.path.exists(src):
            print("skip %s: %s is missing" % (name, src), file=sys.stderr)
            continue
        plain = os.path.join(tmp, name.replace(" ", "_") + ".obj")
        sh(a.epsnet, "convert", src, "-o", plain, "-q", "--float32")
        nfaces = len(read_obj(plain)[2])
        atlases = []
        if name in own_atlas:
            charts, chart = charts_by_edges(own_atlas[name])
            atlases.append((own_atlas[name], charts, chart))
        for cells in (int(c) for c in a.cells.split(",") if name not in own_atlas):
            uv = os.path.join(tmp, "%s_c%d.obj" % (name.replace(" ", "_"), cells))
            charts, _ = atlas(plain, uv, cells)
            # each input corner's chart: the faces it is on are all in one
            # (a position in two charts has a record, and a vt, for each)
            _, tris = corners_of(uv)
            chart = {}
            for t, c in zip(tris, fchart_of(plain, cells)):
                for corner in t:
                    chart[corner] = c
            atlases.append((uv, charts, chart))
        out = os.path.join(tmp, "out.obj")
        for r in ratios:
            goal = round(r * nfaces)
            sh(a.epsnet, "simplify", plain, "-o", out, "--ratio", str(r), "-q")
            base = measure(a.epsnet, plain, out)
            print("| %s | 0 | %g | %d | plain | %d | %.4g | %.4g | |" % ((name, r, goal) + base), flush=True)
            rows.append(dict(mesh=name, charts=0, ratio=r, target=goal, tool="plain", faces=base[0],
                             hausdorff=base[1], mean=base[2], note=""))
            sh(a.epsnet, "simplify", plain, "-o", out, "--ratio", str(r), "-q", "--slab", "4096")
            base_slab = measure(a.epsnet, plain, out)
            print("| %s | 0 | %g | %d | plain slab 4096 | %d | %.4g | %.4g | |" % ((name, r, goal) + base_slab),
                  flush=True)
            rows.append(dict(mesh=name, charts=0, ratio=r, target=goal, tool="plain slab 4096", faces=base_slab[0],
                             hausdorff=base_slab[1], mean=base_slab[2], note=""))
            if have_peer:
                sh("node", os.path.join(HERE, "meshopt1x_simplify.mjs"), plain, out, str(goal))
                faces, h, mean = measure(a.epsnet, plain, out)
                print("| %s | 0 | %g | %d | meshopt plain | %d | %.4g | %.4g | |" % (name, r, goal, faces, h, mean),
                      flush=True)
                rows.append(dict(mesh=name, charts=0, ratio=r, target=goal, tool="meshopt plain", faces=faces,
                                 hausdorff=h, mean=mean, note=""))
            for slab in (["--slab", "4096"], []) if a.seeds else ():
                def hausdorff_of(src, seed):
                    sh(a.epsnet, "simplify", src, "-o", out, "--ratio", str(r), "-q", *slab,
                       *(["--seed", str(seed)] if seed else []))
                    return measure(a.epsnet, plain, out)[1]
                plains = [hausdorff_of(plain, seed) for seed in range(a.seeds + 1)]
                for uv, charts, _ in atlases:
                    ratios_by_seed = [hausdorff_of(uv, seed) / plains[seed] for seed in range(a.seeds + 1)]
                    rotations.append((name, charts, r, "--slab 4096" if slab else "one slab", ratios_by_seed))
            for uv, charts, chart in atlases:
                for tool, cmd in (("uv", [a.epsnet, "simplify", uv, "-o", out, "--ratio", str(r), "-q"]),
                                  ("uv slab 4096", [a.epsnet, "simplify", uv, "-o", out, "--ratio", str(r), "-q",
                                                    "--slab", "4096"]),
                                  ("meshopt w=1", ["node", node, uv, out, str(goal), "1"]),
                                  ("meshopt w=0.01", ["node", node, uv, out, str(goal), "0.01"])):
                    if tool.startswith("meshopt") and not have_peer:
                        continue
                    sh(*cmd)
                    faces, h, mean = measure(a.epsnet, plain, out)
                    note = ""
                    if tool.startswith("uv"):
                        got, tris = corners_of(out)
                        foreign = sum(1 for c in got if c not in chart)
                        smeared = sum(1 for t in tris if len({chart.get(c) for c in t}) > 1)
                        note = "" if not (foreign or smeared) else " (%d foreign corners, %d smeared faces)" % (
                            foreign, smeared)
                    b = base_slab if "slab" in tool else base
                    print("| %s | %d | %g | %d | %s | %d | %.4g | %.4g | %.3f, %.3f%s |" % (
                        name, charts, r, goal, tool, faces, h, mean, h / b[1], mean / b[2], note), flush=True)
                    rows.append(dict(mesh=name, charts=charts, ratio=r, target=goal, tool=tool, faces=faces,
                                     hausdorff=h, mean=mean, note=note))
    with open(os.path.join(tmp, "seams.json"), "w") as f:
        json.dump(rows, f, indent=1)
    # the ratios: the textured run against the plain one and against
    # meshoptimizer's best weight, geometric means
    def gm(xs):
        return math.exp(sum(math.log(x) for x in xs) / len(xs)) if xs else float("nan")
    for tool in ("uv", "uv slab 4096"):
        vs_plain_h, vs_mo_h, vs_mo_mean, worst = [], [], [], 1.0
        for row in rows:
            if row["tool"] != tool:
                continue
            key = (row["mesh"], row["charts"], row["ratio"])
            ptool = "plain slab 4096" if "slab" in tool else "plain"
            plain = [x for x in rows if (x["mesh"], x["ratio"], x["tool"]) == (row["mesh"], row["ratio"], ptool)][0]
            mo = [x for x in rows if (x["mesh"], x["charts"], x["ratio"]) == key and x["tool"].startswith("meshopt")]
            best_h = min((x["hausdorff"] for x in mo), default=float("nan"))
            best_mean = min((x["mean"] for x in mo), default=float("nan"))
            vs_plain_h.append(row["hausdorff"] / plain["hausdorff"])
            worst = max(worst, row["hausdorff"] / plain["hausdorff"])
            vs_mo_h.append(row["hausdorff"] / best_h)
            vs_mo_mean.append(row["mean"] / best_mean)
        print("%s: Hausdorff vs the mesh without UVs %.3f (geometric mean, worst %.3f); vs meshoptimizer's "
              "better weight: Hausdorff %.3f, mean %.3f" % (tool, gm(vs_plain_h), worst, gm(vs_mo_h), gm(vs_mo_mean)))
    # what the seams cost meshoptimizer: its better weight against its own run without UVs
    seam_price = []
    for row in rows:
        if row["tool"] != "meshopt plain":
            continue
        for charts in sorted({x["charts"] for x in rows if x["mesh"] == row["mesh"] and x["charts"]}):
            mo = [x["hausdorff"] for x in rows if (x["mesh"], x["charts"], x["ratio"]) == (row["mesh"], charts, row["ratio"])
                  and x["tool"].startswith("meshopt w")]
            if mo:
                seam_price.append("%s %d charts %g: %.3f" % (row["mesh"], charts, row["ratio"], min(mo) / row["hausdorff"]))
    if seam_price:
        print("meshoptimizer's own uv/plain Hausdorff (better weight): " + "; ".join(seam_price))
    if rotations:
        print("\n| mesh | charts | ratio | slabs | uv/plain Hausdorff: default orientation, --seed 1..%d | median |"
              % a.seeds)
        print("|---|---|---|---|---|---|")
        for name, charts, r, slabs, xs in rotations:
            print("| %s | %d | %g | %s | %s | %.3f |" % (name, charts, r, slabs, ", ".join("%.3f" % x for x in xs),
                                                          statistics.median(xs)))
        print()
        for slabs in ("one slab", "--slab 4096"):
            meds = [statistics.median(xs) for _, _, _, sl, xs in rotations if sl == slabs]
            print("%s: median over orientations, geometric mean %.3f, worst %.3f, cases above 1.2: %d of %d"
                  % (slabs, gm(meds), max(meds), sum(m > 1.2 for m in meds), len(meds)))


if __name__ == "__main__":
    main()
