#!/bin/sh
# check.sh - the README's second command and what CI runs: install what is
# missing, build with warnings as errors and run the whole test suite, then
# do the same in an AddressSanitizer + UndefinedBehaviorSanitizer build
# (tests/browser_osd.sh drives headless Chromium through npm packages),
# then build without the GPU (--without-gpu: lib/gpu/poison stops the build
# if anything outside the GPU parts includes an EGL or GL header) and run
# there the tests that cover what such a build does differently.
# scripts/test-times.sh DIR lists the slowest tests of a build's last run:
# make -j2 runs two tests at a time, so the time a test phase takes is
# about half the tests' sum, and a long test late in TESTS makes the tail.
set -eu
cd "$(dirname "$0")/.."
scripts/install-deps.sh
# The browser test's playwright-core and openseadragon, exactly as
# tests/browser/package-lock.json pins them (into tests/browser/node_modules).
(cd tests/browser && npm ci --no-audit --no-fund)
nogpu_tests="tests/test_render tests/test_filter_graph tests/test_edt_cpu \
    tests/http_api.sh tests/http_iiif.sh tests/http_filters.sh tests/client_render.sh \
    tests/fuzz/corpus-worker.sh tests/test_zfield"
for variant in build:--enable-werror build-asan:--enable-sanitizers \
    build-nogpu:--without-gpu; do
    dir=${variant%%:*}
    # OpenSlide and GDAL are optional to configure, but install-deps.sh
    # installs them: CI builds and tests their readers, never skips them.
    scripts/build.sh "$dir" --enable-werror --with-openslide --with-gdal \
        "${variant#*:}"
    tests=
    [ "$dir" = build-nogpu ] && tests="TESTS=$nogpu_tests"
    if ! make -C "$dir" -j"$(nproc)" check ${tests:+"$tests"}; then
        cat "$dir/test-suite.log"
        exit 1
    fi
done
echo "check: every test passed in the plain and the ASan+UBSan builds, and" \
    "the GPU-less build's subset"
