#!/bin/bash
# plot-encode-speed.sh - bars of gigaview's encode speed over vips dzsave's,
# per input, from the output of encode-speed.sh run with --baseline: the
# baseline program and the new one side by side, and the goal (1.0x) as a
# line.  Several result files are drawn as one chart (their inputs in
# order).
#
#   bench/plot-encode-speed.sh OUT.png RESULT.txt [RESULT.txt...]
#
# An input met again in a later file is drawn once, from the first.
# BASE_LABEL and NEW_LABEL name the two bars (default: baseline, new).
# Needs gnuplot (pngcairo terminal).  Asserts nothing.
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: plot-encode-speed.sh OUT.png RESULT.txt..." >&2; exit 2; }
command -v gnuplot >/dev/null || { echo "plot-encode-speed.sh: gnuplot is needed" >&2; exit 1; }
out=$1
shift
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The main table gives gv/vips per input ("1.03x" in the last column), the
# baseline table base/vips (its second last column); the names are cut to
# their first word.
for f in "$@"; do
	awk '
		/^input/ { table++ }
		/^(TOTAL|gigaview|baseline|CPU|context|output|#)/ { next }
		NF >= 8 && $NF ~ /x$/ && table == 1 { n = substr($1, 1, 18); sub(/[_.].*/, "", n); gv[n] = $NF; order[++k] = n }
		NF >= 7 && table == 2 && $(NF - 3) ~ /x$/ { n = substr($1, 1, 18); sub(/[_.].*/, "", n); base[n] = $(NF - 3) }
		END {
			for (i = 1; i <= k; i++) {
				n = order[i]
				b = base[n]; g = gv[n]; sub(/x$/, "", b); sub(/x$/, "", g)
				if (b != "" && g != "") printf "%s\t%s\t%s\n", n, b, g
			}
		}' "$f"
done | awk -F '\t' '!seen[$1]++' >"$work/data.tsv"
[ -s "$work/data.tsv" ] || { echo "plot-encode-speed.sh: no baseline rows in $*" >&2; exit 1; }
gnuplot <<EOG
set terminal pngcairo size 1000,480 font "sans,10"
set output "$out"
set title "gigaview encode speed / vips dzsave (JPEG Q85 .zip), best wall time, same run"
set style data histograms
set style histogram clustered gap 1
set style fill solid 0.8 border -1
set boxwidth 0.9
set yrange [0:*]
set offsets 0, 0, 0.15, 0
set bmargin 6
set rmargin 10
set ylabel "speed / vips dzsave"
set xtics rotate by -30
set key top left
set grid ytics
set arrow from graph 0, first 1 to graph 1, first 1 nohead dt 2 lw 2 lc rgb "#c00000"
set label "goal 1.0x" at graph 0.01, first 1.04 textcolor rgb "#c00000"
plot "$work/data.tsv" using 2:xtic(1) title "${BASE_LABEL:-baseline}" lc rgb "#9aa7b5", \
     "" using 3 title "${NEW_LABEL:-new}" lc rgb "#2b6cb0"
EOG
echo "wrote $out"
