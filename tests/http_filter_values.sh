#!/bin/sh
# http_filter_values.sh - filter graphs see a store's real samples
# (docs/FILTERS.md section 3.1, the values inputs) through gigaviewd.
#
#   - a 5-channel 16-bit sample store: `values` and `values2` equal the
#     server's tiff32 region (code * scale + offset) sample for sample,
#     channels 6-8 read 0; they are not the 8-bit picture (negative
#     control);
#   - a threshold on the measured values equals the same threshold on
#     the tiff16 codes, pixel for pixel, where one code either side of it
#     would differ; the stock distance transform with its feature mask on
#     values gives distance 0 exactly on those pixels;
#   - `source` of that store is its 8-bit picture (the region's PNG), not
#     its codes read 5 bytes a pixel;
#   - a height store: the stock hillshade (metres_per_level 1) equals
#     Horn's hillshade computed here from the tiff32 heights, within 1/255;
#   - an 8-bit store: values are the source's bytes, exactly.
#
# Needs curl, python3, oiiotool, gdal_translate.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
need_tool oiiotool gdal_translate
srcdir=$(cd "${top_srcdir:-$(dirname "$0")/..}" && pwd)

S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
cd "$T/w" || bail "cd"

oiiotool --pattern "noise:type=uniform:min=0.1:max=0.9" 700x500 5 \
    --pattern "checker:width=64:height=64:color1=0.2,0.4,0.6,0.8,1:color2=0,0.1,0.2,0.3,0.4" 700x500 5 \
    --add -d uint16 -o c5.tif || bail "oiiotool c5"
run encode --bits 16 --max-error 40 c5.tif -o "$S/c5.gv"
[ "$rc" -eq 0 ] || bail "encode c5: $(cat "$T/err")"
run encode --height --max-error 2 synth-height:600x500 -o "$S/dem.gv"
[ "$rc" -eq 0 ] || bail "encode dem: $(cat "$T/err")"
run encode synth:600x400:gray -o "$S/gray.gv"
[ "$rc" -eq 0 ] || bail "encode gray: $(cat "$T/err")"

cat >"$T/v.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 2
access_log = off
filter_library_dir = "$srcdir/filters/library"
filter_workers = 1
filter_timeout_ms = $((GV_TEST_PATIENCE * 1000))
max_filter_pixels = 1M
EOF2
start_daemon "$T/v.conf"
req "$(url /healthz)"
if [ "$(json_get 'j["gpu"].get("built", True)')" = False ] ||
    [ "$(json_get 'j["gpu"]["available"]')" != True ]; then
    skip "filters on values" "no filters here: $(json_get 'j["gpu"]')"
    stop_daemon
    done_testing
fi

# run_filter IMAGE BODY: POST /v1/images/IMAGE/filter.
run_filter() {
    req -X POST -H 'Content-Type: application/json' --data-binary "$2" \
        "$(url "/v1/images/$1/filter")"
}
# toraw IN OUT: the samples of an image file, native order, interleaved.
toraw() {
    gdal_translate -q -of ENVI -co INTERLEAVE=BIP "$1" "$2" >/dev/null 2>&1
}
# point BODY: a one-module graph of four channels over values, values2
# and source.
point() {
    printf '{"name": "t", "output": "o", "output_channels": 4, "modules": [{"id": "o", "template": "point", "inputs": ["values", "values2", "source"], "glsl": "%s"}]}' "$1"
}

R='"level": 0, "region": [130, 70, 200, 150]'
Q='level=0&x=130&y=70&w=200&h=150'
expect_status "c5: the tiff32 region" 200 "/v1/images/c5/region?$Q&format=tiff32"
cp "$T/b" v.tif && toraw v.tif v.raw
expect_status "c5: the tiff16 region" 200 "/v1/images/c5/region?$Q&format=tiff16"
cp "$T/b" c.tif && toraw c.tif c.raw

run_filter c5 "{\"graph\": $(point 'return $(FilterInput1)(rel_pos);'), $R, \"format\": \"raw\"}"
cp "$T/b" f1.raw
run_filter c5 "{\"graph\": $(point 'return $(FilterInput2)(rel_pos);'), $R, \"format\": \"raw\"}"
cp "$T/b" f2.raw
run_filter c5 "{\"graph\": $(point 'return $(FilterInput3)(rel_pos) * 255.0;'), $R, \"format\": \"raw\"}"
cp "$T/b" f3.raw
# values.py F1 F2 F3 REF: the filter's channels against the reference's.
cat >values.py <<'EOF2'
import struct, sys
n = 200 * 150
f1, f2, f3 = (struct.unpack('<%df' % (4 * n), open(p, 'rb').read()) for p in sys.argv[1:4])
ref = struct.unpack('=%df' % (5 * n), open(sys.argv[4], 'rb').read())
bad1 = sum(f1[4 * i + k] != ref[5 * i + k] for i in range(n) for k in range(4))
bad2 = sum(f2[4 * i] != ref[5 * i + 4] or any(f2[4 * i + k] for k in (1, 2, 3)) for i in range(n))
same = sum(f3[4 * i] == ref[5 * i] for i in range(n))
print(bad1, bad2, same)
EOF2
set -- $(python3 values.py f1.raw f2.raw f3.raw v.raw 2>&1)
check "c5: values equal the tiff32 region's channels 1-4 ($1 samples differ)" test "$1" = 0
check "c5: values2 is channel 5, then zeros ($2 pixels differ)" test "$2" = 0
check "negative control: the 8-bit picture is not the values ($3 of 30000 equal)" \
    test "${3:-30000}" -lt 300

# A threshold on the measured values of channel 2, half way up its range.
cat >thr.py <<'EOF2'
import struct, sys
n = 200 * 150
codes = struct.unpack('=%dH' % (5 * n), open(sys.argv[1], 'rb').read())
vals = struct.unpack('=%df' % (5 * n), open(sys.argv[2], 'rb').read())
c = sorted(codes[5 * i + 1] for i in range(n))[n // 2]
# the value of code c, and how many pixels it splits
t = [vals[5 * i + 1] for i in range(n) if codes[5 * i + 1] == c][0]
print(repr(t), c, sum(codes[5 * i + 1] >= c for i in range(n)),
      sum(codes[5 * i + 1] >= c + 1 for i in range(n)))
EOF2
set -- $(python3 thr.py c.raw v.raw)
thr=$1 tcode=$2 above=$3 above1=$4
diag "threshold $thr (code $tcode): $above pixels at or above, $above1 above the next code"
run_filter c5 "{\"graph\": $(point "return vec4(\$(FilterInput1)(rel_pos).g >= $thr ? 1.0 : 0.0);"), $R, \"format\": \"raw\"}"
cp "$T/b" m.raw
cat >mask.py <<'EOF2'
import struct, sys
n = 200 * 150
m = struct.unpack('<%df' % (4 * n), open(sys.argv[1], 'rb').read())
codes = struct.unpack('=%dH' % (5 * n), open(sys.argv[2], 'rb').read())
c = int(sys.argv[3])
print(sum((m[4 * i] == 1.0) != (codes[5 * i + 1] >= c) for i in range(n)),
      sum(m[4 * i] == 1.0 for i in range(n)))
EOF2
set -- $(python3 mask.py m.raw c.raw "$tcode")
check "a threshold on values equals the threshold on the codes ($1 pixels differ)" test "$1" = 0
check "... and one code decides it ($2 pixels marked, $above1 above the next code)" \
    sh -c "[ '$2' = '$above' ] && [ '$above' != '$above1' ]"

# The stock distance transform, its feature mask made from values.
python3 - "$srcdir/filters/library/distance-transform.json" "$thr" >edt.json <<'EOF2'
import json, sys
g = json.load(open(sys.argv[1]))
f = [m for m in g['modules'] if m['id'] == 'features'][0]
f['inputs'] = ['values']
f.pop('params', None)
f['glsl'] = ('if ($(FilterInput1)(rel_pos).g < %s)\n    return uvec4(0u);\n'
             'uvec2 a = uvec2(abs_pos);\n'
             'return uvec4(a, 1u + ((a.y & 4095u) << 12) + (a.x & 4095u), 1u);' % sys.argv[2])
print(json.dumps({'graph': g, 'level': 0, 'region': [130, 70, 200, 150], 'format': 'raw'}))
EOF2
req -X POST -H 'Content-Type: application/json' --data-binary @edt.json "$(url /v1/images/c5/filter)"
if [ "$code" = 200 ]; then
    cp "$T/b" d.raw
    set -- $(python3 - d.raw m.raw <<'EOF2'
import struct, sys
n = 200 * 150
d = struct.unpack('<%df' % (4 * n), open(sys.argv[1], 'rb').read())
m = struct.unpack('<%df' % (4 * n), open(sys.argv[2], 'rb').read())
print(sum((d[4 * i] == 0.0) != (m[4 * i] == 1.0) for i in range(n)),
      max(d[4 * i] for i in range(n)))
EOF2
)
    check "the distance transform on values: 0 exactly on the mask ($1 pixels differ, largest distance $2)" \
        sh -c "[ '$1' = 0 ] && [ '$2' != 0.0 ]"
else
    not_ok "the distance transform on values (HTTP $code)" "$(head -c 400 "$T/b")"
fi

# source of a 5-channel store: its 8-bit picture, as the region's PNG.
expect_status "c5: the region's PNG" 200 "/v1/images/c5/region?$Q"
cp "$T/b" p.png && toraw p.png p.raw
run_filter c5 "{\"graph\": {\"name\": \"s\", \"output\": \"o\", \"modules\": [{\"id\": \"o\", \"template\": \"point\", \"inputs\": [\"source\"], \"glsl\": \"return \$(FilterInput1)(rel_pos);\"}]}, $R}"
cp "$T/b" s.png && toraw s.png s.raw
check "c5: source is the region's 8-bit picture" cmp -s p.raw s.raw

# A height store: the stock hillshade on its heights.
DR='"level": 0, "region": [200, 150, 96, 80]'
expect_status "dem: the tiff32 region, one pixel around" 200 \
    "/v1/images/dem/region?level=0&x=199&y=149&w=98&h=82&format=tiff32"
cp "$T/b" h.tif && toraw h.tif h.raw
run_filter dem "{\"filter\": \"hillshade\", \"params\": {\"hillshade\": {\"pixel_size\": 30, \"z_factor\": 2}}, $DR, \"format\": \"raw\"}"
cp "$T/b" hs.raw
cat >hs.py <<'EOF2'
import math, struct, sys
W, H = 98, 82
z = struct.unpack('=%df' % (W * H), open(sys.argv[1], 'rb').read())
out = struct.unpack('<%df' % (96 * 80), open(sys.argv[2], 'rb').read())
az, alt = math.radians(315), math.radians(45)
k = 1 * 2 / (8.0 * 30)
worst, flat = 0.0, 0
for y in range(80):
    for x in range(96):
        g = lambda i, j: z[(y + 1 + j) * W + x + 1 + i]
        ex = (g(1, -1) + 2 * g(1, 0) + g(1, 1)) - (g(-1, -1) + 2 * g(-1, 0) + g(-1, 1))
        ny = (g(-1, -1) + 2 * g(0, -1) + g(1, -1)) - (g(-1, 1) + 2 * g(0, 1) + g(1, 1))
        p, q = ex * k, ny * k
        c = (math.sin(alt) - (p * math.sin(az) + q * math.cos(az)) * math.cos(alt)) / math.sqrt(1 + p * p + q * q)
        want = (1 + 254 * max(c, 0)) / 255
        worst = max(worst, abs(out[y * 96 + x] - want))
        flat += ex == 0 and ny == 0
print('%.6f' % worst, flat, '%.3f' % min(out), '%.3f' % max(out))
EOF2
out=$(python3 hs.py h.raw hs.raw 2>&1) || diag "$out"
set -- $out ''
check "dem: hillshade on the heights equals Horn's from the tiff32 region (largest difference $1, $2 flat pixels, shades $3..$4)" \
    python3 -c "import sys; sys.exit(not (float('$1') <= 1 / 255 and float('$4') - float('$3') > 0.2))"

# An 8-bit store: values are the source's bytes.
run_filter gray "{\"graph\": $(point 'return $(FilterInput1)(rel_pos) - floor($(FilterInput3)(rel_pos) * 255.0 + 0.5) + $(FilterInput2)(rel_pos);'), \"level\": 0, \"region\": [0, 0, 300, 200], \"format\": \"raw\"}"
check "gray: values are the source's bytes, values2 zero" python3 -c "
import struct, sys
v = struct.unpack('<%df' % (4 * 300 * 200), open('$T/b', 'rb').read())
sys.exit(any(v))"

stop_daemon
done_testing
