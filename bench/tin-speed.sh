#!/usr/bin/env bash
# tin-speed.sh - TINs by greedy insertion: triangle count and meshing time
# of `gigaview mesh` (lib/mesh, C, one thread) against npm delatin (the same
# Garland & Heckbert greedy insertion, in JavaScript) and @mapbox/martini
# (RTIN, JavaScript) under node, in one run on the same ETOPO5 regions
# (1025 x 1025 samples, metres) at three maximum errors.  gigaview runs
# twice: crack-free (border vertices first, the default with --max-error)
# and --no-border-first (the plain greedy insertion delatin runs).  Prints
# the figures and the ratios; asserts nothing.  Writes
# bench/results/tin-DATE.tsv and, with gnuplot, bench/tin-DATE.png.
#
#   bench/tin-speed.sh [E...]        (default: 10 50 200, metres)
#
# Environment: GIGAVIEW (default: ../gigaview, see lib.sh), DATA_DIR,
# REPS (best of, default 3).  The npm anchors come from bench/package.json
# and its lock, installed here with `npm ci` (never at test time).  About
# 3 minutes on the 2-core machine.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=bench/lib.sh
. "$here/lib.sh"

errs=("$@")
[ ${#errs[@]} -gt 0 ] || errs=(10 50 200)
reps=${REPS:-3}
need_cmd node nodejs
need_cmd npm npm
need_cmd gdal_translate gdal-bin
src=$DATA_DIR/elevation/etopo5-4320x2161-u16.png
[ -f "$src" ] || die "no $src (DATA_DIR)"
gv=$(find_gigaview "${GIGAVIEW:-}")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
gv=$(snapshot_gigaview "$gv" "$work")
if [ ! -d "$here/node_modules/delatin" ] || [ "$here/package-lock.json" -nt "$here/node_modules" ]; then
	(cd "$here" && npm ci --no-audit --no-fund >&2)
fi

# name x y: 1025 x 1025 samples of ETOPO5 (12 samples per degree, x = 0
# at 180 W, y = 0 at 90 N)
regions=("himalaya 3000 360" "andes 1140 960" "alps 1920 240")
day=$(date +%F)
tsv=$here/results/tin-$day.tsv
mkdir -p "$here/results"
describe_build "$gv"
machine_line
echo "node $(node --version), delatin $(node -p "require('$here/node_modules/delatin/package.json').version"), martini $(node -p "require('$here/node_modules/@mapbox/martini/package.json').version")"
printf 'region\tE\ttool\ttriangles\tms\tcpu_ms\n' >"$tsv"

# best_gv ARGS...: best-of-reps (by wall time) "triangles ms cpu_ms" of
# gigaview mesh, which times the meshing alone (not reading the PNG)
best_gv() {
	local best="" bms="" line t ms cpu
	for _ in $(seq "$reps"); do
		line=$("$gv" mesh "$src" --offset -11000 "$@" -o "$work/m.glb")
		t=$(sed 's/.* \([0-9]*\) triangles.*/\1/' <<<"$line")
		ms=$(sed 's/.*error [^,]*, \([0-9.]*\) ms.*/\1/' <<<"$line")
		cpu=$(sed 's/.*(\([0-9.]*\) ms CPU).*/\1/' <<<"$line")
		if [ -z "$best" ] || awk -v a="$ms" -v b="$bms" 'BEGIN { exit !(a < b) }'; then
			best="$t $ms $cpu"
			bms=$ms
		fi
	done
	echo "$best"
}

for r in "${regions[@]}"; do
	set -- $r
	name=$1 x=$2 y=$3
	gdal_translate -q -of ENVI -ot Float32 -srcwin "$x" "$y" 1025 1025 "$src" "$work/$name.bin"
	REPS=$reps node "$here/tin-anchors.mjs" "$work/$name.bin" 1025 -11000 "${errs[@]}" >"$work/$name.js"
	for e in "${errs[@]}"; do
		read -r t ms cpu <<<"$(best_gv --region "$x,$y,1024,1024" --max-error "$e")"
		printf '%s\t%s\tgigaview\t%s\t%s\t%s\n' "$name" "$e" "$t" "$ms" "$cpu" >>"$tsv"
		read -r t ms cpu <<<"$(best_gv --region "$x,$y,1024,1024" --max-error "$e" --no-border-first)"
		printf '%s\t%s\tgigaview-plain\t%s\t%s\t%s\n' "$name" "$e" "$t" "$ms" "$cpu" >>"$tsv"
		awk -v n="$name" -v e="$e" '$2 == e { printf "%s\t%s\t%s\t%s\t%s\t%s\n", n, e, $1, $3, $4, $6 }' "$work/$name.js" >>"$tsv"
	done
done

# the table: ratios against delatin in the same run
awk -F'\t' 'NR > 1 { t[$1 " " $2 " " $3] = $4; ms[$1 " " $2 " " $3] = $5; cpu[$1 " " $2 " " $3] = $6; if (!(($1 " " $2) in seen)) { seen[$1 " " $2] = 1; ks[++n] = $1 " " $2 } }
END {
	printf "%-9s %5s | %9s %9s %6s | %9s %6s | %8s %8s %7s | %7s | %9s %8s\n", "region", "E m",
		"gigaview", "delatin", "ratio", "plain", "ratio", "gv ms", "delatin", "speedup", "cpu x",
		"martini", "mart ms"
	for (i = 1; i <= n; i++) {
		c = ks[i]
		printf "%-9s %5s | %9d %9d %6.3f | %9d %6.3f | %8.1f %8.1f %6.1fx | %6.1fx | %9d %8.1f\n", \
			substr(c, 1, index(c, " ") - 1), substr(c, index(c, " ") + 1),
			t[c " gigaview"], t[c " delatin"], t[c " gigaview"] / t[c " delatin"],
			t[c " gigaview-plain"], t[c " gigaview-plain"] / t[c " delatin"],
			ms[c " gigaview"], ms[c " delatin"], ms[c " delatin"] / ms[c " gigaview"],
			cpu[c " delatin"] / cpu[c " gigaview"],
			t[c " martini"], ms[c " martini"]
	}
}' "$tsv"
echo "ratio: triangles / delatin's (goal <= 1.0); speedup: delatin ms / gigaview ms (wall, best of $reps), one thread each (goal >= 10); cpu x: the same in CPU time"
echo "table: $tsv"

if command -v gnuplot >/dev/null 2>&1; then
	png=$here/tin-$day.png
	awk -F'\t' 'NR > 1 { print $1 "/" $2, $3, $4, $5 }' "$tsv" >"$work/plot.dat"
	for tool in gigaview gigaview-plain delatin martini; do
		awk -v t="$tool" '$2 == t { print NR, $1, $3, $4 }' "$work/plot.dat" | awk '{ $1 = ++i; print }' >"$work/$tool.dat"
	done
	gnuplot <<GP
set terminal pngcairo size 1100,460 font ",10"
set output "$png"
set multiplot layout 1,2 title "TINs of ETOPO5 regions (1025^2 samples) at max error E, one thread"
set style data linespoints
set logscale y
set xtics rotate by -30
set key top right
set ylabel "triangles"
set title "triangles at equal max error"
plot "$work/gigaview.dat" using 1:3:xtic(2) title "gigaview (crack-free)", \
     "$work/gigaview-plain.dat" using 1:3 title "gigaview (plain)", \
     "$work/delatin.dat" using 1:3 title "delatin", \
     "$work/martini.dat" using 1:3 title "martini"
set ylabel "ms"
set title "meshing time"
plot "$work/gigaview.dat" using 1:4:xtic(2) title "gigaview (crack-free)", \
     "$work/gigaview-plain.dat" using 1:4 title "gigaview (plain)", \
     "$work/delatin.dat" using 1:4 title "delatin", \
     "$work/martini.dat" using 1:4 title "martini"
unset multiplot
GP
	echo "plot: $png"
fi
