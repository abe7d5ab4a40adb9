#!/bin/sh
# make_corpus_inputs.sh - regenerates the seed corpora of the input-parser
# targets: tests/fuzz/corpus/settings, batch, imageio and listen_fds
# (make_corpus.sh does store and tile).
#
#   tests/fuzz/make_corpus_inputs.sh
#
# settings/: the shipped conf/gigaviewd.conf, small valid files in every
# value style (quotes, suffixes, trailing comments, CRLF) and one file per
# kind of error.  batch/: fuzz_batch inputs - a selector byte (bit 0: JSON,
# the rest: the tile limit minus one, times two) then a query value or a
# JSON body, valid and invalid.  imageio/: fuzz_imageio inputs - a
# selector byte (the extension, index into its table) then a tiny image in
# every format and sample type the bridge handles, tiled and striped,
# plus a few damaged ones and a PNG whose header claims 100000x100000
# pixels (past the 1 MP cap), and the JPEG and PNG variants of
# tests/data/native for the native readers (native-*).  Needs oiiotool
# and python3.  Deterministic.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
top=$(cd "$here/../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Past findings (finding-*) stay: make check replays them forever.
for d in settings batch imageio listen_fds; do
    mkdir -p "$here/corpus/$d"
    find "$here/corpus/$d" -type f ! -name 'finding-*' -delete
done

# ------------------------------------------------------------- images
P="--pattern checker:width=4:height=3:color1=0.1,0.6,0.3:color2=0.9,0.2,0.5 17x13 3"
G="--pattern checker:width=5:height=2:color1=0.2:color2=0.7 11x9 1"
oiiotool --nosoftwareattrib $P -d uint8 -o "$tmp/rgb8.png"
oiiotool --nosoftwareattrib $G -d uint16 -o "$tmp/gray16.png"
oiiotool --nosoftwareattrib $P --ch R,G,B,A=0.5 -d uint8 -o "$tmp/rgba8.png"
oiiotool --nosoftwareattrib $G --ch Y,A=1.0 -d uint8 -o "$tmp/graya8.png"
oiiotool --nosoftwareattrib $P -d uint8 -o "$tmp/rgb.jpg"
oiiotool --nosoftwareattrib $G -d uint8 -o "$tmp/gray.jpg"
oiiotool --nosoftwareattrib $P -d uint8 -o "$tmp/strip8.tif"
oiiotool --nosoftwareattrib $P -d uint16 --tile 16 16 -o "$tmp/tile16.tif"
oiiotool --nosoftwareattrib $G -d float --tile 16 16 -o "$tmp/tilef.tif"
oiiotool --nosoftwareattrib $P -d half --tile 16 16 -o "$tmp/tileh.exr"
oiiotool --nosoftwareattrib $P -d float -o "$tmp/scanf.exr"
oiiotool --nosoftwareattrib $P -d uint8 -o "$tmp/rgb.webp"
oiiotool --nosoftwareattrib $P -d uint8 -o "$tmp/rgb.gif"
oiiotool --nosoftwareattrib $P -d uint8 -o "$tmp/rgb.bmp"
oiiotool --nosoftwareattrib $P -d uint8 -o "$tmp/rgb.ppm"
oiiotool --nosoftwareattrib $P -o "$tmp/rgb.hdr"
oiiotool --nosoftwareattrib $P -d uint8 -o "$tmp/rgb.tga"
oiiotool --nosoftwareattrib $P -d uint16 -o "$tmp/rgb16.dpx"
oiiotool --nosoftwareattrib $P -d uint8 -o "$tmp/rgb.sgi"
oiiotool --nosoftwareattrib $P -d uint8 -o "$tmp/rgb.ico"
oiiotool --nosoftwareattrib $P -d uint8 -o "$tmp/rgb.rla"
oiiotool --nosoftwareattrib $P -d uint8 -o "$tmp/rgb.jp2"
oiiotool --nosoftwareattrib $G -d uint16 -o "$tmp/gray16.fits"

python3 - "$tmp" "$here/corpus" <<'PY'
import os, struct, sys, zlib
tmp, out = sys.argv[1], sys.argv[2]
# The extension table of fuzz_imageio.c, in order.
EXT = ["png", "jpg", "tif", "exr", "webp", "gif", "bmp", "ppm",
       "hdr", "tga", "psd", "dpx", "sgi", "ico", "rla", "bin", "jp2", "fits"]

def save(kind, name, data):
    with open(os.path.join(out, kind, name), "wb") as f:
        f.write(data)

def img(name, ext=None):
    data = open(os.path.join(tmp, name), "rb").read()
    e = ext or name.rsplit(".", 1)[1]
    save("imageio", name.replace(".", "-") + ("-as-" + ext if ext else ""),
         bytes([EXT.index(e)]) + data)
    return data

for name in sorted(os.listdir(tmp)):
    img(name)
# The same bytes under no known extension: every reader is tried.
img("rgb8.png", "bin")
img("tile16.tif", "bin")
# Damaged: truncated, and a flipped byte in the middle.  No truncated
# PNG: OpenImageIO 2.4.7 leaks 31 bytes on one (see fuzz_imageio.c), which
# make check VALGRIND=1 would count.
for name in ["rgb8.png", "rgb.jpg", "tile16.tif", "tileh.exr"]:
    d = open(os.path.join(tmp, name), "rb").read()
    e = EXT.index(name.rsplit(".", 1)[1])
    if e != 0:
        save("imageio", name.replace(".", "-") + "-trunc", bytes([e]) + d[:len(d) // 2])
    f = bytearray(d)
    f[len(f) // 2] ^= 0x40
    save("imageio", name.replace(".", "-") + "-flip", bytes([e]) + bytes(f))

def chunk(kind, data):
    return (struct.pack(">I", len(data)) + kind + data +
            struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff))
# A PNG header claiming 100000x100000 RGB: refused by the cap.
ihdr = struct.pack(">IIBBBBB", 100000, 100000, 8, 2, 0, 0, 0)
save("imageio", "png-huge-header", bytes([0]) + b"\x89PNG\r\n\x1a\n" +
     chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 100)) +
     chunk(b"IEND", b""))
# A palette PNG (colour type 3), 4x2, which oiiotool does not write.
ihdr = struct.pack(">IIBBBBB", 4, 2, 8, 3, 0, 0, 0)
plte = bytes([255, 0, 0, 0, 255, 0, 0, 0, 255])
rows = b"\0\0\1\2\0" + b"\0\2\1\0\1"
save("imageio", "png-palette", bytes([0]) + b"\x89PNG\r\n\x1a\n" +
     chunk(b"IHDR", ihdr) + chunk(b"PLTE", plte) +
     chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))
# A 16-bit binary PGM (maxval 65535) and a 10-bit one (maxval 1023).
save("imageio", "pgm16", bytes([EXT.index("ppm")]) + b"P5\n3 2\n65535\n" +
     struct.pack(">6H", 0, 1, 1000, 30000, 65534, 65535))
save("imageio", "pgm10", bytes([EXT.index("ppm")]) + b"P5\n3 2\n1023\n" +
     struct.pack(">6H", 0, 1, 100, 512, 1022, 1023))
save("imageio", "empty-png", bytes([0]))
save("imageio", "text-jpg", bytes([1]) + b"this is not a picture\n")

# ------------------------------------------------------------- batch
def batch(name, json, limit, body):
    save("batch", name, bytes([(limit - 1) << 1 | json]) + body)
batch("q-one", 0, 8, b"0,0,0")
batch("q-three", 0, 8, b"0,5,3;2,1,0;7,0,0")
batch("q-max", 0, 128, b"2147483647,2147483647,2147483647")
batch("q-over-max", 0, 8, b"0,0,2147483648")
batch("q-leading-zeros", 0, 8, b"0000000000000000001,2,3")
batch("q-trailing-semi", 0, 8, b"0,0,0;")
batch("q-empty", 0, 8, b"")
batch("q-pair", 0, 8, b"0,0")
batch("q-sign", 0, 8, b"0,+1,0")
batch("q-limit", 0, 2, b"0,0,0;0,0,1;0,0,2")
batch("q-nul", 0, 8, b"0,0,0\0;1,1,1")
batch("j-one", 1, 8, b'{"tiles":[[0,0,0]]}')
batch("j-five", 1, 8, b'{"tiles":[[0,0,0],[0,5,3],[2,1,0],[0,99,0],[7,0,0]]}')
batch("j-extra", 1, 8, b'{"x":{"y":[1,2]},"tiles":[[1,2,3]]}')
batch("j-dup", 1, 8, b'{"tiles":[[0,0,0]],"tiles":[[1,1,1]]}')
batch("j-negative", 1, 8, b'{"tiles":[[0,-1,0]]}')
batch("j-float", 1, 8, b'{"tiles":[[0,1.5,0]]}')
batch("j-huge", 1, 8, b'{"tiles":[[0,99999999999999999999,0]]}')
batch("j-pair", 1, 8, b'{"tiles":[[0,0]]}')
batch("j-empty", 1, 8, b'{"tiles":[]}')
batch("j-limit", 1, 2, b'{"tiles":[[0,0,0],[0,0,0],[0,0,0]]}')
batch("j-unterminated", 1, 8, b'{"tiles":[[0,0,0]')
batch("j-deep", 1, 8, b'{"tiles":' + b"[" * 3000 + b"]" * 3000 + b"}")
batch("j-not-object", 1, 8, b"[[0,0,0]]")
batch("j-nul", 1, 8, b'{"tiles":[[0,0,0]]}\0')
PY

# The native JPEG, PNG and TIFF readers (lib/imageio/native_*.c): every
# variant of tests/data/native (colour types, depths, subsampling,
# progressive, arithmetic, interlaced, TIFF codecs, tiles, strips,
# byte orders, BigTIFF, and the ones they leave to the module: CMYK,
# palette, alpha, MINISWHITE, JPEG-in-TIFF), truncated and damaged
# copies of a few, and JPEGs and interlaced PNGs whose headers claim sizes they cannot hold.  Truncated PNGs are safe here: the native reader takes
# them, not OpenImageIO's leaking one.
python3 - "$top/tests/data/native" "$here/corpus" <<'PY'
import os, struct, sys, zlib
src, out = sys.argv[1], sys.argv[2]
def save(name, data):
    with open(os.path.join(out, "imageio", name), "wb") as f:
        f.write(data)
for name in sorted(os.listdir(src)):
    if not name.endswith((".jpg", ".png", ".tif")):
        continue
    e = 1 if name.endswith(".jpg") else 2 if name.endswith(".tif") else 0
    d = open(os.path.join(src, name), "rb").read()
    stem = "native-" + name.replace(".", "-")
    save(stem, bytes([e]) + d)
    if name in ("s420.jpg", "progressive.jpg", "rgb16.png", "palette4.png",
                "rgb8-lzw-tiled.tif", "rgb16-zip.tif",
                "rgb8-bigtiff-be-tiled.tif"):
        save(stem + "-trunc", bytes([e]) + d[:len(d) * 2 // 3])
        f = bytearray(d)
        f[len(f) // 2] ^= 0x40
        save(stem + "-flip", bytes([e]) + bytes(f))
    # Hostile frame headers: a progressive or multi-scan JPEG claiming
    # 1000 x 1000 (within the target's 1 MP cap: refused because 863
    # bytes cannot code its first scan's blocks) and 30000 x 30000
    # (2.5 GiB of coefficients: refused before libjpeg allocates them,
    # lib/imageio/native_jpeg.c check_limits).
    if name in ("progressive.jpg", "multiscan.jpg"):
        i = 2
        while d[i + 1] not in (0xC0, 0xC2):
            i += 2 + (d[i + 2] << 8 | d[i + 3])
        for side in (1000, 30000):
            f = bytearray(d)
            f[i + 5:i + 9] = side.to_bytes(2, "big") * 2
            save(stem + "-claims-%d" % side, bytes([e]) + bytes(f))
    # Hostile IHDRs: an interlaced PNG, held whole while it is read,
    # claiming 1000 x 1000 RGB (within the target's 1 MP cap: 3 MB, then
    # its data runs out) and 12000 x 12000 RGBA of 16 bits (1.1 GiB:
    # refused before it is allocated, lib/imageio/native_png.c, here
    # already by the cap).
    if name == "rgb8-interlaced.png":
        for side, depth, color in ((1000, 8, 2), (12000, 16, 6)):
            f = bytearray(d)
            f[16:29] = struct.pack(">IIBBBBB", side, side, depth, color, 0,
                                   0, 1)
            f[29:33] = struct.pack(">I", zlib.crc32(bytes(f[12:29])))
            save(stem + "-claims-%d" % side, bytes([e]) + bytes(f))
        # A 4 x 4 Photoshop file with this JPEG as its thumbnail, whole
        # and claiming 30000 x 30000 (lib/imageio/psd_thumbnail.c).
        if name == "progressive.jpg":
            for suffix, jpg in (("", d), ("-claims-30000", bytes(f))):
                j = jpg + b"\0" * (len(jpg) & 1)
                res = (b"8BIM" + struct.pack(">HHI", 1036, 0, 28 + len(jpg)) +
                       struct.pack(">IIIIIIHH", 1, 61, 45, 184, 184 * 45,
                                   len(jpg), 24, 1) + j)
                psd = (b"8BPS" + struct.pack(">H6xHIIHH", 1, 3, 4, 4, 8, 3) +
                       struct.pack(">II", 0, len(res)) + res +
                       struct.pack(">IH", 0, 0) + bytes(48))
                save("psd-thumbnail" + suffix, bytes([10]) + psd)
PY

# TIFFs of tests/data/native/limits (make-tiff-limits.py there): JPEG in
# strips and tiles, with JPEGTables, BigTIFF, and headers claiming more
# decoder memory than the limit (lib/imageio/tiff_limits.c).
for f in "$top"/tests/data/native/limits/*.tif; do
    n=$(basename "$f" .tif)
    { printf '\002'; cat "$f"; } >"$here/corpus/imageio/limits-$n-tif"
done

# ------------------------------------------------------------- settings
s=$here/corpus/settings
cp "$top/conf/gigaviewd.conf" "$s/shipped.conf"
cat >"$s/minimal.conf" <<'EOF'
store_dir = "/srv/stores"
port = 0
EOF
cat >"$s/styles.conf" <<'EOF'
# every value style
listen = ::1
port = 8080   # a trailing comment
cache_bytes = 1G
decoder_cache_bytes = 64MiB
max_region_pixels = 4m
max_upscale = 2.5
cors_origin = "https://a.example#b"
auth_token = ""
log_level = debug
gpu = off
jpeg_quality = 100
	threads = 8
EOF
printf 'port = 80\r\nlog_level = warn\r\n' >"$s/crlf.conf"
printf 'port = 1' >"$s/no-newline.conf"
: >"$s/empty.conf"
echo 'bogus_key = 1' >"$s/unknown-key.conf"
echo 'port = 70000' >"$s/out-of-range.conf"
echo 'threads = -1' >"$s/negative.conf"
echo 'cache_bytes = 12Q' >"$s/bad-suffix.conf"
echo 'cache_bytes = 17179869184T' >"$s/suffix-overflow.conf"
echo 'threads = 99999999999999999999999' >"$s/overflow.conf"
echo 'max_upscale = nan' >"$s/nan.conf"
echo 'max_upscale = 1e400' >"$s/inf.conf"
echo 'log_level = loud' >"$s/bad-level.conf"
echo 'gpu = maybe' >"$s/bad-gpu.conf"
echo 'no equals sign' >"$s/no-equals.conf"
echo 'listen = "127.0.0.1' >"$s/unterminated-quote.conf"
echo 'listen = "' >"$s/lone-quote.conf"
python3 -c 'print("listen = " + "x" * 300)' >"$s/string-too-long.conf"
python3 -c 'print("# " + "y" * 5000)' >"$s/line-too-long.conf"
printf 'port = 1\n\0 = 2\n' >"$s/nul.conf"

# ------------------------------------------------------------- listen_fds
# fuzz_listen_fds inputs: a byte saying which of LISTEN_PID, LISTEN_FDS,
# LISTEN_FDNAMES are set (bits 0-2), then their values on three lines; an
# '@' in LISTEN_PID is the replaying process's pid.  Valid activations,
# other processes', and hostile numbers (signs, spaces, hex, overflow).
l=$here/corpus/listen_fds
lf() { printf "$2" >"$l/$1"; }
lf ok '\007@\n1\nhttp'
lf ok-no-names '\003@\n1\n'
lf leading-zeros '\003000@\n0001\n'
lf two '\007@\n2\nhttp:admin'
lf zero '\003@\n0\n'
lf empty-fds '\003@\n\n'
lf no-fds '\005@\n\nx'
lf no-pid '\006\n1\nhttp'
lf empty-pid '\003\n1\n'
lf other-pid '\0031\n1\n'
lf pid-suffix '\003@0\n1\n'
lf pid-twice '\003@@\n1\n'
lf pid-sign '\003+@\n1\n'
lf pid-minus '\003-@\n1\n'
lf pid-space '\003 @\n1\n'
lf pid-trailing-space '\003@ \n1\n'
lf pid-hex '\0030x1\n1\n'
lf pid-overflow '\003@99999999999999999999999999\n1\n'
lf pid-2to31 '\0032147483648\n1\n'
lf fds-sign '\003@\n+1\n'
lf fds-minus '\003@\n-1\n'
lf fds-space '\003@\n 1\n'
lf fds-newline '\003@\n1\n\n'
lf fds-hex '\003@\n0x1\n'
lf fds-overflow '\003@\n99999999999999999999999999999999\n'
lf fds-2to31 '\003@\n2147483648\n'
lf fds-max '\003@\n2147483647\n'
lf fds-long "\\003@\\n$(python3 -c 'print("7" * 100, end="")')\\n"
lf fds-nul '\003@\n1\0002\n'
lf names-long "\\007@\\n1\\n$(python3 -c 'print("n:" * 2000, end="")')"
lf names-only '\004\n\nhttp'
lf nothing-set '\000@\n1\nhttp'
lf garbage '\377\377\377\n\377\n\377'
du -sh "$l"
du -sh "$here/corpus/settings" "$here/corpus/batch" "$here/corpus/imageio"
