#!/bin/sh
# Regenerates the replay logs into DIR (tests/logs, for `make logs`): the scene, its meshes
# and the request logs from trioct-make-logs, then each golden log recorded by trioct-replay
# from its request log against the daemon. NAME.lcmlog replays against NAME.ini when there
# is one, else scene.ini. Every step is deterministic, so DIR comes out byte for byte the
# same on every run, machine and thread count; tests/test_replay.c checks that it does.
#   tools/replay/make_logs.sh BUILD DIR
set -eu
if [ $# -ne 2 ]; then
    echo "usage: $0 BUILD DIR" >&2
    exit 2
fi
build=$1
dir=$2
"$build/trioct-make-logs" "$dir"
for log in "$dir"/*.lcmlog; do
    case $log in
    *.golden.lcmlog) continue ;;
    esac
    name=$(basename "$log" .lcmlog)
    scene=$dir/scene.ini
    if [ -f "$dir/$name.ini" ]; then
        scene=$dir/$name.ini
    fi
    "$build/trioct-replay" record --quiet --threads 4 --daemon "$build/trioctd" --scene "$scene" \
        "$log" -o "$dir/$name.golden.lcmlog"
done
