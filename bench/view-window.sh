#!/bin/bash
# view-window.sh: how fast the native viewer (`gigaview view`, under SDL's
# offscreen driver: llvmpipe where there is no GPU) redraws after a change
# of the display window on a sample store, against what a client without
# GPU windowing pays for the same change: asking the server for the view
# again with the new window.  Same stores, same windows, same run.
#
#   bench/view-window.sh [--gigaview PATH] [--gigaviewd PATH]
#
# Stores, made here (gigaview encode --bits 16 --max-error 40, as
# tests/client_render_codes.sh makes its c5): c5, $IMAGE (default
# 4096x4096) pixels of 5 channels of 16-bit codes (oiiotool: a 64-pixel
# checker plus uniform noise of a fifth of the range), and, unless
# GRAY=0, g1, its first channel alone.
#
# Viewer: one `gigaview view` per store at $SIZE (default 1280x720),
# --no-vsync --no-overlay --stats, on a 1:1 view of level 0 at the
# image's centre.  Its script: `settle` (the view's tiles resident), a
# wait of SETTLE_WAIT ms (default 10000) for the prefetching that follows
# at rest; one window (W0) and a `shot` of it; `counters before`;
# REDRAWS frames (default 20) drawn again with no change (the
# reference: a Shift-press and its release at the same pixel, which show
# and hide an empty selection, each followed by `frames 1`; no motion,
# so nothing is prefetched); `counters redrawn`; then CHANGES (default
# 40) times `window Wi` followed by `frames 1`; `counters after`, and
# the end.  A `window` line runs at the start of a frame
# (the viewer builds the new tables and uploads them) and that frame
# draws it; with --stats the viewer ends every drawn frame with glFinish
# and writes the frame's time, so the time of that frame is the time
# from the change to the completed frame (--stats has all it needs; no
# outside timing).  The changes are the last CHANGES frames of the
# --stats file (the script's end quits before the next one is
# recorded), the reference frames the REDRAWS before them.  The
# `counters` lines say how many tiles were fetched and decoded before
# and after the changes: a change should fetch and decode none.
#
# Anchor: the same view as the server's region, level 0, the same
# rectangle and size, `format=png` (what the browser viewer's region
# renderer asks for at this size), `window=Wi`, fetched with one curl
# over one keep-alive connection, one request after another; the time per
# change is curl's time_total of each request (request sent to last
# byte).  W0 is asked first, untimed, so the server's decoded-tile cache
# holds the view's tiles as the viewer's atlas does; every Wi differs,
# so no answer comes from the server's output cache.  This is fairer
# than `gigaview render --window` run per change: render is itself a GPU
# client (it fetches tiles and decodes them on its own GPU), so each run
# would time a process start, an EGL context and tile decodes, not a
# round trip to a server that applies the window.  The anchor leaves out
# the client's PNG decode and display, and runs over loopback: both
# favour it.
#
# Also checked, not asserted: the viewer's shot of W0 against the
# server's region with W0 (idiff; equal at 1:1 is what
# tests/client_render_codes.sh checks).  Nothing is asserted: the script
# only reports; the ratio is anchor / viewer (above 1: the viewer is
# faster).
#
# Environment: GIGAVIEW, GIGAVIEWD (default: next to bench/, or on PATH),
# IMAGE (WxH, default 4096x4096), SIZE (default 1280x720), CHANGES
# (default 40), REDRAWS (default 20, even), SETTLE_WAIT (ms, default 10000),
# GRAY (default 1), TMPDIR.
set -euo pipefail

# shellcheck source=bench/http-lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/http-lib.sh"

bench_args "$@"
bench_no_inputs
need_cmd oiiotool openimageio-tools
need_cmd idiff openimageio-tools
need_cmd curl curl
GV=$(find_gigaview "$gv_arg")
# find_gigaviewd looks beside $GIGAVIEW.
# shellcheck disable=SC2034
GIGAVIEW=$GV
GVD=$(find_gigaviewd "$gvd_arg")
IMAGE=${IMAGE:-4096x4096}
SIZE=${SIZE:-1280x720}
CHANGES=${CHANGES:-40}
REDRAWS=${REDRAWS:-20}
SETTLE_WAIT=${SETTLE_WAIT:-10000}
GRAY=${GRAY:-1}
W=${SIZE%x*} H=${SIZE#*x}
IW=${IMAGE%x*} IH=${IMAGE#*x}
if [ "$W" -gt "$IW" ] || [ "$H" -gt "$IH" ]; then die "SIZE $SIZE is larger than IMAGE $IMAGE"; fi
# The view: 1:1 at level 0 about the centre; the same pixels as a region.
cx=$((IW / 2)) cy=$((IH / 2))
rx=$((cx - W / 2)) ry=$((cy - H / 2))

work=$(mktemp -d "${TMPDIR:-/tmp}/view-window.XXXXXX")
trap 'http_cleanup; rm -rf "$work"' EXIT
mkdir "$work/stores" "$work/cache"
GV=$(snapshot_gigaview "$GV" "$work")
cp "$GVD" "$work/gigaviewd"
GVD=$work/gigaviewd

echo "# $(date -u '+%F %T') UTC; $(machine_line)"
echo "# $(describe_build "$GV")"
echo "# IMAGE $IMAGE, SIZE $SIZE, CHANGES $CHANGES, REDRAWS $REDRAWS, SETTLE_WAIT $SETTLE_WAIT ms"

oiiotool --pattern "noise:type=uniform:min=0:max=0.2" "$IMAGE" 5 \
	--pattern "checker:width=64:height=64:color1=0.2,0.4,0.6,0.8,0.8:color2=0,0.1,0.2,0.3,0.4" \
	"$IMAGE" 5 --add -d uint16 -o "$work/c5.tif" || die "oiiotool c5"
stores=c5
"$GV" encode --bits 16 --max-error 40 "$work/c5.tif" -o "$work/stores/c5.gv" >/dev/null ||
	die "encode c5 failed"
if [ "$GRAY" = 1 ]; then
	oiiotool "$work/c5.tif" --ch 0 -o "$work/g1.tif" || die "oiiotool g1"
	"$GV" encode --bits 16 --max-error 40 "$work/g1.tif" -o "$work/stores/g1.gv" >/dev/null ||
		die "encode g1 failed"
	stores="c5 g1"
fi
rm -f "$work"/*.tif
for id in $stores; do
	echo "# $id: $("$GV" info "$work/stores/$id.gv" | sed -n 's/^samples *//p'), \
$(stat -c %s "$work/stores/$id.gv") bytes"
done

cat >"$work/d.conf" <<EOF
listen = 127.0.0.1
port = 0
store_dir = "$work/stores"
threads = 2
log_level = info
access_log = "off"
EOF
start_gigaviewd "$GVD" "$work/d.conf" "$work/d.log"
url="http://127.0.0.1:$GVD_PORT"

# windows ID CHANNELS: W0 .. W$CHANGES, one a line, each different (a
# window a channel, black, white and gamma varied with the line and the
# channel; all valid on 16-bit codes).
windows() {
	awk -v n="$CHANGES" -v c="$2" 'BEGIN {
		for (i = 0; i <= n; i++) {
			s = ""
			for (k = 0; k < c; k++) {
				b = (i * 97 + k * 1500) % 20000
				w = b + 20000 + (i * 331 + k * 977) % 25000
				g = 0.6 + ((i + k) % 15) / 10
				s = s sprintf("%s%d,%d,%.1f", k ? ";" : "", b, w, g)
			}
			print s
		}
	}'
}

# pct FILE: p50, p99 and the largest of a column of numbers (nearest rank).
pct() {
	sort -g "$1" | awk '{ t[++n] = $1 }
		END { if (!n) { print "- / - / -"; exit }
		      printf "%.1f / %.1f / %.1f", t[int(n * 0.5) + 1], t[int((n - 1) * 0.99) + 1], t[n] }'
}
p50() { sort -g "$1" | awk '{ t[++n] = $1 } END { print n ? t[int(n * 0.5) + 1] : 0 }'; }
load() { cut -d' ' -f1-3 /proc/loadavg; }

: >"$work/table.txt"
for id in $stores; do
	ch=5
	[ "$id" = g1 ] && ch=1
	windows "$id" "$ch" >"$work/win-$id.txt"
	w0=$(head -n 1 "$work/win-$id.txt")

	# ---- the viewer
	s=$work/script-$id.txt
	{
		echo "view $cx,$cy,0"
		echo "settle"
		echo "wait $SETTLE_WAIT"
		echo "window $w0"
		echo "shot $work/shot-$id.png"
		echo "counters before"
		# The reference: a redraw with no change (a Shift-press starts a
		# selection, its release at the same pixel hides it: each draws
		# the frame again, and nothing moves, so nothing is prefetched).
		for _ in $(seq $((REDRAWS / 2))); do
			echo "down $((W / 2)) $((H / 2)) shift"
			echo "frames 1"
			echo "up $((W / 2)) $((H / 2))"
			echo "frames 1"
		done
		echo "counters redrawn"
		tail -n +2 "$work/win-$id.txt" | while read -r wi; do
			echo "window $wi"
			echo "frames 1"
		done
		echo "counters after"
	} >"$s"
	echo "# $id: viewer (load $(load))" >&2
	t0=$(now)
	SDL_VIDEODRIVER=offscreen XDG_CACHE_HOME="$work/cache" "$GV" view "$url" --image "$id" \
		--size "$SIZE" --no-vsync --no-overlay --script "$s" --stats "$work/frames-$id.tsv" \
		>"$work/view-$id.out" 2>"$work/view-$id.err" ||
		{ cat "$work/view-$id.err" >&2; die "the viewer failed ($id)"; }
	t1=$(now)
	# The last rows of --stats: REDRAWS reference frames, then CHANGES.
	nr=$(((REDRAWS / 2) * 2))
	tail -n "$CHANGES" "$work/frames-$id.tsv" >"$work/vchange-$id.tsv"
	tail -n $((CHANGES + nr)) "$work/frames-$id.tsv" | head -n "$nr" >"$work/vredraw-$id.tsv"
	cut -f2 "$work/vchange-$id.tsv" >"$work/vchange-$id.txt"
	cut -f2 "$work/vredraw-$id.tsv" >"$work/vredraw-$id.txt"
	# Frames of either kind drawn with decode jobs in flight, or moving.
	busy=$(cat "$work/vredraw-$id.tsv" "$work/vchange-$id.tsv" |
		awk -F'\t' '$9 > 0 || $3 != 0 { n++ } END { print n + 0 }')
	# The frames at rest before them (the wait: nothing drawn): the floor.
	idle=$(head -n -$((CHANGES + nr + 1)) "$work/frames-$id.tsv" | tail -n 20 | cut -f2 |
		sort -g | awk '{ t[++n] = $1 } END { print n ? t[int(n * 0.5) + 1] : 0 }')

	# ---- the anchor: the same rectangle from the server, one window each
	q="$url/v1/images/$id/region?level=0&x=$rx&y=$ry&w=$W&h=$H&format=png"
	curl -sS -o "$work/region-$id.png" -w '%{http_code}' "$q&window=${w0//;/%3B}" \
		>"$work/warm-$id.txt" || die "region request failed ($id)"
	[ "$(cat "$work/warm-$id.txt")" = 200 ] || die "region answered $(cat "$work/warm-$id.txt") ($id)"
	tail -n +2 "$work/win-$id.txt" | while read -r wi; do
		echo "url = \"$q&window=${wi//;/%3B}\""
		echo "output = \"/dev/null\""
	done >"$work/curl-$id.cfg"
	echo "# $id: anchor (load $(load))" >&2
	curl -sS -K "$work/curl-$id.cfg" \
		-w '%{http_code} %{time_total} %{size_download} %{num_connects}\n' \
		>"$work/anchor-$id.txt" || die "curl failed ($id)"
	awk '{ print $2 * 1000 }' "$work/anchor-$id.txt" >"$work/achange-$id.txt"
	bad=$(awk '$1 != 200' "$work/anchor-$id.txt" | wc -l)
	conns=$(awk '{ s += $4 } END { print s }' "$work/anchor-$id.txt")
	bytes=$(awk '{ s += $3 } END { printf "%.0f", s / NR }' "$work/anchor-$id.txt")

	# ---- report
	echo
	echo "== $id ($ch channel(s)): view $cx,$cy at 1:1, $SIZE; region level 0 $rx,$ry ${W}x$H"
	grep '^\(before\|redrawn\|after\) ' "$work/view-$id.out" | sed 's/ window=.*//; s/^/  counters: /'
	# counts NAME: "fetched decodes" of the viewer's `counters NAME` line.
	counts() { sed -n "s/^$1 fetched=\([0-9]*\) decodes=\([0-9]*\).*/\1 \2/p" "$work/view-$id.out"; }
	read -r bf bd <<<"$(counts before)"
	read -r rf rd <<<"$(counts redrawn)"
	read -r af ad <<<"$(counts after)"
	df=$((af - rf)) dd=$((ad - rd))
	echo "  during the $CHANGES changes: $df tiles fetched, $dd decoded" \
		"(during the $nr redraws before them: $((rf - bf)), $((rd - bd)));" \
		"$busy of those frames moving or with decode jobs in flight"
	if idiff -a "$work/shot-$id.png" "$work/region-$id.png" >"$work/idiff-$id.txt" 2>&1; then
		same="equal"
	else
		same="DIFFERENT ($(grep -m1 -i 'max error' "$work/idiff-$id.txt" | sed 's/^ *//'))"
	fi
	echo "  the viewer's frame of W0 and the server's region with W0: $same"
	printf '  %-52s %s ms\n' "viewer: change -> completed frame, p50 / p99 / max" \
		"$(pct "$work/vchange-$id.txt")"
	printf '  %-52s %s ms\n' "viewer: redraw, no change, p50 / p99 / max" \
		"$(pct "$work/vredraw-$id.txt")"
	printf '  %-52s %s ms\n' "viewer: frame at rest, nothing drawn, p50" "$idle"
	printf '  %-52s %s ms\n' "anchor: region request with the window, p50/p99/max" \
		"$(pct "$work/achange-$id.txt")"
	echo "  anchor: $CHANGES requests, $bad not 200, $conns new connection(s), $bytes bytes an answer (PNG)"
	echo "  viewer process: $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }') s in all;" \
		"$(grep -m1 '^view: .* frames' "$work/view-$id.err" | sed 's/^view: //')"
	vp=$(p50 "$work/vchange-$id.txt")
	ap=$(p50 "$work/achange-$id.txt")
	vx=$(sort -g "$work/vchange-$id.txt" | tail -n 1)
	ax=$(sort -g "$work/achange-$id.txt" | tail -n 1)
	awk -v v="$vp" -v a="$ap" -v vx="$vx" -v ax="$ax" 'BEGIN {
		printf "  ratio anchor / viewer: p50 %.2fx, max %.2fx (above 1: the viewer redraws faster)\n",
			a / v, ax / vx }'
	printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$id" "$(pct "$work/vchange-$id.txt")" \
		"$(pct "$work/achange-$id.txt")" \
		"$(awk -v v="$vp" -v a="$ap" 'BEGIN { printf "%.2fx", a / v }')" \
		"$df / $dd" "$(pct "$work/vredraw-$id.txt")" >>"$work/table.txt"
done

echo
echo "summary (ms, p50 / p99 / max; ratio = anchor p50 / viewer p50):"
printf '%-6s %-26s %-26s %-8s %-16s %s\n' store "viewer change->frame" \
	"anchor region+window" ratio "fetched/decoded" "viewer redraw, no change"
while IFS=$'\t' read -r id v a r fd rd; do
	printf '%-6s %-26s %-26s %-8s %-16s %s\n' "$id" "$v" "$a" "$r" "$fd" "$rd"
done <"$work/table.txt"
echo "load after: $(load)"
