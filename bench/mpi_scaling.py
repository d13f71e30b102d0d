#!/usr/bin/env python3
"""epsnet-mpi against one process (issue 26's scaling): wall time and each rank's peak.

    python3 bench/mpi_scaling.py --epsnet build-ci/tools/epsnet --mpi build-ci/tools/epsnet-mpi \
        [--faces 20M] [--ranks 2] [--threads 1] [--runs 3] [--ratio R]

Generates `gen bumpy --faces N` as a sorted .smz (kept beside the working
folder as bumpy_N.smz), then alternates, --runs times: one process
(`epsnet simplify -j T`) and `mpirun -n R epsnet-mpi simplify -j T`, each
rank under /usr/bin/time for its peak RSS. Checks that both outputs are the
same bytes. Prints the medians, the speedup, and each rank's peak against
the one process's. Run it on an otherwise idle machine.
"""
import argparse
import os
import re
import statistics
import subprocess
import sys
import time


def timed(cmd):
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode:
        sys.exit(f"mpi_scaling: {' '.join(cmd)} failed: {p.stderr}")
    return time.perf_counter() - t0, p.stderr


def peaks(stderr):
    """Each rank's peak (KB) from the 'rank R peak K' the wrapper prints (the
    ranks write at once: two may share a line)."""
    out = {int(r): int(k) for r, k in re.findall(r"rank (\d+) peak (\d+)", stderr)}
    return [out[r] for r in sorted(out)]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--epsnet", required=True)
    ap.add_argument("--mpi", required=True)
    ap.add_argument("--faces", default="20M")
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--threads", default="1")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--ratio", default=None)
    a = ap.parse_args()
    mesh = f"bumpy_{a.faces}.smz"
    if not os.path.exists(mesh):
        subprocess.run([a.epsnet, "gen", "bumpy", "--faces", a.faces, "-o", mesh, "-q"], check=True)
    opts = ["-j", a.threads, "-q"] + (["--ratio", a.ratio] if a.ratio else [])
    root = ["--allow-run-as-root"] if os.geteuid() == 0 else []
    wrap = 'exec /usr/bin/time -f "rank $OMPI_COMM_WORLD_RANK peak %M" "$@"'
    one_cmd = ["/usr/bin/time", "-f", "rank 0 peak %M", a.epsnet, "simplify", mesh, "-o", "one.smz", *opts]
    mpi_cmd = ["mpirun", *root, "--oversubscribe", "-n", str(a.ranks), "sh", "-c", wrap, "sh", a.mpi,
               "simplify", mesh, "-o", "shared.smz", *opts]
    one_t, mpi_t, one_p, mpi_p = [], [], [], []
    for i in range(a.runs):
        for which in ((0, 1) if i % 2 == 0 else (1, 0)):
            t, err = timed(one_cmd if which == 0 else mpi_cmd)
            (one_t if which == 0 else mpi_t).append(t)
            (one_p if which == 0 else mpi_p).append(peaks(err))
    with open("one.smz", "rb") as f, open("shared.smz", "rb") as g:
        same = f.read() == g.read()
    one, shared = statistics.median(one_t), statistics.median(mpi_t)
    print(f"| {mesh} {'ratio ' + a.ratio if a.ratio else 'default'}, -j {a.threads} | wall (median of {a.runs}) | "
          f"peak RSS per rank (MiB) |")
    print("|---|---|---|")
    print(f"| one process | {one:.2f} s ({min(one_t):.2f}-{max(one_t):.2f}) | "
          f"{max(p[0] for p in one_p) / 1024:.1f} |")
    ranks = max(len(p) for p in mpi_p)
    print(f"| mpirun -n {a.ranks} | {shared:.2f} s ({min(mpi_t):.2f}-{max(mpi_t):.2f}) | "
          + ", ".join(f"{max(p[r] for p in mpi_p if len(p) > r) / 1024:.1f}" for r in range(ranks)) + " |")
    print(f"| speedup | **{one / shared:.2f}x** (pairs: "
          + ", ".join(f"{o / m:.2f}" for o, m in zip(one_t, mpi_t)) + f") | same bytes: {same} |")


if __name__ == "__main__":
    main()
