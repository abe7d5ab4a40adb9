#!/bin/sh
# http_slow.sh - slow clients cannot pin gigaviewd (slowloris).
#
# With connection_timeout = 20 and connection_limit = 12, a client opens
# 8 connections that send half a request and stall.  Well-behaved requests
# must still be answered promptly, the stalled connections must be closed
# by the daemon after the timeout, and when stalled connections fill the
# whole limit, a new client is still answered (the stalled connection that
# waited longest is evicted for it, or timed out) and the daemon recovers
# by itself once they time out.  (tests/http_hostile.sh shows eviction
# alone, with clients that never time out.)
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" || bail "mkdir"
run encode synth:600x400 -o "$S/s.gv"
[ "$rc" -eq 0 ] || bail "encode: $(cat "$T/err")"
cat >"$T/slow.conf" <<EOF2
store_dir = "$S"
threads = 2
connection_timeout = 20
connection_limit = 12
access_log = off
EOF2
start_daemon "$T/slow.conf"

cat >"$T/loris.py" <<'PY'
import os, select, socket, sys, time, http.client
port, n_stall, timeout = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
phase = sys.argv[4]
patience = float(os.environ['GV_TEST_PATIENCE'])

def stall(n):
    socks = []
    for i in range(n):
        s = socket.create_connection(('127.0.0.1', port), timeout=patience)
        s.sendall(b'GET /v1/images/s HTTP/1.1\r\nHost: t\r\nX-Slow: ')
        socks.append(s)
    return socks

def still_open(socks):
    # A connection the daemon closed reads as ready (end of file).
    return len(socks) - len(select.select(socks, [], [], 0)[0])

def good(socks, wait=patience):
    try:
        c = http.client.HTTPConnection('127.0.0.1', port, timeout=wait)
        c.request('GET', '/healthz')
        r = c.getresponse()
        r.read()
        c.close()
        return r.status, still_open(socks)
    except Exception as e:
        return repr(e), still_open(socks)

def closed(s):
    s.settimeout(0.2)
    try:
        return s.recv(1) == b''
    except socket.timeout:
        return False
    except (ConnectionResetError, BrokenPipeError):
        return True

if phase == 'under':
    socks = stall(n_stall)
    time.sleep(0.3)
    res = [good(socks) for _ in range(5)]
    print('good', ' '.join('%s:%d' % r for r in res))
    # Closed by the idle timeout: poll until all are (GV_TEST_PATIENCE s
    # past it at most; kept open, they would stay for ever).
    t_end = time.time() + timeout + patience
    n = 0
    while time.time() < t_end:
        n = sum(closed(s) for s in socks)
        if n == len(socks):
            break
        time.sleep(0.2)
    print('closed', n, 'of', len(socks))
else:  # fill the whole connection limit
    socks = stall(n_stall)
    time.sleep(0.3)
    s, t = good(socks)
    print('during', s)
    t_end = time.time() + timeout + patience
    while time.time() < t_end and sum(closed(x) for x in socks) < len(socks) - 1:
        time.sleep(0.2)
    s, t = good(socks)
    print('after', s)
PY
python3 "$T/loris.py" "$PORT" 8 20 under >"$T/under.out" 2>&1
diag "$(cat "$T/under.out")"
# Each answered while all 8 stalled connections were still open: behind
# them it would have waited for the idle timeout, which closes them.
check "good requests answered while 8 connections stall" \
    sh -c "grep '^good' '$T/under.out' | grep -Eq '^good( 200:8){5}\$'"
check "stalled connections closed after the timeout" grep -q '^closed 8 of 8$' "$T/under.out"
python3 "$T/loris.py" "$PORT" 12 20 fill >"$T/fill.out" 2>&1
diag "$(cat "$T/fill.out")"
check "with the limit full of stalled connections, a new request is answered" \
    grep -q '^during 200$' "$T/fill.out"
check "the daemon recovers once the stalled ones time out" grep -q '^after 200$' "$T/fill.out"
req "$(url /metrics)"
check "open connections back to 0..1" grep -Eq '^gigaview_open_connections [01]$' "$T/b"
stop_daemon
check "exit 0 on SIGTERM" test "$drc" -eq 0
done_testing
