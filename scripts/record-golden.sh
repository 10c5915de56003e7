#!/usr/bin/env bash
# Records the golden images of segpath-render: tests/renderer/golden/<box>.<name>.pfm for every
# box and config of tests/renderer/golden/configs.txt (the one place the arguments are listed),
# rendered with BINARY. CTest renderer.golden.<box>.<name> renders the same with a build's
# segpath-render and compares with pfm_compare, so re-record only to change the images on
# purpose, and say so in the commit.
# Usage: scripts/record-golden.sh BINARY [OUT_DIR]   (OUT_DIR defaults to tests/renderer/golden)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
configs=$root/tests/renderer/golden/configs.txt
if [[ $# -lt 1 || $# -gt 2 || ! -x $1 ]]; then
  echo "usage: $0 BINARY [OUT_DIR]  (BINARY: an executable segpath-render)" >&2
  exit 2
fi
binary=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
out=${2:-$root/tests/renderer/golden}
mkdir -p "$out"

# Parse configs.txt as tests/renderer/CMakeLists.txt does: blank-separated words, '#' comments.
boxes=() common=() names=() args=()
while read -r -a words; do
  [[ ${#words[@]} -eq 0 || ${words[0]} == \#* ]] && continue
  case ${words[0]} in
    boxes) boxes=("${words[@]:1}") ;;
    common) common=("${words[@]:1}") ;;
    *) names+=("${words[0]}") args+=("${words[*]:1}") ;;
  esac
done <"$configs"
if [[ ${#boxes[@]} -eq 0 || ${#names[@]} -eq 0 ]]; then
  echo "$0: $configs lists no boxes or no configs" >&2
  exit 1
fi

# Render everything into a scratch directory first: a failed render leaves the set as it was.
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for box in "${boxes[@]}"; do
  for i in "${!names[@]}"; do
    read -r -a extra <<<"${args[$i]}"
    file=$box.${names[$i]}.pfm
    echo "==> $file: --scene $box ${common[*]} ${extra[*]}"
    "$binary" --scene "$box" "${common[@]}" "${extra[@]}" --out "$tmp/$file"
  done
done
mv "$tmp"/*.pfm "$out"/
echo "==> recorded $(( ${#boxes[@]} * ${#names[@]} )) images in $out with $binary"
# Images of configs no longer listed are left alone; name them so they can be removed.
for f in "$out"/*.pfm; do
  name=$(basename "$f" .pfm)
  box=${name%%.*} config=${name#*.}
  if [[ ! " ${boxes[*]} " == *" $box "* || ! " ${names[*]} " == *" $config "* ]]; then
    echo "==> note: $f is not in configs.txt (stale?)"
  fi
done
