#!/bin/sh
# http_render.sh - IIIF images and regions through the render pool, the
# shared tile cache and the output cache (docs/API.md, "Rendering").
#
#   - a second identical request is an output cache hit (/metrics), with
#     the same bytes and the same strong ETag; another spelling of the same
#     IIIF request shares the entry;
#   - If-None-Match with the ETag is 304 without a render or a lookup;
#   - every render went through the render pool (its wait histogram counts
#     exactly the misses), and the tile cache reports its budget;
#   - while a render runs, the only HTTP thread keeps answering (/metrics
#     shows the render running; skipped if the render ends before it can
#     be seen);
#   - with render_queue = 1 full, a render is refused: 503 busy with
#     Retry-After (skipped if the queue empties first);
#   - a client that closes its connection while its render is queued
#     leaves nothing behind (the render runs; its state is freed);
#   - the output cache keeps to output_cache_bytes: a sequence of regions
#     of known sizes through a budget of about three of them evicts exactly
#     what an LRU model of it predicts, and the bytes stay within it.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
cd "$T/w" || bail "cd"
run encode synth:3000x2000 -o "$S/x.gv"
[ "$rc" -eq 0 ] || bail "encode: $(cat "$T/err")"
conf() {
    cat >"$T/r.conf" <<EOF2
store_dir = "$S"
threads = 1
render_threads = ${2:-2}
access_log = off
gpu = off
decoder_cache_bytes = 32M
output_cache_bytes = $1
EOF2
}

# metric NAME: the value of sample NAME in a fresh /metrics.
metric() {
    curl -sS --max-time "$GV_TEST_PATIENCE" "$(url /metrics)" | awk -v n="$1" '$1 == n { print $2 }'
}
# counts: "hits misses" of the output cache.
counts() {
    echo "$(metric gigaview_output_cache_hits_total) $(metric gigaview_output_cache_misses_total)"
}

conf 64M
start_daemon "$T/r.conf"

tile=/iiif/3/x/512,512,512,512/max/0/default.jpg
same=/iiif/3/x/512,512,512,512/512,512/0/default.jpg
expect_status "IIIF tile" 200 "$tile"
cp "$T/b" first.jpg
etag=$(header ETag)
check "a strong ETag (\"IDENTITY-HASH\", not W/): $etag" \
    sh -c "echo '$etag' | grep -Eq '^\"[0-9a-f]{16}-[0-9a-f]{16}\"$'"
check "first request: a miss, no hit ($(counts))" test "$(counts)" = "0 1"
expect_status "IIIF tile again" 200 "$tile"
check "second request: a hit ($(counts))" test "$(counts)" = "1 1"
check "the hit has the same bytes" cmp -s first.jpg "$T/b"
check "the hit has the same ETag" test "$(header ETag)" = "$etag"
check "the hit keeps the canonical Link" \
    sh -c "grep -qi '^Link: <http://127.0.0.1:$PORT/iiif/3/x/512,512,512,512/max/0/default.jpg>;rel=\"canonical\"' '$T/h'"
expect_status "the same request spelled w,h" 200 "$same"
check "another spelling is a hit ($(counts))" test "$(counts)" = "2 1"
check "another spelling has the same ETag" test "$(header ETag)" = "$etag"

expect_status "If-None-Match with the ETag" 304 "$tile" -H "If-None-Match: $etag"
check "304 carries the ETag" test "$(header ETag)" = "$etag"
n=$(curl -sS --max-time "$GV_TEST_PATIENCE" -o /dev/null -w '%{size_download}' \
    -H "If-None-Match: $etag" "$(url "$tile")")
check "304 has no body ($n bytes)" test "$n" = 0
check "304s neither render nor look up ($(counts))" test "$(counts)" = "2 1"
expect_status "If-None-Match among others" 304 "$same" \
    -H "If-None-Match: \"0000000000000000-0000000000000000\", $etag"
expect_status "If-None-Match with another ETag" 200 "$tile" \
    -H 'If-None-Match: "0000000000000000-0000000000000000"'

region='/v1/images/x/region?level=1&x=100&y=100&w=300&h=200'
expect_status "region" 200 "$region"
retag=$(header ETag)
check "region: another ETag ($retag)" test -n "$retag" -a "$retag" != "$etag"
expect_status "region again" 200 "$region"
check "region: second request is a hit ($(counts))" test "$(counts)" = "4 2"
expect_status "region: If-None-Match" 304 "$region" -H "If-None-Match: $retag"
expect_status "region: another quality is another entry" 200 "$region&format=jpeg&quality=50"
check "a third render ($(counts))" test "$(counts)" = "4 3"

check "render pool: every miss waited in its queue once" \
    test "$(metric gigaview_render_queue_wait_seconds_count)" = 3
check "render pool: nothing queued or running now" \
    test "$(metric gigaview_render_queue_depth) $(metric gigaview_render_running)" = "0 0"
check "tile cache: the budget is decoder_cache_bytes" \
    test "$(metric gigaview_tile_cache_limit_bytes)" = 33554432
check "tile cache: tiles were decoded into it" \
    test "$(metric gigaview_tile_cache_misses_total)" -gt 0
check "output cache: limit is output_cache_bytes" \
    test "$(metric gigaview_output_cache_limit_bytes)" = 67108864

# A long render (the whole level 0 as PNG) does not hold the only HTTP
# thread: /metrics answers while it runs, and says so.
curl -sS --max-time "$GV_TEST_PATIENCE" -o big.png "$(url '/v1/images/x/region?level=0&x=0&y=0&w=3000&h=2000')" &
bigpid=$!
seen=
while kill -0 $bigpid 2>/dev/null; do
    if [ "$(metric gigaview_render_running)" = 1 ]; then
        seen=1
        break
    fi
done
wait $bigpid
if [ -n "$seen" ]; then
    ok "/metrics answered by the only HTTP thread while a render ran"
else
    skip "the render ended before /metrics could see it" "long render"
fi
check "the long render's answer is a 3000x2000 PNG"     test "$(python3 -c 'import struct,sys; d=open(sys.argv[1],"rb").read(24); print(*struct.unpack(">II", d[16:24]))' big.png)" = "3000 2000"

# Five regions, their sizes measured here (the bytes are deterministic).
rurl() {
    echo "/v1/images/x/region?level=0&x=$((300 * $1))&y=0&w=200&h=150"
}
sizes=
for i in 1 2 3 4 5; do
    req "$(url "$(rurl $i)")"
    sizes="$sizes $(wc -c <"$T/b")"
done
stop_daemon
check "SIGTERM: exit 0" test "$drc" -eq 0

# A budget of the first three: the sequence 1..5, then 1 and 5 again.
budget=$(echo $sizes | awk '{ print $1 + $2 + $3 }')
conf "$budget"
start_daemon "$T/r.conf"
for i in 1 2 3 4 5 1 5; do
    req "$(url "$(rurl $i)")"
done
# The LRU model: "hits misses evictions bytes".
want=$(python3 - "$budget" $sizes <<'PY'
import sys
budget, sizes = int(sys.argv[1]), [int(s) for s in sys.argv[2:]]
lru, hits, misses, ev = [], 0, 0, 0
for i in [1, 2, 3, 4, 5, 1, 5]:
    if i in lru:
        hits += 1
        lru.remove(i)
        lru.insert(0, i)
        continue
    misses += 1
    n = sizes[i - 1]
    if n > budget:
        continue
    while lru and sum(sizes[k - 1] for k in lru) + n > budget:
        lru.pop()
        ev += 1
    lru.insert(0, i)
print(hits, misses, ev, sum(sizes[k - 1] for k in lru))
PY
)
got="$(counts) $(metric gigaview_output_cache_evictions_total) $(metric gigaview_output_cache_bytes)"
check "budget $budget (sizes$sizes): hits misses evictions bytes = $want (got $got)" \
    test "$got" = "$want"
check "evictions happened" test "$(echo "$got" | awk '{ print $3 }')" -gt 0
check "bytes within the budget" test "$(metric gigaview_output_cache_bytes)" -le "$budget"

stop_daemon
check "SIGTERM: exit 0" test "$drc" -eq 0
no_sanitizer_report

# A client that goes away while its render waits in the queue: the render
# still runs, the daemon stays healthy, and the render's state is freed
# however libmicrohttpd ends the request (by calling the handler again,
# as it does here, or not: then http.c's completion callback frees it);
# under valgrind or ASan a leak fails the exit status or the log check.
# One render thread, held by a long render, so the second one queues.
conf 0 1
echo "render_queue = 1" >>"$T/r.conf"
start_daemon "$T/r.conf"
long() {
    curl -sS --max-time "$GV_TEST_PATIENCE" -o "$1" "$(url "/v1/images/x/region?level=0&x=0&y=0&w=3000&h=$2")"
}
long a.png 2000 &
apid=$!
queued=
busy=
while kill -0 $apid 2>/dev/null; do
    if [ "$(metric gigaview_render_running)" = 1 ]; then
        long b.png 1999 &
        bpid=$!
        while kill -0 $apid 2>/dev/null && kill -0 $bpid 2>/dev/null; do
            if [ "$(metric gigaview_render_queue_depth)" = 1 ]; then
                # render_queue = 1 is full: a third render is refused.
                busy=$(curl -sS --max-time "$GV_TEST_PATIENCE" -o busy.json -D busy.h -w '%{http_code}' \
                    "$(url '/v1/images/x/region?level=2&x=0&y=0&w=10&h=10')")
                kill $bpid
                queued=1
                break
            fi
        done
        wait $bpid 2>/dev/null
        break
    fi
done
wait $apid
if [ -n "$queued" ] && [ "$busy" = 503 ]; then
    ok "render_queue full: 503"
    check "503: code busy, Retry-After: 1" sh -c "grep -q '\"code\":\"busy\"' busy.json &&
        tr -d '\r' <busy.h | grep -qi '^Retry-After: 1\$'"
    check "503: counted as refused" test "$(metric gigaview_render_rejected_total)" = 1
else
    skip "render_queue full: 503" "the queued render started before the third request"
fi
if [ -n "$queued" ]; then
    ok "a queued render's client closed its connection"
    # Every render ends: nothing queued, nothing running, two renders done.
    # shellcheck disable=SC2317 # run by wait_until
    renders_done() {
        [ "$(metric gigaview_render_queue_depth) $(metric gigaview_render_running) $(metric gigaview_render_queue_wait_seconds_count)" = "0 0 2" ]
    }
    check "both renders ran" wait_until renders_done
    expect_status "the daemon answers after the abandoned render" 200 /healthz
else
    skip "the first render ended before the second could queue" "long render"
fi
stop_daemon
check "SIGTERM after an abandoned render: exit 0" test "$drc" -eq 0
no_sanitizer_report
done_testing
