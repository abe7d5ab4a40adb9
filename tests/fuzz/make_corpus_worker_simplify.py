#!/usr/bin/env python3
"""make_corpus_worker_simplify.py - writes the simplify seeds of the
fuzz_worker corpus (tests/fuzz/corpus/worker/simplify-*): frames of the
GV_WORKER_SIMPLIFY job and its answers (filters/worker.h).

    python3 tests/fuzz/make_corpus_worker_simplify.py tests/fuzz/corpus/worker

Byte 0 picks the reader (tests/fuzz/fuzz_worker.c): 3 the worker's loop,
4 the server reading a simplify answer.
"""
import os
import struct
import sys

MAGIC = 0x57465647
SIMPLIFY, DONE, FAILED = 6, 4, 5
GLB, PLY, OBJ = 0, 2, 3


def frame(kind, body, length=None):
    return struct.pack("<IIQ", MAGIC, kind, len(body) if length is None else length) + body


def job(mesh, faces=4, ratio=-1.0, mode=0, fmt=OBJ, max_bytes=16384,
        max_verts=300, max_tris=100, max_faces=100, time_limit=5.0):
    return struct.pack("<QdIIQIIIdQ", faces, ratio, mode, fmt, max_bytes,
                       max_verts, max_tris, max_faces, time_limit, len(mesh)) + mesh


def done(mesh, in_v=9, in_t=8, out_v=4, out_t=2, asked=2, n=None):
    return struct.pack("<IIIIQIIddddQ", in_v, in_t, out_v, out_t, asked, 1, 3,
                       0.1, 0.2, 0.3, 0.4, len(mesh) if n is None else n) + mesh


def grid(n):
    v = ["v %d %d %d" % (i, j, (i * j) % 3) for j in range(n + 1) for i in range(n + 1)]
    f = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i + 1
            f.append("f %d %d %d" % (a, a + 1, a + n + 2))
            f.append("f %d %d %d" % (a, a + n + 2, a + n + 1))
    return ("\n".join(v + f) + "\n").encode()


def main():
    out = sys.argv[1]
    mesh = grid(3)
    seeds = {
        # the worker: a good job (OBJ), the same as PLY output with a
        # ratio and the paper's interpolation, then a bad format
        "simplify-worker-jobs": b"\x03" + frame(SIMPLIFY, job(mesh)) +
        frame(SIMPLIFY, job(mesh, faces=0, ratio=0.5, mode=1, fmt=PLY)) +
        frame(SIMPLIFY, job(mesh, fmt=1)),
        # a malformed mesh, a mesh over the limits, a NaN time limit
        "simplify-worker-bad-mesh": b"\x03" +
        frame(SIMPLIFY, job(b"v 0 0 0\nf 1 2 3\n")) +
        frame(SIMPLIFY, job(mesh, max_tris=2)) +
        frame(SIMPLIFY, job(mesh, time_limit=float("nan"))),
        # a header announcing 4 GiB, then a short body and end of file
        "simplify-worker-huge-length": b"\x03" +
        frame(SIMPLIFY, job(mesh)[:80], length=0xFFFFFFFF),
        # the mesh length disagrees with the frame
        "simplify-worker-length-mismatch": b"\x03" +
        frame(SIMPLIFY, job(mesh)[:52] + struct.pack("<Q", 7) + mesh),
        # the server: a good answer, one too big, counts over the input's,
        # a lying length, a failure
        "simplify-done": b"\x04" + frame(DONE, done(b"ply\nformat binary")),
        "simplify-done-too-big": b"\x04" + frame(DONE, done(b"x" * 16), length=72 + 5000),
        "simplify-done-bad-counts": b"\x04" + frame(DONE, done(b"abc", out_t=99)),
        "simplify-done-length-mismatch": b"\x04" + frame(DONE, done(b"abc", n=2)),
        "simplify-failed": b"\x04" + frame(FAILED, struct.pack("<II", 3, 11) + b"bad\x01mesh\nxx"),
    }
    for name, data in seeds.items():
        with open(os.path.join(out, name), "wb") as f:
            f.write(data)


if __name__ == "__main__":
    main()
