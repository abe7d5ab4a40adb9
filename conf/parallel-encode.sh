#!/bin/sh
# parallel-encode.sh - encode one image as N shards with GNU parallel, then
# merge them into a store (docs/OPERATIONS.md, "Encoding on many machines").
#
#   conf/parallel-encode.sh N INPUT STORE [ENCODE OPTIONS...]
#
# Runs `gigaview encode --shard I/N` for I = 0..N-1 with GNU parallel, then
# `gigaview merge`.  The store is byte for byte what `gigaview encode INPUT
# -o STORE` writes.  Shard files go to STORE.shards/ (beside the store, or
# SHARD_DIR) and are removed after a successful merge.
#
# Environment:
#   GIGAVIEW=PATH        the gigaview binary (default: gigaview on PATH)
#   PARALLEL_JOBS=J      shards running at once (default N)
#   PARALLEL_HOSTS=LIST  run on other machines: a --sshlogin list for GNU
#                        parallel ("8/node1,8/node2"); INPUT, STORE's
#                        directory and SHARD_DIR must then be on a shared
#                        filesystem at the same path everywhere
#   SHARD_DIR=DIR        where the shard files go
#
# Pass -j (threads per shard) among the ENCODE OPTIONS: with N shards on
# one machine of C cores, -j C/N.  Every shard must get the same options.
set -eu
if [ $# -lt 3 ]; then
    echo "usage: $0 N INPUT STORE [ENCODE OPTIONS...]" >&2
    exit 2
fi
n=$1 input=$2 store=$3
shift 3
: "${GIGAVIEW:=gigaview}"
: "${PARALLEL_JOBS:=$n}"
: "${SHARD_DIR:=$store.shards}"
mkdir -p "$SHARD_DIR"
# Shard I writes SHARD_DIR/I.gvshard, atomically; -q passes every argument
# through unchanged, and --halt stops the rest as soon as one shard fails.
seq 0 $((n - 1)) | parallel -q --halt now,fail=1 -j "$PARALLEL_JOBS" \
    ${PARALLEL_HOSTS:+-S "$PARALLEL_HOSTS"} \
    "$GIGAVIEW" encode --quiet --shard "{}/$n" "$@" -o "$SHARD_DIR/{}.gvshard" "$input"
# Name every shard explicitly, so that a stale file of another run cannot
# sneak in (the merge would refuse it anyway).
set --
i=0
while [ "$i" -lt "$n" ]; do
    set -- "$@" "$SHARD_DIR/$i.gvshard"
    i=$((i + 1))
done
"$GIGAVIEW" merge -o "$store" "$@"
rm -f "$@"
rmdir "$SHARD_DIR" 2>/dev/null || true
