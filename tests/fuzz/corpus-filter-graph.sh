#!/bin/sh
# corpus-filter-graph.sh - replays the fuzz_filter_graph seed corpus
# (tests/fuzz/corpus/filter_graph: valid graphs, every stock graph's shape
# and hostile documents) through run_fuzz_filter_graph.  TAP.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_filter_graph" \
    "$srcdir/tests/fuzz/corpus/filter_graph"
