#!/bin/sh
# http_mesh.sh - GET /v1/images/{id}/mesh on a height store, against
# `gigaview mesh` on the same store, with the limits of its three keys.
#
# A small ETOPO crop is encoded as a height store.  The route must answer
# every format with the bytes the command writes for the same request, put
# the measured error (never above max_error) in X-Mesh-Max-Error also when
# the answer comes from the output cache, give the same border vertices to
# two regions that share an edge, and refuse with the JSON error shape:
# bad queries (400), an image store (400), max_mesh_samples and
# max_mesh_triangles (413, asked or needed), mesh_time_limit (504).
# Last, `gigaview mesh` alone: an image file meshes as its lossless height
# store, --tile gives the same file on any thread count, and bad
# arguments are refused.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
cd "$T/w" || bail "cd"
run encode --height --max-error 2 --unit m --offset -11000 \
    "$TESTDATA/etopo-600x400-u16.png" -o "$S/dem.gv"
[ "$rc" -eq 0 ] || bail "encode height: $(cat "$T/err")"
run encode synth:600x400 -o "$S/img.gv"
[ "$rc" -eq 0 ] || bail "encode image: $(cat "$T/err")"
cat >"$T/m.conf" <<EOF2
store_dir = "$S"
threads = 2
access_log = off
max_mesh_samples = 40000
max_mesh_triangles = 50000
mesh_time_limit = 30
EOF2
start_daemon "$T/m.conf"

# the same bytes as the command, in every format
for f in glb qmesh ply obj; do
    run mesh "$S/dem.gv" --level 0 --region 64,32,128,96 --max-error 15 \
        --format "$f" -o "$T/cli.$f"
    [ "$rc" -eq 0 ] || not_ok "gigaview mesh $f" "$(cat "$T/err")"
    req "$(url "/v1/images/dem/mesh?level=0&region=64,32,128,96&max_error=15&format=$f")"
    check "$f: 200" test "$code" = 200
    check "$f: the bytes of gigaview mesh" cmp -s "$T/b" "$T/cli.$f"
    e=$(header X-Mesh-Max-Error)
    check "$f: X-Mesh-Max-Error $e <= 15" python3 -c "import sys; assert 0 < float(sys.argv[1]) <= 15" "$e"
done
check "content type of obj" test "$(header Content-Type)" = "model/obj"
# a cached answer carries the error too
req "$(url "/v1/images/dem/mesh?level=0&region=64,32,128,96&max_error=15&format=glb")"
check "cached glb: the same error header" test "$(header X-Mesh-Max-Error)" = "$(python3 -c "
import json,struct,sys
b=open(sys.argv[1],'rb').read(); n=struct.unpack_from('<I',b,12)[0]
print(b[20:20+n].decode().split('\"maxError\":')[1].split(',')[0])" "$T/b")"
check "glb: starts with glTF" test "$(head -c 4 "$T/b")" = "glTF"

# max_triangles, and level 1
req "$(url "/v1/images/dem/mesh?level=1&region=0,0,100,80&max_triangles=300&format=obj")"
check "max_triangles=300: 200" test "$code" = 200
n=$(grep -c '^f ' "$T/b")
check "max_triangles=300: $n triangles" test "$n" -le 300 -a "$n" -gt 200

# neighbours share their border vertices (OBJ: x east, y = -row)
req "$(url "/v1/images/dem/mesh?region=0,0,100,100&max_error=8&format=obj")"
awk '$1 == "v" && $2 == 100 { print $3 }' "$T/b" | sort -n >"$T/east"
req "$(url "/v1/images/dem/mesh?region=100,0,100,100&max_error=8&format=obj")"
awk '$1 == "v" && $2 == 100 { print $3 }' "$T/b" | sort -n >"$T/west"
check "shared edge: $(wc -l <"$T/east") vertices on both sides" \
    sh -c "[ \$(wc -l <'$T/east') -gt 2 ] && cmp -s '$T/east' '$T/west'"

# errors
expect_status "no region" 400 "/v1/images/dem/mesh?max_error=1"
expect_status "bad region" 400 "/v1/images/dem/mesh?region=1,2,3&max_error=1"
expect_status "no goal" 400 "/v1/images/dem/mesh?region=0,0,10,10"
expect_status "negative error" 400 "/v1/images/dem/mesh?region=0,0,10,10&max_error=-1"
expect_status "bad format" 400 "/v1/images/dem/mesh?region=0,0,10,10&max_error=1&format=stl"
expect_status "outside the level" 400 "/v1/images/dem/mesh?region=550,0,100,10&max_error=1"
expect_status "an image store" 400 "/v1/images/img/mesh?region=0,0,10,10&max_error=1"
expect_status "unknown image" 404 "/v1/images/nope/mesh?region=0,0,10,10&max_error=1"
expect_status "max_mesh_samples: 199x199 grid" 200 "/v1/images/dem/mesh?region=0,0,198,198&max_error=50"
expect_status "max_mesh_samples: 201x200 grid" 413 "/v1/images/dem/mesh?region=0,0,200,199&max_error=50"
check "413 names max_mesh_samples" grep -q max_mesh_samples "$T/b"
expect_status "max_triangles over the key" 413 "/v1/images/dem/mesh?region=0,0,10,10&max_triangles=50001"
expect_status "max_error needing more triangles" 413 "/v1/images/dem/mesh?region=0,0,198,198&max_error=0"
check "413 names max_mesh_triangles" grep -q max_mesh_triangles "$T/b"
stop_daemon
check "daemon exits 0" test "$drc" = 0

# the time limit: a server allowed 10 ms per mesh, a lossless mesh
cat >"$T/t.conf" <<EOF2
store_dir = "$S"
threads = 2
access_log = off
max_mesh_triangles = 1000000
mesh_time_limit = 0.01
EOF2
start_daemon "$T/t.conf"
expect_status "mesh_time_limit" 504 "/v1/images/dem/mesh?region=0,0,599,399&max_error=0"
stop_daemon

# gigaview mesh: an image file gives the mesh of its lossless height store
run encode --height --offset -11000 "$TESTDATA/etopo-600x400-u16.png" -o "$S/dem0.gv"
[ "$rc" -eq 0 ] || bail "encode lossless: $(cat "$T/err")"
run mesh "$S/dem0.gv" --region 10,20,200,150 --max-error 12 -o "$T/store.ply"
check "mesh of a lossless store" test "$rc" = 0
run mesh "$TESTDATA/etopo-600x400-u16.png" --offset -11000 --region 10,20,200,150 \
    --max-error 12 -o "$T/image.ply"
check "mesh of the image: the same file" cmp -s "$T/store.ply" "$T/image.ply"
run mesh "$S/dem0.gv" --region 0,0,599,399 --max-error 12 --tile 64 -j 3 -o "$T/t3.obj"
run mesh "$S/dem0.gv" --region 0,0,599,399 --max-error 12 --tile 64 -j 1 -o "$T/t1.obj"
check "--tile: the same mesh on 1 and 3 threads" cmp -s "$T/t1.obj" "$T/t3.obj"
run mesh "$S/dem0.gv" --region 0,0,10,10 -o "$T/x.obj"
check "no goal: usage (2)" test "$rc" = 2
run mesh "$S/dem0.gv" --max-triangles 100 --tile 8 -o "$T/x.obj"
check "--tile with --max-triangles: usage (2)" test "$rc" = 2
run mesh "$S/dem0.gv" --max-error 1 -o "$T/x.stl"
check "unknown format: usage (2)" test "$rc" = 2
run mesh "$TESTDATA/etopo-600x400-u16.png" --level 1 --max-error 1 -o "$T/x.obj"
check "an image has only level 0 (1)" test "$rc" = 1
run mesh "$S/img.gv" --max-error 1 -o "$T/x.obj"
check "an image store is refused (1)" sh -c "[ $rc = 1 ] && grep -q 'not a height store' '$T/err'"
done_testing
