#!/usr/bin/env python3
"""make-variants.py - writes the PNG variants of tests/data/native/ from a
crop given as a binary PPM (make-variants.sh makes it with `vips crop`),
with nothing but zlib and struct: every PNG colour type, bit depth and
chunk the native reader must read as OpenImageIO does, each tiny.
Deterministic: the same crop gives the same files.

usage: make-variants.py CROP.ppm OUTDIR
"""
import struct, sys, zlib

def read_ppm(path):
    rest = open(path, "rb").read()
    # header fields, skipping comment lines (vips writes one)
    fields = []
    while len(fields) < 4:
        line, rest = rest.split(b"\n", 1)
        if not line.startswith(b"#"):
            fields += line.split()
    parts = fields + [rest]
    assert parts[0] == b"P6"
    w, h, mx = int(parts[1]), int(parts[2]), int(parts[3])
    assert mx == 255
    px = parts[4]
    return w, h, px[: w * h * 3]

def chunk(kind, body):
    return (struct.pack(">I", len(body)) + kind + body
            + struct.pack(">I", zlib.crc32(kind + body) & 0xffffffff))

def pack_row(samples, bits):
    """Pack integer samples of `bits` (1, 2, 4, 8, 16) into bytes."""
    if bits == 8:
        return bytes(samples)
    if bits == 16:
        return b"".join(struct.pack(">H", s) for s in samples)
    out, acc, n = bytearray(), 0, 0
    for s in samples:
        acc = (acc << bits) | s
        n += bits
        if n == 8:
            out.append(acc)
            acc, n = 0, 0
    if n:
        out.append(acc << (8 - n))
    return bytes(out)

def adam7(w, h):
    passes = [(0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4),
              (0, 2, 2, 4), (1, 0, 2, 2), (0, 1, 1, 2)]
    for x0, y0, dx, dy in passes:
        xs = list(range(x0, w, dx))
        ys = list(range(y0, h, dy))
        if xs and ys:
            yield xs, ys

def png(path, w, h, ctype, bits, pix, extra=b"", interlace=0):
    """pix(x, y) -> tuple of samples for one pixel."""
    raw = bytearray()
    if interlace:
        for xs, ys in adam7(w, h):
            for y in ys:
                row = [s for x in xs for s in pix(x, y)]
                raw += b"\0" + pack_row(row, bits)
    else:
        for y in range(h):
            row = [s for x in range(w) for s in pix(x, y)]
            body = pack_row(row, bits)
            # every other row with the Sub filter, to exercise unfiltering
            if y % 2 and bits >= 8:
                bpp = max(1, len(pix(0, 0)) * bits // 8)
                sub = bytes((body[i] - (body[i - bpp] if i >= bpp else 0)) & 255
                            for i in range(len(body)))
                raw += b"\1" + sub
            else:
                raw += b"\0" + body
    ihdr = struct.pack(">IIBBBBB", w, h, bits, ctype, 0, 0, interlace)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + extra
                + chunk(b"IDAT", zlib.compress(bytes(raw), 9))
                + chunk(b"IEND", b""))

def main():
    src, out = sys.argv[1], sys.argv[2]
    W, H, px = read_ppm(src)
    w, h = 37, 23  # odd sizes: partial bytes at the row ends of 1..4 bits
    def rgb(x, y):
        i = 3 * (y * W + x)
        return px[i], px[i + 1], px[i + 2]
    def gray(x, y):
        r, g, b = rgb(x, y)
        return (r * 77 + g * 150 + b * 29) >> 8
    def p(name):
        return out + "/" + name
    png(p("gray8.png"), w, h, 0, 8, lambda x, y: (gray(x, y),))
    png(p("gray1.png"), w, h, 0, 1, lambda x, y: (gray(x, y) >> 7,))
    png(p("gray2.png"), w, h, 0, 2, lambda x, y: (gray(x, y) >> 6,))
    png(p("gray4.png"), w, h, 0, 4, lambda x, y: (gray(x, y) >> 4,))
    png(p("gray16.png"), w, h, 0, 16, lambda x, y: (gray(x, y) * 257 - x,))
    png(p("gray8-trns.png"), w, h, 0, 8, lambda x, y: (gray(x, y) & 0xf0,),
        extra=chunk(b"tRNS", struct.pack(">H", 0x80)))
    png(p("gray16-trns.png"), w, h, 0, 16, lambda x, y: ((gray(x, y) & 0xf0) * 257,),
        extra=chunk(b"tRNS", struct.pack(">H", 0x8080)))
    png(p("graya8.png"), w, h, 4, 8, lambda x, y: (gray(x, y), (x * 7 + y * 3) & 255))
    png(p("graya16.png"), w, h, 4, 16,
        lambda x, y: (gray(x, y) * 257, ((x * 7 + y * 3) & 255) * 256 + x))
    png(p("rgb8.png"), w, h, 2, 8, rgb)
    png(p("rgb16.png"), w, h, 2, 16,
        lambda x, y: tuple(v * 257 - (x + y) % 200 for v in rgb(x, y)))
    png(p("rgb8-trns.png"), w, h, 2, 8, lambda x, y: tuple(v & 0xe0 for v in rgb(x, y)),
        extra=chunk(b"tRNS", struct.pack(">HHH", 0x60, 0x60, 0x40)))
    png(p("rgba8.png"), w, h, 6, 8, lambda x, y: rgb(x, y) + ((x * 5 + y * 11) & 255,))
    png(p("rgba16.png"), w, h, 6, 16,
        lambda x, y: tuple(v * 257 for v in rgb(x, y)) + (x * 1000 + y,))
    # palette: 16 entries from the picture's colours, 4-bit indices
    pal = [rgb(x * 2, 5) for x in range(16)]
    def idx(x, y):
        r, g, b = rgb(x, y)
        return (min(range(16), key=lambda k: (pal[k][0] - r) ** 2
                    + (pal[k][1] - g) ** 2 + (pal[k][2] - b) ** 2),)
    plte = chunk(b"PLTE", b"".join(bytes(c) for c in pal))
    png(p("palette4.png"), w, h, 3, 4, idx, extra=plte)
    png(p("palette8-trns.png"), w, h, 3, 8, idx,
        extra=plte + chunk(b"tRNS", bytes(k * 16 for k in range(10))))
    png(p("palette1.png"), w, h, 3, 1, lambda x, y: (gray(x, y) >> 7,),
        extra=chunk(b"PLTE", bytes([10, 20, 30, 200, 210, 220])))
    png(p("rgb8-interlaced.png"), w, h, 2, 8, rgb, interlace=1)
    png(p("gray4-interlaced.png"), w, h, 0, 4, lambda x, y: (gray(x, y) >> 4,), interlace=1)
    # ancillary chunks that change nothing in OpenImageIO's pixels
    gama = chunk(b"gAMA", struct.pack(">I", 45455))
    srgb = chunk(b"sRGB", b"\0")
    sbit = chunk(b"sBIT", bytes([5, 6, 5]))
    text = chunk(b"tEXt", b"Comment\0native reader test")
    png(p("rgb8-gama-text.png"), w, h, 2, 8, rgb, extra=gama + text)
    png(p("rgb8-srgb.png"), w, h, 2, 8, rgb, extra=srgb)
    png(p("rgb16-sbit.png"), w, h, 2, 16, lambda x, y: tuple(v * 257 for v in rgb(x, y)),
        extra=chunk(b"sBIT", bytes([10, 10, 10])))
    png(p("rgb8-sbit.png"), w, h, 2, 8, rgb, extra=sbit)
    bad = bytearray(chunk(b"tEXt", b"Comment\0bad crc"))
    bad[-1] ^= 0xff
    png(p("rgb8-badcrc-text.png"), w, h, 2, 8, rgb, extra=bytes(bad))
    png(p("rgb8-offs.png"), w, h, 2, 8, rgb,
        extra=chunk(b"oFFs", struct.pack(">iiB", 5, 7, 0)))

main()
