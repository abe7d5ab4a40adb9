#!/bin/sh
# make_corpus.sh - regenerates the seed corpora in tests/fuzz/corpus/.
#
#   tests/fuzz/make_corpus.sh GIGAVIEW-BINARY
#
# store/: small valid stores (RGB and gray, one and several pages and
# levels, tiled and root-only) plus truncated, bit-flipped and
# header- and index-damaged variants of one of them.  Needs oiiotool.  tile/: tile buffers taken from those stores
# at several rates, each prefixed with fuzz_tile's selector byte (bit 0:
# 3 channels; bits 1-2: quadrant), plus a few malformed ones, and
# context-coded (EX) tiles of a photograph with hostile variants.  The
# encoder is deterministic, so rerunning gives the same files.
set -eu
gv=${1:?usage: make_corpus.sh GIGAVIEW-BINARY}
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Past findings (finding-*) stay: make check replays them forever.
mkdir -p "$here/corpus/store" "$here/corpus/tile"
find "$here/corpus/store" "$here/corpus/tile" -type f ! -name 'finding-*' -delete

# Checkerboards: their roots deflate to almost nothing, so the corpus
# stays small while the tiles still get rates 1 and 2.
oiiotool --pattern checker:width=37:height=23:color1=0.1,0.6,0.3:color2=0.9,0.2,0.5 \
    600x300 3 -d uint8 -o "$tmp/ck.png"
oiiotool --pattern fill:topleft=0:topright=1:bottomleft=0.5:bottomright=0.2 1100x700 1 \
    --pattern checker:width=41:height=29:color1=0:color2=0.3 1100x700 1 --add \
    -d uint8 -o "$tmp/g.png"
"$gv" encode "$tmp/ck.png" -r 2 -q 40 --quiet -o "$tmp/rgb-600x300.gv"
"$gv" encode "$tmp/g.png" -r 1 -q 30 --quiet -o "$tmp/gray-1100x700.gv"
"$gv" encode synth:1x1 --quiet -o "$tmp/rgb-1x1.gv"
"$gv" encode synth:100x60:gray --quiet -o "$tmp/gray-100x60.gv"
"$gv" encode synth:4200x520:gray -r 1 -q 10 --quiet -o "$tmp/gray-4200x520.gv"
# Tiles at several rates (for tile/ only).
"$gv" encode synth:514x514:gray -r 1 -q 40 --quiet -o "$tmp/r1.gv"
"$gv" encode synth:514x514:gray -r 5 -q 40 --quiet -o "$tmp/r5.gv"
"$gv" encode synth:514x514 -r 7 -q 45 --quiet -o "$tmp/r7.gv"
"$gv" encode synth:514x514:gray -r 12 -q 60 --quiet -o "$tmp/r12.gv"
# Context-coded (EX) tiles: a photograph at a middle rate, RGB and gray.
"$gv" encode "$here/../data/picos-1100x700.jpg" -q 34 --quiet -o "$tmp/ex.gv"
oiiotool "$here/../data/picos-1100x700.jpg" --ch R -o "$tmp/picos-gray.png"
"$gv" encode "$tmp/picos-gray.png" -q 38 --rd --quiet -o "$tmp/exg.gv"

python3 - "$tmp" "$here/corpus" <<'PY'
import os, struct, sys, zlib
tmp, out = sys.argv[1], sys.argv[2]

def crc(b):
    return zlib.crc32(b) & 0xffffffff

def save(kind, name, data):
    with open(os.path.join(out, kind, name), "wb") as f:
        f.write(data)

stores = ["rgb-600x300", "gray-1100x700", "rgb-1x1", "gray-100x60",
          "gray-4200x520"]
for name in stores:
    d = open(os.path.join(tmp, name + ".gv"), "rb").read()
    save("store", name, d)
for name in ["rgb-600x300"]:
    d = bytearray(open(os.path.join(tmp, name + ".gv"), "rb").read())
    n = len(d)
    save("store", name + "-trunc-header", bytes(d[:100]))
    save("store", name + "-trunc-half", bytes(d[:n // 2]))
    save("store", name + "-trunc-last", bytes(d[:n - 1]))
    for i, at in enumerate([20, 130, n // 3, n - 10]):  # header, page table, tile, index
        e = bytearray(d)
        e[at] ^= 0x10
        save("store", "%s-flip%d" % (name, i), bytes(e))
    # A header that claims a huge image, with its CRC fixed.
    e = bytearray(d)
    struct.pack_into("<II", e, 12, 0x7fffffff, 3)
    struct.pack_into("<I", e, 124, crc(bytes(e[:124])))
    save("store", name + "-huge-header", bytes(e))
    # Root sides (header bytes 96-97, format version 6) out of range or
    # giving other levels than the header's, CRC fixed.
    for side in (0, 64, 513):
        e = bytearray(d)
        struct.pack_into("<HH", e, 8, 6, 128)
        struct.pack_into("<H", e, 96, side)
        struct.pack_into("<I", e, 124, crc(bytes(e[:124])))
        save("store", "%s-root-side-%d" % (name, side), bytes(e))
    # A page index entry pointing past the end, index CRC fixed.
    index, pages = struct.unpack_from("<QQ", d, 56)
    if pages:
        e = bytearray(d)
        struct.pack_into("<Q", e, index, n + 1000)
        struct.pack_into("<I", e, index + 16 * pages,
                         crc(bytes(e[index:index + 16 * pages])))
        save("store", name + "-bad-index", bytes(e))

def tiles(path):
    d = open(path, "rb").read()
    channels = d[20]
    index, pages = struct.unpack_from("<QQ", d, 56)
    for p in range(pages):
        off, size, _ = struct.unpack_from("<QII", d, index + 16 * p)
        page = d[off:off + size]
        for s in range(64):
            t_off, t_len = struct.unpack_from("<II", page, 16 + 8 * s)
            if t_len:
                yield channels, page[t_off:t_off + t_len]

for name in ["r1", "r5", "r7", "r12"]:
    for k, (c, t) in enumerate(tiles(os.path.join(tmp, name + ".gv"))):
        if k >= (2 if name in ("r1", "r5") else 1):
            break
        sel = (1 if c == 3 else 0) | (k % 4) << 1
        save("tile", "%s-c%d-%d" % (name, c, k), bytes([sel]) + t)
        if k == 0 and name in ("r1", "r5"):
            rate = t[0]
            save("tile", "%s-c%d-trunc" % (name, c), bytes([sel]) + t[:len(t) // 2])
            bad = bytearray(t)
            bad[0] = 13
            save("tile", "%s-c%d-rate13" % (name, c), bytes([sel]) + bytes(bad))
            # The same bytes read as the other channel count.
            save("tile", "%s-c%d-as-c%d" % (name, c, 4 - c),
                 bytes([sel ^ 1]) + t)
# EX tiles and hostile variants of one: each header field out of range,
# a context map entry past the models, a stream length past 516 words, a
# flipped stream word, truncation.
def ex_tiles(name):
    return [(c, t) for c, t in tiles(os.path.join(tmp, name + ".gv")) if t[0] & 0x40]
for name in ["ex", "exg"]:
    for k, (c, t) in enumerate(ex_tiles(name)[:2]):
        sel = (1 if c == 3 else 0) | (k % 4) << 1
        save("tile", "%s-c%d-%d" % (name, c, k), bytes([sel]) + t)
c, t = ex_tiles("ex")[0]
sel = 1 if c == 3 else 0
n, contexts = struct.unpack_from("<H", t, 2)[0], t[1]
mapat = (4 + n * 4 * c + 2 * n + 3) & ~3
lengths = mapat + 8 + 16 * contexts
def variant(label, edits, cut=None):
    b = bytearray(t)
    for at, val in edits:
        b[at] = val
    save("tile", "ex-" + label, bytes([sel]) + bytes(b[:cut] if cut else b))
variant("rate2", [(0, 0xc2)])
variant("no-e", [(0, 0x40 | (t[0] & 15))])
variant("n7", [(2, 7), (3, 0)])
variant("n-huge", [(3, 0xff)])
variant("contexts0", [(1, 0)])
variant("contexts9", [(1, 9)])
variant("map-past", [(mapat, 0xff)])
variant("stream-517", [(lengths, 517 & 255), (lengths + 1, 517 >> 8)])
variant("word-flip", [(lengths + 516 + 9, t[lengths + 516 + 9] ^ 0x5a)])
variant("trunc", [], cut=len(t) // 2 & ~3)
save("tile", "empty", bytes([0]))
save("tile", "rate0-gray", bytes([0, 0, 0, 0, 0]))
save("tile", "rate0-rgb", bytes([1, 0, 0, 0, 0]))
PY
du -sh "$here/corpus"
