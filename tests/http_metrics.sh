#!/bin/sh
# http_metrics.sh - /metrics counts every status gigaviewd sends under its
# own label, and the connections of every HTTP thread.
#
# With nothing else open, 13 keep-alive connections opened at once sit
# 4, 3, 3 and 3 on the 4 HTTP threads (the acceptor hands a connection to
# the thread with the fewest).  Then it provokes 200, 201, 204, 303, 304,
# 400, 401, 404, 405, 413 and 504 (201 and 504 with a GPU: storing a
# graph, and a filter past filter_timeout_ms, which the graph's compile,
# under filter_compile_timeout_ms, never meets however busy the machine
# is; without one the filter
# request's 501 or 503), notes each request's route and the status it
# got, and reads /metrics: every (route, status) counter equals the
# number of such answers, and no request counts as "other".  Three IIIF
# renders and an output-cache hit: each render, and only a render, counts
# once in every stage of gigaview_render_stage_seconds.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

mkdir "$T/s" "$T/stored" || bail "mkdir"
run encode synth:1100x700 -o "$T/s/x.gv"
[ "$rc" -eq 0 ] || bail "encode: $(cat "$T/err")"
# y: only the IIIF renders below read it, so their tiles are not decoded yet
cp "$T/s/x.gv" "$T/s/y.gv" || bail "cp"
TOKEN=m3trics
cat >"$T/m.conf" <<EOF
listen = 127.0.0.1
store_dir = "$T/s"
threads = 4
access_log = off
auth_token = "$TOKEN"
filter_dir = "$T/stored"
filter_workers = 1
filter_timeout_ms = 200
resident_bytes = 0   # y's IIIF renders below must decode
filter_compile_timeout_ms = $((GV_TEST_PATIENCE * 1000))
max_request_bytes = 1K
drain_timeout = 1
EOF
start_daemon "$T/m.conf"

# Connections by thread first, while nothing else is open: one keep-alive
# connection waits until /metrics shows it alone open (the others closed
# and counted out), then 12 more connect at once, and only once the daemon
# holds all 12 (its descriptors, seen in /proc) does each send one request;
# then the first reads /metrics again.  No handler runs while they are
# handed over, so every thread is idle and the acceptor gives each new one
# to the thread with the fewest: the 13 sit 4, 3, 3, 3, however loaded the
# machine (a request in flight would make its thread busy and skipped).
python3 - "$PORT" "$DPID" >spread.out <<'PY' || bail "the 13 connections failed"
import http.client, os, socket, sys, time
port, pid = int(sys.argv[1]), sys.argv[2]
def fds():
    return len(os.listdir("/proc/%s/fd" % pid))
def metric(conn, prefix):
    conn.request("GET", "/metrics")
    text = conn.getresponse().read().decode()
    return [l.split()[-1] for l in text.splitlines() if l.startswith(prefix)]
patience = float(os.environ["GV_TEST_PATIENCE"])
def until(cond, step):  # cond() every step s, GV_TEST_PATIENCE s at most
    end = time.monotonic() + patience
    while not cond() and time.monotonic() < end:
        time.sleep(step)
first = http.client.HTTPConnection("127.0.0.1", port, timeout=patience)
until(lambda: metric(first, "gigaview_open_connections ") == ["1"], 0.05)
base = fds()
socks = [socket.create_connection(("127.0.0.1", port)) for _ in range(12)]
until(lambda: fds() >= base + 12, 0.01)
for s in socks:
    s.sendall(b"GET /healthz HTTP/1.1\r\nHost: t\r\n\r\n")
for s in socks:
    got = b""
    while b"\r\n\r\n" not in got:
        got += s.recv(4096)
print(" ".join(sorted(metric(first, "gigaview_http_thread_open_connections{"))))
PY
check "13 connections at once: 4, 3, 3 and 3 on the 4 threads (got $(cat spread.out))" \
    test "$(cat spread.out)" = "3 3 3 4"

# The 12 healthz requests, in the tally below.
: >"$T/tally"
for i in 1 2 3 4 5 6 7 8 9 10 11 12; do echo "healthz 200" >>"$T/tally"; done
# ask ROUTE WANT PATH [CURL ARGS...]: one request; its status must be
# WANT; the answer is tallied under ROUTE.
ask() {
    route=$1 want=$2 p=$3
    shift 3
    req "$@" "$(url "$p")"
    echo "$route $code" >>"$T/tally"
    check "$route: $p answers $want (got $code)" test "$code" = "$want"
}

ask healthz 200 /healthz
gpu=$(json_get 'j["gpu"]["available"]')
ask images 200 /v1/images
ask tile 200 /v1/images/x/tiles/0/0/0
etag=$(header ETag)
ask tile 304 /v1/images/x/tiles/0/0/0 -H "If-None-Match: $etag"
ask iiif_base 303 /iiif/3/x
ask image 404 /v1/images/nope
ask none 404 /nowhere
ask none 405 /v1/images -X DELETE
ask none 204 /v1/images -X OPTIONS
ask region 400 '/v1/images/x/region?level=0&x=0&y=0&w=0&h=5'
head -c 2000 /dev/zero | tr '\0' ' ' >big.json
ask none 413 /v1/images/x/batch -X POST -H 'Content-Type: application/json' \
    --data-binary @big.json
graph='{"name": "g", "output": "g", "modules": [{"id": "g", "template": "point", "inputs": ["source"], "glsl": "return $(FilterInput1)(rel_pos);"}]}'
ask filters 401 /v1/filters -X POST --data-binary "$graph"
# 65535 sines per pixel over 1000x700: far past 200 ms on any GPU here.
spin='{"name": "spin", "output": "s", "modules": [{"id": "s", "template": "point", "inputs": ["source"], "glsl": "float s = $(FilterInput1)(rel_pos).r;\nfor (int i = 0; i < 100000000; i++) {\n  s = sin(s + float(i)) * 1.0001 + cos(s);\n  if (s > 1e30) break;\n}\nreturn vec4(s);"}]}'
if [ "$gpu" = True ]; then
    ask filters 201 /v1/filters -X POST -H "Authorization: Bearer $TOKEN" \
        --data-binary "$graph"
    ask image_filter 504 /v1/images/x/filter -X POST \
        --data-binary "{\"graph\": $spin, \"region\": [0, 0, 1000, 700]}"
else # no filters: 501 in a build without the GPU, else 503
    req -X POST --data-binary "{\"graph\": $spin, \"region\": [0, 0, 8, 8]}" \
        "$(url /v1/images/x/filter)"
    echo "image_filter $code" >>"$T/tally"
    check "image_filter: no GPU: 501 or 503 (got $code)" \
        test "$code" = 501 -o "$code" = 503
fi

# Three IIIF renders of y (one at level 0, which decodes tiles) and a
# fourth answer from the output cache, which renders nothing.
ask iiif_image 200 /iiif/3/y/0,0,512,512/512,/0/default.jpg
ask iiif_image 200 /iiif/3/y/0,0,1024,700/256,/0/default.jpg
ask iiif_image 200 /iiif/3/y/full/100,/90/gray.png
ask iiif_image 200 /iiif/3/y/0,0,512,512/512,/0/default.jpg

req "$(url /metrics)"
cp "$T/b" metrics.txt
# Each render counts once in every stage's histogram; the buckets are
# cumulative up to +Inf; the level-0 render decoded tiles and encoded.
for st in queue_wait page_read decode decode_wait resample encode; do
    n=$(sed -n "s/^gigaview_render_stage_seconds_count{stage=\"$st\"} //p" metrics.txt)
    inf=$(sed -n "s/^gigaview_render_stage_seconds_bucket{stage=\"$st\",le=\"+Inf\"} //p" metrics.txt)
    check "render stage $st: 3 renders (got ${n:-none}), +Inf bucket ${inf:-none}" \
        test "$n" = 3 -a "$inf" = 3
    check "render stage $st: buckets never decrease" sh -c "grep '^gigaview_render_stage_seconds_bucket{stage=\"$st\"' metrics.txt |
        awk '\$2 < p { bad = 1 } { p = \$2 } END { exit bad }'"
done
for st in decode encode; do
    s=$(sed -n "s/^gigaview_render_stage_seconds_sum{stage=\"$st\"} //p" metrics.txt)
    check "render stage $st took time (${s:-none} s)" \
        awk -v s="${s:-0}" 'BEGIN { exit !(s > 0) }'
done
sort "$T/tally" | uniq -c >"$T/counts"
while read -r n route status; do
    got=$(sed -n "s/^gigaview_http_requests_total{route=\"$route\",status=\"$status\"} //p" \
        metrics.txt)
    if [ "$got" = "$n" ]; then
        ok "metrics: route $route, status $status: $n"
    else
        not_ok "metrics: route $route, status $status: ${got:-none}, wanted $n" \
            "$(grep "route=\"$route\"" metrics.txt | grep requests_total)"
    fi
done <"$T/counts"
check "metrics: no request counts as \"other\"" \
    sh -c "! grep -q 'status=\"other\"' metrics.txt"
check "metrics: every status label is a number" \
    sh -c "! grep '^gigaview_http_requests_total' metrics.txt | grep -vq 'status=\"[1-5][0-9][0-9]\"'"

stop_daemon
check "the daemon stopped cleanly" test "$drc" -eq 0
done_testing
