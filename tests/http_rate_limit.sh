#!/bin/sh
# http_rate_limit.sh - requests per client (rate_limit, rate_limit_burst,
# rate_limit_header; server/rate_limit.h, docs/OPERATIONS.md "Rate
# limits") through gigaviewd.
#
# A burst of 5 and a rate of one request in 100 s, so that nothing refills
# while the test runs, whatever the machine's speed: of 12 requests on one
# connection exactly 5 are answered and 7 get 429 with the JSON error body
# and a Retry-After of about 100 s; /healthz and /metrics are not counted;
# a client named by the proxy's header has its own bucket, and the
# connection's address is the client when the header is absent; the 429s
# are in /metrics.  The bucket arithmetic with its own clock:
# tests/test_rate_limit.c.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" || bail "mkdir"
cd "$T" || bail "cd"
run encode synth:600x400 -o "$S/a.gv"
[ "$rc" -eq 0 ] || bail "encode: $(cat "$T/err")"
cat >"$T/r.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 2
gpu = off
access_log = stderr
rate_limit = 0.01
rate_limit_burst = 5
rate_limit_header = "X-Real-IP"
EOF2
start_daemon "$T/r.conf"

# statuses N [CURL ARGS]: N GETs of /v1/images/a on one connection; their
# statuses, one a line.
statuses() {
    n=$1
    shift
    set -- "$@" -w '%{http_code}\n'
    i=1 args=""
    while [ $i -le "$n" ]; do
        args="$args -o /dev/null $(url /v1/images/a)"
        i=$((i + 1))
    done
    # shellcheck disable=SC2086 # options and URLs a word each
    curl -sS "$@" $args
}
statuses 12 >s1.txt 2>"$T/curl.err" || true
check "12 requests, a burst of 5: 5 answered 200 ($(grep -c '^200$' s1.txt))" \
    test "$(grep -c '^200$' s1.txt)" = 5
check "... and 7 refused with 429 ($(grep -c '^429$' s1.txt))" test "$(grep -c '^429$' s1.txt)" = 7
check "... the first 5 answered, then only 429s" \
    test "$(tr '\n' ' ' <s1.txt)" = "200 200 200 200 200 429 429 429 429 429 429 429 "
req "$(url /v1/images/a)"
check "a refused request: 429" test "$code" = 429
check "... with the JSON error body" error_body_ok 429
check "... its code too_many_requests" test "$(json_get 'j["error"]["code"]')" = too_many_requests
ra=$(header Retry-After)
check "... and Retry-After in seconds, about 100 ($ra)" test "${ra:-0}" -ge 90 -a "${ra:-0}" -le 101
expect_status "/healthz is not counted" 200 /healthz
expect_status "/metrics is not counted" 200 /metrics
check "the 429s are in /metrics" grep -q 'status="429"' "$T/b"
statuses 6 -H 'X-Real-IP: 10.1.2.3' >s2.txt 2>>"$T/curl.err" || true
check "a client named by rate_limit_header has its own bucket: 5 of 6" \
    test "$(tr '\n' ' ' <s2.txt)" = "200 200 200 200 200 429 "
statuses 1 -H 'X-Real-IP: 10.1.2.4' >s3.txt 2>>"$T/curl.err" || true
check "... and another one its own" test "$(cat s3.txt)" = 200
statuses 1 -H 'X-Real-IP;' >s4.txt 2>>"$T/curl.err" || true
check "an empty header: the connection's address, already spent" test "$(cat s4.txt)" = 429

stop_daemon
check "daemon exits 0" test "$drc" -eq 0
no_sanitizer_report
done_testing
