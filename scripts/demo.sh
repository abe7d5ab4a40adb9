#!/bin/sh
# demo.sh - the README's first command: install what is missing, build into
# build/, encode the sample photograph into stores/ and describe the store.
set -eu
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh build
mkdir -p stores
build/gigaview encode samples/seeding_by_Clements_Engelhardt.jpg -o stores/seeding.gv
build/gigaview info stores/seeding.gv
