#!/bin/bash
# encode-speed.sh: wall-clock encode speed of gigaview against vips dzsave,
# on the same inputs in the same run.
#
#   bench/encode-speed.sh [--gigaview PATH] [--baseline PATH] [IMAGE...]
#
#   anchor:   vips dzsave IMAGE OUT.zip --container zip --suffix .jpg[Q=85]
#   measured: gigaview encode IMAGE -o OUT.gv          (default settings)
#
# Both use every core, both read and decode the input themselves, and both
# write their output into the same scratch directory. Each command runs REPS
# times (default 3), alternating between the two, and the best (least) wall
# time is kept. Speeds are source megapixels per
# second of wall time; the least CPU time (user + system) of each is
# printed too, since on a shared machine it moves less than wall time.
# Dirty pages are flushed (sync) before each timed command.
# Peak RSS (maximum resident set, from GNU time) is
# printed for both tools, the largest over the runs. With --baseline, an
# older gigaview binary runs too, in the same alternation, and its speed
# and RSS are printed beside the new one's (before/after in one run); the
# two stores are compared byte for byte. Nothing is asserted: the script
# only reports.
#
# Environment:
#   GIGAVIEW=PATH   binary (default: ../gigaview next to bench/, or on PATH)
#   QUICK=1         two inputs only (one photo and the 58 MP relief), 3 reps
#   REPS=N          repetitions per command (default 3)
#   MOSAIC=1        add a 4x4 mosaic of one photo (214 MP, built once as an
#                   uncompressed tiled TIFF in the scratch directory; both
#                   tools read the same file)
#   MOSAIC=NxM      the same with N x M copies (10x8: 1.07 gigapixels)
#   THREADS=N       N threads for each tool instead of every core: -j N for
#                   gigaview (new and baseline), VIPS_CONCURRENCY=N for vips
#                   (THREADS=1 with REPS=5: the one-thread CPU comparison)
#   TMPDIR=DIR      scratch space (default /tmp)
set -euo pipefail

. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

bench_args "$@"

need_cmd vips libvips-tools
need_cmd vipsheader libvips-tools
[ -x /usr/bin/time ] || die "needs GNU time (/usr/bin/time, Debian package time) for peak RSS"
GV_SRC=$(find_gigaview "$gv_arg")
QUICK=${QUICK:-0}
REPS=${REPS:-3}
MOSAIC=${MOSAIC:-0}
THREADS=${THREADS:-}
gv_threads=()
vips_env=()
if [ -n "$THREADS" ]; then
	[[ $THREADS =~ ^[1-9][0-9]*$ ]] || die "THREADS must be a positive integer"
	gv_threads=(-j "$THREADS")
	vips_env=(env "VIPS_CONCURRENCY=$THREADS")
fi

P=$DATA_DIR/photos
LARGE=$DATA_DIR/large/marble-srtm-relief-10800x5400.png
if [ ${#inputs[@]} -eq 0 ]; then
	if [ "$QUICK" = 1 ]; then
		inputs=("$P/Dragonfly_by_Bolly.jpg" "$LARGE")
	else
		inputs=("$P/seeding_by_Clements_Engelhardt.jpg" "$P/Dragonfly_by_Bolly.jpg"
			"$P/sunset_by_Aitzol_Berasategi.jpg" "$P/Bridge_by_Sander_Klootwijk.jpg"
			"$P/Wine_by_Jakkub_Mede.jpg" "$P/picosdeeuropa_by_Aitzol_Berasategi.jpg"
			"$P/butterfly.png" "$P/flowers.png" "$LARGE")
	fi
fi
for f in "${inputs[@]}"; do [ -r "$f" ] || die "cannot read input $f"; done

work=$(mktemp -d "${TMPDIR:-/tmp}/gv-speed.XXXXXX")
trap 'rm -rf "$work"' EXIT INT TERM
GV=$(snapshot_gigaview "$GV_SRC" "$work")
BASE=""
if [ -n "$base_arg" ]; then
	mkdir -p "$work/baseline"
	BASE=$(snapshot_gigaview "$base_arg" "$work/baseline")
fi

if [ "$MOSAIC" != 0 ]; then
	case $MOSAIC in
	1) mx=4 my=4 ;;
	*x*) mx=${MOSAIC%x*} my=${MOSAIC#*x} ;;
	*) die "MOSAIC must be 0, 1 or NxM" ;;
	esac
	m=$work/mosaic-${mx}x${my}-Dragonfly.tif
	echo "# building $m (${mx}x${my} copies of Dragonfly_by_Bolly.jpg)" >&2
	d=$P/Dragonfly_by_Bolly.jpg
	list=$(for ((i = 0; i < mx * my; i++)); do printf '%s ' "$d"; done)
	vips arrayjoin "$list" "${m}[tile,bigtiff]" --across "$mx"
	inputs+=("$m")
fi

# time_cmd: runs "$@" once and prints the wall time in seconds, the peak
# RSS in MiB and the CPU time (user + system) in seconds.
time_cmd() {
	local t0 t1 rss
	# The previous command's output (vips' zip, a store, a 4 GB scratch
	# file) written back first, outside the timing: at 1 GP the kernel's
	# writeback of one tool's output slowed the next by up to 40 %.
	sync
	t0=$(now)
	/usr/bin/time -f '%M %U %S' -o "$work/rss" "$@" >/dev/null 2>&1 || { echo "FAILED: $*" >&2; return 1; }
	t1=$(now)
	read -r rss us ss < <(tail -1 "$work/rss")
	awk -v a="$t0" -v b="$t1" -v r="$rss" -v u="$us" -v s="$ss" \
		'BEGIN { printf "%.3f %.0f %.2f\n", b - a, r / 1024, u + s }'
}
maxof() { printf '%s\n' "$@" | sort -g | tail -1; }

# best of a list of numbers
best() { printf '%s\n' "$@" | sort -g | head -1; }

echo "# gigaview encode speed vs vips dzsave (same inputs, same run)"
echo "# $(date '+%F %T %Z'); $(machine_line)"
echo "# $(describe_build "$GV_SRC")"
echo "# vips $(vips --version | awk '{print $1}' | sed 's/^vips-//'); anchor: vips dzsave IN OUT.zip --container zip --suffix '.jpg[Q=85]'"
threads_desc="every CPU"
[ -n "$THREADS" ] && threads_desc="-j $THREADS; vips with VIPS_CONCURRENCY=$THREADS"
echo "# gigaview: encode IN -o OUT.gv (defaults: -q 40 whole-image PSNR, -r 10, $threads_desc); best of $REPS wall-clock runs each, alternating"
echo "# MP/s = source megapixels / best wall time (decode of the input included for both);"
echo "# bpp = output bytes * 8 / source pixels (zip of every JPEG tile level; store of every level);"
echo "#   the two run at different qualities (JPEG Q85 vs -q 40), so the bpp columns are not a rate-distortion comparison"

[ -n "$BASE" ] && echo "# baseline: $(describe_build "$base_arg")"
echo "# RSS = peak resident set in MiB (GNU time), the largest over the runs"
echo

fmt='%-34s %7s %7s %8s %7s %7s %8s %7s %8s\n'
printf "$fmt" input MP "vips s" "vips" "vips" "gv s" "gv" "gv" "gv/vips"
printf "$fmt" "" "" "(best)" "MP/s" "RSS" "(best)" "MP/s" "RSS" "speed"
if [ -n "$BASE" ]; then
	bfmt='%-34s %7s %7s %8s %7s %8s %10s\n'
	base_lines=("$(printf "$bfmt" input MP "base s" "base" "base" "base/vips" "new/base")"
		"$(printf "$bfmt" "" "" "(best)" "MP/s" "RSS" "speed" "speed")")
fi
tot_mp=0 tot_v=0 tot_g=0 tot_b=0
bpp_lines=()
cpu_lines=()
for f in "${inputs[@]}"; do
	w=$(img_w "$f"); h=$(img_h "$f"); b=$(img_bands "$f")
	mp=$(awk -v w="$w" -v h="$h" 'BEGIN { printf "%.2f", w * h / 1e6 }')
	tv=(); tg=(); tb=(); rv=(); rg=(); rb=(); cv=(); cg=(); cb=()
	for ((r = 0; r < REPS; r++)); do
		rm -rf "$work/dz" "$work/dz.zip" "$work/out.gv" "$work/base.gv"
		read -r t m u < <(time_cmd "${vips_env[@]}" vips dzsave "$f" "$work/dz.zip" --container zip --suffix '.jpg[Q=85]')
		tv+=("$t"); rv+=("$m"); cv+=("$u")
		read -r t m u < <(time_cmd "$GV" encode "$f" -o "$work/out.gv" "${gv_threads[@]}" --quiet)
		tg+=("$t"); rg+=("$m"); cg+=("$u")
		if [ -n "$BASE" ]; then
			read -r t m u < <(time_cmd "$BASE" encode "$f" -o "$work/base.gv" "${gv_threads[@]}" --quiet)
			tb+=("$t"); rb+=("$m"); cb+=("$u")
		fi
	done
	zip=$work/dz.zip; [ -f "$zip" ] || zip=$work/dz
	vb=$(stat -c %s "$zip"); gb=$(stat -c %s "$work/out.gv")
	bv=$(best "${tv[@]}"); bg=$(best "${tg[@]}")
	read -r sv sg ratio < <(awk -v mp="$mp" -v v="$bv" -v g="$bg" \
		'BEGIN { printf "%.1f %.1f %.2f\n", mp / v, mp / g, (mp / g) / (mp / v) }')
	name=$(basename "$f")
	[ "$b" = 1 ] && name="$name (gray)"
	printf "$fmt" "${name:0:34}" "$mp" "$bv" "$sv" "$(maxof "${rv[@]}")" "$bg" "$sg" "$(maxof "${rg[@]}")" "${ratio}x"
	bcv=$(best "${cv[@]}"); bcg=$(best "${cg[@]}")
	cpu_lines+=("$(printf '%-34s %7s %8s %8s %8s' "${name:0:34}" "$mp" "$bcv" "$bcg" \
		"$(awk -v v="$bcv" -v g="$bcg" 'BEGIN { printf "%.2fx", v / g }')")$( [ -z "$BASE" ] || \
		awk -v b="$(best "${cb[@]}")" -v g="$bcg" 'BEGIN { printf " %8s %9.2fx", b, b / g }')")
	if [ -n "$BASE" ]; then
		bb=$(best "${tb[@]}")
		same=identical; cmp -s "$work/out.gv" "$work/base.gv" || same=DIFFERENT
		read -r sb rbv rnb < <(awk -v mp="$mp" -v v="$bv" -v b="$bb" -v g="$bg" \
			'BEGIN { printf "%.1f %.2f %.2f\n", mp / b, v / b, b / g }')
		base_lines+=("$(printf "$bfmt" "${name:0:34}" "$mp" "$bb" "$sb" "$(maxof "${rb[@]}")" "${rbv}x" "${rnb}x") stores $same")
		tot_b=$(awk -v a="$tot_b" -v b="$bb" 'BEGIN { print a + b }')
	fi
	bpp_lines+=("$(printf '%-34s %7s %10s %10s' "${name:0:34}" "$mp" \
		"$(awk -v s="$vb" -v w="$w" -v h="$h" 'BEGIN { printf "%.3f", s * 8 / (w * h) }')" \
		"$(awk -v s="$gb" -v w="$w" -v h="$h" 'BEGIN { printf "%.3f", s * 8 / (w * h) }')")")
	tot_mp=$(awk -v a="$tot_mp" -v b="$mp" 'BEGIN { print a + b }')
	tot_v=$(awk -v a="$tot_v" -v b="$bv" 'BEGIN { print a + b }')
	tot_g=$(awk -v a="$tot_g" -v b="$bg" 'BEGIN { print a + b }')
done
read -r sv sg ratio < <(awk -v mp="$tot_mp" -v v="$tot_v" -v g="$tot_g" \
	'BEGIN { printf "%.1f %.1f %.2f\n", mp / v, mp / g, (mp / g) / (mp / v) }')
printf "$fmt" "TOTAL (sum MP / sum best s)" "$(printf %.1f "$tot_mp")" "$(printf %.2f "$tot_v")" "$sv" "" \
	"$(printf %.2f "$tot_g")" "$sg" "" "${ratio}x"
echo
echo "gigaview / vips dzsave speed, all inputs: ${ratio}x  (gigaview $sg MP/s, vips dzsave $sv MP/s)"
if [ -n "$BASE" ]; then
	echo
	printf '%s\n' "${base_lines[@]}"
	awk -v mp="$tot_mp" -v v="$tot_v" -v b="$tot_b" -v g="$tot_g" 'BEGIN {
		printf "baseline / vips dzsave speed, all inputs: %.2fx (baseline %.1f MP/s); new / baseline: %.2fx\n",
			v / b, mp / b, b / g }'
fi
echo
printf '%-34s %7s %8s %8s %8s' "CPU seconds (user + sys, least)" MP vips gv gv/vips
[ -n "$BASE" ] && printf ' %8s %10s' base new/base
echo
printf '%s\n' "${cpu_lines[@]}"
echo "context only (other input): CODEC-NOTES quotes vips dzsave JPEG Q85 into one .zip at 59 MP/s on a 264 MP mosaic."
echo
printf '%-34s %7s %10s %10s\n' "output size" MP "vips bpp" "gv bpp"
printf '%s\n' "${bpp_lines[@]}"
