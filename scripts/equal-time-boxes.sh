#!/usr/bin/env bash
# Issue 13's equal-time study on SmallVCM's four boxes (docs/figures.md): our BDPF, MVF and PhF
# (and PT, BDPT, VCM at 10 s) against SmallVCM's vcm, bpt and pt, 512 x 512, 2 threads, 10 s and
# 30 s, relMSE against references made here. Run it on an otherwise idle machine: about 40 min
# for the references (made once, kept in OUT) and 22 min for the runs.
#   scripts/equal-time-boxes.sh [build-dir] [smallvcm binary] [out-dir]
# SmallVCM: ../shared/peers/build-smallvcm.sh builds it (default /tmp/smallvcm-peer/smallvcm).
# Its -t is CPU seconds summed over threads, so -t 2T for T seconds of wall time on 2 threads;
# it uses every processor, so taskset keeps it on two. Needs bc and taskset (util-linux).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
smallvcm=$(realpath "${2:-/tmp/smallvcm-peer/smallvcm}")
out=${3:-$root/out/equal-time}
render=$build/examples/segpath-render
reference=$root/scripts/reference.py
[[ -x $render && -x $smallvcm ]] || { echo "$0: needs $render and $smallvcm" >&2; exit 2; }
mkdir -p "$out"
cd "$out"
# References: two independent halves of 300 s, averaged; BDPT where it samples every family
# (boxes 1, 3), VCM at SmallVCM's radius where nothing unbiased does (the sun's and the point
# light's caustics seen through glass: boxes 0, 2). Each one's own relMSE from its halves.
for box in 1 3 0 2; do
  [[ -f ref$box.pfm ]] && continue
  case $box in 1 | 3) method=(--method bdpt) ;; *) method=(--method vcm --radius 0.0066 --alpha 0.75) ;; esac
  for seed in 11 12; do
    "$render" --scene cornell$box "${method[@]}" --time 300 --threads 2 --seed $seed --out ref${box}_$seed.pfm | tee -a references.txt
  done
  "$reference" average ref$box.pfm ref${box}_11.pfm ref${box}_12.pfm
  echo "box $box: $("$reference" halves ref${box}_11.pfm ref${box}_12.pfm)" | tee -a references.txt
done
: > equal_time.txt
for t in 10 30; do
  for box in 0 1 2 3; do
    ours=(bdpf mvf phf)
    [[ $t == 10 ]] && ours+=(pt bdpt vcm)
    for m in "${ours[@]}"; do
      echo "t $t box $box ours $m: $("$render" --scene cornell$box --method $m --time $t --threads 2 --seed 3 --reference ref$box.pfm)" | tee -a equal_time.txt
    done
    for a in vcm bpt pt; do
      start=$(date +%s.%N)
      taskset -c 0,1 "$smallvcm" -s $box -a $a -t $((2 * t)) -o smallvcm_${box}_${a}_$t.pfm > /dev/null
      end=$(date +%s.%N)
      echo "t $t box $box smallvcm $a: wall $(echo "$end - $start" | bc) s, $("$reference" relmse smallvcm_${box}_${a}_$t.pfm ref$box.pfm)" | tee -a equal_time.txt
    done
  done
done
