#!/usr/bin/env bash
# tin-speed.sh - TINs by greedy insertion: triangle count and meshing time
# of `gigaview mesh` (lib/mesh, C, one thread) against npm delatin (the same
# Garland & Heckbert greedy insertion, in JavaScript) and @mapbox/martini
# (RTIN, JavaScript) under node, in one run on the same ETOPO5 regions
# (1025 x 1025 samples, metres) at three maximum errors.  gigaview runs
# as crack-free (border vertices first, the default with --max-error),
# --no-border-first (the plain greedy insertion delatin runs), and in
# crack-free tiles of 64 x 64 cells (--tile 64) on one thread and on every
# core.  Prints
# the figures and the ratios; asserts nothing.  Writes
# bench/results/tin-DATE.tsv and, with gnuplot, bench/tin-DATE.png.
#
#   bench/tin-speed.sh [E...]        (default: 10 50 200, metres)
#   bench/tin-speed.sh --plot TSV PNG   (only the plot of an earlier run)
#
# Environment: GIGAVIEW (default: ../gigaview, see lib.sh), DATA_DIR,
# REPS (best of, default 3).  The npm anchors come from bench/package.json
# and its lock, installed here with `npm ci` (never at test time).  About
# 3 minutes on the 2-core machine.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=bench/lib.sh
. "$here/lib.sh"

# plot_tsv TSV PNG: triangles over delatin's, and CPU time, per case
# (wall times on a shared machine are too noisy to plot).
plot_tsv() {
	command -v gnuplot >/dev/null 2>&1 || { echo "no gnuplot: no plot"; return 0; }
	local pw
	pw=$(mktemp -d)
	for tool in gigaview gigaview-plain gigaview-tiles64 delatin martini; do
		awk -F'\t' -v t="$tool" 'NR > 1 { c = $1 "/" $2; if (!(c in seen)) { seen[c] = 1; cs[++n] = c }
			tri[c, $3] = $4; cpu[c, $3] = $6 }
			END { for (i = 1; i <= n; i++) print i, cs[i], tri[cs[i], t] / tri[cs[i], "delatin"], cpu[cs[i], t] }' "$1" >"$pw/$tool.dat"
	done
	gnuplot <<GP
set terminal pngcairo size 1100,460 font ",10"
set output "$2"
set multiplot layout 1,2 title "TINs of ETOPO5 regions (1025^2 samples) at max error E (region/E), one thread"
set style data linespoints
set xtics rotate by -30
set key top right
set ylabel "triangles / delatin's"
set title "triangles at equal max error (goal <= 1)"
plot "$pw/gigaview.dat" using 1:3:xtic(2) title "gigaview (crack-free)", \\
     "$pw/gigaview-plain.dat" using 1:3 title "gigaview (plain)", \\
     "$pw/gigaview-tiles64.dat" using 1:3 title "gigaview (64^2 tiles)", \\
     "$pw/delatin.dat" using 1:3 title "delatin", \\
     "$pw/martini.dat" using 1:3 title "martini"
set logscale y
set ylabel "CPU ms"
set title "meshing time (CPU)"
plot "$pw/gigaview.dat" using 1:4:xtic(2) title "gigaview (crack-free)", \\
     "$pw/gigaview-plain.dat" using 1:4 title "gigaview (plain)", \\
     "$pw/gigaview-tiles64.dat" using 1:4 title "gigaview (64^2 tiles)", \\
     "$pw/delatin.dat" using 1:4 title "delatin", \\
     "$pw/martini.dat" using 1:4 title "martini"
unset multiplot
GP
	rm -rf "$pw"
	echo "plot: $2"
}

if [ "${1:-}" = --plot ]; then
	plot_tsv "$2" "$3"
	exit 0
fi

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
		for v in "gigaview:" "gigaview-plain:--no-border-first" \
			"gigaview-tiles64:--tile 64 -j 1" "gigaview-tiles64-j$(nproc):--tile 64 -j $(nproc)"; do
			# shellcheck disable=SC2086
			read -r t ms cpu <<<"$(best_gv --region "$x,$y,1024,1024" --max-error "$e" ${v#*:})"
			printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$e" "${v%%:*}" "$t" "$ms" "$cpu" >>"$tsv"
		done
		awk -v n="$name" -v e="$e" '$2 == e { printf "%s\t%s\t%s\t%s\t%s\t%s\n", n, e, $1, $3, $4, $6 }' "$work/$name.js" >>"$tsv"
	done
done

# the table: ratios against delatin in the same run (the thread CPU time
# of a multi-threaded run counts the calling thread only: shown as -)
awk -F'\t' 'NR > 1 { c = $1 " " $2; t[c, $3] = $4; ms[c, $3] = $5; cpu[c, $3] = $6
	if (!(c in seen)) { seen[c] = 1; cs[++n] = c }
	if (!($3 in tseen)) { tseen[$3] = 1; ts[++m] = $3 } }
END {
	printf "%-9s %5s %-20s %9s %7s %9s %8s %9s %8s\n", "region", "E m", "tool", "triangles",
		"/delatin", "ms", "speedup", "cpu ms", "cpu x"
	for (i = 1; i <= n; i++) {
		c = cs[i]
		for (k = 1; k <= m; k++) {
			tool = ts[k]
			multi = tool ~ /-j[0-9]+$/ && tool !~ /-j1$/
			printf "%-9s %5s %-20s %9d %7.3f %9.1f %7.1fx %9s %8s\n", \
				substr(c, 1, index(c, " ") - 1), substr(c, index(c, " ") + 1), tool,
				t[c, tool], t[c, tool] / t[c, "delatin"], ms[c, tool],
				ms[c, "delatin"] / ms[c, tool],
				multi ? "-" : sprintf("%.1f", cpu[c, tool]),
				multi ? "-" : sprintf("%.1fx", cpu[c, "delatin"] / cpu[c, tool])
		}
	}
}' "$tsv"
echo "/delatin: triangles over delatin's at the same max error (goal <= 1.0); speedup: delatin's wall ms over the tool's"
echo "(best of $reps; goal >= 10 single-threaded); cpu x: the same in CPU time, which the load of a shared machine disturbs less"
echo "table: $tsv"

plot_tsv "$tsv" "$here/tin-$day.png"
