#!/bin/sh
# corpus-access-policy.sh - replays the fuzz_access_policy seed corpus (tests/fuzz/corpus/access_policy)
# through run_fuzz_access_policy, the libFuzzer target built with a plain main()
# (run_corpus.c).  TAP; under valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_access_policy" \
    "$srcdir/tests/fuzz/corpus/access_policy"
