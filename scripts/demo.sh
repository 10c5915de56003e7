#!/usr/bin/env bash
# Builds segpath's example renderer (Release) and renders the custom-adapter demo scene to out/demo.png.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSEGPATH_BUILD_EXAMPLES=ON
cmake --build build -j2 --target segpath-demo
mkdir -p out
build/examples/segpath-demo --out out/demo.png
echo "demo: wrote out/demo.png"
