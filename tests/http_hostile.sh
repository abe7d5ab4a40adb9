#!/bin/sh
# http_hostile.sh - hostile and careless clients get a JSON answer with
# the documented status, cannot hold connections for ever, and leave
# nothing behind when they go away.
#
# Each check fails on the daemon before the watchdog and the head checks:
#  - 500 query arguments: 400 (it never answered); a 10 KB target: 414,
#    a 40 KB head: 431, both JSON (libmicrohttpd's HTML before);
#  - two different Content-Length headers, or Content-Length with
#    Transfer-Encoding: 400 (accepted before);
#  - batch levels beyond a byte: 400 (level 256 came back as level 0);
#    tile levels 40 and 41 both 404 (41 was 400), 256 400;
#  - /v1/images/p%2Froot names image "p/root" (it was p's root: 404 now);
#  - IIIF gif, jp2, pdf: 400 (501); a region number over 2^31-1: 400;
#  - a file with no triangle to /v1/meshes/simplify: 400 (200, X-Faces 0,
#    and a heap overflow in the worker);
#  - a body over simplify_max_bytes sent without "Expect: 100-continue":
#    413 read by the client (it could see a reset connection instead);
#  - with filters (a GPU context, llvmpipe will do): a filter request
#    whose client goes away while it waits in the queue is not run
#    (cancelled in /metrics) and is logged 499, not 200; under the
#    sanitizers its memory is not leaked (no report at exit);
#  - a client trickling its head one line a second is closed by
#    request_timeout (2 s here) although connection_timeout is 60 s; with
#    no request_timeout, four of them at connection_limit 4 do not keep
#    /healthz out: the one that waited longest is evicted.
# The checks before the slow clients have a daemon of their own, with no
# time limit that a request or job which must succeed could meet on a
# slow machine.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" "$T/f" || bail "mkdir"
run encode synth:1500x1000 -o "$S/p.gv"
[ "$rc" -eq 0 ] || bail "encode: $(cat "$T/err")"
cat >"$T/h.conf" <<EOF2
listen = 127.0.0.1
store_dir = "$S"
filter_dir = "$T/f"
threads = 2
connection_timeout = $GV_TEST_PATIENCE
request_timeout = 0
simplify_max_bytes = 64K
filter_workers = 1
filter_timeout_ms = $((GV_TEST_PATIENCE * 1000))
access_log = "stderr"
EOF2
start_daemon "$T/h.conf"

# raw NAME REQUEST-BYTES (python literal): the status line and body of one
# raw request into $T/raw.NAME.
raw() {
    python3 - "$PORT" "$2" >"$T/raw.$1" <<'PY'
import ast, os, socket, sys
s = socket.create_connection(("127.0.0.1", int(sys.argv[1])),
                             timeout=float(os.environ["GV_TEST_PATIENCE"]))
s.sendall(ast.literal_eval(sys.argv[2]))
out = b""
try:
    while True:
        b = s.recv(65536)
        if not b:
            break
        out += b
except OSError:
    pass
head, _, body = out.partition(b"\r\n\r\n")
print(head.split(b"\r\n")[0].decode(errors="replace"))
print(body.decode(errors="replace"))
PY
}

# raw_is NAME STATUS: that raw answer has STATUS and a JSON error body.
raw_is() {
    if python3 - "$T/raw.$1" "$2" <<'PY'
import json, sys
lines = open(sys.argv[1]).read().split("\n", 1)
assert lines[0].split()[1] == sys.argv[2], lines[0]
e = json.loads(lines[1])["error"]
assert e["status"] == int(sys.argv[2]) and e["code"] and e["message"]
PY
    then ok "$1: $2 with a JSON error body"
    else not_ok "$1: $2 with a JSON error body" "$(head -c 400 "$T/raw.$1")"
    fi
}

# --- the head ------------------------------------------------------------
args=$(python3 -c "print('&'.join('a%d=1' % i for i in range(500)))")
expect_status "500 query arguments (max_query_args)" 400 "/v1/images?$args"
long=$(python3 -c "print('x' * 10000)")
expect_status "a 10 KB request target (max_url_bytes)" 414 "/v1/images/$long"
expect_status "a 40 KB header (max_header_bytes)" 431 /v1/images \
    -H "X-Big: $(python3 -c "print('y' * 40000)")"
# libmicrohttpd's buffer per connection holds the head and a record of
# each line (http.c, pool_bytes): a head within the limits in many lines
# is served, one over them still gets our JSON.
# shellcheck disable=SC2046
expect_status "a 15 KB head in 100 lines (within max_header_bytes, 16K)" 200 /v1/images \
    $(python3 -c "print(' '.join('-H X%d:%s' % (i, 'v' * 140) for i in range(100)))")
# shellcheck disable=SC2046
expect_status "an 18 KB head in 160 lines (over max_header_bytes)" 431 /v1/images \
    $(python3 -c "print(' '.join('-H X%d:%s' % (i, 'v' * 110) for i in range(160)))")
raw two-lengths "b'GET /v1/images HTTP/1.1\\r\\nHost: t\\r\\nContent-Length: 0\\r\\nContent-Length: 3\\r\\n\\r\\nabc'"
raw_is two-lengths 400
raw length-and-chunked "b'GET /v1/images HTTP/1.1\\r\\nHost: t\\r\\nContent-Length: 5\\r\\nTransfer-Encoding: chunked\\r\\n\\r\\n0\\r\\n\\r\\n'"
raw_is length-and-chunked 400

# --- levels, paths ---------------------------------------------------------
expect_status "batch level 256 (does not fit a frame)" 400 /v1/images/p/batch \
    -X POST -d '{"tiles":[[256,0,0]]}'
expect_status "batch level 300" 400 '/v1/images/p/batch?t=300,1,0'
req -X POST -d '{"tiles":[[41,0,0],[0,0,0]]}' "$(url /v1/images/p/batch)"
check "batch: level 41 is a 404 frame for level 41, tile 0/0/0 a 200" \
    python3 - "$T/b" <<'PY'
import struct, sys
b = open(sys.argv[1], "rb").read()
assert b[:4] == b"GVB1" and struct.unpack_from("<I", b, 4)[0] == 2
lvl, tx, ty, st, n = b[8], *struct.unpack_from("<IIII", b, 12)
assert (lvl, st, n) == (41, 404, 0), (lvl, st, n)
assert b[28] == 0 and struct.unpack_from("<I", b, 40)[0] == 200
PY
expect_status "tile level 40 (no such level)" 404 /v1/images/p/tiles/40/0/0
expect_status "tile level 41 (no such level)" 404 /v1/images/p/tiles/41/0/0
expect_status "tile level 256 (out of range)" 400 /v1/images/p/tiles/256/0/0
expect_status "an encoded '/' stays in the id: no image 'p/root'" 404 \
    '/v1/images/p%2Froot' --path-as-is
check "... and the message names it" test "$(json_get 'j["error"]["message"]')" = "no image 'p/root'"
expect_status "the root itself" 200 /v1/images/p/root

# --- IIIF ------------------------------------------------------------------
for f in gif jp2 pdf; do
    expect_status "IIIF format $f (not produced)" 400 "/iiif/3/p/full/max/0/default.$f"
done
expect_status "IIIF region past 2^31-1" 400 '/iiif/3/p/0,0,2147483648,10/max/0/default.jpg'
expect_status "IIIF region at 2^31-1 (cropped)" 200 '/iiif/3/p/0,0,2147483647,10/max/0/default.jpg'

# --- uploads ---------------------------------------------------------------
printf garbage >"$T/garbage.obj"
req --data-binary @"$T/garbage.obj" "$(url '/v1/meshes/simplify?faces=10')"
if [ "$code" = 503 ] || [ "$code" = 501 ]; then
    skip "simplify: a file with no triangle" "no filter workers ($code)"
else
    check "simplify: a file with no triangle is 400 (got $code)" test "$code" = 400
    check "... with the JSON error body" error_body_ok 400
fi
head -c 100000 /dev/zero | tr '\0' 'v' >"$T/big.obj"
expect_status "a body over simplify_max_bytes, no Expect: read, then 413" 413 \
    '/v1/meshes/simplify?faces=10' -H 'Expect:' --data-binary @"$T/big.obj"
expect_status "a body over simplify_max_bytes, Expect: 100-continue" 413 \
    '/v1/meshes/simplify?faces=10' -H 'Expect: 100-continue' --data-binary @"$T/big.obj"

# --- abandoned work --------------------------------------------------------
req "$(url /healthz)"
gpu=$(json_get 'j["gpu"]["available"]')
if [ "$gpu" != True ]; then
    skip "abandoned filter requests" "no GPU context"
else
    spin='{"name": "spin", "output": "s", "modules": [{"id": "s", "template": "point", "inputs": ["source"], "glsl": "float s = $(FilterInput1)(rel_pos).r;\nfor (int i = 0; i < 100000000; i++) {\n  s = sin(s + float(i)) * 1.0001 + cos(s);\n  if (s > 1e30) break;\n}\nreturn vec4(s);"}]}'
    # A job that holds the one worker (minutes of llvmpipe) and 3 queued
    # behind it whose clients leave, each once /metrics counts its job
    # queued and the daemon's end of its connection has the client's FIN
    # (CLOSE_WAIT); only then is the long job ended, by killing its
    # worker.  Every step waits for what it needs, so a slow machine only
    # takes longer.
    python3 - "$PORT" "$DPID" "$spin" >"$T/gone.out" 2>&1 <<'PY'
import glob, http.client, json, os, signal, socket, sys, threading, time
port, dpid, spin = int(sys.argv[1]), sys.argv[2], json.loads(sys.argv[3])
patience = float(os.environ["GV_TEST_PATIENCE"])
def metric(name):
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=patience)
    c.request("GET", "/metrics")
    for line in c.getresponse().read().decode().splitlines():
        if line.startswith(name + " "):
            return line.split()[1]
    return None
def until(what, cond):  # cond() every 0.05 s, GV_TEST_PATIENCE s at most
    end = time.monotonic() + patience
    while not cond():
        if time.monotonic() > end:
            sys.exit("gave up waiting for " + what)
        time.sleep(0.05)
def fin_seen(cport):    # the daemon's end of the connection from cport
    for line in open("/proc/net/tcp").read().splitlines()[1:]:
        f = line.split()
        if f[1].endswith(":%04X" % port) and f[2].endswith(":%04X" % cport) \
                and f[3] == "08":   # CLOSE_WAIT
            return True
    return False
res = {}
def busy():   # holds the one worker until it is killed: 500
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=patience)
    c.request("POST", "/v1/images/p/filter",
              json.dumps({"graph": spin, "region": [0, 0, 1000, 700]}))
    res["busy"] = c.getresponse().status
t = threading.Thread(target=busy)
t.start()
until("the spin to run in the one worker",
      lambda: metric("gigaview_filter_jobs_running") == "1")
body = json.dumps({"filter": "negate", "region": [0, 0, 256, 256]}).encode()
for i in range(3):   # queued behind it; the client leaves
    s = socket.create_connection(("127.0.0.1", port))
    s.sendall(b"POST /v1/images/p/filter HTTP/1.1\r\nHost: t\r\n"
              b"Content-Length: %d\r\n\r\n" % len(body) + body)
    until("job %d in the queue" % (i + 1),
          lambda: metric("gigaview_filter_jobs_queued") == str(i + 1))
    cport = s.getsockname()[1]
    s.close()
    until("the daemon's socket to get the FIN", lambda: fin_seen(cport))
# The slot takes the queued jobs once it has replaced the killed worker.
for f in glob.glob("/proc/%s/task/*/children" % dpid):
    for pid in open(f).read().split():
        os.kill(int(pid), signal.SIGKILL)
t.join()
print(res.get("busy"))
PY
    check "the long job ended when its worker was killed (500; got $(tail -n 1 "$T/gone.out"))" \
        test "$(tail -n 1 "$T/gone.out")" = 500
    # The slot takes the queued jobs once it has replaced the killed
    # worker, and each request is logged once its connection is resumed:
    # wait for all three of both.
    # shellcheck disable=SC2317 # run by wait_until
    all_cancelled() {
        req "$(url /metrics)"
        n=$(sed -n 's/^gigaview_filter_jobs_total{result="cancelled"} //p' "$T/b")
        l=$(grep -c '"POST /v1/images/p/filter" 499 0 ' "$T/daemon.log")
        [ "${n:-0}" -ge 3 ] && [ "$l" -ge 3 ]
    }
    wait_until all_cancelled
    check "the 3 abandoned jobs were not run (cancelled: ${n:-none})" test "${n:-0}" = 3
    n=$(grep -c '"POST /v1/images/p/filter" 499 0 ' "$T/daemon.log")
    check "... and each is logged 499 with no bytes ($n)" test "$n" = 3
fi

stop_daemon
check "the daemon stopped cleanly (status $drc)" test "$drc" = 0
no_sanitizer_report

# --- slow clients ----------------------------------------------------------
# A daemon of their own: 4 places, a 60 s idle timeout, 2 s for a whole
# request; nothing else runs on it.
cat >"$T/s.conf" <<EOF2
listen = 127.0.0.1
store_dir = "$S"
threads = 2
connection_limit = 4
connection_timeout = 60
request_timeout = 2
filter_workers = 0
access_log = "stderr"
EOF2
start_daemon "$T/s.conf"
# trickle.py PORT MODE: 4 clients at connection_limit 4 send a header line
# a second, then /healthz is asked.  MODE timeout: each must be closed by
# the daemon (request_timeout; with only the 60 s idle timeout, each line
# restarts it) while it still trickles: they trickle until then, or
# GV_TEST_PATIENCE s.  MODE evict (request_timeout = 0): /healthz must be
# answered while they still trickle (all but the one evicted); they
# trickle until it is.
cat >"$T/trickle.py" <<'PY'
import http.client, os, socket, sys, threading, time
port, mode = int(sys.argv[1]), sys.argv[2]
patience = float(os.environ["GV_TEST_PATIENCE"])
closed = {}          # client: seconds until the daemon closed it
stop = threading.Event()
def trickle(k):
    s = socket.create_connection(("127.0.0.1", port), timeout=patience)
    t0 = time.time()
    try:
        s.sendall(b"GET /v1/images HTTP/1.1\r\nHost: t\r\n")
        i = 0
        while not stop.is_set() and time.time() < t0 + patience:
            s.sendall(b"X-Slow: %d\r\n" % i)
            i += 1
            time.sleep(1)
            s.setblocking(False)
            try:
                if s.recv(1) == b"":
                    closed[k] = time.time() - t0
                    break            # closed by the daemon
            except BlockingIOError:
                pass
            s.setblocking(True)
    except OSError:
        closed[k] = time.time() - t0  # reset by the daemon
ts = [threading.Thread(target=trickle, args=(k,)) for k in range(4)]
for t in ts:
    t.start()
# The 4 places are taken (on a machine too slow for that, /healthz finds
# one free: the check can then only pass more easily).
time.sleep(1.5)
status = "no answer"
try:
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=patience)
    c.request("GET", "/healthz")
    r = c.getresponse()
    r.read()
    status = r.status
except OSError as e:
    status = repr(e)
still = 4 - len(closed)      # clients not seen closed at the answer
if mode == "evict":
    stop.set()
for t in ts:
    t.join()
print("healthz:", status, "; trickling clients closed by the daemon after",
      sorted(round(v) for v in closed.values()), "s;", still,
      "still trickling at the answer")
if mode == "timeout":
    ok = len(closed) == 4
else:
    ok = status == 200 and still >= 3
sys.exit(0 if ok else 1)
PY
python3 "$T/trickle.py" "$PORT" timeout >"$T/slow.out" 2>&1
src=$?
check "request_timeout (2 s) closes clients that trickle a line a second: $(cat "$T/slow.out")" \
    test "$src" = 0
stop_daemon
check "the daemon stopped cleanly (status $drc)" test "$drc" = 0
no_sanitizer_report

# Eviction alone: no request_timeout, tricklers that never idle.
sed 's/^request_timeout = 2$/request_timeout = 0/' "$T/s.conf" >"$T/e.conf"
start_daemon "$T/e.conf"
python3 "$T/trickle.py" "$PORT" evict >"$T/evict.out" 2>&1
src=$?
check "at connection_limit, /healthz evicts a trickling client: $(cat "$T/evict.out")" \
    test "$src" = 0
stop_daemon
check "the daemon stopped cleanly (status $drc)" test "$drc" = 0
no_sanitizer_report
done_testing
