#!/usr/bin/python3
"""simplify_open3d.py IN FACES OUT - the Open3D anchor of simplify-speed.sh:
simplify_vertex_clustering (a uniform voxel grid, averaged vertices) with
the voxel size bisected until the face count is as near FACES as 30 steps
get; prints the best time of 3 calls at that voxel size and the faces
achieved, and writes the result as binary PLY.  Debian's python3-open3d
(run by /usr/bin/python3)."""
import sys, time
import open3d as o3d

inp, faces, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
m = o3d.io.read_triangle_mesh(inp)
lo, hi = 0.0, max(m.get_max_bound() - m.get_min_bound())
avg = o3d.geometry.SimplificationContraction.Average
best = None
for _ in range(30):
    v = (lo + hi) / 2
    n = len(m.simplify_vertex_clustering(v, avg).triangles)
    if best is None or abs(n - faces) < abs(best[1] - faces):
        best = (v, n)
    if n > faces:
        lo = v
    else:
        hi = v
v = best[0]
t = 1e30
for _ in range(3):
    t0 = time.perf_counter()
    r = m.simplify_vertex_clustering(v, avg)
    t = min(t, time.perf_counter() - t0)
o3d.io.write_triangle_mesh(out, r, write_ascii=False)
print("open3d ms %.3f faces %d voxel %.6g" % (t * 1e3, len(r.triangles), v))
