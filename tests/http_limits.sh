#!/bin/sh
# http_limits.sh - every request-size limit of gigaviewd has a
# configuration key, and each key is what sets the limit.
#
# The daemon runs with every key set far below its default, and each
# limit is probed on both sides: a request exactly at the limit is
# served, one just past it is refused with the documented status and its
# exact message, which names the key (413 on /v1 routes; IIIF, which has no
# 413, answers 400 naming the limits as info.json advertises them).
#   max_request_bytes   POST body: announced (refused before the body is
#                       read), received, chunked; any POST route
#   max_region_pixels   /region w*h
#   max_output_pixels   IIIF output area (info.json maxArea)
#   max_output_side     IIIF output width and height (maxWidth, maxHeight)
#   max_upscale         IIIF "^" factor
#   batch_max_tiles     tiles in a batch, POST and GET
# connection_limit is tested by fault_slow_clients.sh; the filter limits
# (filter_max_*, max_filter_pixels) by http_filters.sh and
# test_filter_graph.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
# The source tree, absolute: $0 may be relative (make distcheck).
srcroot=$(cd "$(dirname "$0")/.." && pwd)
cd "$T/w" || bail "cd"
run encode synth:3000x2000 -o "$S/x.gv"
[ "$rc" -eq 0 ] || bail "encode: $(cat "$T/err")"
cat >"$T/l.conf" <<EOF2
store_dir = "$S"
threads = 2
access_log = off
max_request_bytes = 4K
max_region_pixels = 10000
max_output_pixels = 20000
max_output_side = 150
max_upscale = 2
batch_max_tiles = 3
EOF2
start_daemon "$T/l.conf"

# Every key the daemon knows (gigaviewd -S) is documented in the shipped
# file (set, or commented out where the default depends on the install),
# and the shipped file is accepted as it is (with a store_dir that exists
# here: -t checks it).
conf=$srcroot/conf/gigaviewd.conf
missing=
for k in $("$GIGAVIEWD" -S | sed -n 's/^\([a-z_]*\) = .*/\1/p'); do
    grep -Eq "^#?$k = " "$conf" || missing="$missing $k"
done
check "conf/gigaviewd.conf documents every key (missing:${missing:- none})" test -z "$missing"
sed "s|^store_dir = .*|store_dir = \"$S\"|" "$conf" >shipped.conf
check "gigaviewd -t accepts conf/gigaviewd.conf" "$GIGAVIEWD" -t -c shipped.conf

# body N: a batch body of exactly N bytes (valid JSON, padded with spaces).
body() {
    python3 -c '
import sys
n = int(sys.argv[1])
b = "{\"tiles\":[[0,0,0]]}"
sys.stdout.write(b + " " * (n - len(b)))' "$1" >"body.$1"
}
# message_is TEXT: the last error message is exactly TEXT (shown in a
# TAP comment when it is not).
message_is() {
    got=$(json_get 'j["error"]["message"]')
    [ "$got" = "$1" ] && return 0
    diag "message: $got"
    return 1
}

# ---------------------------------------------------------- max_request_bytes
body 4096
body 4097
expect_status "POST body of exactly max_request_bytes (4096)" 200 /v1/images/x/batch \
    -X POST -H 'Content-Type: application/json' --data-binary @body.4096
expect_status "POST body one byte over" 413 /v1/images/x/batch \
    -X POST -H 'Content-Type: application/json' --data-binary @body.4097
check "413 names max_request_bytes and its value" \
    message_is "request body larger than 4096 bytes (max_request_bytes)"
expect_status "chunked POST body over the limit" 413 /v1/images/x/batch \
    -X POST -H 'Transfer-Encoding: chunked' --data-binary @body.4097
expect_status "chunked POST body within the limit" 200 /v1/images/x/batch \
    -X POST -H 'Transfer-Encoding: chunked' --data-binary @body.4096
expect_status "the cap covers every POST route (filters)" 413 /v1/filters \
    -X POST -H 'Content-Type: application/json' --data-binary @body.4097
# Announced too large: answered from the headers alone, the body is never
# sent (the client waits for the answer before sending anything).
python3 - "$PORT" >announce.out <<'PY'
import os, socket, sys
s = socket.create_connection(('127.0.0.1', int(sys.argv[1])),
                             timeout=float(os.environ['GV_TEST_PATIENCE']))
s.sendall(b'POST /v1/images/x/batch HTTP/1.1\r\nHost: t\r\n'
          b'Content-Type: application/json\r\nContent-Length: 104857600\r\n\r\n')
print(s.recv(4096).split(b'\r\n')[0].decode())
PY
check "Content-Length of 100 MB: 413 before any body byte" grep -q '^HTTP/1.1 413' announce.out

# ---------------------------------------------------------- max_region_pixels
expect_status "region of exactly max_region_pixels (100x100)" 200 \
    "/v1/images/x/region?level=0&x=0&y=0&w=100&h=100&format=png"
expect_status "region one row over (100x101)" 413 \
    "/v1/images/x/region?level=0&x=0&y=0&w=100&h=101&format=png"
check "413 names max_region_pixels" \
    message_is "region: 10100 pixels, at most 10000 (max_region_pixels)"

# ---------------------------------------------------------- IIIF output limits
expect_status "info.json" 200 /iiif/3/x/info.json
check "info.json advertises maxArea, maxWidth, maxHeight from the keys" \
    test "$(json_get '(j["maxArea"], j["maxWidth"], j["maxHeight"])')" = "(20000, 150, 150)"
expect_status "IIIF output within max_output_pixels (141x141)" 200 \
    "/iiif/3/x/0,0,1000,1000/141,141/0/default.png"
expect_status "IIIF output over max_output_pixels (142x142)" 400 \
    "/iiif/3/x/0,0,1000,1000/142,142/0/default.png"
check "400 names the limits as info.json does" \
    message_is 'iiif: size "142,142": 142x142 is past the limits (maxWidth 150, maxHeight 150, maxArea 20000)'
expect_status "IIIF output of exactly max_output_side (150x100)" 200 \
    "/iiif/3/x/0,0,1500,1000/150,100/0/default.png"
expect_status "IIIF output over max_output_side (151x100)" 400 \
    "/iiif/3/x/0,0,1510,1000/151,100/0/default.png"
check "400 names the side limits" \
    message_is 'iiif: size "151,100": 151x100 is past the limits (maxWidth 150, maxHeight 150, maxArea 20000)'
expect_status "IIIF full/max shrinks to fit the limits" 200 "/iiif/3/x/full/max/0/default.png"
# 3000x2000 into 150 wide (the side limit binds before the area: 150x100
# is 15000 pixels).
check "full/max is 150x100 (the PNG header)" test "$(python3 -c "
import struct, sys
b = open(sys.argv[1], 'rb').read()
print('%dx%d' % struct.unpack('>II', b[16:24]))" "$T/b")" = 150x100
expect_status "IIIF ^ upscaling of exactly max_upscale (2x)" 200 \
    "/iiif/3/x/0,0,50,50/%5E100,/0/default.png"
expect_status "IIIF ^ upscaling over max_upscale" 400 \
    "/iiif/3/x/0,0,50,50/%5E101,/0/default.png"
check "400 names the upscale factor" \
    message_is 'iiif: size "^101,": 101x101 enlarges the region (50x50) more than the allowed 2x'

# ---------------------------------------------------------- batch_max_tiles
expect_status "batch of exactly batch_max_tiles (3)" 200 /v1/images/x/batch -X POST \
    --data '{"tiles":[[0,0,0],[0,1,0],[0,2,0]]}'
expect_status "batch of 4" 413 /v1/images/x/batch -X POST \
    --data '{"tiles":[[0,0,0],[0,1,0],[0,2,0],[0,3,0]]}'
check "413 names the limit" message_is "batch: 4 tiles, at most 3"
expect_status "GET batch of 3" 200 "/v1/images/x/batch?t=0,0,0;0,1,0;0,2,0"
expect_status "GET batch of 4" 413 "/v1/images/x/batch?t=0,0,0;0,1,0;0,2,0;0,3,0"
check "GET: 413 names the limit" message_is "batch: 4 tiles, at most 3"

# ---------------------------------------------------------- the keys' own range
# Each out-of-range value with the exact line gigaviewd -t prints.
while IFS='|' read -r bad want; do
    printf 'store_dir = "%s"\n%s\n' "$S" "$bad" >bad.conf
    rc=0
    "$GIGAVIEWD" -t -c bad.conf >/dev/null 2>"$T/err" || rc=$?
    if [ "$rc" -eq 1 ] && [ "$(cat "$T/err")" = "gigaviewd: bad.conf:2: $want" ]; then
        ok "-t refuses '$bad' with file:line"
    else
        not_ok "-t refuses '$bad' (exit $rc)" "$(cat "$T/err")" "wanted: gigaviewd: bad.conf:2: $want"
    fi
done <<'EOF2'
max_request_bytes = 1023|max_request_bytes: 1023 is outside 1024..67108864
max_request_bytes = 65M|max_request_bytes: 65M is outside 1024..67108864
max_region_pixels = 0|max_region_pixels: 0 is outside 1..1000000000000000
max_output_side = 0|max_output_side: 0 is outside 1..2147483647
batch_max_tiles = 0|batch_max_tiles: 0 is outside 1..65536
terrain_water_below = "world"|terrain_water_below: 'world' is not a list of ID:HEIGHT (an image id or *, a number)
terrain_water_below = "../x:0"|terrain_water_below: '../x:0' is not a list of ID:HEIGHT (an image id or *, a number)
terrain_water_below = "world:1e999"|terrain_water_below: 'world:1e999' is not a list of ID:HEIGHT (an image id or *, a number)
terrain_water_below = "world:0 :3"|terrain_water_below: 'world:0 :3' is not a list of ID:HEIGHT (an image id or *, a number)
terrain_water_below = "world:0x"|terrain_water_below: 'world:0x' is not a list of ID:HEIGHT (an image id or *, a number)
EOF2

expect_status "the daemon is healthy after it all" 200 /healthz
stop_daemon
check "SIGTERM: exit 0" test "$drc" -eq 0
done_testing
