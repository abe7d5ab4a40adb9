#!/bin/bash
# http-idle.sh: gigaviewd with thousands of idle connections and slow
# readers, on loopback: what tests/fault_slow_clients.sh checks with 400,
# measured at the scale the daemon is meant to hold: thousands of idle
# connections, up to the configured limit.
#
#   bench/http-idle.sh [--gigaview PATH] [--gigaviewd PATH]
#
# gigaviewd runs with connection_limit = LIMIT and THREADS threads over a
# store of synth:3000x2000.  The script measures, in one run:
#   1. baseline: REQS well-behaved requests (tile, health, small region),
#      one connection each, one after another: p50, p99, max latency;
#   2. IDLE connections opened with half a request sent (slowloris), and
#      SLOW clients downloading an 11 MB IIIF image at 1 MiB/s each;
#      the daemon's held sockets (/proc/PID/fd) and its RSS (VmRSS), so
#      the memory per idle connection; the same REQS requests again;
#   3. a flood up to and 50 past the limit: the most sockets the daemon
#      held (must not pass LIMIT), and that the excess waited;
#   4. the slow downloads' throughput and completeness.
# Nothing is asserted: the script reports.  Needs python3 and
# ulimit -n above 2 * IDLE.
#
# Environment: IDLE (default 4000), LIMIT (4096), SLOW (8), THREADS (4),
# REQS (300), TMPDIR.
set -euo pipefail

# shellcheck source=SCRIPTDIR/http-lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/http-lib.sh"

bench_args "$@"
bench_no_inputs
IDLE=${IDLE:-4000}
LIMIT=${LIMIT:-4096}
SLOW=${SLOW:-8}
THREADS=${THREADS:-4}
REQS=${REQS:-300}
ulimit -n $((2 * IDLE + 2 * LIMIT + 256)) 2>/dev/null ||
	die "needs ulimit -n of $((2 * IDLE + 2 * LIMIT + 256)) (have $(ulimit -n))"

GV=$(find_gigaview "$gv_arg")
GVD=$(find_gigaviewd "$gvd_arg")
work=$(mktemp -d "${TMPDIR:-/tmp}/gvidle.XXXXXX")
trap 'http_cleanup; rm -rf "$work"' EXIT
mkdir "$work/s"
"$GV" encode synth:3000x2000 --quiet -o "$work/s/s.gv"
cat >"$work/c.conf" <<EOF
store_dir = "$work/s"
port = 0
threads = $THREADS
connection_limit = $LIMIT
connection_timeout = 120
access_log = off
filter_workers = 0
EOF
start_gigaviewd "$GVD" "$work/c.conf" "$work/log"
describe_build "$GVD"
machine_line
echo "gigaviewd: threads $THREADS, connection_limit $LIMIT; $IDLE idle, $SLOW slow readers at 1 MiB/s"

python3 - "$GVD_PORT" "$GVD_PID" "$IDLE" "$LIMIT" "$SLOW" "$REQS" <<'PY'
import hashlib, os, socket, sys, threading, time
port, pid, n_idle, limit, n_slow, reqs = (int(x) for x in sys.argv[1:7])
big = '/iiif/3/s/full/max/0/default.png'
rate = 1 << 20

def held():
    n = 0
    for fd in os.listdir('/proc/%d/fd' % pid):
        try:
            n += os.readlink('/proc/%d/fd/%s' % (pid, fd)).startswith('socket:')
        except OSError:
            pass
    return n - 1

def rss_kb():
    for line in open('/proc/%d/status' % pid):
        if line.startswith('VmRSS:'):
            return int(line.split()[1])

def get(path, timeout=30):
    s = socket.create_connection(('127.0.0.1', port), timeout=timeout)
    s.sendall(('GET %s HTTP/1.1\r\nHost: t\r\nConnection: close\r\n\r\n' % path).encode())
    data = b''
    while True:
        c = s.recv(65536)
        if not c:
            break
        data += c
    s.close()
    return data

def latencies(tag):
    paths = ['/v1/images/s/tiles/0/1/1', '/healthz',
             '/v1/images/s/region?level=2&x=0&y=0&w=100&h=100']
    t, bad = [], 0
    for i in range(reqs):
        t0 = time.time()
        try:
            ok = get(paths[i % 3]).startswith(b'HTTP/1.1 200')
        except OSError:
            ok = False
        t.append(time.time() - t0)
        bad += not ok
    t.sort()
    print('%-28s %d requests, %d failed; p50 %.1f ms, p99 %.1f ms, max %.1f ms'
          % (tag, reqs, bad, 1e3 * t[len(t) // 2], 1e3 * t[int(len(t) * 0.99)], 1e3 * t[-1]))

def half_open():
    s = socket.create_connection(('127.0.0.1', port), timeout=30)
    s.sendall(b'GET /healthz HTTP/1.1\r\nHost: t\r\nX-Idle: ')
    return s

def wait_held(cond, secs):
    t0 = time.time()
    while time.time() - t0 < secs and not cond(held()):
        time.sleep(0.1)
    return held()

def slow_reader(res, k):
    s = socket.socket()
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 32768)
    s.connect(('127.0.0.1', port))
    s.sendall(('GET %s HTTP/1.1\r\nHost: t\r\nConnection: close\r\n\r\n' % big).encode())
    n, t0, h = 0, time.time(), hashlib.sha256()
    head = b''
    while True:
        c = s.recv(16384)
        if not c:
            break
        if not head:
            head = c[:12]
        n += len(c)
        h.update(c)
        ahead = n / rate - (time.time() - t0)
        if ahead > 0:
            time.sleep(ahead)
    res[k] = (head, n, time.time() - t0)

rss0 = rss_kb()
latencies('baseline:')
idle, t0 = [], time.time()
for i in range(n_idle):
    idle.append(half_open())
    if i % 100 == 99:
        time.sleep(0.02)
h = wait_held(lambda h: h >= n_idle, 60)
rss1 = rss_kb()
print('idle: %d opened in %.1f s, daemon holds %d; RSS %d -> %d KiB (%.1f KiB per connection)'
      % (n_idle, time.time() - t0, h, rss0, rss1, (rss1 - rss0) / max(h, 1)))
res = {}
slow = [threading.Thread(target=slow_reader, args=(res, k)) for k in range(n_slow)]
for t in slow:
    t.start()
latencies('with %d idle + %d slow:' % (n_idle, n_slow))
flood = [half_open() for i in range(max(0, limit - held()) + 50)]
peak = wait_held(lambda h: h >= limit, 30)
for _ in range(20):
    peak = max(peak, held())
    time.sleep(0.1)
print('flood: %d more connections; peak held %d (limit %d); %d slow still running'
      % (len(flood), peak, limit, sum(t.is_alive() for t in slow)))
for s in idle:
    s.close()
wait_held(lambda h: h <= n_slow + len(flood), 60)
for s in flood:
    s.close()
wait_held(lambda h: h <= n_slow, 60)
latencies('after release:')
for t in slow:
    t.join()
for k in sorted(res):
    head, n, secs = res[k]
    print('slow reader %d: %s %d bytes in %.1f s (%.2f MiB/s)'
          % (k, head.decode(errors='replace'), n, secs, n / secs / (1 << 20)))
print('final RSS %d KiB' % rss_kb())
PY
