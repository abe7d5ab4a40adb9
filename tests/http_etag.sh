#!/bin/sh
# http_etag.sh - gigaviewd's ETags follow the store's bytes, not its
# header: a store replaced by one with a byte-identical header but other
# pixels gets new ETags for its tiles, regions, IIIF images and root, so no
# cache between the server and a viewer keeps serving the old answers.
# Also the one If-None-Match matcher: a listed ETag, a weak "W/" one and
# "*" answer 304 on every route tried (the root included), another ETag or
# a malformed list 200.
#
# The two stores: picos-1100x700.jpg and its upside-down copy are encoded
# with the same options (level 0 is one page), and the store whose level-0
# page is larger gets the other's level-0 page grafted into its place (the
# index entry's size and CRC, and the index CRC, updated; the slack after
# it zero): a valid store with the same header, root and levels 1 to 3 and other
# level-0 pixels.
# Needs curl, python3 and oiiotool (openimageio-tools).
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
need_tool oiiotool
set -f  # the request paths below hold '?': no pathname expansion

S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
cd "$T/w" || bail "cd"

oiiotool "$TESTDATA/picos-1100x700.jpg" --flip -o "$T/flipped.png" >/dev/null 2>&1 ||
    bail "oiiotool --flip failed"
run encode "$TESTDATA/picos-1100x700.jpg" -o "$T/a.gv"
[ "$rc" -eq 0 ] || bail "encode a: $(cat "$T/err")"
run encode "$T/flipped.png" -o "$T/b.gv"
[ "$rc" -eq 0 ] || bail "encode b: $(cat "$T/err")"

python3 - "$T/a.gv" "$T/b.gv" "$T/first.gv" "$T/second.gv" <<'PY' ||
import struct, sys, zlib
a, b = (bytearray(open(p, 'rb').read()) for p in sys.argv[1:3])

def entry(s, p):
    index = struct.unpack_from('<Q', s, 56)[0]
    return struct.unpack_from('<QII', s, index + 16 * p)

pages = struct.unpack_from('<Q', a, 64)[0]
last = pages - 1            # level 0's only page: levels are coarse first
assert pages == struct.unpack_from('<Q', b, 64)[0] == 4, pages
if entry(a, last)[1] < entry(b, last)[1]:
    a, b = b, a             # graft the smaller page into the larger's room
off, size, _ = entry(a, last)
boff, bsize, bcrc = entry(b, last)
page = b[boff:boff + bsize]
assert page != a[off:off + size]
c = bytearray(a)
c[off:off + size] = page + bytes(size - bsize)
index = struct.unpack_from('<Q', c, 56)[0]
struct.pack_into('<QII', c, index + 16 * last, off, bsize, zlib.crc32(page))
struct.pack_into('<I', c, index + 16 * pages, zlib.crc32(c[index:index + 16 * pages]))
open(sys.argv[3], 'wb').write(a)
open(sys.argv[4], 'wb').write(c)
PY
    bail "grafting a page failed"
check "the two stores have byte-identical headers" cmp -s -n 128 "$T/first.gv" "$T/second.gv"
check "the two stores differ" sh -c "! cmp -s '$T/first.gv' '$T/second.gv'"
cp "$T/first.gv" "$S/x.gv" || bail "cp"

cat >"$T/good.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 2
cache_bytes = 8M
max_region_pixels = 4M
connection_timeout = 10
access_log = stderr
log_level = info
EOF2
start_daemon "$T/good.conf"
diag "gigaviewd on port $PORT"

# What each route answers: a level-0 tile, a level-0 region, a full-size
# IIIF image (decoded from level 0) and the root (the same in both stores:
# its ETag changes all the same, since the identity covers every page).
paths="/v1/images/x/tiles/0/1/0
/v1/images/x/region?level=0&x=256&y=128&w=512&h=384&format=png
/iiif/3/x/full/max/0/default.png
/v1/images/x/root"

# ---------------------------------------------------------------- before
n=0
for p in $paths; do
    n=$((n + 1))
    req "$(url "$p")"
    etag=$(header ETag)
    printf '%s\n' "$etag" >"$T/etag$n"
    cp "$T/b" "$T/body$n"
    check "$p: 200 with a strong ETag ($etag)" \
        sh -c "[ '$code' = 200 ] && echo '$etag' | grep -Eq '^\"[0-9a-f]{16}[-0-9a-f]'"
    expect_status "$p: If-None-Match with its ETag" 304 "$p" -H "If-None-Match: $etag"
    check "$p: the 304 carries the ETag" test "$(header ETag)" = "$etag"
    expect_status "$p: If-None-Match with its weak form" 304 "$p" -H "If-None-Match: W/$etag"
    expect_status "$p: If-None-Match listing it among others" 304 "$p" \
        -H "If-None-Match: \"a,b\" ,W/\"other\",	$etag , \"z\""
    expect_status "$p: If-None-Match: *" 304 "$p" -H 'If-None-Match: *'
    expect_status "$p: If-None-Match with another ETag" 200 "$p" \
        -H 'If-None-Match: "0000000000000000-0000000000000000"'
    inner=$(printf '%s' "$etag" | tr -d '"')
    expect_status "$p: its ETag without quotes or inside another is no match" 200 "$p" \
        -H "If-None-Match: $inner, \"x$inner\", \"${inner}x\""
done

# ---------------------------------------------------------------- after
# Replace the store by rename, as encoders publish, and rescan.
cp "$T/second.gv" "$S/.x.gv.new" && mv "$S/.x.gv.new" "$S/x.gv" || bail "mv"
kill -HUP "$DPID"
wait_until grep -q 'replaced x (instance' "$T/daemon.log"
check "SIGHUP replaces the store" grep -q 'replaced x (instance' "$T/daemon.log"

n=0
for p in $paths; do
    n=$((n + 1))
    old=$(cat "$T/etag$n")
    req -H "If-None-Match: $old" "$(url "$p")"
    new=$(header ETag)
    check "$p: the old ETag is stale: 200 (got $code)" test "$code" = 200
    check "$p: a new ETag ($old -> $new)" sh -c "[ -n '$new' ] && [ '$new' != '$old' ]"
    case $p in
    */root) ;;  # the root's pixels did not change
    *) check "$p: other bytes" sh -c "! cmp -s '$T/b' '$T/body$n'" ;;
    esac
    expect_status "$p: If-None-Match with the new ETag" 304 "$p" -H "If-None-Match: $new"
done

stop_daemon
check "gigaviewd exits 0 on SIGTERM" test "$drc" -eq 0
done_testing
