#!/bin/sh
# fault_serve_store.sh - gigaviewd while its stores are damaged, deleted
# and replaced under it.
#
# Part 1: a page corrupted on disk while the daemon runs (one byte
# flipped in place, in the open file, after other pages were served and
# cached).  Exactly the tiles of that page answer 500 "corrupt" - alone,
# in a batch, and in regions and IIIF images that need them - everything
# else still serves, each failure is logged as an error line naming the
# image, and /metrics counts them: gigaview_page_errors_total (pages that
# failed their check) and gigaview_page_error_responses_total (answers
# that failed because of one, exactly as many as were sent).
#
# Part 2 (caches off, so every answer reads the file as it is): stores
# deleted, replaced by rename, overwritten in place and truncated
# while 6 client threads keep requesting tiles, batches,
# regions, IIIF images and metadata of them, each followed by SIGHUP.
# Every answer must be a well-formed HTTP response: 200, or 404 once the
# store is gone, or a 500 with the JSON error body while a file changed in
# place is being read; never a reset connection, never a crash.  After
# each reload the new version is served (its tiles byte-identical to the
# same store served under another name).  Then 20 fast cycles of all of
# it.  Finally SIGTERM: exit 0, and no sanitizer report in the log.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
cd "$T/w" || bail "cd"
# m: 4700x600, level 0 is 10x2 tiles in two pages (tiles 0-7 and 8-9).
run encode -q 30 synth:4700x600 -o "$S/m.gv"
[ "$rc" -eq 0 ] || bail "encode m: $(cat "$T/err")"
run encode synth:3000x2000 -o "$T/a.gv"
[ "$rc" -eq 0 ] || bail "encode a: $(cat "$T/err")"
run encode synth:2000x1500:gray -o "$T/b.gv"
[ "$rc" -eq 0 ] || bail "encode b: $(cat "$T/err")"
cp "$T/a.gv" "$S/k.gv"
cp "$T/a.gv" "$S/refa.gv"   # the same stores under fixed names, for
cp "$T/b.gv" "$S/refb.gv"   # byte comparisons

cat >"$T/d.conf" <<EOF2
store_dir = "$S"
threads = 4
cache_bytes = 8M
max_region_pixels = 4M
access_log = off
log_level = info
EOF2
start_daemon "$T/d.conf"

metric() {
    curl -s "$BASE/metrics" | sed -n "s/^$1 //p"
}

# ---------------------------------------------------------- 1. corrupt page
expect_status "before: tile of page 0" 200 /v1/images/m/tiles/0/0/0
expect_status "before: tile of level 1" 200 /v1/images/m/tiles/1/0/0
check "before: no page errors counted" test "$(metric gigaview_page_errors_total) $(metric gigaview_page_error_responses_total)" = "0 0"
ino=$(stat -c %i "$S/m.gv")
python3 - "$S/m.gv" <<'PY' || bail "corrupting the page"
import struct, sys
with open(sys.argv[1], 'r+b') as f:          # in place: the daemon's open file
    b = f.read()
    index, pages = struct.unpack_from('<QQ', b, 56)
    # The last entry of the index is level 0's last page, (1,0).
    off, size, crc = struct.unpack_from('<QII', b, index + 16 * (pages - 1))
    f.seek(off + size // 2)
    f.write(bytes([b[off + size // 2] ^ 0x55]))
PY
check "the file was changed in place (same inode)" test "$(stat -c %i "$S/m.gv")" = "$ino"
expect_status "corrupt page: tile 0/8/0" 500 /v1/images/m/tiles/0/8/0
check "corrupt page: error code corrupt" test "$(json_get 'j["error"]["code"]')" = corrupt
expect_status "corrupt page: tile 0/9/1" 500 /v1/images/m/tiles/0/9/1
expect_status "the other page of level 0 still serves" 200 /v1/images/m/tiles/0/7/1
expect_status "the cached tile still serves" 200 /v1/images/m/tiles/0/0/0
expect_status "level 1 still serves" 200 /v1/images/m/tiles/1/4/0
req "$BASE/v1/images/m/batch?t=0,7,0;0,8,0;1,0,0"
check "batch: 200, 500, 200 for good, corrupt, good" test "$code $(python3 -c "
import struct, sys
b = open(sys.argv[1], 'rb').read()
n, = struct.unpack_from('<I', b, 4)
off, st = 8, []
for i in range(n):
    s, l = struct.unpack_from('<II', b, off + 12)
    st.append(str(s))
    off += 20 + (l + 3) // 4 * 4
print(' '.join(st))" "$T/b")" = "200 200 500 200"
expect_status "a region across the corrupt page" 500 "/v1/images/m/region?level=0&x=4000&y=0&w=300&h=100&format=png"
expect_status "a region inside the good page" 200 "/v1/images/m/region?level=0&x=0&y=0&w=300&h=100&format=png"
expect_status "an IIIF image needing the corrupt page" 500 "/iiif/3/m/4000,0,300,100/max/0/default.png"
expect_status "an IIIF image of the good page" 200 "/iiif/3/m/0,0,300,100/max/0/default.png"
expect_status "healthz" 200 /healthz
check "log: the tile errors, as error lines naming image and tile" \
    sh -c "grep -q ' error tiles: m: tile 0/8/0: ' '$T/daemon.log' && grep -q ' error tiles: m: tile 0/9/1: ' '$T/daemon.log'"
check "log: the region and IIIF errors" \
    sh -c "grep -q ' error region: m: ' '$T/daemon.log' && grep -q ' error iiif: m: ' '$T/daemon.log'"
pe=$(metric gigaview_page_errors_total)
check "metrics: pages that failed their check counted ($pe)" test "${pe:-0}" -ge 2
check "metrics: exactly the 5 failed answers counted" test "$(metric gigaview_page_error_responses_total)" = 5
check "metrics: the 500s by route" sh -c "curl -s '$BASE/metrics' | grep -q '^gigaview_http_requests_total{route=\"tile\",status=\"500\"} 2\$'"

# ------------------------------------------------------- 2. under load
# Without caches (cache_bytes = 0, a small decoded-tile cache), so that
# every answer reads the file as it is at that moment.
stop_daemon
check "part 1: SIGTERM, exit 0" test "$drc" -eq 0
sed -e 's/^cache_bytes = .*/cache_bytes = 0/' "$T/d.conf" >"$T/d2.conf"
echo 'decoder_cache_bytes = 1M' >>"$T/d2.conf"
start_daemon "$T/d2.conf"
cat >load.py <<'PY'
# Client threads request URLs of store k until the file `stop` appears
# (the first answer creates the file `answered`); then print "STATUS COUNT" lines, "reset N" (connection failures) and
# "badbody N" (errors without the JSON error body).
import http.client, json, os, sys, threading, time
port, nthreads = int(sys.argv[1]), int(sys.argv[2])
# Every path exists in both versions of k (3000x2000 RGB, 2000x1500 gray).
paths = ['/v1/images/k', '/v1/images/k/tiles/0/0/0', '/v1/images/k/tiles/0/3/1',
         '/v1/images/k/tiles/1/1/1', '/v1/images/k/tiles/1/0/1',
         '/v1/images/k/batch?t=0,0,0;0,1,1;1,0,0;2,1,0',
         '/v1/images/k/root?format=raw',
         '/v1/images/k/region?level=1&x=100&y=100&w=300&h=200&format=png',
         '/iiif/3/k/full/200,/0/default.jpg', '/iiif/3/k/info.json']
lock = threading.Lock()
counts, reset, badbody = {}, [0], [0]
def worker(k):
    i = k
    while not os.path.exists('stop'):
        p = paths[i % len(paths)]
        i += 1
        try:
            c = http.client.HTTPConnection('127.0.0.1', port,
                                           timeout=float(os.environ['GV_TEST_PATIENCE']))
            c.request('GET', p)
            r = c.getresponse()
            body = r.read()
            c.close()
        except Exception as e:
            with lock:
                reset[0] += 1
                sys.stderr.write('%s: %r\n' % (p, e))
            time.sleep(0.01)
            continue
        ok = True
        if r.status >= 400:
            try:
                e = json.loads(body)['error']
                ok = e['status'] == r.status and bool(e['code']) and bool(e['message'])
            except Exception:
                ok = False
        with lock:
            counts[r.status] = counts.get(r.status, 0) + 1
            if not os.path.exists('answered'):
                open('answered', 'w').close()
            if os.path.exists('mark'):
                with open('after', 'a') as f:
                    f.write('%d\n' % r.status)
            if not ok:
                badbody[0] += 1
ts = [threading.Thread(target=worker, args=(k,)) for k in range(nthreads)]
for t in ts: t.start()
for t in ts: t.join()
for s in sorted(counts): print(s, counts[s])
print('reset', reset[0])
print('badbody', badbody[0])
PY

# load_start / load_stop PHASE: run the clients (load_start returns once
# they have an answer, however long they take to start on a loaded
# machine); load_stop leaves the summary in $T/w/PHASE.out and sets
# $statuses (e.g. "200 404").
# shellcheck disable=SC2317 # run by wait_until
load_answered() {
    [ -e answered ] || ! kill -0 "$LPID" 2>/dev/null
}
load_start() {
    rm -f stop answered
    python3 load.py "$PORT" 6 >"$1.out" 2>"$1.err" &
    LPID=$!
    wait_until load_answered
}
# shellcheck disable=SC2317 # run by wait_until
load_answered_since_mark() {
    [ "$(cat after 2>/dev/null | wc -l)" -ge 7 ] || ! kill -0 "$LPID" 2>/dev/null
}
# settled: wait until the clients have had nthreads + 1 answers since
# now (however loaded the machine): at least one request was sent after
# the caller's last step, so its outcome is among the statuses.
settled() {
    rm -f after
    touch mark
    wait_until load_answered_since_mark
    rm -f mark
}
load_stop() {
    touch stop
    wait "$LPID"
    statuses=$(awk '$1 ~ /^[0-9]+$/ { printf "%s%s", sep, $1; sep = " " }' "$1.out")
    total=$(awk '$1 ~ /^[0-9]+$/ { s += $2 } END { print s + 0 }' "$1.out")
    diag "$1: $(tr '\n' ' ' <"$1.out")"
    check "$1: answers were given ($total)" test "$total" -gt 0
    check "$1: no reset or refused connection" grep -q '^reset 0$' "$1.out"
    check "$1: every error has the JSON error body" grep -q '^badbody 0$' "$1.out"
    check "$1: the daemon is alive" kill -0 "$DPID"
}
# reload N: SIGHUP, wait until a rescan begun after now has finished
# (rescan_daemon), then succeed if /healthz counts N stores.
reload() {
    rescan_daemon
    [ "$(curl -s "$BASE/healthz" | python3 -c 'import json,sys; print(json.load(sys.stdin)["stores"])' 2>/dev/null)" = "$1" ]
}
# serves REF: the tiles of k equal those of REF (refa or refb).
serves() {
    for t in 0/0/0 0/1/1 1/0/0; do
        curl -s -o got "$BASE/v1/images/k/tiles/$t" &&
            curl -s -o want "$BASE/v1/images/$1/tiles/$t" && cmp -s got want || return 1
    done
}
check "k serves version a" serves refa

load_start deleted
rm "$S/k.gv"
# A second of answers from the changed file before the reload; the
# checks hold with any number of them (also after the sleeps below).
sleep 1
check "deleted: SIGHUP drops it" reload 3
settled
load_stop deleted
check "deleted: only 200 (before the reload) and 404 (after)" test "$statuses" = "200 404"
expect_status "deleted: 404 now" 404 /v1/images/k/tiles/0/0/0

cp "$T/a.gv" "$S/k.gv"
check "recreated: SIGHUP picks it up" reload 4
load_start renamed
cp "$T/b.gv" "$S/.k.tmp"
mv "$S/.k.tmp" "$S/k.gv"
sleep 0.5
check "replaced by rename: SIGHUP" reload 4
settled
load_stop renamed
check "replaced by rename: every answer 200" test "$statuses" = 200
check "replaced by rename: version b is served" serves refb

load_start overwritten
cat "$T/a.gv" >"$S/k.gv"      # same inode, other bytes under the open file
sleep 1
check "overwritten in place: SIGHUP" reload 4
settled
load_stop overwritten
check "overwritten in place: only 200 and clean 500s" \
    sh -c "echo '$statuses' | grep -Eq '^200( 500)?\$'"
check "overwritten in place: version a is served after the reload" serves refa

load_start truncated
truncate -s 300000 "$S/k.gv"
sleep 1
check "truncated in place: SIGHUP drops it (it no longer validates)" reload 3
settled
load_stop truncated
check "truncated in place: only 200, clean 500s and 404" \
    sh -c "echo '$statuses' | grep -Eq '^200( 404)?( 500)?\$'"
check "truncated: the reload logged why it skipped the store" \
    grep -q ' warn catalog: skipping .*k\.gv: ' "$T/daemon.log"

# 20 fast cycles of everything, under load.
cp "$T/a.gv" "$S/k.gv"
reload 4 || true
load_start cycles
i=0
while [ $i -lt 20 ]; do
    case $((i % 4)) in
    0) cp "$T/b.gv" "$S/.k.tmp" && mv "$S/.k.tmp" "$S/k.gv" ;;
    1) cat "$T/a.gv" >"$S/k.gv" ;;
    2) rm -f "$S/k.gv" ;;
    3) cp "$T/a.gv" "$S/k.gv" && truncate -s 200000 "$S/k.gv" ;;
    esac
    sleep 0.1
    kill -HUP "$DPID"
    sleep 0.15
    i=$((i + 1))
done
load_stop cycles
check "cycles: only 200, 404 and clean 500s" \
    sh -c "echo '$statuses' | grep -Eq '^200( 404)?( 500)?\$'"
cp "$T/b.gv" "$S/.k.tmp" && mv "$S/.k.tmp" "$S/k.gv"
check "after the cycles: a last reload" reload 4
check "after the cycles: version b is served" serves refb

stop_daemon
check "SIGTERM: exit 0" test "$drc" -eq 0
no_sanitizer_report
if [ "$tap_failed" -ne 0 ]; then
    diag "daemon log (tail):"
    diag "$(tail -n 30 "$T/daemon.log")"
fi
done_testing
