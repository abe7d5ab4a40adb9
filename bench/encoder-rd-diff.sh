#!/bin/bash
# encoder-rd-diff.sh: does an encoder change cost rate-distortion?  Encodes
# each image with two gigaview binaries at several -q and prints, per image
# and -q, both stores' bytes and level-0 PSNR (as `gigaview encode` reports
# it, against the source), then each image's PSNR difference at equal bytes:
# the new point against the old curve, interpolated linearly in
# log(bytes), averaged over the new points inside the old curve's range.
#
#   bench/encoder-rd-diff.sh --baseline OLD [--gigaview NEW] [IMAGE...]
#
# Default images: the five of rate-distortion.sh, at full size.
# Environment: QS="30 34 38 42" (the -q values), TMPDIR.
# Nothing is asserted: the script only reports.
set -euo pipefail

. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

bench_args "$@"
[ -n "$base_arg" ] || die "needs --baseline OLD_BINARY"
need_cmd python3 python3
GV=$(find_gigaview "$gv_arg")
QS=${QS:-30 34 38 42}
P=$DATA_DIR/photos
if [ ${#inputs[@]} -eq 0 ]; then
	inputs=("$P/Dragonfly_by_Bolly.jpg" "$P/picosdeeuropa_by_Aitzol_Berasategi.jpg"
		"$P/sunset_by_Aitzol_Berasategi.jpg" "$P/seeding_by_Clements_Engelhardt.jpg"
		"$P/flowers.png")
fi
work=$(mktemp -d "${TMPDIR:-/tmp}/gv-rddiff.XXXXXX")
trap 'rm -rf "$work"' EXIT INT TERM
printf 'image\tq\told_bytes\told_psnr\tnew_bytes\tnew_psnr\n' > "$work/points.tsv"
for img in "${inputs[@]}"; do
	name=$(basename "$img")
	for q in $QS; do
		row="$name	$q"
		for bin in "$base_arg" "$GV"; do
			"$bin" encode -q "$q" "$img" -o "$work/x.gv" > "$work/out.txt" 2>&1 ||
				die "encode failed: $bin $img -q $q"
			psnr=$(awk '$1 == "psnr" { print $2 }' "$work/out.txt")
			row="$row	$(stat -c %s "$work/x.gv")	$psnr"
		done
		echo "$row" >> "$work/points.tsv"
	done
done
column -t -s "$(printf '\t')" "$work/points.tsv"
python3 - "$work/points.tsv" <<'PY'
import math, sys
rows = [l.rstrip("\n").split("\t") for l in open(sys.argv[1])][1:]
imgs = {}
for r in rows:
    imgs.setdefault(r[0], []).append(tuple(map(float, r[2:])))
deltas = []
for name, pts in imgs.items():
    old = sorted((math.log(b), p) for b, p, _, _ in pts)
    ds = []
    for _, _, nb, np_ in pts:
        x = math.log(nb)
        for (x0, p0), (x1, p1) in zip(old, old[1:]):
            if x0 <= x <= x1 and x1 > x0:
                ds.append(np_ - (p0 + (p1 - p0) * (x - x0) / (x1 - x0)))
                break
    if ds:
        d = sum(ds) / len(ds)
        deltas.append(d)
        print("%-45s new - old at equal bytes: %+.3f dB (%d points)" % (name, d, len(ds)))
if deltas:
    print("mean over images: %+.3f dB" % (sum(deltas) / len(deltas)))
PY
