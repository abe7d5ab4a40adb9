#!/bin/sh
# corpus-imageio.sh - replays the fuzz_imageio seed corpus (tests/fuzz/corpus/imageio)
# through run_fuzz_imageio, the libFuzzer target built with a plain main()
# (run_corpus.c).  TAP; under valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_imageio" \
    "$srcdir/tests/fuzz/corpus/imageio"
