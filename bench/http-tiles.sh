#!/bin/bash
# http-tiles.sh: raw tiles over HTTP, gigaviewd against nginx serving the
# same tile bytes as static files, in the same run, on loopback.
#
#   bench/http-tiles.sh [--gigaview PATH] [--gigaviewd PATH] [IMAGE...]
#
# Each image is encoded into a store (gigaview encode, default settings).
# gigaviewd serves the stores; every tile is fetched once from it with curl
# into files laid out like the URLs (www/v1/images/ID/tiles/L/X/Y), and
# nginx serves that directory. So both servers answer the very same URL list
# with the very same bytes. wrk then GETs random URLs of that list (a Lua
# script; thread i seeds with i, so both servers see the same sequence) at
# CONNS connections for DURATION seconds, alternating between the servers,
# REPS times each after a short warm-up. It reports the best req/s of each,
# the ratio gigaviewd/nginx (the project's goal is >= 1.5, at <= 0.5x
# nginx's server CPU per request), p50/p99/max latency, errors
# (non-2xx/3xx and socket errors, all runs), the server CPU time per
# request, and gigaviewd's peak RSS (VmHWM) against cache_bytes.
# Nothing is asserted: the script only reports.
#
# Environment:
#   GIGAVIEW, GIGAVIEWD  binaries (default: next to bench/, or on PATH)
#   QUICK=1       DURATION=10 and a 2 s warm-up
#   DURATION=S    seconds per wrk run (default 30)
#   REPS=N        runs per server, alternating (default 2)
#   CONNS=N       wrk connections (default 64); WRK_THREADS (default 2)
#   THREADS=N     gigaviewd threads (default 2); nginx always has 2 workers
#   CACHE=SIZE    gigaviewd cache_bytes (default 256M)
#   TMPDIR=DIR    scratch space (default /tmp)
set -euo pipefail

# shellcheck source=SCRIPTDIR/http-lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/http-lib.sh"

bench_args "$@"

need_cmd nginx nginx
need_cmd wrk wrk
need_cmd curl curl
need_cmd jq jq
GV_SRC=$(find_gigaview "$gv_arg")
GVD_SRC=$(find_gigaviewd "$gvd_arg")
QUICK=${QUICK:-0}
if [ "$QUICK" = 1 ]; then DURATION=${DURATION:-10}; WARM=2; else DURATION=${DURATION:-30}; WARM=3; fi
REPS=${REPS:-2}
CONNS=${CONNS:-64}
WRK_THREADS=${WRK_THREADS:-2}
THREADS=${THREADS:-2}
CACHE=${CACHE:-256M}
export CONNS WRK_THREADS

if [ ${#inputs[@]} -eq 0 ]; then
	inputs=("$DATA_DIR/photos/Dragonfly_by_Bolly.jpg" "$DATA_DIR/large/marble-srtm-relief-10800x5400.png")
fi
for f in "${inputs[@]}"; do [ -r "$f" ] || die "cannot read input $f"; done

WORK=$(mktemp -d "${TMPDIR:-/tmp}/gv-http-tiles.XXXXXX")
chmod 755 "$WORK"   # nginx workers run as another user when we are root
trap 'http_cleanup; [ "${KEEP:-0}" = 1 ] || rm -rf "$WORK"' EXIT
trap 'exit 130' INT TERM
GV=$(snapshot_gigaview "$GV_SRC" "$WORK")
cp "$GVD_SRC" "$WORK/gigaviewd"
# the OpenImageIO module beside the copy, as beside the build's binary
snapshot_module "$GVD_SRC" "$WORK"
GVD=$WORK/gigaviewd
write_wrk_lua "$WORK/urls.lua"
mkdir -p "$WORK/stores" "$WORK/www" "$WORK/nginx/tmp"

echo "# encoding ${#inputs[@]} image(s)" >&2
ids=()
for f in "${inputs[@]}"; do
	id=$(basename "${f%.*}" | tr -c 'A-Za-z0-9._\n-' '_')
	"$GV" encode "$f" -o "$WORK/stores/$id.gv" >/dev/null 2>&1 || die "gigaview encode $f failed"
	ids+=("$id")
done

cat >"$WORK/gigaviewd.conf" <<EOF
listen = "127.0.0.1"
port = 0
threads = $THREADS
store_dir = "$WORK/stores"
cache_bytes = $CACHE
log_level = info
access_log = "off"
EOF
"$GVD" -t -c "$WORK/gigaviewd.conf" >/dev/null || die "gigaviewd rejects the configuration"
start_gigaviewd "$GVD" "$WORK/gigaviewd.conf" "$WORK/gigaviewd.log"
GPORT=$GVD_PORT
echo "# gigaviewd pid $GVD_PID on 127.0.0.1:$GPORT" >&2

# The URL list: every tile of every tiled level of every store.
urls=$WORK/tiles.urls
: >"$urls"
store_bytes=0
for id in "${ids[@]}"; do
	meta=$(curl -sf "http://127.0.0.1:$GPORT/v1/images/$id") || die "GET /v1/images/$id failed"
	store_bytes=$((store_bytes + $(jq -r .bytes <<<"$meta")))
	jq -r --arg id "$id" '.levels[] | . as $l | range(0; $l.tiles_y) as $y | range(0; $l.tiles_x) as $x
		| "/v1/images/\($id)/tiles/\($l.level)/\($x)/\($y)"' <<<"$meta" >>"$urls"
done
ntiles=$(wc -l <"$urls")

# Fetch every tile once into www/, laid out like its URL.
awk -v p="$GPORT" -v w="$WORK/www" '{ printf "url = \"http://127.0.0.1:%s%s\"\noutput = \"%s%s\"\n", p, $0, w, $0 }' \
	"$urls" >"$WORK/fetch.curl"
curl -sf --create-dirs -K "$WORK/fetch.curl" || die "fetching the tiles from gigaviewd failed"
chmod -R a+rX "$WORK/www"   # curl --create-dirs makes 0750 directories
nfiles=$(find "$WORK/www" -type f | wc -l)
[ "$nfiles" = "$ntiles" ] || die "fetched $nfiles files for $ntiles tiles"
tile_bytes=$(find "$WORK/www" -type f -printf '%s\n' | awk '{ s += $1 } END { print s }')
tile_stats=$(find "$WORK/www" -type f -printf '%s\n' | sort -n | awk '{ a[NR] = $1 } END {
	printf "min %d, median %d, max %d", a[1], a[int((NR + 1) / 2)], a[NR] }')

NPORT=$(free_port)
{
	nginx_conf_head "$WORK/nginx"
	cat <<EOF
    server {
        listen 127.0.0.1:$NPORT;
        root $WORK/www;
        location / { }
    }
}
EOF
} >"$WORK/nginx/nginx.conf"
start_nginx "$WORK/nginx/nginx.conf" "$WORK/nginx" "$NPORT"
echo "# nginx master pid $NGX_PID (workers $NGX_WORKERS) on 127.0.0.1:$NPORT" >&2

# Both servers must give the same bytes for a sample of URLs.
for u in $(shuf -n 8 --random-source=<(yes) "$urls"); do
	cmp -s <(curl -sf "http://127.0.0.1:$GPORT$u") <(curl -sf "http://127.0.0.1:$NPORT$u") \
		|| die "gigaviewd and nginx differ on $u"
done

res=$WORK/runs
: >"$res"
echo "# warm-up ${WARM}s each (not reported)" >&2
URLS=$urls wrk -t "$WRK_THREADS" -c "$CONNS" -d "${WARM}s" -s "$WORK/urls.lua" "http://127.0.0.1:$GPORT" >/dev/null 2>&1 || true
URLS=$urls wrk -t "$WRK_THREADS" -c "$CONNS" -d "${WARM}s" -s "$WORK/urls.lua" "http://127.0.0.1:$NPORT" >/dev/null 2>&1 || true
rss_runs=""
split_runs=""
for r in $(seq "$REPS"); do
	# Alternate, and swap the order on every other round.
	if [ $((r % 2)) = 1 ]; then order="gigaviewd nginx"; else order="nginx gigaviewd"; fi
	for s in $order; do
		if [ "$s" = gigaviewd ]; then
			wt0=$(worker_ticks "$GVD_PID")
			run_wrk gigaviewd "$GPORT" "$urls" "$DURATION" "$res" "$GVD_PID"
			kill -0 "$GVD_PID" 2>/dev/null || die "gigaviewd died during the run (see $WORK/gigaviewd.log)"
			split_runs="$split_runs $(worker_split "$wt0" "$(worker_ticks "$GVD_PID")")"
			rss_runs="$rss_runs $(($(status_kb VmRSS "$GVD_PID") / 1024))"
		else
			# shellcheck disable=SC2086
			run_wrk nginx "$NPORT" "$urls" "$DURATION" "$res" $NGX_WORKERS
		fi
	done
done

hwm=$(status_kb VmHWM "$GVD_PID")
# shellcheck disable=SC2086
ngx_hwm=$(status_kb VmHWM $NGX_WORKERS)
metrics=$(curl -sf "http://127.0.0.1:$GPORT/metrics" || true)
metric() { awk -v m="$1" '$1 == m { print $2 }' <<<"$metrics"; }
tile_5xx=$(awk 'index($1, "gigaview_http_requests_total{route=\"tile\",status=\"5") == 1 { s += $2 } END { print s + 0 }' <<<"$metrics")
tile_all=$(awk 'index($1, "gigaview_http_requests_total{route=\"tile\"") == 1 { s += $2 } END { print s + 0 }' <<<"$metrics")
log_warn=$(grep -acE ' (warn|error) ' "$WORK/gigaviewd.log" || true)

b_gv=$(best_of "$res" gigaviewd)
b_ng=$(best_of "$res" nginx)
runs_of() { awk -v l="$2" '$1 == l { printf "%s%.0f", (n++ ? ", " : ""), $2 }' "$1"; }
cpu_of() { awk -v l="$2" '$1 == l { c += $10 * $6; n += $6 } END { printf "%.3f", (n ? c / n : 0) }' "$1"; }
row() {
	local name=$1 line=$2 label=$3
	# shellcheck disable=SC2086
	set -- $line
	printf '| %s | %.0f | %s | %.2f | %.2f | %.1f | %d | %s | %.0f |\n' "$name" "$2" "$(runs_of "$res" "$label")" \
		"$3" "$4" "$5" "$(sum_col "$res" "$label" 7)" "$(cpu_of "$res" "$label")" "${11}"
}

echo "## http-tiles.sh, $(date '+%F %H:%M %Z')"
echo
echo "- $(machine_line); load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "- $(describe_build "$GV_SRC")"
echo "- gigaviewd $GVD_SRC (md5 $(md5sum "$GVD_SRC" | cut -c1-12)); $(nginx -v 2>&1 | sed 's/^nginx version: //'); $(wrk -v 2>&1 | head -1 | cut -d' ' -f1-2)"
echo "- inputs: ${inputs[*]}"
echo "- $ntiles tiles in ${#ids[@]} store(s) of $store_bytes bytes; tile bodies $tile_bytes bytes in all ($tile_stats)"
echo "- wrk -t$WRK_THREADS -c$CONNS -d${DURATION}s --latency --timeout 10s, random tile URL of the list per request, ${WARM}s warm-up, $REPS runs each alternating, best run shown"
echo "- gigaviewd: threads = $THREADS, cache_bytes = $CACHE, access_log off; nginx: worker_processes 2, sendfile on, access_log off, keepalive_requests 1000000"
echo
echo "| server | req/s (best) | runs | p50 ms | p99 ms | max ms | errors (all runs) | server CPU ms/req | bytes/resp |"
echo "|---|---|---|---|---|---|---|---|---|"
row gigaviewd "$b_gv" gigaviewd
row "nginx (static files)" "$b_ng" nginx
echo
awk -v a="$(cut -d' ' -f2 <<<"$b_gv")" -v b="$(cut -d' ' -f2 <<<"$b_ng")" \
	-v ca="$(cpu_of "$res" gigaviewd)" -v cb="$(cpu_of "$res" nginx)" 'BEGIN {
	printf "**gigaviewd / nginx: %.2fx req/s** (goal >= 1.5); server CPU per request %.2fx nginx'"'"'s (goal <= 0.5)\n", (b > 0 ? a / b : 0), (cb > 0 ? ca / cb : 0) }'
echo
echo "gigaviewd memory: peak RSS (VmHWM) $((hwm / 1024)) MiB with cache_bytes = $CACHE; VmRSS after each of its runs (MiB):$rss_runs."
echo "CPU share of gigaviewd's worker threads in each of its runs (%):$split_runs (connections are spread over the threads when they are accepted)."
echo "Page cache: $(metric gigaview_page_cache_bytes) bytes in $(metric gigaview_page_cache_pages) pages, $(metric gigaview_page_cache_hits_total) hits, $(metric gigaview_page_cache_misses_total) misses, $(metric gigaview_page_cache_evictions_total) evictions. Tile requests counted by /metrics: $tile_all, of which 5xx: $tile_5xx."
echo "gigaviewd log: $log_warn warn/error line(s)$( [ "$log_warn" = 0 ] || { echo ", the first ones:"; grep -aE ' (warn|error) ' "$WORK/gigaviewd.log" | head -5 | sed 's/^/    /'; })."
echo "nginx workers' peak RSS: $((ngx_hwm / 1024)) MiB in all."
