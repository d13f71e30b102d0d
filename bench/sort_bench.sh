#!/bin/sh
# Sort against its I/O floor (issue "One stage chain from reader to writer"):
# `epsnet sort` of a shuffled PLY to .smz over `epsnet convert` of the same
# file to .smz, run alternately so that a busy machine slows both alike.
# Prints each repetition (wall and CPU seconds, peak RSS) and the medians of
# the per-repetition ratios; the sorted file must not depend on -j.
# Usage: bench/sort_bench.sh BUILD_DIR [FACES] [REPS] [OUTDIR] [SORT OPTIONS...]
set -eu
build=${1:-build-release}
faces=${2:-2M}
reps=${3:-5}
out=${4:-bench/out}
[ $# -ge 4 ] && shift 4 || shift $#
bin=$build/tools/epsnet
mkdir -p "$out"
in=$out/bumpy_${faces}_shuffled.ply
[ -f "$in" ] || $bin gen bumpy --faces "$faces" --seed 7 --shuffle -o "$in" -q
# wall, CPU (user + system) and peak RSS of one command
measure() { /usr/bin/time -f "%e %U %S %M" "$@" 2>&1 >/dev/null | tail -1 | awk '{printf "%s %.2f %s", $1, $2 + $3, $4}'; }
echo "# sort vs convert, $faces-face shuffled bumpy, $reps alternating repetitions; sort options: $*"
printf "%4s %9s %8s %9s %10s %8s %10s %10s\n" rep sort_wall sort_cpu sort_RSS conv_wall conv_cpu wall_ratio cpu_ratio
rows=""
i=1
while [ "$i" -le "$reps" ]; do
    s=$(measure "$bin" sort "$in" -o "$out/sorted.smz" -q "$@")
    c=$(measure "$bin" convert "$in" -o "$out/converted.smz" -q)
    row=$(echo "$s $c" | awk -v i="$i" '{printf "%4d %9s %8s %8.0fM %10s %8s %10.2f %10.2f", i, $1, $2, $3 / 1024, $4, $5, $1 / $4, $2 / $5}')
    echo "$row"
    rows="$rows$row
"
    i=$((i + 1))
done
printf "%s" "$rows" | awk '{w[NR] = $7; c[NR] = $8} END {
    n = NR
    for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) {
        if (w[j] < w[i]) { t = w[i]; w[i] = w[j]; w[j] = t }
        if (c[j] < c[i]) { t = c[i]; c[i] = c[j]; c[j] = t }
    }
    m = int((n + 1) / 2)
    printf "median ratio sort/convert: wall %.2f, CPU %.2f\n", w[m], c[m]
}'
"$bin" sort "$in" -o "$out/sorted_j1.smz" -q -j 1 "$@"
cmp -s "$out/sorted.smz" "$out/sorted_j1.smz" && echo "same bytes with -j 1" || { echo "BYTES DIFFER with -j 1"; exit 1; }
