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
# The VCM family with SmallVCM's merge radius (0.003 x the scene's bounding radius, ~0.0066)
# and alpha, so the comparison with SmallVCM's figures is like for like.
for m in pt bdpt ppm bpm vcm; do
  "$render" --scene cornell1 --method "$m" --spp 8 --threads 2 --radius 0.0066 --alpha 0.75 | tee -a "$out/iterations.txt"
done
for m in mvf phf bdpf; do
  "$render" --scene cornell1 --method "$m" --spp 8 --threads 2 | tee -a "$out/iterations.txt"
done
# Issue 6: propagation scaling, occupancy and factorisation, naive recursion.
"$build/bench/bench_propagation_propagation_bench" | tee "$out/propagation.txt"
# Issue 6: equal-time relMSE on Cornell box 1 against a long PT reference.
ref=$out/cornell1_reference.pfm
[ -f "$ref" ] || "$render" --scene cornell1 --method pt --time 480 --threads 2 --seed 777 --out "$ref"
for m in bdpf vcm bpm mvf phf pt; do
  "$render" --scene cornell1 --method "$m" --time 10 --threads 2 --reference "$ref" | tee -a "$out/equal_time.txt"
done
