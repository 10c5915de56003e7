#!/usr/bin/env bash
# segpath-render on MPI ranks (examples/renderer/ranks.hpp), one case per CTest test:
#   mpi_test.sh RENDER MPIEXEC DIR CASE
# bit_for_bit_METHOD: the image of 1 process (2 threads), 2 ranks (1 thread each) and 3 ranks
#   (2 threads each) is the same file, for an iteration count that no rank count divides;
# time: --time across ranks; checkpoint: a checkpoint of 2 ranks resumed by 1 process;
# stop_on_usr1: SIGUSR1 to mpirun stops every rank after one round, resumable; the
# rest: bad input refused with one clear line from rank 0.
set -euo pipefail
render=$1 mpiexec=$2 dir=$3/$4 case=$4
rm -rf "$dir" && mkdir -p "$dir" && cd "$dir"
mpirun() { "$mpiexec" --allow-run-as-root --oversubscribe "$@"; }
args=(--scene cornell1 --width 64 --height 64)

fail() { echo "FAIL ($case): $*" >&2; exit 1; }
# expect_error MESSAGE MPIRUN-ARGS...: a non-zero exit and MESSAGE on stderr, printed once.
expect_error() {
  local message=$1 code=0
  shift
  mpirun "$@" >out.txt 2>err.txt || code=$?
  [[ $code != 0 ]] || fail "expected a failure; stdout: $(cat out.txt)"
  [[ $(grep -c -E -e "$message" err.txt) == 1 ]] || fail "expected '$message' once on stderr, got: $(cat err.txt)"
  echo "refused: $(grep -E -e "$message" err.txt)"
}

case $case in
  bit_for_bit_*)
    method=${case#bit_for_bit_}
    "$render" "${args[@]}" --method "$method" --spp 5 --threads 2 --out one.pfm
    mpirun -n 2 "$render" "${args[@]}" --method "$method" --spp 5 --threads 1 --out two.pfm | tee two.txt
    mpirun -n 3 "$render" "${args[@]}" --method "$method" --spp 5 --threads 2 --out three.pfm | tee three.txt
    grep -q "2 ranks x 1 thread," two.txt && grep -q "3 ranks x 2 threads" three.txt || fail "the ranks did not run"
    cmp one.pfm two.pfm || fail "2 ranks differ from 1 process"
    cmp one.pfm three.pfm || fail "3 ranks differ from 1 process"
    echo "$method: 1 process, 2 and 3 ranks give the same image" ;;
  time)
    mpirun -n 2 "$render" "${args[@]}" --method pt --time 0.5 --threads 1 --out timed.pfm | tee out.txt
    iterations=$(sed -n 's/.* \([0-9]*\) spp.*/\1/p' out.txt)
    # Every round renders one iteration per rank, and all ranks stop after the same round.
    [[ -n $iterations && $iterations -ge 2 && $((iterations % 2)) == 0 ]] || fail "expected an even count >= 2, got: $(cat out.txt)"
    "$render" "${args[@]}" --method pt --spp "$iterations" --out counted.pfm >/dev/null
    cmp timed.pfm counted.pfm || fail "the timed render differs from --spp $iterations"
    echo "--time on 2 ranks: $iterations iterations, the image of --spp $iterations" ;;
  checkpoint)
    mpirun -n 2 "$render" "${args[@]}" --method bdpf --spp 3 --checkpoint ck >/dev/null
    "$render" "${args[@]}" --method bdpf --spp 5 --resume ck --out resumed.pfm >/dev/null
    "$render" "${args[@]}" --method bdpf --spp 5 --out direct.pfm >/dev/null
    cmp direct.pfm resumed.pfm || fail "3 iterations on 2 ranks + 2 resumed differ from 5"
    echo "checkpoint of 2 ranks resumed by 1 process: identical" ;;
  resume_near_end)
    # Resumed with fewer iterations left than ranks: the last round is partial, not refused.
    "$render" "${args[@]}" --method vcm --spp 4 --checkpoint ck >/dev/null
    mpirun -n 3 "$render" "${args[@]}" --method vcm --spp 5 --threads 1 --resume ck --out resumed.pfm >/dev/null
    "$render" "${args[@]}" --method vcm --spp 5 --out direct.pfm >/dev/null
    cmp direct.pfm resumed.pfm || fail "4 iterations + 1 on 3 ranks differ from 5"
    echo "resumed on 3 ranks for 1 iteration: identical" ;;
  stop_on_usr1)
    # mpirun forwards SIGUSR1: every rank stops after the same round, rank 0 checkpoints.
    "$mpiexec" --allow-run-as-root --oversubscribe -n 2 "$render" "${args[@]}" --method vcm --spp 100000 --threads 1 \
      --checkpoint ck --checkpoint-every 0 >out.txt 2>err.txt &
    pid=$!
    for _ in $(seq 2000); do [[ -f ck ]] && break; sleep 0.01; done
    code=0
    kill -USR1 $pid
    wait $pid || code=$?
    [[ $code != 0 ]] || fail "expected a non-zero exit after the signal"
    at=$(sed -n 's/.*stopped by signal 10 after \([0-9]*\) iterations.*/\1/p' err.txt)
    [[ -n $at && $((at % 2)) == 0 ]] || fail "expected an even iteration count (whole rounds), got: $(cat err.txt)"
    "$render" "${args[@]}" --method vcm --spp $((at + 3)) --resume ck --out resumed.pfm >/dev/null 2>&1
    "$render" "${args[@]}" --method vcm --spp $((at + 3)) --out direct.pfm >/dev/null
    cmp direct.pfm resumed.pfm || fail "the stopped render resumed differs from an uninterrupted one"
    echo "2 ranks stopped by SIGUSR1 after $at iterations; resumed image identical" ;;
  more_ranks_than_iterations)
    expect_error "3 ranks for 2 iterations" -n 3 "$render" "${args[@]}" --spp 2 ;;
  different_options)
    expect_error "rank 1 was started with other options than rank 0 \(--seed: 1 in rank 0, 2 in rank 1\)" \
      -n 1 "$render" "${args[@]}" --spp 4 --seed 1 : -n 1 "$render" "${args[@]}" --spp 4 --seed 2 ;;
  *) fail "unknown case" ;;
esac
