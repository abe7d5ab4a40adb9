#!/bin/sh
# install-deps.sh - install the Debian 12 packages gigaview builds, tests and
# runs with.  Installs only what is missing; needs root (or sudo).
set -eu

PACKAGES="build-essential autoconf automake libtool pkg-config
  libmicrohttpd-dev libopenimageio-dev openimageio-tools libjansson-dev
  libegl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri zlib1g-dev libwebp-dev
  libcurl4-openssl-dev time valgrind python3
  chromium nodejs"

missing=""
for p in $PACKAGES; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" ||
        missing="$missing $p"
done
# npm for the browser test (tests/browser): Debian's nodejs comes without
# it, but a nodejs that bundles its own (NodeSource's) conflicts with
# Debian's npm package, so ask for it only when there is no npm at all.
command -v npm >/dev/null 2>&1 || missing="$missing npm"
[ -z "$missing" ] && exit 0

SUDO=""
if [ "$(id -u)" != 0 ]; then
    command -v sudo >/dev/null 2>&1 || {
        echo "install-deps: need root or sudo to install:$missing" >&2
        exit 1
    }
    SUDO=sudo
fi
echo "install-deps: installing$missing"
$SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -q
# shellcheck disable=SC2086
$SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $missing
