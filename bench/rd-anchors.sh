#!/bin/bash
# rd-anchors.sh: gigaview against the strongest stores a gigapixel service
# could use instead (JPEG 2000, HTJ2K, AVIF / JPEG XL / WebP / JPEG
# pyramids), on the same images in the same run, summed up as Bjontegaard
# deltas (BD-PSNR, BD-SSIM-Y, BD-rate) of gigaview minus each anchor.
#
#   bench/rd-anchors.sh [--gigaview PATH] [--baseline PATH] [IMAGE...]
#
# Every image (default: the photos in $DATA_DIR/photos) is first made into
# a metadata-free 8-bit RGB PNG that every codec reads and every result is
# compared with. JPEG sources are halved (vips resize 0.5, lanczos3; row
# names end in "/2"): re-encoding a JPEG at full size flatters an 8x8 block
# coder whose blocks line up with the source's. With FULL=1 they are kept at
# full size but cropped 4 px off the left and top, so that the source's 8x8
# grid does not line up with any coder's ("/crop4"). PNG sources are used as
# they are.
#
# Then, per image, bpp = bytes * 8 / pixels of the prepared image:
#   gigaview  encode -q Q, Q in GV_QS; bytes: the whole store (every level,
#             codebooks, root); quality: level 0 exported to PNG.
#   j2k       JPEG 2000, OpenJPEG: opj_compress -I -n 6 -r RATIO (9/7
#             wavelet, 6 resolutions, one layer); one .jp2 holds every
#             resolution, as IIIF servers serve it. Decoded by opj_decompress.
#   htj2k     High-throughput JPEG 2000, OpenJPH: ojph_compress -qstep S
#             -num_decomps 5 on a PPM; a raw .j2c codestream; ojph_expand.
#   avif-pyr  a pyramid of whole-image AVIF files: avifenc -s 6 -y 420
#             --min q --max q (libaom); level 0 decoded by avifdec.
#   jxl-pyr   a pyramid of JPEG XL files: cjxl -d D -e 7; djxl.
#   webp-pyr  a pyramid of WebP files: cwebp -q Q -m 6; dwebp.
#   jpeg-pyr  a pyramid of JPEG files: vips jpegsave --Q Q --optimize-coding
#             (vips' default chroma: 4:2:0 below Q 90, 4:4:4 from 90); djpeg.
# A pyramid's levels are the image and its 2x2 box shrinks (vips shrink 2 2)
# down to the first level whose longer side is under 512 px, i.e. 256..511
# px (where gigaview kept its root before format version 6; its root is
# now at most 128 px, the levels above coded as tiles and counted in its
# bytes); a pyramid's bytes are the sum of one file per
# level (no tiles: no tile overhead, which favours the anchor); its quality
# is level 0's. PSNR is over RGB from the total MSE, SSIM is the mean SSIM
# of BT.601 luma (11x11 Gaussian window); both by bench/imgcompare.c against
# the prepared image.
#
# Finally bench/bd.py prints BD-PSNR, BD-SSIM-Y and BD-rate tables (rows
# images, columns anchors, mean row) and, with PLOT=FILE.png,
# bench/plot-rd.sh draws every curve.
#
# Environment:
#   GIGAVIEW=PATH   binary to measure (or --gigaview PATH); it is copied
#                   first, so a rebuild during the run cannot change it
#   BASELINE=PATH   a second binary (or --baseline PATH), run at the same
#                   -q settings as "gv-base": its column in the BD tables is
#                   the new binary minus the baseline
#   IMAGES="A B"    images (paths, or names in $DATA_DIR/photos); the
#                   arguments, when given, win
#   QUICK=1         2 images, 4 to 7 settings per codec (a few minutes)
#   FULL=1          JPEG sources at full size, cropped 4 px (see above)
#   ANCHORS="j2k htj2k avif-pyr jxl-pyr webp-pyr jpeg-pyr"   which to run
#                   ("none": gigaview alone, e.g. to merge with saved anchor rows)
#   GV_QS, J2K_RATIOS, HTJ2K_QSTEPS, AVIF_QS, JXL_DS, WEBP_QS, JPEG_QS
#                   settings lists (space separated)
#   GV_ARGS         extra options for gigaview encode
#   RESULTS=FILE    copy the table of every point (image codec setting bpp
#                   psnr ssim, tab separated) to FILE
#   BD_TSV=FILE     write every BD cell (bench/bd.py --tsv)
#   PLOT=FILE.png   draw the curves (needs gnuplot)
#   SUMMARIZE=FILE  encode nothing: BD tables (and PLOT) of such a table
#   TMPDIR=DIR      scratch space (default /tmp)
set -euo pipefail

. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

bench_args "$@"
images=(${inputs[@]+"${inputs[@]}"})

need_cmd python3 python3
QUICK=${QUICK:-0}
FULL=${FULL:-0}
: "${ANCHORS:=j2k htj2k avif-pyr jxl-pyr webp-pyr jpeg-pyr}"
for a in $ANCHORS; do
	case $a in j2k|htj2k|avif-pyr|jxl-pyr|webp-pyr|jpeg-pyr|none) ;;
	*) die "unknown anchor $a" ;; esac
done
has() { case " $ANCHORS " in *" $1 "*) return 0 ;; esac; return 1; }
# plot RESULTS OUT TITLE: plot-rd.sh on a log rate axis around gigaview's
# rates (a factor 1.5 beyond them each way), where the BD figures are taken
plot() {
	local r
	r=$(awk -F'\t' '$2 == "gigaview" { if (!n++ || $4 < lo) lo = $4; if ($4 > hi) hi = $4 }
		END { if (n) printf "%.3g %.3g", lo / 1.5, hi * 1.5; else print "0.05 8" }' "$1")
	LOGX=1 XMIN=${XMIN:-${r% *}} XMAX=${XMAX:-${r#* }} "$BENCH_DIR/plot-rd.sh" "$1" "$2" "$3"
}

if [ -n "${SUMMARIZE:-}" ]; then
	[ -r "$SUMMARIZE" ] || die "cannot read $SUMMARIZE"
	python3 "$BENCH_DIR/bd.py" "$SUMMARIZE" ${BD_TSV:+--tsv "$BD_TSV"}
	[ -z "${PLOT:-}" ] || plot "$SUMMARIZE" "$PLOT" "${PLOT_TITLE:-gigaview and the anchors}"
	exit 0
fi

need_cmd vips libvips-tools
need_cmd vipsheader libvips-tools
has j2k && { need_cmd opj_compress libopenjp2-tools; need_cmd opj_decompress libopenjp2-tools; }
has htj2k && { need_cmd ojph_compress openjph-tools; need_cmd ojph_expand openjph-tools; }
has avif-pyr && { need_cmd avifenc libavif-bin; need_cmd avifdec libavif-bin; }
has jxl-pyr && { need_cmd cjxl libjxl-tools; need_cmd djxl libjxl-tools; }
has webp-pyr && { need_cmd cwebp webp; need_cmd dwebp webp; }
has jpeg-pyr && need_cmd djpeg libjpeg-turbo-progs
[ -z "${PLOT:-}" ] || need_cmd gnuplot gnuplot-nox
GV_SRC=$(find_gigaview "$gv_arg")
BASE_SRC=${base_arg:-${BASELINE:-}}
[ -z "$BASE_SRC" ] || [ -x "$BASE_SRC" ] || die "baseline $BASE_SRC is not an executable"

P=$DATA_DIR/photos
if [ ${#images[@]} -eq 0 ] && [ -n "${IMAGES:-}" ]; then
	read -r -a images <<<"$IMAGES"
fi
if [ "$QUICK" = 1 ]; then
	: "${GV_QS:=30 36 42 48}"
	: "${J2K_RATIOS:=5 10 20 40 80 160 320}"
	: "${HTJ2K_QSTEPS:=0.001 0.0025 0.006 0.015 0.04 0.1}"
	: "${AVIF_QS:=4 14 24 34 46}"
	: "${JXL_DS:=0.2 0.5 1.2 2.8 6}"
	: "${WEBP_QS:=20 50 80 95 100}"
	: "${JPEG_QS:=20 50 80 93 99}"
	[ ${#images[@]} -gt 0 ] || images=(picosdeeuropa_by_Aitzol_Berasategi.jpg flowers.png)
else
	: "${GV_QS:=30 33 36 39 42 45 48}"
	: "${J2K_RATIOS:=4 6 10 16 28 50 90 160}"
	: "${HTJ2K_QSTEPS:=0.0015 0.003 0.006 0.012 0.024 0.048 0.1}"
	: "${AVIF_QS:=4 12 20 28 36 46}"
	: "${JXL_DS:=0.2 0.4 0.8 1.5 2.8 5}"
	: "${WEBP_QS:=30 55 75 88 95 100}"
	: "${JPEG_QS:=30 55 75 88 95 99}"
	if [ ${#images[@]} -eq 0 ]; then
		for f in "$P"/*.jpg "$P"/*.png; do images+=("$f"); done
	fi
fi
for i in "${!images[@]}"; do
	f=${images[$i]}
	[ -r "$f" ] || [ ! -r "$P/$f" ] || images[i]=$P/$f
	[ -r "${images[$i]}" ] || die "cannot read image $f"
done

work=$(mktemp -d "${TMPDIR:-/tmp}/gv-rda.XXXXXX")
trap 'rm -rf "$work"' EXIT INT TERM
GV=$(snapshot_gigaview "$GV_SRC" "$work")
BASE=""
if [ -n "$BASE_SRC" ]; then
	mkdir "$work/base"
	BASE=$(snapshot_gigaview "$BASE_SRC" "$work/base")
fi
CMP=$(build_imgcompare "$work")
results=$work/results.tsv   # image codec setting bpp psnr ssim
: >"$results"

echo "# rd-anchors: gigaview vs JPEG 2000, HTJ2K and AVIF / JPEG XL / WebP / JPEG pyramids, same images, same run"
echo "# $(date '+%F %T %Z'); $(machine_line)"
echo "# $(describe_build "$GV_SRC")"
[ -z "$BASE_SRC" ] || echo "# baseline (gv-base rows): $(describe_build "$BASE_SRC")"
# tool_version COMMAND...: the first line of what it prints (stdout or
# stderr), whatever its exit status (some version options exit 1)
tool_version() { { "$@" 2>&1 || true; } | sed -n 1p; }
tools="vips $(vips --version | sed 's/^vips-//')"
has j2k && tools="$tools, OpenJPEG $(dpkg-query -W -f '${Version}' libopenjp2-tools 2>/dev/null || echo '?')"
has htj2k && tools="$tools, OpenJPH $(dpkg-query -W -f '${Version}' openjph-tools 2>/dev/null || echo '?')"
has avif-pyr && tools="$tools, avifenc $(tool_version avifenc --version | sed -n 's/^Version: \([^ ]*\).*aom \[enc\/dec\]:\([^ ,]*\).*/\1 (aom \2)/p')"
has jxl-pyr && tools="$tools, $(tool_version cjxl --version | awk '{print $1, $2}')"
has webp-pyr && tools="$tools, cwebp $(tool_version cwebp -version)"
has jpeg-pyr && tools="$tools, libjpeg-turbo $(dpkg-query -W -f '${Version}' libjpeg62-turbo 2>/dev/null || echo '?')"
echo "# tools: $tools"
echo "# settings: gigaview -q {$GV_QS}; j2k -r {$J2K_RATIOS}; htj2k -qstep {$HTJ2K_QSTEPS}; avif q {$AVIF_QS};"
echo "#   jxl -d {$JXL_DS}; webp -q {$WEBP_QS}; jpeg Q {$JPEG_QS}; anchors: $ANCHORS"
echo "# bpp = bytes * 8 / pixels (whole store / one file / sum of the pyramid's files); PSNR: level 0, RGB; SSIM-Y"
echo

row() {  # image codec setting bytes psnr ssim
	local bpp
	bpp=$(awk -v s="$4" -v p="$px" 'BEGIN { printf "%.4f", s * 8 / p }')
	printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$1" "$2" "$3" "$bpp" "$5" "$6" >>"$results"
	printf '%-30s %-9s %7s %8.3f %8s %7s\n' "${1:0:30}" "$2" "$3" "$bpp" "$5" "$6"
}
# quiet COMMAND...: runs it with its chatter kept aside, shown if it fails
quiet() {
	"$@" >"$work/log" 2>&1 || { cat "$work/log" >&2; die "failed: $*"; }
}
# lap CODEC: prints the seconds since the previous lap, per image and codec
lap() {
	local t
	t=$(now)
	laps="$laps $1 $(awk -v a="$t_lap" -v b="$t" 'BEGIN { printf "%.0f", b - a }')s"
	t_lap=$t
}
cmp_any() {  # TEST-ANY-FORMAT -> "psnr ssim" against $ref
	local t=$1
	case $t in *.ppm|*.pnm) ;; *) to_pnm "$1" "$work/test.ppm"; t=$work/test.ppm ;; esac
	"$CMP" "$ref" "$t" | sed 's/psnr=//; s/ssim=//'
}
# pyr ENC-FUNCTION EXT: bytes of one file per level ($work/lvN.png), level 0
# left in $work/pyr0.EXT
pyr() {
	local total=0 l
	for ((l = 0; l < nlev; l++)); do
		"$1" "$work/lv$l.png" "$work/pyr$l.$2"
		total=$((total + $(stat -c %s "$work/pyr$l.$2")))
	done
	echo "$total"
}
enc_avif() { quiet avifenc -s 6 -y 420 --min "$set" --max "$set" "$1" "$2"; }
enc_jxl() { quiet cjxl "$1" "$2" -d "$set" -e 7; }
enc_webp() { cwebp -quiet -q "$set" -m 6 "$1" -o "$2"; }
enc_jpeg() { vips jpegsave "$1" "$2" --Q "$set" --optimize-coding --strip; }

# gv_series BINARY CODEC: the gigaview rows of one binary for this image
gv_series() {
	for set in $GV_QS; do
		# shellcheck disable=SC2086 # GV_ARGS is a list of options
		"$1" encode "$work/lv0.png" -o "$work/x.gv" -q "$set" --quiet ${GV_ARGS:-}
		quiet "$1" export "$work/x.gv" --level 0 -o "$work/x.png"
		read -r ps ss < <(cmp_any "$work/x.png")
		row "$name" "$2" "q$set" "$(stat -c %s "$work/x.gv")" "$ps" "$ss"
	done
}

printf '%-30s %-9s %7s %8s %8s %7s\n' image codec set bpp "PSNR dB" SSIM-Y
t_start=$(now)
for img in "${images[@]}"; do
	name=$(basename "$img")
	ref=$work/ref.ppm
	case "$FULL:${img,,}" in
	0:*.jpg|0:*.jpeg)
		vips resize "$img" "$work/prep.v" 0.5 --kernel lanczos3
		name="$name/2" ;;
	1:*.jpg|1:*.jpeg)
		vips crop "$img" "$work/prep.v" 4 4 $(($(img_w "$img") - 4)) $(($(img_h "$img") - 4))
		name="$name/crop4" ;;
	*)	vips copy "$img" "$work/prep.v" ;;
	esac
	to_pnm "$work/prep.v" "$ref"
	rm -f "$work/prep.v"
	if [ "$(img_bands "$ref")" = 1 ]; then  # gray: RGB, as every anchor reads it
		vips bandjoin "$ref $ref $ref" "$work/rgb.ppm"
		mv "$work/rgb.ppm" "$ref"
	fi
	w=$(img_w "$ref"); h=$(img_h "$ref"); px=$((w * h))
	# the pyramid levels, lossless PNG without metadata; lv0 is what every codec reads
	vips copy "$ref" "$work/lv0.png[strip,compression=1]"
	nlev=1; lw=$w; lh=$h
	while [ $((lw > lh ? lw : lh)) -ge 512 ]; do
		vips shrink "$work/lv$((nlev - 1)).png" "$work/lv$nlev.png[strip,compression=1]" 2 2
		lw=$(img_w "$work/lv$nlev.png"); lh=$(img_h "$work/lv$nlev.png"); nlev=$((nlev + 1))
	done
	echo "# $name: ${w}x${h}, $(awk -v p="$px" 'BEGIN { printf "%.2f", p / 1e6 }') MP; pyramid anchors: $nlev levels down to ${lw}x${lh}"

	laps=""; t_lap=$(now)
	gv_series "$GV" gigaview
	lap gigaview
	if [ -n "$BASE" ]; then
		gv_series "$BASE" gv-base
		lap gv-base
	fi
	if has j2k; then
		for set in $J2K_RATIOS; do
			quiet opj_compress -i "$ref" -o "$work/x.jp2" -I -n 6 -r "$set"
			quiet opj_decompress -i "$work/x.jp2" -o "$work/x.ppm"
			read -r ps ss < <(cmp_any "$work/x.ppm")
			row "$name" j2k "r$set" "$(stat -c %s "$work/x.jp2")" "$ps" "$ss"
		done
		lap j2k
	fi
	if has htj2k; then
		for set in $HTJ2K_QSTEPS; do
			quiet ojph_compress -i "$ref" -o "$work/x.j2c" -qstep "$set" -num_decomps 5
			quiet ojph_expand -i "$work/x.j2c" -o "$work/x.ppm"
			read -r ps ss < <(cmp_any "$work/x.ppm")
			row "$name" htj2k "s$set" "$(stat -c %s "$work/x.j2c")" "$ps" "$ss"
		done
		lap htj2k
	fi
	if has avif-pyr; then
		for set in $AVIF_QS; do
			bytes=$(pyr enc_avif avif)
			quiet avifdec "$work/pyr0.avif" "$work/x.png"
			read -r ps ss < <(cmp_any "$work/x.png")
			row "$name" avif-pyr "q$set" "$bytes" "$ps" "$ss"
		done
		lap avif-pyr
	fi
	if has jxl-pyr; then
		for set in $JXL_DS; do
			bytes=$(pyr enc_jxl jxl)
			quiet djxl "$work/pyr0.jxl" "$work/x.png"
			read -r ps ss < <(cmp_any "$work/x.png")
			row "$name" jxl-pyr "d$set" "$bytes" "$ps" "$ss"
		done
		lap jxl-pyr
	fi
	if has webp-pyr; then
		for set in $WEBP_QS; do
			bytes=$(pyr enc_webp webp)
			dwebp -quiet -ppm "$work/pyr0.webp" -o "$work/x.ppm"
			read -r ps ss < <(cmp_any "$work/x.ppm")
			row "$name" webp-pyr "Q$set" "$bytes" "$ps" "$ss"
		done
		lap webp-pyr
	fi
	if has jpeg-pyr; then
		for set in $JPEG_QS; do
			bytes=$(pyr enc_jpeg jpg)
			djpeg -pnm -outfile "$work/x.ppm" "$work/pyr0.jpg"
			read -r ps ss < <(cmp_any "$work/x.ppm")
			row "$name" jpeg-pyr "Q$set" "$bytes" "$ps" "$ss"
		done
		lap jpeg-pyr
	fi
	echo "# $name: seconds per codec:$laps"
done
elapsed=$(awk -v a="$t_start" -v b="$(now)" 'BEGIN { printf "%.0f", b - a }')
[ -z "${RESULTS:-}" ] || cp "$results" "$RESULTS"

echo
echo "== bpp range per image and codec (min..max) =="
awk -F'\t' '
	{ k = $1 "\t" $2; if (!(k in lo)) { order[++n] = k; lo[k] = $4; hi[k] = $4; plo[k] = $5; phi[k] = $5 }
	  if ($4 < lo[k]) lo[k] = $4; if ($4 > hi[k]) hi[k] = $4
	  if ($5 < plo[k]) plo[k] = $5; if ($5 > phi[k]) phi[k] = $5 }
	END { for (i = 1; i <= n; i++) { split(order[i], a, "\t")
		printf "  %-30s %-9s %6.3f..%-6.3f bpp  %6.2f..%-6.2f dB\n", substr(a[1], 1, 30), a[2], lo[order[i]], hi[order[i]], plo[order[i]], phi[order[i]] } }' "$results"
echo
python3 "$BENCH_DIR/bd.py" "$results" ${BD_TSV:+--tsv "$BD_TSV"}
if [ -n "${PLOT:-}" ]; then
	plot "$results" "$PLOT" \
		"${PLOT_TITLE:-gigaview and the anchors, $(date +%F), $( [ "$FULL" = 1 ] && echo "full size, JPEG sources cropped 4 px" || echo "JPEG sources halved")}"
fi
echo "Run time: ${elapsed} s for ${#images[@]} image(s)."
