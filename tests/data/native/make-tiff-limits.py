#!/usr/bin/env python3
"""make-tiff-limits.py - writes the TIFFs of tests/data/native/limits/, the
files lib/imageio/tiff_limits.c checks against --max-decoder-memory before
OpenImageIO opens them (tests/test_native_read.c, tests/cli_bad_input.sh
and the fuzz_imageio seeds read them).  Run from the repository root:

    python3 tests/data/native/make-tiff-limits.py tests/data/native/limits

Needs python3 and jpegtran (libjpeg-turbo-progs): each TIFF is written
tag by tag (TIFF 6.0, section 2; BigTIFF as libtiff writes it), and the
JPEG in a JPEG-compressed strip or tile is tests/data/native/
progressive.jpg (61x45, 4:2:0, progressive), s420.jpg (the same pixels,
baseline) or rgb.jpg made progressive by jpegtran (RGB, no subsampling),
their frame header's size patched where a file claims more than it holds.
With --large DIR it writes instead the deflate bombs the resident sizes
in lib/imageio/tiff_limits.c were measured on (a few hundred KB to 2 MB
each, not kept in the repository).

Real files (they decode, and the tests read them at their exact limit):
  jpeg-progressive-61x45.tif   the progressive JPEG as the one strip of a
                               YCbCr JPEG TIFF (Compression 7)
  jpeg-progressive-tiled.tif   the same as the one 64x48 tile of a tiled
                               TIFF (the JPEG claims the whole tile)
  jpeg-progressive-tables.tif  as the first, its quantization and Huffman
                               tables moved to JPEGTables (347), the strip
                               an abbreviated stream, as libtiff writes
  jpeg-progressive-big.tif     as the first, big-endian BigTIFF
  jpeg-rgb-progressive.tif     the RGB progressive JPEG as the one strip
                               of an RGB JPEG TIFF (read without libtiff's
                               RGBA interface)
Hostile files (a few KB, headers claiming what they do not hold):
  jpeg-progressive-claims-30000.tif  30000x30000 in one strip whose JPEG
                               is progressive and claims 30000x30000
  jpeg-baseline-claims-30000.tif     the same, its JPEG baseline
  jpeg-rgb-progressive-claims-15000.tif  15000x15000 RGB in one strip
                               (675 MB decoded), its progressive JPEG
                               claiming 15000x15000 (1.3 GB of coefficients)
  jpeg-progressive-claims-tile.tif   a tiled 30016x30016 image of one
                               tile, progressive, claiming 30016x30016
  palette-claims-30000.tif     8-bit palette, LZW, 30000x30000 in one strip
  ycbcr-claims-30000.tif       uncompressed YCbCr 4:2:0, 30000x30000
  gray-claims-tile.tif         8-bit grey, LZW, one 65536x65536 tile
  gray-64x64-tile-65536.tif    the same tile for an image of 64x64 (tiles
                               may overhang the image: within any pixel
                               limit, 4 GiB of tile)
  gray-tile-duplicate.tif, gray-tile-strip-offsets.tif,
  gray-tile-bad-entry.tif, gray-tile-long-offsets.tif
                               the 64x64 one as libtiff reads it from a
                               directory with a later duplicate TileWidth,
                               the tiles under StripOffsets, a broken
                               Photometric entry, TileOffsets claiming
                               more entries than the file holds
  bilevel-tile-40000.tif       1-bit grey, 64x64, one 40000x40000 tile:
                               200 MB as stored, 1.6 GB as delivered
  jpeg-rps-claims.tif          the RGB one with a RowsPerStrip of
                               1095582055 for its 45 rows
  jpeg-rgb-progressive-claims-1000.tif  1000x1000 RGB in one strip, its
                               progressive JPEG claiming as much (6 MB of
                               coefficients: within the limit, then its
                               data runs out)
"""
import os
import struct
import subprocess
import sys
import zlib

SHORT, LONG, UNDEFINED, LONG8 = 3, 4, 7, 16
SIZES = {SHORT: 2, LONG: 4, UNDEFINED: 1, LONG8: 8}


def tiff(entries, chunks, be=False, big=False, offsets_tag=273,
         counts_tag=279):
    """A TIFF of one directory: entries (tag, type, values), the chunks
    (strips or tiles) appended after it, their offsets and byte counts
    filled into offsets_tag and counts_tag."""
    e = ">" if be else "<"
    head = (b"MM" if be else b"II")
    if big:
        head += struct.pack(e + "HHHQ", 43, 8, 0, 16)
    else:
        head += struct.pack(e + "HI", 42, 8)
    ofs_type = LONG8 if big else LONG
    entries = [x for x in entries if x[0] not in (offsets_tag, counts_tag)]
    entries.append((offsets_tag, ofs_type, [0] * len(chunks)))
    entries.append((counts_tag, ofs_type, [len(c) for c in chunks]))
    entries.sort(key=lambda x: x[0])
    n = len(entries)
    count_fmt, ent_size, inline = ("Q", 20, 8) if big else ("H", 12, 4)
    ifd_size = (8 if big else 2) + n * ent_size + (8 if big else 4)
    data_at = len(head) + ifd_size
    # lay out the values that do not fit in an entry, then the chunks
    blobs, at = [], data_at
    for tag, typ, vals in entries:
        size = len(vals) if typ == UNDEFINED else SIZES[typ] * len(vals)
        if size > inline:
            blobs.append((tag, at))
            at += size + (size & 1)
    chunk_at = []
    for c in chunks:
        chunk_at.append(at)
        at += len(c)
    out = bytearray(head)
    out += struct.pack(e + count_fmt, n)
    extra = bytearray()
    blob_at = dict(blobs)
    for tag, typ, vals in entries:
        if tag == offsets_tag:
            vals = chunk_at
        raw = (bytes(vals) if typ == UNDEFINED else
               b"".join(struct.pack(e + {SHORT: "H", LONG: "I",
                                         LONG8: "Q"}[typ], v) for v in vals))
        count = len(vals)
        if tag in blob_at:
            field = struct.pack(e + ("Q" if big else "I"), blob_at[tag])
            extra += raw + b"\0" * (len(raw) & 1)
        else:
            field = raw + b"\0" * (inline - len(raw))
        out += struct.pack(e + "HH" + ("Q" if big else "I"), tag, typ,
                           count) + field
    out += struct.pack(e + ("Q" if big else "I"), 0)
    assert len(out) == data_at
    out += extra
    for c in chunks:
        out += c
    return bytes(out)


def segments(jpg):
    """The JPEG's marker segments up to and including SOS's header, as
    (marker, bytes), and the rest (entropy-coded data and EOI)."""
    i, segs = 2, []
    while True:
        m, n = jpg[i + 1], jpg[i + 2] << 8 | jpg[i + 3]
        segs.append((m, jpg[i:i + 2 + n]))
        i += 2 + n
        if m == 0xDA:
            return segs, jpg[i:]


def claim(jpg, w, h):
    """jpg with its frame header claiming w x h."""
    segs, rest = segments(jpg)
    out = bytearray(b"\xff\xd8")
    for m, s in segs:
        if m in (0xC0, 0xC2):
            s = s[:5] + struct.pack(">HH", h, w) + s[9:]
        out += s
    return bytes(out + rest)


def split_tables(jpg):
    """(JPEGTables, abbreviated stream): DQT and DHT moved out."""
    segs, rest = segments(jpg)
    tables, stream = bytearray(b"\xff\xd8"), bytearray(b"\xff\xd8")
    for m, s in segs:
        if m in (0xDB, 0xC4):
            tables += s
        elif m != 0xE0:
            stream += s
    return bytes(tables + b"\xff\xd9"), bytes(stream + rest)


def ycbcr_jpeg(w, h, rps, chunks, tables=None, tile=None, **kw):
    ent = [(256, LONG, [w]), (257, LONG, [h]), (258, SHORT, [8, 8, 8]),
           (259, SHORT, [7]), (262, SHORT, [6]), (277, SHORT, [3]),
           (284, SHORT, [1]), (530, SHORT, [2, 2])]
    if tile:
        ent += [(322, LONG, [tile[0]]), (323, LONG, [tile[1]])]
        kw.update(offsets_tag=324, counts_tag=325)
    else:
        ent.append((278, LONG, [rps]))
    if tables:
        ent.append((347, UNDEFINED, list(tables)))
    return tiff(ent, chunks, **kw)


def rgb8(w, h, rps, chunks, comp, photometric=2, spp=3, **kw):
    return tiff([(256, LONG, [w]), (257, LONG, [h]),
                 (258, SHORT, [8] * spp), (259, SHORT, [comp]),
                 (262, SHORT, [photometric]), (277, SHORT, [spp]),
                 (278, LONG, [rps]), (284, SHORT, [1])], chunks, **kw)


def large(out):
    """Deflate bombs: one strip of zeros, decoded whole by the reader."""
    os.makedirs(out, exist_ok=True)
    cmap = [(i * 257) & 0xFFFF for i in range(256)] * 3

    def bomb(n):
        z = zlib.compressobj(9)
        block = bytes(1 << 24)
        data = b"".join(z.compress(block) for _ in range(n >> 24))
        return data + z.compress(bytes(n % (1 << 24))) + z.flush()
    for name, w, h, spp, photometric in (
            ("gray-deflate-40000.tif", 40000, 40000, 1, 1),
            ("rgb-deflate-20000.tif", 20000, 20000, 3, 2),
            ("palette-deflate-30000.tif", 30000, 30000, 1, 3)):
        ent = [(256, LONG, [w]), (257, LONG, [h]), (258, SHORT, [8] * spp),
               (259, SHORT, [8]), (262, SHORT, [photometric]),
               (277, SHORT, [spp]), (278, LONG, [h]), (284, SHORT, [1])]
        if photometric == 3:
            ent.append((320, SHORT, cmap))
        with open(os.path.join(out, name), "wb") as f:
            f.write(tiff(ent, [bomb(w * h * spp)]))


def main():
    if sys.argv[1:2] == ["--large"]:
        return large(sys.argv[2])
    out = sys.argv[1] if len(sys.argv) > 1 else "tests/data/native/limits"
    here = os.path.dirname(os.path.abspath(__file__))
    prog = open(os.path.join(here, "progressive.jpg"), "rb").read()
    rgbp = subprocess.run(["jpegtran", "-progressive",
                           os.path.join(here, "rgb.jpg")],
                          stdout=subprocess.PIPE, check=True).stdout
    base = open(os.path.join(here, "s420.jpg"), "rb").read()
    os.makedirs(out, exist_ok=True)

    def save(name, data):
        with open(os.path.join(out, name), "wb") as f:
            f.write(data)

    save("jpeg-progressive-61x45.tif", ycbcr_jpeg(61, 45, 45, [prog]))
    save("jpeg-progressive-tiled.tif",
         ycbcr_jpeg(61, 45, 0, [claim(prog, 64, 48)], tile=(64, 48)))
    tables, stream = split_tables(prog)
    save("jpeg-progressive-tables.tif",
         ycbcr_jpeg(61, 45, 45, [stream], tables=tables))
    save("jpeg-progressive-big.tif",
         ycbcr_jpeg(61, 45, 45, [prog], be=True, big=True))
    save("jpeg-rgb-progressive.tif", rgb8(61, 45, 45, [rgbp], 7))
    # RowsPerStrip of 1095582055 for 45 rows (found by fuzz_imageio):
    # OpenImageIO allocates that many rows
    save("jpeg-rps-claims.tif", rgb8(61, 45, 1095582055, [rgbp], 7))
    save("jpeg-rgb-progressive-claims-15000.tif",
         rgb8(15000, 15000, 15000, [claim(rgbp, 15000, 15000)], 7))
    save("jpeg-rgb-progressive-claims-1000.tif",
         rgb8(1000, 1000, 1000, [claim(rgbp, 1000, 1000)], 7))
    save("jpeg-progressive-claims-30000.tif",
         ycbcr_jpeg(30000, 30000, 30000, [claim(prog, 30000, 30000)]))
    save("jpeg-baseline-claims-30000.tif",
         ycbcr_jpeg(30000, 30000, 30000, [claim(base, 30000, 30000)]))
    save("jpeg-progressive-claims-tile.tif",
         ycbcr_jpeg(30016, 30016, 0, [claim(prog, 30016, 30016)],
                    tile=(30016, 30016)))
    # LZW: a clear code, one 0, end of information (9-bit codes, TIFF 6.0
    # section 13): a valid stream of one sample, the rest missing
    lzw = bytes([0x80, 0x00, 0x20, 0x20])
    cmap = [(i * 257) & 0xFFFF for i in range(256)] * 3
    save("palette-claims-30000.tif",
         tiff([(256, LONG, [30000]), (257, LONG, [30000]),
               (258, SHORT, [8]), (259, SHORT, [5]), (262, SHORT, [3]),
               (277, SHORT, [1]), (278, LONG, [30000]),
               (320, SHORT, cmap)], [lzw]))
    save("ycbcr-claims-30000.tif",
         tiff([(256, LONG, [30000]), (257, LONG, [30000]),
               (258, SHORT, [8, 8, 8]), (259, SHORT, [1]),
               (262, SHORT, [6]), (277, SHORT, [3]), (278, LONG, [30000]),
               (284, SHORT, [1]), (530, SHORT, [2, 2])], [bytes(600)]))
    for name, side in (("gray-claims-tile.tif", 65536),
                       ("gray-64x64-tile-65536.tif", 64)):
        save(name, tiff([(256, LONG, [side]), (257, LONG, [side]),
                         (258, SHORT, [8]), (259, SHORT, [5]),
                         (262, SHORT, [1]), (277, SHORT, [1]),
                         (322, LONG, [65536]), (323, LONG, [65536])],
                        [lzw], offsets_tag=324, counts_tag=325))
    # The same as libtiff reads it from directories a stricter parser
    # would misread: a later duplicate TileWidth of 16 (libtiff keeps the
    # first), the tiles' offsets under StripOffsets (one array in
    # libtiff), an entry whose values lie outside the file (libtiff
    # ignores it; found by fuzz_imageio).
    gray = [(256, LONG, [64]), (257, LONG, [64]), (258, SHORT, [8]),
            (259, SHORT, [5]), (262, SHORT, [1]), (277, SHORT, [1]),
            (322, LONG, [65536]), (323, LONG, [65536])]
    save("gray-tile-duplicate.tif",
         tiff(gray + [(322, LONG, [16])], [lzw], offsets_tag=324,
              counts_tag=325))
    save("gray-tile-strip-offsets.tif", tiff(gray, [lzw]))
    bad = tiff(gray, [lzw], offsets_tag=324, counts_tag=325)
    i = bad.index(struct.pack("<HHI", 262, SHORT, 1))
    bad = bad[:i] + struct.pack("<HHI", 262, LONG, 0xFFFFFFFF) + bad[i + 8:]
    save("gray-tile-bad-entry.tif", bad)
    # TileOffsets claiming 786433 entries: libtiff trims the array to the
    # file and reads the tile (found by fuzz_imageio)
    long = tiff(gray, [lzw], offsets_tag=324, counts_tag=325)
    i = long.index(struct.pack("<HHI", 324, LONG, 1))
    long = long[:i] + struct.pack("<HHI", 324, LONG, 0xC0001) + long[i + 8:]
    save("gray-tile-long-offsets.tif", long)
    # 1 bit a sample: 200 MB a tile as stored, 1.6 GB as delivered
    save("bilevel-tile-40000.tif",
         tiff([(256, LONG, [64]), (257, LONG, [64]), (258, SHORT, [1]),
               (259, SHORT, [5]), (262, SHORT, [1]), (277, SHORT, [1]),
               (322, LONG, [40000]), (323, LONG, [40000])], [lzw],
              offsets_tag=324, counts_tag=325))


if __name__ == "__main__":
    main()
