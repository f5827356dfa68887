#!/bin/sh
# `make run`'s path, as a new user takes it: scripts/run_demo.sh brings the demo daemon up
# in its private namespace; from outside, scripts/demo-shell runs `trioct worlds` and
# `trioct render` there, and render_check compares sampled pixels of the depth picture
# with the daemon's own answers to their rays; a TERM then stops the demo with exit 0 and
# its namespace file gone; and make run itself, in a terminal (a pty), ends with exit 0 and
# no make error at Ctrl-C. Needs root (exit 77 without).
#   tests/e2e/demo_test.sh BUILD
set -u
build=$1
if [ "$(id -u)" -ne 0 ]; then
    echo "demo_test.sh: needs root for the demo's namespace" >&2
    exit 77
fi
tmp=$(mktemp -d)
demo=
cleanup() {
    [ -n "$demo" ] && kill -TERM "$demo" 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT
fail() {
    echo "FAIL: $*"
    echo "--- the demo's output:"
    cat "$tmp/run.log" 2>/dev/null
    exit 1
}
export BUILD="$build"
envfile="$build/demo/netns.env"
rm -f "$envfile"

out=$(sh scripts/demo-shell trioct worlds 2>&1) && fail "demo-shell succeeded with no demo running: $out"
case $out in *"no demo is running"*) ;; *) fail "demo-shell without a demo said: $out" ;; esac

sh scripts/run_demo.sh "$build" >"$tmp/run.log" 2>&1 &
demo=$!
. scripts/demo_wait.sh
why=$(demo_wait "$build" "$tmp/run.log" "$demo") || fail "$why"
echo "ok: the demo is up and says how to reach it ($(grep -c demo-shell "$tmp/run.log") demo-shell lines)"

worlds=$(sh scripts/demo-shell trioct worlds 2>&1) || fail "trioct worlds through demo-shell: $worlds"
for w in yard yard_lidar cell; do
    echo "$worlds" | grep -q "^$w " || fail "trioct worlds does not list $w: $worlds"
done
echo "ok: demo-shell trioct worlds lists yard, yard_lidar and cell"

png="$tmp/yard.png"
msg=$(sh scripts/demo-shell trioct render yard --camera 22 -26 12 --look-at -2 4 0 --size 200x120 -o "$png" 2>&1) ||
    fail "trioct render: $msg"
[ -s "$png" ] || fail "trioct render wrote no picture: $msg"
echo "ok: $msg"
check=$(sh scripts/demo-shell "$build/tests/render_check" "$png" 3 2>&1) || fail "$check"
echo "ok: $check"

kill -TERM "$demo"
rc=0
wait "$demo" || rc=$?
demo=
[ "$rc" -eq 0 ] || fail "the demo exited $rc after TERM, not 0"
[ ! -e "$envfile" ] || fail "$envfile is left behind"
grep -q "stopped:" "$tmp/run.log" || fail "the daemon did not log a clean stop"
echo "ok: TERM stopped the demo with exit 0 and removed $envfile"

# The way a user ends it: make run in a terminal, then Ctrl-C.
"${PYTHON:-python3}" tests/e2e/ctrl_c.py "${MAKE:-make}" "$build" || fail "make run under Ctrl-C"
