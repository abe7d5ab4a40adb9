#!/bin/bash
# http-iiif.sh: IIIF 512-pixel JPEG tiles, gigaviewd against iipsrv (Debian
# iipimage-server, FastCGI behind nginx) in the same run, on loopback.
#
#   bench/http-iiif.sh [--gigaview PATH] [--gigaviewd PATH] [IMAGE...]
#
# Each image is encoded into a store (gigaview encode, default settings) for
# gigaviewd, and made into a pyramid TIFF for iipsrv with
#   vips tiffsave IN ID.tif --tile --pyramid --compression jpeg --Q 90 \
#       --tile-width 256 --tile-height 256
# The URL list holds, for every scale factor s in SCALES (default 1 2 4 8),
# every tile that OpenSeadragon asks for when info.json says tiles of width
# 512: /iiif/3/ID/x,y,w,h/W,/0/default.jpg with a region of 512*s pixels
# (cut at the image's edge) and W = ceil(w/s). nginx maps /iiif/3/ID/REST to
# iipsrv's IIIF=ID.tif/REST, so both servers get the very same URLs. Both
# write JPEG at quality 90 (gigaviewd's jpeg_quality default; iipsrv's
# JPEG_QUALITY is set to 90).
#
# gigaviewd runs at its default configuration (only listen, port,
# store_dir and access_log are set; GV_CONF adds lines, e.g.
# GV_CONF="output_cache_bytes = 0" to see the renders alone). First the
# cold pass: each server freshly started, every URL of the list requested
# exactly once, in one shuffled order (the same for both), over COLD_CONNS
# keep-alive connections (bench/iiif_cold.py): req/s, p50/p99/max. Then the
# warm runs: wrk GETs random URLs of the list (same seeds, so the same
# sequence for every server) at CONNS connections for DURATION seconds per
# run, REPS rounds alternating between the servers after a short warm-up.
# It reports the best req/s of each, the ratio gigaviewd/iipsrv (the
# project's goal is >= 2.0 warm, with a p99 no worse than iipsrv's),
# p50/p99/max latency, errors (non-2xx/3xx and socket errors, all runs),
# server CPU time per request, gigaviewd's cache counters, and peak RSS
# beside the memory budget the configuration documents (cache_bytes +
# decoder_cache_bytes + output_cache_bytes). Nothing is asserted: the
# script only reports.
#
# Environment:
#   GIGAVIEW, GIGAVIEWD  binaries (default: next to bench/, or on PATH)
#   QUICK=1        DURATION=10 and a 2 s warm-up
#   DURATION=S     seconds per wrk run (default 30)
#   REPS=N         rounds (default 2)
#   CONNS=N        wrk connections (default 64); WRK_THREADS (default 2)
#   COLD_CONNS=N   connections of the cold pass (default 16)
#   THREADS=N      iipsrv FastCGI processes (default 2)
#   GV_CONF="k = v"  a line added to gigaviewd's configuration (default none)
#   IIP_CACHE_MB=N iipsrv MAX_IMAGE_CACHE_SIZE in MB (default 10, its default)
#   SCALES="1 2 4 8"  IIIF scale factors in the URL list
#   TMPDIR=DIR     scratch space (default /tmp)
set -euo pipefail

# shellcheck source=SCRIPTDIR/http-lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/http-lib.sh"

bench_args "$@"

IIPSRV=${IIPSRV:-/usr/lib/iipimage-server/iipsrv.fcgi}
need_cmd nginx nginx
need_cmd wrk wrk
need_cmd curl curl
need_cmd jq jq
need_cmd vips libvips-tools
need_cmd vipsheader libvips-tools
need_cmd spawn-fcgi spawn-fcgi
if [ ! -x "$IIPSRV" ]; then
	echo "# $IIPSRV not found: installing Debian package iipimage-server" >&2
	apt-get install -y iipimage-server >&2 || die "apt-get install iipimage-server failed"
	[ -x "$IIPSRV" ] || die "$IIPSRV still missing after installing iipimage-server"
fi
GV_SRC=$(find_gigaview "$gv_arg")
GVD_SRC=$(find_gigaviewd "$gvd_arg")
QUICK=${QUICK:-0}
if [ "$QUICK" = 1 ]; then DURATION=${DURATION:-10}; WARM=2; else DURATION=${DURATION:-30}; WARM=3; fi
REPS=${REPS:-2}
CONNS=${CONNS:-64}
WRK_THREADS=${WRK_THREADS:-2}
THREADS=${THREADS:-2}
COLD_CONNS=${COLD_CONNS:-16}
GV_CONF=${GV_CONF:-}
IIP_CACHE_MB=${IIP_CACHE_MB:-10}
SCALES=${SCALES:-1 2 4 8}
export CONNS WRK_THREADS

if [ ${#inputs[@]} -eq 0 ]; then
	inputs=("$DATA_DIR/photos/Dragonfly_by_Bolly.jpg" "$DATA_DIR/large/marble-srtm-relief-10800x5400.png")
fi
for f in "${inputs[@]}"; do [ -r "$f" ] || die "cannot read input $f"; done

WORK=$(mktemp -d "${TMPDIR:-/tmp}/gv-http-iiif.XXXXXX")
chmod 755 "$WORK"
trap 'http_cleanup; [ "${KEEP:-0}" = 1 ] || rm -rf "$WORK"' EXIT
trap 'exit 130' INT TERM
GV=$(snapshot_gigaview "$GV_SRC" "$WORK")
cp "$GVD_SRC" "$WORK/gigaviewd"
# the OpenImageIO module beside the copy, as beside the build's binary
snapshot_module "$GVD_SRC" "$WORK"
GVD=$WORK/gigaviewd
write_wrk_lua "$WORK/urls.lua"
mkdir -p "$WORK/stores" "$WORK/tif" "$WORK/nginx/tmp" "$WORK/out"

echo "# encoding ${#inputs[@]} image(s): stores and pyramid TIFFs" >&2
urls=$WORK/iiif.urls
: >"$urls"
ids=()
for f in "${inputs[@]}"; do
	id=$(basename "${f%.*}" | tr -c 'A-Za-z0-9._\n-' '_')
	ids+=("$id")
	"$GV" encode "$f" -o "$WORK/stores/$id.gv" >/dev/null 2>&1 || die "gigaview encode $f failed"
	vips tiffsave "$f" "$WORK/tif/$id.tif" --tile --pyramid --compression jpeg --Q 90 \
		--tile-width 256 --tile-height 256 || die "vips tiffsave $f failed"
	awk -v id="$id" -v W="$(img_w "$f")" -v H="$(img_h "$f")" -v scales="$SCALES" 'BEGIN {
		n = split(scales, sc, " ")
		for (i = 1; i <= n; i++) {
			s = sc[i]; t = 512 * s
			for (y = 0; y < H; y += t) for (x = 0; x < W; x += t) {
				w = (W - x < t) ? W - x : t; h = (H - y < t) ? H - y : t
				printf "/iiif/3/%s/%d,%d,%d,%d/%d,/0/default.jpg\n", id, x, y, w, h, int((w + s - 1) / s)
			}
		}
	}' >>"$urls"
done
chmod -R a+rX "$WORK/tif"
nurls=$(wc -l <"$urls")

# gigaviewd at its default configuration.
cat >"$WORK/gigaviewd.conf" <<EOF
listen = "127.0.0.1"
port = 0
store_dir = "$WORK/stores"
access_log = "off"
$GV_CONF
EOF
"$GVD" -t -c "$WORK/gigaviewd.conf" >/dev/null || die "gigaviewd rejects the configuration"
# gv_key KEY: its value in force (the file's, else the default), in bytes
# for sizes.
gv_key() {
	local v
	v=$(sed -n "s/^$1 = //p" "$WORK/gigaviewd.conf" | tail -1)
	[ -n "$v" ] || v=$("$GVD" -S | sed -n "s/^#* *$1 = \([^ ]*\).*/\1/p" | tail -1)
	numfmt --from=iec "${v//\"/}"
}
start_gigaviewd "$GVD" "$WORK/gigaviewd.conf" "$WORK/gigaviewd.log"
gv_labels=(gigaviewd) gv_pids=("$GVD_PID") gv_ports=("$GVD_PORT")
echo "# gigaviewd (defaults${GV_CONF:+ + $GV_CONF}) pid $GVD_PID on 127.0.0.1:$GVD_PORT" >&2

# iipsrv: THREADS FastCGI processes sharing one socket (spawn-fcgi -F), behind nginx.
FPORT=$(free_port)
env FILESYSTEM_PREFIX="$WORK/tif/" JPEG_QUALITY=90 VERBOSITY=1 LOGFILE="$WORK/iipsrv.log" \
	MAX_IMAGE_CACHE_SIZE="$IIP_CACHE_MB" \
	spawn-fcgi -a 127.0.0.1 -p "$FPORT" -F "$THREADS" -P "$WORK/iipsrv.pids" -- "$IIPSRV" >/dev/null \
	|| die "spawn-fcgi $IIPSRV failed"
mapfile -t IIP_PIDS <"$WORK/iipsrv.pids"
SERVER_PIDS+=("${IIP_PIDS[@]}")
NPORT=$(free_port)
{
	nginx_conf_head "$WORK/nginx"
	cat <<EOF
    server {
        listen 127.0.0.1:$NPORT;
        location ~ ^/iiif/3/([A-Za-z0-9._-]+)/(.+)\$ {
            fastcgi_pass 127.0.0.1:$FPORT;
            fastcgi_param QUERY_STRING "IIIF=\$1.tif/\$2";
            fastcgi_param REQUEST_METHOD \$request_method;
            fastcgi_param REQUEST_URI \$request_uri;
            fastcgi_param SERVER_PROTOCOL \$server_protocol;
            fastcgi_param HTTP_HOST \$host;
        }
    }
}
EOF
} >"$WORK/nginx/nginx.conf"
start_nginx "$WORK/nginx/nginx.conf" "$WORK/nginx" "$NPORT"
echo "# iipsrv pids ${IIP_PIDS[*]} on 127.0.0.1:$FPORT behind nginx $NGX_PID (workers $NGX_WORKERS) on 127.0.0.1:$NPORT" >&2
port_free 11211 || echo "# note: something listens on 127.0.0.1:11211 (memcached?); iipsrv may cache its output there" >&2

# The cold pass: both servers were just started, nothing has been asked.
shuf --random-source=<(yes) "$urls" >"$WORK/cold.urls"
declare -A cold
for s in iipsrv gigaviewd; do
	[ "$s" = iipsrv ] && p=$NPORT || p=$GVD_PORT
	cold[$s]=$(python3 "$(dirname "${BASH_SOURCE[0]}")/iiif_cold.py" "http://127.0.0.1:$p" "$WORK/cold.urls" "$COLD_CONNS")
	echo "# cold pass $s: ${cold[$s]}" >&2
done
gv_cold_metrics=$(curl -sf "http://127.0.0.1:$GVD_PORT/metrics" || true)

# Check a sample of URLs: 200, image/jpeg, the same pixel size from every server.
check() { # LABEL PORT URL -> prints "WxH bytes"
	local f=$WORK/out/$1.jpg h
	h=$(curl -s -o "$f" -w '%{http_code} %{content_type}' "http://127.0.0.1:$2$3") || true
	[ "${h%%;*}" = "200 image/jpeg" ] || die "$1: $3 answered '$h' (wanted 200 image/jpeg)"
	echo "$(img_w "$f")x$(img_h "$f") $(stat -c %s "$f")"
}
samples=$( (for id in "${ids[@]}"; do grep -m1 "/$id/" "$urls"; grep "/$id/" "$urls" | tail -1; done;
	shuf -n 4 --random-source=<(yes) "$urls") )
for u in $samples; do
	ref=$(check iipsrv "$NPORT" "$u")
	for i in "${!gv_labels[@]}"; do
		got=$(check "${gv_labels[$i]}" "${gv_ports[$i]}" "$u")
		[ "${got% *}" = "${ref% *}" ] || die "size differs on $u: iipsrv ${ref% *}, ${gv_labels[$i]} ${got% *}"
	done
	echo "# ok $u: ${ref% *}, iipsrv ${ref#* } bytes, gigaviewd ${got#* } bytes" >&2
done

servers=("${gv_labels[@]}" iipsrv)
port_of() { local i; for i in "${!gv_labels[@]}"; do [ "${gv_labels[$i]}" = "$1" ] && { echo "${gv_ports[$i]}"; return; }; done; echo "$NPORT"; }
pid_of() { local i; for i in "${!gv_labels[@]}"; do [ "${gv_labels[$i]}" = "$1" ] && { echo "${gv_pids[$i]}"; return; }; done; }
server_pids() { if [ "$1" = iipsrv ]; then echo "${IIP_PIDS[*]} $NGX_WORKERS"; else pid_of "$1"; fi; }

res=$WORK/runs
: >"$res"
echo "# warm-up ${WARM}s each (not reported)" >&2
for s in "${servers[@]}"; do
	URLS=$urls wrk -t "$WRK_THREADS" -c "$CONNS" -d "${WARM}s" -s "$WORK/urls.lua" "http://127.0.0.1:$(port_of "$s")" >/dev/null 2>&1 || true
done
declare -A rss_runs split_runs
n=${#servers[@]}
for r in $(seq "$REPS"); do
	for k in $(seq 0 $((n - 1))); do
		s=${servers[$(((k + r - 1) % n))]}   # rotate the order every round
		pids=$(server_pids "$s")
		[ "$s" = iipsrv ] || wt0=$(worker_ticks "$pids")
		# shellcheck disable=SC2086
		run_wrk "$s" "$(port_of "$s")" "$urls" "$DURATION" "$res" $pids
		for p in $pids; do kill -0 "$p" 2>/dev/null || die "$s (pid $p) died during the run"; done
		if [ "$s" != iipsrv ]; then
			rss_runs[$s]="${rss_runs[$s]:-} $(($(status_kb VmRSS "$pids") / 1024))"
			split_runs[$s]="${split_runs[$s]:-} $(worker_split "$wt0" "$(worker_ticks "$pids")")"
		fi
	done
done

runs_of() { awk -v l="$2" '$1 == l { printf "%s%.0f", (n++ ? ", " : ""), $2 }' "$1"; }
cpu_of() { awk -v l="$2" '$1 == l { c += $10 * $6; n += $6 } END { printf "%.3f", (n ? c / n : 0) }' "$1"; }
row() {
	local name=$1 label=$2
	# shellcheck disable=SC2046
	set -- $(best_of "$res" "$label")
	printf '| %s | %.0f | %s | %.1f | %.1f | %.1f | %d | %s | %.0f |\n' "$name" "$2" "$(runs_of "$res" "$label")" \
		"$3" "$4" "$5" "$(sum_col "$res" "$label" 7)" "$(cpu_of "$res" "$label")" "${11}"
}
iip_best=$(best_of "$res" iipsrv | cut -d' ' -f2)

# metric TEXT NAME: the value of sample NAME in the /metrics TEXT.
metric() { awk -v n="$2" '$1 == n { print $2 }' <<<"$1"; }
gv_metrics=$(curl -sf "http://127.0.0.1:$GVD_PORT/metrics" || true)
mib() { echo $(($1 / 1048576)); }
budget=$(($(gv_key cache_bytes) + $(gv_key decoder_cache_bytes) + $(gv_key output_cache_bytes)))

resident=$(gv_key resident_bytes 2>/dev/null || true)   # absent before 2026-12-02
echo "## http-iiif.sh, $(date '+%F %H:%M %Z')"
echo
echo "- $(machine_line); load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "- $(describe_build "$GV_SRC")"
echo "- gigaviewd $GVD_SRC (md5 $(md5sum "$GVD_SRC" | cut -c1-12)); iipsrv $(dpkg-query -W -f '${Version}' iipimage-server 2>/dev/null || echo '?') ($IIPSRV); $(nginx -v 2>&1 | sed 's/^nginx version: //'); $(wrk -v 2>&1 | head -1 | cut -d' ' -f1-2); vips $(vips --version | sed 's/^vips-//')"
echo "- inputs: ${inputs[*]}"
echo "- $nurls IIIF tile URLs (scale factors $SCALES, 512-px tiles, JPEG); stores $(du -cb "$WORK"/stores/*.gv | tail -1 | cut -f1) bytes, pyramid TIFFs $(du -cb "$WORK"/tif/*.tif | tail -1 | cut -f1) bytes"
echo "- gigaviewd at its defaults${GV_CONF:+ plus '$GV_CONF'}: threads = $(gv_key threads), render_threads = $(gv_key render_threads), render_queue = $(gv_key render_queue), cache_bytes = $(mib "$(gv_key cache_bytes)") MiB, decoder_cache_bytes = $(mib "$(gv_key decoder_cache_bytes)") MiB${resident:+ (resident_bytes = $(mib "$resident") MiB of it)}, output_cache_bytes = $(mib "$(gv_key output_cache_bytes)") MiB, jpeg_quality = $(gv_key jpeg_quality); iipsrv: $THREADS FastCGI processes (spawn-fcgi -F $THREADS), JPEG_QUALITY=90, MAX_IMAGE_CACHE_SIZE=$IIP_CACHE_MB MB, behind nginx (2 workers, fastcgi_pass, no upstream keepalive)"
echo
echo "**Cold** (each server just started; every URL once, the same shuffled order, $COLD_CONNS keep-alive connections, bench/iiif_cold.py):"
echo
echo "| server | requests | ok | errors | seconds | req/s | p50 ms | p99 ms | max ms |"
echo "|---|---|---|---|---|---|---|---|---|"
for s in gigaviewd iipsrv; do
	echo "| $s | $(tr ' ' '\n' <<<"${cold[$s]}" | paste -sd'|' | sed 's/|/ | /g') |"
done
echo
awk -v a="$(cut -d' ' -f5 <<<"${cold[gigaviewd]}")" -v b="$(cut -d' ' -f5 <<<"${cold[iipsrv]}")" \
	-v pa="$(cut -d' ' -f7 <<<"${cold[gigaviewd]}")" -v pb="$(cut -d' ' -f7 <<<"${cold[iipsrv]}")" 'BEGIN {
	printf "- **cold: gigaviewd / iipsrv %.2fx req/s**, p99 %.0f ms against %.0f ms\n", (b > 0 ? a / b : 0), pa, pb }'
echo "- gigaviewd after the cold pass: tile cache $(metric "$gv_cold_metrics" gigaview_tile_cache_misses_total) decodes, $(metric "$gv_cold_metrics" gigaview_tile_cache_hits_total) hits, $(metric "$gv_cold_metrics" gigaview_tile_cache_waits_total) waits for another request's decode, $(metric "$gv_cold_metrics" gigaview_tile_cache_evictions_total) evictions; render queue wait: $(metric "$gv_cold_metrics" gigaview_render_queue_wait_seconds_count) renders, $(awk -v s="$(metric "$gv_cold_metrics" gigaview_render_queue_wait_seconds_sum)" -v n="$(metric "$gv_cold_metrics" gigaview_render_queue_wait_seconds_count)" 'BEGIN { printf "%.1f", n ? 1000 * s / n : 0 }') ms mean"
stages=$(awk '$1 ~ /^gigaview_render_stage_seconds_(sum|count)[{]/ {
	match($1, /stage="[^"]*"/); st = substr($1, RSTART + 7, RLENGTH - 8)
	if ($1 ~ /_sum/) sum[st] = $2; else cnt[st] = $2
	if (!(st in seen)) { seen[st] = 1; order[n++] = st } }
	END { for (i = 0; i < n; i++) { st = order[i]
		printf "%s%s %.2f s (%.1f ms a render)", (i ? ", " : ""), st, sum[st], cnt[st] ? 1000 * sum[st] / cnt[st] : 0 } }' <<<"$gv_cold_metrics")
echo "- gigaviewd's render stages in the cold pass (gigaview_render_stage_seconds, summed over the renders): ${stages:-none}"
echo
echo "**Warm** (wrk -t$WRK_THREADS -c$CONNS -d${DURATION}s --latency --timeout 10s, random URL of the list per request, ${WARM}s warm-up, $REPS rounds alternating, best run shown):"
echo
echo "| server | req/s (best) | runs | p50 ms | p99 ms | max ms | errors (all runs) | server CPU ms/req | bytes/resp |"
echo "|---|---|---|---|---|---|---|---|---|"
row "gigaviewd (defaults)" gigaviewd
row "iipsrv + nginx" iipsrv
echo
# shellcheck disable=SC2046
set -- $(best_of "$res" gigaviewd)
gp99=$4
# shellcheck disable=SC2046
set -- $(best_of "$res" iipsrv)
ip99=$4
awk -v a="$(best_of "$res" gigaviewd | cut -d' ' -f2)" -v b="$iip_best" -v pa="$gp99" -v pb="$ip99" \
	-v ca="$(cpu_of "$res" gigaviewd)" -v cb="$(cpu_of "$res" iipsrv)" 'BEGIN {
	printf "- **warm: gigaviewd / iipsrv %.2fx req/s** (goal >= 2.0); **p99 %.1f ms against %.1f ms** (goal: no worse); server CPU per request %.2fx iipsrv+nginx'"'"'s\n", (b > 0 ? a / b : 0), pa, pb, (cb > 0 ? ca / cb : 0) }'
st=$(awk 'index($1, "gigaview_http_requests_total{route=\"iiif_image\"") == 1 {
	match($1, /status="[^"]*"/); c[substr($1, RSTART + 8, RLENGTH - 9)] += $2 }
	END { for (k in c) printf "%s%s: %d", (n++ ? ", " : ""), k, c[k] }' <<<"$gv_metrics")
lw=$(grep -acE ' (warn|error) ' "$WORK/gigaviewd.log" || true)
echo "- gigaviewd at the end: output cache $(metric "$gv_metrics" gigaview_output_cache_hits_total) hits, $(metric "$gv_metrics" gigaview_output_cache_misses_total) misses, $(mib "$(metric "$gv_metrics" gigaview_output_cache_bytes)") MiB held; tile cache $(mib "$(metric "$gv_metrics" gigaview_tile_cache_bytes)") MiB held, $(metric "$gv_metrics" gigaview_tile_cache_misses_total) decodes in all; page cache $(mib "$(metric "$gv_metrics" gigaview_page_cache_bytes)") MiB; renders refused (503): $(metric "$gv_metrics" gigaview_render_rejected_total); iiif_image responses by status: ${st:-none}; $lw warn/error log line(s)."
echo "- gigaviewd peak RSS (VmHWM) **$(($(status_kb VmHWM "$GVD_PID") / 1024)) MiB** against the documented budget of $(mib "$budget") MiB (cache_bytes + decoder_cache_bytes + output_cache_bytes, plus about 125 MiB of libraries); VmRSS after each run (MiB):${rss_runs[gigaviewd]}; HTTP threads' CPU share per run (%):${split_runs[gigaviewd]}."
# shellcheck disable=SC2086
echo "- iipsrv: peak RSS $(($(status_kb VmHWM "${IIP_PIDS[@]}") / 1024)) MiB over its $THREADS processes; nginx workers $(($(status_kb VmHWM $NGX_WORKERS) / 1024)) MiB."
