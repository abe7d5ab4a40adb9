#!/bin/sh
# cli_shard.sh - a sharded encode is bit-identical to a single encode.
#
# A real photograph (tests/data/picos-1100x700.jpg) is encoded whole, then
# as 2, 3 and 4 shards run as concurrent local processes and merged (the
# shard files listed in reverse order): each merged store must equal the
# whole one byte for byte (the default mode: one slope for the whole
# image, from a model of every row, which every shard reads).  The same
# for the per-tile mode (--min-tile-psnr) on a PNG, for a multi-page
# gray image, for an uncompressed tiled TIFF (whose level 0 shards read
# again from the file) and for an image that is all root.  The merge must refuse,
# writing nothing, a missing, duplicated, foreign or damaged shard; a
# killed shard leaves no file.  conf/slurm-encode.sh (its shard and merge
# modes, as the array tasks run them) and conf/parallel-encode.sh (when
# GNU parallel is installed) must give the same store too.  Under
# valgrind (make check VALGRIND=1) only the 2-shard, per-tile and failure
# cases run: every encode is some 40 times slower there.
. "$(dirname "$0")/lib.sh"

src="$TESTDATA/picos-1100x700.jpg"
d="$T/d"
mkdir "$d" || bail "mkdir"

# shards N OUT SRC [OPTIONS...]: encode SRC as N concurrent shard processes
# into OUT.shards/, merge them (last shard first) into OUT.  Sets $why.
shards() {
    n=$1 out=$2 in=$3
    shift 3
    mkdir -p "$out.shards"
    pids=
    i=0
    while [ "$i" -lt "$n" ]; do
        gv encode --quiet -j 1 --shard "$i/$n" "$@" "$in" \
            -o "$out.shards/$i.gvshard" 2>"$out.shards/$i.err" &
        pids="$pids $!"
        i=$((i + 1))
    done
    why=
    for p in $pids; do
        wait "$p" || why="a shard failed: $(cat "$out.shards"/*.err)"
    done
    [ -z "$why" ] || return 1
    list=
    i=$((n - 1))
    while [ "$i" -ge 0 ]; do
        list="$list $out.shards/$i.gvshard"
        i=$((i - 1))
    done
    # shellcheck disable=SC2086 # one word per shard file, no spaces in $T
    gv merge --quiet -o "$out" $list 2>"$out.merge.err" ||
        { why="merge failed: $(cat "$out.merge.err")"; return 1; }
}

# same DESCRIPTION A B: A and B are byte-identical stores.
same() {
    if cmp "$2" "$3" >/dev/null 2>&1; then ok "$1"; else
        not_ok "$1" "$why" "$(cmp "$2" "$3" 2>&1)"; fi
}

run encode --quiet -j 2 "$src" -o "$d/whole.gv"
expect_rc "single encode of $src" 0
counts="2 3 4"
under_valgrind && counts=2
for n in $counts; do
    why=
    shards "$n" "$d/m$n.gv" "$src"
    same "$n shards merged = single encode, byte for byte" "$d/whole.gv" "$d/m$n.gv"
done
run info "$d/m2.gv"
expect_rc "the merged store validates (gigaview info)" 0

# --rd names the default mode: the same store.
run encode --quiet -j 1 --rd "$src" -o "$d/rd.gv"
expect_rc "encode --rd" 0
same "--rd = the default mode, byte for byte" "$d/whole.gv" "$d/rd.gv"

# The per-tile mode: each tile's rate from its own target alone.
run encode --quiet -j 2 --min-tile-psnr 33 "$TESTDATA/seeding-700x520.png" -o "$d/pt.gv"
expect_rc "single --min-tile-psnr encode" 0
shards 3 "$d/pt3.gv" "$TESTDATA/seeding-700x520.png" --min-tile-psnr 33
same "--min-tile-psnr, 3 shards = single encode" "$d/pt.gv" "$d/pt3.gv"

# Several pages per level and 5 levels, gray, more shards than cores.
if ! under_valgrind; then
    run encode --quiet -j 2 synth:4700x1100:gray -o "$d/gray.gv"
    expect_rc "single encode of a 4700x1100 gray image" 0
    shards 5 "$d/gray5.gv" synth:4700x1100:gray
    same "multi-page gray, 5 shards = single encode" "$d/gray.gv" "$d/gray5.gv"
fi

# An uncompressed tiled TIFF: shards read level 0 again from it in pass 2
# (lib/imageio/raw_regions.c) instead of a scratch copy; the whole encode
# keeps it in memory.  Two pages of level 0 (4700 wide).
if command -v tiffcp >/dev/null 2>&1; then
    gv encode --quiet -q 30 synth:4700x900 -o "$d/raw-src.gv" &&
        gv export "$d/raw-src.gv" -o "$d/raw-src.tif" &&
        tiffcp -c none -t -w 128 -l 64 "$d/raw-src.tif" "$d/raw.tif" ||
        bail "cannot make an uncompressed tiled TIFF"
    run encode --quiet -j 2 "$d/raw.tif" -o "$d/raw.gv"
    expect_rc "single encode of an uncompressed tiled TIFF" 0
    shards 3 "$d/raw3.gv" "$d/raw.tif"
    same "uncompressed tiled TIFF read again, 3 shards = single encode" \
        "$d/raw.gv" "$d/raw3.gv"
else
    skip "tiffcp (libtiff-tools) is not installed"
fi

# An image that fits the root: no tiles at all.
run encode --quiet "$TESTDATA/seeding-300x200-striped.tif" -o "$d/small.gv"
shards 2 "$d/small2.gv" "$TESTDATA/seeding-300x200-striped.tif"
same "all-root image, 2 shards = single encode" "$d/small.gv" "$d/small2.gv"

# More shards than level-0 tiles (6): the extra shards are empty.
if ! under_valgrind; then
    shards 8 "$d/m8.gv" "$src"
    same "8 shards of a 6-tile image = single encode" "$d/whole.gv" "$d/m8.gv"
fi

# ---- the merge refuses what does not belong together, writing nothing
s="$d/m2.gv.shards"
run merge -o "$d/bad.gv" "$s/0.gvshard"
expect_rc "merge with a shard missing fails" 1
expect_err_is "... and says how many were expected" \
    "gigaview merge: merge: $s/0.gvshard is shard 0 of 2, but 1 shard files were given"
run merge -o "$d/bad.gv" "$s/0.gvshard" "$s/0.gvshard"
expect_rc "merge with a shard given twice fails" 1
expect_err_is "... and names it" "gigaview merge: merge: shard 0/2 is given twice ($s/0.gvshard)"
gv encode --quiet --shard 1/3 "$src" -o "$d/n3.gvshard" 2>/dev/null
run merge -o "$d/bad.gv" "$s/0.gvshard" "$d/n3.gvshard"
expect_rc "merge with a shard of another count fails" 1
expect_err_is "... as coming from another shard count" \
    "gigaview merge: merge: $s/0.gvshard and $d/n3.gvshard come from different images, options or shard counts"
gv encode --quiet --shard 1/2 -q 30 "$src" -o "$d/q30.gvshard" 2>/dev/null
run merge -o "$d/bad.gv" "$s/0.gvshard" "$d/q30.gvshard"
expect_rc "merge with a shard encoded at another -q fails" 1
expect_err_is "... as coming from different options" \
    "gigaview merge: merge: $s/0.gvshard and $d/q30.gvshard come from different images, options or shard counts"
cp "$s/1.gvshard" "$d/damaged.gvshard"
size=$(wc -c <"$d/damaged.gvshard")
# Flip a byte in the last tile buffer (records are at the end).
printf '\377' | dd of="$d/damaged.gvshard" bs=1 seek=$((size - 100)) conv=notrunc 2>/dev/null
run merge -o "$d/bad.gv" "$s/0.gvshard" "$d/damaged.gvshard"
expect_rc "merge with a damaged shard fails" 1
expect_err_is "... on its CRC" "gigaview merge: shard: $d/damaged.gvshard: tile 0/2/1 fails its CRC"
run merge -o "$d/bad.gv" "$d/whole.gv" "$s/1.gvshard"
expect_rc "a store is not a shard file" 1
expect_err_is "... and is named" "gigaview merge: shard: $d/whole.gv is not a shard file"
check "no store was written by any failed merge" test ! -e "$d/bad.gv"
cp "$d/whole.gv" "$d/keep.gv"
run merge -o "$d/keep.gv" "$s/0.gvshard"
check "a failed merge leaves an existing store as it was" cmp "$d/whole.gv" "$d/keep.gv"

# ---- bad --shard values; a size whose last tile needs the half-tiles rule
for bad in 3/3 -1/2 1/0 x 2 1/2/3; do
    run encode --shard "$bad" "$src" -o "$d/x.gvshard"
    expect_rc "--shard $bad is a usage error" 2
done
# 1026 wide: 3 level-0 tiles over a 513-wide level, which has 2 tiles
# (docs/FORMAT.md: a level has at least half the tiles of the level below).
run encode --quiet synth:1026x600 -o "$d/odd.gv"
expect_rc "single encode of a 1026x600 image" 0
shards 3 "$d/odd3.gv" synth:1026x600
same "1026 wide, 3 shards = single encode" "$d/odd.gv" "$d/odd3.gv"

# ---- a killed shard leaves nothing (the file is published atomically)
if ! under_valgrind; then
    # Large enough that 1 s is early in it (a 6000 x 6000 shard once took
    # longer than that; it now finishes first on a fast, idle machine).
    # Should it still finish first, its file must be whole.
    mkdir "$d/k"
    "$GIGAVIEW" encode --quiet --shard 0/2 synth:12000x12000 -o "$d/k/0.gvshard" \
        2>/dev/null &
    pid=$!
    sleep 1
    kill -KILL "$pid" 2>/dev/null
    status=0
    wait "$pid" 2>/dev/null || status=$?
    if [ "$status" -eq 137 ]; then
        check "a shard killed after 1 s leaves no file" test -z "$(listing "$d/k")"
    else
        check "a shard that finished before the kill (exit $status) left its whole file" \
            sh -c "test '$status' -eq 0 && test '$(listing "$d/k")' = 0.gvshard"
    fi
fi

# ---- the Slurm script's modes, as the array tasks and the merge job run them
conf="${top_srcdir:-$(dirname "$0")/..}/conf"
i=0
why=
while [ "$i" -lt 3 ]; do
    SLURM_ARRAY_TASK_ID=$i SLURM_ARRAY_TASK_COUNT=3 GIGAVIEW="$GIGAVIEW" \
        sh "$conf/slurm-encode.sh" shard 3 "$src" "$d/slurm.gv" >/dev/null 2>"$T/err" ||
        why="shard $i: $(cat "$T/err")"
    i=$((i + 1))
done
GIGAVIEW="$GIGAVIEW" sh "$conf/slurm-encode.sh" merge 3 "$src" "$d/slurm.gv" \
    >/dev/null 2>"$T/err" || why="$why merge: $(cat "$T/err")"
same "conf/slurm-encode.sh shard x3 + merge = single encode" "$d/whole.gv" "$d/slurm.gv"
check "conf/slurm-encode.sh removed its shard files" test ! -e "$d/slurm.gv.shards"

if command -v parallel >/dev/null 2>&1; then
    why=
    GIGAVIEW="$GIGAVIEW" sh "$conf/parallel-encode.sh" 4 "$src" "$d/par.gv" -j 1 \
        >/dev/null 2>"$T/err" || why=$(cat "$T/err")
    same "conf/parallel-encode.sh with 4 shards = single encode" "$d/whole.gv" "$d/par.gv"
else
    skip "conf/parallel-encode.sh" "GNU parallel is not installed"
fi

done_testing
