#!/usr/bin/env python3
"""window_ref.py - an independent reference of the display window
(lib/render/window.h) for tests/http_window.sh and tests/browser_window.sh.

  window_ref.py table WINDOW            the tables, one line of 256 decimal
                                        bytes per channel window
  window_ref.py apply WINDOW RAW OUT    check that PNM OUT is PNM RAW
                                        through WINDOW's tables; exit 1 if not
  window_ref.py tables FILE [MAX]       one line per window text of FILE
                                        (points up to MAX, default 255):
                                        its tables joined by ';', or "error";
                                        past 255 each table as the SHA-256
                                        of its MAX + 1 bytes

The window text is parsed here with a regular expression, the table built
from its definition: 0 up to black, 255 from white, else
floor(255 * t ** (1 / gamma) + 0.500000001), t = (v - black) / (white - black).
"""
import hashlib
import re
import sys

CH = re.compile(r'^([0-9]+),([0-9]+)(?:,([0-9]+)(?:\.([0-9]{1,3}))?)?$')


def parse(text, vmax=255):
    if len(text) > 512:
        return None
    parts = text.split(';')
    if len(parts) > 8:
        return None
    out = []
    for p in parts:
        m = CH.match(p)
        if not m:
            return None
        b, w = int(m.group(1)), int(m.group(2))
        g = 1000
        if m.group(3) is not None:
            if int(m.group(3)) > 10:
                return None
            g = int(m.group(3)) * 1000 + int((m.group(4) or '').ljust(3, '0'))
        if b > vmax or w > vmax or b >= w or not 100 <= g <= 10000:
            return None
        out.append((b, w, g))
    return out


def table(b, w, g, vmax=255):
    t = []
    for v in range(vmax + 1):
        if v <= b:
            t.append(0)
        elif v >= w:
            t.append(255)
        else:
            x = (v - b) / (w - b)
            p = x if g == 1000 else x ** (1000 / g)
            y = int((255 * p + 0.500000001) // 1)
            t.append(max(0, min(255, y)))
    return t


def read_pnm(path):
    data = open(path, 'rb').read()
    fields, pos = [], 0
    while len(fields) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b'#':
            pos = data.index(b'\n', pos)
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    pos += 1
    ch = {b'P5': 1, b'P6': 3}[fields[0]]
    w, h = int(fields[1]), int(fields[2])
    return w, h, ch, data[pos:pos + w * h * ch]


def main():
    cmd = sys.argv[1]
    if cmd == 'table':
        for c in parse(sys.argv[2]):
            print(' '.join(map(str, table(*c))))
    elif cmd == 'tables':
        vmax = int(sys.argv[3]) if len(sys.argv) > 3 else 255

        def text(t):
            if vmax > 255:
                return hashlib.sha256(bytes(t)).hexdigest()
            return ' '.join(map(str, t))
        for line in open(sys.argv[2]):
            win = parse(line.rstrip('\n'), vmax)
            print('error' if win is None else
                  ';'.join(text(table(*c, vmax)) for c in win))
    elif cmd == 'apply':
        win = parse(sys.argv[2])
        w, h, ch, raw = read_pnm(sys.argv[3])
        w2, h2, ch2, got = read_pnm(sys.argv[4])
        if (w, h, ch) != (w2, h2, ch2):
            print(f'sizes differ: {w}x{h}x{ch} and {w2}x{h2}x{ch2}')
            sys.exit(1)
        tabs = [table(*win[0 if len(win) == 1 else k]) for k in range(ch)]
        bad = sum(1 for i, v in enumerate(raw) if tabs[i % ch][v] != got[i])
        print(f'{bad} of {len(raw)} samples differ from the reference')
        sys.exit(1 if bad else 0)


main()
