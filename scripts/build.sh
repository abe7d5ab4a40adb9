#!/bin/sh
# build.sh DIR [CONFIGURE-ARGS...] - configure gigaview into the build
# directory DIR (out of tree, so several configurations can live side by
# side) and build it.  Reconfigures when arguments are given or the build
# system changed.
set -eu
cd "$(dirname "$0")/.."
top=$(pwd)
dir=$1
shift
if [ ! -x configure ] || [ configure.ac -nt configure ] || [ Makefile.am -nt configure ]; then
    autoreconf -fi
fi
mkdir -p "$dir"
cd "$dir"
if [ ! -f Makefile ] || [ "$#" -gt 0 ] || [ "$top/configure" -nt Makefile ]; then
    "$top/configure" -q "$@"
fi
make -j"$(nproc)"
