#!/usr/bin/env python3
"""Quality of a size target's streamed order against its one-slab order
(docs/architecture.md §7, target stage).

The shared scans fit one slab, where the collapses follow one global
cheapest-first order; forced through small slabs (--slab 4096, 16384) they
take the streamed shape: a thinning pass, rounds under a global cost
ceiling, and an exact last round. Each output is measured with
`epsnet hausdorff IN OUT --json` against the input, and the table gives the
streamed error over the one-slab error, case by case, with geometric means.

    python3 bench/streamed_order.py --epsnet build-rel/tools/epsnet [--data ../shared/data]
        [--ratios 0.05,0.10,0.25,0.50] [--slabs 4096,16384] [--out table.md]
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

MESHES = ("bun_zipper.ply.zst", "armadillo_decim100k.obj.zst", "dragon_vrip_res2.ply.zst")


def run(argv):
    p = subprocess.run(argv, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(argv), p.stderr))
    return p


def simplify(epsnet, src, out, ratio, slab, work):
    stats = os.path.join(work, "stats.json")
    argv = [epsnet, "simplify", src, "-o", out, "--ratio", ratio, "-q", "--stats", stats]
    if slab:
        argv += ["--slab", slab]
    run(argv)
    return json.load(open(stats))


def errors(epsnet, src, out, work):
    js = os.path.join(work, "h.json")
    run([epsnet, "hausdorff", src, out, "--json", js, "-q"])
    h = json.load(open(js))
    ab, ba = h["a_to_b"], h["b_to_a"]
    return h["hausdorff_relative"], max(ab["mean_relative"], ba["mean_relative"])


def geomean(xs):
    return math.exp(sum(math.log(x) for x in xs) / len(xs)) if xs else float("nan")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--epsnet", required=True)
    ap.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data"))
    ap.add_argument("--ratios", default="0.05,0.10,0.25,0.50")
    ap.add_argument("--slabs", default="4096,16384")
    ap.add_argument("--out")
    a = ap.parse_args()
    rows, ratios = [], {s: ([], []) for s in a.slabs.split(",")}
    with tempfile.TemporaryDirectory() as work:
        for mesh in MESHES:
            src = os.path.join(a.data, mesh)
            if not os.path.exists(src):
                print("skipped (not found):", src, file=sys.stderr)
                continue
            for ratio in a.ratios.split(","):
                one = os.path.join(work, "one.ply")
                s1 = simplify(a.epsnet, src, one, ratio, None, work)
                h1, m1 = errors(a.epsnet, src, one, work)
                for slab in a.slabs.split(","):
                    out = os.path.join(work, "streamed.ply")
                    s2 = simplify(a.epsnet, src, out, ratio, slab, work)
                    h2, m2 = errors(a.epsnet, src, out, work)
                    ratios[slab][0].append(h2 / h1)
                    ratios[slab][1].append(m2 / m1)
                    rows.append((mesh.split(".")[0], ratio, slab, s1["output_faces"], s2["output_faces"],
                                 s2["passes"], 1e3 * h1, 1e3 * h2, 1e3 * m1, 1e3 * m2))
                    print(*rows[-1], file=sys.stderr)
    lines = ["| mesh | ratio | --slab | faces one / streamed | passes | Hausdorff ‰ one / streamed | "
             "mean ‰ one / streamed |", "|---|---|---:|---|---:|---|---|"]
    for r in rows:
        lines.append("| %s | %s | %s | %d / %d | %d | %.3f / %.3f (%.2f×) | %.4f / %.4f (%.2f×) |" % (
            r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[7] / r[6], r[8], r[9], r[9] / r[8]))
    for slab, (h, m) in ratios.items():
        lines.append("")
        lines.append("--slab %s: Hausdorff geometric mean %.3f×, worst %.2f×; mean error geometric mean %.3f×, "
                     "worst %.2f×" % (slab, geomean(h), max(h or [0]), geomean(m), max(m or [0])))
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        open(a.out, "w").write(text)


main()
