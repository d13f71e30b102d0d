#!/usr/bin/env python3
"""epsnet-mpi against one process (issue 26's scaling): wall time and each rank's peak.

    python3 bench/mpi_scaling.py --epsnet build-ci/tools/epsnet --mpi build-ci/tools/epsnet-mpi \
        [--faces 20M] [--ranks 2] [--threads 1] [--runs 3] [--ratio R]

Generates `gen bumpy --faces N` as a sorted .smz (kept beside the working
folder as bumpy_N.smz), then runs in turn, --runs times: one process
(`epsnet simplify -j T`), `mpirun -n 1 epsnet-mpi simplify -j T` (the
issue's baseline) and `mpirun -n R epsnet-mpi simplify -j T`, each rank
under /usr/bin/time for its peak RSS. Checks that the outputs are the same
bytes. Prints the medians, the speedup against each one-process run, and
each rank's peak. Run it on an otherwise idle machine.
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

    def mpi_cmd(ranks, out):
        return ["mpirun", *root, "--oversubscribe", "-n", str(ranks), "sh", "-c", wrap, "sh", a.mpi,
                "simplify", mesh, "-o", out, *opts]

    # the plain command, `mpirun -n 1` (the baseline: MPI's start
    # and end paid by both), and `mpirun -n R`, in a rotating order
    runs = [("one process", one_cmd, "one.smz"), ("mpirun -n 1", mpi_cmd(1, "alone.smz"), "alone.smz"),
            (f"mpirun -n {a.ranks}", mpi_cmd(a.ranks, "shared.smz"), "shared.smz")]
    times = [[] for _ in runs]
    peak = [[] for _ in runs]
    for i in range(a.runs):
        for k in range(len(runs)):
            which = (i + k) % len(runs)
            t, err = timed(runs[which][1])
            times[which].append(t)
            peak[which].append(peaks(err))
    outs = []
    for _, _, out in runs:
        with open(out, "rb") as f:
            outs.append(f.read())
    same = all(o == outs[0] for o in outs)
    print(f"| {mesh} {'ratio ' + a.ratio if a.ratio else 'default'}, -j {a.threads} | wall (median of {a.runs}) | "
          f"peak RSS per rank (MiB) |")
    print("|---|---|---|")
    for (name, _, _), t, p in zip(runs, times, peak):
        nranks = max(len(x) for x in p)
        print(f"| {name} | {statistics.median(t):.2f} s ({min(t):.2f}-{max(t):.2f}) | "
              + ", ".join(f"{max(x[r] for x in p if len(x) > r) / 1024:.1f}" for r in range(nranks)) + " |")
    shared = times[2]
    for k in (0, 1):
        print(f"| speedup against {runs[k][0]} | **{statistics.median(times[k]) / statistics.median(shared):.2f}x** "
              "(runs in turn: " + ", ".join(f"{o / m:.2f}" for o, m in zip(times[k], shared)) + ") | |")
    print(f"| same bytes, all three | {same} | |")


if __name__ == "__main__":
    main()
