#!/bin/bash
# rate-distortion.sh: bits per pixel against level-0 PSNR and SSIM-Y for
# gigaview, JPEG, WebP and ASTC, on the same images in the same run.
#
#   bench/rate-distortion.sh [--gigaview PATH] [IMAGE...]
#
# Every image (default: 5 of the photos in $DATA_DIR/photos) is first made
# into a metadata-free PNG that every codec reads and every result is compared
# with. JPEG sources are halved (vips resize 0.5, lanczos3) unless PREP=none:
# re-encoding a JPEG with the quantizer it was made with is near-lossless
# (picosdeeuropa: 62 dB at JPEG Q90, more than at Q98), which would flatter
# JPEG; halving washes out the source's block grid and quantization. PNG
# sources are used as they are. The row names carry "/2" when halved.
#
# Then, per image:
#   gigaview  encode -q Q for each Q in GV_QS (-q: the whole level 0's PSNR to
#             aim for, the default equal-slope mode); bpp = store bytes * 8 / source
#             pixels (the store holds every pyramid level, every codebook and
#             the root); quality = level 0 exported to PNG, against the input.
#   jpeg      cjpeg (libjpeg-turbo) -quality Q -optimize, 4:2:0, one JPEG of
#             the full image; bpp = file bytes * 8 / pixels; quality of the
#             decoded JPEG (djpeg).
#   jpeg-dz   pyramid cost: vips dzsave --container zip with .jpg tiles at the
#             same Q (optimize_coding, 4:2:0 forced), bpp = whole zip * 8 /
#             source pixels. Its PSNR/SSIM is that of the single JPEG at the
#             same Q: the level-0 tiles are coded with the same settings, so
#             this row answers "what would a JPEG pyramid with this level-0
#             quality cost", which is what gigaview's bpp counts.
#   webp      cwebp -q Q -m 6 (one file of the full image), decoded by dwebp.
#   webp-dz   as jpeg-dz, with .webp tiles (Q, effort 6) and the webp PSNR.
#   gv-pertile with PERTILE=1: the per-tile mode, --min-tile-psnr Q, same Qs.
#   gv-noroot diagnostic only: the same stores less the root level, which
#             gigaview keeps as raw pixels with a mip chain (32 bpp at root
#             resolution); shows how much of the rate the root takes on
#             images of a few megapixels. Not a fair comparison point.
#   astc8x8   astcenc -thorough, 8x8 blocks (2.00 bpp; a full mip chain
#             would add a third: 2.67 bpp), level 0 only.
#   astc6x6   the same with 6x6 blocks (3.56 bpp).
# PSNR is over RGB from the total MSE; SSIM is the mean SSIM of BT.601 luma
# with an 11x11 Gaussian window (sigma 1.5); both by bench/imgcompare.c, the
# reference being the 8-bit input as vips decodes it.
#
# Then: averages over images per setting, and the key figures: each codec's
# PSNR interpolated at exactly RATES bpp (default "2.0 1.0 0.5"; linear in bpp
# between the two settings that bracket the rate, per image, then averaged),
# and the difference "gigaview vs X" in dB and in SSIM-Y over the images
# where both reach the rate.
#
# Environment:
#   GIGAVIEW=PATH    binary (default ../gigaview next to bench/, or on PATH)
#   QUICK=1          2 images, fewer settings, no ASTC 6x6 (about 1 minute)
#   PREP=auto|half|none   source preparation (see above; default auto)
#   GV_QS, JPEG_QS, WEBP_QS   settings lists (space separated)
#   GV_ARGS          extra options for gigaview encode, e.g. -r 8
#   PERTILE=1        also the per-tile mode (gv-pertile rows)
#   RESULTS=FILE     copy the table of every point (image codec setting bpp
#                    psnr ssim, tab separated) to FILE, e.g. for plot-rd.sh
#   SUMMARIZE=FILE   encode nothing: print the summaries of such a table
#                    (e.g. two runs' tables concatenated)
#   RATES="2.0 1.0 0.5"  rates of the key comparison
#   ASTC=0           skip ASTC (it is the slowest part: -thorough)
#   DZ=0             skip the dzsave pyramid-cost rows
#   TMPDIR=DIR       scratch space (default /tmp)
set -euo pipefail

. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

gv_arg=""
images=()
while [ $# -gt 0 ]; do
	case $1 in
	--gigaview) gv_arg=$2; shift 2 ;;
	--gigaview=*) gv_arg=${1#*=}; shift ;;
	-h|--help) sed -n '2,64p' "$0"; exit 0 ;;
	*) images+=("$1"); shift ;;
	esac
done

need_cmd vips libvips-tools
need_cmd vipsheader libvips-tools
need_cmd cjpeg libjpeg-turbo-progs
need_cmd djpeg libjpeg-turbo-progs
need_cmd cwebp webp
need_cmd dwebp webp
ASTC=${ASTC:-1}
DZ=${DZ:-1}
if [ "$ASTC" = 1 ] && ! command -v astcenc >/dev/null 2>&1; then
	if apt-cache show astcenc >/dev/null 2>&1; then
		need_cmd astcenc astcenc
	else
		echo "# astcenc is not packaged here: ASTC rows left out" >&2
		ASTC=0
	fi
fi
GV_SRC=$(find_gigaview "$gv_arg")
QUICK=${QUICK:-0}
P=$DATA_DIR/photos
if [ "$QUICK" = 1 ]; then
	: "${GV_QS:=34 38 42 46 50}"
	: "${JPEG_QS:=30 50 70 90 98}"
	: "${WEBP_QS:=50 80 95 100}"
	ASTC_BLOCKS="8x8"
	[ ${#images[@]} -gt 0 ] || images=("$P/Dragonfly_by_Bolly.jpg" "$P/picosdeeuropa_by_Aitzol_Berasategi.jpg")
else
	: "${GV_QS:=32 35 38 41 44 47 50}"
	: "${JPEG_QS:=30 40 50 60 70 80 90 95 98}"
	: "${WEBP_QS:=50 70 80 90 95 100}"
	ASTC_BLOCKS="8x8 6x6"
	[ ${#images[@]} -gt 0 ] || images=("$P/Dragonfly_by_Bolly.jpg"
		"$P/picosdeeuropa_by_Aitzol_Berasategi.jpg" "$P/sunset_by_Aitzol_Berasategi.jpg"
		"$P/seeding_by_Clements_Engelhardt.jpg" "$P/flowers.png")
fi
: "${RATES:=2.0 1.0 0.5}"
: "${PREP:=auto}"
case $PREP in auto|half|none) ;; *) die "PREP must be auto, half or none" ;; esac
for f in "${images[@]}"; do [ -r "$f" ] || die "cannot read image $f"; done

work=$(mktemp -d "${TMPDIR:-/tmp}/gv-rd.XXXXXX")
trap 'rm -rf "$work"' EXIT INT TERM
GV=$(snapshot_gigaview "$GV_SRC" "$work")
CMP=$(build_imgcompare "$work")
results=$work/results.tsv   # image codec setting bpp psnr ssim
: >"$results"

echo "# rate-distortion: gigaview vs JPEG / WebP / ASTC, same images, same run"
echo "# $(date '+%F %T %Z'); $(machine_line)"
echo "# $(describe_build "$GV_SRC")"
tools="vips $(vips --version | sed 's/^vips-//'), $(cjpeg -version 2>&1 | head -1 | awk '{print $1, $2, $3}')"
tools="$tools, cwebp $(cwebp -version 2>&1 | head -1)"
[ "$ASTC" = 1 ] && tools="$tools, $(astcenc 2>&1 | head -1 | awk '{print $1, $2}')"
echo "# tools: $tools"
echo "# settings: gigaview -q {$GV_QS}; JPEG Q {$JPEG_QS}; WebP Q {$WEBP_QS}$( [ "$ASTC" = 1 ] && echo "; ASTC $ASTC_BLOCKS -thorough")"
echo "# bpp = file bits / source pixels. PSNR: RGB, total MSE. SSIM: luma (BT.601), 11x11 Gaussian window."
echo "# jpeg-dz / webp-dz rows: bpp of the whole vips dzsave zip pyramid at that Q; PSNR/SSIM taken from the"
echo "#   single full-size file at the same Q (level 0 of the pyramid uses the same coder settings)."
echo

row() {  # image codec setting bytes pixels psnr ssim
	local bpp
	bpp=$(awk -v s="$4" -v p="$5" 'BEGIN { printf "%.4f", s * 8 / p }')
	printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$1" "$2" "$3" "$bpp" "$6" "$7" >>"$results"
	printf '%-26s %-9s %6s %8.3f %8s %7s\n' "${1:0:26}" "$2" "$3" "$bpp" "$6" "$7"
}
cmp_pnm() {  # REF TEST-ANY-FORMAT -> "psnr ssim"
	to_pnm "$2" "$work/test.ppm"
	"$CMP" "$1" "$work/test.ppm" | sed 's/psnr=//; s/ssim=//'
}
# dz_bytes SUFFIX: bytes of a dzsave zip pyramid of $img
dz_bytes() {
	rm -rf "$work/dz" "$work/dz.zip"
	vips dzsave "$src" "$work/dz.zip" --container zip --suffix "$1" >/dev/null
	if [ -f "$work/dz.zip" ]; then stat -c %s "$work/dz.zip"; else stat -c %s "$work/dz"; fi
}

printf '%-26s %-9s %6s %8s %8s %7s\n' image codec set bpp "PSNR dB" SSIM-Y
t_start=$(now)
if [ -n "${SUMMARIZE:-}" ]; then
	cp "$SUMMARIZE" "$results"
	mapfile -t images < <(awk -F'\t' '!s[$1]++ { print $1 }' "$results")
	images_to_run=()
else
	images_to_run=("${images[@]}")
fi
for img in "${images_to_run[@]}"; do
	name=$(basename "$img")
	# the source every codec reads: a metadata-free PNG, JPEG sources halved
	src=$work/src.png
	case "$PREP:${img,,}" in
	auto:*.jpg|auto:*.jpeg|half:*)
		vips resize "$img" "${src}[strip,compression=1]" 0.5 --kernel lanczos3
		name="$name/2" ;;
	*)	vips copy "$img" "${src}[strip,compression=1]" ;;
	esac
	w=$(img_w "$src"); h=$(img_h "$src"); px=$((w * h))
	ref=$work/ref.ppm
	to_pnm "$src" "$ref"
	echo "# $name: ${w}x${h}, $(img_bands "$src") band(s), $(awk -v p="$px" 'BEGIN { printf "%.1f", p / 1e6 }') MP"

	for q in $GV_QS; do
		# shellcheck disable=SC2086 # GV_ARGS is a list of options
		"$GV" encode "$src" -o "$work/x.gv" -q "$q" --quiet ${GV_ARGS:-}
		"$GV" export "$work/x.gv" --level 0 -o "$work/x.png" >/dev/null
		read -r ps ss < <(cmp_pnm "$ref" "$work/x.png")
		gbytes=$(stat -c %s "$work/x.gv")
		row "$name" gigaview "q$q" "$gbytes" "$px" "$ps" "$ss"
		# diagnostic: the same store less its root level (raw pixels + mips)
		rbytes=$("$GV" info "$work/x.gv" --json | sed 's/},{/\n/g' | grep '"tiles_x":0,' | sed 's/.*"bytes":\([0-9]*\).*/\1/' || true)
		row "$name" gv-noroot "q$q" "$((gbytes - ${rbytes:-0}))" "$px" "$ps" "$ss"
		if [ "${PERTILE:-0}" = 1 ]; then
			# shellcheck disable=SC2086
			"$GV" encode "$src" -o "$work/x.gv" --min-tile-psnr "$q" --quiet ${GV_ARGS:-}
			"$GV" export "$work/x.gv" --level 0 -o "$work/x.png" >/dev/null
			read -r ps ss < <(cmp_pnm "$ref" "$work/x.png")
			row "$name" gv-pertile "q$q" "$(stat -c %s "$work/x.gv")" "$px" "$ps" "$ss"
		fi
	done
	for q in $JPEG_QS; do
		cjpeg -quality "$q" -optimize -outfile "$work/x.jpg" "$ref"
		djpeg -pnm -outfile "$work/x.pnm" "$work/x.jpg"
		read -r ps ss < <("$CMP" "$ref" "$work/x.pnm" | sed 's/psnr=//; s/ssim=//')
		row "$name" jpeg "Q$q" "$(stat -c %s "$work/x.jpg")" "$px" "$ps" "$ss"
		if [ "$DZ" = 1 ]; then
			row "$name" jpeg-dz "Q$q" "$(dz_bytes ".jpg[Q=$q,optimize-coding,subsample-mode=on]")" "$px" "$ps" "$ss"
		fi
	done
	for q in $WEBP_QS; do
		cwebp -quiet -q "$q" -m 6 "$src" -o "$work/x.webp"
		dwebp -quiet -ppm "$work/x.webp" -o "$work/x.ppm"
		read -r ps ss < <("$CMP" "$ref" "$work/x.ppm" | sed 's/psnr=//; s/ssim=//')
		row "$name" webp "Q$q" "$(stat -c %s "$work/x.webp")" "$px" "$ps" "$ss"
		if [ "$DZ" = 1 ]; then
			row "$name" webp-dz "Q$q" "$(dz_bytes ".webp[Q=$q,effort=6]")" "$px" "$ps" "$ss"
		fi
	done
	if [ "$ASTC" = 1 ]; then
		for blk in $ASTC_BLOCKS; do
			bx=${blk%x*}; by=${blk#*x}
			astcenc -tl "$src" "$work/x.png" "$blk" -thorough -silent -j "$(nproc)" >/dev/null
			read -r ps ss < <(cmp_pnm "$ref" "$work/x.png")
			bytes=$(( ((w + bx - 1) / bx) * ((h + by - 1) / by) * 16 ))
			row "$name" "astc$blk" "thor" "$bytes" "$px" "$ps" "$ss"
		done
	fi
done
elapsed=$(awk -v a="$t_start" -v b="$(now)" 'BEGIN { printf "%.0f", b - a }')
[ -z "${RESULTS:-}" ] || cp "$results" "$RESULTS"

# ---- summaries -----------------------------------------------------------
nimg=${#images[@]}
echo
echo "== Averages over $nimg image(s), per setting (mean bpp, mean PSNR dB, mean SSIM-Y) =="
awk -F'\t' '
	{ k = $2 "\t" $3; if (!(k in n)) order[++no] = k; n[k]++; b[k] += $4; p[k] += $5; s[k] += $6 }
	END {
		printf "%-10s %6s %8s %8s %7s %4s\n", "codec", "set", "bpp", "PSNR dB", "SSIM-Y", "n"
		for (i = 1; i <= no; i++) { k = order[i]; split(k, a, "\t")
			printf "%-10s %6s %8.3f %8.2f %7.4f %4d\n", a[1], a[2], b[k] / n[k], p[k] / n[k], s[k] / n[k], n[k] }
	}' <(sort -t$'\t' -k2,2 -s "$results")

echo
echo "== Key figure: PSNR at a fixed rate (linear in bpp between the two settings that bracket it, per image) =="
echo "   'common' columns: mean over the images where every JPEG/WebP series and gigaview reach the rate, so the"
echo "   means are comparable; 'pairwise': gigaview minus codec over every image where both reach it."
echo "   ASTC is fixed-rate: its own point is used, and gigaview is interpolated at ASTC's exact bpp"
echo "   (8x8: 2.00 bpp, level 0 only; 'astc8x8+mips' puts gigaview at 4/3 of that, the cost of a full mip chain)."
for rate in $RATES; do
	awk -F'\t' -v R="$rate" '
	function interp(img, c, x,    i, lo, hi, blo, bhi, t) {
		blo = -1; bhi = 1e99
		for (i = 1; i <= cnt[img, c]; i++) {
			if (B[img, c, i] <= x && B[img, c, i] > blo) { blo = B[img, c, i]; lo = i }
			if (B[img, c, i] >= x && B[img, c, i] < bhi) { bhi = B[img, c, i]; hi = i }
		}
		if (blo < 0 || bhi > 1e98) return 0
		if (bhi == blo) { IP = P[img, c, lo]; IS = S[img, c, lo]; return 1 }
		t = (x - blo) / (bhi - blo)
		IP = P[img, c, lo] + t * (P[img, c, hi] - P[img, c, lo])
		IS = S[img, c, lo] + t * (S[img, c, hi] - S[img, c, lo])
		return 1
	}
	{
		if (!($1 in seen)) { seen[$1] = 1; imgs[++ni] = $1 }
		if (!($2 in cseen)) { cseen[$2] = 1; codecs[++nc] = $2 }
		i = ++cnt[$1, $2]; B[$1, $2, i] = $4; P[$1, $2, i] = $5; S[$1, $2, i] = $6
		if ($4 > maxb[$1, $2]) maxb[$1, $2] = $4
		if (!(($1, $2) in minb) || $4 < minb[$1, $2]) minb[$1, $2] = $4
	}
	END {
		# images where gigaview and every JPEG/WebP series bracket R
		for (k = 1; k <= ni; k++) { im = imgs[k]; ok = 1
			for (j = 1; j <= nc; j++) { c = codecs[j]
				if (c == "gv-noroot" || c == "gv-pertile" || c ~ /^astc/) continue
				if (!interp(im, c, R)) ok = 0 }
			common[im] = ok; ncom += ok; comlist = comlist (ok ? " " imgs[k] : "") }
		printf "\n-- at %.2f bpp -- common images: %d of %d:%s\n", R, ncom, ni, comlist
		printf "%-13s %9s %8s %10s %9s   %s\n", "codec", "PSNR dB", "SSIM-Y", "gv - codec", "SSIM diff", "gv - codec pairwise: dB [per image, in image order]; SSIM-Y"
		printf "%-13s %9s %8s %10s %9s\n", "", "(common)", "(common)", "(common)", "(common)"
		for (j = 1; j <= nc; j++) { c = codecs[j]
			if (c == "gigaview" || c == "gv-noroot") continue
			for (m = 0; m <= (c ~ /^astc/ ? 1 : 0); m++) {
				if (c ~ /^astc/ && R + 0 != 2.0) continue
				sp = ss = sd = n = 0; nd = pd = 0; per = ""; sdS = pdS = 0
				for (k = 1; k <= ni; k++) { im = imgs[k]
					if (c ~ /^astc/) {
						if (cnt[im, c] < 1) { per = per " -"; continue }
						cp = P[im, c, 1]; cs = S[im, c, 1]; x = B[im, c, 1] * (m ? 4 / 3 : 1); have = 1
					} else {
						have = interp(im, c, R); cp = IP; cs = IS; x = R
					}
					g = have ? interp(im, "gigaview", x) : 0
					if (g) { nd++; pd += IP - cp; pdS += IS - cs; per = per sprintf(" %+.2f", IP - cp) } else per = per " n/a"
					if (common[im] && have && g) { n++; sp += cp; ss += cs; sd += IP - cp; sdS += IS - cs }
				}
				lab = c (m ? "+mips" : "")
				if (n) printf "%-13s %9.2f %8.4f %+10.2f %+9.4f", lab, sp / n, ss / n, sd / n, sdS / n
				else printf "%-13s %9s %8s %10s %9s", lab, "n/a", "n/a", "n/a", "n/a"
				if (nd) printf "   %+.2f over %d image(s) [%s ]; SSIM %+.4f\n", pd / nd, nd, per, pdS / nd
				else printf "   n/a [%s ]\n", per
			}
		}
		for (g = 0; g <= 1; g++) {
			c = g ? "gv-noroot" : "gigaview"; if (!(c in cseen)) continue
			sp = ss = n = 0
			for (k = 1; k <= ni; k++) if (common[imgs[k]] && interp(imgs[k], c, R)) { n++; sp += IP; ss += IS }
			if (n) printf "%-13s %9.2f %8.4f %10s   %s\n", c, sp / n, ss / n, "", g ? "diagnostic: store less its raw root (over " n " image(s))" : "reference"
			else printf "%-13s %9s %8s %10s   %s\n", c, "n/a", "n/a", "", g ? "diagnostic: does not reach the rate on the common images" : "reference"
		}
		printf "   bpp range reached (min..max) per image:\n"
		for (k = 1; k <= ni; k++) { printf "     %-26s", substr(imgs[k], 1, 26)
			for (j = 1; j <= nc; j++) if (codecs[j] !~ /^astc/ && codecs[j] != "gv-noroot")
				printf " %s %.2f..%.2f", codecs[j], minb[imgs[k], codecs[j]], maxb[imgs[k], codecs[j]]
			printf "\n" }
	}' "$results"
done

echo
echo "Context only (different images, not comparable to the table above): CODEC-NOTES, Kodak set:"
echo "  ASTC 8x8 -thorough 2.00 bpp 34.63 dB / SSIM 0.961; ASTC 6x6 3.56 bpp 38.43 dB; JPEG 1.96 bpp 36.87 dB;"
echo "  WebP -m 6 1.93 bpp 39.26 dB. The same-run, same-image differences above are the real comparison."
echo "Image order in per-image lists: $(for f in "${images[@]}"; do printf '%s ' "$(basename "$f")"; done)"
echo "Run time: ${elapsed} s for $nimg image(s)."
