#!/bin/sh
# Runs a command inside a private network and pid namespace with multicast routed over the
# loopback only: LCM's udpm traffic cannot leave the machine, and every process the command
# starts (a daemon a failed test left behind) dies with the namespace.
#   tests/e2e/netns.sh CMD [ARGS...]
set -eu
if [ "$(id -u)" -ne 0 ] || ! command -v unshare >/dev/null 2>&1; then
    echo "netns.sh: needs root and unshare(1) to make a private network namespace" >&2
    exit 77
fi
exec unshare -n -p -f --mount-proc sh -c \
    'ip link set lo up && ip route add 224.0.0.0/4 dev lo && exec "$@"' netns "$@"
