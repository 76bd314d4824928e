#!/usr/bin/env bash
# The Chmutov octic in nes and in POV-Ray (`polynomial { 8 ... sturm }`,
# scripts/povray/chmutov-octic.pov: the same surface, camera and lights),
# whole process, runs interleaved so both see the same hour of the
# machine. Needs POV-Ray 3.7 (Debian: apt-get install povray).
#   scripts/povray-compare.sh [RUNS]
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
command -v povray >/dev/null || { echo "povray is not installed (apt-get install povray)" >&2; exit 1; }
cargo build --release --quiet
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
seconds() { /usr/bin/time -f %e "$@" 2>&1 >/dev/null | tail -1; }
for i in $(seq "$runs"); do
  n=$(seconds target/release/nes render examples/gallery/chmutov-octic.nes -o "$out/nes.png")
  p=$(seconds povray -D -A +W800 +H500 +WT2 +Iscripts/povray/chmutov-octic.pov +O"$out/pov.png")
  echo "run $i: nes $n s, POV-Ray $p s"
done
