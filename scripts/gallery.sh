#!/bin/sh
# Regenerates the README's gallery (docs/images/gallery): the seed
# report's figures, each by the one command the README shows for it.
set -eu
cd "$(dirname "$0")/.."
cargo build --release --quiet
nes=./target/release/nes
g=docs/images/gallery
mkdir -p "$g"
$nes rays examples/sphere-space.nes --width 420 --method march -o "$g/fig12-bundle-side.png"
# Figure 11: every other pixel of the middle column marked (the dense
# drawing that comes with it is not kept).
tmp=$(mktemp -d)
$nes rays examples/sphere-space.nes --width 420 --column 210 --every 2 -o "$tmp/dense.svg" \
  --mark "$g/fig11-marked-pixels.png"
rm -rf "$tmp"
$nes rays examples/sphere-space.nes --width 140 --row 30 --view top -o "$g/fig8-rays-from-above.png"
$nes rays examples/sphere-space.nes --width 140 --every 5 --method march -o "$g/fig9-rays-from-side.png"
$nes rays examples/sphere-space.nes --width 140 --method march --view 3d -o "$g/rays-3d.png"
$nes rays examples/approach.nes --width 140 --row 50 --view top -o "$g/fig14-row-of-rays.png"
$nes render examples/approach.nes --frames 0..60 --width 280 -q -o "$g/fig13-approach.png"
$nes probe examples/seed.nes --pixel 750,500 -o "$g/fig22-probe-euclidean.png" > /dev/null
$nes probe examples/sphere-space.nes --pixel 700,500 --method ode -o "$g/fig23-probe-sphere.png" > /dev/null
$nes probe examples/seed.nes --pixel 975,265 --method march --step 0.5 --distance 12 \
  -o "$g/fig19-missed-by-march.png" > /dev/null
# The surfaces from the literature (examples/gallery), as thumbnails.
s=docs/images/surfaces
mkdir -p "$s"
for scene in examples/gallery/*.nes; do
  name=$(basename "$scene" .nes)
  $nes render "$scene" --width 320 -q -o "$s/$name.png"
done
