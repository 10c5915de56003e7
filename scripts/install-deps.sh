#!/usr/bin/env bash
# Installs the Debian 12 packages that segpath's library, tests, benchmarks and examples need.
# Safe to re-run: when every package is already installed it does nothing (no apt-get update).
set -euo pipefail

packages=(
  cmake g++ make            # toolchain
  libglm-dev                # the library's only dependency
  catch2                    # tests
  libbenchmark-dev          # benchmarks
  libembree-dev libtbb-dev libtinyobjloader-dev libstb-dev libtinyexr-dev libcli11-dev  # examples
  python3-matplotlib        # plots of benchmark results
  clang-14 libclang-rt-14-dev  # the libFuzzer harnesses (fuzz/)
  libopenmpi-dev openmpi-bin  # segpath-render on MPI ranks (mpirun), and its tests
  doxygen                   # the API reference (target segpath_api_docs)
)

missing=()
for package in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$package" 2>/dev/null || true)
  if [[ "$status" != "install ok installed" ]]; then
    missing+=("$package")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages are already installed"
  exit 0
fi

if [[ $(id -u) -eq 0 ]]; then
  as_root=()
elif command -v sudo >/dev/null 2>&1; then
  as_root=(sudo)
else
  echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2
  exit 1
fi

echo "install-deps: installing ${missing[*]}"
apt_get=(env DEBIAN_FRONTEND=noninteractive apt-get -y -q -o Dpkg::Use-Pty=0)
"${as_root[@]}" "${apt_get[@]}" update
"${as_root[@]}" "${apt_get[@]}" install --no-install-recommends "${missing[@]}"
