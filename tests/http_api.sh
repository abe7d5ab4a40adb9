#!/bin/sh
# http_api.sh - gigaviewd end to end: start it on port 0 over a scratch
# store directory and drive every route with curl.
#
# Covers: the image list and metadata, tiles (bytes, strong ETag, immutable
# Cache-Control, 304, HEAD, CORS), batches (POST JSON and GET, framing
# parsed), the root (PNG, raw, and the lossless WebP, which decodes to
# exactly the raw samples; ETags, 304), /healthz, /metrics, /, every
# error case (400, 404, 405, 413, 501, traversal ids), a corrupt page (500
# for exactly that page's tiles while the rest serves), SIGHUP pick-up and
# drop, SIGTERM drain of a request in flight (exit 0), `gigaviewd -t`, and
# the start-up GPU context: opened (gpu = auto), on the platform
# gpu_platform forces, disabled (gpu = off), failing because EGL finds no
# driver at all (the daemon serves anyway), and not built (configure
# --without-gpu: the daemon serves tiles, regions and IIIF all the same).
# Regions in every format and IIIF, pixel-compared with `gigaview export`,
# are tests/http_iiif.sh's.
# Needs curl, python3, oiiotool and idiff (openimageio-tools).
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
need_tool oiiotool idiff

S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
# The source tree, absolute: $0 may be relative (make distcheck).
srcroot=$(cd "$(dirname "$0")/.." && pwd)
cd "$T/w" || bail "cd"

# Stores: x (3000x2000: levels 0-2 tiled, root 375x250 at level 3) and m
# (4700x600: level 0 has 10x2 tiles in two pages, for the corrupt-page
# case).  Encoded once, reused by every check.
run encode synth:3000x2000 -o "$S/x.gv"
[ "$rc" -eq 0 ] || bail "encode x: $(cat "$T/err")"
run encode -q 30 synth:4700x600 -o "$T/m.gv"
[ "$rc" -eq 0 ] || bail "encode m: $(cat "$T/err")"

cat >"$T/good.conf" <<EOF2
# test configuration
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 4
cache_bytes = 8M   # small, but holds every page of x
max_region_pixels = 4M
batch_max_tiles = 8
# The SIGTERM drain below holds a request half sent while the test
# checks the drain: no idle, request or drain timeout may end it first,
# however slow the machine.
connection_timeout = $GV_TEST_PATIENCE
request_timeout = 0
drain_timeout = $GV_TEST_PATIENCE
access_log = stderr
log_level = info
EOF2

# ---------------------------------------------------------------- -t
check "-t accepts a good configuration" "$GIGAVIEWD" -t -c "$T/good.conf"
printf 'port = 0\nstore_dir = "%s"\nbogus_key = 1\n' "$S" >"$T/bad1.conf"
rc=0
"$GIGAVIEWD" -t -c "$T/bad1.conf" >/dev/null 2>"$T/err" || rc=$?
expect_rc "-t rejects an unknown key" 1
expect_err_is "-t names file:line of the unknown key" \
    "gigaviewd: $T/bad1.conf:3: unknown key 'bogus_key'"
printf 'threads = 4\nport = 70000\n' >"$T/bad2.conf"
rc=0
"$GIGAVIEWD" -t -c "$T/bad2.conf" >/dev/null 2>"$T/err" || rc=$?
expect_rc "-t rejects a port out of range" 1
expect_err_is "-t names file:line of the bad value" \
    "gigaviewd: $T/bad2.conf:2: port: 70000 is outside 0..65535"
# Each bad line with the exact message -t prints.
while IFS='|' read -r bad want; do
    printf '%s\n' "$bad" >"$T/bad3.conf"
    rc=0
    "$GIGAVIEWD" -t -c "$T/bad3.conf" >/dev/null 2>"$T/err" || rc=$?
    if [ "$rc" -eq 1 ] && [ "$(cat "$T/err")" = "gigaviewd: $T/bad3.conf:1: $want" ]; then
        ok "-t rejects '$bad' with file:line"
    else
        not_ok "-t rejects '$bad' (exit $rc)" "$(cat "$T/err")" "wanted: gigaviewd: $T/bad3.conf:1: $want"
    fi
done <<'EOF2'
threads = -1|threads: '-1' is not a non-negative integer
cache_bytes = 12Q|cache_bytes: '12Q' is not a size (digits with optional K, M, G, T)
max_upscale = nan|max_upscale: 'nan' is not a number
threads = 99999999999999999999999|threads: '99999999999999999999999' is not a non-negative integer
log_level = loud|log_level: 'loud' is not error, warn, info or debug
no equals sign|expected 'key = value'
EOF2
rc=0
"$GIGAVIEWD" -t -c "$T/nonexistent.conf" >/dev/null 2>&1 || rc=$?
expect_rc "-t on a missing file" 1

# ---------------------------------------------------------------- systemd unit
# systemd-analyze verify, with ExecStart pointing at the binary under
# test; any complaint (unknown key, bad value) counts as a failure.
unit=$srcroot/conf/gigaviewd.service
if ! command -v systemd-analyze >/dev/null 2>&1; then
    skip "systemd-analyze verify conf/gigaviewd.service" "no systemd-analyze"
elif [ ! -f "$unit" ]; then
    not_ok "conf/gigaviewd.service exists"
else
    mkdir "$T/unit"
    sed "s|/usr/local/bin/gigaviewd|$GIGAVIEWD|g" "$unit" >"$T/unit/gigaviewd.service"
    # The service requires its socket unit: verify the pair.
    cp "$srcroot/conf/gigaviewd.socket" "$T/unit/"
    rc=0
    systemd-analyze verify "$T/unit/gigaviewd.socket" "$T/unit/gigaviewd.service" \
        >"$T/unit.out" 2>&1 || rc=$?
    if [ "$rc" -eq 0 ] && [ ! -s "$T/unit.out" ]; then
        ok "systemd-analyze verify conf/gigaviewd.service (and its socket unit)"
    elif grep -qi "system has not been booted\|failed to connect to bus\|Failed to initialize manager" "$T/unit.out"; then
        skip "systemd-analyze verify conf/gigaviewd.service" "systemd cannot run here"
    else
        not_ok "systemd-analyze verify conf/gigaviewd.service (exit $rc)" "$(cat "$T/unit.out")"
    fi
fi

printf 'gpu = maybe\n' >"$T/bad4.conf"
rc=0
"$GIGAVIEWD" -t -c "$T/bad4.conf" >/dev/null 2>"$T/err" || rc=$?
expect_rc "-t rejects gpu = maybe" 1
expect_err_is "-t says what gpu accepts" "gigaviewd: $T/bad4.conf:1: gpu: 'maybe' is not auto or off"
printf '# platforms\ngpu_platform = wayland\n' >"$T/bad5.conf"
rc=0
"$GIGAVIEWD" -t -c "$T/bad5.conf" >/dev/null 2>"$T/err" || rc=$?
expect_rc "-t rejects gpu_platform = wayland" 1
expect_err_is "-t says what gpu_platform accepts" "gigaviewd: $T/bad5.conf:2: gpu_platform: 'wayland' is not auto, device, surfaceless or default"

start_daemon "$T/good.conf"
diag "gigaviewd on port $PORT"
# The log up to "listening on": what start-up said about the GPU (good.conf
# leaves gpu at its default, auto).
cp "$T/daemon.log" "$T/start.log"
diag "$(grep ' gpu: ' "$T/start.log")"
no_egl=
grep -q ' error gpu: no usable EGL context' "$T/start.log" &&
    no_egl=$(sed -n 's/.* error gpu: //p' "$T/start.log" | head -n 1)
not_built=
grep -q ' info gpu: not built ' "$T/start.log" && not_built=yes

# ---------------------------------------------------------------- list, metadata
expect_status "GET /v1/images" 200 /v1/images
check "list names x with its size" test "$(json_get '[(i["id"],i["width"],i["height"],i["levels"]) for i in j["images"]]')" = "[('x', 3000, 2000, 6)]"
check "CORS header on /v1" test "$(header Access-Control-Allow-Origin)" = "*"
expect_status "GET /v1/images/x" 200 /v1/images/x
check "metadata: geometry" test "$(json_get '(j["width"],j["height"],j["channels"],j["tile_size"],j["tile_overlap"],j["tile_step"],j["format_version"],j["root"]["level"],j["root"]["width"],j["root"]["height"],j["root"]["side"])')" = "(3000, 2000, 3, 513, 1, 512, 6, 5, 94, 63, 128)"
check "metadata: tile grid per level" test "$(json_get '[(l["level"],l["width"],l["height"],l["tiles_x"],l["tiles_y"]) for l in j["levels"]]')" = "[(0, 3000, 2000, 6, 4), (1, 1500, 1000, 3, 2), (2, 750, 500, 2, 1), (3, 375, 250, 1, 1), (4, 188, 125, 1, 1)]"
check "metadata: IIIF link" test "$(json_get 'j["links"]["iiif"]')" = "http://127.0.0.1:$PORT/iiif/3/x/info.json"
# bytes is the store file's size and bpp is 8 bytes / pixels, as gigaviewd
# computes it and prints it (8 significant digits: JSON_REAL_PRECISION(8));
# per level, the bytes are those `gigaview info --json` reports and bpp is
# computed the same way.  gigaview info prints bpp to 6 decimals.
cp "$T/b" meta.json
run info "$S/x.gv" --json
cp "$T/out" info.json
if got=$(python3 - meta.json info.json "$(wc -c <"$S/x.gv")" <<'PY'
import json, sys
j, info, size = json.load(open(sys.argv[1])), json.load(open(sys.argv[2])), int(sys.argv[3])
bad = []
def bpp(nbytes, w, h):
    return float("%.8g" % (nbytes * 8 / (w * h)))
if j["bytes"] != size or info["bytes"] != size:
    bad.append("bytes %d, info %d, file %d" % (j["bytes"], info["bytes"], size))
want = size * 8 / (j["width"] * j["height"])
if j["bpp"] != bpp(size, j["width"], j["height"]) or info["bpp"] != float("%.6f" % want):
    bad.append("bpp %r, info %r, 8 * %d / (%d x %d)" % (j["bpp"], info["bpp"], size, j["width"], j["height"]))
for l, il in zip(j["levels"], info["level"]):
    if l["bytes"] != il["bytes"] or l["bpp"] != bpp(l["bytes"], l["width"], l["height"]):
        bad.append("level %d: bytes %d (info %d), bpp %r" % (l["level"], l["bytes"], il["bytes"], l["bpp"]))
if len(j["levels"]) != 5:
    bad.append("%d tiled levels" % len(j["levels"]))
print("; ".join(bad) if bad else "bpp %.6f from %d bytes" % (j["bpp"], size))
sys.exit(1 if bad else 0)
PY
); then
    ok "metadata: bytes and bpp of the store and of each level ($got)"
else
    not_ok "metadata: bytes and bpp of the store and of each level" "$got"
fi
expect_status "HEAD /v1/images/x" 200 /v1/images/x -I
check "HEAD has no body" cmp -s "$T/b" "$T/h"

# ---------------------------------------------------------------- tiles
expect_status "tile 0/0/0" 200 /v1/images/x/tiles/0/0/0
cp "$T/b" t000
etag=$(header ETag)
check "tile: Content-Type octet-stream" test "$(header Content-Type)" = "application/octet-stream"
check "tile: strong ETag" sh -c "echo '$etag' | grep -Eq '^\"[0-9a-f]+-0-0-0\"\$'"
check "tile: immutable Cache-Control" test "$(header Cache-Control)" = "public, max-age=31536000, immutable"
check "tile: CORS" test "$(header Access-Control-Allow-Origin)" = "*"
check "tile: length is a whole number of 32-bit words" test $(( $(wc -c <t000) % 4 )) -eq 0
expect_status "tile 304 on If-None-Match" 304 /v1/images/x/tiles/0/0/0 -H "If-None-Match: $etag"
check "304 has the ETag" test "$(header ETag)" = "$etag"
expect_status "tile 200 on another ETag" 200 /v1/images/x/tiles/0/0/0 -H 'If-None-Match: "nope"'
expect_status "tile HEAD" 200 /v1/images/x/tiles/0/5/3 -I
check "tile HEAD: no body" cmp -s "$T/b" "$T/h"
head_len=$(header Content-Length)
expect_status "tile 2/1/0" 200 /v1/images/x/tiles/2/1/0
other=$(header ETag)
check "ETags differ between tiles" test "$other" != "$etag"

# ---------------------------------------------------------------- batch
expect_status "batch POST" 200 /v1/images/x/batch -X POST \
    -H 'Content-Type: application/json' \
    --data '{"tiles":[[0,0,0],[0,5,3],[2,1,0],[0,99,0],[7,0,0]]}'
cp "$T/b" batch.bin
check "batch: Content-Type" test "$(header Content-Type)" = "application/x-gigaview-batch"
curl -s -o t053 "$(url /v1/images/x/tiles/0/5/3)"
check "tile HEAD: Content-Length is the tile's size" test "$head_len" = "$(wc -c <t053 | tr -d ' ')"
curl -s -o t210 "$(url /v1/images/x/tiles/2/1/0)"
cat >parse_batch.py <<'PY'
import struct, sys
b = open(sys.argv[1], 'rb').read()
assert b[:4] in (b'GVB1', b'GVB2'), 'magic'
n, = struct.unpack_from('<I', b, 4)
off, out = 8, []
for i in range(n):
    level, elen = struct.unpack_from('<BB', b, off)
    assert b[off+2:off+4] == b'\0\0' and (elen == 0 or b[:4] == b'GVB2'), 'pad'
    tx, ty, status, length = struct.unpack_from('<IIII', b, off + 4)
    off += 20
    etag = b[off:off+elen].decode()
    assert b[off+elen:off+(elen + 3) // 4 * 4].strip(b'\0') == b'', 'etag pad'
    off += (elen + 3) // 4 * 4
    data = b[off:off+length]
    off += (length + 3) // 4 * 4
    out.append((level, tx, ty, status, data, etag))
assert off == len(b), 'trailing bytes %d != %d' % (off, len(b))
for level, tx, ty, status, data, etag in out:
    print(level, tx, ty, status, len(data), *([etag] if b[:4] == b'GVB2' else []))
    if len(sys.argv) > 2 and status == 200:
        open('b_%d_%d_%d' % (level, tx, ty), 'wb').write(data)
PY
got=$(python3 parse_batch.py batch.bin save 2>&1)
want="0 0 0 200 $(wc -c <t000 | tr -d ' ')
0 5 3 200 $(wc -c <t053 | tr -d ' ')
2 1 0 200 $(wc -c <t210 | tr -d ' ')
0 99 0 404 0
7 0 0 404 0"
if [ "$got" = "$want" ]; then ok "batch framing: statuses and lengths"; else
    not_ok "batch framing" "got:" "$got" "wanted:" "$want"; fi
check "batch tile bytes equal single tiles" sh -c 'cmp -s b_0_0_0 t000 && cmp -s b_0_5_3 t053 && cmp -s b_2_1_0 t210'
expect_status "batch GET" 200 "/v1/images/x/batch?t=0,5,3;2,1,0"
check "batch GET: immutable" test "$(header Cache-Control)" = "public, max-age=31536000, immutable"
cp "$T/b" batch2.bin
check "batch GET framing" test "$(python3 parse_batch.py batch2.bin)" = "0 5 3 200 $(wc -c <t053 | tr -d ' ')
2 1 0 200 $(wc -c <t210 | tr -d ' ')"
# ?etag=1: GVB2 frames carry each tile's ETag (the single tile's), and
# a tile whose ETag If-None-Match lists is a 304 frame without bytes.
e053=$(curl -s -D - -o /dev/null "$(url /v1/images/x/tiles/0/5/3)" | sed -n 's/^ETag: *//Ip' | tr -d '\r')
e210=$(curl -s -D - -o /dev/null "$(url /v1/images/x/tiles/2/1/0)" | sed -n 's/^ETag: *//Ip' | tr -d '\r')
expect_status "batch with etag=1" 200 "/v1/images/x/batch?t=0,5,3;2,1,0;0,99,0&etag=1"
cp "$T/b" batch3.bin
check "batch etag=1: GVB2 frames with each tile's ETag, none for a 404" \
    test "$(python3 parse_batch.py batch3.bin)" = "0 5 3 200 $(wc -c <t053 | tr -d ' ') $e053
2 1 0 200 $(wc -c <t210 | tr -d ' ') $e210
0 99 0 404 0 "
expect_status "batch etag=1 POST with If-None-Match" 200 "/v1/images/x/batch?etag=1" -X POST \
    -H "If-None-Match: $e053, \"0000000000000000-2-1-0\"" --data '{"tiles":[[0,5,3],[2,1,0]]}'
cp "$T/b" batch4.bin
check "batch etag=1: a listed ETag is a 304 frame without bytes, a stale one a 200" \
    test "$(python3 parse_batch.py batch4.bin)" = "0 5 3 304 0 $e053
2 1 0 200 $(wc -c <t210 | tr -d ' ') $e210"
expect_status "batch GET etag=1 with If-None-Match" 200 "/v1/images/x/batch?t=0,5,3&etag=1" \
    -H "If-None-Match: $e053"
check "batch GET with a 304 frame: not cacheable" test "$(header Cache-Control)" = "no-store"
expect_status "batch without etag=1 ignores If-None-Match (GVB1)" 200 "/v1/images/x/batch?t=0,5,3" \
    -H "If-None-Match: $e053"
cp "$T/b" batch5.bin
check "batch without etag=1: GVB1 with the tile" test "$(head -c 4 batch5.bin)$(python3 parse_batch.py batch5.bin)" = \
    "GVB10 5 3 200 $(wc -c <t053 | tr -d ' ')"
expect_status "batch: etag=2" 400 "/v1/images/x/batch?t=0,5,3&etag=2"
expect_status "batch: bad JSON" 400 /v1/images/x/batch -X POST --data '{"tiles":[[0,0,0]'
check "batch: bad JSON message has line and column" test "$(json_get 'j["error"]["message"]')" = "batch: bad JSON at line 1, column 17: ']' expected near end of file"
expect_status "batch: not triples" 400 /v1/images/x/batch -X POST --data '{"tiles":[[0,0]]}'
expect_status "batch: negative index" 400 /v1/images/x/batch -X POST --data '{"tiles":[[0,-1,0]]}'
expect_status "batch: empty" 400 /v1/images/x/batch -X POST --data '{"tiles":[]}'
expect_status "batch: over batch_max_tiles" 413 /v1/images/x/batch -X POST \
    --data '{"tiles":[[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0]]}'
head -c 1100000 /dev/zero | tr '\0' ' ' >big.json
expect_status "batch: body over 1 MiB" 413 /v1/images/x/batch -X POST \
    -H 'Content-Type: application/json' --data-binary @big.json
expect_status "batch: chunked body over 1 MiB" 413 /v1/images/x/batch -X POST \
    -H 'Transfer-Encoding: chunked' --data-binary @big.json
expect_status "batch GET: malformed t" 400 "/v1/images/x/batch?t=0,0"
expect_status "batch GET: missing t" 400 "/v1/images/x/batch"
expect_status "batch: unknown image" 404 /v1/images/nope/batch -X POST --data '{"tiles":[[0,0,0]]}'

# ---------------------------------------------------------------- root
run export "$S/x.gv" --level 5 -o e_root.png
expect_status "root PNG" 200 /v1/images/x/root
cp "$T/b" root.png
check "root: image/png" test "$(header Content-Type)" = "image/png"
check "root PNG equals export --level 5" idiff -q e_root.png root.png
expect_status "root raw" 200 "/v1/images/x/root?format=raw"
check "root raw: headers" test "$(header X-Width)x$(header X-Height)x$(header X-Channels)" = "94x63x3"
check "root raw: w*h*c bytes" test "$(wc -c <"$T/b")" -eq $((94 * 63 * 3))
expect_status "root mip 1" 200 "/v1/images/x/root?mip=1&format=raw"
check "root mip 1 is 47x32" test "$(header X-Width)x$(header X-Height)" = "47x32"
expect_status "root: mip out of range" 404 "/v1/images/x/root?mip=10"
expect_status "root: bad format" 400 "/v1/images/x/root?format=gif"
# The root level as the store keeps it: a lossless WebP that decodes to
# exactly the raw samples, with a validator of its own.
expect_status "root raw (mip 0)" 200 "/v1/images/x/root?format=raw&mip=0"
cp "$T/b" root.raw
raw_etag=$(header ETag)
expect_status "root PNG, for its ETag" 200 /v1/images/x/root
png_etag=$(header ETag)
expect_status "root WebP" 200 "/v1/images/x/root?format=webp"
cp "$T/b" root.webp
webp_etag=$(header ETag)
check "root WebP: image/webp, cacheable, headers" test "$(header Content-Type) $(header Cache-Control) $(header X-Width)x$(header X-Height)x$(header X-Channels)" = "image/webp public, max-age=3600 94x63x3"
check "root WebP: smaller than the raw samples" test "$(wc -c <root.webp)" -lt "$(wc -c <root.raw)"
check "root WebP decodes to exactly the raw root" webp_is_raw root.webp root.raw 3
check "root WebP: an ETag of its own ($webp_etag)" sh -c "[ -n '$webp_etag' ] &&
    [ '$webp_etag' != '$raw_etag' ] && [ '$webp_etag' != '$png_etag' ]"
req -H "If-None-Match: $webp_etag" "$(url "/v1/images/x/root?format=webp")"
check "root WebP: If-None-Match gets 304" test "$code $(header ETag)" = "304 $webp_etag"
req -H "If-None-Match: $raw_etag" "$(url "/v1/images/x/root?format=webp")"
check "root WebP: the raw root's ETag does not match" test "$code" = 200
expect_status "root WebP with mip=0" 200 "/v1/images/x/root?format=webp&mip=0"
expect_status "root WebP of a mip is 400" 400 "/v1/images/x/root?format=webp&mip=1"
check "... saying it is the root level only" grep -q 'root level only' "$T/b"

# (Regions in other formats and IIIF, pixel-compared with the export:
# tests/http_iiif.sh, a test of its own so that the two halves run in
# parallel.)

# ---------------------------------------------------------------- health, metrics, home
expect_status "healthz" 200 /healthz
check "healthz: ok, 1 store" test "$(json_get '(j["status"],j["stores"])')" = "('ok', 1)"
gpu_vendor=$(json_get 'j["gpu"].get("vendor", "")')
if [ -n "$not_built" ]; then
    # configure --without-gpu: EGL is never touched.
    for d in "healthz: gpu available with a renderer" \
        "log: the info gpu line names platform, api, vendor, renderer, version"; do
        skip "$d" "built without the GPU"
    done
    check "healthz: gpu not built, saying so" test "$(json_get '(j["gpu"]["available"], j["gpu"]["built"], "configured --without-gpu" in j["gpu"]["reason"])')" = "(False, False, True)"
    check "log: no error line at start-up" sh -c "! grep -q '^[^ ]* [0-9]* error ' '$T/start.log'"
elif [ -n "$no_egl" ]; then
    # A machine with no EGL driver at all: the checks below then only
    # hold where Mesa (llvmpipe) or a GPU driver is installed.
    for d in "healthz: gpu available with a renderer" \
        "log: the info gpu line names platform, api, vendor, renderer, version" \
        "log: no error line at start-up"; do
        skip "$d" "no EGL context here: $no_egl"
    done
    check "healthz: gpu unavailable with the logged reason" test "$(json_get '(j["gpu"]["available"],"no usable EGL context" in j["gpu"]["reason"])')" = "(False, True)"
else
    check "healthz: gpu available with a renderer" python3 -c "
import json, sys
g = json.load(open(sys.argv[1]))['gpu']
assert g['available'] is True, g
assert g['platform'] in ('device', 'surfaceless', 'default'), g
assert g['api'].startswith('OpenGL'), g
assert all(g[k] for k in ('vendor', 'renderer', 'version')), g
assert 'reason' not in g, g" "$T/b"
    r=$(json_get 'j["gpu"]["renderer"]')
    check "log: the info gpu line names platform, api, vendor, renderer, version" \
        grep -Fq " info gpu: EGL $(json_get 'j["gpu"]["platform"]') platform, $(json_get 'j["gpu"]["api"]'): $(json_get 'j["gpu"]["vendor"]') / $r / $(json_get 'j["gpu"]["version"]')" "$T/start.log"
    check "log: no error line at start-up" sh -c "! grep -q '^[^ ]* [0-9]* error ' '$T/start.log'"
fi
expect_status "home page" 200 /
check "home: HTML listing x" sh -c "grep -q 'text/html' '$T/h' && grep -q '/iiif/3/x/info.json' '$T/b' && grep -qi 'viewer' '$T/b'"

# ---------------------------------------------------------------- errors
expect_status "tile: level not a number" 400 /v1/images/x/tiles/a/0/0
expect_status "tile: negative" 400 /v1/images/x/tiles/0/-1/0
expect_status "tile: overflowing" 400 /v1/images/x/tiles/0/99999999999999999999/0
expect_status "tile: plus sign" 400 /v1/images/x/tiles/0/+1/0
expect_status "tile: outside the grid" 404 /v1/images/x/tiles/0/6/0
expect_status "tile: root level has no tiles" 404 /v1/images/x/tiles/5/0/0
expect_status "tile: level past the pyramid" 404 /v1/images/x/tiles/39/0/0
expect_status "tile: unknown image" 404 /v1/images/nope/tiles/0/0/0
expect_status "unknown image" 404 /v1/images/nope
expect_status "unknown route" 404 /v2/images
expect_status "trailing slash" 404 /v1/images/x/
expect_status "traversal in id (encoded)" 404 '/v1/images/..%2F..%2Fetc%2Fpasswd'
expect_status "traversal in id (raw)" 404 '/v1/images/../../etc/passwd'
expect_status "traversal in IIIF id" 404 '/iiif/3/..%2F..%2Fetc%2Fpasswd/info.json'
expect_status "dot id" 404 '/v1/images/..'
expect_status "NUL in id" 404 '/v1/images/x%00.gv/root'
expect_status "method: DELETE image" 405 /v1/images/x -X DELETE
check "405 has Allow" test "$(header Allow)" = "GET, HEAD"
expect_status "method: POST tile" 405 /v1/images/x/tiles/0/0/0 -X POST --data x
expect_status "method: PUT batch" 405 /v1/images/x/batch -X PUT --data x
check "405 Allow lists GET and POST" test "$(header Allow)" = "GET, HEAD, POST"
expect_status "CORS preflight" 204 /v1/images/x/batch -X OPTIONS
expect_status "region: zero width" 400 "/v1/images/x/region?level=0&x=0&y=0&w=0&h=10"
expect_status "region: negative" 400 "/v1/images/x/region?level=0&x=-1&y=0&w=10&h=10"
expect_status "region: overflow" 400 "/v1/images/x/region?level=0&x=4294967296&y=0&w=10&h=10"
expect_status "region: missing h" 400 "/v1/images/x/region?level=0&x=0&y=0&w=10"
expect_status "region: outside the level" 400 "/v1/images/x/region?level=1&x=1400&y=0&w=200&h=10"
expect_status "region: no such level" 400 "/v1/images/x/region?level=13&x=0&y=0&w=1&h=1"
expect_status "region: bad format" 400 "/v1/images/x/region?level=0&x=0&y=0&w=10&h=10&format=bmp"
expect_status "region: over max_region_pixels" 413 "/v1/images/x/region?level=0&x=0&y=0&w=3000&h=2000"
expect_status "region: huge" 413 "/v1/images/x/region?level=0&x=0&y=0&w=2000000000&h=2000000000"
expect_status "daemon still healthy" 200 /healthz

# ---------------------------------------------------------------- SIGHUP, corrupt page
# m.gv with one byte flipped in the middle of its last page (level 0,
# page (1,0): tiles 8..9 x 0..1), and a clean copy as m2.
cp "$T/m.gv" "$S/m2.gv"
python3 - "$T/m.gv" "$S/bad.gv" <<'PY'
import struct, sys
b = bytearray(open(sys.argv[1], 'rb').read())
index, pages = struct.unpack_from('<QQ', b, 56)
off, size, crc = struct.unpack_from('<QII', b, index + 16 * (pages - 1))
b[off + size // 2] ^= 0x55
open(sys.argv[2], 'wb').write(b)
PY
# stores_are N: /healthz counts N stores.
# shellcheck disable=SC2317 # run by wait_until
stores_are() {
    req "$(url /healthz)"
    [ "$(json_get 'j["stores"]')" = "$1" ]
}
kill -HUP "$DPID"
wait_until stores_are 3
check "SIGHUP picks up two added stores" test "$(json_get 'j["stores"]')" = 3
bad500=
for ty in 0 1; do
    for tx in 0 1 2 3 4 5 6 7 8 9; do
        req "$(url "/v1/images/bad/tiles/0/$tx/$ty")"
        [ "$code" = 200 ] || bad500="$bad500 $tx,$ty:$code"
    done
done
check "corrupt page: exactly its 4 tiles fail with 500" test "$bad500" = " 8,0:500 9,0:500 8,1:500 9,1:500"
expect_status "corrupt page: tile again, still 500" 500 /v1/images/bad/tiles/0/9/1
check "corrupt page: error code names the corruption" test "$(json_get 'j["error"]["code"]')" = corrupt
expect_status "corrupt page: other levels serve" 200 /v1/images/bad/tiles/1/4/0
req "$(url "/v1/images/bad/batch?t=0,7,0;0,8,0")"
check "corrupt page in a batch: 200 then 500" test "$(python3 parse_batch.py "$T/b" | cut -d' ' -f4 | tr '\n' ' ')" = "200 500 "
expect_status "clean copy serves the same tile" 200 /v1/images/m2/tiles/0/9/1
# The counts are checked exactly, against the access log.  A request is
# counted when it completes, just after its access line is written: wait
# until one /metrics answer shows no other request in flight, so that the
# next one counts every request made before it.
# in_flight PATTERN: a fresh /metrics shows requests in flight (itself
# included) matching PATTERN.
# shellcheck disable=SC2317 # run by wait_until
in_flight() {
    req "$(url /metrics)"
    grep -Eq "^gigaview_http_requests_in_flight $1\$" "$T/b"
}
wait_until in_flight 1
expect_status "metrics" 200 /metrics
check "metrics: text format 0.0.4" test "$(header Content-Type)" = "text/plain; version=0.0.4; charset=utf-8"
cp "$T/b" metrics.txt
# metric NAME: the value of the sample NAME (with its labels) in metrics.txt.
metric() {
    awk -v n="$1" '$1 == n { print $2 }' metrics.txt
}
# The tile requests (GET and HEAD: a POST is refused before routing) by
# status, from the access log and from the metrics.
tile_log=$(sed -n 's#.* info access: [^ ]* "\(GET\|HEAD\) /v1/images/[^/" ]*/tiles/[^" ]*" \([0-9]*\) .*#\2#p' \
    "$T/daemon.log" | sort | uniq -c | awk '{ printf "%s:%s ", $2, $1 }')
tile_metrics=$(sed -n 's|^gigaview_http_requests_total{route="tile",status="\([0-9a-z]*\)"} \([0-9]*\)$|\1:\2|p' \
    metrics.txt | sort | tr '\n' ' ')
check "metrics: tile requests by status equal the access log ($tile_metrics)" \
    test "$tile_metrics" = "$tile_log"
tiles_total=$(echo "$tile_log" | tr ' ' '\n' | awk -F: '{ n += $2 } END { print n }')
check "metrics: latency histogram counts every tile request ($tiles_total)" test \
    "$(metric 'gigaview_http_request_duration_seconds_bucket{route="tile",le="+Inf"}') $(metric 'gigaview_http_request_duration_seconds_count{route="tile"}')" = "$tiles_total $tiles_total"
# The damaged page was read (and failed its CRC) once for each of the 6
# answers it spoiled: 5 tile requests and 1 batch entry.  Failed pages are
# not cached, so every page read is a page cached now, evicted, or failed.
check "metrics: page errors and the answers they spoiled" test \
    "$(metric gigaview_page_errors_total) $(metric gigaview_page_error_responses_total)" = "6 6"
check "metrics: page cache misses = pages cached + evicted + failed" test \
    "$(metric gigaview_page_cache_misses_total)" -eq \
    "$(($(metric gigaview_page_cache_pages) + $(metric gigaview_page_cache_evictions_total) + $(metric gigaview_page_errors_total)))"
# Hits and bytes depend on whether regions and IIIF images were drawn on
# the GPU or the CPU here; they are bounded, not pinned.
check "metrics: page cache hits" test "$(metric gigaview_page_cache_hits_total)" -gt 0
check "metrics: page cache bytes within the limit" test \
    "$(metric gigaview_page_cache_bytes)" -gt 0 -a \
    "$(metric gigaview_page_cache_bytes)" -le "$(metric gigaview_page_cache_limit_bytes)"
# The connection of the request before may not be closed yet: at least 1.
check "metrics: this request's connection is open and in flight" test \
    "$(metric gigaview_open_connections)" -ge 1 -a "$(metric gigaview_http_requests_in_flight)" -ge 1
check "metrics: stores" test "$(metric gigaview_stores)" = 3

# A replaced store gets new ETags; a removed one disappears; requests
# never see a half-replaced store.
req "$(url /v1/images/m2/tiles/0/0/0)"
e1=$(header ETag)
cp "$S/x.gv" "$S/.m2.tmp.gv"
mv "$S/.m2.tmp.gv" "$S/m2.gv"
rm "$S/bad.gv"
kill -HUP "$DPID"
wait_until stores_are 2
expect_status "SIGHUP drops a removed store" 404 /v1/images/bad
req "$(url /v1/images/m2/tiles/0/0/0)"
check "replaced store: the new content" cmp -s "$T/b" t000
check "replaced store: tile served with a new ETag" test "$code" = 200 -a "$(header ETag)" != "$e1"
req "$(url '/v1/images/a%22b%0A%1b%E2%82%AC')"
check "log: client strings escaped in the access line" grep -q 'access: 127.0.0.1 "GET /v1/images/a\\x22b\\x0a\\x1b\\xe2\\x82\\xac" 404' "$T/daemon.log"
check "log: traversal path logged" grep -q 'access: 127.0.0.1 "GET /v1/images/../../etc/passwd" 404' "$T/daemon.log"
check "log: the query string in the access line" grep -q 'access: 127.0.0.1 "GET /v1/images/x/batch?t=0,5,3&etag=1" 200' "$T/daemon.log"
req "$(url '/v1/images/x/batch?t=%22%0a')"
check "log: query arguments escaped too" grep -q 'access: 127.0.0.1 "GET /v1/images/x/batch?t=\\x22\\x0a" 400' "$T/daemon.log"
check "log lines carry time pid level module" grep -Eq '^[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9:]{8}Z [0-9]+ info catalog: ' "$T/daemon.log"

# ---------------------------------------------------------------- SIGTERM drain
# A client sends a batch request's headers and half its body, the daemon
# gets SIGTERM, then the client sends the rest: the request in flight is
# answered (200) and the daemon exits 0.
cat >slow.py <<'PY'
import os, socket, sys, time
body = b'{"tiles":[[0,0,0],[0,1,0]]}'
s = socket.create_connection(('127.0.0.1', int(sys.argv[1])))
s.sendall(b'POST /v1/images/x/batch HTTP/1.1\r\nHost: t\r\nContent-Type: application/json\r\n'
          b'Content-Length: %d\r\nConnection: close\r\n\r\n' % len(body) + body[:10])
open(sys.argv[2], 'w').write('sent\n')
# The rest once the drain waits for it (GV_TEST_PATIENCE s at most).
t_end = time.monotonic() + float(os.environ.get('GV_TEST_PATIENCE', '240'))
while not os.path.exists(sys.argv[3]) and time.monotonic() < t_end:
    time.sleep(0.1)
s.sendall(body[10:])
data = b''
while True:
    chunk = s.recv(65536)
    if not chunk:
        break
    data += chunk
print(data.split(b'\r\n')[0].decode())
PY
python3 slow.py "$PORT" started go >slow.out 2>&1 &
spid=$!
wait_until test -s started
# In flight once the daemon has its head: /metrics counts it and itself.
wait_until in_flight '[2-9][0-9]*'
kill -TERM "$DPID"
# The drain has stopped accepting once it logs what it waits for.
wait_until grep -q 'waiting for 1 requests in flight' "$T/daemon.log"
# Refused at once (the listening socket is closed); a connection accepted
# or left waiting would fail the check however long it took.
rc=0
curl -s -o /dev/null --max-time "$GV_TEST_PATIENCE" "$(url /healthz)" || rc=$?
check "SIGTERM: new connections refused while draining (curl exit $rc, 7 = refused)" \
    test "$rc" -eq 7
: >go
wait "$spid"
check "SIGTERM: the request in flight is answered" grep -q '^HTTP/1.1 200' slow.out
drc=0
wait "$DPID" || drc=$?
DPID=
check "SIGTERM: exit status 0" test "$drc" -eq 0
check "SIGTERM: drain logged" grep -q 'waiting for 1 requests in flight' "$T/daemon.log"

# ---------------------------------------------------------------- GPU off, no EGL
# gpu_daemon DESC: the daemon (started) answers /healthz with the GPU
# unavailable for reason $reason (a substring), still serves a tile equal
# to the one served before, and drains to exit 0 on SIGTERM.
gpu_daemon() {
    req "$(url /healthz)"
    check "$1: healthz ok" test "$code $(json_get 'j["status"]')" = "200 ok"
    check "$1: healthz gpu unavailable with the reason" test "$(json_get '(j["gpu"]["available"], sorted(j["gpu"]), "'"$reason"'" in j["gpu"]["reason"])')" = "(False, $keys, True)"
    req "$(url /v1/images/x/tiles/0/0/0)"
    check "$1: tiles still serve" sh -c "test '$code' = 200 && cmp -s '$T/b' t000"
    req "$(url '/iiif/3/x/full/375,250/0/default.png')"
    check "$1: IIIF images still serve" test "$code $(header Content-Type)" = "200 image/png"
    stop_daemon
    check "$1: SIGTERM, exit status 0" test "$drc" -eq 0
}
keys="['available', 'reason']"
{ cat "$T/good.conf"; echo 'gpu = off'; } >"$T/off.conf"
if [ -n "$not_built" ]; then
    # Without the GPU built, gpu = off changes nothing: EGL is never
    # touched either way, and /healthz says why.
    keys="['available', 'built', 'reason']"
    start_daemon "$T/off.conf"
    check "not built, gpu = off: logs that the GPU is not built" grep -q ' info gpu: not built (configured --without-gpu)' "$T/daemon.log"
    reason="configured --without-gpu"
    gpu_daemon "not built"
else
    start_daemon "$T/off.conf"
    check "gpu = off: logs that it is disabled" grep -q ' info gpu: disabled by configuration$' "$T/daemon.log"
    check "gpu = off: no error line" sh -c "! grep -q '^[^ ]* [0-9]* error ' '$T/daemon.log'"
    reason="disabled by configuration"
    gpu_daemon "gpu = off"
fi

# gpu_platform = surfaceless: only Mesa's surfaceless platform is tried,
# and it works wherever the automatic choice was Mesa (llvmpipe or a Mesa
# GPU driver).
{ cat "$T/good.conf"; echo 'gpu_platform = surfaceless'; } >"$T/surfaceless.conf"
case $not_built:$gpu_vendor in
:*Mesa*)
    start_daemon "$T/surfaceless.conf"
    req "$(url /healthz)"
    check "gpu_platform = surfaceless: healthz platform" test "$(json_get '(j["gpu"]["available"], j["gpu"]["platform"])')" = "(True, 'surfaceless')"
    check "gpu_platform = surfaceless: the info gpu line says so" grep -q ' info gpu: EGL surfaceless platform, ' "$T/daemon.log"
    stop_daemon ;;
*)
    why="no EGL context from Mesa here (${gpu_vendor:-none})"
    [ -n "$not_built" ] && why="built without the GPU"
    for d in "gpu_platform = surfaceless: healthz platform" \
        "gpu_platform = surfaceless: the info gpu line says so"; do
        skip "$d" "$why"
    done ;;
esac

# No EGL at all.  libglvnd's libEGL loads the vendor libraries named by the
# JSON files in __EGL_VENDOR_LIBRARY_FILENAMES (instead of
# /usr/share/glvnd/egl_vendor.d); one that does not exist leaves it with no
# vendor, so every platform's display query fails, as on a machine with no
# EGL driver installed.  Where libEGL is not libglvnd's, the variable has
# no effect and the checks are skipped.
__EGL_VENDOR_LIBRARY_FILENAMES=$T/nonexistent.json
export __EGL_VENDOR_LIBRARY_FILENAMES
start_daemon "$T/good.conf"
unset __EGL_VENDOR_LIBRARY_FILENAMES
if [ -n "$not_built" ]; then
    skip "no EGL: the daemon starts and serves" "built without the GPU"
    stop_daemon
elif grep -q ' info gpu: EGL ' "$T/daemon.log"; then
    skip "no EGL: the daemon starts and serves" "__EGL_VENDOR_LIBRARY_FILENAMES did not hide EGL here"
    stop_daemon
else
    ok "no EGL: the daemon starts"
    diag "$(grep ' gpu: ' "$T/daemon.log")"
    check "no EGL: exactly one error line, from gpu, listing the attempts" test "$(grep -c '^[^ ]* [0-9]* error ' "$T/daemon.log") $(grep -c '^[^ ]* [0-9]* error gpu: no usable EGL context: .*default: .*; serving without a GPU$' "$T/daemon.log")" = "1 1"
    check "no EGL: no info gpu line" sh -c "! grep -q ' info gpu: ' '$T/daemon.log'"
    reason="no usable EGL context"
    gpu_daemon "no EGL"
fi
# An empty store directory: the daemon starts and serves no images (the
# catalog once handed qsort a NULL array here, which UBSan refused).
mkdir -p "$T/empty"
sed "s|^store_dir = .*|store_dir = \"$T/empty\"|" "$T/good.conf" >"$T/empty.conf"
start_daemon "$T/empty.conf"
req "$BASE/v1/images"
check "empty store directory: 200 and no images" test "$code $(tr -d ' \n' <"$T/b")" = '200 {"images":[]}'
stop_daemon
check "empty store directory: SIGTERM exits 0" test "$drc" -eq 0

if [ "$tap_failed" -ne 0 ]; then
    diag "daemon log (tail):"
    diag "$(tail -n 30 "$T/daemon.log")"
fi
done_testing
