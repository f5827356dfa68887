#!/bin/sh
# The peer benchmark's libraries: Embree 3 and FCL, Debian packages that only
# build/bench/peers/bench_peers links (never the product). Exits 0 when they are installed,
# installing them first when run as root; 3 when they are missing and this is not root,
# after printing the apt-get line (the caller then skips the peer benchmark); otherwise
# apt-get's own failure.
set -eu
PACKAGES="libembree-dev libfcl-dev"

missing=""
for p in $PACKAGES; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
[ -z "$missing" ] && exit 0

if [ "$(id -u)" -ne 0 ]; then
    echo "bench_peers: missing Debian packages; the peer benchmark is skipped. Install them with:" >&2
    echo "  sudo apt-get update && sudo apt-get install -y$missing" >&2
    exit 3
fi
echo "bench_peers: installing$missing" >&2
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends$missing >/dev/null
