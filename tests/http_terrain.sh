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
#
# Extensions (docs/API.md): layer.json lists octvertexnormals and metadata
# with metadataAvailability 10; every tile has the metadata extension (id
# 4), whose "available" is on levels 0 and 10 only (a 262145 x 3 store
# reaches level 11) and names the tile's descendants; the normals (id 1)
# come when the Accept header or the extensions query asks (hostile Accept
# values too), and decode (as CesiumJS does) to the normals of the mesh:
# straight up on a flat store even from two triangles of 180 degrees, and
# on a store with a ramp rising eastwards tilted west by the ramp's angle
# on it and up off it; with terrain_water_below the water mask (id 2) is
# the store below that height at the mask's pixel centres, rows north to
# south, one byte for an all-water or all-land tile, and layer.json lists
# watermask; without it, no mask even when asked.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" || bail "mkdir"
run encode --height --max-error 2 --unit m --offset -11000 \
    "$TESTDATA/etopo5-720x361-u16.png" -o "$S/world.gv"
[ "$rc" -eq 0 ] || bail "encode height: $(cat "$T/err")"
run encode synth:300x200 -o "$S/img.gv"
[ "$rc" -eq 0 ] || bail "encode image: $(cat "$T/err")"
# flat: 1000 m everywhere; slope: 1000 m, rising 10 km a column over
# columns 230..236 (0.703 degrees each: 7.3 degrees at the equator), with
# a 3 m checkerboard so that an exact mesh keeps every sample; long:
# 262145 x 3 samples, level 11 (metadata availability on levels 0 and 10)
python3 - "$T" <<'PY' || bail "write PNG-16 inputs"
import struct, sys, zlib
def png16(path, w, h, f):
    raw = b"".join(b"\0" + struct.pack(">%dH" % w, *[f(x, y) for x in range(w)])
                   for y in range(h))
    def chunk(t, d):
        return (struct.pack(">I", len(d)) + t + d +
                struct.pack(">I", zlib.crc32(t + d) & 0xffffffff))
    open(path, "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(
        ">IIBBBBB", w, h, 16, 0, 0, 0, 0)) + chunk(b"IDAT", zlib.compress(raw))
        + chunk(b"IEND", b""))
d = sys.argv[1]
png16(d + "/flat.png", 513, 257, lambda x, y: 1000)
png16(d + "/slope.png", 513, 257, lambda x, y: 1000 + 3 * ((x + y) % 2) +
      10000 * min(max(x - 230, 0), 6))
png16(d + "/long.png", 262145, 3, lambda x, y: 100)
PY
for n in flat slope long; do
    run encode --height --unit m "$T/$n.png" -o "$S/$n.gv"
    [ "$rc" -eq 0 ] || bail "encode $n: $(cat "$T/err")"
done
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
assert j["extensions"] == ["octvertexnormals", "metadata"], j["extensions"]
assert j["metadataAvailability"] == 10
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
    t["meta"] = t["normals"] = t["water"] = None
    t["ids"] = []
    while p < len(b):
        eid, ln = struct.unpack_from("<BI", b, p)
        p += 5
        t["ids"].append(eid)
        if eid == 4:      # metadata: a length and JSON
            jl = struct.unpack_from("<I", b, p)[0]
            assert jl + 4 == ln, (jl, ln)
            t["meta"] = json.loads(b[p + 4:p + 4 + jl])
        elif eid == 1:    # oct-encoded normals, two bytes a vertex
            assert ln == 2 * n, (ln, n)
            t["normals"] = [octdecode(b[p + 2 * i], b[p + 2 * i + 1])
                            for i in range(n)]
        elif eid == 2:    # water mask
            assert ln in (1, 65536), ln
            t["water"] = b[p:p + ln]
        p += ln
    assert p == len(b)
    return t

def octdecode(a, b):
    # CesiumJS's AttributeCompression.octDecodeInRange(a, b, 255)
    x, y = a / 255 * 2 - 1, b / 255 * 2 - 1
    z = 1 - abs(x) - abs(y)
    if z < 0:
        x, y = ((1 - abs(y)) * (1 if x >= 0 else -1),
                (1 - abs(x)) * (1 if y >= 0 else -1))
    l = math.sqrt(x * x + y * y + z * z)
    assert abs(abs(x) + abs(y) + abs(z) - 1) < 1e-9 and l > 0.5
    return (x / l, y / l, z / l)

def lonlat(t, i, w, s, e, n):
    return (w + (e - w) * t["u"][i] / 32767, s + (n - s) * t["v"][i] / 32767)

def enu(lon, lat):
    # east, north and up (the ellipsoid's normal) at a geodetic point
    lo, la = math.radians(lon), math.radians(lat)
    return ((-math.sin(lo), math.cos(lo), 0),
            (-math.sin(la) * math.cos(lo), -math.sin(la) * math.sin(lo),
             math.cos(la)),
            (math.cos(la) * math.cos(lo), math.cos(la) * math.sin(lo),
             math.sin(la)))

def dot(a, b):
    return sum(x * y for x, y in zip(a, b))

def bounds(z, x, y):
    side = 180 / 2 ** z
    return (-180 + x * side, -90 + y * side, -180 + (x + 1) * side,
            -90 + (y + 1) * side)

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
check "tile: Vary: Accept-Encoding, Accept" test "$(header Vary)" = "Accept-Encoding, Accept"
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

# extensions: what is asked for, and only that (the metadata always)
QM='application/vnd.quantized-mesh'
ext_ids() { # PATH [CURL ARGS]: the extension ids of a tile, "1 4"
    p=$1
    shift
    req "$@" "$(url "$p")"
    [ "$code" = 200 ] || { echo "HTTP $code"; return; }
    python3 -c "import sys; sys.path.insert(0, sys.argv[1]); from qm import load; print(*load(sys.argv[1] + '/b')['ids'])" "$T"
}
check "extensions: metadata only when none is asked" \
    test "$(ext_ids /v1/images/world/terrain/2/5/2.terrain)" = 4
check "extensions: normals on CesiumJS's Accept header" test "$(ext_ids \
    /v1/images/world/terrain/2/5/2.terrain -H \
    "Accept: $QM;extensions=octvertexnormals-watermask-metadata,application/octet-stream;q=0.9,*/*;q=0.01")" = "1 4"
check "extensions: Vary names Accept" test "$(header Vary)" = "Accept-Encoding, Accept"
etagn=$(header ETag)
check "extensions: normals on the extensions query (ion's form)" test \
    "$(ext_ids '/v1/images/world/terrain/2/5/2.terrain?extensions=octvertexnormals-metadata')" = "1 4"
req "$(url /v1/images/world/terrain/2/5/2.terrain)"
check "extensions: the tile with normals has its own ETag" test "$(header ETag)" != "$etagn"
check "extensions: no water mask unless configured, even when asked" test "$(ext_ids \
    /v1/images/world/terrain/2/5/2.terrain -H "Accept: $QM;extensions=watermask")" = 4
# hostile Accept values: a type that only begins alike, other types, an
# empty or endless list, quotes, odd case and spacing
check "Accept: another type with the same prefix asks nothing" test "$(ext_ids \
    /v1/images/world/terrain/2/5/2.terrain -H "Accept: $QM-x;extensions=octvertexnormals")" = 4
check "Accept: another type's extensions ask nothing" test "$(ext_ids \
    /v1/images/world/terrain/2/5/2.terrain -H "Accept: application/json;extensions=octvertexnormals")" = 4
check "Accept: a name inside another asks nothing" test "$(ext_ids \
    /v1/images/world/terrain/2/5/2.terrain -H "Accept: $QM;extensions=xoctvertexnormals-octvertexnormalsx")" = 4
long=$(python3 -c 'print("-" * 12000 + "octvertexnormals")')
check "Accept: a 12 kB list is cut (the name past 4096 bytes ignored)" test "$(ext_ids \
    /v1/images/world/terrain/2/5/2.terrain -H "Accept: $QM;extensions=$long")" = 4
check "Accept: quoted, any case, spaces, in a later range" test "$(ext_ids \
    /v1/images/world/terrain/2/5/2.terrain -H \
    "Accept: text/html, APPLICATION/Vnd.Quantized-Mesh ; q=1 ; Extensions=\"metadata-OctVertexNormals\"")" = "1 4"
check "Accept: an empty list and a lone ';'" test "$(ext_ids \
    /v1/images/world/terrain/2/5/2.terrain -H "Accept: $QM;extensions=;,$QM;,;")" = 4

# normals: decoded as CesiumJS does, unit vectors, as the mesh says
for t in 0/0/0 0/1/0 1/1/0 2/3/2; do
    req -H "Accept: $QM;extensions=octvertexnormals" "$(url "/v1/images/flat/terrain/$t.terrain")"
    cp "$T/b" "$T/flat-$(echo "$t" | tr / -)"
done
check "normals: straight up on a flat store (levels 0 to 2, two-triangle tiles)" \
    python3 - "$T" <<'PY'
import math, sys
sys.path.insert(0, sys.argv[1])
from qm import load, lonlat, enu, dot, bounds
worst = 0
for name in ("0-0-0", "0-1-0", "1-1-0", "2-3-2"):
    z, x, y = map(int, name.split("-"))
    t = load("%s/flat-%s" % (sys.argv[1], name))
    assert t["normals"] and len(t["normals"]) == len(t["u"]), name
    for i, nrm in enumerate(t["normals"]):
        assert abs(math.sqrt(dot(nrm, nrm)) - 1) < 1e-9
        up = enu(*lonlat(t, i, *bounds(z, x, y)))[2]
        worst = max(worst, math.degrees(math.acos(min(1, dot(nrm, up)))))
print("# largest angle to the ellipsoid's normal %.2f degrees" % worst)
assert worst < 0.7, worst
PY
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

# normals on a slope, from the exact mesh (every sample a vertex)
for t in 2/3/2 2/3/1; do
    req -H "Accept: $QM;extensions=octvertexnormals" "$(url "/v1/images/slope/terrain/$t.terrain")"
    cp "$T/b" "$T/slope-$(echo "$t" | tr / -)"
done
check "normals: tilted west by the ramp's angle on it, up off it, as the mesh's faces" \
    python3 - "$T" <<'PY'
import math, sys
sys.path.insert(0, sys.argv[1])
from qm import load, lonlat, enu, dot, bounds
col = lambda lon: (lon + 180) * 512 / 360     # the store's column
on = off = 0
for name in ("2-3-2", "2-3-1"):
    z, x, y = map(int, name.split("-"))
    t = load("%s/slope-%s" % (sys.argv[1], name))
    assert len(t["u"]) == 65 * 65 and len(t["normals"]) == 65 * 65
    near = {}                   # columns of each vertex's triangles
    tr = t["tris"]
    for k in range(0, len(tr), 3):
        cs = [col(lonlat(t, i, *bounds(z, x, y))[0]) for i in tr[k:k + 3]]
        for i in tr[k:k + 3]:
            near.setdefault(i, []).extend(cs)
    for i, nrm in enumerate(t["normals"]):
        lon, lat = lonlat(t, i, *bounds(z, x, y))
        if abs(lat) > 40:
            continue
        e, n, u = enu(lon, lat)
        ne, nn, nu = dot(nrm, e), dot(nrm, n), dot(nrm, u)
        assert abs(nn) < 0.02, (name, i, lon, lat, ne, nn, nu)
        lo, hi = min(near[i]), max(near[i])
        tilt = math.degrees(math.atan2(-ne, nu))
        dx = 6378137 * math.cos(math.radians(lat)) * math.radians(360 / 512)
        want = math.degrees(math.atan(10000 / dx))
        if lo >= 230 - 1e-6 and hi <= 236 + 1e-6:   # only ramp triangles
            assert abs(tilt - want) < 1.0, (name, lon, lat, tilt, want)
            on += 1
        elif hi <= 230 + 1e-6 or lo >= 236 - 1e-6:  # only level triangles
            assert abs(tilt) < 0.7, (name, lon, lat, tilt)
            off += 1
        else:                                       # both: between
            assert -0.7 < tilt < want + 1, (name, lon, lat, tilt)
print("# %d vertices on the ramp, %d off it" % (on, off))
assert on >= 100 and off >= 1000, (on, off)
PY

# metadata availability: levels 0 and 10 name their descendants
req "$(url /v1/images/long/terrain/layer.json)"
check "long store: maxzoom 11" test "$(json_get 'j["maxzoom"]')" = 11
for t in 0/0/0 0/1/0 1/3/1 9/700/300 10/1234/517 11/2468/1034; do
    req "$(url "/v1/images/long/terrain/$t.terrain")"
    cp "$T/b" "$T/long-$(echo "$t" | tr / -)"
done
check "metadata: available on levels 0 and 10 (the tile's descendants, TMS), not between" \
    python3 - "$T" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
from qm import load
m = lambda n: load("%s/long-%s" % (sys.argv[1], n))["meta"]
for x in (0, 1):
    a = m("0-%d-0" % x)["available"]
    assert len(a) == 10, len(a)          # levels 1 .. 10
    for k, r in enumerate(a, 1):
        assert r == [{"startX": x << k, "startY": 0,
                      "endX": ((x + 1) << k) - 1, "endY": (1 << k) - 1}], (k, r)
a = m("10-1234-517")["available"]        # level 11 only (the last)
assert a == [[{"startX": 2468, "startY": 1034, "endX": 2469,
               "endY": 1035}]], a
for n in ("1-3-1", "9-700-300", "11-2468-1034"):
    assert "available" not in m(n) and "maxError" in m(n), n
PY
stop_daemon

# terrain_water_below: a water mask where the store is below 0 m
cat >"$T/w.conf" <<EOF2
store_dir = "$S"
threads = 2
access_log = off
terrain_water_below = "world:0 flat:2000 slope:500"
EOF2
start_daemon "$T/w.conf"
req "$(url "/v1/images/world/terrain/layer.json")"
check "water: layer.json lists watermask" test \
    "$(json_get 'j["extensions"], j["gigaview"]["waterBelow"]')" = "['octvertexnormals', 'watermask', 'metadata'] 0.0"
req "$(url "/v1/images/long/terrain/layer.json")"
check "water: not for a store it does not name" test \
    "$(json_get 'j["extensions"]')" = "['octvertexnormals', 'metadata']"
for t in 2/5/2 2/0/1; do
    req -H "Accept: $QM;extensions=octvertexnormals-watermask-metadata" \
        "$(url "/v1/images/world/terrain/$t.terrain?lon0=0")"
    cp "$T/b" "$T/water-$(echo "$t" | tr / -)"
done
req -H "Accept: $QM;extensions=watermask" "$(url "/v1/images/flat/terrain/1/2/1.terrain")"
cp "$T/b" "$T/water-flat"
req -H "Accept: $QM;extensions=watermask" "$(url "/v1/images/slope/terrain/1/1/1.terrain")"
cp "$T/b" "$T/water-slope"
check "water: 256 x 256 where mixed, rows north to south; one byte all water or all land" \
    python3 - "$T" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
from qm import load
t = load(sys.argv[1] + "/water-2-5-2")   # 45..90 E, 0..45 N
assert t["ids"] == [1, 2, 4], t["ids"]
w = t["water"]
assert len(w) == 65536 and set(w) == {0, 255}
row = lambda j: sum(w[256 * j:256 * (j + 1)]) / 255 / 256
# the north row (45 N: Kazakhstan, Mongolia; the Caspian, at -28 m, is
# water) is mostly land, the south (the equator: the Indian Ocean) water;
# Everest (86.9 E, 28 N) land
print("# water: north row %.2f, south row %.2f, all %.2f" %
      (row(0), row(255), sum(w) / 255 / 65536))
assert row(0) < 0.3 and row(255) > 0.9, (row(0), row(255))
j, i = int((45 - 27.99) / 45 * 256), int((86.93 - 45) / 45 * 256)
assert w[256 * j + i] == 0
pac = load(sys.argv[1] + "/water-2-0-1")  # the Pacific, 180..135 W, 45 S..0
assert pac["water"] == b"\xff", len(pac["water"])
flat = load(sys.argv[1] + "/water-flat")  # 1000 m, under 2000 m: all water
assert flat["ids"] == [2, 4] and flat["water"] == b"\xff", len(flat["water"])
land = load(sys.argv[1] + "/water-slope")  # 1000 m and more, over 500 m
assert land["water"] == b"\x00", len(land["water"])
PY
stop_daemon
done_testing
