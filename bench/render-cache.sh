#!/bin/bash
# render-cache.sh: `gigaview render` through its disk cache, fetching
# tiles one request each (--no-batch, the anchor: what the client did
# before batch frames carried ETags) against batches (the default), the
# same binary against the same gigaviewd, in the same run.
#
#   bench/render-cache.sh [IMAGE]
#
# IMAGE (default photos/seeding_by_Clements_Engelhardt.jpg, 5312x2988) is
# encoded once.  Two pictures: a 1920x1080 view at level 0 in the middle,
# and the whole of level 0 (--region).  For each, REPS times, alternating
# the clients: a cold run (empty cache directory) and a warm run (the same
# picture again).  Reported per client: HTTP requests and body bytes, the
# median time spent waiting for HTTP transfers (render -v: "ms waited")
# and the median wall time of the whole run (EGL start and GPU decoding
# included, which dominate it on llvmpipe); then the ratios batch/anchor.
# Both must write the same PNG (checked).  Nothing is asserted otherwise:
# the script only reports.
#
# Environment: GIGAVIEW, GIGAVIEWD (default: next to bench/, or on PATH),
# REPS (default 7), TMPDIR; DELAY_MS=N puts a proxy in front of gigaviewd
# that holds every response N ms (a network round trip; default 0: no
# proxy, loopback).
set -euo pipefail

. "$(dirname "${BASH_SOURCE[0]}")/http-lib.sh"

img=${1:-$DATA_DIR/photos/seeding_by_Clements_Engelhardt.jpg}
REPS=${REPS:-7}
gv=$(find_gigaview "")
gvd=$(find_gigaviewd "")
work=$(mktemp -d "${TMPDIR:-/tmp}/render-cache.XXXXXX")
trap 'http_cleanup; rm -rf "$work"' EXIT
mkdir "$work/s"
gv=$(snapshot_gigaview "$gv" "$work")

echo "# $(date -u '+%F %T') UTC; $(machine_line)"
echo "# $(describe_build "$gv")"
echo "# image $(basename "$img"); $REPS reps"
"$gv" encode "$img" -o "$work/s/img.gv" >/dev/null 2>&1 || die "encode failed"
cat >"$work/d.conf" <<EOF
listen = 127.0.0.1
port = 0
store_dir = "$work/s"
threads = 2
log_level = info
EOF
start_gigaviewd "$gvd" "$work/d.conf" "$work/d.log"
base=http://127.0.0.1:$GVD_PORT
if [ "${DELAY_MS:-0}" != 0 ]; then
	cat >"$work/delay.py" <<'PY'
import http.server, sys, time, urllib.request, urllib.error
delay, upstream, portfile = float(sys.argv[1]) / 1000, sys.argv[2], sys.argv[3]
class H(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"
    disable_nagle_algorithm = True     # else 40 ms delayed-ACK stalls
    def log_message(self, *a): pass
    def do_POST(self):
        self.do_GET(self.rfile.read(int(self.headers.get("Content-Length", 0))))
    def do_GET(self, data=None):
        hdrs = {k: self.headers[k] for k in ("Content-Type", "If-None-Match") if self.headers[k]}
        try:
            with urllib.request.urlopen(urllib.request.Request(upstream + self.path, data, hdrs)) as r:
                status, body, h = r.status, r.read(), r.headers
        except urllib.error.HTTPError as e:
            status, body, h = e.code, e.read(), e.headers
        time.sleep(delay)
        self.send_response(status)
        for k in ("Content-Type", "ETag", "Cache-Control"):
            if h.get(k): self.send_header(k, h.get(k))
        self.send_header("Content-Length", str(len(body)))
        self._headers_buffer.append(b"\r\n" + body)  # end_headers, and the
        self.flush_headers()                          # body in the same write
s = http.server.ThreadingHTTPServer(("127.0.0.1", 0), H)
s.daemon_threads = True
open(portfile, "w").write(str(s.server_address[1]))
s.serve_forever()
PY
	python3 "$work/delay.py" "$DELAY_MS" "$base" "$work/delay.port" &
	SERVER_PIDS+=("$!")
	for _ in $(seq 50); do [ -s "$work/delay.port" ] && break; sleep 0.1; done
	base=http://127.0.0.1:$(cat "$work/delay.port")
	echo "# every response held ${DELAY_MS} ms by a proxy (python http.server)"
fi
read -r W H < <("$gv" info "$work/s/img.gv" 2>/dev/null |
	sed -n 's/^image *\([0-9]*\) x \([0-9]*\),.*/\1 \2/p' | head -1)
[ -n "${W:-}" ] || die "cannot read the image size"

# one MODE CACHE OUT ARGS...: one render (MODE anchor: --no-batch);
# prints "seconds requests bytes waited-ms".
one() {
	local m=$1 cache=$2 out=$3 t0 t1
	shift 3
	[ "$m" = anchor ] && set -- --no-batch "$@"
	t0=$(date +%s.%N)
	"$gv" render "$base" --image img --cache-dir "$cache" -o "$out" -v "$@" 2>"$work/err" >/dev/null ||
		{ cat "$work/err" >&2; die "render failed"; }
	t1=$(date +%s.%N)
	sed -n 's/.*http: \([0-9]*\) requests, .* revalidated (304), \([0-9]*\) bytes, \([0-9.]*\) ms waited.*/\1 \2 \3/p' "$work/err" |
		awk -v t="$(echo "$t1 - $t0" | bc)" '{ print t, $1, $2, $3 }'
}

median() { sort -g | awk '{ a[NR] = $1 } END { print a[int((NR + 1) / 2)] }'; }

# picture NAME ARGS...: REPS cold + warm runs of each client.
picture() {
	local name=$1 c r
	shift
	: >"$work/res"
	for r in $(seq "$REPS"); do
		for c in anchor batch; do
			rm -rf "$work/cache-$c"
			echo "$c cold $(one $c "$work/cache-$c" "$work/$c.png" "$@")" >>"$work/res"
			echo "$c warm $(one $c "$work/cache-$c" "$work/$c-w.png" "$@")" >>"$work/res"
		done
		cmp -s "$work/anchor.png" "$work/batch.png" && cmp -s "$work/anchor.png" "$work/batch-w.png" ||
			die "$name: the two clients rendered different pictures"
	done
	echo
	echo "## $name"
	printf '%-7s %-5s %9s %12s %10s %10s\n' client cache requests bytes 'http ms' 'run ms'
	col() { awk -v c="$1" -v w="$2" -v k="$3" '$1 == c && $2 == w { print $k }' "$work/res" | median; }
	for c in anchor batch; do
		for w in cold warm; do
			printf '%-7s %-5s %9d %12d %10.1f %10.1f\n' $c $w "$(col $c $w 4)" "$(col $c $w 5)" \
				"$(col $c $w 6)" "$(echo "$(col $c $w 3) * 1000" | bc)"
		done
	done
	for w in cold warm; do
		echo "# $w: requests $(col anchor $w 4) -> $(col batch $w 4); median http wait batch/anchor" \
			"$(echo "scale=3; $(col batch $w 6) / $(col anchor $w 6)" | bc)," \
			"median run batch/anchor $(echo "scale=3; $(col batch $w 3) / $(col anchor $w 3)" | bc)"
	done
}

picture "view 1920x1080 at level 0" --center $((W / 2)),$((H / 2)) --zoom 0 --size 1920x1080
picture "all of level 0 (${W}x${H})" --level 0 --region 0,0,$W,$H
