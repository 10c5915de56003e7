#!/usr/bin/env bash
# Builds segpath's example renderer (Release) and renders the demo scene to out/sphere.png.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSEGPATH_BUILD_EXAMPLES=ON
cmake --build build -j2 --target segpath-demo
mkdir -p out
build/examples/segpath-demo --out out/sphere.png
echo "demo: wrote out/sphere.png"
