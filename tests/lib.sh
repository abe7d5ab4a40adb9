# lib.sh - shared helpers for the shell tests (tests/cli_*.sh).
#
# Sourced, not run.  Gives every test a TAP stream (ok/not ok lines, plan
# at the end), a private scratch directory removed on exit, and `gv`, which
# runs the gigaview binary - under valgrind when VALGRIND is set to
# anything but "" or 0 (make check VALGRIND=1), so that memory errors and
# definite leaks fail the test with status 99 (tests/valgrind.supp lists
# what is not ours).
#
# Environment (set by make check; defaults let a test run by hand from the
# build directory): GIGAVIEW, the binary; TESTDATA, tests/data.
# POSIX sh only: the harness runs the tests with $(SHELL).
#
# No outcome may depend on how fast the machine is.  A test waits for what
# must happen (a daemon's first line, an answer, a page's element) with
# wait_until, req or GV_TEST_PATIENCE: seconds after which the wait is
# called a hang.  It is generous on purpose: on a busy machine, in the
# sanitizer build, work that takes 0.2 s idle (loading OpenImageIO's 260
# libraries) has taken over 30 s; the bound only decides how long a real
# hang takes to be reported.  The browser scripts get it through the
# environment (tests/browser/chromium.mjs).

set -u

: "${GIGAVIEW:=./gigaview}"
: "${TESTDATA:=$(cd "$(dirname "$0")" && pwd)/data}"
: "${VALGRIND:=}"
: "${GV_TEST_PATIENCE:=240}"
export GIGAVIEW TESTDATA VALGRIND GV_TEST_PATIENCE

tap_n=0
tap_failed=0

# ok DESCRIPTION / not_ok DESCRIPTION [DETAIL...]
ok() {
    tap_n=$((tap_n + 1))
    echo "ok $tap_n - $*"
}
not_ok() {
    tap_n=$((tap_n + 1))
    tap_failed=$((tap_failed + 1))
    echo "not ok $tap_n - $1"
    shift
    for line in "$@"; do
        printf '%s\n' "$line" | sed 's/^/#   /'
    done
}
# skip DESCRIPTION REASON
skip() {
    tap_n=$((tap_n + 1))
    echo "ok $tap_n - $1 # SKIP $2"
}
# check DESCRIPTION COMMAND...: passes when COMMAND exits 0.
check() {
    desc=$1
    shift
    if "$@"; then ok "$desc"; else not_ok "$desc" "failed: $*"; fi
}
# diag TEXT: a TAP comment.
diag() {
    printf '%s\n' "$*" | sed 's/^/# /'
}
# bail TEXT: stop the whole test (set-up failure).
bail() {
    echo "Bail out! $*"
    exit 99
}
# done_testing: print the plan and exit with the verdict.
done_testing() {
    echo "1..$tap_n"
    [ "$tap_failed" -eq 0 ] && exit 0
    exit 1
}

under_valgrind() {
    [ -n "$VALGRIND" ] && [ "$VALGRIND" != 0 ]
}

# wait_until CMD...: run CMD every 0.1 s until it succeeds (status 0), or
# until GV_TEST_PATIENCE seconds have passed (status 1).
wait_until() {
    wait_end=$(($(date +%s) + GV_TEST_PATIENCE))
    until "$@"; do
        [ "$(date +%s)" -lt "$wait_end" ] || return 1
        sleep 0.1
    done
}

# browser_preflight [NEEDED] [COVERED]: set CHROMIUM (default
# /usr/bin/chromium), srcdir and BROWSER_DIR (tests/browser) for a headless
# Chromium test, or skip the whole test (TAP "1..0 # SKIP", exit 0) when
# chromium, node 20 or later, tests/browser/node_modules/playwright-core
# or tests/browser/node_modules/NEEDED (a file or folder, if given) is
# missing, and under valgrind (COVERED says which test covers the server
# there).  BROWSER_HANG is the bound on a whole browser script (its
# `timeout`), after which it is called a hang: each of its waits has
# GV_TEST_PATIENCE, and a script has several.
browser_preflight() {
    : "${CHROMIUM:=/usr/bin/chromium}"
    BROWSER_HANG=$((GV_TEST_PATIENCE * 8))
    srcdir=${top_srcdir:-$(dirname "$0")/..}
    BROWSER_DIR=$(cd "$srcdir/tests/browser" && pwd)
    if [ ! -x "$CHROMIUM" ]; then
        echo "1..0 # SKIP $CHROMIUM not installed (apt-get install chromium)"
        exit 0
    fi
    if ! command -v node >/dev/null 2>&1; then
        echo "1..0 # SKIP node not installed (apt-get install nodejs npm)"
        exit 0
    fi
    node_major=$(node -p 'process.versions.node.split(".")[0]' 2>/dev/null || echo 0)
    if [ "$node_major" -lt 20 ]; then
        echo "1..0 # SKIP node $node_major is too old for playwright-core (needs 20)"
        exit 0
    fi
    if [ ! -d "$BROWSER_DIR/node_modules/playwright-core" ] ||
        { [ -n "${1:-}" ] && [ ! -e "$BROWSER_DIR/node_modules/$1" ]; }; then
        echo "1..0 # SKIP no tests/browser/node_modules${1:+ with $1} (cd tests/browser && npm ci)"
        exit 0
    fi
    if under_valgrind; then
        echo "1..0 # SKIP browser timings are not meant for valgrind (${2:-gigaviewd is covered by http_api.sh})"
        exit 0
    fi
}

# browser_relay OUT RC NAME: the PASS/FAIL/# lines a browser script wrote
# to OUT as TAP, and a failed "NAME ran" check when it exited with RC != 0
# without saying FAIL.
browser_relay() {
    while IFS= read -r line; do
        case $line in
        "PASS "*) ok "${line#PASS }" ;;
        "FAIL "*) not_ok "${line#FAIL }" ;;
        "#"*) printf '%s\n' "$line" ;;
        *) diag "$line" ;;
        esac
    done <"$1"
    if [ "$2" -ne 0 ] && ! grep -q '^FAIL ' "$1"; then
        not_ok "$3 ran (exit $2)" "$(tail -n 20 "$1")"
    fi
}

# gv ARGS...: run gigaview (under valgrind when asked).
gv() {
    if under_valgrind; then
        valgrind -q --error-exitcode=99 --leak-check=full \
            --errors-for-leak-kinds=definite --show-leak-kinds=definite \
            --suppressions="$(dirname "$0")/valgrind.supp" \
            "$GIGAVIEW" "$@"
    else
        "$GIGAVIEW" "$@"
    fi
}

# run ARGS...: gv with stdout to $T/out, stderr to $T/err, status in $rc.
# Never fails (so set -e style callers are safe).
run() {
    rc=0
    gv "$@" >"$T/out" 2>"$T/err" || rc=$?
}

# expect_rc DESCRIPTION WANT: check $rc from the last run.
expect_rc() {
    if [ "$rc" -eq "$2" ]; then
        ok "$1 (exit $2)"
    else
        not_ok "$1 (exit $rc, wanted $2)" "stderr: $(head -c 2000 "$T/err")"
    fi
}

# expect_err DESCRIPTION PATTERN: stderr of the last run matches the
# extended regular expression PATTERN.
expect_err() {
    if grep -Eq -- "$2" "$T/err"; then
        ok "$1"
    else
        not_ok "$1" "stderr does not match /$2/:" "$(head -c 2000 "$T/err")"
    fi
}

# expect_err_is DESCRIPTION TEXT: stderr of the last run is exactly TEXT
# (all of it; lines separated by newlines).
expect_err_is() {
    if [ "$(cat "$T/err")" = "$2" ]; then
        ok "$1"
    else
        not_ok "$1" "stderr:" "$(head -c 2000 "$T/err")" "wanted:" "$2"
    fi
}

# Scratch directory, removed on exit whatever happens.
T=$(mktemp -d "${TMPDIR:-/tmp}/gvtest.XXXXXX") || bail "mktemp -d failed"
cleanup() {
    chmod -R u+w "$T" 2>/dev/null
    rm -rf "$T"
}
trap cleanup EXIT
trap 'exit 130' INT TERM HUP

# listing DIR: its entries, one a line (hidden ones included), for
# "nothing was left behind" checks.
listing() {
    ls -A "$1"
}

# kill_at_progress PID FILE PERCENT SIGNAL: wait until the progress line
# (`gigaview encode --progress`) that process PID writes to FILE reaches
# PERCENT, or PID ends (or GV_TEST_PATIENCE seconds pass), then send it
# SIGNAL and reap it; sets $status.  A kill at a point of the work, not of
# the clock: a loaded or a fast machine moves it in time only.
kill_at_progress() {
    kp_end=$(($(date +%s) + GV_TEST_PATIENCE))
    kp_i=0
    while kill -0 "$1" 2>/dev/null; do
        kp_got=$(tr '\r' '\n' <"$2" | sed -n 's/.* \([0-9][0-9]*\)\.[0-9]%.*/\1/p' | tail -n 1)
        [ -n "$kp_got" ] && [ "$kp_got" -ge "$3" ] && break
        kp_i=$((kp_i + 1))
        [ $((kp_i % 100)) -ne 0 ] || [ "$(date +%s)" -lt "$kp_end" ] || break
        sleep 0.01
    done
    kill -s "$4" "$1" 2>/dev/null
    status=0
    wait "$1" || status=$?
}

# peak_rss_preflight: end the test as skipped (exit 0) where a peak RSS
# measures nothing: without GNU time (Debian package `time`), under
# valgrind, and in a sanitizer build (AddressSanitizer's shadow memory and
# quarantine inflate RSS).
peak_rss_preflight() {
    if [ ! -x /usr/bin/time ]; then
        echo "1..0 # SKIP /usr/bin/time not installed (apt-get install time)"
        exit 0
    fi
    if under_valgrind; then
        echo "1..0 # SKIP peak memory is meaningless under valgrind"
        exit 0
    fi
    if ldd "$GIGAVIEW" 2>/dev/null | grep -q libasan; then
        echo "1..0 # SKIP peak memory is meaningless in a sanitizer build"
        exit 0
    fi
}

# peak_kib ARGS...: run gigaview ARGS (stdout in $T/out, stderr in
# $T/err), print its peak RSS in KiB; bail if it fails.
peak_kib() {
    /usr/bin/time -f '%M' -o "$T/rss" "$GIGAVIEW" "$@" >"$T/out" 2>"$T/err" ||
        bail "gigaview $* failed: $(cat "$T/err")"
    tail -n 1 "$T/rss"
}

# close_to A B EPS: |A - B| <= EPS (decimal numbers).
close_to() {
    awk -v a="$1" -v b="$2" -v e="$3" \
        'BEGIN { d = a - b; if (d < 0) d = -d; exit !(a != "" && b != "" && d <= e) }'
}

# idiff_psnr REF TEST: the "Peak SNR" idiff prints.
idiff_psnr() {
    idiff "$1" "$2" 2>/dev/null | sed -n 's/.*Peak SNR = *//p'
}

# json_field FILE NAME: the first numeric value of "NAME": in FILE.
json_field() {
    grep -o "\"$2\":[-0-9.]*" "$1" | head -n 1 | cut -d: -f2
}

# need_tool TOOL...: bail out unless every TOOL is on PATH.
need_tool() {
    for t in "$@"; do
        command -v "$t" >/dev/null 2>&1 ||
            bail "$t is needed (see README: apt-get install openimageio-tools)"
    done
}

# image_size FILE: "W H C" of an image file, from oiiotool --info.
image_size() {
    oiiotool --info "$1" 2>/dev/null |
        sed -n 's/.*: *\([0-9]*\) x *\([0-9]*\), \([0-9]*\) channel.*/\1 \2 \3/p'
}

# filter_setup SIZE: the set-up of the filter-worker tests
# (filter_seccomp.sh, systemd_unit.sh): S=$T/stores holding x.gv, encoded
# from synth:SIZE, and a filter library in $T/lib with negate (1 - v per
# RGB channel) and blur (a 3x3 box).
filter_setup() {
    S=$T/stores
    mkdir "$S" "$T/lib" || bail "mkdir"
    run encode "synth:$1" -o "$S/x.gv"
    [ "$rc" -eq 0 ] || bail "encode: $(cat "$T/err")"
    cat >"$T/lib/negate.json" <<'EOF_NEGATE'
{"name": "negate", "output": "neg", "output_channels": 3,
 "modules": [{"id": "neg", "template": "point", "inputs": ["source"],
              "glsl": "vec4 v = $(FilterInput1)(rel_pos);\nreturn vec4(1.0 - v.rgb, v.a);"}]}
EOF_NEGATE
    cat >"$T/lib/blur.json" <<'EOF_BLUR'
{"name": "blur", "output": "b",
 "modules": [{"id": "b", "template": "point", "inputs": ["source"],
              "kernel": {"width": 3, "height": 3, "weights": [1,1,1,1,1,1,1,1,1],
                         "scale": 0.1111111111111111}}]}
EOF_BLUR
}
