#!/bin/sh
# scaleout_nginx.sh - three gigaviewd replicas behind nginx lose one under
# load, and no client request fails.
#
# The nginx configuration is conf/nginx-gigaview.conf itself, with only its
# addresses and cache directory rewritten for loopback and its time
# limits (client_*_timeout, proxy_*_timeout) raised to GV_TEST_PATIENCE
# (a request to a loaded sanitizer-build replica must not time out:
# failover here is for the killed replica's refused and reset
# connections), wrapped in a
# minimal nginx.conf with a private prefix (no root needed).  Three
# replicas serve one store directory (four stores).  A Python client with
# 12 keep-alive connections sends a mix of tiles, POST batches, IIIF
# images and regions (distinct URLs, so most reach a replica despite the
# proxy cache) until the replicas left have served 20 requests after the
# kill; the replica that has served the most is SIGKILLed once every one
# has served (waits, not sleeps, so a loaded machine only takes longer).  Every response must be a complete 200,
# the killed replica must have been serving before the kill, and the
# others must have served requests after it.  Also checks that a repeated
# tile is a proxy cache HIT.  Skipped when nginx is not installed.
. "$(dirname "$0")/lib.sh"

NGINX=$(command -v nginx 2>/dev/null || true)
[ -n "$NGINX" ] || [ ! -x /usr/sbin/nginx ] || NGINX=/usr/sbin/nginx
if [ -z "$NGINX" ]; then
    echo "1..0 # SKIP nginx is not installed (apt-get install nginx-light)"
    exit 0
fi
if under_valgrind; then
    echo "1..0 # SKIP a load test is meaningless under valgrind"
    exit 0
fi
need_tool python3 curl
GIGAVIEWD=${GIGAVIEWD:-$(dirname "$GIGAVIEW")/gigaviewd}
[ -x "$GIGAVIEWD" ] || bail "no gigaviewd next to $GIGAVIEW"
conf_src="${top_srcdir:-$(dirname "$0")/..}/conf/nginx-gigaview.conf"
[ -f "$conf_src" ] || bail "no $conf_src"

PIDS=
NGX=
scaleout_cleanup() {
    # nginx's master stops its workers on TERM (on KILL they would linger).
    if [ -n "$NGX" ]; then
        kill -TERM "$NGX" 2>/dev/null
        wait_until ngx_gone
    fi
    for p in $PIDS $NGX; do
        kill -KILL "$p" 2>/dev/null
    done
    wait 2>/dev/null
    cleanup
}
# shellcheck disable=SC2317 # run by wait_until
ngx_gone() {
    ! kill -0 "$NGX" 2>/dev/null
}
trap scaleout_cleanup EXIT

S=$T/stores
mkdir "$S" "$T/ngx" "$T/ngx/tmp" "$T/ngx/cache" || bail "mkdir"
run encode -q 30 -r 6 synth:3000x2000 -o "$S/a.gv"
[ "$rc" -eq 0 ] || bail "encode: $(cat "$T/err")"
for id in b c d; do cp "$S/a.gv" "$S/$id.gv"; done

# ---- three replicas on free ports, over the same store directory
# replica_port R: success once replica R's log names its port (in port)
# or it has gone (port empty).
# shellcheck disable=SC2317 # run by wait_until
replica_port() {
    port=$(sed -n 's|.*listening on http://.*:\([0-9][0-9]*\)/$|\1|p' "$T/r$1.log" |
        head -n 1)
    [ -n "$port" ] || ! kill -0 "$pid" 2>/dev/null
}
ports=
for r in 1 2 3; do
    cat >"$T/r$r.conf" <<EOF
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 4
cache_bytes = 16M
gpu = off
filter_workers = 0
access_log = "$T/r$r.access"
EOF
    : >"$T/r$r.log"
    "$GIGAVIEWD" -c "$T/r$r.conf" 2>"$T/r$r.log" &
    pid=$!
    PIDS="$PIDS $pid"
    eval "pid$r=$pid"
    port=
    wait_until replica_port "$r"
    [ -n "$port" ] || bail "replica $r did not start: $(tail -n 5 "$T/r$r.log")"
    eval "port$r=$port"
    ports="$ports $port"
done
ok "three replicas listening on$ports"

# ---- nginx: the shipped example, pointed at them
nport=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
python3 - "$conf_src" "$T/ngx/gigaview.conf" "$nport" "$T/ngx/cache" $ports <<'PY' ||
import os, re, sys
src, dst, nport, cache = sys.argv[1:5]
ports = sys.argv[5:]
text = open(src).read()
servers = [l for l in text.splitlines() if re.match(r"\s*server\s+10\.0\.0\.\d+:8080", l)]
assert len(servers) == 3, "the example should list three replicas"
for line, port in zip(servers, ports):
    text = text.replace(line, re.sub(r"10\.0\.0\.\d+:8080", "127.0.0.1:" + port, line), 1)
text, n1 = re.subn(r"listen 80;", "listen 127.0.0.1:%s;" % nport, text)
text, n2 = re.subn(r"/var/cache/nginx/gigaview", cache, text)
assert n1 == 1 and n2 == 1, "listen or proxy_cache_path not found"
text, n3 = re.subn(r"\b((?:client|proxy)_[a-z_]*timeout)\s+\d+s;",
                   r"\1 %ss;" % os.environ["GV_TEST_PATIENCE"], text)
assert n3 >= 5, "the time limits not found"
open(dst, "w").write(text)
PY
    bail "cannot rewrite $conf_src"
# As root, nginx would run its workers as nobody, who cannot enter $T.
user_line=
[ "$(id -u)" != 0 ] || user_line="user root;"
cat >"$T/ngx/nginx.conf" <<EOF
$user_line
daemon off;
worker_processes 2;
pid $T/ngx/nginx.pid;
error_log $T/ngx/error.log warn;
events { worker_connections 1024; }
http {
    access_log $T/ngx/access.log;
    client_body_temp_path $T/ngx/tmp;
    proxy_temp_path $T/ngx/tmp;
    fastcgi_temp_path $T/ngx/tmp;
    uwsgi_temp_path $T/ngx/tmp;
    scgi_temp_path $T/ngx/tmp;
    include $T/ngx/gigaview.conf;
}
EOF
if "$NGINX" -t -p "$T/ngx" -c "$T/ngx/nginx.conf" >"$T/ngx/t.out" 2>&1; then
    ok "conf/nginx-gigaview.conf passes nginx -t"
else
    not_ok "conf/nginx-gigaview.conf passes nginx -t" "$(cat "$T/ngx/t.out")"
    done_testing
fi
"$NGINX" -p "$T/ngx" -c "$T/ngx/nginx.conf" 2>>"$T/ngx/error.log" &
NGX=$!
wait_until curl -s -o /dev/null "http://127.0.0.1:$nport/healthz" ||
    bail "nginx did not start: $(cat "$T/ngx/error.log")"
B="http://127.0.0.1:$nport"

# ---- the proxy cache holds tiles
c1=$(curl -s -o /dev/null -D - "$B/v1/images/a/tiles/0/1/1" | tr -d '\r' | sed -n 's/^X-Cache: //Ip')
c2=$(curl -s -o /dev/null -D - "$B/v1/images/a/tiles/0/1/1" | tr -d '\r' | sed -n 's/^X-Cache: //Ip')
check "a repeated tile is a proxy cache hit ($c1, then $c2)" test "$c1" = MISS -a "$c2" = HIT

# ---- load, and a replica killed in the middle of it
# The client prints one line per second: "t=N served=R1,R2,R3" is not
# known to it, so the shell reads the replicas' access logs instead.
# It runs until the file $T/stop appears (the shell makes it once the
# other replicas have served after the kill), 3 x GV_TEST_PATIENCE s at the
# most (a wait for the replicas, then one for the others after the kill).
python3 - "$B" 12 $((3 * GV_TEST_PATIENCE)) "$T/load.out" "$T/stop" <<'PY' &
import http.client, os, sys, threading, time, json
base, conns, secs, out, stopfile = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), sys.argv[4], sys.argv[5]
host, port = base[len("http://"):].split(":")
ids = ["a", "b", "c", "d"]
lock = threading.Lock()
stats = {"ok": 0, "fail": 0, "kinds": {}}
failures = []
stop = time.time() + secs

def one(i, k):
    img = ids[(i // 4) % 4]
    if k == 0:
        lvl = i % 3
        nx, ny = ((6, 4), (3, 2), (2, 1))[lvl]   # the tile grid of 3000x2000
        return "tile", "GET", "/v1/images/%s/tiles/%d/%d/%d" % (img, lvl, (i // 4) % nx, (i // 24) % ny), None
    if k == 1:
        body = json.dumps({"tiles": [[1, 0, 0], [0, i % 6, 0], [0, (i + 1) % 6, 1]]})
        return "batch", "POST", "/v1/images/%s/batch" % img, body
    if k == 2:
        w = 64 + (i * 7) % 700
        return "iiif", "GET", "/iiif/3/%s/full/%d,/0/default.jpg" % (img, w), None
    x = (i * 37) % 2400
    return "region", "GET", "/v1/images/%s/region?level=0&x=%d&y=%d&w=300&h=200&format=png" % (img, x, (i * 13) % 1700), None

patience = float(os.environ["GV_TEST_PATIENCE"])

def worker(wid):
    c = http.client.HTTPConnection(host, int(port), timeout=patience)
    n = 0
    while time.time() < stop and not os.path.exists(stopfile):
        # Every worker cycles through the four kinds; i numbers requests.
        kind, method, path, body = one(n * conns + wid, (n + wid) % 4)
        n += 1
        try:
            hdr = {"Content-Type": "application/json"} if body else {}
            c.request(method, path, body=body, headers=hdr)
            r = c.getresponse()
            data = r.read()
            good = r.status == 200 and len(data) > 0 and (
                r.getheader("Content-Length") is None or int(r.getheader("Content-Length")) == len(data))
            why = "status %d" % r.status
        except Exception as e:  # a reset, a truncated body...
            good, why = False, repr(e)
            c.close()
            c = http.client.HTTPConnection(host, int(port), timeout=patience)
        with lock:
            stats["kinds"][kind] = stats["kinds"].get(kind, 0) + 1
            if good:
                stats["ok"] += 1
            else:
                stats["fail"] += 1
                failures.append("%s %s: %s" % (method, path, why))

threads = [threading.Thread(target=worker, args=(w,)) for w in range(conns)]
for t in threads: t.start()
for t in threads: t.join()
with open(out, "w") as f:
    f.write("ok %d fail %d kinds %s\n" % (stats["ok"], stats["fail"], stats["kinds"]))
    for line in failures[:20]:
        f.write(line + "\n")
PY
load=$!
# served R: requests replica R has logged.
served() { wc -l <"$T/r$1.access" 2>/dev/null || echo 0; }
# Until every replica has served (however slowly the machine starts them).
# shellcheck disable=SC2317 # run by wait_until
all_served() {
    ! kill -0 "$load" 2>/dev/null ||
        { [ "$(served 1)" -gt 0 ] && [ "$(served 2)" -gt 0 ] && [ "$(served 3)" -gt 0 ]; }
}
wait_until all_served
# The busiest replica so far is the one to kill.
best=1 most=-1
for r in 1 2 3; do
    n=$(wc -l <"$T/r$r.access" 2>/dev/null || echo 0)
    if [ "$n" -gt "$most" ]; then best=$r most=$n; fi
done
eval "victim=\$pid$best"
eval "vport=\$port$best"
kill -KILL "$victim"
diag "killed replica $best (pid $victim) after it served $most requests"
for r in 1 2 3; do eval "mark$r=\$(wc -l <\"$T/r$r.access\")"; done
# Until the two others have served 20 more requests, then stop the load.
# shellcheck disable=SC2317 # run by wait_until
served_after() {
    kill -0 "$load" 2>/dev/null || return 0
    more=0
    for r in 1 2 3; do
        [ "$r" = "$best" ] && continue
        eval "m=\$mark$r"
        more=$((more + $(served "$r") - m))
    done
    [ "$more" -ge 20 ]
}
wait_until served_after
touch "$T/stop"
wait "$load" || bail "the load client failed"
diag "$(head -n 1 "$T/load.out")"
check "the killed replica had been serving ($most requests)" test "$most" -gt 0
after=0
for r in 1 2 3; do
    [ "$r" = "$best" ] && continue
    eval "m=\$mark$r"
    n=$(wc -l <"$T/r$r.access")
    after=$((after + n - m))
done
check "the two others served $after requests after the kill" test "$after" -gt 0
read -r _ nok _ nfail _ <"$T/load.out"
if [ "$nfail" = 0 ] && [ "$nok" -gt 0 ]; then
    ok "no client request failed ($nok complete 200 responses)"
else
    not_ok "no client request failed ($nok ok, $nfail failed)" "$(tail -n +2 "$T/load.out")"
fi
kinds=$(head -n 1 "$T/load.out")
mixed=1
for k in tile batch iiif region; do
    case $kinds in *"'$k'"*) ;; *) mixed=0 ;; esac
done
check "the load mixed tiles, batches, IIIF and regions" test "$mixed" = 1
retried=$(grep "connect() failed\|prematurely closed\|reset by peer" "$T/ngx/error.log" |
    grep -c "127.0.0.1:$vport")
if [ "$retried" -gt 0 ]; then
    ok "nginx saw the failure and passed the requests on ($retried errors logged)"
else
    not_ok "nginx saw the failure and passed the requests on" "$(tail -n 5 "$T/ngx/error.log")"
fi

done_testing
