#!/bin/sh
# Foundation benchmarks (issue 2):
#  - read throughput of binary PLY and SMB through the reader API, against
#    `cat FILE > /dev/null` on the same (cached) file as the floor;
#  - peak RSS of `epsnet gen bumpy` at 1M and 10M faces (must be flat).
# Usage: bench/io_bench.sh BUILD_DIR [FACES] [OUTDIR]
set -eu
build=${1:-build-release}
faces=${2:-10M}
out=${3:-bench/out}
bin=$build/tools/epsnet
reader=$build/bench/bench_read
mkdir -p "$out"
time_s() { /usr/bin/time -f "%e %M" "$@" 2>&1 >/dev/null | tail -1; }

echo "# read throughput, $faces-face bumpy (best of 3; file in page cache)"
printf "%-8s %10s %8s %9s %12s %12s\n" format MB seconds MB/s faces/s cat_MB/s
for fmt in ply smb; do
    f=$out/bumpy_$faces.$fmt
    [ -f "$f" ] || $bin gen bumpy --faces "$faces" -o "$f" -q
    cat "$f" >/dev/null
    best=999
    for i in 1 2 3; do
        t=$(/usr/bin/time -f "%e" cat "$f" 2>&1 >/dev/null | tail -1)
        best=$(echo "$t $best" | awk '{print ($1 < $2) ? $1 : $2}')
    done
    set -- $($reader "$f" 3)
    mb=$(echo "$2" | awk '{printf "%.1f", $1/1e6}')
    catr=$(echo "$2 $best" | awk '{ if ($2 > 0) printf "%.0f", $1/1e6/$2; else print "inf" }')
    printf "%-8s %10s %8s %9s %12s %12s\n" "$fmt" "$mb" "$3" "$4" "$5" "$catr"
done

echo
echo "# peak RSS of epsnet gen bumpy (sorted stream to SMB)"
printf "%-10s %10s %12s\n" faces seconds peak_RSS_MB
for n in 1M 10M; do
    set -- $(time_s $bin gen bumpy --faces $n -o "$out/rss_$n.smb" -q)
    printf "%-10s %10s %12s\n" "$n" "$1" "$(echo "$2" | awk '{printf "%.1f", $1/1024}')"
    rm -f "$out/rss_$n.smb"
done
