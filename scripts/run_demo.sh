#!/bin/sh
# `make run`: trioctd on the demo scene, inside a private network and pid namespace so its
# LCM multicast never reaches the host's network; a demo client asks it a few questions,
# then the daemon keeps serving until Ctrl-C or a TERM to this script (or for RUN_SECONDS
# seconds when set), and the script exits with the daemon's exit code: 0 after a clean stop.
#
# While it runs, $BUILD/demo/netns.env says where the namespace is (a pid inside it) and
# which bus it serves, for scripts/demo-shell to run clients there from another terminal.
#   scripts/run_demo.sh BUILD_DIR
set -eu
build=$1
url="udpm://239.255.76.67:7667?ttl=0"
envfile="$build/demo/netns.env"
exitfile="$build/demo/exit-code"

# make runs its recipes in its own process group, which the terminal's Ctrl-C reaches whole:
# make itself would die of the SIGINT, with exit 130, however cleanly the daemon stopped.
# Under a terminal the demo therefore runs as a job of its own (bash's job control), so
# Ctrl-C reaches the demo alone and make sees the exit code of a clean stop.
if [ -t 0 ] && [ -z "${TRIOCT_DEMO_JOB:-}" ] && command -v bash >/dev/null 2>&1; then
    TRIOCT_DEMO_JOB=1 exec bash -mc '"$@" & fg %1 >/dev/null' run_demo sh "$0" "$@"
fi

mkdir -p "$build/demo"
rm -f "$exitfile"
# The namespace's first process sets no trap: as a pid namespace's init it ignores the
# terminal's SIGINT, which stops the daemon (trioctd stops cleanly on SIGINT as on
# SIGTERM), so its one wait is never cut short and the daemon's exit code is what it
# writes down.
tests/e2e/netns.sh sh -c '
    build=$1 url=$2 seconds=$3 exitfile=$4
    "$build/trioctd" --scene scenes/demo.ini --world-dir "$build/demo" --url "$url" &
    pid=$!
    "$build/trioct-demo" "$url" || true
    echo
    echo "trioctd serves the demo scene on $url inside a private network namespace."
    echo "Ask it from another terminal (as root), for example:"
    echo "  scripts/demo-shell trioct worlds"
    echo "  scripts/demo-shell trioct ray yard 0 0 50 0 0 -1"
    echo "  scripts/demo-shell        (a shell inside the namespace)"
    echo "Ctrl-C stops it."
    if [ -n "$seconds" ]; then sleep "$seconds"; kill -TERM $pid; fi
    rc=0
    wait $pid || rc=$?
    echo $rc >"$exitfile"' run_demo "$build" "$url" "${RUN_SECONDS:-}" "$exitfile" &
ns=$!

# The namespace's first process is unshare's child; its pid (as this side sees it) is what
# nsenter needs. Until unshare runs, the children are netns.sh's own checks: a child counts
# only once it is in another pid namespace. The file is gone again when the demo ends.
inside=
ours=$(readlink /proc/self/ns/pid)
trap : INT TERM
for _ in $(seq 1 200); do
    for child in $(cat "/proc/$ns/task/$ns/children" 2>/dev/null); do
        theirs=$(readlink "/proc/$child/ns/pid" 2>/dev/null) || continue
        [ "$theirs" != "$ours" ] && inside=$child
    done
    [ -n "$inside" ] && break
    kill -0 "$ns" 2>/dev/null || break
    sleep 0.05
done
if [ -n "$inside" ]; then
    printf 'TRIOCT_DEMO_PID=%s\nTRIOCT_DEMO_URL=%s\nTRIOCT_DEMO_BUILD=%s\n' "$inside" "$url" \
        "$(cd "$build" && pwd)" >"$envfile"
    # A TERM for this script (not from a terminal, which signals the daemon itself) goes
    # to the daemon: the namespace's init ignores it, as it ignores SIGINT.
    trap 'kill -TERM $(cat "/proc/$inside/task/$inside/children" 2>/dev/null) 2>/dev/null' TERM
fi

# A signal cuts a wait short: wait until the namespace is really gone.
while kill -0 "$ns" 2>/dev/null; do
    wait "$ns" || true
done
rm -f "$envfile"
rc=1
[ -s "$exitfile" ] && rc=$(cat "$exitfile")
rm -f "$exitfile"
exit "$rc"
