#!/usr/bin/python3
"""sim_layouts.py - which pyramid layout codes a photograph in fewer bits:
gigaview's closed-loop Laplacian pyramid with 8x8 (or 16x16) transforms of
the residual, or a critically sampled wavelet pyramid whose tiles are still
decoded from their parent alone.

    /usr/bin/python3 bench/sim_layouts.py IMAGE.ppm|.png ... [--steps "..."]

Both layouts get the same everything else, so that only the layout differs:
  - the same colour transform (YCoCg, float, orthonormal-scaled), PSNR over
    RGB at level 0 after the inverse;
  - the same quantizer: uniform, step D in the image's own scale, rounding
    with a dead zone (|x|/D + 0.5 - 0.2, toward zero), every coefficient of
    an orthonormal transform or of a subband scaled by its synthesis gain;
  - the same ideal entropy coder: the zeroth-order entropy of the quantized
    values per context, no model cost.  The contexts are one per
    (level, channel, coefficient position) for the transforms (64 or 256
    a level and channel) and one per (level, channel, subband) for the
    wavelet, which favours the transform layout a little (more contexts);
  - the same root: levels are built down to a root of at most 32 pixels a
    side, counted at 8 bits a sample for both (a few hundred bytes).

Layout "laplace8" (today's layout D, section 4.3 of docs/FORMAT.md): level
k+1 is the 2x2 box mean of level k; from the root down, level k is
predicted from the decoded level k+1 with the quarter-pixel Catmull-Rom
taps (-3, 29, 111, -9)/128 and its whole residual is transform-coded, so
the levels together code 4/3 of the image's samples.  The step of level
k is D * s^k; the best s of 1, 0.85 and 0.7 is kept per point (the
encoder's level weighting is a free choice).

Layout "cdf97" / "cdf53": a lifting wavelet (CDF 9/7 or LeGall 5/3,
symmetric extension) applied level by level; level k+1 is the low band of
level k, and only the three detail bands of each level are coded: exactly
as many coefficients as pixels.  A tile of 512 x 512 is its parent's low
band plus three detail bands of 256 x 256; to decode it from the parent
alone a tile also carries the detail coefficients its synthesis filter
reaches past its edges (2 for 9/7, 1 for 5/3, each side, per band), and the
parent's low band over the same halo, which the parent tile's own overlap
provides.  The halo's duplicated coefficients are counted: the bits of
each band are multiplied by ((256 + 2h) / 256)^2.

Output: one line per (image, layout, step): bits per pixel and level-0
PSNR, then the BD-PSNR (Bjontegaard, cubic in log rate) of each layout
against laplace8.  The model flatters every layout alike (ideal entropy,
no side information); only the differences carry over.  Needs numpy
(Debian: python3-numpy) and vips to read the images.
"""
import subprocess
import sys
import tempfile

import numpy as np

DEADZONE = 0.2
LAYOUTS = ('laplace8', 'laplace8w', 'laplace8c', 'laplace16', 'cdf53', 'cdf97')


def read_image(path):
    """RGB float array (h, w, 3) of an image vips can read."""
    with tempfile.NamedTemporaryFile(suffix='.ppm') as t:
        subprocess.run(['vips', 'copy', path, t.name], check=True)
        data = open(t.name, 'rb').read()
    fields, pos = [], 0
    while len(fields) < 4:          # magic, width, height, maxval; # comments
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b'#':
            pos = data.index(b'\n', pos) + 1
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    assert fields[0] == b'P6' and fields[3] == b'255', 'expected 8-bit RGB'
    w, h = int(fields[1]), int(fields[2])
    px = np.frombuffer(data[pos + 1:pos + 1 + w * h * 3], dtype=np.uint8)
    return px.reshape(h, w, 3).astype(np.float64)


# YCoCg scaled to an orthonormal transform (rows of unit length).
CT = np.array([[1 / 4, 1 / 2, 1 / 4], [1 / 2, 0, -1 / 2], [-1 / 4, 1 / 2, -1 / 4]])
CT = CT / np.linalg.norm(CT, axis=1, keepdims=True)
CTI = np.linalg.inv(CT)


def to_ycocg(rgb):
    return rgb @ CT.T


def to_rgb(ycc):
    return ycc @ CTI.T


def quantize(x, step):
    """Dead-zone uniform quantizer: the integer levels."""
    a = np.floor(np.abs(x) / step + 0.5 - DEADZONE)
    return np.sign(x) * np.maximum(a, 0)


def entropy_bits(q):
    """Zeroth-order entropy of the integer array q, in bits (total)."""
    _, counts = np.unique(q, return_counts=True)
    p = counts / counts.sum()
    return float(-(counts * np.log2(p)).sum())


def psnr(a, b):
    a = np.clip(np.round(a), 0, 255)
    mse = np.mean((a - b) ** 2)
    return 10 * np.log10(255 * 255 / mse)


# ---- layout laplace8: closed-loop Laplacian pyramid, block transforms ----

def box_down(x):
    h, w = x.shape[:2]
    if h % 2:
        x = np.concatenate([x, x[-1:]], axis=0)
    if w % 2:
        x = np.concatenate([x, x[:, -1:]], axis=1)
    return (x[0::2, 0::2] + x[1::2, 0::2] + x[0::2, 1::2] + x[1::2, 1::2]) / 4


CR_EVEN = np.array([-3, 29, 111, -9]) / 128   # taps at p-2 .. p+1
CR_ODD = np.array([-9, 111, 29, -3]) / 128    # taps at p-1 .. p+2


def cubic_up_axis0(p, n):
    """Child rows 0..n-1 from parent rows p, quarter-pixel Catmull-Rom."""
    m = p.shape[0]
    out = np.empty((n,) + p.shape[1:])
    u = np.arange(n)
    base = u >> 1
    for j in range(4):
        even_idx = np.clip(base - 2 + j, 0, m - 1)
        odd_idx = np.clip(base - 1 + j, 0, m - 1)
        w = np.where(u % 2 == 0, CR_EVEN[j], CR_ODD[j])
        idx = np.where(u % 2 == 0, even_idx, odd_idx)
        term = p[idx] * w.reshape((n,) + (1,) * (p.ndim - 1))
        out = term if j == 0 else out + term
    return out


def cubic_up(parent, h, w):
    t = cubic_up_axis0(parent, h)
    return np.swapaxes(cubic_up_axis0(np.swapaxes(t, 0, 1), w), 0, 1)


def dct_matrix(n):
    k = np.arange(n)
    m = np.cos(np.pi * (2 * k[None, :] + 1) * k[:, None] / (2 * n)) * np.sqrt(2 / n)
    m[0] /= np.sqrt(2)
    return m


def code_blocks(res, step, n):
    """Transform-code a residual (h, w, 3) in n x n blocks: (decoded, bits)."""
    h, w = res.shape[:2]
    H, W = -(-h // n) * n, -(-w // n) * n
    pad = np.pad(res, ((0, H - h), (0, W - w), (0, 0)), mode='edge')
    m = dct_matrix(n)
    blocks = pad.reshape(H // n, n, W // n, n, 3).transpose(0, 2, 4, 1, 3)
    coef = m @ blocks @ m.T
    q = quantize(coef, step)
    bits = 0.0
    for c in range(3):
        for v in range(n):
            for u in range(n):
                bits += entropy_bits(q[:, :, c, v, u])
    rec = m.T @ (q * step) @ m
    dec = rec.transpose(0, 3, 1, 4, 2).reshape(H, W, 3)[:h, :w]
    # Only the blocks' share inside the image is coded in the real layout
    # too (blocks past the edge are nearly free); scale by the inside area.
    return dec, bits * (h * w) / (H * W)


def pyramid_levels(img, root_max=32):
    levels = [img]
    while max(levels[-1].shape[:2]) > root_max:
        levels.append(box_down(levels[-1]))
    return levels


def laplace(img, step, n, s):
    levels = pyramid_levels(img)
    dec = levels[-1].copy()
    bits = dec.size * 8.0
    for k in range(len(levels) - 2, -1, -1):
        h, w = levels[k].shape[:2]
        pred = cubic_up(dec, h, w)
        d, b = code_blocks(levels[k] - pred, step * s ** k, n)
        dec = pred + d
        bits += b
    return dec, bits


# ---- layouts cdf97 / cdf53: critically sampled lifting wavelets ----

def sym(x, i):
    """Whole-sample symmetric index into length-n axis."""
    n = x.shape[0]
    i = np.abs(i)
    i = np.where(i >= n, 2 * (n - 1) - i, i)
    return x[i]


def lift_fwd_axis0(x, kind):
    n = x.shape[0]
    if n % 2:
        x = np.concatenate([x, x[-2:-1]], axis=0)   # symmetric pad to even
    s, d = x[0::2].copy(), x[1::2].copy()
    ns, nd = s.shape[0], d.shape[0]
    i = np.arange(nd)
    j = np.arange(ns)

    def s_at(k):
        return s[np.clip(k, 0, ns - 1)]

    def d_at(k):
        return d[np.clip(k, 0, nd - 1) if True else k]

    if kind == 'cdf53':
        d = d - 0.5 * (s_at(i) + s_at(i + 1))
        s = s + 0.25 * (d[np.clip(j - 1, 0, nd - 1)] + d[np.clip(j, 0, nd - 1)])
        return s * np.sqrt(2), d / np.sqrt(2), n
    a, b, c, e, K = -1.586134342, -0.05298011854, 0.8829110762, 0.4435068522, 1.149604398
    d = d + a * (s_at(i) + s_at(i + 1))
    s = s + b * (d[np.clip(j - 1, 0, nd - 1)] + d[np.clip(j, 0, nd - 1)])
    d = d + c * (s_at(i) + s_at(i + 1))
    s = s + e * (d[np.clip(j - 1, 0, nd - 1)] + d[np.clip(j, 0, nd - 1)])
    return s * K, d / K, n


def lift_inv_axis0(s, d, n, kind):
    ns, nd = s.shape[0], d.shape[0]
    i = np.arange(nd)
    j = np.arange(ns)
    if kind == 'cdf53':
        s, d = s / np.sqrt(2), d * np.sqrt(2)
        s = s - 0.25 * (d[np.clip(j - 1, 0, nd - 1)] + d[np.clip(j, 0, nd - 1)])
        d = d + 0.5 * (s[np.clip(i, 0, ns - 1)] + s[np.clip(i + 1, 0, ns - 1)])
    else:
        a, b, c, e, K = -1.586134342, -0.05298011854, 0.8829110762, 0.4435068522, 1.149604398
        s, d = s / K, d * K
        s = s - e * (d[np.clip(j - 1, 0, nd - 1)] + d[np.clip(j, 0, nd - 1)])
        d = d - c * (s[np.clip(i, 0, ns - 1)] + s[np.clip(i + 1, 0, ns - 1)])
        s = s - b * (d[np.clip(j - 1, 0, nd - 1)] + d[np.clip(j, 0, nd - 1)])
        d = d - a * (s[np.clip(i, 0, ns - 1)] + s[np.clip(i + 1, 0, ns - 1)])
    x = np.empty((ns + nd,) + s.shape[1:])
    x[0::2], x[1::2] = s, d
    return x[:n]


def dwt2(x, kind):
    s, d, n0 = lift_fwd_axis0(x, kind)
    ll, lh, n1 = lift_fwd_axis0(np.swapaxes(s, 0, 1), kind)
    hl, hh, _ = lift_fwd_axis0(np.swapaxes(d, 0, 1), kind)
    sw = lambda a: np.swapaxes(a, 0, 1)
    return sw(ll), (sw(lh), sw(hl), sw(hh)), (n0, n1)


def idwt2(ll, bands, shape, kind):
    lh, hl, hh = bands
    n0, n1 = shape
    sw = lambda a: np.swapaxes(a, 0, 1)
    s = sw(lift_inv_axis0(sw(ll), sw(lh), n1, kind))
    d = sw(lift_inv_axis0(sw(hl), sw(hh), n1, kind))
    return lift_inv_axis0(s, d, n0, kind)


def band_gains(kind, depth):
    """L2 norm of the synthesis of a unit coefficient in the middle of each
    detail band of levels 0 .. depth-1 (index [level][band]), on a 512 x 512
    stand-in: a quantization error of e in that band is e * gain in pixels."""
    x = np.zeros((512, 512, 1))
    stack, ll = [], x
    for _ in range(depth):
        ll, bands, shape = dwt2(ll, kind)
        stack.append((bands, shape))
    gains = []
    for lv in range(depth):
        row = []
        for b in range(3):
            bands = [[np.zeros_like(t) for t in bs] for bs, _ in stack]
            h, w = bands[lv][b].shape[:2]
            bands[lv][b][h // 2, w // 2, 0] = 1
            rec = np.zeros_like(ll)
            for k in range(depth - 1, -1, -1):
                rec = idwt2(rec, bands[k], stack[k][1], kind)
            row.append(float(np.sqrt((rec ** 2).sum())))
        gains.append(row)
    return gains


def wavelet(img, step, kind, root_max=32):
    halo = 2 if kind == 'cdf97' else 1
    dup = ((256 + 2 * halo) / 256) ** 2
    stack = []
    x = img
    while max(x.shape[:2]) > root_max:
        ll, bands, shape = dwt2(x, kind)
        stack.append((bands, shape))
        x = ll
    gains = band_gains(kind, min(len(stack), 6))
    bits = x.size * 8.0
    rec = x
    for lv in range(len(stack) - 1, -1, -1):
        bands, shape = stack[lv]
        coded = []
        for bi, b in enumerate(bands):
            g = gains[min(lv, len(gains) - 1)][bi]
            q = quantize(b, step / g)
            for c in range(3):
                bits += entropy_bits(q[..., c]) * dup
            coded.append(q * step / g)
        rec = idwt2(rec, coded, shape, kind)
    return rec, bits


def bd_psnr(a, b):
    """Mean PSNR of curve a minus curve b over their common log-rate range."""
    la, lb = np.log(a[:, 0]), np.log(b[:, 0])
    pa, pb = np.polyfit(la, a[:, 1], 3), np.polyfit(lb, b[:, 1], 3)
    lo, hi = max(la.min(), lb.min()), min(la.max(), lb.max())
    if hi <= lo:
        return float('nan')
    ia, ib = np.polyint(pa), np.polyint(pb)
    return ((np.polyval(ia, hi) - np.polyval(ia, lo)) -
            (np.polyval(ib, hi) - np.polyval(ib, lo))) / (hi - lo)


def self_check():
    x = np.random.default_rng(1).normal(size=(37, 29, 3)) * 50
    for kind in ('cdf53', 'cdf97'):
        ll, bands, shape = dwt2(x, kind)
        assert np.allclose(idwt2(ll, bands, shape, kind), x), kind
    c = np.array([[0.5, 30], [1, 33], [2, 36], [4, 39.5]])
    assert abs(bd_psnr(c, c)) < 1e-9
    assert abs(bd_psnr(c + [0, 1], c) - 1) < 1e-9


def main(argv):
    steps = [4, 6, 9, 13, 19, 28, 40]
    images = []
    for a in argv:
        if a.startswith('--steps='):
            steps = [float(v) for v in a.split('=', 1)[1].split()]
        else:
            images.append(a)
    self_check()
    table = {}
    for path in images:
        rgb = read_image(path)
        ycc = to_ycocg(rgb)
        px = rgb.shape[0] * rgb.shape[1]
        name = path.rsplit('/', 1)[-1].rsplit('.', 1)[0]
        curves = {}
        for layout in LAYOUTS:
            pts = []
            for st in steps:
                if layout.startswith('laplace'):
                    n = 16 if layout.startswith('laplace16') else 8
                    s = {'w': 0.7, 'c': 1.4}.get(layout[-1], 1.0)
                    dec, bits = laplace(ycc, st, n, s)
                else:
                    dec, bits = wavelet(ycc, st, layout)
                pts.append((bits / px, psnr(to_rgb(dec), rgb)))
                print('%s\t%s\tstep=%g\tbpp=%.4f\tpsnr=%.3f' %
                      ((name, layout, st) + pts[-1]), flush=True)
            curves[layout] = np.array(pts)
        table[name] = {k: bd_psnr(v, curves['laplace8']) for k, v in curves.items()}
    cols = LAYOUTS[1:]
    print('\nBD-PSNR against laplace8 (dB, positive: better than today\'s layout)')
    print('image\t' + '\t'.join(cols))
    for name, row in table.items():
        print(name + '\t' + '\t'.join('%+.2f' % row[c] for c in cols))
    print('mean\t' + '\t'.join('%+.2f' % np.mean([r[c] for r in table.values()])
                              for c in cols))


if __name__ == '__main__':
    main(sys.argv[1:])
