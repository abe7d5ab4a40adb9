#!/bin/sh
# systemd_unit.sh - conf/gigaviewd.service lets gigaviewd and its filter
# workers make every system call they make, and its exposure score does
# not regress.
#
# The unit's SystemCallFilter= lines are expanded with systemd-analyze
# syscall-filter into the set of allowed calls (allow list, then the
# "~" lines taken out, later allow lines added back, @default always in).
# gigaviewd then runs under strace -f with the EGL context opened at
# start (gpu = auto) and two filter workers, and serves tiles, a batch, a
# region, an IIIF image, metrics, two filter jobs (Mesa compiles and runs
# them), a SIGHUP rescan and a SIGTERM drain.  Every system call any of
# the processes made must be in the allowed set: one that is not would
# kill the service with SIGSYS in production (where there is no strace to
# show why).  Finally `systemd-analyze security --offline=yes` must rate
# the unit at most 1.2 (docs/OPERATIONS.md records the score and why each
# remaining point stays).  Skipped without systemd-analyze or strace, and
# under valgrind; the traced run is skipped for a sanitizer build.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

unit="$(cd "$(dirname "$0")/.." && pwd)/conf/gigaviewd.service"
for t in systemd-analyze strace; do
    if ! command -v "$t" >/dev/null 2>&1; then
        echo "1..0 # SKIP $t is not installed"
        exit 0
    fi
done
if under_valgrind; then
    echo "1..0 # SKIP strace and valgrind do not mix"
    exit 0
fi
[ -f "$unit" ] || bail "no $unit"

# ---------------------------------------------------------------- allowed set
python3 - "$unit" >"$T/allowed" 2>"$T/allowed.err" <<'PY' || bail "expanding the filter: $(cat "$T/allowed.err")"
import subprocess, sys
groups = {}
def expand(name, seen=()):
    if not name.startswith('@'):
        return {name}
    if name not in groups:
        out = subprocess.run(['systemd-analyze', 'syscall-filter', name],
                             capture_output=True, text=True).stdout
        members = [l.strip() for l in out.splitlines()[1:]
                   if l.startswith('    ') and not l.strip().startswith('#')]
        if not members:
            sys.exit('unknown group ' + name)
        groups[name] = members
    s = set()
    for m in groups[name]:
        if m not in seen:
            s |= expand(m, seen + (name,))
    return s
allowed, mode = set(), None
for line in open(sys.argv[1]):
    line = line.strip()
    if not line.startswith('SystemCallFilter='):
        continue
    v = line.split('=', 1)[1].strip()
    deny = v.startswith('~')
    names = set()
    for w in v.lstrip('~').split():
        names |= expand(w.split(':')[0])
    if mode is None:
        mode = 'deny' if deny else 'allow'
        if mode == 'deny':
            sys.exit('a deny-list filter: nothing to check')
        allowed = names | expand('@default')
    elif deny:
        allowed -= names
    else:
        allowed |= names
print('\n'.join(sorted(allowed)))
PY
ok "the unit's SystemCallFilter allows $(wc -l <"$T/allowed" | tr -d ' ') system calls"

# ---------------------------------------------------------------- traced run
# A sanitizer build makes calls of its own (shadow memory), and its leak
# checker needs ptrace, which strace holds: not what production runs.
sanitized=
ldd "$GIGAVIEWD" 2>/dev/null | grep -q 'libasan\|libubsan\|libtsan' && sanitized=1
if [ -n "$sanitized" ]; then
    skip "the traced run" "a sanitizer build"
else
S=$T/stores
mkdir "$S" "$T/lib" "$T/stored" || bail "mkdir"
run encode synth:1500x1000 -o "$S/x.gv"
[ "$rc" -eq 0 ] || bail "encode: $(cat "$T/err")"
cat >"$T/lib/negate.json" <<'EOF'
{"name": "negate", "output": "neg", "output_channels": 3,
 "modules": [{"id": "neg", "template": "point", "inputs": ["source"],
              "glsl": "vec4 v = $(FilterInput1)(rel_pos);\nreturn vec4(1.0 - v.rgb, v.a);"}]}
EOF
cat >"$T/lib/blur.json" <<'EOF'
{"name": "blur", "output": "b",
 "modules": [{"id": "b", "template": "point", "inputs": ["source"],
              "kernel": {"width": 3, "height": 3, "weights": [1,1,1,1,1,1,1,1,1],
                         "scale": 0.1111111111111111}}]}
EOF
cat >"$T/u.conf" <<EOF2
store_dir = "$S"
threads = 2
access_log = off
gpu = auto
filter_workers = 2
filter_dir = "$T/stored"
filter_library_dir = "$T/lib"
EOF2
# start_daemon runs "$GIGAVIEWD"; run it under strace instead.
real_gvd=$GIGAVIEWD
cat >"$T/traced" <<EOF2
#!/bin/sh
exec strace -f -qq -o "$T/trace" "$real_gvd" "\$@"
EOF2
chmod +x "$T/traced"
GIGAVIEWD=$T/traced
start_daemon "$T/u.conf"
GIGAVIEWD=$real_gvd
for p in /v1/images/x/tiles/0/0/0 "/v1/images/x/batch?t=0,0,0;1,0,0" \
    "/v1/images/x/region?level=1&x=0&y=0&w=300&h=200&format=png" \
    /iiif/3/x/full/200,/0/default.jpg /metrics /healthz; do
    expect_status "traced: GET $p" 200 "$p"
done
for f in negate blur; do
    req -X POST --data "{\"filter\":\"$f\",\"region\":[0,0,128,96]}" "$(url /v1/images/x/filter)"
    if [ "$code" = 200 ]; then ok "traced: filter $f (200)"
    elif grep -q "no usable EGL\|EGL" "$T/b"; then skip "traced: filter $f" "no EGL here"
    elif [ "$code" = 501 ] && grep -q 'without-gpu' "$T/b"; then skip "traced: filter $f" "built without the GPU"
    else not_ok "traced: filter $f (got $code)" "$(head -c 300 "$T/b")"; fi
done
# $DPID is strace; the daemon is its child.  strace exits with the
# daemon's status.
gvpid=$(pgrep -P "$DPID" | head -n 1)
kill -HUP "$gvpid"
sleep 1
expect_status "traced: after SIGHUP" 200 /healthz
kill -TERM "$gvpid"
drc=0
wait "$DPID" || drc=$?
DPID=
check "traced: SIGTERM, exit 0" test "$drc" -eq 0
awk '{ s = $2; if (s ~ /^[a-z_0-9]+\(/) { sub(/\(.*/, "", s); print s } }' "$T/trace" |
    sort -u >"$T/used"
diag "$(wc -l <"$T/used" | tr -d ' ') distinct system calls made by $(awk '{print $1}' "$T/trace" | sort -u | wc -l | tr -d ' ') processes and threads"
denied=$(comm -23 "$T/used" "$T/allowed" | tr '\n' ' ')
if [ -z "$denied" ]; then
    ok "every system call made is allowed by the unit"
else
    not_ok "system calls the unit would kill the service for: $denied" \
        "$(for s in $denied; do grep -m 2 " $s(" "$T/trace"; done)"
fi
fi # the traced run

# ---------------------------------------------------------------- exposure score
score=$(systemd-analyze security --offline=yes "$unit" 2>/dev/null |
    sed -n 's/.*Overall exposure level for [^:]*: \([0-9.]*\).*/\1/p')
diag "systemd-analyze security: $score"
check "exposure score at most 1.2 (is ${score:-none})" \
    awk -v s="${score:-99}" 'BEGIN { exit !(s <= 1.2) }'
done_testing
