#!/bin/sh
# Installs the Debian packages the build needs when run as root; otherwise prints the exact
# apt-get line and fails, so a build never half-works on a machine that lacks them.
#   scripts/deps.sh [PACKAGE...]   the extra packages a target needs too (make fuzz: clang)
set -eu
PACKAGES="$* gcc g++ make pkg-config libcmocka-dev libassimp-dev assimp-testmodels libgmp-dev gnuplot-nox liblcm-dev liblcm-bin libuv1-dev libinih-dev libseccomp-dev libsodium-dev libpng-dev iproute2 util-linux systemd procps groff-base man-db python3 python3-numpy"

missing=""
for p in $PACKAGES; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
[ -z "$missing" ] && exit 0

if [ "$(id -u)" -ne 0 ]; then
    echo "trioct: missing Debian packages. Install them with:" >&2
    echo "  sudo apt-get update && sudo apt-get install -y$missing" >&2
    exit 1
fi
echo "trioct: installing$missing" >&2
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends$missing >/dev/null
