#!/bin/sh
# cli_samples.sh - sample stores (docs/FORMAT.md section 13): images of 1
# to 8 channels kept at 16 bits, on the command line and over HTTP
# (docs/API.md, "Sample stores"):
#
#   - `gigaview encode --bits 16` of a 4-channel 16-bit TIFF, a 16-bit
#     gray PNG and an 8-channel TIFF, made here with GDAL from samples
#     Python writes: lossless, every level equals the box-filtered
#     pyramid of the input exactly (levels 0, 1 and 2);
#   - --max-error 40: every sample of levels 0, 1 and 2 within 40 of the
#     exact pyramid, and not all exact; -q 60: the PSNR `info` reports
#     is the PSNR measured here, and within 60 .. 61 dB (the trial);
#   - a 4-band GeoTIFF through GDAL keeps every band and its
#     georeference (builds with GDAL); a 4-page OME-TIFF every page, its
#     channels' names and colours;
#   - info and info --json; a default window kept as metadata;
#   - over HTTP: the samples object, tiff16 and png16 regions equal to
#     `export --bits 16`, png16 of 8 channels refused, the 8-bit picture
#     (window and colours, gray for one channel) equal to a reference
#     written here in Python from the rule in docs/API.md, with a window
#     given and with the store's default, IIIF, windows past 255 refused
#     for an 8-bit image store;
#   - bad options and inputs are refused.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
need_tool gdal_translate
need_tool oiiotool

builddir=$(cd "${top_builddir:-.}" && pwd)
S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
cd "$T/w" || bail "cd"

# mk NAME W H C SEED: NAME.raw (u16, pixel-interleaved) and its ENVI
# header; smooth gradients, a ring pattern and noise, each channel its own.
mk() {
    python3 - "$@" <<'PY' || bail "python samples"
import array, math, random, sys
name, w, h, c, seed = sys.argv[1], *map(int, sys.argv[2:])
random.seed(seed)
a = array.array('H', bytes(2 * w * h * c))
for y in range(h):
    for x in range(w):
        i = (y * w + x) * c
        for k in range(c):
            if k % 4 == 0:
                v = 30000 + 20000 * math.sin(x / (17.0 + k)) * math.cos(y / 23.0)
            elif k % 4 == 1:
                v = ((x * x + y * y) // (5 + k)) % 65536
            elif k % 4 == 2:
                v = 1000 + (x * 41 + y * 17) % 3000 + random.randint(0, 60)
            else:
                v = 65535.0 * x / w * y / h
            a[i + k] = int(v)
open(name + '.raw', 'wb').write(a.tobytes())
open(name + '.hdr', 'w').write(
    f"ENVI\nsamples = {w}\nlines = {h}\nbands = {c}\nheader offset = 0\n"
    f"file type = ENVI Standard\ndata type = 12\ninterleave = bip\nbyte order = 0\n")
PY
}
mk c4 1100 700 4 1
mk c8 600 300 8 2
gdal_translate -q -of GTiff -co INTERLEAVE=PIXEL -co COMPRESS=DEFLATE c4.raw c4.tif ||
    bail "gdal_translate c4"
gdal_translate -q -of GTiff -co INTERLEAVE=PIXEL c8.raw c8.tif || bail "gdal_translate c8"
gdal_translate -q -b 1 -of PNG c4.raw g1.png || bail "gdal_translate g1"

# toraw IN OUT: a TIFF or PNG of 16-bit samples to pixel-interleaved raw.
toraw() {
    gdal_translate -q -of ENVI -co INTERLEAVE=BIP "$1" "$2" >/dev/null 2>&1
}

# pyr_check RAW W H C LEVEL OUT_RAW BOUND [exact|lossy]: OUT_RAW (level
# LEVEL of the store) against level LEVEL of RAW's exact box pyramid
# (docs/FORMAT.md section 12: (a+b+c+d+2)>>2, odd edges replicated),
# every sample within BOUND; `lossy` also wants some sample not exact.
pyr_check() {
    python3 - "$@" <<'PY'
import array, sys
raw, w, h, c, level, out, bound = sys.argv[1], *map(int, sys.argv[2:5]), int(sys.argv[5]), sys.argv[6], int(sys.argv[7])
mode = sys.argv[8] if len(sys.argv) > 8 else 'exact'
a = array.array('H', open(raw, 'rb').read())
for _ in range(level):
    dw, dh = (w + 1) // 2, (h + 1) // 2
    b = array.array('H', bytes(2 * dw * dh * c))
    for y in range(dh):
        y0, y1 = 2 * y, min(2 * y + 1, h - 1)
        for x in range(dw):
            x0, x1 = 2 * x, min(2 * x + 1, w - 1)
            for k in range(c):
                s = (a[(y0 * w + x0) * c + k] + a[(y0 * w + x1) * c + k] +
                     a[(y1 * w + x0) * c + k] + a[(y1 * w + x1) * c + k] + 2) >> 2
                b[(y * dw + x) * c + k] = s
    a, w, h = b, dw, dh
o = array.array('H', open(out, 'rb').read())
assert len(o) == len(a), (len(o), len(a))
worst = max(abs(p - q) for p, q in zip(a, o))
assert worst <= bound, ('worst', worst, 'bound', bound)
if mode == 'lossy':
    assert worst > 0, 'every sample exact'
PY
}

# ---------------------------------------------------------------- lossless
run encode --bits 16 c4.tif -o "$S/c4.gv"
expect_rc "encode --bits 16 of a 4-channel 16-bit TIFF" 0
check "the summary says 4 channels" grep -q '^samples    1100 x 700 x 4 channels' "$T/out"
check "... and lossless" grep -q '^psnr       99.00 dB' "$T/out"
for L in 0 1 2; do
    run export --bits 16 --level $L "$S/c4.gv" -o c4-$L.tif
    expect_rc "export --bits 16 --level $L" 0
    toraw c4-$L.tif c4-$L.raw
    check "lossless: level $L equals the input's exact pyramid" \
        pyr_check c4.raw 1100 700 4 $L c4-$L.raw 0
done
run encode --bits 16 g1.png -o "$S/g1.gv"
expect_rc "encode --bits 16 of a 16-bit gray PNG" 0
run export --bits 16 "$S/g1.gv" -o g1-0.png
toraw g1-0.png g1-0.raw
toraw g1.png g1.raw
check "lossless gray: level 0 equals the input" cmp -s g1.raw g1-0.raw
run encode --bits 16 c8.tif -o "$S/c8.gv"
expect_rc "encode --bits 16 of an 8-channel TIFF" 0
run export --bits 16 --level 1 "$S/c8.gv" -o c8-1.tif
toraw c8-1.tif c8-1.raw
check "lossless 8 channels: level 1 equals the exact pyramid" \
    pyr_check c8.raw 600 300 8 1 c8-1.raw 0
run export --bits 16 "$S/c8.gv" -o c8.png
expect_rc "export --bits 16 of 8 channels to PNG is refused" 1
expect_err "... naming the channels" "channels"

# four_channels WHAT INPUT NAME: INPUT (c4.raw's four channels in another
# file) encodes losslessly to $S/NAME.gv with all four, level 0 equal to
# c4.raw; then `info --json` of it is in $T/out.
four_channels() {
    run encode --bits 16 "$2" -o "$S/$3.gv"
    expect_rc "encode --bits 16 of $1" 0
    check "... every channel is kept" grep -q '^samples    1100 x 700 x 4 channels' "$T/out"
    run export --bits 16 "$S/$3.gv" -o "$3-0.tif"
    toraw "$3-0.tif" "$3-0.raw"
    check "... lossless: level 0 equals the input" cmp -s c4.raw "$3-0.raw"
    run info --json "$S/$3.gv"
}

# A 4-band GeoTIFF through GDAL: every band, and the georeference.
if grep -q "^#define GV_HAVE_GDAL 1" "$builddir/config.h"; then
    gdal_translate -q -a_srs EPSG:4326 -a_ullr -10 50 10 40 -co INTERLEAVE=PIXEL \
        c4.raw geo4.tif || bail "gdal_translate geo4"
    four_channels "a 4-band GeoTIFF (GDAL)" geo4.tif geo4
    check "... the georeference is kept" python3 -c "
import json,sys; m=json.load(open(sys.argv[1]))['metadata']
assert m['geo.epsg']==4326 and m['geo.bands']==4 and m['geo.transform'][0]==-10, m" "$T/out"
else
    skip "a GeoTIFF through GDAL" "built without GDAL"
fi

# An OME-TIFF whose channels are pages (lib/imageio/ome_tiff.h): the
# four bands as four 16-bit pages, OME-XML on the first with names and
# colours.
for k in 1 2 3 4; do
    gdal_translate -q -b $k -co COMPRESS=DEFLATE c4.raw band$k.tif || bail "band $k"
done
tiffcp band1.tif band2.tif band3.tif band4.tif ome.tif || bail "tiffcp"
OMEXML='<?xml version="1.0" encoding="UTF-8"?><OME xmlns="http://www.openmicroscopy.org/Schemas/OME/2016-06"><Image ID="Image:0"><Pixels ID="Pixels:0" DimensionOrder="XYCZT" Type="uint16" SizeX="1100" SizeY="700" SizeC="4" SizeZ="1" SizeT="1"><Channel ID="Channel:0:0" Name="DAPI" Color="65535" SamplesPerPixel="1"/><Channel ID="Channel:0:1" Name="GFP" Color="16711935" SamplesPerPixel="1"/><Channel ID="Channel:0:2" Name="Cy3" Color="-16776961" SamplesPerPixel="1"/><Channel ID="Channel:0:3" Name="Cy5;far red" Color="-16711681" SamplesPerPixel="1"/><TiffData/></Pixels></Image></OME>'
tiffset -s 270 "$OMEXML" ome.tif || bail "tiffset"
four_channels "a 4-page OME-TIFF" ome.tif ome
check "... the channels' names and colours are kept" python3 -c "
import json,sys; m=json.load(open(sys.argv[1]))['metadata']
assert m['ome.channels']=='DAPI;GFP;Cy3;Cy5,far red', m
assert m['display.colours']=='0000ff;00ff00;ff0000;ff00ff', m" "$T/out"
tiffset -s 270 "$(printf %s "$OMEXML" | sed 's/SizeC="4"/SizeC="6"/')" ome.tif || bail "tiffset"
run encode --bits 16 ome.tif -o "$S/ome6.gv"
check "an OME-TIFF claiming more channels than pages is read as its first page" \
    grep -q '^samples    1100 x 700 x 1 channels' "$T/out"
rm -f "$S/ome6.gv"

# An OME-TIFF stack: 2 channels x 3 Z planes in 6 pages, the plane chosen
# with --plane; the pages of a plane follow the DimensionOrder.
gdal_translate -q -b 1 -scale 0 65535 65535 0 -ot UInt16 c4.raw band5.tif || bail "band 5"
gdal_translate -q -b 2 -scale 0 65535 65535 0 -ot UInt16 c4.raw band6.tif || bail "band 6"
for k in 1 2 3 4 5 6; do toraw band$k.tif band$k.raw; done
tiffcp band1.tif band2.tif band3.tif band4.tif band5.tif band6.tif stack.tif || bail "tiffcp stack"
STACKXML=$(printf %s "$OMEXML" | sed 's/DimensionOrder="XYCZT"/DimensionOrder="XYZCT"/; s/SizeC="4" SizeZ="1"/SizeC="2" SizeZ="3"/; s|<Channel ID="Channel:0:2".*<TiffData/>|<TiffData/>|')
tiffset -s 270 "$STACKXML" stack.tif || bail "tiffset stack"
# plane_is DESC STORE PAGE PAGE: the store's level 0 is those two pages.
plane_is() {
    run export --bits 16 "$2" -o plane.tif
    toraw plane.tif plane.raw
    check "$1" python3 -c "
import sys
a, b, p = (open(f, 'rb').read() for f in ('band$3.raw', 'band$4.raw', 'plane.raw'))
want = b''.join(a[i:i + 2] + b[i:i + 2] for i in range(0, len(a), 2))
sys.exit(p != want)"
}
run encode --bits 16 stack.tif -o "$S/stack.gv"
expect_rc "an OME-TIFF Z stack without --plane is refused" 1
expect_err "... saying how to choose a plane" "stack of 3 Z planes and 1 time point: choose a plane with --plane Z\[,T\]"
check "... and writes nothing" test ! -e "$S/stack.gv"
run encode --bits 16 --plane 1 stack.tif -o "$S/stack.gv"
expect_rc "encode --plane 1 of a XYZCT stack" 0
plane_is "--plane 1, XYZCT: its channels are pages 2 and 5 (Z varies fastest)" "$S/stack.gv" 2 5
run info --json "$S/stack.gv"
check "... the plane and the stack's size are in the metadata" python3 -c "
import json,sys; m=json.load(open(sys.argv[1]))['metadata']
assert (m['ome.plane_z'], m['ome.plane_t'], m['ome.size_z'], m['ome.size_t']) == (1, 0, 3, 1), m
assert m['ome.channels'] == 'DAPI;GFP', m" "$T/out"
tiffset -s 270 "$(printf %s "$STACKXML" | sed 's/XYZCT/XYCZT/')" stack.tif || bail "tiffset XYCZT"
run encode --bits 16 --plane 2,0 stack.tif -o "$S/stack2.gv"
expect_rc "encode --plane 2,0 of a XYCZT stack" 0
plane_is "--plane 2,0, XYCZT: pages 5 and 6 (C varies fastest)" "$S/stack2.gv" 5 6
run encode --bits 16 --plane 3 stack.tif -o "$S/stack3.gv"
expect_rc "--plane past the stack's Z planes is refused" 1
expect_err "... naming the stack's planes" "--plane 3,0 is outside the stack \\(Z 0..2, T 0..0\\)"
run encode --bits 16 --plane 0,1 stack.tif -o "$S/stack3.gv"
expect_rc "--plane past its time points is refused" 1
run encode --bits 16 --plane 0 c4.tif -o "$S/stack3.gv"
expect_rc "--plane of a file that is not an OME-TIFF is refused" 1
expect_err "... saying so" "--plane picks a plane of an OME-TIFF stack, and this is not one"
run encode --bits 16 --plane x stack.tif -o "$S/stack3.gv"
expect_rc "--plane x is a usage error" 2
tiffset -s 270 "$(printf %s "$STACKXML" | sed 's/SizeZ="3"/SizeZ="4"/')" stack.tif || bail "tiffset Z4"
run encode --bits 16 --plane 3 stack.tif -o "$S/stack3.gv"
expect_rc "a stack claiming more pages than it has is refused, not read as its first page" 1
check "nothing written by the refused encodes" test ! -e "$S/stack3.gv"
rm -f "$S/stack.gv" "$S/stack2.gv"

# ----------------------------------------------------------- near-lossless
run encode --bits 16 --max-error 40 c4.tif -o "$S/c4e.gv"
expect_rc "encode --bits 16 --max-error 40" 0
check "the summary gives the bound" grep -q '^max error  40 (40 codes)' "$T/out"
for L in 0 1 2; do
    run export --bits 16 --level $L "$S/c4e.gv" -o c4e-$L.tif
    toraw c4e-$L.tif c4e-$L.raw
    check "--max-error 40: level $L within 40 of the exact pyramid, not exact" \
        pyr_check c4.raw 1100 700 4 $L c4e-$L.raw 40 lossy
done
check "the near-lossless store is smaller" \
    test "$(wc -c <"$S/c4e.gv")" -lt "$(wc -c <"$S/c4.gv")"

run encode --bits 16 -q 60 c4.tif -o "$S/c4q.gv"
expect_rc "encode --bits 16 -q 60" 0
check "the summary names the trial" grep -q '^trial      e = [0-9]* after [0-9]* tries' "$T/out"
run info --json "$S/c4q.gv"
check "info --json: kind samples, 16 bits, 4 channels, version 7" python3 -c "
import json,sys; j=json.load(open(sys.argv[1]))
assert j['kind']=='samples' and j['bits']==16 and j['channels']==4 and j['version']==7, j
assert j['error_codes'] > 0 and j['max_error'] == j['error_codes'], j" "$T/out"
psnr=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['psnr0'])" "$T/out")
run export --bits 16 "$S/c4q.gv" -o c4q.tif
toraw c4q.tif c4q.raw
check "-q 60: the PSNR info reports ($psnr dB) is the one measured" python3 -c "
import array, math, sys
a = array.array('H', open('c4.raw','rb').read()); b = array.array('H', open('c4q.raw','rb').read())
mse = sum((p - q) ** 2 for p, q in zip(a, b)) / len(a)
p = 10 * math.log10(65535 ** 2 / mse)
assert abs(p - float(sys.argv[1])) < 0.01, (p, sys.argv[1])
assert 60 <= p <= 61, ('-q 60 landed at', p)" "$psnr"

run info "$S/c4.gv"
expect_rc "info" 0
check "info: the channels and the bound" sh -c "
grep -q '^samples      1100 x 700, 4 channels of 16-bit codes' '$T/out' &&
grep -q '^max error    0 (0 codes), lossless' '$T/out'"

# A default window, kept in the store's metadata.
run encode --bits 16 --window '1000,60000;0,65535;900,4200,2;0,40000' c4.tif -o "$S/c4w.gv"
expect_rc "encode --bits 16 --window (one per channel)" 0
run info --json "$S/c4w.gv"
check "the window is the store's display.window" python3 -c "
import json,sys; j=json.load(open(sys.argv[1]))
assert j['metadata']['display.window']=='1000,60000,1.000;0,65535,1.000;900,4200,2.000;0,40000,1.000', j" "$T/out"
run encode --bits 16 --window '0,100;0,100' c4.tif -o "$S/bad.gv"
expect_rc "two windows for four channels are refused" 1
run encode --bits 16 --colours '0000ff;00ff00;ff8000;ffffff' c4.tif -o "$S/c4c.gv"
expect_rc "encode --bits 16 --colours (one per channel)" 0
run info --json "$S/c4c.gv"
check "the colours are the store's display.colours" python3 -c "
import json,sys; j=json.load(open(sys.argv[1]))
assert j['metadata']['display.colours']=='0000ff;00ff00;ff8000;ffffff', j" "$T/out"
crange=$(python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print('%d,%d' % (j['min'], j['max']))" "$T/out")
run encode --bits 16 --colours '0000ff;00ff00' c4.tif -o "$S/bad.gv"
expect_rc "two colours for four channels are refused" 1
run encode --colours '0000ff;00ff00;ff0000' c4.tif -o "$S/bad.gv"
expect_rc "--colours without --bits 16 is a usage error" 2

# ------------------------------------------------------------------- HTTP
run encode synth:300x200 -o "$S/img.gv"
expect_rc "an 8-bit image store beside them" 0
cat >"$T/s.conf" <<EOF2
store_dir = "$S"
threads = 2
access_log = off
gpu = off
EOF2
start_daemon "$T/s.conf"

expect_status "image info" 200 /v1/images/c4
check "the samples object" test \
    "$(json_get "j['samples']['bits'], j['samples']['error_codes'], j['samples']['code_max'], j['channels'], j['format_version']")" \
    = "16 0 65535 4 7"
check "no elevation object" test "$(json_get "'elevation' in j")" = False

R='level=0&x=450&y=300&w=300&h=200'
expect_status "region tiff16" 200 "/v1/images/c4e/region?$R&format=tiff16"
cp "$T/b" r16.tif
run export --bits 16 --region 450,300,300,200 "$S/c4e.gv" -o e16.tif
toraw r16.tif r16.raw
toraw e16.tif e16.raw
check "tiff16 equals export --bits 16 of the same region" cmp -s r16.raw e16.raw
expect_status "region png16 of 4 channels" 200 "/v1/images/c4e/region?$R&format=png16"
cp "$T/b" r16.png
toraw r16.png r16p.raw
check "png16 equals tiff16 (4 channels, no alpha rule applied)" cmp -s r16.raw r16p.raw
expect_status "png16 of 8 channels is 400" 400 '/v1/images/c8/region?level=0&x=0&y=0&w=10&h=10&format=png16'
expect_status "tiff16 of 8 channels" 200 '/v1/images/c8/region?level=0&x=0&y=0&w=10&h=10&format=tiff16'
expect_status "tiff16 of an 8-bit image store is 400" 400 '/v1/images/img/region?level=0&x=0&y=0&w=10&h=10&format=tiff16'

# picture OUT.ppm|OUT.pgm: the last response (a PNG) as PNM, for display.
picture() {
    cp "$T/b" "${1%.*}.png" && oiiotool "${1%.*}.png" -o "$1"
}

# display REF_RAW C W H WINDOW PPM [COLOURS]: the 8-bit picture of the
# rule in docs/API.md from raw codes, against the server's PNG (as
# PPM/PGM); COLOURS "RRGGBB;..." (default: the palette).
display() {
    python3 - "$@" <<'PY'
import array, math, sys
raw, c, w, h, win, ppm = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5], sys.argv[6]
a = array.array('H', open(raw, 'rb').read())
wins = [tuple(x.split(',')) for x in win.split(';')]
def table(wd):
    b, wt = int(wd[0]), int(wd[1]); g = int(round(float(wd[2]) * 1000)) if len(wd) > 2 else 1000
    t = bytearray(65536)
    for v in range(65536):
        if v <= b: t[v] = 0
        elif v >= wt: t[v] = 255
        else:
            x = (v - b) / (wt - b)
            p = x if g == 1000 else math.pow(x, 1000.0 / g)
            t[v] = max(0, min(255, math.floor(255.0 * p + 0.500000001)))
    return t
tabs = [table(wins[0 if len(wins) == 1 else k]) for k in range(c)]
col = [(255,0,0),(0,255,0),(0,0,255),(255,0,255),(0,255,255),(255,255,0),(255,128,0),(255,255,255)]
if len(sys.argv) > 7:
    col = [tuple(int(x[i:i + 2], 16) for i in (0, 2, 4)) for x in sys.argv[7].split(';')]
d = open(ppm, 'rb').read()
parts = d.split(maxsplit=4)
assert parts[1] == str(w).encode() and parts[2] == str(h).encode(), parts[:4]
px = parts[4]
oc = 1 if c == 1 else 3
assert len(px) == w * h * oc, (len(px), w * h * oc)
bad = 0
for i in range(w * h):
    if c == 1:
        want = (tabs[0][a[i]],)
    else:
        acc = [0, 0, 0]
        for k in range(c):
            t = tabs[k][a[i * c + k]]
            for j in range(3): acc[j] += t * col[k][j]
        want = tuple(min(255, (s + 127) // 255) for s in acc)
    got = tuple(px[i * oc:(i + 1) * oc])
    bad += got != want
assert bad == 0, ('pixels differing', bad)
PY
}
W='2000,50000,1.5;0,65535;900,4200;100,60000,0.7'
expect_status "an 8-bit region with a window per channel" 200 "/v1/images/c4e/region?$R&window=$(printf %s "$W" | sed 's/;/%3B/g')"
picture w.ppm
check "the picture is the windows' colours added, as the reference gives" \
    display r16.raw 4 300 200 "$W" w.ppm
expect_status "an 8-bit region of c4w (the store's default window)" 200 "/v1/images/c4w/region?$R"
picture d.ppm
run export --bits 16 --region 450,300,300,200 "$S/c4w.gv" -o w16.tif
toraw w16.tif w16.raw
check "... is the default window's picture" \
    display w16.raw 4 300 200 '1000,60000;0,65535;900,4200,2;0,40000' d.ppm
expect_status "c4w's info" 200 /v1/images/c4w
range=$(json_get "'%d,%d' % (j['samples']['code_min'], j['samples']['code_max'])")
check "... has the default window" test "$(json_get "j['window']")" = \
    '1000,60000,1.000;0,65535,1.000;900,4200,2.000;0,40000,1.000'
expect_status "window=none over the default: the codes' range" 200 "/v1/images/c4w/region?$R&window=none"
picture n.ppm
check "... is the picture of one window from the smallest to the largest code ($range)" \
    display w16.raw 4 300 200 "$range" n.ppm
expect_status "gray: a region of the one-channel store" 200 '/v1/images/g1/region?level=0&x=0&y=0&w=200&h=100&window=20000,40000'
picture g.pgm
run export --bits 16 --region 0,0,200,100 "$S/g1.gv" -o g16.png
toraw g16.png g16.raw
check "... is one gray channel through the window" display g16.raw 1 200 100 '20000,40000' g.pgm
run export --region 450,300,300,200 "$S/c4w.gv" -o x8.png
oiiotool x8.png -o x8.ppm
check "export (8-bit) gives the server's picture with the default window" cmp -s x8.ppm d.ppm

# Colours: the store's (display.colours), and the request's over them.
C4='0000ff;00ff00;ff8000;ffffff'
expect_status "a region of c4c (colours kept at encode)" 200 "/v1/images/c4c/region?$R"
picture cc.ppm
run export --bits 16 --region 450,300,300,200 "$S/c4c.gv" -o c16.tif
toraw c16.tif c16.raw
check "... is the picture in the store's colours" \
    display c16.raw 4 300 200 "$crange" cc.ppm "$C4"
CQ='ff0000;00ffff;ffff00;102030'
expect_status "colours= over them" 200 "/v1/images/c4c/region?$R&colours=$(printf %s "$CQ" | sed 's/;/%3B/g')"
picture cq.ppm
check "... is the picture in the request's colours" \
    display c16.raw 4 300 200 "$crange" cq.ppm "$CQ"
expect_status "IIIF with colours= gives the same picture" 200 \
    "/iiif/3/c4c/450,300,300,200/max/0/default.png?colours=$(printf %s "$CQ" | sed 's/;/%3B/g')"
picture icq.ppm
check "... byte for byte" cmp -s icq.ppm cq.ppm
expect_status "malformed colours are 400" 400 "/v1/images/c4c/region?$R&colours=12345"
expect_status "two colours for four channels are 400" 400 "/v1/images/c4c/region?$R&colours=ff0000%3B00ff00"
expect_status "colours for a one-channel store are 400" 400 '/v1/images/g1/region?level=0&x=0&y=0&w=10&h=10&colours=ff0000'
expect_status "colours for an 8-bit image store are 400" 400 '/v1/images/img/region?level=0&x=0&y=0&w=10&h=10&colours=ff0000%3B00ff00%3B0000ff'

expect_status "IIIF info.json" 200 /iiif/3/c4/info.json
expect_status "IIIF full/max" 200 /iiif/3/c4/full/max/0/default.png
expect_status "IIIF a region at full size, with a window" 200 \
    "/iiif/3/c4e/450,300,300,200/max/0/default.png?window=$(printf %s "$W" | sed 's/;/%3B/g')"
picture iw.ppm
check "IIIF gives the region's picture" cmp -s iw.ppm w.ppm
expect_status "a window past 255 on an 8-bit image store is 400" 400 \
    '/v1/images/img/region?level=0&x=0&y=0&w=10&h=10&window=0,300'
expect_status "root as 16-bit PNG" 200 '/v1/images/c4/root'
check "the root PNG is 16-bit with 4 channels" sh -c "oiiotool --info -v '$T/b' 2>/dev/null | grep -q '4 channel, uint16 png'"
expect_status "root of 8 channels as PNG is 400" 400 '/v1/images/c8/root'
expect_status "root of 8 channels raw" 200 '/v1/images/c8/root?format=raw'
check "raw root: 8 channels of 2 bytes" test "$(wc -c <"$T/b")" -eq \
    "$(( $(header X-Width) * $(header X-Height) * 16 ))"

stop_daemon
check "the daemon exits cleanly" test "$drc" -eq 0
no_sanitizer_report

# ------------------------------------------------------------ bad options
run encode --bits 12 c4.tif -o "$S/x.gv"
expect_rc "--bits 12 is refused" 2
run encode --bits 16 --range 0:1000 c4.tif -o "$S/x.gv"
expect_rc "--bits 16 with --range is refused" 2
run encode --bits 16 --height g1.png -o "$S/x.gv"
expect_rc "--bits 16 with --height is refused" 2
run encode --bits 16 -q 60 --max-error 3 c4.tif -o "$S/x.gv"
expect_rc "-q with --max-error is refused" 2
run export --bits 16 "$S/img.gv" -o x.png
expect_rc "export --bits 16 of an 8-bit store is refused" 2
check "no store is left behind" test ! -e "$S/x.gv"
done_testing
