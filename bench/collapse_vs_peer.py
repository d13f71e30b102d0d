#!/usr/bin/env python3
"""The collapse core against meshoptimizer's simplify call, by mesh size
(issue 24's per-collapse measure): the same mesh, the same collapses, only
the calls timed, in alternating rounds (the machine may be shared).

    python3 bench/collapse_vs_peer.py --build build-rel [--faces 8000,30000,131768,500000]
        [--level 3] [--rounds 3] [--calls 9] [--out DIR]

For each size, `epsnet gen bumpy --faces N` writes a binary PLY. Then, in
each round, one after the other:

  epsnet  bench/bench_collapse MESH LEVEL CALLS: every non-sample collapsed
          at the level (the default path's collapses), the best of CALLS
          calls, in ns per collapse
  peer    bench/peer_meshopt MESH OUT F: meshoptimizer's meshopt_simplify,
          to the F faces the epsnet call left (so the same number of
          collapses), its call alone (peer_meshopt's third column)

Prints a markdown table with the minimum and the median of the rounds,
and their ratio. `bench/peer_meshopt` is built only with Debian's
libmeshoptimizer-dev. Python 3 standard library only.
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile


def run(argv):
    p = subprocess.run(argv, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(argv), p.stderr))
    return p.stdout


def ours(build, mesh, level, calls):
    """(collapses, ns per collapse) from bench_collapse's last line."""
    last = run([os.path.join(build, "bench", "bench_collapse"), mesh, str(level), str(calls)]).strip().splitlines()[-1]
    f = last.split()
    return int(f[0]), float(f[4])


def peer(build, mesh, out, faces, collapses):
    f = run([os.path.join(build, "bench", "peer_meshopt"), mesh, out, str(faces)]).split()
    return float(f[2]) / collapses * 1e9


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default="build-rel")
    ap.add_argument("--faces", default="8000,30000,131768,500000")
    ap.add_argument("--level", type=int, default=3)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--calls", type=int, default=9)
    ap.add_argument("--out", default=None, help="meshes go here (default: a temporary folder)")
    a = ap.parse_args()
    for tool in ("bench_collapse", "peer_meshopt"):
        if not os.path.exists(os.path.join(a.build, "bench", tool)):
            sys.exit("%s/bench/%s is missing (peer_meshopt needs libmeshoptimizer-dev)" % (a.build, tool))
    work = a.out or tempfile.mkdtemp(prefix="collapse_vs_peer-")
    os.makedirs(work, exist_ok=True)
    print("| faces | collapses | epsnet ns/collapse (min, median) | meshoptimizer (min, median) | ratio of minima |")
    print("|---|---|---|---|---|")
    for n in [int(x) for x in a.faces.split(",")]:
        mesh = os.path.join(work, "bumpy_%d.ply" % n)
        if not os.path.exists(mesh):
            run([os.path.join(a.build, "tools", "epsnet"), "gen", "bumpy", "--faces", str(n), "-o", mesh])
        collapses, _ = ours(a.build, mesh, a.level, 1)
        faces = n - 2 * collapses  # a collapse inside a closed surface takes two faces
        e, m = [], []
        for _ in range(a.rounds):
            e.append(ours(a.build, mesh, a.level, a.calls)[1])
            m.append(peer(a.build, mesh, os.path.join(work, "peer.ply"), faces, collapses))
        print("| %d | %d | %.0f, %.0f | %.0f, %.0f | %.2f |" % (n, collapses, min(e), statistics.median(e), min(m),
                                                             statistics.median(m), min(e) / min(m)))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
