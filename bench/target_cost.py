#!/usr/bin/env python3
"""The cost of a size target against the default path (issue 15's
Deliverable 4: time per input face no worse than the default's), in one run
with alternating repetitions: ratios are taken rep by rep and the median is
reported, since the machine may be shared.

    bench/target_cost.py --build build-release --sizes 2M,20M --ratio 0.1 --mem 1G --reps 3

For each size, `epsnet gen bumpy` makes a sorted .smz (seed 7). Measured, each
a whole process under /usr/bin/time (wall, user+sys CPU, peak RSS), in turn:

  default    epsnet simplify IN.smz -o OUT.smz -j T -q
  target     epsnet simplify IN.smz -o OUT.smz -j T -q --ratio R      (the finish in one slab
                                                                      when it fits the budget)
  on_slabs   the same with --mem M                                    (the finish on slabs, when M
                                                                      is small enough)

with --stats, for the face counts and the slabs. Prints a markdown table of
medians and of ratios to the default; writes runs.csv and results.md under --out.
"""
import argparse
import csv
import json
import os
import platform
import statistics
import subprocess
import sys


def size_arg(text):
    mult = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30}
    t = text.strip().upper()
    return int(float(t[:-1]) * mult[t[-1]]) if t[-1] in mult else int(t)


def timed(cmd):
    """Run cmd under GNU time: (wall s, cpu s, peak RSS MB)."""
    p = subprocess.run(["/usr/bin/time", "-f", "%e %U %S %M"] + cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), p.stderr[-2000:]))
    last = p.stderr.strip().splitlines()[-1].split()
    return float(last[0]), float(last[1]) + float(last[2]), int(last[3]) / 1024.0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build-release")
    ap.add_argument("--sizes", default="2M")
    ap.add_argument("--ratio", default="0.1")
    ap.add_argument("--mem", default="150M", help="budget for the finish on slabs ('' to skip that run)")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default="bench/out/target_cost")
    a = ap.parse_args()
    epsnet = os.path.join(a.build, "tools", "epsnet")
    os.makedirs(a.out, exist_ok=True)
    runs = [("default", []), ("target", ["--ratio", a.ratio])]
    if a.mem:
        runs.append(("on_slabs", ["--ratio", a.ratio, "--mem", a.mem]))
    rows, table = [], []
    for size_text in a.sizes.split(","):
        smz = os.path.join(a.out, "bumpy_%s.smz" % size_text)
        if not os.path.exists(smz):
            subprocess.run([epsnet, "gen", "bumpy", "--faces", str(size_arg(size_text)), "--seed", "7", "-o", smz,
                            "-q"], check=True)
        out, stats = os.path.join(a.out, "out.smz"), os.path.join(a.out, "stats.json")
        got = {name: [] for name, _ in runs}
        for rep in range(a.reps):
            for name, opts in runs:
                w, c, r = timed([epsnet, "simplify", smz, "-o", out, "-j", str(a.threads), "-q", "--stats", stats]
                                + opts)
                st = json.load(open(stats))
                got[name].append((w, c, r))
                rows.append(dict(size=size_text, run=name, rep=rep, wall=w, cpu=c, rss_mb=r,
                                 faces=st["output_faces"], target=st["target"]["faces"], slabs=st["slabs"]))
        base = got["default"]
        for name, _ in runs:
            med = [statistics.median(x[i] for x in got[name]) for i in range(3)]
            ratio = [statistics.median(x[i] / b[i] for x, b in zip(got[name], base)) for i in range(3)]
            last = [r for r in rows if r["size"] == size_text and r["run"] == name][-1]
            table.append("| %s | %s | %.2f s | %.2f s | %.0f MB | %.2f× | %.2f× | %.2f× | %d (%d) | %d |" % (
                size_text, name, med[0], med[1], med[2], ratio[0], ratio[1], ratio[2], last["faces"], last["target"],
                last["slabs"]))
    head = ["machine: %s, %d cores; %s; -j %d, --ratio %s, %d reps" % (platform.processor() or platform.machine(),
                                                                        os.cpu_count(), a.build, a.threads, a.ratio,
                                                                        a.reps),
            "",
            "| size | run | wall | CPU | peak | wall / default | CPU / default | peak / default | faces (target) | slabs |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    text = "\n".join(head + table) + "\n"
    print(text)
    with open(os.path.join(a.out, "results.md"), "w") as f:
        f.write(text)
    with open(os.path.join(a.out, "runs.csv"), "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        wr.writeheader()
        wr.writerows(rows)


if __name__ == "__main__":
    main()
