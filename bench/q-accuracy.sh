#!/bin/bash
# q-accuracy.sh: how close `gigaview encode -q Q` lands to Q, the level-0
# PSNR it was asked for (docs/FORMAT.md section 8, the "achieved minus
# asked" tables).  Encodes each image at each Q and prints the PSNR the
# encoder reports minus Q; with --baseline, a second binary's figure
# beside it (an encoder change that moves the landing shows here).
#
#   bench/q-accuracy.sh [--gigaview NEW] [--baseline OLD] [IMAGE...]
#
# Default images: the eight photographs of $DATA_DIR/photos, the JPEGs
# halved (vips resize 0.5, lanczos3, as rate-distortion.sh does) and the
# PNGs as they are.  Environment: QS="32 36 40 44 46" (the -q values),
# FULL=1 (the JPEGs at full size, cropped 4 px off the left and top so
# that their 8x8 grid does not line up with the coder's, as rd-anchors.sh
# FULL=1; rows named "/crop4"), TMPDIR.  Nothing is asserted: the script
# only reports.
set -euo pipefail

. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

bench_args "$@"
GV=$(find_gigaview "$gv_arg")
QS=${QS:-32 36 40 44 46}
if [ ${#inputs[@]} -eq 0 ]; then
	for f in "$DATA_DIR"/photos/*.jpg "$DATA_DIR"/photos/*.png; do
		inputs+=("$f")
	done
fi
work=$(mktemp -d "${TMPDIR:-/tmp}/gv-qacc.XXXXXX")
trap 'rm -rf "$work"' EXIT INT TERM

# The PSNR a binary reaches at -q: the summary's "psnr" line.
reached() {
	"$1" encode "$2" -q "$3" -o "$work/s.gv" | sed -n 's/^psnr *\([0-9.]*\) dB.*/\1/p'
}

printf '%-40s %4s %9s %9s' image q reached minus_q
[ -n "$base_arg" ] && printf ' %13s %14s' base_reached base_minus_q
printf '\n'
for img in "${inputs[@]}"; do
	name=$(basename "$img")
	src=$img
	case $img in
	*.jpg|*.jpeg|*.JPG)
		need_cmd vips libvips-tools
		src=$work/${name%.*}-prep.png
		if [ "${FULL:-0}" = 1 ]; then
			vips crop "$img" "${src}[strip,compression=1]" 4 4 \
				$(($(vipsheader -f width "$img") - 4)) $(($(vipsheader -f height "$img") - 4))
			name="$name/crop4"
		else
			vips resize "$img" "${src}[strip,compression=1]" 0.5 --kernel lanczos3
			name="$name/2"
		fi ;;
	esac
	for q in $QS; do
		p=$(reached "$GV" "$src" "$q")
		printf '%-40s %4s %9s %+9.2f' "$name" "$q" "$p" "$(echo "$p - $q" | bc -l)"
		if [ -n "$base_arg" ]; then
			b=$(reached "$base_arg" "$src" "$q")
			printf ' %13s %+14.2f' "$b" "$(echo "$b - $q" | bc -l)"
		fi
		printf '\n'
	done
done
