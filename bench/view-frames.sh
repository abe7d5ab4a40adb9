#!/bin/bash
# view-frames.sh: frame times and tile decodes of the native viewer
# (`gigaview view`) while it pans a scripted path across a large store,
# under SDL's offscreen driver (llvmpipe where there is no GPU).
#
#   bench/view-frames.sh [--gigaview PATH] [--gigaviewd PATH]
#
# The store is synth:$IMAGE (default 16384x12288, 201 megapixels), encoded
# once into $TMPDIR (kept there for the next run).  The path (generated below): a drag that pans level 0
# right at 16 window pixels a frame for 300 frames, then down for 150,
# then half a level out and right again for 150, at $SIZE (default
# 1280x720), --budget $BUDGET decodes a frame (default 4; and the viewer's
# default --budget-ms), no vsync (the
# driver has none), a cold tile cache.  It reports, for the frames drawn
# while the view moved: p50, p99 and the longest frame time (the frame's
# whole work: events, decodes within the budget, the draw, glFinish), the
# frames over 16.7 and 50 ms, the tiles decoded per second, the bytes
# fetched, and writes the frame times as a plot (bench/view-frames.png
# when PLOT=1, else into the scratch directory).  The anchor, measured in
# the same run on the same store: `gigaview render` of one view of the
# path (1280x720, level 0, its own cold cache), the still-frame client's
# time to a picture; the ratio is that time over the viewer's p50.
# Nothing is asserted.
#
# Environment: GIGAVIEW, GIGAVIEWD, IMAGE, SIZE, BUDGET, PLOT, TMPDIR.
set -euo pipefail

. "$(dirname "${BASH_SOURCE[0]}")/http-lib.sh"

gv_arg="" gvd_arg=""
while [ $# -gt 0 ]; do
	case $1 in
	--gigaview) gv_arg=$2; shift 2 ;;
	--gigaviewd) gvd_arg=$2; shift 2 ;;
	*) die "usage: view-frames.sh [--gigaview PATH] [--gigaviewd PATH]" ;;
	esac
done
GV=$(find_gigaview "$gv_arg")
GIGAVIEW=$GV
GVD=$(find_gigaviewd "$gvd_arg")
IMAGE=${IMAGE:-16384x12288}
SIZE=${SIZE:-1280x720}
BUDGET=${BUDGET:-4}
W=${SIZE%x*} H=${SIZE#*x}
IW=${IMAGE%x*} IH=${IMAGE#*x}

work=$(mktemp -d "${TMPDIR:-/tmp}/view-frames.XXXXXX")
trap 'http_cleanup; rm -rf "$work"' EXIT
mkdir "$work/stores" "$work/cache" "$work/cache2"

# The store is kept between runs (encoding takes minutes on 2 cores).
keep="${TMPDIR:-/tmp}/view-frames-synth-$IMAGE.gv"
if [ ! -s "$keep" ]; then
	echo "# encoding synth:$IMAGE into $keep" >&2
	"$GV" encode -j 2 "synth:$IMAGE" -o "$keep" >/dev/null
fi
ln -s "$keep" "$work/stores/big.gv"
cat >"$work/d.conf" <<EOF
listen = 127.0.0.1
port = 0
store_dir = "$work/stores"
threads = 4
cache_bytes = 256M
log_level = info
EOF
start_gigaviewd "$GVD" "$work/d.conf" "$work/d.log"
url="http://127.0.0.1:$GVD_PORT"

# The path: start a quarter in, pan right, down, zoom out, pan right.
cx=$((IW / 4)) cy=$((IH / 4))
{
	echo "view $cx,$cy,0"
	echo "settle"
	x=$((W / 2)) y=$((H / 2))
	echo "down $x $y"
	for _ in $(seq 300); do x=$((x - 16)); echo "move $x $y"; echo "frames 1"; done
	for _ in $(seq 150); do y=$((y - 16)); echo "move $x $y"; echo "frames 1"; done
	echo "up $x $y"
	echo "wheel $((W / 2)) $((H / 2)) -1"
	echo "settle"
	x=$((W / 2)) y=$((H / 2))
	echo "down $x $y"
	for _ in $(seq 150); do x=$((x - 16)); echo "move $x $y"; echo "frames 1"; done
	echo "up $x $y"
	echo "settle"
} >"$work/path.txt"

echo "# viewer: $SIZE, budget $BUDGET" >&2
SDL_VIDEODRIVER=offscreen XDG_CACHE_HOME="$work/cache" "$GV" view "$url" --image big \
	--size "$SIZE" --budget "$BUDGET" --no-vsync --no-overlay \
	--script "$work/path.txt" --stats "$work/frames.tsv" 2>"$work/view.err" ||
	{ cat "$work/view.err" >&2; die "the viewer failed"; }
summary=$(grep '^view: .* frames' "$work/view.err")

# The anchor: one view of the path rendered by the still-frame client.
t0=$(date +%s%N)
XDG_CACHE_HOME="$work/cache2" "$GV" render "$url" --image big --center "$cx,$cy" \
	--zoom 0 --size "$SIZE" -o "$work/r.png"
t1=$(date +%s%N)
render_ms=$(( (t1 - t0) / 1000000 ))

awk -F'\t' 'NR > 1 && $3 == 1 { print $2 }' "$work/frames.tsv" | sort -g >"$work/moving.txt"
# Frames that decoded a tile against those that only drew: what decoding
# adds to a frame, apart from drawing.
awk -F'\t' 'NR > 1 && $3 == 1 { d = $6 > prev; print d, $2 } NR > 1 { prev = $6 }' \
	"$work/frames.tsv" >"$work/split.txt"
for d in 0 1; do
	awk -v d=$d '$1 == d { print $2 }' "$work/split.txt" | sort -g |
		awk -v d=$d '{ t[++n] = $1 } END { if (n) printf "frames %s  %d, p50 %.2f ms, longest %.2f ms\n", d ? "that decoded" : "only drawn  ", n, t[int(n * 0.5) + 1], t[n] }'
done
awk -v r="$render_ms" -v s="$summary" '
	{ t[++n] = $1; if ($1 > 16.7) o16++; if ($1 > 50) o50++ }
	END {
		p50 = t[int(n * 0.5) + 1]; p99 = t[int((n - 1) * 0.99) + 1]
		printf "frames while moving  %d\n", n
		printf "frame time p50       %.2f ms\n", p50
		printf "frame time p99       %.2f ms\n", p99
		printf "longest frame        %.2f ms\n", t[n]
		printf "frames over 16.7 ms  %d\n", o16
		printf "frames over 50 ms    %d\n", o50
		printf "anchor: render, one view, cold  %d ms  (%.0fx the viewer p50)\n", r, r / p50
		print s
	}' "$work/moving.txt"

out="$work/view-frames.png"
[ "${PLOT:-0}" = 1 ] && out="$BENCH_DIR/view-frames.png"
if command -v gnuplot >/dev/null 2>&1; then
	gnuplot <<EOF
set terminal pngcairo size 900,400
set output "$out"
set title "gigaview view: frame time while panning synth:$IMAGE at $SIZE (budget $BUDGET)"
set xlabel "frame"
set ylabel "ms"
set yrange [0:*]
plot "$work/frames.tsv" using 1:(\$3 == 1 ? \$2 : 1/0) with points pt 7 ps 0.3 title "moving", \
     16.7 with lines dt 2 title "16.7 ms", 50 with lines dt 3 title "50 ms"
EOF
	echo "plot: $out"
fi
