#!/usr/bin/env bash
# The sanitizer builds' test launcher (rerun-on-tracer-crash.sh): reruns a run that failed
# only by LeakSanitizer's tracer crash, once; passes every other failure through as it
# was; leaves output and passing runs alone.
set -u
launcher="$(dirname "$0")/rerun-on-tracer-crash.sh"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failures=0

# fake <name> <first-run script> <later-run script>: a program that runs the first script
# on its first call and the second on every later one, counting its calls.
fake() {
    cat > "$work/$1" <<EOF
#!/usr/bin/env bash
n=\$(cat "$work/$1.calls" 2>/dev/null || echo 0); echo \$((n + 1)) > "$work/$1.calls"
if [[ \$n -eq 0 ]]; then $2; else $3; fi
EOF
    chmod +x "$work/$1"
}
tracer='echo "[  PASSED  ] 1 test."; echo "Tracer caught signal 11: addr=0x3258" >&2; echo "==1==LeakSanitizer has encountered a fatal error." >&2; exit 134'
passes='echo "[  PASSED  ] 1 test."; exit 0'

# expect <name> <status> <calls> [args...]
expect() {
    local name=$1 status=$2 calls=$3
    shift 3
    "$launcher" "$work/$name" "$@" > "$work/$name.out" 2> "$work/$name.err"
    local rc=$? n
    n=$(cat "$work/$name.calls")
    if [[ $rc -ne $status || $n -ne $calls ]]; then
        echo "FAIL $name: exit $rc (expected $status), $n calls (expected $calls)"
        failures=$((failures + 1))
    else
        echo "ok   $name: exit $rc, $n calls"
    fi
}

fake tracer_then_pass "$tracer" "$passes"
expect tracer_then_pass 0 2
grep -q "running it once more" "$work/tracer_then_pass.err" || { echo "FAIL: the rerun is not announced"; failures=$((failures + 1)); }

fake tracer_twice "$tracer" "$tracer"
expect tracer_twice 134 2

fake leak 'echo "ERROR: LeakSanitizer: detected memory leaks" >&2; echo "Tracer caught signal 11" >&2; echo "LeakSanitizer has encountered a fatal error." >&2; exit 23' "$passes"
expect leak 23 1

fake address_error 'echo "==1==ERROR: AddressSanitizer: heap-use-after-free" >&2; exit 1' "$passes"
expect address_error 1 1

fake ub 'echo "a.cpp:3:5: runtime error: signed integer overflow" >&2; echo "Tracer caught signal 11" >&2; echo "LeakSanitizer has encountered a fatal error." >&2; exit 1' "$passes"
expect ub 1 1

# A death test whose child's tracer crashed: the child's output is in the test's stdout.
fake death_test 'echo "[  DEATH   ] Tracer caught signal 11: addr=0x100004ad0"; echo "[  DEATH   ] ==613==LeakSanitizer has encountered a fatal error."; echo "[  FAILED  ] A.B"; exit 1' "$passes"
expect death_test 0 2

# A test that fails for its own reasons as well fails on the rerun too.
fake failed_twice 'echo "[  FAILED  ] A.B"; echo "Tracer caught signal 11" >&2; echo "LeakSanitizer has encountered a fatal error." >&2; exit 1' 'echo "[  FAILED  ] A.B"; exit 1'
expect failed_twice 1 2

fake leak_in_child 'echo "[  DEATH   ] ERROR: LeakSanitizer: detected memory leaks"; echo "Tracer caught signal 11"; echo "LeakSanitizer has encountered a fatal error."; exit 1' "$passes"
expect leak_in_child 1 1

fake plain_failure 'echo "[  FAILED  ] A.B"; exit 1' "$passes"
expect plain_failure 1 1

# Arguments and both streams pass through unchanged.
fake echo_args 'echo "out:$*"; echo "err:$*" >&2; exit 0' 'exit 9'
expect echo_args 0 1 --gtest_filter=A.B "two words"
if [[ "$(cat "$work/echo_args.out")" != "out:--gtest_filter=A.B two words" ||
      "$(cat "$work/echo_args.err")" != "err:--gtest_filter=A.B two words" ]]; then
    echo "FAIL echo_args: output changed: '$(cat "$work/echo_args.out")' / '$(cat "$work/echo_args.err")'"
    failures=$((failures + 1))
fi

[[ $failures -eq 0 ]]
