#!/bin/sh
# simplify-plot.sh TSV PNG - the plot of simplify-speed.sh: time of each
# method against the faces asked, and the Hausdorff error, from its TSV
# (gnuplot; does nothing without it).
command -v gnuplot >/dev/null || exit 0
tsv=$1 png=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for m in ours-cpu ours-gpu sloppy open3d quadric; do
	awk -F'\t' -v m="$m" 'NR > 1 && $4 == m && $1 == "volume300" {print $3, $6, $7}' "$tsv" >"$tmp/$m.dat"
done
gnuplot <<EOG
set terminal pngcairo size 1100,450
set output "$png"
set multiplot layout 1,2 title "Simplifying the 2.1M-triangle volume surface (bench/simplify-speed.sh)"
set logscale x
set xlabel "faces asked"
set ylabel "ms"
set key top left
plot for [m in "ours-cpu ours-gpu sloppy open3d quadric"] "$tmp/".m.".dat" using 1:2 with linespoints title m
set ylabel "Hausdorff, % of the diagonal"
set logscale y
plot for [m in "ours-cpu sloppy open3d quadric"] "$tmp/".m.".dat" using 1:3 with linespoints title m
EOG
