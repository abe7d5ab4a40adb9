#!/bin/sh
# http_soak.sh - a bounded load generator, on loopback only, that mixes
# hostile and careless clients with normal traffic for GV_SOAK_SECONDS
# (default 40) and asserts that the daemon holds:
#  - normal clients (tiles, batches, regions, IIIF, info.json) are answered
#    throughout: every one gets 200 or 304 (503 with Retry-After from a
#    full render queue counts as answered), in each third of the run at
#    least an eighth as many as in the busiest;
#  - every error gigaviewd answers is a JSON body with its documented
#    status (400, 404, 413, 414, 431); requests whose framing
#    libmicrohttpd refuses itself (a garbage request line) get an answer
#    or a close, never a hang;
#  - slow clients (a byte every half second) are closed by
#    request_timeout (each trickles until the daemon closes it, or for
#    GV_TEST_PATIENCE s); clients that leave with renders and filters
#    queued leave nothing behind;
#  - RSS is flat: its peak over the last third of the run is within 24 MiB
#    of its peak over the second third (the caches are small and full by
#    then, so growth is a leak);
#  - in the sanitizer build, no report, and a clean exit.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

: "${GV_SOAK_SECONDS:=40}"
S=$T/stores
mkdir "$S" "$T/f" || bail "mkdir"
run encode synth:2000x1500 -o "$S/p.gv"
[ "$rc" -eq 0 ] || bail "encode: $(cat "$T/err")"
cat >"$T/s.conf" <<EOF2
listen = 127.0.0.1
store_dir = "$S"
filter_dir = "$T/f"
threads = 2
connection_limit = 48
request_timeout = 3
cache_bytes = 8M
decoder_cache_bytes = 8M
output_cache_bytes = 2M
max_request_bytes = 64K
render_queue = 16
filter_workers = 1
filter_max_jobs = 4
access_log = off
EOF2
# ASan keeps freed blocks in a quarantine of up to 256 MiB: bound it, so
# that RSS shows leaks rather than the quarantine filling.
ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}quarantine_size_mb=8"
export ASAN_OPTIONS
start_daemon "$T/s.conf"

python3 - "$PORT" "$DPID" "$GV_SOAK_SECONDS" >"$T/soak.out" 2>&1 <<'PY'
import http.client, json, os, random, socket, sys, threading, time
port, pid, dur = int(sys.argv[1]), sys.argv[2], float(sys.argv[3])
patience = float(os.environ["GV_TEST_PATIENCE"])   # for what must come
t_end = time.time() + dur
lock = threading.Lock()
stats = {}
problems = []
normal_ok_times = []

def note(k, n=1):
    with lock:
        stats[k] = stats.get(k, 0) + n

def problem(s):
    with lock:
        if len(problems) < 20:
            problems.append(s)

def rss():
    for l in open("/proc/%s/status" % pid):
        if l.startswith("VmRSS"):
            return int(l.split()[1]) * 1024
    return 0

def json_error(status, body):
    try:
        e = json.loads(body)["error"]
        return e["status"] == status and e["code"] and e["message"]
    except Exception:
        return False

def normal(seed):
    rnd = random.Random(seed)
    c = None
    while time.time() < t_end:
        if c is None:
            c = http.client.HTTPConnection("127.0.0.1", port, timeout=patience)
        k = rnd.randrange(5)
        if k == 0:
            p = "/v1/images/p/tiles/%d/0/0" % rnd.randrange(2)
        elif k == 1:
            p = "/v1/images/p/batch?t=0,0,0;0,1,0;1,0,0"
        elif k == 2:
            x, y = rnd.randrange(1500), rnd.randrange(1000)
            p = "/v1/images/p/region?level=0&x=%d&y=%d&w=200&h=150" % (x, y)
        elif k == 3:
            x, y = rnd.randrange(1800), rnd.randrange(1300)
            p = "/iiif/3/p/%d,%d,200,200/100,/0/default.jpg" % (x, y)
        else:
            p = "/iiif/3/p/info.json"
        try:
            c.request("GET", p)
            r = c.getresponse()
            r.read()
            if r.status in (200, 304) or (r.status == 503 and r.getheader("Retry-After")):
                note("normal %d" % r.status)
                with lock:
                    normal_ok_times.append(time.time())
            else:
                problem("normal %s: %d" % (p, r.status))
        except Exception as e:
            problem("normal %s: %r" % (p, e))
            c = None

def slow():
    head = b"GET /v1/images HTTP/1.1\r\nHost: x\r\nX-Slow: "
    while time.time() < t_end:
        s = socket.create_connection(("127.0.0.1", port), timeout=patience)
        t0 = time.time()
        closed, i = False, 0
        try:
            # A byte every half second until the daemon closes the
            # connection (request_timeout), however long that takes.
            while time.time() < t0 + patience:
                s.send(head[i:i + 1] if i < len(head) else b"a")
                i += 1
                time.sleep(0.5)
        except OSError:
            closed = True
        s.close()
        if not closed:
            problem("a slow client held on for %.1f s" % (time.time() - t0))
        note("slow closed")

def abandon(seed):
    rnd = random.Random(seed)
    while time.time() < t_end:
        x, y = rnd.randrange(1800), rnd.randrange(1300)
        if rnd.random() < 0.8:
            req = b"GET /iiif/3/p/%d,%d,190,190/max/%d/default.png HTTP/1.1\r\nHost: x\r\n\r\n" % (
                x, y, rnd.choice([0, 90, 180]))
        else:
            body = json.dumps({"filter": "negate", "region": [x, y, 128, 128]}).encode()
            req = (b"POST /v1/images/p/filter HTTP/1.1\r\nHost: x\r\nContent-Length: %d\r\n\r\n"
                   % len(body)) + body
        try:
            s = socket.create_connection(("127.0.0.1", port), timeout=patience)
            s.sendall(req)
            time.sleep(rnd.choice([0, 0.005, 0.05]))
            s.close()
            note("abandoned")
        except OSError as e:
            problem("abandon: %r" % e)

HOSTILE = [
    # (method, path, headers, body, wanted status)
    ("GET", "/v1/images?" + "&".join("a%d=1" % i for i in range(300)), {}, None, 400),
    ("GET", "/v1/images/" + "x" * 9000, {}, None, 414),
    ("GET", "/v1/images", {"X-Big": "y" * 40000}, None, 431),
    ("POST", "/v1/images/p/batch", {"Expect": "100-continue"}, b"x" * 100000, 413),
    ("POST", "/v1/images/p/batch", {}, b"{" * 70000, 413),
    ("POST", "/v1/images/p/batch", {}, b'{"tiles":[[256,0,0]]}', 400),
    ("POST", "/v1/images/p/batch", {}, b'{"tiles":', 400),
    ("GET", "/v1/images/p/tiles/300/0/0", {}, None, 400),
    ("GET", "/v1/images/p/tiles/41/0/0", {}, None, 404),
    ("GET", "/v1/images/p%2Froot", {}, None, 404),
    ("GET", "/iiif/3/p/full/max/0/default.gif", {}, None, 400),
    ("GET", "/iiif/3/p/0,0,2147483648,1/max/0/default.jpg", {}, None, 400),
    ("GET", "/iiif/3/p/full/99999,/0/default.jpg", {}, None, 400),
    ("GET", "/v1/images/p/region?level=0&x=0&y=0&w=0&h=5", {}, None, 400),
    ("POST", "/v1/meshes/simplify?faces=10", {}, b"garbage", (400, 501, 503)),
    ("GET", "/v1/images/nope", {}, None, 404),
]

def hostile(seed):
    rnd = random.Random(seed)
    while time.time() < t_end:
        m, p, h, body, want = rnd.choice(HOSTILE)
        try:
            c = http.client.HTTPConnection("127.0.0.1", port, timeout=patience)
            c.request(m, p, body=body, headers=h)
            r = c.getresponse()
            b = r.read()
            c.close()
            wants = want if isinstance(want, tuple) else (want,)
            if r.status not in wants:
                problem("%s %s: %d, wanted %s" % (m, p[:60], r.status, wants))
            elif not json_error(r.status, b):
                problem("%s %s: %d without the JSON body: %r" % (m, p[:60], r.status, b[:80]))
            else:
                note("hostile %d" % r.status)
        except Exception as e:
            problem("%s %s: %r" % (m, p[:60], e))

def garbage(seed):
    rnd = random.Random(seed)
    while time.time() < t_end:
        req = bytes(rnd.randrange(1, 256) for _ in range(rnd.randrange(1, 300)))
        try:
            s = socket.create_connection(("127.0.0.1", port), timeout=patience)
            s.sendall(req + b"\r\n\r\n")
            s.settimeout(patience)
            t0 = time.time()
            while s.recv(4096):
                pass
            note("garbage answered or closed")
            s.close()
        except socket.timeout:
            problem("garbage: no answer and no close in %g s" % patience)
        except OSError:
            note("garbage answered or closed")

samples = []
def sampler():
    while time.time() < t_end:
        samples.append((time.time(), rss()))
        time.sleep(0.5)

ths = [threading.Thread(target=normal, args=(i,)) for i in range(3)]
ths += [threading.Thread(target=slow) for _ in range(4)]
ths += [threading.Thread(target=abandon, args=(10 + i,)) for i in range(2)]
ths += [threading.Thread(target=hostile, args=(20 + i,)) for i in range(2)]
ths += [threading.Thread(target=garbage, args=(30,)), threading.Thread(target=sampler)]
t0 = time.time()
for t in ths:
    t.start()
for t in ths:
    t.join()
print("counts:", json.dumps(stats, sort_keys=True))
third = dur / 3
mid = max((r for t, r in samples if t0 + third <= t < t0 + 2 * third), default=0)
last = max((r for t, r in samples if t >= t0 + 2 * third), default=0)
print("rss peak: second third %.1f MiB, last third %.1f MiB" % (mid / 2**20, last / 2**20))
if last > mid + 24 * 2**20:
    problem("RSS grew from %.1f to %.1f MiB" % (mid / 2**20, last / 2**20))
# Answered throughout: the normal answers of each third of the run are
# at least an eighth of those of the busiest third.  A daemon that stops
# answering or slows down as the run goes on fails it; a machine that is
# slow all along, or in bursts, does not: only ratios of its own pace.
times = sorted(normal_ok_times)
per_third = [sum(1 for t in times if t0 + k * third <= t < t0 + (k + 1) * third)
             for k in range(3)]
print("normal answers per third of the run:", per_third)
if not times or min(per_third) * 8 < max(per_third):
    problem("normal answers per third of the run: %s" % per_third)
for k in ("abandoned", "slow closed", "garbage answered or closed"):
    if not stats.get(k):
        problem("the %s clients did nothing" % k)
for p in problems:
    print("PROBLEM:", p)
sys.exit(1 if problems else 0)
PY
src=$?
diag "$(cat "$T/soak.out")"
check "$GV_SOAK_SECONDS s of mixed hostile and normal clients: no problem" test "$src" = 0
req "$(url /healthz)"
check "the daemon still answers (got $code)" test "$code" = 200
stop_daemon
check "the daemon stopped cleanly (status $drc)" test "$drc" = 0
no_sanitizer_report
done_testing
