# http_util.sh - helpers for the HTTP tests (tests/http_*.sh), on top of
# lib.sh.  Sourced, not run.
#
# start_daemon CONFIG: start gigaviewd with that configuration file on
# port 0 (under valgrind when VALGRIND is set), wait for its "listening on
# http://ADDR:PORT/" line and set DPID, PORT and BASE.  The daemon's
# stderr goes to $T/daemon.log.  stop_daemon sends SIGTERM and waits;
# the EXIT trap kills a daemon still running, whatever happens.
# req [CURL ARGS...] URL-PATH: one request; status in $code, headers in
# $T/h, body in $T/b.
# Needs curl and python3.

: "${GIGAVIEWD:=$(dirname "$GIGAVIEW")/gigaviewd}"
need_tool curl python3
[ -x "$GIGAVIEWD" ] || bail "no gigaviewd next to $GIGAVIEW"

DPID=
http_cleanup() {
    if [ -n "$DPID" ] && kill -0 "$DPID" 2>/dev/null; then
        kill -KILL "$DPID" 2>/dev/null
        wait "$DPID" 2>/dev/null
    fi
    cleanup
}
trap http_cleanup EXIT

# gvd ARGS...: the daemon, under valgrind when asked.
gvd() {
    if under_valgrind; then
        exec valgrind -q --error-exitcode=99 --leak-check=full \
            --errors-for-leak-kinds=definite --show-leak-kinds=definite \
            --suppressions="$(dirname "$0")/valgrind.supp" \
            "$GIGAVIEWD" "$@"
    else
        exec "$GIGAVIEWD" "$@"
    fi
}

# daemon_port: success once the daemon's log names its port (in PORT) or
# the daemon has gone (PORT empty).
daemon_port() {
    PORT=$(sed -n 's|.*listening on http://.*:\([0-9][0-9]*\)/$|\1|p' \
        "$T/daemon.log" | head -n 1)
    [ -n "$PORT" ] || ! kill -0 "$DPID" 2>/dev/null
}

start_daemon() {
    : >"$T/daemon.log"
    (gvd -c "$1" -p 0) 2>>"$T/daemon.log" &
    DPID=$!
    PORT=
    wait_until daemon_port
    [ -n "$PORT" ] || bail "gigaviewd did not start: $(tail -n 20 "$T/daemon.log")"
    BASE="http://127.0.0.1:$PORT"
}

# stop_daemon: SIGTERM, wait; exit status in $drc.
stop_daemon() {
    drc=0
    kill -TERM "$DPID" 2>/dev/null
    wait "$DPID" || drc=$?
    DPID=
}

# rescan_daemon [PID]: SIGHUP the daemon (PID, else DPID) and wait until a
# rescan of its store directory begun after the signal has ended: the
# catalog's summary lines (one for the start-up scan, one for each
# rescan) number the start-up scan, the rescans begun before the signal
# ("SIGHUP: rescanning" lines, some maybe still running) and this one.
# SIGHUPs close together may make one rescan, so counting signals would
# not do, nor would a count of stores that the rescan does not change.
# Needs log_level info (the default).
rescan_daemon() {
    rs_begun=$(grep -c ' info main: SIGHUP: rescanning ' "$T/daemon.log")
    kill -HUP "${1:-$DPID}"
    wait_until scans_ended $((rs_begun + 2))
}

# scans_ended N: the daemon's log has N or more catalog summary lines.
scans_ended() {
    [ "$(grep -cE ' info catalog: .*: [0-9]+ images \(' "$T/daemon.log")" -ge "$1" ]
}

# no_sanitizer_report: the daemon's log has no ASan/UBSan/LSan report
# (its first one is shown when there is one).  The reports' own first
# lines: the filter workers of a sanitizer build log "built with
# AddressSanitizer" as information.
no_sanitizer_report() {
    san='==[0-9]+==ERROR: [A-Za-z]+Sanitizer|: runtime error: '
    if grep -Eq "$san" "$T/daemon.log"; then
        not_ok "no sanitizer or UBSan report in the log" \
            "$(grep -E -m 1 -A 40 "$san" "$T/daemon.log")"
    else
        ok "no sanitizer or UBSan report in the log"
    fi
}

req() {
    code=$(curl -sS --path-as-is -o "$T/b" -D "$T/h" -w '%{http_code}' \
        --max-time "$GV_TEST_PATIENCE" "$@" 2>"$T/curl.err") || code=000
}

# url PATH: the daemon's URL for PATH.
url() {
    printf '%s%s' "$BASE" "$1"
}

# expect_status DESCRIPTION WANT PATH [CURL ARGS...]: request PATH and
# check the status (and, for an error, the JSON error body).
expect_status() {
    d=$1 want=$2 p=$3
    shift 3
    req "$@" "$(url "$p")"
    if [ "$code" != "$want" ]; then
        not_ok "$d (got $code, wanted $want)" "$(head -c 600 "$T/b")"
    elif [ "$want" -ge 400 ] && [ -s "$T/b" ] && ! error_body_ok "$want"; then
        not_ok "$d ($want) but not the JSON error body" "$(head -c 600 "$T/b")"
    else
        ok "$d ($want)"
    fi
}

# header NAME: the value of response header NAME from the last req.
header() {
    tr -d '\r' <"$T/h" | sed -n "s/^$1: //Ip" | tail -n 1
}

# json_get EXPR: evaluate a Python expression on the parsed body `j`.
json_get() {
    python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print($1)" \
        "$T/b" 2>/dev/null
}

# error_ok STATUS: the last body is the JSON error shape with that status.
error_body_ok() {
    python3 - "$T/b" "$1" <<'PY' 2>/dev/null
import json, sys
e = json.load(open(sys.argv[1]))["error"]
assert e["status"] == int(sys.argv[2]) and e["code"] and e["message"]
PY
}

# webp_is_raw WEBP RAW CHANNELS: the WebP decodes (oiiotool) to exactly the
# raw samples RAW (CHANNELS a pixel; a gray one's three channels must each
# equal it).
webp_is_raw() {
    oiiotool "$1" --ch R,G,B -d uint8 -o "$1.ppm" >/dev/null 2>&1 || return 1
    python3 - "$1.ppm" "$2" "$3" <<'PY'
import sys
d = open(sys.argv[1], 'rb').read()
tok, i = [], 0
while len(tok) < 4:        # P6 width height maxval, '#' comments skipped
    while d[i:i + 1].isspace():
        i += 1
    if d[i:i + 1] == b'#':
        i = d.index(b'\n', i)
        continue
    j = i
    while not d[j:j + 1].isspace():
        j += 1
    tok.append(d[i:j])
    i = j
px, raw, c = d[i + 1:], open(sys.argv[2], 'rb').read(), int(sys.argv[3])
assert tok[0] == b'P6' and tok[3] == b'255', tok
assert len(px) == int(tok[1]) * int(tok[2]) * 3, (tok, len(px))
if c == 3:
    assert px == raw, 'the RGB samples differ'
else:
    assert all(px[k::3] == raw for k in range(3)), 'a channel differs'
PY
}

# pnm PATH OUT: fetch PATH (a PNG) into OUT.png and convert it to OUT.pnm
# (oiiotool); 0 on success.
pnm() {
    req "$(url "$1")"
    [ "$code" = 200 ] && cp "$T/b" "$2.png" && oiiotool "$2.png" -o "$2.pnm" 2>/dev/null
}
