#!/bin/sh
# http_simplify.sh - POST /v1/meshes/simplify against `gigaview simplify`
# on the same mesh, with the limits of its keys.
#
# A 70x70 grid surface (9800 triangles) is written as OBJ.  The route must
# answer every format with the bytes the command writes for the same
# request (the server may select on its GPU, the command on another
# context or the CPU: the file is the same), put the counts in X-Faces and
# X-Faces-Asked, and refuse with the JSON error shape: bad queries and
# malformed files (400), big-endian PLY (501), faces asked or in the file
# over simplify_max_faces and a body over simplify_max_bytes (413), another
# method (405).
#
# The work runs in the filter worker processes: /metrics counts each job
# that reached one (gigaview_worker_jobs_total{kind="simplify"}) and the
# answer carries X-Gigaview-Worker-Ms.  With the test worker
# (tests/gigaview-filter-worker-hooks, GV_TEST_WORKER_SIMPLIFY=1) a mesh
# that starts with "#gv-test:crash" kills its worker with SIGSEGV (500),
# and the next mesh gets the same bytes as before from a new worker; one
# that starts with "#gv-test:hang" never ends (504 at simplify_time_limit,
# the worker killed), and the next job (storing a filter graph) runs on a
# new worker.  The jobs that must succeed run under limits of
# GV_TEST_PATIENCE s: the endless one gets a daemon of its own, where
# it is the only simplification under the short limit.  Skipped where gigaviewd has
# no worker pool (no EGL, a build without the GPU: the 503 or 501 of the
# filters is checked instead).
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

mkdir "$T/s" "$T/w" || bail "mkdir"
cd "$T/w" || bail "cd"
grid() {   # grid N FILE: an N x N cell surface as OBJ
    python3 - "$1" "$2" <<'PY'
import math, sys
n = int(sys.argv[1])
with open(sys.argv[2], "w") as f:
    for j in range(n + 1):
        for i in range(n + 1):
            f.write("v %d %d %.4f\n" % (i, j, 4 * math.sin(i / 9.0) * math.cos(j / 7.0)))
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i + 1
            f.write("f %d %d %d\nf %d %d %d\n" % (a, a + 1, a + n + 2, a, a + n + 2, a + n + 1))
PY
}
grid 70 in.obj || bail "grid"
grid 120 big.obj || bail "grid"
cat >"$T/m.conf" <<EOF2
store_dir = "$T/s"
threads = 2
access_log = off
simplify_max_bytes = 600K
simplify_max_faces = 20000
simplify_time_limit = $GV_TEST_PATIENCE
EOF2
start_daemon "$T/m.conf"

req --data-binary @in.obj "$(url "/v1/meshes/simplify?faces=1000")"
if [ "$code" = 503 ] || [ "$code" = 501 ]; then
    check "no worker pool: the filters' JSON error ($code)" error_body_ok "$code"
    skip "simplification in the workers" "no filter workers here: $(head -c 200 "$T/b")"
    stop_daemon
    done_testing
    exit 0
fi
check "X-Gigaview-Worker-Ms: the job ran in a worker" \
    test -n "$(header X-Gigaview-Worker-Ms)"

for f in glb ply obj; do
    run simplify in.obj --faces 1000 -o "cli.$f"
    [ "$rc" -eq 0 ] || not_ok "gigaview simplify $f" "$(cat "$T/err")"
    req --data-binary @in.obj "$(url "/v1/meshes/simplify?faces=1000&format=$f")"
    check "$f: 200" test "$code" = 200
    check "$f: the bytes of gigaview simplify" cmp -s "$T/b" "cli.$f"
done
check "content type of obj" test "$(header Content-Type)" = "model/obj"
n=$(grep -c '^f ' "$T/b")
check "X-Faces = the file's $n triangles" test "$(header X-Faces)" = "$n"
check "X-Faces-Asked 1000" test "$(header X-Faces-Asked)" = 1000
check "faces $n within 2% of 1000" test "$n" -ge 980 -a "$n" -le 1020
req --data-binary @in.obj "$(url "/v1/meshes/simplify?ratio=0.25&format=ply")"
check "ratio=0.25: 200, asked 2450" test "$code" = 200 -a "$(header X-Faces-Asked)" = 2450
check "ply: starts with ply" test "$(head -c 3 "$T/b")" = "ply"
run simplify "$T/b" --ratio 1 -o again.obj
check "the answer reads back" test "$rc" -eq 0
req --data-binary @in.obj "$(url "/v1/meshes/simplify?faces=500&interp=paper")"
check "interp=paper: 200" test "$code" = 200

D="--data-binary @in.obj"
expect_status "no faces or ratio" 400 "/v1/meshes/simplify" $D
expect_status "both faces and ratio" 400 "/v1/meshes/simplify?faces=5&ratio=0.5" $D
expect_status "ratio 2" 400 "/v1/meshes/simplify?ratio=2" $D
expect_status "faces 0" 400 "/v1/meshes/simplify?faces=0" $D
expect_status "format qmesh" 400 "/v1/meshes/simplify?faces=9&format=qmesh" $D
expect_status "empty body" 400 "/v1/meshes/simplify?faces=9" --data-binary ""
printf 'v 0 0 0\nf 1 2 3\n' >bad.obj
expect_status "index past the vertices" 400 "/v1/meshes/simplify?faces=9" --data-binary @bad.obj
printf 'ply\nformat binary_big_endian 1.0\nend_header\n' >be.ply
expect_status "big-endian PLY" 501 "/v1/meshes/simplify?faces=9" --data-binary @be.ply
expect_status "faces over simplify_max_faces" 413 "/v1/meshes/simplify?faces=20001" $D
head -c 300000 big.obj | sed '$d' >bigv.obj
grep '^f ' big.obj | head -n 20001 | awk '{print "f 1 2 3"}' >>bigv.obj
expect_status "a file over simplify_max_faces" 413 "/v1/meshes/simplify?faces=9" --data-binary @bigv.obj
expect_status "a body over simplify_max_bytes" 413 "/v1/meshes/simplify?faces=9" --data-binary @big.obj
expect_status "GET" 405 "/v1/meshes/simplify?faces=9"
# Jobs that reached a worker: the first request, three formats, ratio,
# paper, and the bad index, big-endian and over-the-limit files (the
# query errors, faces=20001 and the oversized body are refused before).
curl -s "$(url /metrics)" >metrics.txt
check "metrics: 9 simplify jobs sent to workers" \
    grep -qx 'gigaview_worker_jobs_total{kind="simplify"} 9' metrics.txt
stop_daemon
check "daemon exited cleanly" test "$drc" -eq 0

# ------------------------------------------------- hostile meshes (hooks)
hooks=$(dirname "$GIGAVIEW")/tests/gigaview-filter-worker-hooks
if [ ! -x "$hooks" ]; then
    skip "hostile meshes" "no $hooks"
    done_testing
    exit 0
fi
cat >"$T/h.conf" <<EOF2
store_dir = "$T/s"
threads = 2
access_log = off
log_level = info
filter_workers = 1
filter_worker = "$hooks"
simplify_time_limit = $GV_TEST_PATIENCE
drain_timeout = 1
EOF2
GV_TEST_WORKER_SIMPLIFY=1
export GV_TEST_WORKER_SIMPLIFY
start_daemon "$T/h.conf"
{ echo "#gv-test:crash"; cat in.obj; } >crash.obj
{ echo "#gv-test:hang"; cat in.obj; } >hang.obj
req --data-binary @crash.obj "$(url "/v1/meshes/simplify?faces=1000&format=obj")"
check "a mesh that crashes its worker: 500" test "$code" = 500
check "500: the worker died of SIGSEGV" test "$(json_get 'j["error"]["message"]')" = \
    "simplify: the worker process died during the job (killed by signal 11 (SIGSEGV))"
req --data-binary @in.obj "$(url "/v1/meshes/simplify?faces=1000&format=obj")"
check "after the crash: 200, the bytes of gigaview simplify" \
    sh -c "[ $code = 200 ] && cmp -s '$T/b' cli.obj"
curl -s "$(url /metrics)" >metrics.txt
check "metrics: one crash, a worker replaced" sh -c \
    "grep -qx 'gigaview_filter_jobs_total{result=\"crash\"} 1' metrics.txt &&
     grep -qx 'gigaview_filter_worker_restarts_total 1' metrics.txt"
stop_daemon
check "daemon exited cleanly" test "$drc" -eq 0

# The endless mesh, the only simplification of a daemon with a 4 s limit;
# the job after it stores a graph (compiled under
# filter_compile_timeout_ms, GV_TEST_PATIENCE s) on the new worker.
sed "s/^simplify_time_limit = .*/simplify_time_limit = 4/" "$T/h.conf" >"$T/t.conf"
cat >>"$T/t.conf" <<EOF2
auth_token = "t0ken"
filter_dir = "$T/graphs"
filter_compile_timeout_ms = $((GV_TEST_PATIENCE * 1000))
EOF2
mkdir "$T/graphs" || bail "mkdir"
start_daemon "$T/t.conf"
req --data-binary @hang.obj "$(url "/v1/meshes/simplify?faces=1000&format=obj")"
check "a mesh that never ends: 504" test "$code" = 504
check "504: the time limit's message" test "$(json_get 'j["error"]["message"]')" = \
    "simplify: the job ran past the time limit of 4000 ms (simplify_time_limit); its worker was killed"
cat >graph.json <<'EOF2'
{"name": "g", "output": "g", "modules": [{"id": "g", "template": "point", "inputs": ["source"], "glsl": "return $(FilterInput1)(rel_pos);"}]}
EOF2
req -X POST -H "Authorization: Bearer t0ken" --data-binary @graph.json "$(url /v1/filters)"
check "after the timeout: the next job (storing a graph) runs on a new worker (got $code)" \
    test "$code" = 201
curl -s "$(url /metrics)" >metrics.txt
check "metrics: one timeout, a worker replaced" sh -c \
    "grep -qx 'gigaview_filter_jobs_total{result=\"timeout\"} 1' metrics.txt &&
     grep -qx 'gigaview_filter_worker_restarts_total 1' metrics.txt"
stop_daemon
unset GV_TEST_WORKER_SIMPLIFY
check "daemon exited cleanly" test "$drc" -eq 0
done_testing
