#!/usr/bin/env python3
"""make_corpus_mesh.py - writes the fuzz_mesh_read seed corpus
(tests/fuzz/corpus/mesh_read): small valid PLY (ascii, binary), OBJ and GLB
meshes and hostile variants (truncated, huge counts, bad indices, offsets
past the end, big endian, NaN).  Byte 0 of each file is fuzz_mesh_read's
reader selector.  Deterministic: rerunning gives the same files."""
import json, os, struct, sys

here = os.path.dirname(os.path.abspath(__file__))
out = os.path.join(here, "corpus", "mesh_read")
os.makedirs(out, exist_ok=True)
for f in os.listdir(out):
    if not f.startswith("finding-"):
        os.remove(os.path.join(out, f))

def put(name, sel, data):
    with open(os.path.join(out, name), "wb") as f:
        f.write(bytes([sel]) + data)

# A small grid: 5x5 vertices, 32 triangles.
V = [(i, j, (i * j) % 3 * 0.5) for j in range(5) for i in range(5)]
T = []
for j in range(4):
    for i in range(4):
        a = j * 5 + i
        T += [(a, a + 1, a + 6), (a, a + 6, a + 5)]

def ply_ascii(v, t, extra=""):
    h = ("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\n"
         "property float y\nproperty float z\nelement face %d\n"
         "property list uchar int vertex_indices\n%send_header\n"
         % (len(v), len(t), extra))
    return (h + "".join("%g %g %g\n" % p for p in v) +
            "".join("3 %d %d %d\n" % f for f in t)).encode()

def ply_bin(v, t, fmt="binary_little_endian"):
    h = ("ply\nformat %s 1.0\nelement vertex %d\nproperty float x\n"
         "property float y\nproperty float z\nproperty uchar flags\n"
         "element face %d\nproperty list uchar uint vertex_indices\n"
         "element edge 1\nproperty int a\nproperty list uchar short b\n"
         "end_header\n" % (fmt, len(v), len(t))).encode()
    b = b"".join(struct.pack("<fffB", *p, 7) for p in v)
    b += b"".join(struct.pack("<BIII", 3, *f) for f in t)
    b += struct.pack("<iBhh", 1, 2, 3, 4)
    return h + b

def obj(v, t):
    s = "# grid\no g\n" + "".join("v %g %g %g\n" % p for p in v)
    s += "vt 0 0\nvn 0 0 1\n"
    s += "".join("f %d/1/1 %d/1/1 %d/1/1\n" % (a + 1, b + 1, c + 1) for a, b, c in t)
    s += "f -1 -2 -3 -4\n"
    return s.encode()

def glb(v, t, idx_type=5125, js_patch=None, stride=0):
    pos = b"".join(struct.pack("<fff", *p) for p in v)
    fmt = {5121: "B", 5123: "H", 5125: "I"}[idx_type]
    idx = b"".join(struct.pack("<" + fmt, i) for f in t for i in f)
    while len(idx) % 4:
        idx += b"\0"
    j = {"asset": {"version": "2.0"}, "buffers": [{"byteLength": len(pos) + len(idx)}],
         "bufferViews": [{"buffer": 0, "byteLength": len(pos)},
                         {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)}],
         "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(v), "type": "VEC3"},
                       {"bufferView": 1, "componentType": idx_type, "count": 3 * len(t), "type": "SCALAR"}],
         "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1},
                                    {"attributes": {"POSITION": 0}, "mode": 4}]}]}
    if stride:
        j["bufferViews"][0]["byteStride"] = stride
    if js_patch:
        js_patch(j)
    js = json.dumps(j).encode()
    while len(js) % 4:
        js += b" "
    binc = pos + idx
    total = 12 + 8 + len(js) + 8 + len(binc)
    return (struct.pack("<III", 0x46546C67, 2, total) + struct.pack("<II", len(js), 0x4E4F534A)
            + js + struct.pack("<II", len(binc), 0x004E4942) + binc)

V2 = V[:24]   # unindexed primitive needs a multiple of 3 vertices
put("ply-ascii", 0, ply_ascii(V, T))
put("ply-ascii-quad", 1, ply_ascii(V[:4], []).replace(b"element face 0", b"element face 1") + b"4 0 1 2 3\n")
put("ply-binary", 0, ply_bin(V, T))
put("ply-big-endian", 0, ply_bin(V, T, "binary_big_endian"))
put("ply-truncated", 1, ply_bin(V, T)[:-40])
put("ply-huge-count", 1, ply_ascii(V, T).replace(b"vertex 25", b"vertex 4000000000"))
put("ply-bad-index", 1, ply_ascii(V, T).replace(b"3 0 1 6", b"3 0 1 600"))
put("ply-nan", 1, ply_ascii(V, T).replace(b"0 0 0\n", b"nan 0 0\n", 1))
put("ply-no-end-header", 1, b"ply\nformat ascii 1.0\nelement vertex 1\n")
put("ply-list-count-float", 1, ply_ascii(V, T).replace(b"list uchar int", b"list float int"))
put("obj", 0, obj(V, T))
put("obj-negative-out", 2, b"v 0 0 0\nv 1 0 0\nf -1 -2 -3\n")
put("obj-zero-index", 2, b"v 0 0 0\nf 0 1 2\n")
put("obj-huge-polygon", 2, b"v 0 0 0\nf " + b"1 " * 400 + b"\n")
put("obj-no-newline", 2, b"v 1 2 3\nv 4 5 6\nv 7 8 9\nf 1 2 3")
put("glb", 0, glb(V2, T[:8]))
put("glb-u8", 3, glb(V2, T[:8], 5121))
put("glb-u16", 3, glb(V2, T[:8], 5123))
put("glb-offset-past", 3, glb(V2, T[:8], js_patch=lambda j: j["bufferViews"][1].update(byteOffset=1 << 40)))
put("glb-count-past", 3, glb(V2, T[:8], js_patch=lambda j: j["accessors"][0].update(count=1 << 31)))
put("glb-uri", 3, glb(V2, T[:8], js_patch=lambda j: j["buffers"][0].update(uri="x.bin")))
put("glb-sparse", 3, glb(V2, T[:8], js_patch=lambda j: j["accessors"][0].update(sparse={})))
put("glb-bad-json", 3, glb(V2, T[:8]).replace(b'"asset"', b'"asset\x01'))
put("glb-truncated", 3, glb(V2, T[:8])[:-30])
put("empty", 0, b"")
