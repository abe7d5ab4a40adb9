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
# 1280x720), --budget $BUDGET (default 4; and the viewer's default
# --budget-ms), no vsync (the driver has none), a cold tile cache.  The
# path runs twice: with tiles decoded on the decode thread (a GL context
# sharing the window's, the default) and decoded in the frame on the
# render thread (--no-decode-thread, the design before it, the anchor of
# the ratio).  For the frames drawn while the view moved it reports, for
# each run, p50, p99 and the longest of: the frame time (the frame's whole
# work: events, scheduling, the decode work, the draw, glFinish), the
# render thread's decode work in it (--stats' decode_ms: the decodes in
# the frame; posting jobs, testing fences and publishing with the thread),
# the rest of the frame, and the frames that published a tile; the frames
# over 50 ms and those whose decode work took over 50 ms; the longest
# frame and the longest decode work of the two runs as ratios; and writes
# the frame times as a plot (bench/view-frames.png when PLOT=1, else into
# the scratch directory).  Another anchor, measured in the same run on the
# same store: `gigaview render` of one view of the path (level 0, its own
# cold cache), the still-frame client's time to a picture.  Nothing is
# asserted.
#
# Environment: GIGAVIEW, GIGAVIEWD, IMAGE, SIZE, BUDGET, PLOT, TMPDIR.
set -euo pipefail

# shellcheck source=SCRIPTDIR/http-lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/http-lib.sh"

bench_args "$@"
bench_no_inputs
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
mkdir "$work/stores" "$work/cache2"

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

# Two runs on the same path, each with a cold tile cache: tiles decoded on
# the decode thread (a GL context sharing the window's; the default), and
# decoded in the frame on the render thread (--no-decode-thread, the
# design before it).
for mode in thread frame; do
	opt=""
	[ "$mode" = frame ] && opt=--no-decode-thread
	mkdir -p "$work/cache-$mode"
	echo "# viewer: $SIZE, budget $BUDGET, decode $mode" >&2
	SDL_VIDEODRIVER=offscreen XDG_CACHE_HOME="$work/cache-$mode" "$GV" view "$url" \
		--image big --size "$SIZE" --budget "$BUDGET" --no-vsync --no-overlay $opt \
		--script "$work/path.txt" --stats "$work/frames-$mode.tsv" 2>"$work/view-$mode.err" ||
		{ cat "$work/view-$mode.err" >&2; die "the viewer failed (decode $mode)"; }
	said="decode thread,"
	[ "$mode" = frame ] && said="decode in frame,"
	grep -q "$said" "$work/view-$mode.err" || {
		grep -m1 'no decode thread' "$work/view-$mode.err" >&2
		die "the viewer did not decode as asked ($mode)"
	}
done

# The anchor: one view of the path rendered by the still-frame client.
t0=$(date +%s%N)
XDG_CACHE_HOME="$work/cache2" "$GV" render "$url" --image big --center "$cx,$cy" \
	--zoom 0 --size "$SIZE" -o "$work/r.png"
t1=$(date +%s%N)
render_ms=$(( (t1 - t0) / 1000000 ))

# pct FILE: p50, p99 and the largest of a column of numbers (sorted here).
pct() {
	sort -g "$1" | awk '{ t[++n] = $1 }
		END { if (!n) { print "-"; exit }
		      printf "%.1f / %.1f / %.1f ms", t[int(n * 0.5) + 1], t[int((n - 1) * 0.99) + 1], t[n] }'
}
# For each run, over the frames drawn while the view moved: the frame time;
# the render thread's decode work in the frame (--stats' decode_ms: the
# decodes themselves in the frame; posting jobs, testing fences and
# publishing with the thread); the rest of the frame (events, scheduling,
# the draw, glFinish); and the frames that published a tile.
for mode in thread frame; do
	f="$work/frames-$mode.tsv"
	awk -F'\t' 'NR > 1 && $3 == 1 { print $2 }' "$f" >"$work/ms-$mode.txt"
	awk -F'\t' 'NR > 1 && $3 == 1 { print $7 }' "$f" >"$work/dec-$mode.txt"
	awk -F'\t' 'NR > 1 && $3 == 1 { print $2 - $7 }' "$f" >"$work/rest-$mode.txt"
	awk -F'\t' 'NR > 1 && $3 == 1 && $8 > prev { print $2 } NR > 1 { prev = $8 }' \
		"$f" >"$work/pub-$mode.txt"
	# Frames over 50 ms: all; those whose decode work took over 50 ms;
	# those drawn while decode jobs were in flight (this frame's or the
	# last one's), whose draw competed for the CPU with the decoding on
	# llvmpipe's threads.
	awk -F'\t' 'NR > 1 && $3 == 1 { n++; if ($2 > 50) { o++; if ($7 > 50) d++;
			if ($9 > 0 || prev > 0) c++ } } NR > 1 { prev = $9 }
		END { printf "%d %d %d %d\n", n, o, d, c }' "$f" >"$work/n-$mode.txt"
done
printf '%-40s %-28s %-28s\n' "p50 / p99 / longest, frames while moving" \
	"decode thread" "decode in the frame (anchor)"
row() { printf '%-40s %-28s %-28s\n' "$1" "$(pct "$work/$2-thread.txt")" "$(pct "$work/$2-frame.txt")"; }
row "frame time" ms
row "  decode work on the render thread" dec
row "  the rest (events, draw, glFinish)" rest
row "frames that published a tile" pub
read -r n_t o_t d_t c_t <"$work/n-thread.txt"
read -r n_f o_f d_f c_f <"$work/n-frame.txt"
printf '%-40s %-28s %-28s\n' "frames while moving" "$n_t" "$n_f"
printf '%-40s %-28s %-28s\n' "frames over 50 ms" "$o_t" "$o_f"
printf '%-40s %-28s %-28s\n' "  of which decode work over 50 ms" "$d_t" "$d_f"
printf '%-40s %-28s %-28s\n' "  of which drawn with jobs in flight" "$c_t" "$c_f"
lt=$(sort -g "$work/ms-thread.txt" | tail -n 1)
lf=$(sort -g "$work/ms-frame.txt" | tail -n 1)
dt=$(sort -g "$work/dec-thread.txt" | tail -n 1)
df=$(sort -g "$work/dec-frame.txt" | tail -n 1)
awk -v lt="$lt" -v lf="$lf" -v dt="$dt" -v df="$df" 'BEGIN {
	printf "longest frame: %.1f ms with the thread, %.1f ms in the frame: %.2fx shorter\n", lt, lf, lf / lt
	printf "longest decode work in a frame: %.2f ms with the thread, %.1f ms in the frame: %.0fx shorter\n", dt, df, df / (dt > 0 ? dt : 0.001)
	printf "goal: no frame stalls over 50 ms from decoding on llvmpipe: %s\n", dt <= 50 ? "met (decode work)" : "MISSED"
}'
# The first moving frame is the jump to the path's start, the first draw
# (llvmpipe compiles the display shader then): the longest frame without it.
l2() { awk -F'\t' 'NR > 1 && $3 == 1 && seen++ { print $2 }' "$work/frames-$1.tsv" |
	sort -g | tail -n 1; }
awk -v lt="$(l2 thread)" -v lf="$(l2 frame)" 'BEGIN {
	printf "longest frame after the first draw: %.1f ms with the thread, %.1f ms in the frame: %.2fx shorter\n", lt, lf, lf / lt }'
p50=$(sort -g "$work/ms-thread.txt" | awk '{ t[++n] = $1 } END { print t[int(n * 0.5) + 1] }')
awk -v r="$render_ms" -v p="$p50" 'BEGIN { printf "anchor: render, one view, cold  %d ms  (%.0fx the viewer p50 with the thread)\n", r, r / p }'
for mode in thread frame; do
	awk -F'\t' 'NR > 1 && $3 == 1 { printf "%s %.1f %.2f %d\n", $1, $2, $7, $9 }' \
		"$work/frames-$mode.tsv" | sort -k2,2gr | head -n 3 |
		awk -v m="$mode" '{ s = s sprintf("  #%s %s ms (decode work %s ms, %s in flight)", $1, $2, $3, $4) }
			END { printf "longest frames, %s:%s\n", m, s }'
done
grep '^view: .* frames' "$work/view-thread.err" | sed 's/^/thread: /'
grep '^view: .* frames' "$work/view-frame.err" | sed 's/^/frame:  /'

out="$work/view-frames.png"
[ "${PLOT:-0}" = 1 ] && out="$BENCH_DIR/view-frames.png"
if command -v gnuplot >/dev/null 2>&1; then
	gnuplot <<EOF
set terminal pngcairo size 1000,480
set output "$out"
set title "gigaview view: frame time while panning synth:$IMAGE at $SIZE (budget $BUDGET)"
set xlabel "frame"
set ylabel "ms (log)"
set logscale y
set yrange [0.05:2000]
set key top right
plot "$work/frames-frame.tsv" using 1:(\$3 == 1 ? \$2 : 1/0) with points pt 7 ps 0.3 lc rgb "#cc4444" title "decode in the frame: frame time", \
     "$work/frames-thread.tsv" using 1:(\$3 == 1 ? \$2 : 1/0) with points pt 7 ps 0.3 lc rgb "#3366cc" title "decode thread: frame time", \
     "$work/frames-thread.tsv" using 1:(\$3 == 1 ? (\$7 < 0.05 ? 0.05 : \$7) : 1/0) with points pt 2 ps 0.4 lc rgb "#22aa22" title "decode thread: its decode work on the render thread (0.05: none)", \
     "$work/frames-frame.tsv" using 1:(\$3 == 1 && \$7 > 0.05 ? \$7 : 1/0) with points pt 1 ps 0.5 lc rgb "#aa6600" title "in the frame: its decode work", \
     16.7 with lines dt 2 lc rgb "black" title "16.7 ms", 50 with lines dt 3 lc rgb "black" title "50 ms"
EOF
	echo "plot: $out"
fi
