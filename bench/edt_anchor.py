#!/usr/bin/python3
"""edt_anchor.py - the anchors of bench/edt-speed.sh on the same input.

    edt_anchor.py MASK.npy REPS [--save-opencv OUT.npy] [--scipy-reps N]

MASK.npy is the uint8 mask written by `edt_bench gen` (0 at the sites).
Times OpenCV cv2.distanceTransform(DIST_L2, DIST_MASK_PRECISE) and SciPy
scipy.ndimage.distance_transform_edt (best of REPS wall-clock runs each;
--scipy-reps overrides the count for SciPy, the slow one) and prints

    method NAME WxH MS MPX_S CPU_MS

like edt_bench (CPU_MS: best process CPU time of a call, every thread).  --save-opencv writes OpenCV's float32 distances for
`edt_bench run -c opencv=OUT.npy` to compare with the exact EDT.
"""
import sys
import time

import cv2
import numpy as np
import scipy
import scipy.ndimage


def best_of(reps, fn):
    """Best wall-clock and best process CPU time (every thread) of reps
    calls, and the last result."""
    best, best_cpu, out = float("inf"), float("inf"), None
    for _ in range(max(1, reps)):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        best = min(best, time.perf_counter() - t0)
        best_cpu = min(best_cpu, time.process_time() - c0)
    return best, best_cpu, out


def main():
    args = sys.argv[1:]
    if len(args) < 2:
        sys.exit(__doc__)
    mask = np.load(args[0])
    reps = int(args[1])
    save = None
    scipy_reps = reps
    rest = args[2:]
    while rest:
        if rest[0] == "--save-opencv" and len(rest) > 1:
            save, rest = rest[1], rest[2:]
        elif rest[0] == "--scipy-reps" and len(rest) > 1:
            scipy_reps, rest = int(rest[1]), rest[2:]
        else:
            sys.exit("edt_anchor.py: bad argument " + rest[0])
    h, w = mask.shape
    n = w * h
    print("# OpenCV %s (%d threads), SciPy %s, NumPy %s"
          % (cv2.__version__, cv2.getNumThreads(), scipy.__version__,
             np.__version__))
    t, c, d = best_of(reps, lambda: cv2.distanceTransform(
        mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE))
    print("method opencv %dx%d %.2f %.1f %.2f"
          % (w, h, t * 1e3, n / t / 1e6, c * 1e3), flush=True)
    if save:
        np.save(save, d.astype(np.float32, copy=False))
    del d
    t, c, d = best_of(scipy_reps,
                      lambda: scipy.ndimage.distance_transform_edt(mask))
    print("method scipy %dx%d %.2f %.1f %.2f"
          % (w, h, t * 1e3, n / t / 1e6, c * 1e3), flush=True)


if __name__ == "__main__":
    main()
