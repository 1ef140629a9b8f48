#!/usr/bin/env bash
# rerun-on-tracer-crash.sh <test executable> [args...]: the test launcher of sanitizer
# builds (tests/CMakeLists.txt sets it as the test groups' CROSSCOMPILING_EMULATOR, which
# gtest_discover_tests puts before every test command).
#
# Runs the command once. When it failed and its output shows LeakSanitizer's own
# stop-the-world tracer crashing ("Tracer caught signal", then "LeakSanitizer has
# encountered a fatal error"; in the test's process, or in a child whose output the test
# printed: a death test's, a CLI test's) with no leak report and no address or
# undefined-behaviour error anywhere, it runs the command once more and exits with that
# run's status. Anything else exits with the first run's status, so every real finding
# still fails the test, and a test that fails for its own reasons fails on the rerun too.
#
# Why: the tracer scans every thread's stacks and TLS and every module's globals from a
# cloned task; in rare runs it faults itself, in __lsan::ScanRangeForPointers
# (google/sanitizers#1353, unfixed in GCC 12's libsanitizer). The leak check already runs
# at the end of main with TBB's workers stopped (engine/src/core/LeakCheck.cpp: that took
# the crash from 1-2 in 100 traced runs to 0 in 200), yet CI met it once per full
# sanitizer run in two runs: after a passing test whose process had only its main thread
# left (60 of 60 local runs of that test passed), and in the child of the death test
# ReferencePlugin.TheLeakCheckStopsTheWorkerThreadsEmbreeStarted.
set -u

if [[ $# -eq 0 ]]; then
    echo "usage: $0 <command> [args...]" >&2
    exit 2
fi

# Where the runs' output is copied to be searched. Without a temporary folder (a full or
# read-only $TMPDIR) nothing can be searched, so the test runs once, as it would without
# this launcher, and its own status stands.
logs=$(mktemp -d "${TMPDIR:-/tmp}/penumbra-rerun.XXXXXX") || exec "$@"
trap 'rm -rf "$logs"' EXIT

# Runs "$@" with its stdout and stderr passing through unchanged and copied into
# $logs/out and $logs/err; returns its exit status once both copies are complete.
run_logged() {
    local out_pid err_pid rc
    exec {out_fd}> >(tee "$logs/out")
    out_pid=$!
    exec {err_fd}> >(tee "$logs/err" >&2)
    err_pid=$!
    "$@" >&"$out_fd" 2>&"$err_fd"
    rc=$?
    exec {out_fd}>&- {err_fd}>&-
    # The tees end at end of input; wait for them so that the logs are whole.
    while kill -0 "$out_pid" 2>/dev/null || kill -0 "$err_pid" 2>/dev/null; do sleep 0.02; done
    return "$rc"
}

tracer_crash_only() {
    cat "$logs/out" "$logs/err" > "$logs/all"
    grep -q "Tracer caught signal" "$logs/all" &&
        grep -q "LeakSanitizer has encountered a fatal error" "$logs/all" &&
        ! grep -qE "ERROR: (AddressSanitizer|LeakSanitizer: detected)|runtime error:" "$logs/all"
}

run_logged "$@"
rc=$?
if [[ $rc -ne 0 ]] && tracer_crash_only; then
    echo "rerun-on-tracer-crash: LeakSanitizer's tracer crashed (exit $rc) in a run that reported" \
        "no leak and no sanitizer error; running it once more" >&2
    "$@"
    exit $?
fi
exit "$rc"
