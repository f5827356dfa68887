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
i=0
until [ -f "$envfile" ] && grep -q "Ctrl-C stops it" "$log"; do
    i=$((i + 1))
    if [ $i -gt 600 ] || ! kill -0 $demo 2>/dev/null; then
        echo "render_demo.sh: the demo did not come up:" >&2
        cat "$log" >&2
        exit 1
    fi
    sleep 0.2
done
BUILD="$build" sh scripts/demo-shell trioct render yard --camera 22 -26 12 --look-at -2 4 0 \
    --shade normal --size 800x450 -o "$out"
