#!/bin/sh
# `make test`'s runner: every test program runs even when another failed, then one line
# counts them: "N passed, N failed, N skipped", naming the failed and the skipped ones.
# A program is skipped when it exits 77 (the end-to-end runs without root) or when it
# reports a skipped test (cmocka's "[  SKIPPED ] name", a script's "SKIPPED: why"). Under
# CI (CI=true) or as root everything a test needs is there, so nothing may be skipped: a
# skip is counted as a failure. Exits 1 when anything failed.
#   tests/run_tests.sh BUILD   with TEST_BIN, E2E_BIN, E2E_CLI_BIN, DAEMON_BIN, CLI_BIN, MAKE,
#                              SAN and PYTHON from the Makefile
set -u
build=$1
export LCM_DEFAULT_URL=memq://
strict=0
if [ "${CI:-}" = true ] || [ "$(id -u)" -eq 0 ]; then
    strict=1
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
passed=0
failed=0
skipped=0
failed_names=
skipped_names=

# run NAME DESCRIPTION CMD...: runs CMD with its output shown (and kept to read the skips).
run() {
    name=$1
    echo "== $2"
    shift 2
    { "$@"; echo $? >"$tmp/rc"; } 2>&1 | tee "$tmp/out"
    rc=$(cat "$tmp/rc")
    skips=$(sed -n -e 's/^\[  SKIPPED \] \([A-Za-z_][A-Za-z0-9_]*\)$/\1/p' -e 's/^SKIPPED: \(.*\)$/\1/p' "$tmp/out" |
        sort -u | sed -e ':a' -e 'N' -e '$!ba' -e 's/\n/; /g')
    if [ "$rc" -eq 77 ] && [ -z "$skips" ]; then
        skips="the whole program (exit 77)"
    fi
    if [ "$rc" -ne 0 ] && [ "$rc" -ne 77 ]; then
        failed=$((failed + 1))
        failed_names="$failed_names
  $name (exit $rc)"
    elif [ -n "$skips" ] && [ $strict -eq 1 ]; then
        failed=$((failed + 1))
        failed_names="$failed_names
  $name: skipped under CI or as root, where nothing may be: $skips"
    elif [ -n "$skips" ]; then
        skipped=$((skipped + 1))
        skipped_names="$skipped_names
  $name: $skips"
    else
        passed=$((passed + 1))
    fi
}

for t in $TEST_BIN; do
    run "$t" "$t" "$t"
done
run java_test.sh "tests/java/java_test.sh (make java's types jar: C-encoded messages and tests/logs decoded in Java, scripts/lcm-spy headless)" \
    env MAKE="$MAKE" sh tests/java/java_test.sh "$build"
run systemd_test.sh "tests/e2e/systemd_test.sh (the unit, its sandbox score, man pages, install)" \
    env MAKE="$MAKE" sh tests/e2e/systemd_test.sh "$build"
run install_test.sh "tests/e2e/install_test.sh (make install into a DESTDIR, pkg-config, C and C++ users)" \
    env MAKE="$MAKE" TRIOCT_TEST_SAN="$SAN" sh tests/e2e/install_test.sh "$build"
run demo_test.sh "tests/e2e/demo_test.sh (make run's path: the demo up, demo-shell, trioct render checked against the daemon)" \
    sh tests/e2e/demo_test.sh "$build"
run "$E2E_BIN" "$E2E_BIN (udpm in a private network namespace)" tests/e2e/netns.sh "$E2E_BIN" "$DAEMON_BIN"
run "$E2E_CLI_BIN" "$E2E_CLI_BIN (the trioct command against trioctd, udpm in a private network namespace)" \
    tests/e2e/netns.sh "$E2E_CLI_BIN" "$DAEMON_BIN" "$CLI_BIN"
# The Python package from the build tree against a daemon of its own. A sanitized build's
# libtrioct needs the ASan runtime loaded first in an interpreter that was not built with
# it, and CPython's own allocations would read as leaks.
py_env=
case "$SAN" in
*address*) py_env="LD_PRELOAD=$(${CC:-cc} -print-file-name=libasan.so) ASAN_OPTIONS=detect_leaks=0" ;;
esac
run python_test "python/tests (the trioct Python package against trioctd, udpm in a private network namespace)" \
    tests/e2e/netns.sh env $py_env PYTHONDONTWRITEBYTECODE=1 PYTHONPATH="$build/python" TRIOCT_BUILD="$build" TRIOCT_DAEMON="$DAEMON_BIN" \
    "${PYTHON:-/usr/bin/python3}" -m unittest discover -v -s python/tests

echo "make test: $passed passed, $failed failed, $skipped skipped (test programs)"
if [ -n "$skipped_names" ]; then
    echo "skipped:$skipped_names"
fi
if [ -n "$failed_names" ]; then
    echo "failed:$failed_names"
    exit 1
fi
exit 0
