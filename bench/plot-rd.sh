#!/bin/bash
# plot-rd.sh: draw the rate-distortion curves of rate-distortion.sh.
#
#   bench/plot-rd.sh RESULTS.tsv OUT.png [TITLE]
#
# RESULTS.tsv is what rate-distortion.sh writes with RESULTS=FILE: one
# point per line, "image codec setting bpp psnr ssim", tab separated
# (several files may be concatenated, e.g. a run of ASTC alone). The
# picture has one row per image: level-0 PSNR (RGB) against bits per source
# pixel on the left, SSIM-Y on the right, one curve per codec, points in
# bpp order. gigaview's bpp counts the whole store and the dzsave rows the
# whole .zip pyramid; the single JPEG and WebP files are level 0 alone, and
# ASTC 8x8 (fixed 2 bpp, level 0 alone) is one point. gv-noroot rows are
# left out (a diagnostic). The x axis stops at XMAX bpp (default 3).
# rd-anchors.sh's rows (j2k, htj2k and the *-pyr pyramids) are drawn too;
# with LOGX=1 the x axis is logarithmic from XMIN (default 0.05) bpp, the
# axis the Bjontegaard fits use.
#
# Needs gnuplot (with the pngcairo terminal). Environment: XMAX, XMIN, LOGX,
# WIDTH (pixels, default 1200), ROW_HEIGHT (pixels per image, default 380).
set -euo pipefail

[ $# -ge 2 ] || { sed -n '2,20p' "$0"; exit 2; }
in=$1 out=$2 title=${3:-rate-distortion}
command -v gnuplot >/dev/null || { echo "plot-rd.sh: gnuplot is needed" >&2; exit 1; }
XMAX=${XMAX:-3}
XMIN=${XMIN:-0.05}
LOGX=${LOGX:-0}
WIDTH=${WIDTH:-1200}
ROW_HEIGHT=${ROW_HEIGHT:-380}

work=$(mktemp -d "${TMPDIR:-/tmp}/gv-plot.XXXXXX")
trap 'rm -rf "$work"' EXIT INT TERM

# Images in the order they first appear; codecs in a fixed order.
mapfile -t images < <(awk -F'\t' '!s[$1]++ { print $1 }' "$in")
codecs="gigaview gv-base gv-pertile j2k htj2k avif-pyr jxl-pyr webp-pyr jpeg-pyr jpeg-dz webp-dz jpeg webp astc8x8 astc6x6"
declare -A label=(
	[gigaview]="gigaview (default, whole store)"
	[gv-pertile]="gigaview --min-tile-psnr (whole store)"
	[gv-base]="gigaview, baseline binary (whole store)"
	[j2k]="JPEG 2000, OpenJPEG, one file"
	[htj2k]="HTJ2K, OpenJPH, one file"
	[avif-pyr]="AVIF pyramid (sum of levels)"
	[jxl-pyr]="JPEG XL pyramid (sum of levels)"
	[webp-pyr]="WebP pyramid (sum of levels)"
	[jpeg-pyr]="JPEG pyramid (sum of levels)"
	[jpeg-dz]="JPEG pyramid, vips dzsave .zip"
	[webp-dz]="WebP pyramid, vips dzsave .zip"
	[jpeg]="single JPEG (level 0 only)"
	[webp]="single WebP (level 0 only)"
	[astc8x8]="ASTC 8x8 -thorough (level 0 only)"
	[astc6x6]="ASTC 6x6 -thorough (level 0 only)")
declare -A style=(
	[gigaview]="lw 3 lc rgb '#d62728' pt 7"
	[gv-pertile]="lw 2 dt 2 lc rgb '#ff9896' pt 6"
	[gv-base]="lw 2 dt 3 lc rgb '#e377c2' pt 6"
	[j2k]="lw 2 lc rgb '#000000' pt 13"
	[htj2k]="lw 2 dt 2 lc rgb '#7f7f7f' pt 12"
	[avif-pyr]="lw 2 lc rgb '#9467bd' pt 11"
	[jxl-pyr]="lw 2 lc rgb '#ff7f0e' pt 9"
	[webp-pyr]="lw 2 lc rgb '#2ca02c' pt 8"
	[jpeg-pyr]="lw 2 lc rgb '#1f77b4' pt 5"
	[jpeg-dz]="lw 2 lc rgb '#1f77b4' pt 5"
	[webp-dz]="lw 2 lc rgb '#2ca02c' pt 9"
	[jpeg]="lw 1 dt 3 lc rgb '#1f77b4' pt 4"
	[webp]="lw 1 dt 3 lc rgb '#2ca02c' pt 8"
	[astc8x8]="lc rgb '#9467bd' pt 11 ps 2"
	[astc6x6]="lc rgb '#8c564b' pt 13 ps 2")

n=${#images[@]}
{
	echo "set terminal pngcairo noenhanced size $WIDTH,$((n * ROW_HEIGHT + 40)) font 'DejaVu Sans,10'"
	echo "set output '$out'"
	echo "set multiplot layout $n,2 title '$title'"
	if [ "$LOGX" = 1 ]; then
		echo "set grid; set key bottom right font ',8'; set logscale x; set xrange [$XMIN:$XMAX]"
	else
		echo "set grid; set key bottom right font ',8'; set xrange [0:$XMAX]"
	fi
	echo "set xlabel 'bits per source pixel'"
	i=0
	for img in "${images[@]}"; do
		i=$((i + 1))
		for metric in 5 6; do
			plots=""
			for c in $codecs; do
				f=$work/$i-$c.dat
				awk -F'\t' -v im="$img" -v c="$c" '$1 == im && $2 == c { print $4, $5, $6 }' "$in" |
					sort -g >"$f"
				[ -s "$f" ] || continue
				col=$((metric - 3))
				with="linespoints"
				case $c in astc*) with="points" ;; esac
				plots="$plots${plots:+, }'$f' using 1:$col with $with ${style[$c]} title '${label[$c]}'"
			done
			if [ "$metric" = 5 ]; then
				echo "set ylabel 'level-0 PSNR, dB (RGB, or gray)'; set title '$img: PSNR'"
				echo "set yrange [*:*]"
			else
				echo "set ylabel 'SSIM-Y'; set title '$img: SSIM-Y'"
				echo "set yrange [*:1]"
			fi
			echo "plot $plots"
		done
	done
	echo "unset multiplot"
} >"$work/plot.gp"
gnuplot "$work/plot.gp"
echo "plot-rd.sh: wrote $out ($n image(s))"
