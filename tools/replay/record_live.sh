#!/bin/sh
# Records tests/logs/recorded/live.lcmlog from a live system: lcm-logger and trioctd on a
# udpm bus, the trioct command asking its questions, all inside tests/e2e/netns.sh (a
# private network namespace: nothing reaches the host's network). Then records the golden
# log of the recording with trioct-replay. Timestamps, heartbeats and the order replies
# arrive in differ from run to run, so a new recording is new bytes; test_replay replays
# whichever is kept.
#   tools/replay/record_live.sh BUILD [DIR]      (as root; DIR defaults to tests/logs/recorded)
set -eu
build=$(cd "$1" && pwd)
dir=${2:-tests/logs/recorded}
if [ "${TRIOCT_IN_NETNS:-}" != 1 ]; then
    TRIOCT_IN_NETNS=1 exec tests/e2e/netns.sh sh "$0" "$build" "$dir"
fi
url='udpm://239.255.76.67:7667?ttl=0'
log=$dir/live.lcmlog
rm -f "$log"
lcm-logger --lcm-url="$url" --quiet -f "$log" &
logger=$!
sleep 0.5
# From the scene's directory, as a replay runs it, so the worlds' source reads the same.
(cd "$dir" && exec "$build/trioctd" --scene scene.ini --url "$url" --threads 2 --status-interval 250 \
    --log-level warn) &
daemon=$!
cli() { "$build/trioct" --url "$url" "$@" || true; }
# Ready when its heartbeat says so: waiting on a heartbeat sends no request, so the log holds
# no question the daemon was too young to answer.
tries=0
until "$build/trioct" --url "$url" --timeout 500 status 2>/dev/null | grep -q ': ready'; do
    tries=$((tries + 1))
    [ $tries -lt 40 ] || { echo "record_live: the daemon never answered" >&2; kill $daemon $logger; exit 1; }
    sleep 0.25
done
# Rays cross face interiors, off every edge: their answers do not hang on a crossing rule.
cli worlds
cli info yard
cli ray yard -5.5 -5.25 10 0 0 -1
cli ray yard 0.3 0.2 10 0 0 -1 --all
cli ray yard -10 0.1 2.1 1 0 0 --any
cli ray yard 0.3 0.2 10 0 0 -1 --tmax 6
cli ray yard_fast -5.5 -5.25 10 0 0 -1
cli tri yard -6 -6 1.5  -4 -6 1.5  -6 -4 1.5 --ids
cli tri yard -0.5 -0.5 4  0.5 -0.5 4  0 0.5 5 --segments
cli tri yard 20 20 20  21 20 20  20 21 20
cli ray nowhere 0 0 0 1 0 0
cli ray yard 0 0 0 0 0 0
cli mesh yard probe --pose "0 0 4" --pose "0 0 10" --pose "-5 -5 1 0 0 45" --pairs
cli distance yard --point 0 0 10 --point -10 0.1 2.1 --point 0.3 0.2 -3
cli distance yard --point 0 0 10 --within 0.5 --json
cli distance yard_fast --point 0 0 0
cli distance yard --shape probe --pose "0 0 4"
cli clear yard --shape probe --pose "0 0 4" --within 0.1
cli status
kill -TERM $daemon
wait $daemon || true
sleep 0.5
kill -INT $logger
wait $logger || true
"$build/trioct-replay" record --quiet --threads 2 --daemon "$build/trioctd" --scene "$dir/scene.ini" \
    "$log" -o "$dir/live.golden.lcmlog"
echo "record_live: wrote $log and $dir/live.golden.lcmlog"
