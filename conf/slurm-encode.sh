#!/bin/sh
# slurm-encode.sh - encode one image as a Slurm job array of shards, then
# merge them in a dependent job (docs/OPERATIONS.md, "Encoding on many
# machines").
#
#   conf/slurm-encode.sh submit N INPUT STORE [ENCODE OPTIONS...]
#
# submits `sbatch --array=0-(N-1)` of this script in "shard" mode (one
# `gigaview encode --shard I/N` per array task) and a "merge" job that
# runs after every task succeeded (--dependency=afterok).  INPUT, STORE's
# directory and the shard directory must be on a filesystem every node
# sees.  The other two modes are what the jobs run (and what a test runs
# without Slurm, with the variables set by hand):
#
#   SLURM_ARRAY_TASK_ID=I SLURM_ARRAY_TASK_COUNT=N \
#       conf/slurm-encode.sh shard N INPUT STORE [ENCODE OPTIONS...]
#   conf/slurm-encode.sh merge N INPUT STORE
#
# Environment: GIGAVIEW (default: gigaview on PATH), SHARD_DIR (default
# STORE.shards), SBATCH_OPTS (extra sbatch options: partition, account).
# Threads per shard follow --cpus-per-task.
#SBATCH --job-name=gigaview-encode
#SBATCH --cpus-per-task=8
#SBATCH --mem=2G
#SBATCH --time=04:00:00
set -eu
if [ $# -lt 4 ]; then
    echo "usage: $0 submit|shard|merge N INPUT STORE [ENCODE OPTIONS...]" >&2
    exit 2
fi
mode=$1 n=$2 input=$3 store=$4
shift 4
: "${GIGAVIEW:=gigaview}"
: "${SHARD_DIR:=$store.shards}"
case $mode in
submit)
    mkdir -p "$SHARD_DIR"
    # The array runs this script in "shard" mode, the merge job in "merge".
    # shellcheck disable=SC2086 # SBATCH_OPTS is a list of options
    jid=$(sbatch --parsable ${SBATCH_OPTS:-} --array="0-$((n - 1))" \
        --export="ALL,GIGAVIEW=$GIGAVIEW,SHARD_DIR=$SHARD_DIR" \
        "$0" shard "$n" "$input" "$store" "$@")
    # shellcheck disable=SC2086
    sbatch --parsable ${SBATCH_OPTS:-} --dependency="afterok:${jid%%;*}" \
        --cpus-per-task=1 --job-name=gigaview-merge \
        --export="ALL,GIGAVIEW=$GIGAVIEW,SHARD_DIR=$SHARD_DIR" \
        "$0" merge "$n" "$input" "$store"
    ;;
shard)
    i=${SLURM_ARRAY_TASK_ID:?not running as an array task}
    if [ "${SLURM_ARRAY_TASK_COUNT:-$n}" != "$n" ]; then
        echo "$0: the array has ${SLURM_ARRAY_TASK_COUNT} tasks, not $n" >&2
        exit 2
    fi
    mkdir -p "$SHARD_DIR"
    exec "$GIGAVIEW" encode --quiet --shard "$i/$n" \
        -j "${SLURM_CPUS_PER_TASK:-1}" "$@" -o "$SHARD_DIR/$i.gvshard" "$input"
    ;;
merge)
    set --
    i=0
    while [ "$i" -lt "$n" ]; do
        set -- "$@" "$SHARD_DIR/$i.gvshard"
        i=$((i + 1))
    done
    "$GIGAVIEW" merge -o "$store" "$@"
    rm -f "$@"
    rmdir "$SHARD_DIR" 2>/dev/null || true
    ;;
*)
    echo "$0: unknown mode '$mode' (submit, shard or merge)" >&2
    exit 2
    ;;
esac
