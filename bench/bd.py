#!/usr/bin/env python3
"""bd.py: Bjontegaard deltas of one codec against the others, from a results TSV.

    bench/bd.py RESULTS.tsv [--ref gigaview] [--tsv OUT.tsv]
    bench/bd.py --self-test

RESULTS.tsv is what bench/rd-anchors.sh and bench/rate-distortion.sh write:
one point per line, "image codec setting bpp psnr ssim", tab separated.
For each image and each codec other than the reference this prints

  BD-PSNR   reference minus codec, dB: PSNR fitted as a cubic polynomial
            of ln(bpp) by least squares for each curve, both integrated over
            the rates the two curves share, the difference of the means
            (Bjontegaard, VCEG-M33). Positive: the reference is better.
  BD-SSIM   the same with SSIM-Y in place of PSNR.
  BD-rate   the rate side, in percent: ln(bpp) fitted as a cubic of PSNR over
            the PSNR range both reach; negative: the reference needs fewer
            bits for the same PSNR.

as tables with one row per image and one column per codec, and a mean row
over the images where the cell exists. Each curve's fit uses the points in
the shared range plus the nearest one beyond each end (at least 4), so that
wide settings lists can cover every image. A cell is "n/a" when a curve has
fewer than 4 distinct rates (a cubic needs 4) or when the two ranges do not
overlap, and is marked "*" when the shared range is short. Points with an
infinite PSNR (lossless) are left out.

The fit is done by hand (normal equations, Gaussian elimination) so that
nothing beyond the standard library is needed. --tsv writes every cell as
"image codec metric value lo hi" (lo/hi: the shared range, in bpp for
bd-psnr and bd-ssim, in dB for bd-rate-pct).
"""
import argparse
import math
import sys

# A cell whose curves share less than this is marked "*": a BD figure over a
# short range is mostly the two fits' extrapolation error.
NARROW_RATE = 1.5   # factor in bpp (BD-PSNR, BD-SSIM)
NARROW_DB = 2.0     # dB (BD-rate)


def polyfit3(xs, ys):
    """Least-squares cubic through (xs, ys): returns [c0, c1, c2, c3] of
    c0 + c1 x + c2 x^2 + c3 x^3. x is centred first for conditioning;
    the returned coefficients are for the original x."""
    n = len(xs)
    if n < 4:
        raise ValueError("a cubic fit needs at least 4 points")
    mx = sum(xs) / n
    us = [x - mx for x in xs]
    # normal equations A c = b, A[i][j] = sum u^(i+j)
    a = [[sum(u ** (i + j) for u in us) for j in range(4)] for i in range(4)]
    b = [sum(y * u ** i for u, y in zip(us, ys)) for i in range(4)]
    for col in range(4):          # elimination with partial pivoting
        piv = max(range(col, 4), key=lambda r: abs(a[r][col]))
        if abs(a[piv][col]) < 1e-300:
            raise ValueError("singular fit (repeated rates?)")
        a[col], a[piv] = a[piv], a[col]
        b[col], b[piv] = b[piv], b[col]
        for r in range(col + 1, 4):
            f = a[r][col] / a[col][col]
            for k in range(col, 4):
                a[r][k] -= f * a[col][k]
            b[r] -= f * b[col]
    c = [0.0] * 4
    for r in range(3, -1, -1):
        c[r] = (b[r] - sum(a[r][k] * c[k] for k in range(r + 1, 4))) / a[r][r]
    # expand c(u) with u = x - mx back into powers of x
    out = [0.0] * 4
    for k in range(4):            # c[k] (x - mx)^k
        for j in range(k + 1):
            out[j] += c[k] * math.comb(k, j) * (-mx) ** (k - j)
    return out


def integral(p, lo, hi):
    """Integral of the cubic p from lo to hi."""
    def prim(x):
        return sum(p[k] * x ** (k + 1) / (k + 1) for k in range(4))
    return prim(hi) - prim(lo)


def trim(points, lo, hi):
    """The points of one curve (x, y) that a fit over [lo, hi] should use:
    those inside, plus the nearest one beyond each end, plus more of the
    nearest outside ones until there are 4. Settings lists are wide so that
    every image's range is covered; points far beyond the other curve's
    range would only bend the cubic where it is not integrated."""
    pts = sorted(points)
    below = [i for i, (x, _) in enumerate(pts) if x < lo]
    above = [i for i, (x, _) in enumerate(pts) if x > hi]
    a = below[-1] if below else 0
    b = above[0] if above else len(pts) - 1
    while b - a + 1 < 4 and (a > 0 or b < len(pts) - 1):
        below = pts[a - 1][0] if a > 0 else None
        above = pts[b + 1][0] if b < len(pts) - 1 else None
        if above is None or (below is not None and lo - below <= above - hi):
            a -= 1
        else:
            b += 1
    return pts[a:b + 1]


def dedupe(points):
    """One point per x (the first): a rate-controlled coder that cannot
    spend more returns the same file for several settings."""
    seen, out = set(), []
    for x, y in points:
        if x not in seen:
            seen.add(x)
            out.append((x, y))
    return out


def bd_delta(ref, test):
    """ref, test: lists of (x, y). Mean of y_ref - y_test over the x range
    both cover, each y a least-squares cubic of x through the points that
    trim() keeps. Returns (delta, lo, hi) or None."""
    ref, test = dedupe(ref), dedupe(test)
    if len(ref) < 4 or len(test) < 4:
        return None
    lo = max(min(x for x, _ in ref), min(x for x, _ in test))
    hi = min(max(x for x, _ in ref), max(x for x, _ in test))
    if hi <= lo:
        return None
    ref, test = trim(ref, lo, hi), trim(test, lo, hi)
    pr = polyfit3([x for x, _ in ref], [y for _, y in ref])
    pt = polyfit3([x for x, _ in test], [y for _, y in test])
    return ((integral(pr, lo, hi) - integral(pt, lo, hi)) / (hi - lo), lo, hi)


def bd_metric(ref, test, col):
    """BD of metric col ('psnr' or 'ssim') against ln(bpp). ref/test: lists
    of dicts with bpp, psnr, ssim."""
    r = [(math.log(p["bpp"]), p[col]) for p in ref]
    t = [(math.log(p["bpp"]), p[col]) for p in test]
    d = bd_delta(r, t)
    if d is None:
        return None
    return d[0], math.exp(d[1]), math.exp(d[2]), d[2] - d[1] < math.log(NARROW_RATE)


def bd_rate(ref, test):
    """BD-rate in percent (ref against test): ln(bpp) as a cubic of PSNR."""
    r = [(p["psnr"], math.log(p["bpp"])) for p in ref]
    t = [(p["psnr"], math.log(p["bpp"])) for p in test]
    d = bd_delta(r, t)
    if d is None:
        return None
    return (math.exp(d[0]) - 1) * 100, d[1], d[2], d[2] - d[1] < NARROW_DB


def read_points(path):
    """{image: {codec: [points]}}, plus images and codecs in file order."""
    data, images, codecs = {}, [], []
    with open(path) as f:
        for line in f:
            if not line.strip() or line.startswith("#"):
                continue
            cols = line.rstrip("\n").split("\t")
            if len(cols) < 6:
                continue
            img, codec = cols[0], cols[1]
            try:
                bpp, psnr, ssim = float(cols[3]), float(cols[4]), float(cols[5])
            except ValueError:
                continue
            if not (bpp > 0 and math.isfinite(psnr) and math.isfinite(ssim)):
                continue
            if img not in data:
                data[img] = {}
                images.append(img)
            if codec not in codecs:
                codecs.append(codec)
            data[img].setdefault(codec, []).append(
                {"bpp": bpp, "psnr": psnr, "ssim": ssim})
    return data, images, codecs


def table(title, images, anchors, cells, fmt):
    """Prints one table: rows images, columns anchors, then the mean row."""
    width = max([len("mean")] + [len(i) for i in images]) + 2
    colw = max([10] + [len(a) + 2 for a in anchors])
    print(title)
    print("image".ljust(width) + "".join(a.rjust(colw) for a in anchors))
    for img in images:
        row = img.ljust(width)
        for a in anchors:
            v = cells.get((img, a))
            row += ((fmt % v[0]) + ("*" if v[3] else " ") if v else "n/a ").rjust(colw)
        print(row)
    row, counts = "mean".ljust(width), []
    for a in anchors:
        vals = [cells[(i, a)][0] for i in images if cells.get((i, a))]
        counts.append(len(vals))
        row += ((fmt % (sum(vals) / len(vals))) + " " if vals else "n/a ").rjust(colw)
    print(row)
    if any(v and v[3] for v in cells.values()):
        print("* the two curves share a short range (under a factor %g in rate, or %g dB):"
              " an uncertain figure" % (NARROW_RATE, NARROW_DB))
    if any(c != len(images) for c in counts):
        print("(mean over the images where the cell exists: "
              + ", ".join("%s %d" % (a, c) for a, c in zip(anchors, counts)) + ")")
    print()


def self_test():
    """Identical curves give 0; a curve 1 dB up gives +1 dB (and a negative
    BD-rate); the fit reproduces an exact cubic."""
    rates = [0.25, 0.5, 1.0, 1.6, 2.5, 4.0]
    base = [{"bpp": r, "psnr": 30 + 4 * math.log(r) - 0.3 * math.log(r) ** 2,
             "ssim": 0.95 + 0.01 * math.log(r)} for r in rates]
    up = [dict(p, psnr=p["psnr"] + 1, ssim=p["ssim"] + 0.01) for p in base]
    fails = 0

    def check(name, got, want, tol=1e-9):
        nonlocal fails
        ok = abs(got - want) <= tol
        print("%s %s: %.12g (want %g)" % ("ok  " if ok else "FAIL", name, got, want))
        fails += not ok

    check("identical curves, BD-PSNR", bd_metric(base, base, "psnr")[0], 0)
    check("identical curves, BD-SSIM", bd_metric(base, base, "ssim")[0], 0)
    check("identical curves, BD-rate", bd_rate(base, base)[0], 0)
    check("+1 dB curve as reference, BD-PSNR", bd_metric(up, base, "psnr")[0], 1)
    check("+1 dB curve as test, BD-PSNR", bd_metric(base, up, "psnr")[0], -1)
    check("+0.01 SSIM curve, BD-SSIM", bd_metric(up, base, "ssim")[0], 0.01)
    if not bd_rate(up, base)[0] < 0:
        print("FAIL +1 dB curve needs fewer bits: BD-rate %g" % bd_rate(up, base)[0])
        fails += 1
    # shifted rates: only the shared part counts, and the shift is still 1 dB
    shifted = [dict(p, bpp=p["bpp"] * 1.5, psnr=p["psnr"] + 4 * math.log(1.5)
                    - 0.3 * (math.log(p["bpp"] * 1.5) ** 2 - math.log(p["bpp"]) ** 2) + 1)
               for p in base]
    check("+1 dB over a partly shared range", bd_metric(shifted, base, "psnr")[0], 1, 1e-7)
    # trimming keeps one bracketing point each side, and at least 4
    line = [(float(x), 0.0) for x in range(1, 11)]
    check("trim to [4, 6]: points", len(trim(line, 4, 6)), 5)
    check("trim to [4, 6]: first", trim(line, 4, 6)[0][0], 3)
    check("trim to [4.5, 4.6]: points", len(trim(line, 4.5, 4.6)), 4)
    # a rate-capped coder repeating its last file: duplicates dropped
    capped = base + [dict(base[-1])]
    check("repeated point, BD-PSNR", bd_metric(up, capped, "psnr")[0], 1)
    c = polyfit3([0, 1, 2, 3, 4], [1 - 2 * x + 0.5 * x ** 3 for x in range(5)])
    for k, want in enumerate([1, -2, 0, 0.5]):
        check("cubic coefficient %d" % k, c[k], want, 1e-9)
    if bd_metric(base[:3], base[:3], "psnr") is not None:
        print("FAIL three points must give n/a")
        fails += 1
    print("self-test: %s" % ("FAILED" if fails else "passed"))
    return 1 if fails else 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("results", nargs="?")
    ap.add_argument("--ref", default="gigaview", help="reference codec (default gigaview)")
    ap.add_argument("--tsv", help="write every cell to this file")
    ap.add_argument("--self-test", action="store_true")
    args = ap.parse_args()
    if args.self_test:
        return self_test()
    if not args.results:
        ap.error("a results TSV is needed")
    data, images, codecs = read_points(args.results)
    if args.ref not in codecs:
        sys.exit("bd.py: no %s points in %s" % (args.ref, args.results))
    anchors = [c for c in codecs if c != args.ref]
    psnr, ssim, rate = {}, {}, {}
    for img in images:
        ref = data[img].get(args.ref, [])
        for a in anchors:
            test = data[img].get(a, [])
            psnr[(img, a)] = bd_metric(ref, test, "psnr")
            ssim[(img, a)] = bd_metric(ref, test, "ssim")
            rate[(img, a)] = bd_rate(ref, test)
    table("== BD-PSNR, dB: %s minus the anchor (positive: %s better) ==" % (args.ref, args.ref),
          images, anchors, psnr, "%+.2f")
    table("== BD-SSIM-Y: %s minus the anchor ==" % args.ref, images, anchors, ssim, "%+.4f")
    table("== BD-rate, %%: %s's bits against the anchor's at equal PSNR (negative: %s smaller) =="
          % (args.ref, args.ref), images, anchors, rate, "%+.1f")
    print("Shared rate range of each BD-PSNR cell, bpp:")
    for img in images:
        print("  %s: " % img + ", ".join(
            "%s %.2f..%.2f" % (a, psnr[(img, a)][1], psnr[(img, a)][2])
            if psnr[(img, a)] else "%s none" % a for a in anchors))
    if args.tsv:
        with open(args.tsv, "w") as f:
            f.write("image\tcodec\tmetric\tvalue\tlo\thi\n")
            for name, cells in (("bd-psnr", psnr), ("bd-ssim", ssim), ("bd-rate-pct", rate)):
                for img in images:
                    for a in anchors:
                        v = cells[(img, a)]
                        if v:
                            f.write("%s\t%s\t%s\t%.6f\t%.6f\t%.6f\n" % (img, a, name, *v[:3]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
