#!/usr/bin/env bash
# The engine on a real GPU in one command: builds the release preset, runs the `gpu` and
# `technique` test labels on the GPU, renders every config under config/ (with --timings),
# and runs a short bench of every technique (config/bench/gpu-check.json), writing a
# report (device, passes, failures, timings) to a folder. Meant for a machine with an
# NVIDIA (or any discrete) GPU and its Vulkan driver, within 8 minutes; CI never runs it.
#
#   .ci/gpu-check.sh [-o DIR] [--budget SECONDS] [--device SPEC] [--jobs N] [--build-dir DIR]
#
#   -o DIR          the report folder (default: gpu-check-out); report.md is the summary,
#                   beside it each step's log, ctest's JUnit XML, the renders' PNGs and
#                   timings, the bench's results.json and summary.md
#   --budget S      wall-clock seconds for the whole run (default 480): each step gets a
#                   share and what is left; a step cut short is reported as timed out
#   --device SPEC   the Vulkan device, as PENUMBRA_DEVICE takes it (default type:discrete;
#                   type:cpu runs it on lavapipe, to try the script where there is no GPU)
#   --jobs N        build and test parallelism (default: the number of cores)
#   --build-dir DIR use this build tree as it is instead of building the release preset
#                   (one built elsewhere and carried to the GPU machine)
#
# Needs what .ci/install-deps.sh installs (the GPU machine may have no network: install
# there beforehand, or carry them). Exit status: 0 when every step passed, 1 when any
# failed or timed out, 2 for a usage error; the report is written in every case.
set -uo pipefail
cd "$(dirname "$0")/.."
root=$PWD

out=gpu-check-out
budget=480
device=type:discrete
jobs=$(nproc)
build=""
while [[ $# -gt 0 ]]; do
    case $1 in
    -o) out=$2; shift 2 ;;
    --budget) budget=$2; shift 2 ;;
    --device) device=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    --build-dir) build=$(cd "$2" && pwd) || exit 2; shift 2 ;;
    *) echo "usage: $0 [-o DIR] [--budget SECONDS] [--device SPEC] [--jobs N] [--build-dir DIR]" >&2; exit 2 ;;
    esac
done
[[ $budget =~ ^[0-9]+$ && $budget -gt 0 ]] || { echo "$0: --budget: a whole number of seconds > 0, got '$budget'" >&2; exit 2; }
[[ $jobs =~ ^[0-9]+$ && $jobs -gt 0 ]] || { echo "$0: --jobs: a whole number > 0, got '$jobs'" >&2; exit 2; }

mkdir -p "$out" || exit 2
out=$(cd "$out" && pwd)
report=$out/report.md
prebuilt=$build
[[ -n $build ]] || build=$root/build/release
cli=$build/apps/penumbra/penumbra
export PENUMBRA_DEVICE=$device
deadline=$((SECONDS + budget))
failed=0
rows=()

# step NAME SHARE CMD...: runs CMD with its output in $out/NAME.log, for at most SHARE
# percent of the budget or what is left of it, and records a row of the report.
step() {
    local name=$1 share=$2
    shift 2
    local left=$((deadline - SECONDS)) limit=$((budget * share / 100))
    ((limit > left)) && limit=$left
    if ((limit <= 0)); then
        rows+=("| $name | skipped: no time left | 0 |")
        failed=1
        return 1
    fi
    local start=$SECONDS rc=0
    timeout --kill-after=10 "$limit" "$@" >"$out/$name.log" 2>&1 || rc=$?
    local took=$((SECONDS - start)) status=passed
    if ((rc == 124 || rc == 137)); then
        status="timed out after $limit s"
    elif ((rc != 0)); then
        status="FAILED (exit $rc)"
    fi
    [[ $status == passed ]] || failed=1
    rows+=("| $name | $status | $took |")
    [[ $status == passed ]]
}

renderAll() {
    local rc=0 config name
    mkdir -p "$out/renders"
    for config in config/*.json; do
        name=$(basename "$config" .json)
        echo "== $config"
        "$cli" render "$config" -o "$out/renders/$name.png" --frames 3 --timings \
            >"$out/renders/$name.txt" 2>&1 || { rc=1; echo "FAILED: $config"; tail -n 5 "$out/renders/$name.txt"; }
    done
    return $rc
}

if [[ -z $prebuilt ]]; then
    step configure 5 cmake --preset release
    step build 40 cmake --build --preset release -j "$jobs"
fi
step devices 2 "$cli" devices
step tests 35 ctest --test-dir "$build" -L 'gpu|technique' -j "$jobs" --output-on-failure \
    --output-junit "$out/tests.xml" --timeout 300
export -f renderAll
export cli out
step renders 10 bash -c renderAll
step bench 10 "$cli" bench config/bench/gpu-check.json -o "$out/bench" --summary "$out/bench/summary.md" \
    --frames 5 --warmup 2

{
    echo "# gpu-check: $(date -u +%Y-%m-%dT%H:%MZ)"
    echo
    echo "Commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown), build $build, PENUMBRA_DEVICE=$device," \
        "budget $budget s, took $SECONDS s."
    echo
    echo "## Device"
    echo
    echo '```'
    cat "$out/devices.log" 2>/dev/null
    command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
    echo '```'
    echo
    echo "## Steps"
    echo
    echo "| step | status | s |"
    echo "|---|---|---|"
    printf '%s\n' "${rows[@]}"
    echo
    echo "## Tests"
    echo
    echo '```'
    echo "passed: $(grep -c ' Passed ' "$out/tests.log" 2>/dev/null), failed: $(grep -cE '\*\*\*Failed|\*\*\*Exception|\*\*\*Timeout' "$out/tests.log" 2>/dev/null)"
    grep -E "tests passed|tests failed|Total Test time" "$out/tests.log" 2>/dev/null
    sed -n '/The following tests FAILED/,$p' "$out/tests.log" 2>/dev/null
    echo '```'
    echo
    echo "## Renders (medians of 3 frames: the sum of passes on the GPU and the wall clock, ms; every pass in renders/NAME.txt)"
    echo
    echo "| config | GPU ms | wall ms |"
    echo "|---|---|---|"
    for t in "$out"/renders/*.txt; do
        [[ -e $t ]] || continue
        gpu=$(awk '/sum of passes \(GPU\)/ {print $5; exit}' "$t")
        wall=$(awk '/frame wall clock/ {print $5; exit}' "$t")
        echo "| $(basename "$t" .txt) | ${gpu:-failed} | ${wall:-failed} |"
    done
    echo
    echo "## Bench (config/bench/gpu-check.json)"
    echo
    cat "$out/bench/summary.md" 2>/dev/null || echo "no summary (see bench.log)"
} >"$report"

echo "gpu-check: report in $report"
exit $failed
