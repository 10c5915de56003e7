#!/usr/bin/env bash
# Builds segpath's renderer (Release) and renders SmallVCM's Cornell box 1 with the paper's
# method, bidirectional path filtering (12 iterations, 512x512, default kernel and beta), to
# out/cornell1.exr and out/cornell1.png, printing the renderer's summary line.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSEGPATH_BUILD_EXAMPLES=ON
cmake --build build -j2 --target segpath-render
mkdir -p out
build/examples/segpath-render --scene cornell1 --method bdpf --spp 12 --out out/cornell1.exr --out out/cornell1.png
echo "demo: wrote out/cornell1.exr and out/cornell1.png"
