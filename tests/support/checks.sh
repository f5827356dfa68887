# The counters of the shell tests (tests/e2e/systemd_test.sh, install_test.sh,
# tests/java/java_test.sh), sourced by each: `ok WHAT` and `not_ok WHAT` count and print
# one line; `checks_summary NAME` prints "NAME: N passed, M failed" (with ", K skipped" when
# the script counts skips in $skipped) and returns 1 when anything failed.
passed=0
failed=0
ok() {
    passed=$((passed + 1))
    echo "ok: $1"
}
not_ok() {
    failed=$((failed + 1))
    echo "FAILED: $1"
}
checks_summary() {
    if [ -n "${skipped:-}" ]; then
        echo "$1: $passed passed, $failed failed, $skipped skipped"
    else
        echo "$1: $passed passed, $failed failed"
    fi
    [ "$failed" -eq 0 ]
}
