#!/bin/sh
# The README gallery, docs/gallery/*.png, made by `epsnet render` alone:
#   sh tools/gallery.sh [BUILD_DIR]     (default build-release, set up if missing)
# For the Stanford bunny, the Armadillo and Fandisk (from ../shared/data, or
# $EPSNET_SHARED_DATA): the samples on the input, and the input beside its
# simplification (default rotation, one ε-net pass); then a 10M-face
# generated scan rendered as a stream. The output is the same bytes every run.
set -eu
cd "$(dirname "$0")/.."

build=${1:-build-release}
data=${EPSNET_SHARED_DATA:-../shared/data}
out=docs/gallery
[ -d "$build" ] || meson setup "$build" --buildtype=release >/dev/null
ninja -C "$build" >/dev/null
bin=$build/tools/epsnet
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT INT TERM

# name : file in $data : view (azimuth,elevation) chosen to face the model :
# Gaussian sphere level : sample dot radius. The Armadillo is finely
# detailed everywhere, so it gets level 1 (18 Gaussian vertices, 18 dot
# colours) and small dots to stay readable; the others level 2 (66).
# note: Fandisk seen from 120,30 shows its flat back face edge-on, which
# reads as the part cut off; 210,25 shows the fin, the groove and the
# cylinder whole.
for spec in bunny:bun_zipper.ply.zst:20,10:2:3 armadillo:armadillo_decim100k.obj.zst:200,10:1:2 \
            fandisk:fandisk.obj.zst:210,25:2:3; do
    IFS=: read -r name file view level dot <<ROWS
$spec
ROWS
    "$bin" render "$data/$file" -o "$out/${name}_samples.png" --samples --level "$level" --dot-radius "$dot" \
        --size 400x300 --view "$view" -q
    "$bin" render "$data/$file" -o "$out/${name}_simplified.png" --simplified --wire --level "$level" \
        --size 640x300 --view "$view" -q
    echo "gallery: $out/${name}_samples.png $out/${name}_simplified.png"
done

# A scan-like mesh larger than the others together, drawn as it streams in:
# memory holds the image and the stream's live vertices, not the mesh.
"$bin" gen bumpy --faces 10M --seed 3 --param 0.1 -o "$tmp/bumpy10m.smz" -q
"$bin" render "$tmp/bumpy10m.smz" -o "$out/bumpy10m.png" --size 400x300 --view 30,20 -q
echo "gallery: $out/bumpy10m.png"
