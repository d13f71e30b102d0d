#!/usr/bin/env python3
"""Attribute weights against the texture slide: how far the texture moves on
the surface when a textured mesh is simplified with `--attribute-weight
uv=W`, and what that costs in geometric error, against meshoptimizer 1.x's
simplifyWithAttributes at the same face count.

bench/seams.py's atlas cannot measure this: each chart there is projected
on the xy plane, so the UV is an affine function of position inside a chart,
the UV interpolated inside any output triangle is exactly the UV of its
position, and no simplification can slide the texture. Here the charts are
the same (faces put in charts by the cell of a C x C x C grid over the
bounding box their centroid falls in, seams.fchart_of), but each chart's UV
is a smooth non-affine function of the 3D position:

  (x', y', z') = (p - lo_c) / h          lo_c the cell's low corner, h its
                                         edge (bounding box's largest
                                         extent / C), so about [0, 1]^3
  s = x' + 0.15 sin(2 pi y') + 0.1 z'^2
  t = y' + 0.15 sin(2 pi x') - 0.1 z'^2
  f_c(p) = ((col_c, row_c) + 0.05 + k (s - s0, t - t0)) / ncol

(col_c, row_c) is chart c's tile in an ncol x ncol atlas; s0, t0 and k (one
scale for the whole atlas and both axes) put every input vertex record in
[0.05, 0.95] of its tile, so a UV's tile names its chart. In (x', y') the
warp is the identity plus a perturbation of Lipschitz constant 0.15 * 2 pi
< 1, so one-to-one; the z' term makes it non-planar (a chart's texture
changes along z as well).

The metric, texture slide: each output triangle's chart is the tile its
corners' UVs lie in (all three must agree; the triangles that do not are
counted, as are corners without UV). The triangle is sampled at the
centroids of its n x n sub-triangles (--subdiv n, default 3: 9 points, equal
area), and at every point q the UV interpolated from its corners is compared
with f_c(q) (f_c is defined for any 3D point, also off the input surface).
Reported in units of one tile (x ncol): the area-weighted RMS and the
maximum of |uv_interp - f_c(q)|. Output vertices are input vertex records,
so this is zero at the corners and the slide of a triangle grows with how
far f_c bends across it; the input's own triangles have some (the `input`
rows, ratio 1: the floor). Geometric error: `epsnet hausdorff` of the mesh
without UVs against the output, as seams.py's measure(): Hausdorff and the
mean of both directions' mean distance, relative to the diagonal.

For every mesh (the shared scans bunny and armadillo, `epsnet gen` shapes
from --gen), grid size C and ratio R:
  epsnet             epsnet simplify --ratio R of the textured OBJ
  epsnet uv=W        the same with --attribute-weight uv=W, W in --weights
  epsnet slab        both of these (W = 0 and 1) through --slab 4096
  meshopt w          node bench/meshopt1x_attributes.mjs, UV weight w in
                     --meshopt-weights (0.01, 0.1, 1, 10, 100), to the face
                     count `epsnet` produced
A second table gives each method's values over every mesh, C and R as a
geometric mean of its ratio to the unweighted epsnet run's.

  python3 bench/attribute_error.py [--epsnet BIN] [--data DIR] [--gen bumpy:200K]
      [--cells 4,8] [--ratios 0.05,0.25] [--weights 0.25,0.5,1,2,4] [--out FILE]
      [--meshopt-weights 0.01,0.1,1,10,100] [--subdiv 3] [--work DIR]

Python 3 standard library; node with bench/node_modules (npm install in
bench/) for the meshoptimizer rows, skipped with a note without them. The
tools run one after another; nothing is timed.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.dont_write_bytecode = True   # leave bench/__pycache__ alone
import seams  # noqa: E402  (read_obj, fchart_of, measure)

REPO = os.path.dirname(HERE)
SCANS = (("bunny", "bun_zipper.ply.zst"), ("armadillo", "armadillo_decim100k.obj.zst"))
AMP, ZQ = 0.15, 0.1          # the warp's sine amplitude and z'^2 coefficient
MARGIN = 0.05                # each chart's UVs within [MARGIN, 1 - MARGIN] of its tile
SLAB = 4096


def run(args):
    """(return code, stdout, stderr) of a command; never raises."""
    r = subprocess.run([str(x) for x in args], capture_output=True, text=True)
    return r.returncode, r.stdout, r.stderr


class Atlas:
    """The charts of a mesh (v, faces from seams.read_obj) for a C-grid and
    their UV function f_c."""

    def __init__(self, path, v, faces, cells):
        self.fchart = seams.fchart_of(path, cells)
        self.nch = max(self.fchart) + 1
        self.ncol = math.ceil(math.sqrt(self.nch))
        lo = [min(p[i] for p in v) for i in range(3)]
        ext = max(max(p[i] for p in v) - lo[i] for i in range(3))
        self.h = ext / cells
        # each chart's cell, as seams.fchart_of finds it (the centroid's)
        self.cell_lo = [None] * self.nch
        for (pos, _), c in zip(faces, self.fchart):
            if self.cell_lo[c] is None:
                cell = [min(cells - 1, int((sum(v[k][i] for k in pos) / 3 - lo[i]) / ext * cells))
                        for i in range(3)]
                self.cell_lo[c] = tuple(lo[i] + cell[i] * self.h for i in range(3))
        # the atlas's scale: every input record's (s, t) into its tile's margins
        self.s0 = self.t0 = 0.0
        self.k = 1.0
        st = [self.warp(c, v[k]) for (pos, _), c in zip(faces, self.fchart) for k in pos]
        s0, s1 = min(x[0] for x in st), max(x[0] for x in st)
        t0, t1 = min(x[1] for x in st), max(x[1] for x in st)
        self.s0, self.t0 = s0, t0
        self.k = (1 - 2 * MARGIN) / max(s1 - s0, t1 - t0)

    def warp(self, c, p):
        lx, ly, lz = self.cell_lo[c]
        x, y, z = (p[0] - lx) / self.h, (p[1] - ly) / self.h, (p[2] - lz) / self.h
        return (x + AMP * math.sin(2 * math.pi * y) + ZQ * z * z,
                y + AMP * math.sin(2 * math.pi * x) - ZQ * z * z)

    def tile_uv(self, c, p):
        """f_c(p) in tile units (x ncol)."""
        s, t = self.warp(c, p)
        return (c % self.ncol + MARGIN + self.k * (s - self.s0),
                c // self.ncol + MARGIN + self.k * (t - self.t0))

    def write(self, v, faces, dst):
        """The mesh with this atlas as an OBJ (one vt per position and chart)."""
        vt_of, vts, lines = {}, [], []
        n = self.ncol
        for (pos, _), c in zip(faces, self.fchart):
            ids = []
            for k in pos:
                if (k, c) not in vt_of:
                    vt_of[(k, c)] = len(vts) + 1
                    u, w = self.tile_uv(c, v[k])
                    vts.append("vt %.9g %.9g\n" % (u / n, w / n))
                ids.append("%d/%d" % (k + 1, vt_of[(k, c)]))
            lines.append("f %s\n" % " ".join(ids))
        with open(dst, "w") as out:
            for p in v:
                out.write("v %r %r %r\n" % p)
            out.write("".join(vts))
            out.write("".join(lines))


def sub_centroids(n):
    """Barycentric centroids of the n x n congruent sub-triangles."""
    pts = []
    for i in range(n):
        for j in range(n - i):
            pts.append(((i + 1 / 3) / n, (j + 1 / 3) / n))          # upward
            if i + j < n - 1:
                pts.append(((i + 2 / 3) / n, (j + 2 / 3) / n))      # downward
    return [(a, b, 1 - a - b) for a, b in pts]


def slide(atlas, path, subdiv):
    """Texture slide of an output OBJ: dict(rms, max, faces, disagree,
    no_uv, outside) in tile units; rms area-weighted."""
    v, vt, faces = seams.read_obj(path)
    n, nch = atlas.ncol, atlas.nch
    bary = sub_centroids(subdiv)
    w_each = 1.0 / len(bary)
    sum_w = sum_e2 = 0.0
    emax = 0.0
    disagree = no_uv = 0
    warp = atlas.warp
    k, s0, t0 = atlas.k, atlas.s0, atlas.t0
    for pos, tex in faces:
        if min(tex) < 0:
            no_uv += 1
            continue
        uv = [(vt[t][0] * n, vt[t][1] * n) for t in tex]
        tiles = {(math.floor(u), math.floor(w)) for u, w in uv}
        if len(tiles) != 1:
            disagree += 1
            continue
        col, row = tiles.pop()
        c = col + n * row
        if not (0 <= col < n and 0 <= c < nch):
            disagree += 1
            continue
        ou, ov = col + MARGIN - k * s0, row + MARGIN - k * t0
        a, b, d = (v[i] for i in pos)
        e1 = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
        e2 = (d[0] - a[0], d[1] - a[1], d[2] - a[2])
        cx = e1[1] * e2[2] - e1[2] * e2[1]
        cy = e1[2] * e2[0] - e1[0] * e2[2]
        cz = e1[0] * e2[1] - e1[1] * e2[0]
        area = 0.5 * math.sqrt(cx * cx + cy * cy + cz * cz)
        (ua, va), (ub, vb), (ud, vd) = uv
        acc = 0.0
        for wa, wb, wd in bary:
            q = (wa * a[0] + wb * b[0] + wd * d[0], wa * a[1] + wb * b[1] + wd * d[1],
                 wa * a[2] + wb * b[2] + wd * d[2])
            s, t = warp(c, q)
            du = wa * ua + wb * ub + wd * ud - (ou + k * s)
            dv = wa * va + wb * vb + wd * vd - (ov + k * t)
            e2_ = du * du + dv * dv
            acc += e2_
            if e2_ > emax:
                emax = e2_
        sum_e2 += area * w_each * acc
        sum_w += area
    return dict(rms=math.sqrt(sum_e2 / sum_w) if sum_w else float("nan"), max=math.sqrt(emax),
                faces=len(faces), disagree=disagree, no_uv=no_uv)


def geometric(epsnet, plain, out):
    """seams.measure (faces, Hausdorff rel, mean rel), or None on failure."""
    try:
        return seams.measure(epsnet, plain, out)
    except SystemExit as e:
        print("hausdorff failed: %s" % e, file=sys.stderr)
        return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--epsnet", default=os.path.join(REPO, "build-release", "tools", "epsnet"))
    ap.add_argument("--data", default=os.path.join(REPO, "..", "shared", "data"))
    ap.add_argument("--gen", default="bumpy:200K", help="generated meshes, SHAPE:FACES,... ('' for none)")
    ap.add_argument("--cells", default="4,8")
    ap.add_argument("--ratios", default="0.05,0.25")
    ap.add_argument("--weights", default="0.25,0.5,1,2,4", help="epsnet's uv weights (besides none)")
    ap.add_argument("--meshopt-weights", default="0.01,0.1,1,10,100", help="meshoptimizer's UV weights")
    ap.add_argument("--subdiv", type=int, default=3, help="samples per triangle: subdiv^2 (default 3)")
    ap.add_argument("--out", default=None, help="the markdown tables (default stdout); rows also as .json")
    ap.add_argument("--work", default=None, help="work files (default a new temporary folder)")
    a = ap.parse_args()
    work = a.work or tempfile.mkdtemp(prefix="epsnet_attrerr_")
    os.makedirs(work, exist_ok=True)
    node = os.path.join(HERE, "meshopt1x_attributes.mjs")
    have_peer = shutil.which("node") and os.path.isdir(os.path.join(HERE, "node_modules", "meshoptimizer"))
    notes = []
    if not have_peer:
        notes.append("no meshoptimizer rows: node or bench/node_modules/meshoptimizer is missing "
                     "(npm install in bench/)")
        print(notes[-1], file=sys.stderr)
    ratios = [float(x) for x in a.ratios.split(",")]
    weights = [x for x in a.weights.split(",") if x]
    mweights = [float(x) for x in a.meshopt_weights.split(",") if x]

    meshes = [(name, os.path.join(a.data, file)) for name, file in SCANS]
    for spec in filter(None, a.gen.split(",")):
        shape, faces = spec.split(":")
        src = os.path.join(work, "%s_%s.ply" % (shape, faces))
        rc, _, err = run([a.epsnet, "gen", shape, "--faces", faces, "-o", src, "-q"])
        if rc:
            notes.append("gen %s failed (exit %d): %s" % (spec, rc, err.strip()))
            continue
        meshes.append(("%s %s" % (shape, faces), src))

    rows = []
    out = os.path.join(work, "out.obj")

    def log(row):
        print("%-14s c%-2d %-5g %-22s faces %7s  uv rms %.3g max %.3g  H %.4g mean %.4g %s" % (
            row["mesh"], row["cells"], row["ratio"], row["method"], row["faces"], row["uv_rms"], row["uv_max"],
            row["hausdorff"], row["mean"], row["note"]), file=sys.stderr, flush=True)

    for name, src in meshes:
        if not os.path.exists(src):
            notes.append("skip %s: %s is missing" % (name, src))
            print(notes[-1], file=sys.stderr)
            continue
        tag = name.replace(" ", "_")
        plain = os.path.join(work, tag + ".obj")
        rc, _, err = run([a.epsnet, "convert", src, "-o", plain, "-q", "--float32"])
        if rc:
            notes.append("convert %s failed (exit %d): %s" % (name, rc, err.strip()))
            continue
        v, _, faces = seams.read_obj(plain)
        for cells in (int(c) for c in a.cells.split(",")):
            atlas = Atlas(plain, v, faces, cells)
            uvobj = os.path.join(work, "%s_c%d.obj" % (tag, cells))
            atlas.write(v, faces, uvobj)
            # the input's own slide: f_c bends across the input triangles too (the floor)
            m = slide(atlas, uvobj, a.subdiv)
            notes.append("%s, %d cells: %d faces, %d charts in a %dx%d atlas" % (
                name, cells, len(faces), atlas.nch, atlas.ncol, atlas.ncol))
            print(notes[-1], file=sys.stderr, flush=True)
            rows.append(dict(mesh=name, cells=cells, charts=atlas.nch, ratio=1.0, target=len(faces), method="input",
                             faces=m["faces"], uv_rms=m["rms"], uv_max=m["max"], disagree=m["disagree"],
                             no_uv=m["no_uv"], hausdorff=0.0, mean=0.0,
                             note="%d faces across tiles" % m["disagree"] if m["disagree"] else ""))
            log(rows[-1])
            for r in ratios:
                goal = round(r * len(faces))
                runs = [("epsnet", [], None)]
                runs += [("epsnet uv=%s" % w, ["--attribute-weight", "uv=%s" % w], None) for w in weights]
                runs += [("epsnet slab %d" % SLAB, ["--slab", str(SLAB)], None),
                         ("epsnet uv=1 slab %d" % SLAB, ["--attribute-weight", "uv=1", "--slab", str(SLAB)], None)]
                if have_peer:
                    runs += [("meshopt w=%g" % w, None, w) for w in mweights]
                base_faces = None
                for method, opts, mw in runs:
                    if os.path.exists(out):
                        os.remove(out)
                    if mw is None:
                        cmd = [a.epsnet, "simplify", uvobj, "-o", out, "--ratio", str(r), "-q"] + opts
                    else:
                        if base_faces is None:
                            notes.append("%s c%d %g %s: no epsnet face count to aim at" % (name, cells, r, method))
                            continue
                        cmd = ["node", node, uvobj, out, str(base_faces), str(mw)]
                    rc, stdout, err = run(cmd)
                    note = []
                    if rc:
                        notes.append("%s c%d %g %s: exit %d: %s" % (name, cells, r, method, rc, err.strip()[-300:]))
                        print(notes[-1], file=sys.stderr)
                        continue
                    if err.strip():
                        note.append("stderr: " + " / ".join(err.strip().splitlines())[:300])
                    g = geometric(a.epsnet, plain, out)
                    m = slide(atlas, out, a.subdiv)
                    target = goal if mw is None else base_faces
                    if method == "epsnet":
                        base_faces = m["faces"]
                    if m["faces"] != target:
                        note.append("%d faces for a target of %d%s" % (
                            m["faces"], target, " (an even count: a closed surface?)"
                            if target % 2 and m["faces"] == target - 1 else ""))
                    if m["disagree"] or m["no_uv"]:
                        note.append("%d faces across tiles, %d without UV" % (m["disagree"], m["no_uv"]))
                    row = dict(mesh=name, cells=cells, charts=atlas.nch, ratio=r, target=target, method=method,
                               faces=m["faces"], uv_rms=m["rms"], uv_max=m["max"], disagree=m["disagree"],
                               no_uv=m["no_uv"], hausdorff=g[1] if g else float("nan"),
                               mean=g[2] if g else float("nan"), note="; ".join(note))
                    if mw is not None:
                        row["meshopt_stdout"] = stdout.strip()
                    rows.append(row)
                    log(row)

    lines = ["| mesh | cells | ratio | method | faces | UV RMS | UV max | Hausdorff rel | mean rel |",
             "|---|---|---|---|---|---|---|---|---|"]
    for x in rows:
        lines.append("| %s | %d | %g | %s | %d | %.3g | %.3g | %.4g | %.4g |" % (
            x["mesh"], x["cells"], x["ratio"], x["method"], x["faces"], x["uv_rms"], x["uv_max"],
            x["hausdorff"], x["mean"]))

    # each method against the unweighted epsnet run of the same mesh, cells
    # and ratio (slab rows against the unweighted slab run), geometric means
    def gm(xs):
        xs = [x for x in xs if x > 0 and math.isfinite(x)]
        return math.exp(sum(math.log(x) for x in xs) / len(xs)) if xs else float("nan")
    lines += ["", "Against the unweighted epsnet run of the same mesh, cells and ratio (the slab rows against "
              "`epsnet slab %d`): geometric means of the ratios over %d cases." % (
                  SLAB, len({(x["mesh"], x["cells"], x["ratio"]) for x in rows if x["method"] != "input"})), "",
              "| method | UV RMS | UV max | Hausdorff rel | mean rel | faces / target |", "|---|---|---|---|---|---|"]
    for method in dict.fromkeys(x["method"] for x in rows if x["method"] != "input"):
        ratios_ = {key: [] for key in ("uv_rms", "uv_max", "hausdorff", "mean", "faces")}
        for x in rows:
            if x["method"] != method:
                continue
            bm = "epsnet slab %d" % SLAB if "slab" in method else "epsnet"
            base = [y for y in rows if (y["mesh"], y["cells"], y["ratio"], y["method"]) ==
                    (x["mesh"], x["cells"], x["ratio"], bm)]
            if not base:
                continue
            for key in ("uv_rms", "uv_max", "hausdorff", "mean"):
                ratios_[key].append(x[key] / base[0][key] if base[0][key] else float("nan"))
            ratios_["faces"].append(x["faces"] / x["target"])
        lines.append("| %s | %.3f | %.3f | %.3f | %.3f | %.4f |" % (
            method, gm(ratios_["uv_rms"]), gm(ratios_["uv_max"]), gm(ratios_["hausdorff"]), gm(ratios_["mean"]),
            gm(ratios_["faces"])))
    # the same note on several runs of a mesh once, with the runs it was on
    grouped = {}
    for x in rows:
        for note in filter(None, x["note"].split("; ")):
            grouped.setdefault((x["mesh"], note), []).append("c%d %g %s" % (x["cells"], x["ratio"], x["method"]))
    row_notes = ["%s: %s (%d run%s: %s)" % (mesh, note, len(runs_), "s" * (len(runs_) > 1), ", ".join(runs_))
                 for (mesh, note), runs_ in grouped.items()]
    across = sum(x["disagree"] for x in rows if x["method"] != "input")
    no_uv = sum(x["no_uv"] for x in rows if x["method"] != "input")
    notes.append("%d output faces across tiles (corners of two charts) and %d without UV over the %d runs" % (
        across, no_uv, sum(1 for x in rows if x["method"] != "input")))
    lines += ["", "Notes:", ""] + ["- " + n for n in notes + row_notes]
    text = "\n".join(lines) + "\n"
    if a.out:
        os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
        with open(a.out, "w") as f:
            f.write(text)
        with open(os.path.splitext(a.out)[0] + ".json", "w") as f:
            json.dump(rows, f, indent=1)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main()
