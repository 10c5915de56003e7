#!/usr/bin/env bash
# segpath-render's checkpoints (examples/renderer/checkpoint.hpp), one case per CTest test:
#   checkpoint_test.sh RENDER DIR CASE
# resume_after_kill: a render killed (SIGKILL) after a checkpoint, resumed, equals an
#   uninterrupted render bit for bit; stop_on_signal: the same after SIGTERM, which stops the
#   render cleanly (checkpoint, image, exit code 143); extend: a finished render resumed with a larger --spp
#   equals one render of that --spp; the rest: a bad --resume file is refused with one line.
set -euo pipefail
render=$1 dir=$2/$3 case=$3
rm -rf "$dir" && mkdir -p "$dir" && cd "$dir"
# VCM: a kernel method, so a resume must also continue the radius schedule.
args=(--scene cornell1 --method vcm --width 32 --height 32 --threads 2 --seed 7)

fail() { echo "FAIL ($case): $*" >&2; exit 1; }
# expect_error MESSAGE ARGS...: exit code 1, one line on stderr matching MESSAGE.
expect_error() {
  local message=$1 code=0
  shift
  "$render" "${args[@]}" "$@" >out.txt 2>err.txt || code=$?
  [[ $code == 1 ]] || fail "exit code $code, expected 1; stderr: $(cat err.txt)"
  [[ $(wc -l <err.txt) == 1 ]] || fail "expected one line on stderr, got: $(cat err.txt)"
  grep -q -E -e "$message" err.txt || fail "expected '$message', got: $(cat err.txt)"
  echo "refused: $(cat err.txt)"
}
# Sets ck's trailing checksum (FNV-1a 64 of every byte before it) after a case edited its bytes.
reseal() {
  python3 - <<'PY'
import struct
data = bytearray(open("ck", "rb").read())
h = 0xcbf29ce484222325
for b in data[:-8]:
    h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
struct.pack_into("<Q", data, len(data) - 8, h)
open("ck", "wb").write(data)
PY
}
# Replaces the options line $1 of ck by $2, its length and checksum kept consistent (as a
# checkpoint written with those options would be).
rewrite_option() {
  python3 - "$1" "$2" <<'PY'
import struct, sys
data = bytearray(open("ck", "rb").read())
at = len(b"segpath-checkpoint\n") + 8
(length,) = struct.unpack_from("<Q", data, at)
old = bytes(data[at + 8:at + 8 + length])
new = old.replace(("\n" + sys.argv[1] + "\n").encode(), ("\n" + sys.argv[2] + "\n").encode())
assert new != old, old
data[at + 8:at + 8 + length] = new
struct.pack_into("<Q", data, at, len(new))
open("ck", "wb").write(data)
PY
  reseal
}
# A finished 4-iteration render's checkpoint.
checkpoint4() { "$render" "${args[@]}" --spp 4 --checkpoint ck >/dev/null; }

case $case in
  resume_after_kill)
    spp=1000
    "$render" "${args[@]}" --spp $spp --out uninterrupted.pfm
    "$render" "${args[@]}" --spp $spp --checkpoint ck --checkpoint-every 0 --out killed.pfm >/dev/null 2>&1 &
    pid=$!
    for _ in $(seq 1000); do [[ -f ck ]] && break; sleep 0.01; done
    [[ -f ck ]] || fail "no checkpoint written"
    sleep 0.1
    kill -KILL $pid 2>/dev/null || fail "the render finished before it was killed (make it longer)"
    wait $pid 2>/dev/null || true
    [[ ! -f killed.pfm ]] || fail "the killed render wrote its image"
    "$render" "${args[@]}" --spp $spp --resume ck --checkpoint ck --out resumed.pfm 2>err.txt
    at=$(sed -n 's/.*resuming ck at iteration \([0-9]*\).*/\1/p' err.txt)
    [[ -n $at && $at -gt 0 && $at -lt $spp ]] || fail "expected a resume inside the render, got: $(cat err.txt)"
    cmp uninterrupted.pfm resumed.pfm || fail "the resumed render differs from the uninterrupted one"
    echo "killed at iteration $at of $spp; resumed image identical" ;;
  stop_on_signal)
    # SIGTERM: the render stops after its round, writes its checkpoint and image, exits 143.
    spp=1000
    "$render" "${args[@]}" --spp $spp --out uninterrupted.pfm >/dev/null
    code=0
    "$render" "${args[@]}" --spp $spp --checkpoint ck --checkpoint-every 0 --out stopped.pfm >out.txt 2>err.txt &
    pid=$!
    for _ in $(seq 1000); do [[ -f ck ]] && break; sleep 0.01; done
    kill -TERM $pid
    wait $pid || code=$?
    [[ $code == 143 ]] || fail "exit code $code, expected 143; stderr: $(cat err.txt)"
    grep -q -E "stopped by signal 15 after [0-9]+ iterations; continue with --resume ck" err.txt || fail "stderr: $(cat err.txt)"
    [[ -f stopped.pfm ]] || fail "the stopped render wrote no image"
    "$render" "${args[@]}" --spp $spp --resume ck --out resumed.pfm 2>err.txt >/dev/null
    at=$(sed -n 's/.*resuming ck at iteration \([0-9]*\).*/\1/p' err.txt)
    [[ -n $at && $at -gt 0 && $at -lt $spp ]] || fail "expected a resume inside the render, got: $(cat err.txt)"
    cmp uninterrupted.pfm resumed.pfm || fail "the resumed render differs from the uninterrupted one"
    echo "stopped at iteration $at of $spp; resumed image identical" ;;
  extend)
    "$render" "${args[@]}" --spp 6 --out direct.pfm >/dev/null
    checkpoint4
    "$render" "${args[@]}" --spp 6 --resume ck --out extended.pfm >/dev/null
    cmp direct.pfm extended.pfm || fail "4 + 2 iterations differ from 6"
    echo "4 + 2 iterations identical to 6" ;;
  unwritable_checkpoint)
    # A checkpoint that cannot be written is a warning; the images are written, the exit code is 1.
    mkdir ck.tmp
    code=0
    "$render" "${args[@]}" --spp 4 --checkpoint ck --out image.pfm >out.txt 2>err.txt || code=$?
    [[ $code == 1 ]] || fail "exit code $code, expected 1"
    grep -q "warning: --checkpoint ck: cannot create ck.tmp" err.txt || fail "stderr: $(cat err.txt)"
    [[ -f image.pfm ]] || fail "no image written"
    grep -q "4 spp" out.txt || fail "no summary line: $(cat out.txt)"
    echo "checkpoint failure: warned, image and summary written" ;;
  wrong_size|huge_size)
    # A checkpoint whose header is consistent with its checksum but not with the render: a
    # 1 x 1 sum, or a size whose byte count overflows 64 bits.
    checkpoint4
    python3 - "$case" <<'PY'
import struct, sys
data = bytearray(open("ck", "rb").read())
at = len(b"segpath-checkpoint\n") + 8
(length,) = struct.unpack_from("<Q", data, at)
at += 8 + length
if sys.argv[1] == "wrong_size":
    struct.pack_into("<II", data, at, 1, 1)
    del data[at + 8 + 8 * 3 + 8 + 8 * 3 + 24: -8]  # keep one pixel (the drop counts' number is read below)
else:
    struct.pack_into("<II", data, at, 1 << 31, 1 << 30)
open("ck", "wb").write(data)
PY
    reseal
    expect_error "--resume ck: the checkpoint is corrupt" --spp 8 --resume ck ;;
  missing) expect_error "--resume .*: no such file" --spp 4 --resume nothing.ck ;;
  not_a_checkpoint)
    "$render" "${args[@]}" --spp 1 --out image.pfm >/dev/null
    expect_error "not a segpath-render checkpoint" --spp 4 --resume image.pfm ;;
  corrupt)
    checkpoint4
    size=$(stat -c %s ck)
    # Flip one bit of a pixel of the sum (the middle of the file).
    python3 - "$size" <<'PY'
import sys
size = int(sys.argv[1])
with open("ck", "r+b") as f:
    f.seek(size // 2)
    b = f.read(1)
    f.seek(size // 2)
    f.write(bytes([b[0] ^ 0x10]))
PY
    expect_error "corrupt" --spp 8 --resume ck ;;
  truncated)
    checkpoint4
    truncate -s -100 ck
    expect_error "corrupt|truncated" --spp 8 --resume ck ;;
  other_options)
    checkpoint4
    expect_error "--resume ck: written by a render with other options \(--alpha: 0.75 in the checkpoint, 0.5 in this render\)" \
      --spp 8 --resume ck --alpha 0.5 ;;
  automatic_radius)
    # An automatic radius is recorded with its footprints, so a checkpoint written when the
    # options said only "radius=default" (under another default) is refused rather than resumed
    # at another radius.
    checkpoint4
    rewrite_option "radius=default (1.25 footprints)" "radius=default"
    expect_error "--radius: default in the checkpoint, default \\(1.25 footprints\\) in this render" --spp 8 --resume ck ;;
  changed_default)
    # Defaults are recorded as the numbers the method runs with: a checkpoint of a version whose
    # default alpha was 0.5 is refused rather than resumed with this version's.
    checkpoint4
    rewrite_option "alpha=0.75" "alpha=0.5"
    expect_error "--alpha: 0.5 in the checkpoint, 0.75 in this render" --spp 8 --resume ck ;;
  more_than_spp)
    checkpoint4
    expect_error "it holds 4 iterations, more than --spp 3" --spp 3 --resume ck ;;
  *) fail "unknown case" ;;
esac
