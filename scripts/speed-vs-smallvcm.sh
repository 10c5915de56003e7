#!/usr/bin/env bash
# Issue 14's speed figures: iterations per second of our PT (at its roulette schedule and at
# SmallVCM's: pt1), BDPT, PPM, BPM and VCM against
# SmallVCM's on box 1 at SmallVCM's radius (0.0066), alpha 0.75 and path length 10, 512 x 512,
# 2 threads, the two alternating, each pair twice. Prints SmallVCM's wall time over ours (above 1:
# ours is faster). Wall times include set-up. Run on an otherwise idle machine.
#   scripts/speed-vs-smallvcm.sh [build-dir] [smallvcm binary]
# SmallVCM: ../shared/peers/build-smallvcm.sh builds it (default /tmp/smallvcm-peer/smallvcm); it
# uses every processor, so taskset keeps it on two. Needs bc, taskset and GNU time.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
render=$(cd "${1:-$root/build}" && pwd)/examples/segpath-render
smallvcm=$(realpath "${2:-/tmp/smallvcm-peer/smallvcm}")
[[ -x $render && -x $smallvcm ]] || { echo "$0: needs $render and $smallvcm" >&2; exit 2; }
out=$(mktemp -d); trap 'rm -rf "$out"' EXIT
wall() { { /usr/bin/time -f "%e" "$@" > /dev/null; } 2>&1 | tail -1; }
for round in 1 2; do
  # pt1: our PT with SmallVCM's roulette schedule (from the first scattering; ours starts at 3).
  for m in vcm bpm ppm bdpt pt pt1; do
    iterations=8; [[ $m == pt* ]] && iterations=16
    peer=$m; [[ $m == bdpt ]] && peer=bpt; [[ $m == pt1 ]] && peer=pt
    method=(--method $m); [[ $m == pt1 ]] && method=(--method pt --roulette-from 1)
    # Only the VCM family has a merge radius (pt and bdpt would warn that they ignore it).
    [[ $m == vcm || $m == bpm || $m == ppm ]] && method+=(--radius 0.0066 --alpha 0.75)
    ours=$(wall "$render" --scene cornell1 "${method[@]}" --spp $iterations --threads 2 --seed 3 --out "$out/ours.pfm")
    theirs=$(wall taskset -c 0,1 "$smallvcm" -s 1 -a $peer -i $iterations -o "$out/smallvcm.pfm")
    echo "round $round $m ($iterations iterations): ours $ours s, SmallVCM $theirs s, ratio $(echo "scale=2; $theirs / $ours" | bc)"
  done
done
