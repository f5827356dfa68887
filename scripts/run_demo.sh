#!/bin/sh
# `make run`: trioctd on the demo scene, inside a private network and pid namespace so its
# LCM multicast never reaches the host's network; a demo client asks it a few questions,
# then the daemon keeps serving until Ctrl-C (or for RUN_SECONDS seconds when set).
#   scripts/run_demo.sh BUILD_DIR
set -eu
build=$1
url="udpm://239.255.76.67:7667?ttl=0"
exec tests/e2e/netns.sh sh -c '
    build=$1 url=$2 seconds=$3
    "$build/trioctd" --scene scenes/demo.ini --world-dir "$build/demo" --url "$url" &
    pid=$!
    trap "kill -TERM $pid" INT TERM
    "$build/trioct-demo" "$url" || true
    echo
    echo "trioctd serves the demo scene on $url inside this private namespace; Ctrl-C stops it."
    if [ -n "$seconds" ]; then sleep "$seconds"; kill -TERM $pid; fi
    wait $pid' run_demo "$build" "$url" "${RUN_SECONDS:-}"
