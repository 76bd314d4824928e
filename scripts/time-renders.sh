#!/usr/bin/env bash
# Wall time of the whole `nes render` process (parse, compile, trace, PNG
# write) at the examples' full size, median of N runs. Used for the figures
# in docs/performance.md. Arguments: "SCENE METHOD" pairs (default: the
# list below), e.g. scripts/time-renders.sh "sphere-r25.nes ode".
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${RUNS:-7}
cargo build --release --quiet
out=$(mktemp -d)
median() { sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
specs=("$@")
if [ ${#specs[@]} -eq 0 ]; then
  specs=("seed.nes auto" "seed.nes march" "heart-and-cube.nes auto"
         "heart-and-cube.nes adaptive" "heart-and-cube.nes march" "csg.nes auto"
         "torus.nes auto" "torus.nes march" "sphere-r25.nes auto" "sphere-r25.nes ode")
fi
for spec in "${specs[@]}"; do
  set -- $spec
  t=$(for _ in $(seq "$runs"); do
        s=$(date +%s%N)
        ./target/release/nes render "examples/$1" --method "$2" -q -o "$out/x.png"
        e=$(date +%s%N)
        echo $(( (e - s) / 1000000 ))
      done | median)
  printf '%-22s %-9s %6d ms\n' "$1" "$2" "$t"
done
rm -rf "$out"
