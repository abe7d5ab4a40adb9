#!/usr/bin/env bash
# load-soak.sh - gigaviewd under a mixed load for a bounded time, on
# loopback: latencies, errors, and memory over time.
#
#   bench/load-soak.sh [--duration SECONDS] [--conns "64 256"]
#                      [--gigaview PATH] [--gigaviewd PATH]
#
# One gigaviewd (its filter workers included) serves two stores: the
# 16 MP "seeding" photograph (samples/) and a 25 MP procedural image.
# bench/load_client.c (libcurl multi, compiled here) keeps C requests in
# flight for DURATION / (number of C values) seconds per C, drawing from a
# shuffled list of
#
#   tile    40 %  GET /v1/images/ID/tiles/L/X/Y, any level
#   batch   10 %  POST /v1/images/ID/batch, 16 tiles
#   iiif    25 %  GET /iiif/3/ID/x,y,w,h/512,/0/default.jpg (viewer tiles)
#   region  20 %  GET /v1/images/ID/region, 512x512 JPEG at a random level
#   filter   5 %  POST /v1/images/ID/filter (negate, box blur, Sobel;
#                 only when the daemon can run filters)
#
# Errors are anything but a complete 2xx; "limited" counts deliberate
# refusals by configured limits (413, 429, 503 with Retry-After: busy
# filter queue).  The daemon's RSS (VmRSS of gigaviewd, and of its filter
# workers separately) is sampled every INTERVAL seconds and compared with
# the configured bound: cache_bytes + decoder_cache_bytes (one tile cache
# for every thread and image) + output_cache_bytes + the RSS measured
# after start-up (libraries, EGL) +
# PER_CONN for each connection of the largest phase: the working memory
# of requests in flight (responses waiting to be sent and the pages they
# point into, output images, encoder state, malloc arenas); 512 KiB by
# default, 1.6 times the 0.31 MiB per connection measured in
# bench/README.md.  Growth is reported per phase (fixed connection count):
# the RSS of its first sample, its largest, and its last.  Prints
# figures; asserts nothing, but exits 1 when a request failed.
#
# Environment: CACHE (page cache, default 4M: smaller than the stores'
# 11 MB of pages, so that it evicts), DECODER_CACHE (default
# 16M), OUTPUT_CACHE (default 16M), THREADS (default 4), PER_CONN (default 512K), INTERVAL (RSS
# sampling, default 10 s), WORK
# (scratch directory, default a new one under /tmp, removed at the end).
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/http-lib.sh"

DURATION=60
CONNS="64 256"
GV_ARG="" GVD_ARG=""
while [ $# -gt 0 ]; do
	case $1 in
	--duration) DURATION=$2; shift 2 ;;
	--conns) CONNS=$2; shift 2 ;;
	--gigaview) GV_ARG=$2; shift 2 ;;
	--gigaviewd) GVD_ARG=$2; shift 2 ;;
	-h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
	*) die "unknown argument $1 (--help)" ;;
	esac
done
CACHE=${CACHE:-4M}
DECODER_CACHE=${DECODER_CACHE:-16M}
OUTPUT_CACHE=${OUTPUT_CACHE:-16M}
THREADS=${THREADS:-4}
PER_CONN=${PER_CONN:-512K}
INTERVAL=${INTERVAL:-10}
need_cmd curl curl
need_cmd python3 python3
need_cmd cc gcc
GV=$(find_gigaview "$GV_ARG")
GVD=$(find_gigaviewd "$GVD_ARG")
WORKER=$(dirname "$GVD")/gigaview-filter-worker

own_work=0
if [ -z "${WORK:-}" ]; then
	WORK=$(mktemp -d /tmp/gv-soak.XXXXXX)
	own_work=1
fi
finish() {
	http_cleanup
	[ "$own_work" = 0 ] || rm -rf "$WORK"
}
trap finish EXIT
mkdir -p "$WORK/stores"

cc -std=c11 -D_GNU_SOURCE -O2 -Wall -Wextra "$BENCH_DIR/load_client.c" \
	-o "$WORK/load_client" -lcurl || die "cannot build load_client (libcurl4-openssl-dev)"

photo="$top/samples/seeding_by_Clements_Engelhardt.jpg"
[ -f "$WORK/stores/seeding.gv" ] || "$GV" encode --quiet "$photo" -o "$WORK/stores/seeding.gv"
[ -f "$WORK/stores/synth.gv" ] || "$GV" encode --quiet synth:6144x4096 -o "$WORK/stores/synth.gv"

to_bytes() { numfmt --from=iec "$1"; }
filters=yes
[ -x "$WORKER" ] || filters=no
cat >"$WORK/gvd.conf" <<EOF
listen = 127.0.0.1
port = 0
store_dir = "$WORK/stores"
threads = $THREADS
cache_bytes = $CACHE
decoder_cache_bytes = $DECODER_CACHE
output_cache_bytes = $OUTPUT_CACHE
connection_limit = 1024
access_log = off
log_level = info
filter_worker = "$WORKER"
filter_library_dir = "$top/filters/library"
filter_dir = ""
EOF
start_gigaviewd "$GVD" "$WORK/gvd.conf" "$WORK/gvd.log"
BASE="http://127.0.0.1:$GVD_PORT"
sleep 1
if [ "$filters" = yes ]; then
	code=$(curl -s -o /dev/null -w '%{http_code}' -H 'Content-Type: application/json' \
		-d '{"filter":"negate","level":3,"region":[0,0,64,64]}' "$BASE/v1/images/seeding/filter")
	[ "$code" = 200 ] || filters=no
fi

# The request list: 20000 lines, shuffled with a fixed seed.
python3 - "$BASE" "$WORK/requests.txt" "$filters" <<'PY'
import json, random, sys, urllib.request
base, out, filters = sys.argv[1], sys.argv[2], sys.argv[3] == "yes"
rnd = random.Random(1)
imgs = []
for i in json.load(urllib.request.urlopen(base + "/v1/images"))["images"]:
    m = json.load(urllib.request.urlopen(base + "/v1/images/" + i["id"]))
    w, h, tiled = m["width"], m["height"], m["levels_tiled"]
    levels = []
    for k in range(tiled):
        lw, lh = -(-w // 2**k), -(-h // 2**k)
        tx = 1 if lw <= 513 else -(-(lw - 1) // 512)
        ty = 1 if lh <= 513 else -(-(lh - 1) // 512)
        levels.append((lw, lh, tx, ty))
    imgs.append((m["id"], w, h, levels))
def tile(img):
    idn, w, h, levels = img
    k = rnd.randrange(len(levels))
    return k, rnd.randrange(levels[k][2]), rnd.randrange(levels[k][3])
lines = []
graphs = ["negate", "box-blur-3x3", "sobel"]
mix = [("tile", 40), ("batch", 10), ("iiif", 25), ("region", 20)] + ([("filter", 5)] if filters else [])
for n in range(20000):
    img = rnd.choice(imgs)
    idn, w, h, levels = img
    kind = rnd.choices([m[0] for m in mix], [m[1] for m in mix])[0]
    if kind == "tile":
        lines.append("tile GET /v1/images/%s/tiles/%d/%d/%d" % ((idn,) + tile(img)))
    elif kind == "batch":
        ts = [list(tile(img)) for _ in range(16)]
        lines.append("batch POST /v1/images/%s/batch %s" % (idn, json.dumps({"tiles": ts}, separators=(",", ":"))))
    elif kind == "iiif":
        s = 2 ** rnd.randrange(0, 5)          # scale factors a viewer asks for
        x = rnd.randrange(0, max(1, w - 1), 512 * s); y = rnd.randrange(0, max(1, h - 1), 512 * s)
        rw, rh = min(512 * s, w - x), min(512 * s, h - y)
        lines.append("iiif GET /iiif/3/%s/%d,%d,%d,%d/%d,/0/default.jpg" % (idn, x, y, rw, rh, -(-rw // s)))
    elif kind == "region":
        k = rnd.randrange(len(levels)); lw, lh = levels[k][0], levels[k][1]
        rw, rh = min(512, lw), min(512, lh)
        x, y = rnd.randrange(lw - rw + 1), rnd.randrange(lh - rh + 1)
        lines.append("region GET /v1/images/%s/region?level=%d&x=%d&y=%d&w=%d&h=%d&format=jpg" % (idn, k, x, y, rw, rh))
    else:
        k = min(len(levels) - 1, rnd.randrange(1, 4)); lw, lh = levels[k][0], levels[k][1]
        rw, rh = min(256, lw), min(256, lh)
        x, y = rnd.randrange(lw - rw + 1), rnd.randrange(lh - rh + 1)
        body = {"filter": rnd.choice(graphs), "level": k, "region": [x, y, rw, rh]}
        lines.append("filter POST /v1/images/%s/filter %s" % (idn, json.dumps(body, separators=(",", ":"))))
open(out, "w").write("\n".join(lines) + "\n")
PY

rss_kb() { awk '/^VmRSS/ {print $2}' "/proc/$1/status" 2>/dev/null || echo 0; }
workers_kb() {
	local s=0 p
	for p in $(pgrep -P "$GVD_PID" 2>/dev/null); do s=$((s + $(rss_kb "$p"))); done
	echo "$s"
}
base_kb=$(rss_kb "$GVD_PID")
nimg=$(ls "$WORK/stores" | wc -l)
maxc=$(echo "$CONNS" | tr ' ' '\n' | sort -n | tail -n 1)
bound_kb=$(( ($(to_bytes "$CACHE") + $(to_bytes "$DECODER_CACHE") + $(to_bytes "$OUTPUT_CACHE") +
	maxc * $(to_bytes "$PER_CONN")) / 1024 + base_kb ))

echo "# $(machine_line)"
echo "# $(describe_build "$GV")"
echo "# gigaviewd $GVD: threads $THREADS, cache_bytes $CACHE, decoder_cache_bytes $DECODER_CACHE, output_cache_bytes $OUTPUT_CACHE, $nimg images, filters $filters"
echo "# duration ${DURATION}s over connections: $CONNS; RSS every ${INTERVAL}s"
echo "# load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "# RSS after start-up $((base_kb / 1024)) MiB; bound = start-up + cache + decoder cache + output cache + $maxc x $PER_CONN = $((bound_kb / 1024)) MiB"

nphase=$(echo "$CONNS" | wc -w)
per=$((DURATION / nphase))
[ "$per" -ge 1 ] || die "duration too short for $nphase phases"
: >"$WORK/rss.txt"
t0=$(date +%s)
status=0
for c in $CONNS; do
	"$WORK/load_client" "$BASE" "$c" "$per" "$WORK/requests.txt" "$INTERVAL" \
		>"$WORK/load.$c" 2>"$WORK/progress.$c" &
	lp=$!
	while kill -0 "$lp" 2>/dev/null; do
		sleep "$INTERVAL"
		kill -0 "$GVD_PID" 2>/dev/null || die "gigaviewd died: $(tail -n 5 "$WORK/gvd.log")"
		echo "$(( $(date +%s) - t0 )) $c $(rss_kb "$GVD_PID") $(workers_kb)" >>"$WORK/rss.txt"
	done
	wait "$lp" || status=1
	echo
	echo "## $c connections, ${per}s"
	cat "$WORK/load.$c"
	grep -v '^progress' "$WORK/progress.$c" | head -n 10 || true
done

echo
echo "## RSS over time (seconds, connections, gigaviewd MiB, filter workers MiB)"
awk '{printf "%5d %4d %7.1f %7.1f\n", $1, $2, $3/1024, $4/1024}' "$WORK/rss.txt"
max_kb=$(awk 'BEGIN{m=0} {if ($3>m) m=$3} END{print m}' "$WORK/rss.txt")
echo "# peak RSS $((max_kb / 1024)) MiB against a bound of $((bound_kb / 1024)) MiB:" \
	"$([ "$max_kb" -le "$bound_kb" ] && echo inside || echo OUTSIDE)"
for c in $CONNS; do
	awk -v c="$c" '$2 == c { if (!n++) first = $3; if ($3 > m) m = $3; last = $3 }
		END { if (n) printf "# %d connections: RSS first %.1f, peak %.1f, last %.1f MiB (%d samples)\n",
			c, first / 1024, m / 1024, last / 1024, n }' "$WORK/rss.txt"
done
echo "# load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
curl -s "$BASE/metrics" | grep -E '^gigaview_(page_cache_(bytes|evictions_total|limit_bytes)|page_errors_total|open_connections) ' || true
exit "$status"
