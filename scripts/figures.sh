#!/usr/bin/env bash
# Reproduces every performance figure the issues ask for, on this machine, into
# out/figures/*.txt. Needs a Release build with benchmarks and examples (build/, as
# scripts/test.sh makes). Takes about 20 minutes; run it on an otherwise idle machine.
#   scripts/figures.sh [build-dir]
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
build=${1:-build}
out=out/figures
mkdir -p "$out"
render="$build/examples/segpath-render"

# Issue 2: generic sequential estimator / hand-written loop.
"$build/bench/bench_estimators_sequential_bench" --benchmark_repetitions=3 --benchmark_report_aggregates_only=true \
  | tee "$out/sequential.txt"
# Issue 3: samples per second of every sampler, BSDF, emitter and the camera.
"$build/bench/bench_samplers_samplers_bench" | tee "$out/samplers.txt"
"$build/bench/bench_materials_bsdf_bench" | tee "$out/materials.txt"
"$build/bench/bench_lights_lights_bench" | tee "$out/lights.txt"
# Issue 4: PT iterations per second on Cornell box 1 and the fraction of bare Embree rays.
"$build/bench/renderer/bench_renderer_cornell_pt_bench" | tee "$out/cornell_pt.txt"
"$build/bench/renderer/bench_renderer_embree_rays_bench" | tee "$out/embree_rays.txt"
# Issue 5: iterations per second of every method on Cornell box 1, 512x512, 2 threads.
for m in pt bdpt; do
  "$render" --scene cornell1 --method "$m" --spp 8 --threads 2 | tee -a "$out/iterations.txt"
done
# The VCM family with SmallVCM's merge radius (0.003 x the scene's bounding radius, ~0.0066)
# and alpha, so the comparison with SmallVCM's figures is like for like.
for m in ppm bpm vcm; do
  "$render" --scene cornell1 --method "$m" --spp 8 --threads 2 --radius 0.0066 --alpha 0.75 | tee -a "$out/iterations.txt"
done
for m in mvf phf bdpf; do
  "$render" --scene cornell1 --method "$m" --spp 8 --threads 2 | tee -a "$out/iterations.txt"
done
# Issue 6: propagation scaling, occupancy and factorisation, naive recursion.
"$build/bench/bench_propagation_propagation_bench" | tee "$out/propagation.txt"
# Issue 6: equal-time relMSE on Cornell box 1 against a long BDPT reference: two independent
# halves of 768 spp, averaged (~30 min). Its own relMSE, which every figure below carries, is
# printed from the halves (scripts/reference.py; ~0.0008, against ~0.010 for 1527 spp of PT).
ref=$out/cornell1_reference.pfm
if [ ! -f "$ref" ]; then
  "$render" --scene cornell1 --method bdpt --spp 768 --threads 2 --seed 11 --out "$out/cornell1_reference_a.pfm"
  "$render" --scene cornell1 --method bdpt --spp 768 --threads 2 --seed 12 --out "$out/cornell1_reference_b.pfm"
  scripts/reference.py average "$ref" "$out/cornell1_reference_a.pfm" "$out/cornell1_reference_b.pfm"
fi
scripts/reference.py halves "$out/cornell1_reference_a.pfm" "$out/cornell1_reference_b.pfm" | tee "$out/reference.txt"
: > "$out/equal_time.txt"
for t in 10 30; do
  for args in "bdpf" "bdpf --seed 2" "vcm" "vcm --seed 2" "bdpf --no-next-event" "bdpf --weighting paper" "bpm" "mvf" \
      "mvf --no-next-event" "phf" "pt"; do
    [ "$t" = 30 ] && case "$args" in bdpf|"bdpf --seed 2"|vcm|"vcm --seed 2") ;; *) continue ;; esac
    # shellcheck disable=SC2086
    echo "$args: $("$render" --scene cornell1 --method $args --time "$t" --threads 2 --reference "$ref")" | tee -a "$out/equal_time.txt"
  done
done
