# Helpers for the HTTP benchmarks (bench/http-*.sh). Sourced, not run.
# Everything listens on 127.0.0.1 only; every server started here is
# recorded in SERVER_PIDS and killed by http_cleanup (the scripts trap it).
# shellcheck shell=bash

# shellcheck source=SCRIPTDIR/lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

SERVER_PIDS=()

# find_gigaviewd [PATH]: the argument, else $GIGAVIEWD, else gigaviewd next
# to the gigaview binary in use ($GIGAVIEW), else ../gigaviewd next to this
# directory, else gigaviewd on PATH.
find_gigaviewd() {
	local c
	for c in "${1:-}" "${GIGAVIEWD:-}" "${GIGAVIEW:+$(dirname "$GIGAVIEW")/gigaviewd}" \
		"$BENCH_DIR/../gigaviewd"; do
		if [ -n "$c" ] && [ -x "$c" ] && [ -f "$c" ]; then
			echo "$c"; return 0
		fi
	done
	c=$(command -v gigaviewd 2>/dev/null) && { echo "$c"; return 0; }
	die "no gigaviewd binary: pass --gigaviewd PATH or set GIGAVIEWD"
}

# http_cleanup: TERM every server we started, then KILL what is left.
http_cleanup() {
	local p
	for p in "${SERVER_PIDS[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
	sleep 0.3
	for p in "${SERVER_PIDS[@]}"; do
		if kill -0 "$p" 2>/dev/null; then
			sleep 1
			kill -KILL "$p" 2>/dev/null || true
		fi
	done
	wait 2>/dev/null || true
}

# port_free PORT: true when nothing accepts on 127.0.0.1:PORT.
port_free() { ! (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }

# free_port: a port nothing listens on (there is a small race; the servers
# started on it fail loudly if they lose it).
free_port() {
	local p
	for _ in $(seq 50); do
		p=$((20000 + RANDOM % 40000))
		port_free "$p" && { echo "$p"; return 0; }
	done
	die "no free port found"
}

# wait_port PORT PID [SECONDS]: waits until PORT accepts, or PID dies.
wait_port() {
	local n=$((${3:-20} * 10))
	for _ in $(seq "$n"); do
		port_free "$1" || return 0
		kill -0 "$2" 2>/dev/null || return 1
		sleep 0.1
	done
	return 1
}

# start_browser_gigaviewd BIN DIR [ACCESS_LOG]: gigaviewd BIN serving the
# stores of DIR/stores on 127.0.0.1 for the browser benches (2 threads, an
# access log only where ACCESS_LOG names one), its configuration in
# DIR/gv.conf and its log in DIR/gigaviewd.log; sets GVD_PID and GVD_PORT.
start_browser_gigaviewd() {
	cat >"$2/gv.conf" <<EOF
listen = 127.0.0.1
port = 0
store_dir = "$2/stores"
threads = 2
log_level = info
access_log = "${3:-off}"
EOF
	start_gigaviewd "$1" "$2/gv.conf" "$2/gigaviewd.log"
}

# browser_gpu: what the browser benches pass as --gpu: host with GPU=host,
# else swiftshader.
browser_gpu() {
	if [ "${GPU:-}" = host ]; then echo host; else echo swiftshader; fi
}

# start_gigaviewd BIN CONF LOG: starts it on the port of CONF (use port = 0),
# sets GVD_PID and GVD_PORT from its "listening on" line.
start_gigaviewd() {
	"$1" -c "$2" 2>"$3" &
	GVD_PID=$!
	SERVER_PIDS+=("$GVD_PID")
	GVD_PORT=""
	for _ in $(seq 200); do
		GVD_PORT=$(grep -ao 'listening on http://127\.0\.0\.1:[0-9]*' "$3" 2>/dev/null | sed 's/.*://' | head -1 || true)
		[ -n "$GVD_PORT" ] && break
		kill -0 "$GVD_PID" 2>/dev/null || { cat "$3" >&2; die "gigaviewd exited at start"; }
		sleep 0.1
	done
	[ -n "$GVD_PORT" ] || { cat "$3" >&2; die "gigaviewd did not report its port"; }
}

# stop_pid PID: TERM and wait for one server we started.
stop_pid() {
	kill -TERM "$1" 2>/dev/null || true
	wait "$1" 2>/dev/null || true
}

# nginx_conf_head DIR: the common part of a minimal non-daemon nginx.conf
# whose pid, logs and temp files live in DIR; the caller appends server{}s
# and the closing brace of http{}.
nginx_conf_head() {
	cat <<EOF
daemon off;
master_process on;
worker_processes 2;
pid $1/nginx.pid;
error_log $1/error.log warn;
events { worker_connections 4096; }
http {
    access_log off;
    sendfile on;
    tcp_nopush on;
    keepalive_requests 1000000;
    keepalive_timeout 65;
    default_type application/octet-stream;
    types { image/jpeg jpg; }
    client_body_temp_path $1/tmp;
    proxy_temp_path $1/tmp;
    fastcgi_temp_path $1/tmp;
    uwsgi_temp_path $1/tmp;
    scgi_temp_path $1/tmp;
EOF
}

# start_nginx CONF DIR PORT: starts nginx in the foreground (as our child),
# sets NGX_PID (the master) and NGX_WORKERS once PORT accepts.
start_nginx() {
	nginx -p "$2" -c "$1" 2>>"$2/error.log" &
	NGX_PID=$!
	SERVER_PIDS+=("$NGX_PID")
	wait_port "$3" "$NGX_PID" || { cat "$2/error.log" >&2; die "nginx did not start"; }
	sleep 0.2
	# shellcheck disable=SC2034
	NGX_WORKERS=$(pgrep -P "$NGX_PID" | tr '\n' ' ')
}

# cpu_ticks PID...: user+system clock ticks used so far by these processes.
cpu_ticks() {
	local p t=0 v
	for p in "$@"; do
		# Fields 14 and 15 (utime, stime); the command name may hold spaces.
		v=$(sed 's/.*) //' "/proc/$p/stat" 2>/dev/null | awk '{ print $12 + $13 }') || v=0
		t=$((t + ${v:-0}))
	done
	echo "$t"
}

# status_kb FIELD PID...: sum of a /proc/PID/status field (VmHWM, VmRSS) in kB.
status_kb() {
	local f=$1 p t=0 v
	shift
	for p in "$@"; do
		v=$(awk -v f="$f:" '$1 == f { print $2 }' "/proc/$p/status" 2>/dev/null)
		t=$((t + ${v:-0}))
	done
	echo "$t"
}

# write_wrk_lua FILE: the wrk script. It GETs a random path from the file
# named by $URLS (one path per line). Thread i seeds its generator with i, so
# runs against two servers request the same sequence of paths.
write_wrk_lua() {
	cat >"$1" <<'EOF'
local paths = {}
local n_threads = 0
function setup(thread)
  n_threads = n_threads + 1
  thread:set("tid", n_threads)
end
function init(args)
  local f = assert(io.open(os.getenv("URLS"), "r"))
  for line in f:lines() do
    if #line > 0 then paths[#paths + 1] = line end
  end
  f:close()
  math.randomseed(tid or 1)
end
function request()
  return wrk.format("GET", paths[math.random(#paths)])
end
EOF
}

# run_wrk LABEL PORT URLFILE SECONDS OUT PID...: runs wrk (WRK_THREADS
# threads, CONNS connections, --latency) and appends one line to OUT:
#   LABEL rps p50_ms p99_ms max_ms requests errors non2xx sockerr cpu_ms_per_req bytes_per_req
# where the CPU time is that of the PIDs (the server's processes) during the
# run. wrk's own output goes to OUT.LABEL.N.txt.
run_wrk() {
	local label=$1 port=$2 urls=$3 secs=$4 out=$5
	shift 5
	local c0 c1 n raw hz
	hz=$(getconf CLK_TCK)
	n=$(wc -l <"$out")
	raw=$out.$label.$n.txt
	c0=$(cpu_ticks "$@")
	URLS=$urls wrk -t "${WRK_THREADS:-2}" -c "${CONNS:-64}" -d "${secs}s" --timeout 10s \
		--latency -s "$WORK/urls.lua" "http://127.0.0.1:$port" >"$raw" 2>&1 || true
	c1=$(cpu_ticks "$@")
	awk -v label="$label" -v ticks=$((c1 - c0)) -v hz="$hz" '
	function ms(s) {
		if (s ~ /us$/) return s / 1000
		if (s ~ /ms$/) return s + 0
		if (s ~ /m$/) return s * 60000
		if (s ~ /s$/) return s * 1000
		return s + 0
	}
	function bytes(v, u) {
		if (u ~ /^KB/) return v * 1024
		if (u ~ /^MB/) return v * 1048576
		if (u ~ /^GB/) return v * 1073741824
		return v + 0
	}
	/^ +Latency / && !lat { max = ms($4); lat = 1 }
	/^ +50% / { p50 = ms($2) }
	/^ +99% / { p99 = ms($2) }
	/requests in .* read/ { req = $1; b = $5; sub(/[A-Za-z]+$/, "", b); u = $5; sub(/^[0-9.]+/, "", u); rbytes = bytes(b, u) }
	/^ +Non-2xx or 3xx responses:/ { non2xx = $NF }
	/^ +Socket errors:/ { gsub(/,/, ""); sock = $4 + $6 + $8 + $10 }
	/^Requests\/sec:/ { rps = $2 }
	END {
		if (req == "") { req = 0; rps = 0 }
		printf "%s %.1f %.2f %.2f %.2f %d %d %d %d %.3f %.0f\n", label, rps, p50, p99, max, req,
			non2xx + sock, non2xx, sock, (req > 0 ? ticks * 1000 / hz / req : 0),
			(req > 0 ? rbytes / req : 0)
	}' "$raw" >>"$out"
	tail -1 "$out" | awk '{ printf "#   %-22s %9.1f req/s  p50 %7.2f ms  p99 %8.2f ms  max %8.2f ms  errors %d  cpu %.3f ms/req\n", $1, $2, $3, $4, $5, $7, $10 }' >&2
}

# best_of OUT LABEL: the line with the highest req/s for LABEL.
best_of() { awk -v l="$2" '$1 == l' "$1" | sort -k2,2gr | head -1; }

# sum_col OUT LABEL COL: sum of a column over the runs of LABEL.
sum_col() { awk -v l="$2" -v c="$3" '$1 == l { s += $c } END { print s + 0 }' "$1"; }

# worker_ticks PID: "TID:TICKS" for each libmicrohttpd worker thread of PID.
worker_ticks() {
	local t
	for t in /proc/"$1"/task/*; do
		# MHD-single: each daemon's one thread (http.c), MHD-worker: a pool's
		case $(cat "$t/comm" 2>/dev/null) in MHD-single|MHD-worker) ;; *) continue ;; esac
		printf '%s:%s ' "${t##*/}" "$(sed 's/.*) //' "$t/stat" | awk '{ print $12 + $13 }')"
	done
}

# worker_split BEFORE AFTER: each worker's share of the CPU its workers used
# between two worker_ticks snapshots, e.g. "48/52".
worker_split() {
	awk -v b="$1" -v a="$2" 'BEGIN {
		n = split(b, x, " "); for (i = 1; i <= n; i++) { split(x[i], y, ":"); before[y[1]] = y[2] }
		n = split(a, x, " "); tot = 0
		for (i = 1; i <= n; i++) { split(x[i], y, ":"); d[i] = y[2] - before[y[1]]; tot += d[i] }
		for (i = 1; i <= n; i++) printf "%s%d", (i > 1 ? "/" : ""), (tot > 0 ? 100 * d[i] / tot + 0.5 : 0)
	}'
}
