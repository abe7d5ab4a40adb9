#!/bin/sh
# corpus-settings.sh - replays the fuzz_settings seed corpus (tests/fuzz/corpus/settings)
# through run_fuzz_settings, the libFuzzer target built with a plain main()
# (run_corpus.c).  TAP; under valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_settings" \
    "$srcdir/tests/fuzz/corpus/settings"
