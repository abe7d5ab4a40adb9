#!/bin/sh
# http_terrain.sh - the Cesium terrain service of a height store:
# GET /v1/images/{id}/terrain/layer.json and {z}/{x}/{y}.terrain.
#
# tests/data/etopo5-720x361-u16.png, the whole globe every half degree
# (a global grid: W = 2 (H - 1)), is encoded as a height store.  Checks:
# layer.json has the fields CesiumTerrainProvider reads (tilejson,
# format, scheme tms, tiles, projection, available per level) and the
# maxzoom of docs/MESHES.md; tiles are application/vnd.quantized-mesh,
# gzipped exactly when the client accepts gzip (the same mesh either way),
# with an ETag (304 on If-None-Match) and Cache-Control; a decoder written
# from the quantized-mesh-1.0 specification reads every tile of level 2
# back (header, zig-zag vertices, high-water-mark indices, the four edge
# lists, the metadata extension) and checks: indices in range, the
# bounding sphere on the Earth, the measured error within the level's
# bound; with lon0=0 (this ETOPO5's column 0 is at Greenwich) the Himalaya
# tile is high and a Pacific tile deep (the mapping is north up, TMS y from
# the south), and the default lon0 (-180) gives the same meshes four tiles
# (180 degrees) to the east; each tile's east edge has the same
# vertices (v, and the height within the two tiles' quantisation) as its
# neighbour's west edge, across the antimeridian too, and each north edge
# as the south edge of the tile above; errors are the JSON shape.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" || bail "mkdir"
run encode --height --max-error 2 --unit m --offset -11000 \
    "$TESTDATA/etopo5-720x361-u16.png" -o "$S/world.gv"
[ "$rc" -eq 0 ] || bail "encode height: $(cat "$T/err")"
run encode synth:300x200 -o "$S/img.gv"
[ "$rc" -eq 0 ] || bail "encode image: $(cat "$T/err")"
cat >"$T/t.conf" <<EOF2
store_dir = "$S"
threads = 2
access_log = off
EOF2
start_daemon "$T/t.conf"

# layer.json
req "$(url /v1/images/world/terrain/layer.json)"
check "layer.json: 200" test "$code" = 200
check "layer.json: application/json" test "$(header Content-Type)" = application/json
check "layer.json: fields for CesiumTerrainProvider" python3 - "$T/b" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
assert j["tilejson"] == "2.1.0" and j["format"] == "quantized-mesh-1.0"
assert j["scheme"] == "tms" and j["projection"] == "EPSG:4326"
assert j["tiles"] == ["{z}/{x}/{y}.terrain?v={version}"] and j["version"]
assert j["bounds"] == [-180, -90, 180, 90]
# 720 columns: level 3 is the first whose 64-step grid is at most 1 sample
assert j["minzoom"] == 0 and j["maxzoom"] == 3, j["maxzoom"]
a = j["available"]
assert len(a) == 4
for z, r in enumerate(a):
    assert r == [{"startX": 0, "startY": 0, "endX": 2 ** (z + 1) - 1,
                  "endY": 2 ** z - 1}], r
g = j["gigaview"]
assert g["global"] is True and g["unit"] == "m" and g["storeMaxError"] == 2
e = g["maxError"]
assert abs(e[0] - 0.03125 * 6378137 * 2 * 3.141592653589793 * 0.25 / 130) < 1e-6
assert all(abs(e[z] * 2 ** z - e[0]) < 1e-6 for z in range(4))
PY
etag=$(header ETag)
req -H "If-None-Match: $etag" "$(url /v1/images/world/terrain/layer.json)"
check "layer.json: 304 on its ETag" test "$code" = 304
req "$(url "/v1/images/world/terrain/layer.json?lon0=0")"
check "layer.json?lon0=0: passed on in the tiles template" test \
    "$(json_get 'j["tiles"][0], j["gigaview"]["lon0"]')" = "{z}/{x}/{y}.terrain?v={version}&lon0=0 0.0"
check "layer.json?lon0=0: its own ETag" test "$(header ETag)" != "$etag"

# the decoder, from the quantized-mesh-1.0 specification
cat >"$T/qm.py" <<'PY'
import gzip, json, math, struct, sys

def decode(b):
    if b[:2] == b"\x1f\x8b":
        b = gzip.decompress(b)
    h = struct.unpack_from("<3d2f4d3d", b, 0)
    t = {"center": h[0:3], "min": h[3], "max": h[4], "sphere": h[5:9],
         "occl": h[9:12]}
    p = 88
    n = struct.unpack_from("<I", b, p)[0]
    p += 4
    arr = []
    for _ in range(3):
        d = struct.unpack_from("<%dH" % n, b, p)
        p += 2 * n
        v, out = 0, []
        for x in d:
            v += (x >> 1) ^ -(x & 1)
            out.append(v)
        arr.append(out)
    t["u"], t["v"], t["h"] = arr
    assert all(0 <= x <= 32767 for a in arr for x in a)
    wide = n > 65536
    fmt, sz = ("I", 4) if wide else ("H", 2)
    if wide and p % 4:
        p += 4 - p % 4
    nt = struct.unpack_from("<I", b, p)[0]
    p += 4
    raw = struct.unpack_from("<%d%s" % (3 * nt, fmt), b, p)
    p += 3 * nt * sz
    hi, idx = 0, []
    for c in raw:
        idx.append(hi - c)
        if c == 0:
            hi += 1
    assert all(0 <= i < n for i in idx)
    t["tris"] = idx
    for e in ("west", "south", "east", "north"):
        k = struct.unpack_from("<I", b, p)[0]
        p += 4
        t[e] = list(struct.unpack_from("<%d%s" % (k, fmt), b, p))
        p += k * sz
        assert all(0 <= i < n for i in t[e])
    t["meta"] = None
    while p < len(b):
        eid, ln = struct.unpack_from("<BI", b, p)
        p += 5
        if eid == 0x67:   # the service's metadata (id 4 stops CesiumJS)
            jl = struct.unpack_from("<I", b, p)[0]
            t["meta"] = json.loads(b[p + 4:p + 4 + jl])
        p += ln
    assert p == len(b)
    return t

def height(t, i):
    return t["min"] + t["h"][i] / 32767 * (t["max"] - t["min"])

def load(path):
    return decode(open(path, "rb").read())
PY

# content type, gzip, caching
req -H "Accept-Encoding: gzip" "$(url /v1/images/world/terrain/2/5/2.terrain)"
check "tile: 200" test "$code" = 200
check "tile: application/vnd.quantized-mesh" test "$(header Content-Type)" = application/vnd.quantized-mesh
check "tile: gzip when accepted" test "$(header Content-Encoding)" = gzip
check "tile: Vary: Accept-Encoding" test "$(header Vary)" = Accept-Encoding
check "tile: Cache-Control" test "$(header Cache-Control)" = "public, max-age=86400"
check "tile: gzip magic" test "$(head -c 2 "$T/b" | od -An -tx1 | tr -d ' ')" = 1f8b
cp "$T/b" "$T/gz"
etag=$(header ETag)
req "$(url /v1/images/world/terrain/2/5/2.terrain)"
check "tile: plain without Accept-Encoding" test -z "$(header Content-Encoding)"
check "tile: plain and gzip are the same mesh" sh -c "gzip -dc '$T/gz' | cmp -s - '$T/b'"
check "tile: the encodings have their own ETags" test "$(header ETag)" != "$etag"
req -H "Accept-Encoding: gzip;q=0" "$(url /v1/images/world/terrain/2/5/2.terrain)"
check "tile: gzip;q=0 is plain" test -z "$(header Content-Encoding)"
req -H "Accept-Encoding: gzip, deflate" -H "If-None-Match: $etag" \
    "$(url /v1/images/world/terrain/2/5/2.terrain)"
check "tile: 304 on its ETag" test "$code" = 304

# every tile of level 2 (8 x 4), then the checks across them
z=2
for y in 0 1 2 3; do
    for x in 0 1 2 3 4 5 6 7; do
        req "$(url "/v1/images/world/terrain/$z/$x/$y.terrain?lon0=0")"
        [ "$code" = 200 ] || not_ok "tile $z/$x/$y: 200 (got $code)" "$(head -c 300 "$T/b")"
        cp "$T/b" "$T/t-$x-$y"
    done
done
check "level 2: decoded, indices in range, sphere on the Earth, error within the bound" \
    python3 - "$T" <<'PY'
import math, sys
sys.path.insert(0, sys.argv[1])
from qm import load
bound = 0.03125 * 6378137 * 2 * math.pi * 0.25 / 130 / 4
for y in range(4):
    for x in range(8):
        t = load("%s/t-%d-%d" % (sys.argv[1], x, y))
        c = math.sqrt(sum(v * v for v in t["center"]))
        assert 6.34e6 < c < 6.39e6, (x, y, c)
        assert 0 < t["sphere"][3] < 7e6
        m = t["meta"]
        assert m and 0 <= m["maxError"] <= bound, (x, y, m, bound)
        assert len(t["tris"]) >= 6 and min(t["h"]) == 0
        for e in ("west", "south", "east", "north"):
            assert len(t[e]) >= 2, (x, y, e)
PY
check "mapping: the Himalaya tile is high, a Pacific tile deep" python3 - "$T" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
from qm import load
# level 2: 45-degree tiles; x from 180 W, y from 90 S
him = load(sys.argv[1] + "/t-5-2")    # 45..90 E, 0..45 N
pac = load(sys.argv[1] + "/t-0-1")    # 180..135 W, 45 S..0
assert him["max"] > 5000, him["max"]
assert pac["min"] < -5000 and pac["max"] < 500, (pac["min"], pac["max"])
PY
req "$(url /v1/images/world/terrain/2/1/2.terrain)"
check "lon0=-180 (default): the meshes of lon0=0 180 degrees east" python3 - "$T" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
from qm import load
a, b = load(sys.argv[1] + "/b"), load(sys.argv[1] + "/t-5-2")
for k in ("u", "v", "h", "tris", "west", "east", "min", "max"):
    assert a[k] == b[k], k
assert a["center"] != b["center"]
PY
check "neighbours: the same edge vertices, east-west (antimeridian too) and north-south" \
    python3 - "$T" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
from qm import load, height
t = {(x, y): load("%s/t-%d-%d" % (sys.argv[1], x, y))
     for x in range(8) for y in range(4)}
def edge(m, name, coord):
    return [(m[coord][i], height(m, i)) for i in m[name]]
def same(a, b, ta, tb, what):
    tol = (ta["max"] - ta["min"] + tb["max"] - tb["min"]) / 32767 + 1e-3
    assert len(a) == len(b) and len(a) >= 2, (what, len(a), len(b))
    for (pa, ha), (pb, hb) in zip(a, b):
        assert pa == pb and abs(ha - hb) <= tol, (what, pa, pb, ha, hb)
n = 0
for y in range(4):
    for x in range(8):
        a = t[(x, y)]
        b = t[((x + 1) % 8, y)]
        same(edge(a, "east", "v"), edge(b, "west", "v"), a, b, ("E", x, y))
        n += len(a["east"])
        if y < 3:
            c = t[(x, y + 1)]
            same(edge(a, "north", "u"), edge(c, "south", "u"), a, c, ("N", x, y))
            n += len(a["north"])
print("# %d shared edge vertices" % n)
assert n > 2 * (32 + 24)
PY

# level 3 (the last)
req "$(url "/v1/images/world/terrain/3/11/5.terrain?lon0=0")"
check "level 3 (maxzoom): 200" test "$code" = 200
cp "$T/b" "$T/l3"

# errors
expect_status "tile past maxzoom" 404 "/v1/images/world/terrain/4/0/0.terrain"
expect_status "x outside the level" 404 "/v1/images/world/terrain/1/4/0.terrain"
expect_status "y outside the level" 404 "/v1/images/world/terrain/1/0/2.terrain"
expect_status "not .terrain" 404 "/v1/images/world/terrain/1/0/0.png"
expect_status "bad z" 400 "/v1/images/world/terrain/x/0/0.terrain"
expect_status "z over 24" 400 "/v1/images/world/terrain/25/0/0.terrain"
expect_status "huge x" 400 "/v1/images/world/terrain/1/99999999999/0.terrain"
expect_status "an image store: tile" 400 "/v1/images/img/terrain/0/0/0.terrain"
expect_status "an image store: layer.json" 400 "/v1/images/img/terrain/layer.json"
expect_status "bad lon0" 400 "/v1/images/world/terrain/0/0/0.terrain?lon0=400"
expect_status "bad lon0: layer.json" 400 "/v1/images/world/terrain/layer.json?lon0=x"
expect_status "unknown image" 404 "/v1/images/nope/terrain/layer.json"
expect_status "POST" 405 "/v1/images/world/terrain/layer.json" -X POST
stop_daemon
check "daemon exits 0" test "$drc" = 0

# terrain_error_scale = 0: the grid meshed exactly (more vertices)
cat >"$T/z.conf" <<EOF2
store_dir = "$S"
threads = 2
access_log = off
terrain_error_scale = 0
EOF2
start_daemon "$T/z.conf"
req "$(url "/v1/images/world/terrain/3/11/5.terrain?lon0=0")"
check "terrain_error_scale 0: error 0, more vertices" python3 - "$T/b" "$T" <<'PY'
import sys
sys.path.insert(0, sys.argv[2])
from qm import load
t, d = load(sys.argv[1]), load(sys.argv[2] + "/l3")
assert t["meta"]["maxError"] == 0 < d["meta"]["maxError"], (t["meta"], d["meta"])
assert len(d["u"]) < len(t["u"]) <= 65 * 65, (len(d["u"]), len(t["u"]))
PY
stop_daemon
done_testing
