#!/usr/bin/env python3
"""The stage chain's whole-process measures against meshoptimizer, in one run
with alternating repetitions (the machine may be shared: ratios are taken
pair by pair and the median is reported).

    bench/chain_vs_peer.py --build build-release --sizes 2M,20M --reps 3 --out bench/out/chain

For each size, `epsnet gen bumpy` makes a sorted .smz, then two binary PLYs:
the coherent order scanners write (`epsnet convert` of the stream) and a
shuffled one (`gen --shuffle`). Measured, each a whole process under
/usr/bin/time (wall, user+sys CPU, peak RSS):

  simplify_ply   epsnet simplify IN.ply -o OUT.ply -j T     (coherent and shuffled)
  meshopt_ply    bench/peer_meshopt IN.ply OUT.ply F        (F = epsnet's output faces)
  sort           epsnet sort IN.ply -o OUT.smz -j T         (shuffled)
  convert        epsnet convert IN.ply -o OUT.smz           (the sort's yardstick)
  simplify_smz   epsnet simplify IN.smz -o OUT.smz -j T --stats (cpu.main, cpu.workers)
  read_floor     epsnet info IN.smz                          (reads and checks every record)

Prints a markdown table; writes runs.csv and results.md under --out.
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
    """Run cmd under GNU time: (wall s, cpu s, peak RSS MB, stdout)."""
    fmt = "%e %U %S %M"
    p = subprocess.run(["/usr/bin/time", "-f", fmt] + cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), p.stderr[-2000:]))
    last = p.stderr.strip().splitlines()[-1].split()
    wall, user, sys_, rss_kb = float(last[0]), float(last[1]), float(last[2]), int(last[3])
    return wall, user + sys_, rss_kb / 1024.0, p.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build-release")
    ap.add_argument("--sizes", default="2M")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default="bench/out/chain")
    a = ap.parse_args()
    epsnet = os.path.join(a.build, "tools", "epsnet")
    peer = os.path.join(a.build, "bench", "peer_meshopt")
    if not os.path.exists(peer):
        sys.exit("no %s: install Debian's libmeshoptimizer-dev and reconfigure" % peer)
    os.makedirs(a.out, exist_ok=True)
    j = str(a.threads)
    rows = []
    for size_text in a.sizes.split(","):
        n = size_arg(size_text)
        base = os.path.join(a.out, "bumpy_%s" % size_text)
        smz, coh, shuf = base + ".smz", base + "_coherent.ply", base + "_shuffled.ply"
        if not os.path.exists(smz):
            subprocess.run([epsnet, "gen", "bumpy", "--faces", str(n), "--seed", "7", "-o", smz, "-q"], check=True)
        if not os.path.exists(coh):
            subprocess.run([epsnet, "convert", smz, "-o", coh, "-q"], check=True)
        if not os.path.exists(shuf):
            subprocess.run([epsnet, "gen", "bumpy", "--faces", str(n), "--seed", "7", "--shuffle", "-o", shuf, "-q"],
                           check=True)
        out_ply, out_smz, stats = base + "_out.ply", base + "_out.smz", base + "_stats.json"
        for rep in range(a.reps):
            for order, src in (("coherent", coh), ("shuffled", shuf)):
                w, c, r, _ = timed([epsnet, "simplify", src, "-o", out_ply, "-j", j, "-q", "--stats", stats])
                st = json.load(open(stats))
                faces = st["output_faces"]
                rows.append(dict(size=size_text, rep=rep, op="simplify_ply", order=order, wall=w, cpu=c, rss=r,
                                 cpu_main=st["cpu"]["main"], cpu_workers=st["cpu"]["workers"], faces=faces))
                w, c, r, _ = timed([peer, src, out_ply, str(faces)])
                rows.append(dict(size=size_text, rep=rep, op="meshopt_ply", order=order, wall=w, cpu=c, rss=r,
                                 faces=faces))
            w, c, r, _ = timed([epsnet, "sort", shuf, "-o", out_smz, "-j", j, "-q"])
            rows.append(dict(size=size_text, rep=rep, op="sort", order="shuffled", wall=w, cpu=c, rss=r))
            w, c, r, _ = timed([epsnet, "convert", shuf, "-o", out_smz, "-q"])
            rows.append(dict(size=size_text, rep=rep, op="convert", order="shuffled", wall=w, cpu=c, rss=r))
            w, c, r, _ = timed([epsnet, "simplify", smz, "-o", out_smz, "-j", j, "-q", "--stats", stats])
            st = json.load(open(stats))
            rows.append(dict(size=size_text, rep=rep, op="simplify_smz", order="sorted", wall=w, cpu=c, rss=r,
                             cpu_main=st["cpu"]["main"], cpu_workers=st["cpu"]["workers"]))
            w, c, r, _ = timed([epsnet, "info", smz])
            rows.append(dict(size=size_text, rep=rep, op="read_floor", order="sorted", wall=w, cpu=c, rss=r))
        for f in (out_ply, out_smz, stats):
            if os.path.exists(f):
                os.remove(f)

    keys = ["size", "rep", "op", "order", "wall", "cpu", "rss", "cpu_main", "cpu_workers", "faces"]
    with open(os.path.join(a.out, "runs.csv"), "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=keys)
        wr.writeheader()
        for r in rows:
            wr.writerow({k: r.get(k, "") for k in keys})

    def pick(size, op, order):
        return [r for r in rows if r["size"] == size and r["op"] == op and r["order"] == order]

    def med(xs):
        return statistics.median(xs) if xs else float("nan")

    lines = ["Machine: %s, %d cores; `%s` (-j %s, %d alternating repetitions; medians, ratios pair by pair)."
             % (platform.processor() or platform.machine(), os.cpu_count(), " ".join(sys.argv), j, a.reps), "",
             "| size | measure | epsnet | other | ratio |", "|---|---|---|---|---|"]
    for size in a.sizes.split(","):
        for order in ("coherent", "shuffled"):
            e, m = pick(size, "simplify_ply", order), pick(size, "meshopt_ply", order)
            speed = med([mm["wall"] / ee["wall"] for ee, mm in zip(e, m)])
            cpu = med([ee["cpu"] / mm["cpu"] for ee, mm in zip(e, m)])
            lines.append("| %s | %s PLY -> PLY wall s (meshopt / epsnet = speed-up) | %.2f | %.2f | %.2f× |"
                         % (size, order, med([x["wall"] for x in e]), med([x["wall"] for x in m]), speed))
            lines.append("| %s | %s PLY -> PLY CPU s (epsnet / meshopt) | %.2f | %.2f | %.2f× |"
                         % (size, order, med([x["cpu"] for x in e]), med([x["cpu"] for x in m]), cpu))
            lines.append("| %s | %s peak RSS MB | %.0f | %.0f | |"
                         % (size, order, med([x["rss"] for x in e]), med([x["rss"] for x in m])))
        s, c = pick(size, "sort", "shuffled"), pick(size, "convert", "shuffled")
        lines.append("| %s | sort shuffled PLY wall s (sort / convert to .smz) | %.2f | %.2f | %.2f× |"
                     % (size, med([x["wall"] for x in s]), med([x["wall"] for x in c]),
                        med([ss["wall"] / cc["wall"] for ss, cc in zip(s, c)])))
        z, fl = pick(size, "simplify_smz", "sorted"), pick(size, "read_floor", "sorted")
        lines.append("| %s | .smz -> .smz wall s (read floor / simplify = share of the floor) | %.2f | %.2f | %.0f%% |"
                     % (size, med([x["wall"] for x in z]), med([x["wall"] for x in fl]),
                        100 * med([ff["wall"] / zz["wall"] for zz, ff in zip(z, fl)])))
        serial = med([x["cpu_main"] / (x["cpu_main"] + x["cpu_workers"]) for x in z])
        lines.append("| %s | .smz serial fraction cpu.main / (main + workers) | %.1f%% | | "
                     "Amdahl at 16 cores: %.1f× |" % (size, 100 * serial, 1 / (serial + (1 - serial) / 16)))
    text = "\n".join(lines) + "\n"
    open(os.path.join(a.out, "results.md"), "w").write(text)
    print(text)


if __name__ == "__main__":
    main()
