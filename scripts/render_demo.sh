#!/bin/sh
# `make demo-picture`: the picture of the demo yard the README shows. Brings the demo up as
# `make run` does (scripts/run_demo.sh, in its private namespace), renders the yard through
# scripts/demo-shell with `trioct render`, and stops the demo again.
#   scripts/render_demo.sh BUILD OUT.png
set -eu
build=$1
out=$2
envfile="$build/demo/netns.env"
log=$(mktemp)
rm -f "$envfile"
sh scripts/run_demo.sh "$build" >"$log" 2>&1 &
demo=$!
trap 'kill -TERM $demo 2>/dev/null; rm -f "$log"' EXIT
. scripts/demo_wait.sh
if ! why=$(demo_wait "$build" "$log" $demo); then
    echo "render_demo.sh: $why:" >&2
    cat "$log" >&2
    exit 1
fi
BUILD="$build" sh scripts/demo-shell trioct render yard --camera 22 -26 12 --look-at -2 4 0 \
    --shade normal --size 800x450 -o "$out"
