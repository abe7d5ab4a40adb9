#!/bin/sh
# demo.sh - the README's first command: install what is missing, build into
# build/, encode the sample photograph into stores/, describe the store and
# serve it with gigaviewd on 127.0.0.1 (PORT, default 8080) until Ctrl-C.
set -eu
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh build
mkdir -p stores
[ -f stores/seeding.gv ] ||
    build/gigaview encode samples/seeding_by_Clements_Engelhardt.jpg -o stores/seeding.gv
build/gigaview info stores/seeding.gv
port=${PORT:-8080}
echo
echo "gigaview: serving stores/ at http://127.0.0.1:$port/"
echo "  image list    http://127.0.0.1:$port/v1/images"
echo "  IIIF          http://127.0.0.1:$port/iiif/3/seeding/info.json"
echo "  a region      http://127.0.0.1:$port/iiif/3/seeding/full/1024,/0/default.jpg"
echo "  filters       http://127.0.0.1:$port/v1/filters (the tree's filters/library)"
echo "  (Ctrl-C stops the server)"
exec build/gigaviewd -l 127.0.0.1 -p "$port" -d stores
