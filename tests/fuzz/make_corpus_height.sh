#!/bin/sh
# make_corpus_height.sh - regenerates tests/fuzz/corpus/height: the tile
# buffers of two small height stores (smooth synthetic terrain at a 4 m
# bound, and a flat field whose tiles are prediction-only), each prefixed
# with fuzz_height's selector byte (bits 0-1: quadrant), plus truncated,
# bit-flipped and header-damaged variants.  Deterministic.
#
#   tests/fuzz/make_corpus_height.sh GIGAVIEW-BINARY
set -eu
gv=${1:?usage: make_corpus_height.sh GIGAVIEW-BINARY}
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
out=$here/corpus/height
mkdir -p "$out"
find "$out" -type f ! -name 'finding-*' -delete
"$gv" encode --height --quiet --max-error 4 synth-height:600x520 -o "$tmp/s.gv"
oiiotool --pattern constant:color=0.25 600x520 1 -d uint16 -o "$tmp/flat.png"
"$gv" encode --height --quiet "$tmp/flat.png" -o "$tmp/f.gv"
python3 - "$tmp/s.gv" "$tmp/f.gv" "$out" <<'PY'
import struct, sys
out = sys.argv[3]
def tiles(path):
    b = open(path, 'rb').read()
    index, pages = struct.unpack_from('<QQ', b, 56)
    for p in range(pages):
        off, size = struct.unpack_from('<QI', b, index + 16 * p)
        page = b[off:off + size]
        for s in range(64):
            to, ts = struct.unpack_from('<II', page, 16 + 8 * s)
            if ts:
                yield p, s, page[to:to + ts]
n = 0
for name, path in (('synth', sys.argv[1]), ('flat', sys.argv[2])):
    for p, s, t in tiles(path):
        sel = bytes([s & 3])
        open(f'{out}/{name}-p{p}-s{s}', 'wb').write(sel + t)
        if name == 'synth' and n == 0 and len(t) > 400:
            n = 1
            open(f'{out}/truncated', 'wb').write(sel + t[:len(t) // 2])
            open(f'{out}/short-by-4', 'wb').write(sel + t[:-4])
            for k, at in enumerate((2, 5, 7, 140, 300, len(t) // 2, len(t) - 6)):
                m = bytearray(t)
                m[at] ^= 0x41
                open(f'{out}/flip{k}', 'wb').write(sel + bytes(m))
            m = bytearray(t); m[4] = 0; m[5] = 0
            open(f'{out}/no-contexts', 'wb').write(sel + bytes(m))
            m = bytearray(t); m[0] = 0
            open(f'{out}/mode0-long', 'wb').write(sel + bytes(m))
open(f'{out}/empty', 'wb').write(b'\x00')
PY
