#!/bin/sh
# check.sh - the README's second command and what CI runs: install what is
# missing, build with warnings as errors and run the whole test suite, then
# do the same in an AddressSanitizer + UndefinedBehaviorSanitizer build
# (tests/browser_osd.sh drives headless Chromium through npm packages).
set -eu
cd "$(dirname "$0")/.."
scripts/install-deps.sh
# The browser test's playwright-core and openseadragon, exactly as
# tests/browser/package-lock.json pins them (into tests/browser/node_modules).
(cd tests/browser && npm ci --no-audit --no-fund)
for variant in build:--enable-werror build-asan:--enable-sanitizers; do
    dir=${variant%%:*}
    scripts/build.sh "$dir" --enable-werror "${variant#*:}"
    if ! make -C "$dir" -j"$(nproc)" check; then
        cat "$dir/test-suite.log"
        exit 1
    fi
done
echo "check: every test passed in the plain and the ASan+UBSan builds"
