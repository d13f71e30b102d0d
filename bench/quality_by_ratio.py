#!/usr/bin/env python3
"""Quality by target ratio (issue 15, deliverable 5).

For every mesh and every target ratio R, four rows at (about) the same face
count:
  epsnet --ratio R     epsnet simplify --ratio R ('n/a' while the option
                       does not exist in this build)
  epsnet default       epsnet simplify without a target (one row per mesh,
                       at its own face count)
  meshopt 0.18         bench/peer_meshopt (Debian's libmeshoptimizer) to the
                       face count epsnet --ratio produced, else round(R*faces)
  meshopt 1.x          the npm package `meshoptimizer` (WASM, under node) via
                       bench/meshopt1x_simplify.mjs, to the same face count
Each output is measured with `epsnet hausdorff IN OUT --json`. Writes
OUT/quality.md (also printed), OUT/quality.csv, OUT/quality_MESH.svg, and
prints the issue's 'Must show' summary.

Python 3 standard library only. See bench/README.md.
"""
import argparse
import csv
import glob
import json
import math
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
GNU_TIME = "/usr/bin/time" if os.access("/usr/bin/time", os.X_OK) else None

# Friendly names for the meshes of ../shared/data; the 'Must show' summary
# is over the first three.
KNOWN = {
    "bun_zipper": "bunny",
    "armadillo_decim100k": "armadillo",
    "dragon_vrip_res2": "dragon",
}
SUMMARY_MESHES = ("bunny", "armadillo", "dragon")
SUMMARY_RATIOS = (0.05, 0.10, 0.25, 0.50)
DEFAULT_GEN = "bumpy:200K,cad:150K"

T_RATIO = "epsnet --ratio"
T_DEFAULT = "epsnet default"
T_MO18 = "meshopt 0.18"
T_MO1X = "meshopt 1.x"
TOOLS = (T_RATIO, T_DEFAULT, T_MO18, T_MO1X)

CSV_COLUMNS = ["mesh", "input_faces", "ratio", "target_faces", "tool",
               "faces", "hausdorff_max_rel", "hausdorff_mean_rel",
               "normal_dev_mean_deg", "seconds", "peak_rss_mb", "note"]


class BenchError(Exception):
    pass


def log(message):
    print(message, file=sys.stderr, flush=True)


# ------------------------------------------------------- running a program

def measure(argv, what, cwd=None):
    """Run argv; wall seconds, GNU time's peak RSS in bytes (0 if unknown),
    stdout. A child's ru_maxrss would include the forking Python's image,
    so the peak comes from /usr/bin/time (its 'Maximum resident set size',
    %M)."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err, \
            tempfile.NamedTemporaryFile(mode="r") as rss:
        wrapped = list(argv)
        if GNU_TIME:
            wrapped = [GNU_TIME, "-f", "%M", "-o", rss.name] + wrapped
        start = time.monotonic()
        proc = subprocess.run(wrapped, stdout=out, stderr=err, cwd=cwd)
        seconds = time.monotonic() - start
        out.seek(0)
        err.seek(0)
        stdout = out.read().decode(errors="replace")
        stderr = err.read().decode(errors="replace")
        rss_words = rss.read().split()
    if proc.returncode != 0:
        tail = "\n".join(stderr.strip().splitlines()[-5:])
        raise BenchError(f"{what} failed (exit {proc.returncode}): "
                         f"{' '.join(argv)}\n{tail}")
    peak = 0
    if rss_words and rss_words[-1].isdigit():
        peak = int(rss_words[-1]) * 1024
    return {"seconds": seconds, "peak_rss": peak, "stdout": stdout}


def read_json(path, what):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        raise BenchError(f"{what}: cannot read {path}: {e}")


def remove(path):
    try:
        os.remove(path)
    except FileNotFoundError:
        pass


# ------------------------------------------------------------------ tools

class Tools:
    def __init__(self, args):
        self.epsnet = args.epsnet or os.path.join(args.build, "tools", "epsnet")
        if not os.access(self.epsnet, os.X_OK):
            raise BenchError(f"{self.epsnet} not found: build first "
                             f"(ninja -C {args.build}) or pass --build DIR")
        peer = os.path.join(args.build, "bench", "peer_meshopt")
        self.peer = peer if os.access(peer, os.X_OK) else None
        self.threads = str(args.threads)
        self.notes = []
        if not self.peer:
            self.notes.append(f"{peer} not built (Debian's libmeshoptimizer-dev "
                              "missing?): the meshopt 0.18 rows are n/a")
        help_text = subprocess.run([self.epsnet, "simplify", "--help"],
                                   capture_output=True, text=True).stdout
        self.has_ratio = "--ratio" in help_text
        if not self.has_ratio:
            self.notes.append("this epsnet has no `simplify --ratio`: the epsnet "
                              "--ratio rows are n/a, and the peers run to "
                              "round(R*faces)")
        self.node = shutil.which("node")
        self.mo1x_script = os.path.join(HERE, "meshopt1x_simplify.mjs")
        self.mo1x_version = None
        pkg = os.path.join(HERE, "node_modules", "meshoptimizer", "package.json")
        if not self.node:
            self.notes.append("node not found: the meshopt 1.x rows are n/a")
        elif not os.path.exists(pkg):
            self.notes.append("bench/node_modules/meshoptimizer missing (run "
                              "`npm install` in bench/): the meshopt 1.x rows "
                              "are n/a")
        else:
            self.mo1x_version = read_json(pkg, "meshoptimizer package.json")["version"]
            if not self.mo1x_version.startswith("1."):
                self.notes.append(f"bench/node_modules has meshoptimizer "
                                  f"{self.mo1x_version}, not 1.x")

    def faces_of(self, path):
        got = measure([self.epsnet, "info", path], "epsnet info")
        for line in got["stdout"].splitlines():
            if line.startswith("triangles:"):
                return int(line.split()[1])
        raise BenchError(f"epsnet info {path}: no 'triangles:' line")

    def hausdorff(self, reference, candidate, work):
        """Symmetric figures: Hausdorff max is the symmetric one; mean and
        mean normal deviation are the worse of the two directions (a
        one-sided mean hides a surface that misses a region)."""
        out = os.path.join(work, "hausdorff.json")
        measure([self.epsnet, "hausdorff", reference, candidate, "--json", out,
                 "-q", "-j", self.threads], "epsnet hausdorff")
        h = read_json(out, "epsnet hausdorff --json")
        remove(out)
        ab, ba = h["a_to_b"], h["b_to_a"]
        return {
            "faces": h["b"]["faces"],
            "hausdorff_max_rel": h["hausdorff_relative"],
            "hausdorff_mean_rel": max(ab["mean_relative"], ba["mean_relative"]),
            "normal_dev_mean_deg": max(ab["normal_deviation_deg"]["mean"],
                                       ba["normal_deviation_deg"]["mean"]),
        }


# ----------------------------------------------------------------- inputs

def mesh_name(path):
    base = os.path.basename(path)
    stem = base.split(".")[0]
    return KNOWN.get(stem, stem)


def parse_count(text):
    text = text.strip().upper()
    scale = {"K": 10**3, "M": 10**6, "G": 10**9}.get(text[-1:], 1)
    if scale > 1:
        text = text[:-1]
    return int(float(text) * scale)


def inputs(args, tools):
    meshes = []
    if args.meshes:
        paths = args.meshes
    else:
        pattern = os.path.join(args.shared_data, "*.zst")
        paths = sorted(glob.glob(pattern))
        if not paths:
            msg = f"no meshes at {pattern}: the shared meshes are skipped"
            log(msg)
            tools.notes.append(msg)
    for path in paths:
        if not os.path.exists(path):
            msg = f"{path} not present: skipped"
            log(msg)
            tools.notes.append(msg)
            continue
        meshes.append((mesh_name(path), path))
    gen = args.gen if args.gen is not None else ("" if args.meshes else DEFAULT_GEN)
    for item in filter(None, (s.strip() for s in gen.split(","))):
        shape, _, faces = item.partition(":")
        faces = parse_count(faces or "150K")
        path = os.path.join(args.out, "meshes", f"{shape}_{faces}_seed{args.seed}.smb")
        if not os.path.exists(path):
            os.makedirs(os.path.dirname(path), exist_ok=True)
            log(f"generating {shape} with about {faces} faces -> {path}")
            measure([tools.epsnet, "gen", shape, "--faces", str(faces), "-o", path,
                     "--seed", str(args.seed), "-q"], f"epsnet gen {shape}")
        meshes.append((f"{shape}_{faces // 1000}k", path))
    return meshes


# ------------------------------------------------------------------- rows

def na_row(mesh, faces_in, ratio, target, tool, note):
    return {"mesh": mesh, "input_faces": faces_in, "ratio": ratio,
            "target_faces": target, "tool": tool, "faces": None,
            "hausdorff_max_rel": None, "hausdorff_mean_rel": None,
            "normal_dev_mean_deg": None, "seconds": None, "peak_rss_mb": None,
            "note": note}


def done_row(mesh, faces_in, ratio, target, tool, got, metrics, note=""):
    row = na_row(mesh, faces_in, ratio, target, tool, note)
    row.update(metrics)
    row["seconds"] = round(got["seconds"], 3)
    row["peak_rss_mb"] = round(got["peak_rss"] / 1e6, 1) if got["peak_rss"] else None
    return row


def failed_row(mesh, faces_in, ratio, target, tool, error):
    """A run that failed stays in the table as n/a with the reason, so one
    bad case does not lose the others."""
    first = str(error).splitlines()
    log(f"    {tool} failed: {error}")
    return na_row(mesh, faces_in, ratio, target, tool,
                  "failed: " + (first[-1] if first else "?"))


def run_epsnet(tools, src, work, extra):
    out = os.path.join(work, "epsnet.smb")
    stats = os.path.join(work, "epsnet.json")
    got = measure([tools.epsnet, "simplify", src, "-o", out, "-j", tools.threads,
                   "--stats", stats, "-q"] + extra, "epsnet simplify")
    data = read_json(stats, "epsnet simplify --stats")
    # the tool's own high-water mark (VmHWM), else GNU time's
    got["peak_rss"] = data.get("peak_rss") or got["peak_rss"]
    remove(stats)
    # what a targeted run reports about its skeleton (issue 15), when it does
    facts = []
    sphere = data.get("gaussian_sphere")
    if extra and isinstance(sphere, dict) and "frequency" in sphere:
        facts.append(f"frequency {sphere['frequency']}")
    target = data.get("target") if extra else None
    if isinstance(target, dict):
        if data.get("output_vertices"):
            share = target.get("skeleton_vertices", 0) / data["output_vertices"]
            facts.append(f"skeleton {100 * share:.0f}% of the output vertices")
        facts.append(f"samples given up {target.get('samples_given_up', 0)}")
    got["note"] = ", ".join(facts)
    return out, got


def run_mo18(tools, src, work, target):
    out = os.path.join(work, "mo18.smb")
    got = measure([tools.peer, src, out, str(target)], "peer_meshopt")
    fields = got["stdout"].split()
    if len(fields) >= 4 and fields[3].isdigit():
        got["peak_rss"] = int(fields[3])  # the peer's own VmHWM
    return out, got


def run_mo1x(tools, ply, work, target):
    out = os.path.join(work, "mo1x.obj")
    # node resolves 'meshoptimizer' from bench/node_modules beside the script
    got = measure([tools.node, tools.mo1x_script, ply, out, str(target)],
                  "meshopt1x_simplify.mjs")
    # GNU time's peak covers node itself and the WASM heap
    return out, got


def measure_mesh(tools, args, mesh, src, work):
    faces_in = tools.faces_of(src)
    rows = []
    log(f"{mesh}: {faces_in} faces")

    out, got = run_epsnet(tools, src, work, [])
    metrics = tools.hausdorff(src, out, work)
    remove(out)
    rows.append(done_row(mesh, faces_in, metrics["faces"] / faces_in, None,
                         T_DEFAULT, got, metrics))

    ply = None
    if tools.node and tools.mo1x_version:
        ply = os.path.join(work, "input_f32.ply")
        measure([tools.epsnet, "convert", src, "-o", ply, "--float32", "-q"],
                "epsnet convert (for meshopt 1.x)")

    for ratio in args.ratios:
        target = round(ratio * faces_in)
        peer_target = target
        log(f"  {mesh} ratio {ratio:g}: target {target} faces")
        if tools.has_ratio:
            try:
                out, got = run_epsnet(tools, src, work, ["--ratio", f"{ratio:g}"])
                metrics = tools.hausdorff(src, out, work)
                remove(out)
                rows.append(done_row(mesh, faces_in, ratio, target, T_RATIO, got,
                                     metrics, got["note"]))
                peer_target = metrics["faces"]
            except BenchError as e:
                rows.append(failed_row(mesh, faces_in, ratio, target, T_RATIO, e))
        else:
            rows.append(na_row(mesh, faces_in, ratio, target, T_RATIO,
                               "no --ratio in this epsnet"))
        if tools.peer:
            try:
                out, got = run_mo18(tools, src, work, peer_target)
                metrics = tools.hausdorff(src, out, work)
                remove(out)
                rows.append(done_row(mesh, faces_in, ratio, target, T_MO18, got, metrics))
            except BenchError as e:
                rows.append(failed_row(mesh, faces_in, ratio, target, T_MO18, e))
        else:
            rows.append(na_row(mesh, faces_in, ratio, target, T_MO18,
                               "peer_meshopt not built"))
        if ply:
            try:
                out, got = run_mo1x(tools, ply, work, peer_target)
                metrics = tools.hausdorff(src, out, work)
                remove(out)
                rows.append(done_row(mesh, faces_in, ratio, target, T_MO1X, got, metrics,
                                     f"meshoptimizer {tools.mo1x_version}; "
                                     "time not comparable"))
            except BenchError as e:
                rows.append(failed_row(mesh, faces_in, ratio, target, T_MO1X, e))
        else:
            rows.append(na_row(mesh, faces_in, ratio, target, T_MO1X,
                               "node or the npm package missing"))
    if ply:
        remove(ply)
    return rows


# ---------------------------------------------------------------- outputs

def fmt(value, digits):
    return "n/a" if value is None else f"{value:.{digits}f}"


def markdown(rows, command, notes):
    lines = [
        "# Quality by target ratio",
        "",
        f"Command: `{command}`",
        "",
        "Errors are `epsnet hausdorff IN OUT`: Hausdorff max is the symmetric "
        "distance, mean the worse direction's area-weighted mean, both in ‰ "
        "(10⁻³) of the input's bounding-box diagonal; normal deviation is the "
        "worse direction's mean angle in degrees. Time is the wall clock of "
        "the whole process (read, simplify, write); meshopt 1.x runs as WASM "
        "under node, so its time and RSS are not comparable. Peak RSS is the "
        "tool's own high-water mark where it prints one, else GNU time's.",
        "",
        "| mesh | target | tool | faces | Hausdorff max ‰ | mean ‰ "
        "| normal dev ° | time s | peak RSS MB |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        if r["tool"] == T_DEFAULT:
            target = f"(default, {100 * r['ratio']:.1f}%)"
        else:
            target = f"{100 * r['ratio']:g}% = {r['target_faces']}"
        hmax = None if r["hausdorff_max_rel"] is None else 1e3 * r["hausdorff_max_rel"]
        hmean = None if r["hausdorff_mean_rel"] is None else 1e3 * r["hausdorff_mean_rel"]
        lines.append(
            f"| {r['mesh']} | {target} | {r['tool']} "
            f"| {'n/a' if r['faces'] is None else r['faces']} "
            f"| {fmt(hmax, 3)} | {fmt(hmean, 4)} "
            f"| {fmt(r['normal_dev_mean_deg'], 2)} | {fmt(r['seconds'], 2)} "
            f"| {fmt(r['peak_rss_mb'], 1)} |")
    failed = [f"{r['mesh']} {r['tool']} at {100 * r['ratio']:g}%: {r['note']}"
              for r in rows if r["note"].startswith("failed")]
    extra = [f"{r['mesh']} {100 * r['ratio']:g}%: {r['note']}" for r in rows
             if r["tool"] == T_RATIO and r["faces"] is not None and r["note"]]
    notes = list(notes) + failed
    if extra:
        notes.append("epsnet --ratio runs: " + "; ".join(extra))
    if notes:
        lines += ["", "Notes:"] + [f"- {n}" for n in notes]
    return "\n".join(lines) + "\n"


def geomean(values):
    return math.exp(sum(math.log(v) for v in values) / len(values))


def pair_summary(rows, candidate, reference, ratios):
    """Ratios candidate/reference over bunny, armadillo, dragon x ratios."""
    by = {(r["mesh"], r["ratio"], r["tool"]): r for r in rows
          if r["tool"] != T_DEFAULT}
    cases, missing = [], []
    for mesh in SUMMARY_MESHES:
        for ratio in ratios:
            c = by.get((mesh, ratio, candidate))
            m = by.get((mesh, ratio, reference))
            if not c or not m or c["faces"] is None or m["faces"] is None:
                missing.append(f"{mesh} {100 * ratio:g}%")
                continue
            cases.append((mesh, ratio, c, m))
    return cases, missing


def must_show(rows, ratios):
    ratios = [r for r in ratios if any(abs(r - s) < 1e-12 for s in SUMMARY_RATIOS)] or ratios
    out = ["", f"## Must show (issue 15): {', '.join(SUMMARY_MESHES)} at "
           f"{', '.join(f'{100 * r:g}%' for r in ratios)}, against {T_MO1X}", ""]

    def block(candidate, label):
        cases, missing = pair_summary(rows, candidate, T_MO1X, ratios)
        if not cases:
            out.append(f"- {label}: n/a ({len(missing)} cases without a row)")
            return
        def ratio_of(key):
            vals = []
            for _, _, c, m in cases:
                if m[key] > 0 and c[key] > 0:
                    vals.append(c[key] / m[key])
            return vals
        hmax = ratio_of("hausdorff_max_rel")
        hmean = ratio_of("hausdorff_mean_rel")
        ndev = ratio_of("normal_dev_mean_deg")
        gm_max, gm_mean, gm_ndev = geomean(hmax), geomean(hmean), geomean(ndev)
        worst = max(hmax)
        worst_case = [f"{mesh} {100 * ratio:g}%" for (mesh, ratio, c, m), v
                      in zip(cases, hmax) if v == worst][0]
        face_ok = []
        for mesh, ratio, c, m in cases:
            want = round(ratio * c["input_faces"])
            face_ok.append((mesh, ratio, c["faces"], want,
                            abs(c["faces"] - want) <= 0.005 * want))
        misses = [f"{mesh} {100 * ratio:g}%: {got} vs {want}"
                  for mesh, ratio, got, want, ok in face_ok if not ok]

        def verdict(ok):
            return "yes" if ok else "NO"
        out.append(f"- {label}, {len(cases)} of {len(cases) + len(missing)} cases"
                   + (f" (INCOMPLETE, no row for: {', '.join(missing)}; the "
                      "figures below cover only the cases measured)" if missing else ""))
        out.append(f"  - Hausdorff max, geometric mean of ratios: {gm_max:.3f}× "
                   f"(goal ≤ 1.0: {verdict(gm_max <= 1.0)})")
        out.append(f"  - Hausdorff max, worst case: {worst:.3f}× at {worst_case} "
                   f"(goal ≤ 1.3: {verdict(worst <= 1.3)})")
        out.append(f"  - mean error, geometric mean: {gm_mean:.3f}× "
                   f"(goal ≤ 1.1: {verdict(gm_mean <= 1.1)})")
        out.append(f"  - mean normal deviation, geometric mean: {gm_ndev:.3f}× "
                   f"(goal ≤ 1.0: {verdict(gm_ndev <= 1.0)})")
        out.append(f"  - face counts within ±0.5% of round(R·faces): "
                   f"{verdict(not misses)}"
                   + (f" (misses: {'; '.join(misses)})" if misses else
                      f" (all {len(face_ok)})"))

    block(T_RATIO, f"{T_RATIO} / {T_MO1X}")
    block(T_MO18, f"for reference, {T_MO18} / {T_MO1X}")
    return "\n".join(out) + "\n"


def write_csv(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=CSV_COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in CSV_COLUMNS})


# -------------------------------------------------------------------- SVG

COLORS = {T_RATIO: "#d62728", T_DEFAULT: "#9467bd", T_MO18: "#1f77b4",
          T_MO1X: "#2ca02c"}
MARKERS = {T_RATIO: "circle", T_DEFAULT: "star", T_MO18: "square",
           T_MO1X: "triangle"}


def esc(text):
    return (str(text).replace("&", "&amp;").replace("<", "&lt;")
            .replace(">", "&gt;"))


def log_ticks(lo, hi):
    """Decades and, when the span is short, 2 and 5 between them."""
    ticks = []
    span = math.log10(hi) - math.log10(lo)
    steps = (1,) if span > 3 else (1, 2, 5)
    for e in range(math.floor(math.log10(lo)) - 1, math.ceil(math.log10(hi)) + 1):
        for s in steps:
            v = s * 10.0 ** e
            if lo <= v <= hi:
                ticks.append(v)
    return ticks


def tick_label(v):
    if v >= 1000:
        return f"{v / 1000:g}K" if v < 1e6 else f"{v / 1e6:g}M"
    return f"{v:g}"


def marker(kind, x, y, color, size=4):
    if kind == "square":
        return (f'<rect x="{x - size:.1f}" y="{y - size:.1f}" width="{2 * size}" '
                f'height="{2 * size}" fill="{color}"/>')
    if kind == "triangle":
        return (f'<polygon points="{x:.1f},{y - size - 1:.1f} {x - size - 1:.1f},'
                f'{y + size:.1f} {x + size + 1:.1f},{y + size:.1f}" fill="{color}"/>')
    if kind == "star":
        pts = []
        for i in range(10):
            r = (size + 3) if i % 2 == 0 else (size + 3) / 2.4
            a = math.pi / 2 + i * math.pi / 5
            pts.append(f"{x + r * math.cos(a):.1f},{y - r * math.sin(a):.1f}")
        return f'<polygon points="{" ".join(pts)}" fill="{color}"/>'
    return f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{size}" fill="{color}"/>'


def panel(rows, key, title, x0, y0, w, h):
    """One log-log panel: error `key` against output faces, one polyline
    per tool; returns SVG elements."""
    pts = [(r["faces"], r[key]) for r in rows
           if r["faces"] and r[key] is not None and r[key] > 0]
    el = [f'<text x="{x0 + w / 2}" y="{y0 - 10}" text-anchor="middle" '
          f'font-size="14">{esc(title)}</text>']
    el.append(f'<rect x="{x0}" y="{y0}" width="{w}" height="{h}" fill="none" '
              f'stroke="#333"/>')
    if not pts:
        el.append(f'<text x="{x0 + w / 2}" y="{y0 + h / 2}" text-anchor="middle">'
                  'no data</text>')
        return el
    xs = [p[0] for p in pts]
    ys = [1e3 * p[1] for p in pts]
    xlo, xhi = min(xs) / 1.25, max(xs) * 1.25
    ylo, yhi = min(ys) / 1.4, max(ys) * 1.4

    def px(v):
        return x0 + w * (math.log10(v) - math.log10(xlo)) / (math.log10(xhi) - math.log10(xlo))

    def py(v):
        return y0 + h - h * (math.log10(v) - math.log10(ylo)) / (math.log10(yhi) - math.log10(ylo))

    for t in log_ticks(xlo, xhi):
        x = px(t)
        el.append(f'<line x1="{x:.1f}" y1="{y0}" x2="{x:.1f}" y2="{y0 + h}" '
                  f'stroke="#ddd"/>')
        el.append(f'<text x="{x:.1f}" y="{y0 + h + 16}" text-anchor="middle" '
                  f'font-size="11">{tick_label(t)}</text>')
    for t in log_ticks(ylo, yhi):
        y = py(t)
        el.append(f'<line x1="{x0}" y1="{y:.1f}" x2="{x0 + w}" y2="{y:.1f}" '
                  f'stroke="#ddd"/>')
        el.append(f'<text x="{x0 - 6}" y="{y + 4:.1f}" text-anchor="end" '
                  f'font-size="11">{t:g}</text>')
    el.append(f'<text x="{x0 + w / 2}" y="{y0 + h + 36}" text-anchor="middle" '
              f'font-size="12">output faces (log)</text>')
    el.append(f'<text transform="translate({x0 - 48},{y0 + h / 2}) rotate(-90)" '
              f'text-anchor="middle" font-size="12">‰ of bbox diagonal (log)</text>')
    for tool in TOOLS:
        series = sorted((r["faces"], 1e3 * r[key]) for r in rows
                        if r["tool"] == tool and r["faces"] and r[key] is not None
                        and r[key] > 0)
        if not series:
            continue
        color = COLORS[tool]
        if len(series) > 1:
            coords = " ".join(f"{px(x):.1f},{py(y):.1f}" for x, y in series)
            el.append(f'<polyline points="{coords}" fill="none" stroke="{color}" '
                      f'stroke-width="1.8"/>')
        for x, y in series:
            el.append(marker(MARKERS[tool], px(x), py(y), color))
    return el


def write_svg(path, mesh, rows, notes):
    W, H = 1040, 430
    el = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" '
          f'viewBox="0 0 {W} {H}" font-family="sans-serif">',
          f'<rect width="{W}" height="{H}" fill="white"/>',
          f'<text x="{W / 2}" y="22" text-anchor="middle" font-size="16" '
          f'font-weight="bold">{esc(mesh)}: error against output faces</text>']
    el += panel(rows, "hausdorff_max_rel", "Hausdorff max", 80, 60, 330, 290)
    el += panel(rows, "hausdorff_mean_rel", "mean error", 500, 60, 330, 290)
    ly = 70
    for tool in TOOLS:
        present = any(r["tool"] == tool and r["faces"] for r in rows)
        label = tool + ("" if present else " (n/a)")
        el.append(marker(MARKERS[tool], 860, ly, COLORS[tool]))
        el.append(f'<text x="872" y="{ly + 4}" font-size="12">{esc(label)}</text>')
        ly += 22
    if notes:
        el.append(f'<text x="80" y="{H - 12}" font-size="10" fill="#555">'
                  f'{esc(notes)}</text>')
    el.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(el) + "\n")


# ------------------------------------------------------------------- main

def parse_args(argv):
    p = argparse.ArgumentParser(
        description="Quality table by target ratio: epsnet --ratio, epsnet's "
        "default, meshoptimizer 0.18 (bench/peer_meshopt) and meshoptimizer "
        "1.x (npm, WASM under node) at the same face count.")
    p.add_argument("meshes", nargs="*",
                   help="meshes to measure (default: every ../shared/data/*.zst "
                   "plus the --gen shapes)")
    p.add_argument("--build", default=None,
                   help="meson build directory (default build-release, else build)")
    p.add_argument("--epsnet", default=None,
                   help="the epsnet binary (default BUILD/tools/epsnet)")
    p.add_argument("--ratios", default="0.05,0.10,0.25,0.50",
                   help="target ratios, comma-separated (default 0.05,0.10,0.25,0.50)")
    p.add_argument("--out", default=os.path.join(HERE, "out", "quality_by_ratio"),
                   help="results folder (default bench/out/quality_by_ratio)")
    p.add_argument("--shared-data", default=os.path.join(REPO, "..", "shared", "data"),
                   help="folder of the shared meshes (default ../shared/data)")
    p.add_argument("--gen", default=None,
                   help=f"generated shapes as SHAPE:FACES,... (default {DEFAULT_GEN} "
                   "when no mesh is named, else none; '' for none)")
    p.add_argument("--seed", type=int, default=1, help="seed of epsnet gen (default 1)")
    p.add_argument("-j", "--threads", type=int, default=1,
                   help="threads for epsnet simplify and hausdorff (default 1)")
    args = p.parse_args(argv)
    try:
        args.ratios = [float(x) for x in args.ratios.split(",") if x.strip()]
    except ValueError:
        p.error(f"bad --ratios '{args.ratios}'")
    if not args.ratios or any(not 0 < r <= 1 for r in args.ratios):
        p.error("--ratios: each R must satisfy 0 < R <= 1")
    if args.build is None:
        args.build = os.path.join(REPO, "build-release")
        if not os.path.exists(os.path.join(args.build, "tools", "epsnet")):
            args.build = os.path.join(REPO, "build")
    return args


def main(argv):
    args = parse_args(argv)
    try:
        tools = Tools(args)
        os.makedirs(args.out, exist_ok=True)
        meshes = inputs(args, tools)
        if not meshes:
            raise BenchError("no mesh to measure")
        rows = []
        with tempfile.TemporaryDirectory(dir=args.out, prefix="work_") as work:
            for mesh, src in meshes:
                mesh_rows = measure_mesh(tools, args, mesh, src, work)
                rows += mesh_rows
                write_svg(os.path.join(args.out, f"quality_{mesh}.svg"), mesh,
                          mesh_rows, "" if tools.has_ratio else
                          "epsnet --ratio: n/a in this build")
    except BenchError as e:
        print(f"quality_by_ratio: {e}", file=sys.stderr)
        return 1
    command = shlex.join(["bench/quality_by_ratio.py"] + list(argv))
    text = markdown(rows, command, tools.notes) + must_show(rows, args.ratios)
    with open(os.path.join(args.out, "quality.md"), "w") as f:
        f.write(text)
    write_csv(os.path.join(args.out, "quality.csv"), rows)
    sys.stdout.write(text)
    log(f"wrote {args.out}/quality.md, quality.csv and quality_*.svg")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
