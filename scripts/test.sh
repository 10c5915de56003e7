#!/usr/bin/env bash
# Runs every segpath test: a Release build with warnings as errors running all CTest labels
# (fast, stat, packaging), then an ASan+UBSan build running the fast tests, then clang's
# libFuzzer harnesses of the renderer's input (fuzz/), each for SEGPATH_FUZZ_SECONDS (60).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

jobs=2
timings=()
# phase NAME COMMAND...: runs COMMAND and records how long it took.
phase() {
  local name=$1 start=$SECONDS
  shift
  echo "==> $name"
  "$@"
  timings+=("$(printf '%-28s %5d s' "$name" $((SECONDS - start)))")
  echo "==> $name: $((SECONDS - start)) s"
}

phase "configure build/" cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSEGPATH_WERROR=ON \
  -DSEGPATH_SANITIZE=OFF -DSEGPATH_BUILD_TESTS=ON -DSEGPATH_BUILD_EXAMPLES=ON \
  -DSEGPATH_BUILD_BENCHMARKS=ON
phase "build build/" cmake --build build -j"$jobs"
phase "ctest build/ (all labels)" ctest --test-dir build --output-on-failure -j"$jobs"
phase "API reference (Doxygen)" cmake --build build --target segpath_api_docs

# Sanitizers: any error or undefined behaviour stops the test with a stack trace.
export ASAN_OPTIONS=halt_on_error=1:print_stacktrace=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
phase "configure build-asan/" cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DSEGPATH_WERROR=OFF -DSEGPATH_SANITIZE=ON -DSEGPATH_BUILD_TESTS=ON \
  -DSEGPATH_BUILD_EXAMPLES=OFF -DSEGPATH_BUILD_BENCHMARKS=OFF
phase "build build-asan/" cmake --build build-asan -j"$jobs"
phase "ctest build-asan/ (-L fast)" ctest --test-dir build-asan --output-on-failure -j"$jobs" -L fast

# Fuzzing (clang 14, libFuzzer + ASan + UBSan): the OBJ/MTL loader and the command line.
phase "configure build-fuzz/" env CXX=clang++-14 cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DSEGPATH_BUILD_TESTS=OFF -DSEGPATH_BUILD_EXAMPLES=OFF -DSEGPATH_BUILD_BENCHMARKS=OFF \
  -DSEGPATH_BUILD_FUZZERS=ON -DSEGPATH_FUZZ_SECONDS="${SEGPATH_FUZZ_SECONDS:-60}"
phase "build build-fuzz/" cmake --build build-fuzz -j"$jobs"
phase "ctest build-fuzz/ (-L fuzz)" ctest --test-dir build-fuzz --output-on-failure -j"$jobs" -L fuzz

echo "==> all tests passed; timings:"
printf '    %s\n' "${timings[@]}"
