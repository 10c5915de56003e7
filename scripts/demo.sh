#!/usr/bin/env bash
# Builds segpath's renderer (Release) and renders SmallVCM's Cornell box 1 with path tracing
# (64 samples per pixel, 512x512) to out/cornell1.exr and out/cornell1.png, printing the
# renderer's summary line.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSEGPATH_BUILD_EXAMPLES=ON
cmake --build build -j2 --target segpath-render
mkdir -p out
build/examples/segpath-render --scene cornell1 --method pt --spp 64 --out out/cornell1.exr --out out/cornell1.png
echo "demo: wrote out/cornell1.exr and out/cornell1.png"
