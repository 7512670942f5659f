#!/usr/bin/env bash
# Runs every fuzz target (or those named) for SECONDS each, FUZZ_JOBS (2) at a time:
#   fuzz/run.sh BUILD_DIR SECONDS [TARGET...]
# Seeds are written fresh into BUILD_DIR/fuzz-seeds/<target> (fuzz_seeds, from tests/data); new
# inputs that libFuzzer finds accumulate in BUILD_DIR/fuzz-corpus/<target>, crashing inputs go to
# BUILD_DIR/fuzz-artifacts/. Exits non-zero when any target found a crash, a leak, a timeout or
# an out-of-memory input; the log of each run is BUILD_DIR/fuzz-logs/<target>.log.
set -uo pipefail

build=${1:?usage: fuzz/run.sh BUILD_DIR SECONDS [TARGET...]}
seconds=${2:?usage: fuzz/run.sh BUILD_DIR SECONDS [TARGET...]}
shift 2
here=$(cd "$(dirname "$0")" && pwd)
data="$here/../tests/data"
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    targets=(obj vs3 properties matrix_csv matrix_npy matrix_txt matrix_mtx solution points msh idf
        epjson matrix_dat mesh)
fi

"$build/fuzz/fuzz_seeds" "$data" "$build/fuzz-seeds" || exit 1
mkdir -p "$build/fuzz-corpus" "$build/fuzz-artifacts" "$build/fuzz-logs"

# One target: its libFuzzer run, then a line of figures in fuzz-logs/<target>.summary and its exit
# status in fuzz-logs/<target>.rc.
run_one() {
    local t=$1 log="$build/fuzz-logs/$1.log" start rc runs cov
    mkdir -p "$build/fuzz-corpus/$t"
    start=$(date +%s)
    # -timeout: one input taking FUZZ_TIMEOUT s (default 30; wall time, so generous for a loaded
    # machine) is a hang; -rss_limit_mb / -malloc_limit_mb: an input that makes a reader
    # allocate 2 GB (a size field it believed) is a bug.
    # tests/lsan.supp: the leaks of Open Asset Import itself on damaged files (`mesh`).
    ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1} \
    LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$here/../tests/lsan.supp} \
    UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1} \
        "$build/fuzz/fuzz_$t" -max_total_time="$seconds" -timeout="${FUZZ_TIMEOUT:-30}" -rss_limit_mb=2048 \
        -malloc_limit_mb=2048 -print_final_stats=1 \
        -artifact_prefix="$build/fuzz-artifacts/$t-" \
        "$build/fuzz-corpus/$t" "$build/fuzz-seeds/$t" >"$log" 2>&1
    rc=$?
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1)
    echo "fuzz_$t: ${runs:-?} executions in $(($(date +%s) - start)) s, ${cov:-cov: ?}, exit $rc" \
        >"$build/fuzz-logs/$t.summary"
    echo $rc >"$build/fuzz-logs/$t.rc"
}

# FUZZ_JOBS targets at a time (default 2: CI's two cores).
jobs=${FUZZ_JOBS:-2}
running=0
for t in "${targets[@]}"; do
    if [ "$running" -ge "$jobs" ]; then
        wait -n
        running=$((running - 1))
    fi
    run_one "$t" &
    running=$((running + 1))
done
wait

failed=()
for t in "${targets[@]}"; do
    cat "$build/fuzz-logs/$t.summary"
    rc=$(cat "$build/fuzz-logs/$t.rc")
    if [ "$rc" -ne 0 ]; then
        failed+=("$t")
        grep -m1 -A3 'ERROR:\|==ERROR\|runtime error\|deadly signal\|Timeout\|out-of-memory' \
            "$build/fuzz-logs/$t.log" | head -20
        ls "$build/fuzz-artifacts/" | grep "^$t-" | head -5
    fi
done
if [ ${#failed[@]} -ne 0 ]; then
    echo "fuzz: FAILED: ${failed[*]} (logs in $build/fuzz-logs, inputs in $build/fuzz-artifacts)"
    exit 1
fi
echo "fuzz: ${#targets[@]} targets, no crash"
