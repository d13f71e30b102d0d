#!/usr/bin/env python3
"""The Python binding's cost on `gen bumpy` (issue 27): time beyond the C call, memory beyond the arrays.

    build-venv/bin/python bench/python_overhead.py [--faces 2M] [--ratio R] [--runs 3] [--epsnet build-release/tools/epsnet]

For each run, in a fresh interpreter (the venv's, with the package
installed): load the mesh's arrays (.npy files another interpreter wrote
with epsnet.read_mesh), then time epsnet.simplify() on them. Reported:

  - binding time: the call's wall time minus the library's own
    (stats["seconds_simplify"], measured inside epsnet_simplify_arrays);
    the issue asks for at most 5% of the call;
  - peak RSS during the call against the same call made from C on the
    same arrays (bench/bench_arrays, built beside the CLI: it loads the
    .npy files and calls epsnet_simplify_arrays, which hands the kept mesh
    back in arrays as the binding does): the issue asks that the Python
    process's peak be at most the input arrays plus the C run's own peak.
    Here that sum is the Python process's resident set after loading (the
    interpreter, numpy and the arrays) plus the C call's own growth (its
    peak minus its resident set after loading). The process peak is taken
    over the call alone (VmHWM reset through /proc/self/clear_refs after
    loading, Linux 4.0+) and, as well, over the whole process. The CLI's
    peak on the same mesh is printed too, for reference only: it streams
    its output to a file, so it is not the same work (bench/RESULTS.md,
    session 24).

Medians of --runs runs. Run it on an otherwise idle machine; smoke-test
with --faces 20000 --runs 1.
"""
import argparse
import json
import os
import pathlib
import resource
import statistics
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]

WORKER = r"""
import json, resource, sys, time
import numpy as np
import epsnet
def rss():  # current resident set, bytes
    with open('/proc/self/statm') as f:
        return int(f.read().split()[1]) * 4096
path, options = sys.argv[1], json.loads(sys.argv[2])
base = rss()
# the arrays as numpy saved them (written by another process): nothing of
# a reader's own heap stays behind in this one (epsnet.read_mesh left 1 MB,
# bench/RESULTS.md session 22)
v, f = np.load(path + ".v.npy"), np.load(path + ".f.npy")
loaded = rss()
def hwm():  # peak resident set since the last reset, bytes
    with open('/proc/self/status') as status:
        return next(int(l.split()[1]) * 1024 for l in status if l.startswith('VmHWM:'))
try:
    with open('/proc/self/clear_refs', 'w') as refs:
        refs.write('5')  # reset the peak: the call's own, without the loading's
    reset = True
except OSError:
    reset = False
t0 = time.perf_counter()
sv, sf, info = epsnet.simplify(v, f, return_info=True, **options)
wall = time.perf_counter() - t0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
call_peak = hwm() if reset else peak
print(json.dumps({"wall": wall, "c_seconds": info.stats["seconds_simplify"], "faces": int(len(sf)),
                  "input_bytes": int(v.nbytes + f.nbytes), "base": base, "loaded": loaded, "peak": peak,
                  "call_peak": call_peak}))
"""


def size(text):
    units = {"K": 1e3, "M": 1e6, "G": 1e9}
    return int(float(text[:-1]) * units[text[-1].upper()]) if text[-1].upper() in units else int(text)


def cli_peak(epsnet, src, dst, options):
    """Peak RSS of one CLI run (a child of its own, so that its peak is its own)."""
    code = ("import resource, subprocess, sys; subprocess.run(sys.argv[1:], check=True, capture_output=True); "
            "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024)")
    args = [epsnet, "simplify", str(src), "-o", str(dst), "-q"] + options
    return int(subprocess.run([sys.executable, "-c", code] + args, check=True, capture_output=True, text=True).stdout)


def c_call(bench_arrays, src, ratio):
    """The same call from C on the same arrays: its resident sets and peak (bench/bench_arrays.c)."""
    args = [bench_arrays, str(src) + ".v.npy", str(src) + ".f.npy"] + ([str(ratio)] if ratio else [])
    return json.loads(subprocess.run(args, check=True, capture_output=True, text=True).stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--faces", default="2M")
    ap.add_argument("--ratio", type=float, default=None, help="a target (default: the ε-net method)")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--epsnet", default=str(ROOT / "build-release" / "tools" / "epsnet"))
    ap.add_argument("--python", default=sys.executable, help="the interpreter with epsnet installed (default: this one)")
    a = ap.parse_args()
    bench_arrays = str(pathlib.Path(a.epsnet).resolve().parents[1] / "bench" / "bench_arrays")
    for tool in (a.epsnet, a.python, bench_arrays):
        if not os.access(tool, os.X_OK):
            sys.exit(f"python_overhead: {tool} is missing (build it, or sh tools/quickstart.sh test for the venv)")
    options = {"ratio": a.ratio} if a.ratio else {}
    cli_options = ["--ratio", str(a.ratio)] if a.ratio else []
    with tempfile.TemporaryDirectory() as tmp:
        src = pathlib.Path(tmp) / "bumpy.ply"
        subprocess.run([a.epsnet, "gen", "bumpy", "--faces", str(size(a.faces)), "--seed", "7", "--shuffle",
                        "-o", str(src)], check=True, capture_output=True)
        save = ("import sys, numpy as np, epsnet; v, f, _ = epsnet.read_mesh(sys.argv[1]); "
                "np.save(sys.argv[1] + '.v.npy', np.ascontiguousarray(v)); "
                "np.save(sys.argv[1] + '.f.npy', np.ascontiguousarray(f))")
        subprocess.run([a.python, "-c", save, str(src)], check=True, capture_output=True)
        runs, cli, c = [], [], []
        for _ in range(a.runs):
            out = subprocess.run([a.python, "-c", WORKER, str(src), json.dumps(options)], check=True,
                                 capture_output=True, text=True, cwd=tmp).stdout
            runs.append(json.loads(out))
            c.append(c_call(bench_arrays, src, a.ratio))
            cli.append(cli_peak(a.epsnet, src, pathlib.Path(tmp) / "out.ply", cli_options))
    med = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
    cli_peak_bytes = statistics.median(cli)
    c_growth = statistics.median(r["call_peak"] - r["loaded"] for r in c)
    c_whole = statistics.median(r["call_peak"] for r in c)
    if any(r["faces"] != runs[0]["faces"] for r in c):
        sys.exit("python_overhead: the C call kept another face count than the binding")
    overhead = med["wall"] - med["c_seconds"]
    allowed = med["loaded"] + c_growth
    mb = 1 / 2**20
    print(f"| gen bumpy {a.faces}{' ratio ' + str(a.ratio) if a.ratio else ''} | value |")
    print("|---|---|")
    print(f"| simplify() wall | {med['wall']:.3f} s |")
    print(f"| library's own (seconds_simplify) | {med['c_seconds']:.3f} s |")
    print(f"| binding beyond the C call | {overhead:.3f} s ({100 * overhead / med['wall']:.1f}%, at most 5% asked) |")
    print(f"| input arrays | {med['input_bytes'] * mb:.0f} MB |")
    print(f"| interpreter + numpy before loading | {med['base'] * mb:.0f} MB |")
    print(f"| after loading (interpreter, numpy, arrays) | {med['loaded'] * mb:.1f} MB |")
    print(f"| the same call from C (bench_arrays): its peak, its growth over its loaded arrays | "
          f"{c_whole * mb:.1f} MB, {c_growth * mb:.1f} MB |")
    print(f"| Python call's growth over its loaded arrays | {(med['call_peak'] - med['loaded']) * mb:.1f} MB |")
    print(f"| CLI's peak on the same mesh (streams its output: not the same work) | {cli_peak_bytes * mb:.0f} MB |")
    print(f"| Python process peak during simplify() | {med['call_peak'] * mb:.1f} MB (at most {allowed * mb:.1f} asked: "
          f"{'within' if med['call_peak'] <= allowed else 'OVER'}) |")
    print(f"| Python process peak, the loading included | {med['peak'] * mb:.0f} MB "
          f"({'within' if med['peak'] <= allowed else 'over'} {allowed * mb:.0f}) |")
    print(f"| output faces | {int(med['faces'])} |")


if __name__ == "__main__":
    main()
