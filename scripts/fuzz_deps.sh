#!/bin/sh
# What `make fuzz` needs beyond scripts/deps.sh: clang and its libFuzzer runtime. Installs
# them as root; otherwise prints the apt-get line and fails.
set -eu
sh scripts/deps.sh
PACKAGES="clang libclang-rt-dev"
missing=""
for p in $PACKAGES; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
[ -z "$missing" ] && exit 0
if [ "$(id -u)" -ne 0 ]; then
    echo "trioct: make fuzz needs:$missing; install them with:" >&2
    echo "  sudo apt-get update && sudo apt-get install -y$missing" >&2
    exit 1
fi
echo "trioct: installing$missing" >&2
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends$missing >/dev/null
