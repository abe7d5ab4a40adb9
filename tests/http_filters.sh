#!/bin/sh
# http_filters.sh - filter graphs as a service: gigaviewd's /v1/filters
# routes and POST /v1/images/{id}/filter end to end, and the sandbox of
# worker processes (docs/API.md "Filters", docs/FILTERS.md section 9).
#
# Covers: listing, storing (token required: 401 without or with a wrong
# one, 403 when no token is configured or storing is off; 201, then 200
# for the same document; the file written atomically and kept across a
# restart), reading and deleting graphs (stock graphs cannot be deleted);
# every kind of validation failure as 400 with its message, a GLSL
# compile error as 400 naming the module and line; running graphs on a
# colour and a gray store with the result checked pixel by pixel against
# the region endpoint (negate: 255 - v), every output form (PNG gray, RGB
# and RGBA; 16-bit TIFF with two scales; float TIFF; raw), the padding
# and alignment of the decoded region, request errors (400, 404, 413);
# and the sandbox: tiles keep being served while a shader that never ends
# runs; past filter_timeout_ms it gets 504, and the next job runs on a new
# worker; a worker killed during a job gets 500 and one killed while idle is replaced
# unnoticed; an out-of-bounds array write; a full queue gets 503 with
# Retry-After; SIGTERM cancels a job in flight and exits 0; gpu = off and
# a machine with no EGL answer 503 with the reason, and a build
# configured --without-gpu answers 501 not_implemented; gpu_platform reaches the
# workers.  /metrics counts it.
# Needs curl, python3 and oiiotool (openimageio-tools).
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
need_tool oiiotool

# Absolute before the cd below ($0 is relative under make distcheck).
conf=$(cd "$(dirname "$0")/../conf" && pwd)/gigaviewd.conf
S=$T/stores
mkdir "$S" "$T/w" "$T/lib" || bail "mkdir"
cd "$T/w" || bail "cd"

# Stores: x (3000x2000 RGB: levels 0-2 tiled, root 375x250 at level 3) and
# g (1200x800 gray).
run encode synth:3000x2000 -o "$S/x.gv"
[ "$rc" -eq 0 ] || bail "encode x: $(cat "$T/err")"
run encode synth:1200x800:gray -o "$S/g.gv"
[ "$rc" -eq 0 ] || bail "encode g: $(cat "$T/err")"

# The stock library of this test: negate and a 3x3 box blur (support 1),
# and a file that does not parse (skipped with a warning).
cat >"$T/lib/negate.json" <<'EOF'
{"name": "negate", "description": "1 - v per RGB channel", "output": "neg",
 "output_channels": 3,
 "modules": [{"id": "neg", "template": "point", "inputs": ["source"],
              "glsl": "vec4 v = $(FilterInput1)(rel_pos);\nreturn vec4(1.0 - v.rgb, v.a);"}]}
EOF
cat >"$T/lib/blur.json" <<'EOF'
{"name": "blur", "output": "b",
 "modules": [{"id": "b", "template": "point", "inputs": ["source"],
              "kernel": {"width": 3, "height": 3, "weights": [1,1,1,1,1,1,1,1,1],
                         "scale": 0.1111111111111111}}]}
EOF
printf '{"name": "broken"' >"$T/lib/broken.json"

TOKEN=s3cret-token
cat >"$T/f.conf" <<EOF
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 4
access_log = off
log_level = info
auth_token = "$TOKEN"
filter_dir = "$T/stored"
filter_library_dir = "$T/lib"
filter_workers = 2
filter_timeout_ms = $((GV_TEST_PATIENCE * 1000))
filter_compile_timeout_ms = $((GV_TEST_PATIENCE * 1000))
filter_max_jobs = 4
max_filter_pixels = 1M
filter_max_modules = 8
filter_max_json_bytes = 8K
filter_memory_limit = 256M
drain_timeout = 5
EOF

# ---------------------------------------------------------------- settings
missing=$("$GIGAVIEWD" -S | sed -n 's/^\(filter_[a-z_]*\|max_filter_pixels\) = .*/\1/p' |
    while read -r k; do grep -Eq "^#?$k = " "$conf" || echo "$k"; done)
check "conf/gigaviewd.conf documents every filter key" test -z "$missing"
check "-t accepts the filter settings" sh -c "'$GIGAVIEWD' -t -c '$T/f.conf' >/dev/null"
# Each bad line with the exact message -t prints.
while IFS='|' read -r bad want; do
    printf 'store_dir = "%s"\n%s\n' "$S" "$bad" >"$T/bad.conf"
    rc=0
    "$GIGAVIEWD" -t -c "$T/bad.conf" >/dev/null 2>"$T/err" || rc=$?
    if [ "$rc" -eq 1 ] && [ "$(cat "$T/err")" = "gigaviewd: $T/bad.conf:2: $want" ]; then
        ok "-t rejects '$bad' with file:line"
    else
        not_ok "-t rejects '$bad' (exit $rc)" "$(cat "$T/err")" "wanted: gigaviewd: $T/bad.conf:2: $want"
    fi
done <<'EOF2'
filter_workers = 65|filter_workers: 65 is outside 0..64
filter_timeout_ms = 5|filter_timeout_ms: 5 is outside 100..3600000
filter_memory_limit = 1X|filter_memory_limit: '1X' is not a size (digits with optional K, M, G, T)
max_filter_pixels = 0|max_filter_pixels: 0 is outside 1..268435456
filter_max_modules = 65|filter_max_modules: 65 is outside 1..64
filter_max_json_depth = x|filter_max_json_depth: 'x' is not a non-negative integer
EOF2

start_daemon "$T/f.conf"
diag "gigaviewd on port $PORT"

# post_graph FILE [CURL ARGS...]: POST /v1/filters with the token.
post_graph() {
    f=$1
    shift
    req -X POST -H "Authorization: Bearer $TOKEN" --data-binary "@$f" "$@" \
        "$(url /v1/filters)"
}
# run_filter JSON: POST /v1/images/x/filter with that body (or @file).
run_filter() {
    img=${2:-x}
    req -X POST -H 'Content-Type: application/json' --data-binary "$1" \
        "$(url "/v1/images/$img/filter")"
}
# expect DESC WANT-STATUS [MESSAGE-REGEX]: check the last req.
expect() {
    if [ "$code" != "$2" ]; then
        not_ok "$1 (got $code, wanted $2)" "$(head -c 600 "$T/b")"
    elif [ "$2" -ge 400 ] && ! error_body_ok "$2"; then
        not_ok "$1 ($2) but not the JSON error body" "$(head -c 600 "$T/b")"
    elif [ -n "${3:-}" ] && [ "$(json_get 'j["error"]["message"]')" != "$3" ]; then
        not_ok "$1 ($2) but not the message" "$(head -c 600 "$T/b")" "wanted: $3"
    else
        ok "$1 ($2)"
    fi
}
# expect_re DESCRIPTION STATUS PATTERN: expect, with the message matching
# the extended regular expression PATTERN, for messages that end in a
# driver's or the system's own words.
expect_re() {
    if [ "$code" != "$2" ]; then
        not_ok "$1 (got $code, wanted $2)" "$(head -c 600 "$T/b")"
    elif ! error_body_ok "$2"; then
        not_ok "$1 ($2) but not the JSON error body" "$(head -c 600 "$T/b")"
    elif ! json_get 'j["error"]["message"]' | grep -Eq -- "$3"; then
        not_ok "$1 ($2) but the message does not match /$3/" "$(head -c 600 "$T/b")"
    else
        ok "$1 ($2)"
    fi
}
metric() {
    curl -s "$(url /metrics)" | sed -n "s/^$1 //p"
}

# ---------------------------------------------------------------- list, get
req "$(url /v1/filters)"
expect "GET /v1/filters" 200
check "list: the two stock graphs, sorted, the broken file skipped" test "$(json_get '[(f["id"], f["stock"], f["name"]) for f in j["filters"]]')" = "[('blur', True, 'blur'), ('negate', True, 'negate')]"
check "list: negate's description and channels" test "$(json_get '[(f["description"], f["output_channels"], f["params"]) for f in j["filters"] if f["id"] == "negate"][0]')" = "('1 - v per RGB channel', 3, [])"
check "the broken stock file was logged" grep -q 'skipping .*broken.json' "$T/daemon.log"
req "$(url /v1/filters/blur)"
expect "GET /v1/filters/blur" 200
check "get: the document and the plan" test "$(json_get '(j["id"], j["stock"], j["graph"]["name"], j["plan"]["padding"], j["plan"]["textures"], [m["id"] for m in j["plan"]["modules"]])')" = "('blur', True, 'blur', [1, 1, 1, 1], 1, ['b'])"
req "$(url /v1/filters/nope)"
expect "GET an unknown graph" 404
req -X PUT "$(url /v1/filters/blur)"
expect "PUT /v1/filters/blur" 405

# Is there a GPU?  Without one the daemon serves no filters (503), and
# only the checks that need no worker run.
req "$(url /healthz)"
if [ "$(json_get 'j["gpu"].get("built", True)')" = False ]; then
    # configure --without-gpu: graphs are listed and validated (above; no
    # GPU needed), running or storing one is 501 not_implemented.
    run_filter '{"filter":"negate","region":[0,0,8,8]}'
    expect "not built: running a graph is 501" 501 "filter: filters need GPU support, which this gigaviewd lacks (configured --without-gpu)"
    check "not built: the code is not_implemented" test "$(json_get 'j["error"]["code"]')" = not_implemented
    post_graph "$T/lib/negate.json"
    expect "not built: storing a graph (it cannot be compiled) is 501" 501 "filter: filters need GPU support, which this gigaviewd lacks (configured --without-gpu)"
    printf '{"name": "bad", "output": "nope", "modules": []}' >bad.json
    post_graph bad.json
    expect "not built: an invalid graph is still refused (400)" 400
    check "not built: no worker started" sh -c "! grep -q 'ready in' '$T/daemon.log'"
    stop_daemon
    done_testing
fi
gpu_vendor=$(json_get 'j["gpu"]["vendor"]')
if [ "$(json_get 'j["gpu"]["available"]')" != True ]; then
    diag "no EGL context here: $(json_get 'j["gpu"]')"
    run_filter '{"filter":"negate","region":[0,0,8,8]}'
    expect_re "no GPU: running a graph is 503" 503 \
        "^filter: filters need an EGL context and there is none: gpu: no usable EGL context: "
    stop_daemon
    done_testing
fi
diag "$(grep ' filter: ' "$T/daemon.log" | head -n 4)"

# ---------------------------------------------------------------- store
cat >gain.json <<'EOF'
{"name": "gain", "output": "g", "output_channels": 4,
 "modules": [{"id": "g", "template": "point", "inputs": ["source"],
              "params": [{"name": "k", "min": 0, "max": 4, "default": 1}],
              "glsl": "vec4 v = $(FilterInput1)(rel_pos);\nreturn vec4(v.rgb * $(1), 0.5);"}]}
EOF
req -X POST --data-binary @gain.json "$(url /v1/filters)"
expect "store without a token" 401
check "401 carries WWW-Authenticate" test "$(header WWW-Authenticate)" = 'Bearer realm="gigaview"'
req -X POST -H "Authorization: Bearer wrong" --data-binary @gain.json "$(url /v1/filters)"
expect "store with a wrong token" 401
post_graph gain.json
expect "store a graph" 201
gid=$(json_get 'j["id"]')
check "store: the id is user- and 16 hex digits" sh -c "echo '$gid' | grep -Eq '^user-[0-9a-f]{16}\$'"
check "store: Location" test "$(header Location)" = "$BASE/v1/filters/$gid"
check "store: the file, and no temporary left" test "$(listing "$T/stored")" = "$gid.json"
check "store: the file holds the document" cmp -s gain.json "$T/stored/$gid.json"
post_graph gain.json
expect "store the same document again" 200
check "same document, same id, not created" test "$(json_get '(j["id"], j["created"])')" = "('$gid', False)"
req "$(url /v1/filters)"
check "list: the stored graph after the stock ones" test "$(json_get '[(f["id"], f["stock"]) for f in j["filters"]]')" = "[('blur', True), ('negate', True), ('$gid', False)]"
check "list: the stored graph's params" test "$(json_get '[f["params"] for f in j["filters"] if not f["stock"]][0]')" = "[{'module': 'g', 'name': 'k', 'min': 0.0, 'max': 4.0, 'default': 1.0}]"
req "$(url "/v1/filters/$gid")"
expect "GET the stored graph" 200

# ---------------------------------------------------------------- validation
# bad NAME MESSAGE JSON: POST /v1/filters must answer 400 with MESSAGE.
bad() {
    printf '%s' "$3" >bad.json
    post_graph bad.json
    expect "validation: $1" 400 "$2"
}
M='"output": "a", "modules": ['
P='"template": "point", "inputs": ["source"]'
bad "malformed JSON" "filter: JSON: string or '}' expected near end of file at line 1 column 14" '{"name": "x", '
bad "not an object" "filter: a graph must be a JSON object" '[1, 2]'
bad "no name" 'filter: "name" is required (1-127 bytes)' '{"output": "a", "modules": [{"id": "a", '"$P"', "glsl": "return vec4(1.0);"}]}'
bad "unknown key" 'filter: unknown key "nope"' '{"name": "x", "nope": 1, '"$M"'{"id": "a", '"$P"', "glsl": "return vec4(1.0);"}]}'
bad "unknown template" "filter: module 'a': unknown template (point, logreduce, propagation): blend" '{"name": "x", '"$M"'{"id": "a", "template": "blend", "inputs": ["source"], "glsl": "return vec4(1.0);"}]}'
bad "missing input" "filter: module 'a': input 1 names no module: \"zz\"" '{"name": "x", '"$M"'{"id": "a", "template": "point", "inputs": ["zz"], "glsl": "return vec4(1.0);"}]}'
bad "a cycle" "filter: the graph has a cycle: a <- b <- a" '{"name": "x", '"$M"'{"id": "a", "template": "point", "inputs": ["b"], "glsl": "return vec4(1.0);"}, {"id": "b", "template": "point", "inputs": ["a"], "glsl": "return vec4(1.0);"}]}'
bad "duplicate id" "filter: module 'a': duplicate id" '{"name": "x", '"$M"'{"id": "a", '"$P"', "glsl": "return vec4(1.0);"}, {"id": "a", '"$P"', "glsl": "return vec4(1.0);"}]}'
bad "parameter default out of range" "filter: module 'a': default outside [min, max]: param k" '{"name": "x", '"$M"'{"id": "a", '"$P"', "params": [{"name": "k", "min": 0, "max": 1, "default": 2}], "glsl": "return vec4($(1));"}]}'
bad "parameter min > max" "filter: module 'a': min > max: param k" '{"name": "x", '"$M"'{"id": "a", '"$P"', "params": [{"name": "k", "min": 2, "max": 1, "default": 1}], "glsl": "return vec4($(1));"}]}'
bad "register past the params" "filter: module 'a' line 1: \$(1) but the module has 0 params" '{"name": "x", '"$M"'{"id": "a", '"$P"', "glsl": "return vec4($(1));"}]}'
bad "kernel of the wrong size" "filter: module 'a': kernel \"weights\" must hold width x height = 9 numbers" '{"name": "x", '"$M"'{"id": "a", '"$P"', "kernel": {"width": 3, "height": 3, "weights": [1, 2]}}]}'
bad "output names no module" 'filter: "output" names no module: q' '{"name": "x", "output": "q", "modules": [{"id": "a", '"$P"', "glsl": "return vec4(1.0);"}]}'
bad "a uniform in a body" "filter: module 'a' line 1: 'uniform' is not allowed in a body (the template owns the interface)" '{"name": "x", '"$M"'{"id": "a", '"$P"', "glsl": "uniform float u;\nreturn vec4(u);"}]}'
mods=$(python3 -c 'print(", ".join("{\"id\": \"m%d\", \"template\": \"point\", \"inputs\": [\"source\"], \"glsl\": \"return vec4(1.0);\"}" % i for i in range(9)))')
bad "more modules than filter_max_modules" "filter: 9 modules exceed the limit of 8" '{"name": "x", "output": "m0", "modules": ['"$mods"']}'
python3 -c 'import json; print(json.dumps({"name": "x", "output": "a", "modules": [{"id": "a", "template": "point", "inputs": ["source"], "glsl": "// " + "x" * 9000 + "\nreturn vec4(1.0);"}]}))' >big.json
post_graph big.json
expect "validation: a document over filter_max_json_bytes" 400 \
    "filter: graph document of $(wc -c <big.json | tr -d ' ') bytes exceeds the limit of 8192"
printf '{"name": "x", "output": "a", "modules": [{"id": "a", "template": "point", "inputs": ["source"], "glsl": "vec4 v = $(FilterInput1)(rel_pos);\\nfloat y = v.r +;\\nreturn vec4(y);"}]}' >glsl.json
post_graph glsl.json
# The driver's words follow the line number.
expect_re "GLSL compile error" 400 "^filter: module 'a' line 2: "
diag "GLSL error: $(json_get 'j["error"]["message"]')"
check "nothing was stored by the failures" test "$(listing "$T/stored")" = "$gid.json"

# ---------------------------------------------------------------- delete
req -X DELETE "$(url "/v1/filters/$gid")"
expect "delete without a token" 401
req -X DELETE -H "Authorization: Bearer $TOKEN" "$(url /v1/filters/negate)"
expect "delete a stock graph" 403 "filter: 'negate' is a stock graph and cannot be deleted"
req -X DELETE -H "Authorization: Bearer $TOKEN" "$(url /v1/filters/user-0000000000000000)"
expect "delete an unknown graph" 404

# ---------------------------------------------------------------- run
# A region of level 1 and the same region from /region, as ground truth.
R='"level": 1, "region": [100, 50, 120, 80]'
curl -s -o region.png "$(url '/v1/images/x/region?level=1&x=100&y=50&w=120&h=80&format=png')"
curl -s -o gregion.png "$(url '/v1/images/g/region?level=0&x=300&y=200&w=64&h=48&format=png')"
cat >pix.py <<'PY'
# pix.py MODE ARGS: compare images through oiiotool --dumpdata.
import re, struct, subprocess, sys

def load(path):
    """(w, h, c, values): integer samples where the file has them, else floats."""
    # as stored: no premultiplication by alpha on reading
    out = subprocess.run(["oiiotool", "--iconfig", "oiio:UnassociatedAlpha", "1",
                          "--dumpdata", path], capture_output=True,
                         text=True, check=True).stdout
    head = re.search(r":\s*(\d+)\s*x\s*(\d+),\s*(\d+) channel", out)
    w, h, c = int(head[1]), int(head[2]), int(head[3])
    vals = []
    for line in out.splitlines():
        # integer files: "Pixel (x, y): 51 128 179 (0.2 0.50 0.70)"
        # float files:   "Pixel (x, y): 0.200000003 0.5 0.699999988"
        m = re.match(r"\s*Pixel \((\d+), (\d+)\): ([^(]*)(\(.*\))?", line)
        if m:
            vals.append([int(v) for v in m[3].split()] if m[4] else
                        [float(v) for v in m[3].split()])
    assert len(vals) == w * h, (len(vals), w, h)
    return w, h, c, vals

mode = sys.argv[1]
if mode == "size":
    w, h, c, _ = load(sys.argv[2])
    print(w, h, c)
elif mode == "negate":            # filtered.png region.png
    _, _, c, got = load(sys.argv[2])
    _, _, rc, ref = load(sys.argv[3])
    bad = [(i, g, r) for i, (g, r) in enumerate(zip(got, ref))
           if g[:3] != [255 - (r[k if rc == 3 else 0]) for k in range(min(c, 3))]]
    print("ok" if not bad else "mismatch %s" % bad[:3])
elif mode == "gain":              # filtered.png (RGBA) region.png k
    _, _, c, got = load(sys.argv[2])
    _, _, _, ref = load(sys.argv[3])
    k = float(sys.argv[4])
    bad = [(i, g, r) for i, (g, r) in enumerate(zip(got, ref))
           if c != 4 or g[3] != 128 or any(
               abs(g[j] - min(255, int(r[j] / 255 * k * 255 + 0.5))) > 1 for j in range(3))]
    print("ok" if not bad else "mismatch c=%d %s" % (c, bad[:3]))
elif mode in ("f32", "u16"):      # filtered.tif region.png [scale]
    _, _, c, got = load(sys.argv[2])
    _, _, _, ref = load(sys.argv[3])
    scale = float(sys.argv[4]) if len(sys.argv) > 4 else 65535
    bad = []
    for i, (g, r) in enumerate(zip(got, ref)):
        want = [1 - r[j] / 255 for j in range(3)]
        if mode == "f32":
            ok = all(abs(g[j] - want[j]) <= 1e-6 for j in range(3))
        else:
            ok = all(abs(g[j] - int(want[j] * scale + 0.5)) <= 1 for j in range(3))
        if not ok or c != 3:
            bad.append((i, g, r))
    print("ok" if not bad else "mismatch %s" % bad[:3])
elif mode == "raw":               # raw.bin filtered32f.tif w h c
    data = open(sys.argv[2], "rb").read()
    w, h, c = int(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6])
    assert len(data) == w * h * c * 4, len(data)
    raw = struct.unpack("<%df" % (w * h * c), data)
    _, _, _, tif = load(sys.argv[3])
    # dumpdata prints 9 significant digits: enough to round-trip a float32
    f32 = lambda v: struct.unpack("<f", struct.pack("<f", v))[0]
    bad = [i for i in range(w * h)
           if list(raw[i * c:i * c + c]) != [f32(v) for v in tif[i]]]
    print("ok" if not bad else "mismatch at %s" % bad[:3])
PY

run_filter "{\"filter\": \"negate\", $R}"
expect "run negate (stock, by id) as PNG" 200
cp "$T/b" neg.png
check "negate: Content-Type and size headers" test "$(header Content-Type) $(header X-Gigaview-Width) $(header X-Gigaview-Height) $(header X-Gigaview-Channels) $(header X-Gigaview-Level)" = "image/png 120 80 3 1"
check "negate: the PNG is 120x80 RGB" test "$(python3 pix.py size neg.png)" = "120 80 3"
check "negate: every pixel is 255 - the region's" test "$(python3 pix.py negate neg.png region.png)" = ok
check "negate: no padding" test "$(header X-Gigaview-Padded-Region)" = "100,50,120,80"
check "negate: one pass, one texture" test "$(header X-Gigaview-Filter-Passes) $(header X-Gigaview-Filter-Textures) $(header X-Gigaview-Filter-Merges-Skipped)" = "1 1 0"
check "negate: GPU and worker times reported" sh -c "echo '$(header X-Gigaview-Filter-Gpu-Ms) $(header X-Gigaview-Filter-Worker-Ms)' | grep -Eq '^[0-9]+\.[0-9]{3} [0-9]+\.[0-9]{3}\$'"
diag "negate 120x80: worker $(header X-Gigaview-Filter-Worker-Ms) ms, GPU $(header X-Gigaview-Filter-Gpu-Ms) ms"
check "negate: CORS exposes the filter headers" sh -c "grep -qi '^Access-Control-Expose-Headers: .*X-Gigaview-Filter-Passes' '$T/h'"

run_filter "{\"graph\": $(cat "$T/lib/negate.json"), $R, \"format\": \"tiff32f\"}"
expect "run negate inline as float TIFF" 200
cp "$T/b" neg32.tif
check "float TIFF: 1 - v/255 within 1e-6" test "$(python3 pix.py f32 neg32.tif region.png)" = ok
run_filter "{\"filter\": \"negate\", $R, \"format\": \"tiff16\"}"
expect "run negate as 16-bit TIFF" 200
cp "$T/b" neg16.tif
check "16-bit TIFF: round((1 - v/255) * 65535)" test "$(python3 pix.py u16 neg16.tif region.png)" = ok
run_filter "{\"filter\": \"negate\", $R, \"format\": \"tiff16\", \"scale\": 1000}"
expect "16-bit TIFF with scale 1000" 200
cp "$T/b" neg16s.tif
check "16-bit TIFF: round((1 - v/255) * 1000)" test "$(python3 pix.py u16 neg16s.tif region.png 1000)" = ok
run_filter "{\"filter\": \"negate\", $R, \"format\": \"raw\"}"
expect "run negate as raw floats" 200
cp "$T/b" neg.raw
check "raw: octet-stream, 120x80x3" test "$(header Content-Type) $(header X-Gigaview-Width) $(header X-Gigaview-Height) $(header X-Gigaview-Channels)" = "application/octet-stream 120 80 3"
check "raw: the float TIFF's values" test "$(python3 pix.py raw neg.raw neg32.tif 120 80 3)" = ok

run_filter "{\"filter\": \"$gid\", $R, \"params\": {\"g\": {\"k\": 1.5}}}"
expect "run the stored graph with a parameter" 200
cp "$T/b" gain.png
check "gain: RGBA PNG, rgb * 1.5, alpha 0.5" test "$(python3 pix.py gain gain.png region.png 1.5)" = ok

grayg='{"name": "luma", "output": "y", "output_channels": 1, "modules": [{"id": "y", "template": "point", "inputs": ["source"], "glsl": "vec4 v = $(FilterInput1)(rel_pos);\nreturn vec4(1.0 - v.g, 0.0, 0.0, 1.0);"}]}'
run_filter "{\"graph\": $grayg, \"region\": [300, 200, 64, 48]}" g
expect "a one-channel graph on the gray store" 200
cp "$T/b" gneg.png
check "gray store, one channel: a 64x48 gray PNG" test "$(python3 pix.py size gneg.png)" = "64 48 1"
check "gray store: the source reads (g, g, g, 1): 255 - g" test "$(python3 pix.py negate gneg.png gregion.png)" = ok
run_filter '{"filter": "negate", "region": [300, 200, 64, 48]}' g
cp "$T/b" gneg3.png
check "gray store through negate: RGB, each 255 - g" test "$code $(python3 pix.py negate gneg3.png gregion.png)" = "200 ok"

run_filter '{"filter": "blur", "level": 1, "region": [0, 10, 40, 30]}'
expect "blur at the left edge" 200
check "blur: padded by 1, clipped at the left edge" test "$(header X-Gigaview-Padded-Region)" = "0,9,41,32"
run_filter '{"filter": "blur", "level": 1, "region": [1460, 960, 40, 40]}'
check "blur: clipped at the right and bottom edges" test "$code $(header X-Gigaview-Padded-Region)" = "200 1459,959,41,41"
align='{"name": "bmax", "output": "show", "modules": [{"id": "max", "template": "logreduce", "max_passes": 3, "inputs": ["source"], "glsl": "ivec2 q = 2 * texel_pos;\nreturn max(max($(FilterInput1)(q), $(FilterInput1)(q + ivec2(1, 0))), max($(FilterInput1)(q + ivec2(0, 1)), $(FilterInput1)(q + ivec2(1, 1))));"}, {"id": "show", "template": "point", "inputs": ["max"], "glsl": "return $(FilterInput1)(rel_pos, 3);"}]}'
run_filter "{\"graph\": $align, \"region\": [13, 21, 30, 20]}"
expect "a log-reduce graph" 200
padded=$(header X-Gigaview-Padded-Region)
printf '%s' "$align" >align.json
post_graph align.json
req "$(url "/v1/filters/$(json_get 'j["id"]')")"
# docs/FILTERS.md section 5 from the plan's padding and alignment
want=$(json_get '",".join(str(v) for v in (lambda p, a: (max(0, 13 - p[0]) // a * a, max(0, 21 - p[1]) // a * a))(j["plan"]["padding"], j["plan"]["align"]) + (lambda p, a: (min(3000, 43 + p[2]) - max(0, 13 - p[0]) // a * a, min(2000, 41 + p[3]) - max(0, 21 - p[1]) // a * a))(j["plan"]["padding"], j["plan"]["align"]))')
check "log-reduce: padded by the plan, the corner aligned to $(json_get 'j["plan"]["align"]')" test "$padded" = "$want"
diag "log-reduce: plan padding $(json_get 'j["plan"]["padding"]'), padded region $padded"
req -X DELETE -H "Authorization: Bearer $TOKEN" "$(url "/v1/filters/$(json_get 'j["id"]')")"

# ---------------------------------------------------------------- request errors
run_filter '{"filter": "negate"}'
expect "no region" 400 'filter: "region" must be an array of 4 integers'
run_filter '{"filter": "negate", "region": [0, 0, 0, 5]}'
expect "a zero-width region" 400 'filter: "region"[2] must be an integer in 1..2147483647'
run_filter '{"filter": "negate", "level": 1, "region": [1400, 0, 200, 5]}'
expect "a region outside the level" 400 "filter: region 1400,0,200,5 is outside level 1 (1500x1000)"
run_filter '{"filter": "negate", "level": 40, "region": [0, 0, 5, 5]}'
expect "no such level" 400 "filter: no level 40 (0..12)"
run_filter '{"region": [0, 0, 5, 5]}'
exactly_one='filter: give exactly one of "graph" (a graph document) and "filter" (a graph id)'
expect "neither graph nor filter" 400 "$exactly_one"
run_filter "{\"filter\": \"negate\", \"graph\": $(cat "$T/lib/negate.json"), \"region\": [0, 0, 5, 5]}"
expect "both graph and filter" 400 "$exactly_one"
run_filter '{"filter": "negate", "region": [0, 0, 5, 5], "colour": 1}'
expect "an unknown key" 400 'filter: unknown key "colour" in the request'
run_filter '{"filter": "negate", "region": [0, 0, 5, 5], "format": "jpeg"}'
expect "an unknown format" 400 'filter: "format" must be "png", "tiff16", "tiff32f" or "raw"'
run_filter '{"filter": "negate", "region": [0, 0, 5, 5], "scale": -1}'
expect "a negative scale" 400 'filter: "scale" must be a positive number'
run_filter '{"filter": "negate", "region": [0, 0, 5, 5'
expect "a malformed body" 400 "filter: request body: JSON: ']' expected near end of file at line 1 column 42"
run_filter "{\"filter\": \"$gid\", \"region\": [0, 0, 5, 5], \"params\": {\"g\": {\"k\": 9}}}"
expect "a parameter out of range" 400 "filter: params: g.k = 9 is outside [0, 4]"
run_filter "{\"filter\": \"$gid\", \"region\": [0, 0, 5, 5], \"params\": {\"h\": {\"k\": 1}}}"
expect "a parameter of no module" 400 'filter: params: no module "h"'
run_filter '{"graph": {"name": "x"}, "region": [0, 0, 5, 5]}'
expect "an invalid inline graph" 400 'filter: "modules" must be a non-empty array'
run_filter '{"filter": "nope", "region": [0, 0, 5, 5]}'
expect "an unknown graph id" 404
run_filter '{"filter": "negate", "region": [0, 0, 5, 5]}' nope
expect "an unknown image" 404
run_filter '{"filter": "negate", "region": [0, 0, 1100, 1000]}'
expect "a region over max_filter_pixels" 413 \
    "filter: the padded region 1100x1000 (1100000 pixels) exceeds max_filter_pixels (1048576)"
run_filter '{"filter": "blur", "region": [1, 1, 1000, 1048]}'
expect "a padded region over max_filter_pixels" 413 \
    "filter: the padded region 1002x1050 (1052100 pixels) exceeds max_filter_pixels (1048576)"
req "$(url /v1/images/x/filter)"
expect "GET on the filter route" 405

# ---------------------------------------------------------------- sandbox
# A shader that does not end in any useful time.  llvmpipe stops every
# loop after 65535 iterations, so "for (;;)" ends too; this one does
# 65535 sines and cosines per pixel over a million pixels: about 6
# minutes of llvmpipe on two cores, far past any time limit here.  The
# jobs of this daemon have GV_TEST_PATIENCE seconds (filter_timeout_ms,
# filter_compile_timeout_ms), so that none meets them however slow the
# machine; the shader is ended by a killed worker, SIGTERM, or (in a daemon
# where it is the only job that runs) filter_timeout_ms.
spin='{"name": "spin", "output": "s", "modules": [{"id": "s", "template": "point", "inputs": ["source"], "glsl": "float s = $(FilterInput1)(rel_pos).r;\nfor (int i = 0; i < 100000000; i++) {\n  s = sin(s + float(i)) * 1.0001 + cos(s);\n  if (s > 1e30) break;\n}\nreturn vec4(s);"}]}'
printf '{"graph": %s, "region": [0, 0, 1000, 1000]}' "$spin" >spin.json
# metric_is NAME VALUE: /metrics shows VALUE for NAME.
# shellcheck disable=SC2317 # run by wait_until
metric_is() {
    [ "$(metric "$1")" = "$2" ]
}
# wait_workers N: until /metrics shows N workers.
wait_workers() {
    wait_until metric_is gigaview_filter_workers "$1"
}
# wait_running N: until /metrics shows N jobs in workers.
wait_running() {
    wait_until metric_is gigaview_filter_jobs_running "$1"
}
# spin_start: POST the endless shader in the background (spid), the
# status to spin.code and the body to spin.out.
spin_start() {
    curl -s -o spin.out -w '%{http_code}' -X POST --data-binary @spin.json \
        "$(url /v1/images/x/filter)" >spin.code &
    spid=$!
}

# Kill the workers during a job: 500, and the next job succeeds.
workers() {
    cat /proc/"$DPID"/task/*/children 2>/dev/null
}
# exited PID: PID has exited, socket closed: gone, or a zombie whose other
# threads have exited too (the leader turns zombie first, and the
# descriptors close with the last thread).
# shellcheck disable=SC2317 # run by wait_until
exited() {
    [ ! -e /proc/"$1" ] || {
        [ "$(sed 's/.*) \(.\).*/\1/' /proc/"$1"/stat 2>/dev/null)" = Z ] &&
            [ "$(ls /proc/"$1"/task 2>/dev/null | wc -l)" -le 1 ]
    }
}
# dead PID...: until each has exited.
dead() {
    for p in "$@"; do
        wait_until exited "$p"
    done
}
starts0=$(metric gigaview_filter_worker_starts_total)
wait_workers 2 # none starting: every child is a worker that said hello
spin_start
check "an endless shader: its job is running" wait_running 1
tiles=""
for t in 0/0/0 0/1/0 0/2/0 0/3/0 1/0/0 1/1/0 1/2/1 2/0/0 2/1/0 0/5/3; do
    tiles="$tiles -o /dev/null $(url /v1/images/x/tiles/$t)"
done
# shellcheck disable=SC2086
codes=$(curl -s -w '%{http_code} ' $tiles)
during=$(metric gigaview_filter_jobs_running)
check "tiles keep answering while the shader runs (one connection)" test "$codes" = "200 200 200 200 200 200 200 200 200 200 "
check "... and the shader was still running after them" test "$during" = 1
req "$(url '/iiif/3/x/full/375,250/0/default.png')"
check "IIIF keeps answering too" test "$code" = 200
pids=$(workers)
# shellcheck disable=SC2086
kill -KILL $pids 2>/dev/null
wait "$spid"
# shellcheck disable=SC2086
dead $pids # the idle one too: its socket closes only when it has exited
check "a worker killed during the job: 500" test "$(cat spin.code)" = 500
cp spin.out "$T/b"
check "500: worker_crashed, with the signal" test "$(json_get '(j["error"]["code"], j["error"]["message"])')" = \
    "('worker_crashed', 'filter: the worker process died during the job (killed by signal 9 (SIGKILL))')"
run_filter "{\"filter\": \"negate\", $R}"
check "the next job succeeds on a fresh worker" sh -c "test '$code' = 200 && cmp -s '$T/b' neg.png"

# A shader that crashes the worker for real: a local array of 50 million
# floats makes LLVM (llvmpipe's compiler) run into filter_memory_limit
# (RLIMIT_DATA) and abort with std::bad_alloc.  500, and the next job
# runs on a fresh worker.
huge='{"name": "huge", "output": "h", "modules": [{"id": "h", "template": "point", "inputs": ["source"], "glsl": "float a[50000000];\nint i = (abs_pos.x * 7919 + abs_pos.y * 104729) % 50000000;\na[i] = $(FilterInput1)(rel_pos).r;\nreturn vec4(a[(i * 31) % 50000000]);"}]}'
if grep -q 'memory limit not applied' "$T/daemon.log"; then
    skip "a shader that exhausts the worker's memory" "no memory limit in this build"
else
    run_filter "{\"graph\": $huge, \"region\": [0, 0, 64, 64]}"
    # The signal is the compiler's: an abort on std::bad_alloc, or a fault.
    expect_re "a shader that exhausts the worker's memory" 500 \
        '^filter: the worker process died during the job \(killed by signal [0-9]+ \(SIG[A-Z]+\)\)$'
    diag "huge array: $(json_get 'j["error"]["message"]')"
    run_filter "{\"filter\": \"negate\", $R}"
    check "the next job succeeds on a fresh worker" sh -c "test '$code' = 200 && cmp -s '$T/b' neg.png"
fi

# Kill the idle workers: they are replaced before they get a job.
run_filter "{\"filter\": \"negate\", $R}"
wait_workers 2
idle=$(workers)
# shellcheck disable=SC2086
kill -KILL $idle 2>/dev/null
# shellcheck disable=SC2086
dead $idle
for i in 1 2 3; do
    run_filter "{\"filter\": \"negate\", $R}"
    check "after killing idle workers, job $i succeeds" sh -c "test '$code' = 200 && cmp -s '$T/b' neg.png"
done
check "the dead idle workers were noticed" grep -q 'idle worker killed by signal 9' "$T/daemon.log"

# An out-of-bounds array write and read: GLSL defines no crash for it;
# whatever the driver does, the daemon answers and goes on.
oob='{"name": "oob", "output": "o", "modules": [{"id": "o", "template": "point", "inputs": ["source"], "glsl": "float a[4];\nint i = abs_pos.x * 1048576 + 123456789;\nfor (int k = 0; k < 4; k++) a[k] = 0.0;\na[i] = 1.0;\na[-i] = 2.0;\nreturn vec4(a[i & 1023], a[(i * 7) & 1023], 0.0, 1.0);"}]}'
run_filter "{\"graph\": $oob, \"region\": [0, 0, 64, 64]}"
oobcode=$code
diag "out-of-bounds write: $code $(head -c 200 "$T/b" | tr -cd '[:print:]')"
check "out-of-bounds array write: answered (200, or 400/500 from the worker)" sh -c "case '$oobcode' in 200|400|500) true;; *) false;; esac"
run_filter "{\"filter\": \"negate\", $R}"
check "after the out-of-bounds job, jobs succeed" sh -c "test '$code' = 200 && cmp -s '$T/b' neg.png"

req "$(url /metrics)"
check "metrics: jobs by result" sh -c "grep -q '^gigaview_filter_jobs_total{result=\"ok\"} [1-9]' '$T/b' && grep -q '^gigaview_filter_jobs_total{result=\"crash\"} [1-9]' '$T/b' && grep -q '^gigaview_filter_jobs_total{result=\"error\"} [1-9]' '$T/b'"
check "metrics: two workers running" test "$(metric gigaview_filter_workers)" = 2
check "metrics: the filter routes" sh -c "grep -q '^gigaview_http_requests_total{route=\"image_filter\",status=\"500\"} [1-9]' '$T/b' && grep -q '^gigaview_http_requests_total{route=\"filters\",status=\"200\"} [1-9]' '$T/b'"
diag "worker starts: $(metric gigaview_filter_worker_starts_total) (at the sandbox tests: $starts0)"

# SIGTERM with a job in flight: the job is cancelled after drain_timeout
# (503) and the daemon exits 0.
spin_start
wait_running 1 || diag "the job did not start"
dpid=$DPID
stop_daemon
wait "$spid"
cp spin.out "$T/b"
check "SIGTERM: the job in flight gets 503" test "$(cat spin.code) $(json_get '(j["error"]["code"], j["error"]["message"])')" = \
    "503 ('unavailable', 'filter: cancelled: the server is stopping')"
check "SIGTERM: exit status 0" test "$drc" -eq 0
check "SIGTERM: no worker left" sh -c "! pgrep -f 'gigaview-filter-worke[r] .*--parent $dpid '"

# ---------------------------------------------------------------- restart
post_again() {
    start_daemon "$1"
    req "$(url "/v1/filters/$gid")"
}
post_again "$T/f.conf"
expect "the stored graph is there after a restart" 200
req -X DELETE -H "Authorization: Bearer $TOKEN" "$(url "/v1/filters/$gid")"
expect "delete the stored graph" 204
check "delete: the file is gone" test -z "$(listing "$T/stored")"
req "$(url "/v1/filters/$gid")"
expect "deleted: 404" 404
req -X DELETE -H "Authorization: Bearer $TOKEN" "$(url "/v1/filters/$gid")"
expect "delete again: 404" 404
# SIGHUP reads the directories again: a new stock graph, one gone.
cp gain.json "$T/lib/gain.json"
rm "$T/lib/blur.json"
# library_is LIST: /v1/filters lists the ids LIST (a Python list).
# shellcheck disable=SC2317 # run by wait_until
library_is() {
    req "$(url /v1/filters)"
    [ "$(json_get '[f["id"] for f in j["filters"]]')" = "$1" ]
}
kill -HUP "$DPID"
wait_until library_is "['gain', 'negate']"
check "SIGHUP: the library read again" test "$(json_get '[f["id"] for f in j["filters"]]')" = "['gain', 'negate']"
stop_daemon

# ---------------------------------------------------------------- time limit
# A job past filter_timeout_ms gets 504, its worker killed, and the next
# job runs on a new worker.  The limit is 20 s here, and the endless
# shader is the only job it counts: one worker, and the job after it
# stores a graph (compiled under filter_compile_timeout_ms, GV_TEST_PATIENCE
# seconds), so no job that must succeed can meet the limit on a slow
# machine.
sed -e 's/^filter_workers = .*/filter_workers = 1/' \
    -e 's/^filter_timeout_ms = .*/filter_timeout_ms = 20000/' "$T/f.conf" >"$T/t.conf"
start_daemon "$T/t.conf"
wait_workers 1
t0=$(date +%s%N)
spin_start
wait "$spid"
t1=$(date +%s%N)
check "the endless shader gets 504" test "$(cat spin.code)" = 504
cp spin.out "$T/b"
check "504: the timeout error body" test "$(json_get '(j["error"]["code"], j["error"]["message"])')" = \
    "('timeout', 'filter: the job ran past the time limit of 20000 ms (filter_timeout_ms); its worker was killed')"
diag "504 after $(( (t1 - t0) / 1000000 )) ms (filter_timeout_ms = 20000)"
req "$(url /v1/images/x/tiles/0/0/0)"
check "tiles answer after the timeout" test "$code" = 200
wait_workers 1
post_graph gain.json
expect "the next job (storing a graph) runs on a new worker" 201
check "metrics: one timeout, a worker restarted" test "$(metric 'gigaview_filter_jobs_total{result="timeout"}') $(metric gigaview_filter_worker_restarts_total)" = "1 1"
diag "$(grep 'ready in' "$T/daemon.log" | tail -n 1)"
stop_daemon

# ---------------------------------------------------------------- a full queue
sed -e 's/^filter_workers = .*/filter_workers = 1/' \
    -e 's/^filter_max_jobs = .*/filter_max_jobs = 1/' \
    -e 's/^auth_token = .*/auth_token = ""/' "$T/f.conf" >"$T/q.conf"
start_daemon "$T/q.conf"
spin_start
wait_running 1 || diag "the job did not start"
run_filter "{\"filter\": \"negate\", $R}"
expect "a second job past filter_max_jobs = 1" 503 \
    "filter: 1 jobs are queued or running (filter_max_jobs), or the server is stopping; try again"
check "503 busy: Retry-After" test "$(header Retry-After)" = 1
post_graph gain.json
expect "no auth_token configured: storing is 403" 403 \
    "filter: storing and deleting graphs is disabled: no auth_token is configured"
check "metrics: one rejected job" test "$(metric gigaview_filter_jobs_rejected_total)" = 1
check "the first job is still running" test "$(metric gigaview_filter_jobs_running)" = 1
stop_daemon
wait "$spid"
check "... until SIGTERM cancels it (503)" test "$(cat spin.code)" = 503

# ---------------------------------------------------------------- no GPU
{ cat "$T/f.conf"; echo 'gpu = off'; } >"$T/off.conf"
start_daemon "$T/off.conf"
run_filter "{\"filter\": \"negate\", $R}"
expect "gpu = off: running a graph" 503 "filter: filters are disabled: they need the GPU, and gpu = off"
post_graph gain.json
expect "gpu = off: storing a graph (it cannot be compiled)" 503 \
    "filter: filters are disabled: they need the GPU, and gpu = off"
req "$(url /v1/filters)"
expect "gpu = off: the list still answers" 200
check "gpu = off: no worker started" sh -c "! grep -q 'ready in' '$T/daemon.log'"
stop_daemon

__EGL_VENDOR_LIBRARY_FILENAMES=$T/nonexistent.json
export __EGL_VENDOR_LIBRARY_FILENAMES
start_daemon "$T/f.conf"
unset __EGL_VENDOR_LIBRARY_FILENAMES
if grep -q ' info gpu: EGL ' "$T/daemon.log"; then
    skip "no EGL: running a graph is 503" "__EGL_VENDOR_LIBRARY_FILENAMES did not hide EGL here"
else
    run_filter "{\"filter\": \"negate\", $R}"
    expect_re "no EGL: running a graph" 503 \
        "^filter: filters need an EGL context and there is none: gpu: no usable EGL context: "
fi
stop_daemon

# gpu_platform reaches the workers: with Mesa's surfaceless platform
# forced, gigaviewd and every worker open their contexts there.
case $gpu_vendor in
*Mesa*)
    { cat "$T/f.conf"; echo 'gpu_platform = surfaceless'; } >"$T/sl.conf"
    start_daemon "$T/sl.conf"
    run_filter "{\"filter\": \"negate\", $R}"
    expect "gpu_platform = surfaceless: running a graph" 200
    check "gpu_platform = surfaceless: the workers say hello from it" sh -c "grep 'ready in' '$T/daemon.log' | grep -q '(surfaceless, ' && ! grep 'ready in' '$T/daemon.log' | grep -vq '(surfaceless, '"
    stop_daemon ;;
*)
    skip "gpu_platform = surfaceless: running a graph" "the EGL driver is not Mesa ($gpu_vendor)"
    skip "gpu_platform = surfaceless: the workers say hello from it" "the EGL driver is not Mesa" ;;
esac

{ cat "$T/f.conf"; echo 'filter_worker = "/nonexistent/worker"'; } >"$T/nw.conf"
start_daemon "$T/nw.conf"
run_filter "{\"filter\": \"negate\", $R}"
expect "a missing worker program: 503" 503 \
    "filter: filters are unavailable: filter_worker /nonexistent/worker: No such file or directory"
stop_daemon

if [ "$tap_failed" -ne 0 ]; then
    diag "daemon log (tail):"
    diag "$(tail -n 40 "$T/daemon.log")"
fi
done_testing
