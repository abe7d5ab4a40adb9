#!/bin/sh
# readme.sh - README.md as a test: every command block runs, exactly as
# written, and what the README says comes out does.
#
# Every fenced block of README.md is a command block.  Lines of the form
#     <!-- readme-test: DIRECTIVE: TEXT -->
# directly above a block's opening fence (no other line between them and
# the fence) say how to test it:
#   skip: REASON    the block is not run (REASON is required): the commands
#                   that cannot run inside the suite (the demo, the suite
#                   itself, a daemon in the foreground)
#   needs: gpu      the block is run only when the daemon has an EGL context
#                   (it is a TAP SKIP otherwise: a build --without-gpu)
#   check: COMMAND  after the block, COMMAND must exit 0: a documented
#                   output (an image's size, a listing, the merged store
#                   equal to the unsharded one)
# Any other directive, a skip without a reason, a directive that no fence
# follows and an unskipped block that starts gigaviewd in the foreground
# fail the test, so a new block is never left out silently.
#
# The blocks run in order, each logical line (joined at a trailing
# backslash) on its own with sh -c, in one scratch directory holding:
#   build/      a link to the build directory (GIGAVIEW's)
#   stores/     seeding.gv, the sample photograph encoded, served by a
#               gigaviewd started as scripts/demo.sh starts it (stock
#               filters found from the build tree), on a free port;
#               "127.0.0.1:8080" in commands and checks becomes its address
#   the inputs the README names: photo.jpg (the sample), big.tif, r?c?.tif
#               (a 4x3 mosaic), dem-u16.png, huge.tif (small test images)
# and on PATH: curl, which fails on an HTTP error (--fail-with-body), and
# image-size FILE, which prints WIDTHxHEIGHT.  A command that exits non-0,
# that names an output (-o FILE) it did not write, or that runs past 300 s
# fails.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
need_tool oiiotool
srcroot=$(cd "$(dirname "$0")/.." && pwd)
readme=${GV_README:-$srcroot/README.md}   # another README: the test's own test
[ -f "$readme" ] || bail "no $readme"

# ---------------------------------------------------------------- the plan
# One directory per block under $T/plan: meta (line, skip reason, needs),
# cmd.N and check.N; errors lists the directives refused.
mkdir "$T/plan" || bail "mkdir"
python3 - "$readme" "$T/plan" <<'PY' || bail "cannot read $readme"
import os, re, sys
readme, plan = sys.argv[1], sys.argv[2]
lines = open(readme, encoding="utf-8").read().split("\n")
directive = re.compile(r"^<!--\s*readme-test:\s*([a-z]+)(?::\s*(.*?))?\s*-->\s*$")
errors, pending, nblock, i = [], [], 0, 0
while i < len(lines):
    line = lines[i]
    m = directive.match(line)
    if m:
        pending.append((i + 1, m.group(1), m.group(2) or ""))
        i += 1
        continue
    if "readme-test" in line:
        errors.append("line %d: not a directive: %s" % (i + 1, line.strip()))
    if not line.startswith("```"):
        for n, _, _ in pending:
            errors.append("line %d: no fence follows this directive" % n)
        pending = []
        i += 1
        continue
    start, body, i = i + 1, [], i + 1
    while i < len(lines) and not lines[i].startswith("```"):
        body.append(lines[i])
        i += 1
    i += 1  # the closing fence
    nblock += 1
    d = os.path.join(plan, "%03d" % nblock)
    os.mkdir(d)
    skip, needs, checks = "", "", []
    for n, kind, text in pending:
        if kind == "skip" and text:
            skip = text
        elif kind == "needs" and text == "gpu":
            needs = text
        elif kind == "check" and text:
            checks.append(text)
        else:
            errors.append("line %d: unknown directive, or one without its "
                          "text: '%s: %s'" % (n, kind, text))
    pending = []
    cmds, cur = [], ""
    for b in body:
        cur += b
        if cur.endswith("\\"):
            cur = cur[:-1] + " "
            continue
        if cur.strip():
            cmds.append(cur)
        cur = ""
    if cur.strip():
        cmds.append(cur)
    # A daemon in the foreground never returns: such a block is skipped
    # with its reason, never run.
    for c in cmds:
        if not skip and re.match(r"\s*(\S*/)?gigaviewd(\s|$)", c) and \
                not re.search(r"\s-[tSVh](\s|$)", c):
            errors.append("line %d: '%s' serves in the foreground: mark the "
                          "block 'skip: REASON'" % (start, c.strip()))
            skip = "refused (see the first test)"
    with open(os.path.join(d, "meta"), "w") as f:
        f.write("%d\n%s\n%s\n" % (start, skip, needs))
    for k, c in enumerate(cmds):
        open(os.path.join(d, "cmd.%03d" % k), "w").write(c + "\n")
    for k, c in enumerate(checks):
        open(os.path.join(d, "check.%03d" % k), "w").write(c + "\n")
for n, _, _ in pending:
    errors.append("line %d: no fence follows this directive" % n)
with open(os.path.join(plan, "errors"), "w") as f:
    f.writelines(e + "\n" for e in errors)
PY
blocks=$(ls "$T/plan" | grep -c '^[0-9]')
if [ -s "$T/plan/errors" ]; then
    not_ok "README.md's readme-test directives are well formed" "$(cat "$T/plan/errors")"
else
    ok "README.md's readme-test directives are well formed ($blocks blocks)"
fi
[ "$blocks" -gt 0 ] || bail "README.md has no command block"

# ------------------------------------------------------- the scratch tree
W=$T/work
mkdir -p "$W/stores" "$T/bin" || bail "mkdir"
ln -s "$(cd "$(dirname "$GIGAVIEW")" && pwd)" "$W/build" || bail "ln build"
sample=$srcroot/samples/seeding_by_Clements_Engelhardt.jpg
"$GIGAVIEW" encode "$sample" -o "$W/stores/seeding.gv" >/dev/null ||
    bail "cannot encode the sample"
cp "$sample" "$W/photo.jpg" || bail "cp"
cp "$TESTDATA/etopo-600x400-u16.png" "$W/dem-u16.png" || bail "cp"
oiiotool "$TESTDATA/picos-1100x700.jpg" -o "$W/big.tif" &&
    oiiotool "$TESTDATA/picos-1100x700.jpg" -o "$W/huge.tif" ||
    bail "oiiotool cannot write TIFF"
for r in 0 1 2; do
    for c in 0 1 2 3; do
        cp "$TESTDATA/seeding-300x200-striped.tif" "$W/r${r}c$c.tif" || bail "cp"
    done
done
realcurl=$(command -v curl)
cat >"$T/bin/curl" <<EOF || bail "cannot write the curl wrapper"
#!/bin/sh
exec "$realcurl" --fail-with-body -sS --max-time "$GV_TEST_PATIENCE" "\$@"
EOF
cat >"$T/bin/image-size" <<'EOF' || bail "cannot write image-size"
#!/bin/sh
oiiotool --info "$1" 2>/dev/null |
    sed -n 's/.*: *\([0-9]*\) x *\([0-9]*\), [0-9]* channel.*/\1x\2/p'
EOF
chmod +x "$T/bin/curl" "$T/bin/image-size"

# The daemon as scripts/demo.sh runs it, on a free port.
cat >"$T/d.conf" <<EOF
listen = "127.0.0.1"
store_dir = "$W/stores"
filter_dir = ""
access_log = "off"
# Its filter jobs and compiles must succeed however busy the machine.
filter_timeout_ms = $((GV_TEST_PATIENCE * 1000))
filter_compile_timeout_ms = $((GV_TEST_PATIENCE * 1000))
EOF
start_daemon "$T/d.conf"
req "$(url /healthz)"
gpu=$(json_get 'j["gpu"]["available"]')

# ------------------------------------------------------------- the blocks
# in_work FILE OUT: run the command in FILE (127.0.0.1:8080 made the
# daemon's address) in the scratch tree, stdout and stderr to OUT.
in_work() {
    sed "s|127\.0\.0\.1:8080|127.0.0.1:$PORT|g" "$1" >"$T/cmd"
    (cd "$W" && PATH="$T/bin:$PATH" timeout $((GV_TEST_PATIENCE + 60)) sh -c "$(cat "$T/cmd")") >"$2" 2>&1
}

# title FILE: the command in FILE for a TAP line: spaces squeezed, shell
# comments cut (a '#' in TAP text could read as a directive), at most 110
# characters.
title() {
    tr -s ' ' <"$1" | sed 's/ #.*//' | cut -c 1-110
}

# outputs FILE: the files the command names with -o (literal names only).
outputs() {
    tr ' ' '\n' <"$1" | sed -n '/^-o$/{n;/\$/!p;}'
}

for b in "$T"/plan/[0-9]*; do
    at=$(sed -n 1p "$b/meta")
    reason=$(sed -n 2p "$b/meta")
    needs=$(sed -n 3p "$b/meta")
    what="README.md:$at ($(title "$b/cmd.000" 2>/dev/null | cut -c 1-50))"
    if [ -n "$reason" ]; then
        skip "$what" "$reason"
        continue
    fi
    if [ "$needs" = gpu ] && [ "$gpu" != True ]; then
        skip "$what" "needs a GPU context and the daemon has none"
        continue
    fi
    [ -e "$b/cmd.000" ] || { not_ok "$what: an empty block"; continue; }
    for c in "$b"/cmd.*; do
        cmd=$(title "$c")
        for o in $(outputs "$c"); do rm -f "$W/$o"; done
        if ! in_work "$c" "$T/out"; then
            for o in $(outputs "$c"); do # an HTTP error's JSON body
                head -c 400 "$W/$o" 2>/dev/null | grep '^{' >>"$T/out"
            done
            not_ok "README.md:$at: $cmd" "$(tail -n 20 "$T/out")"
            continue
        fi
        missing=
        for o in $(outputs "$c"); do
            [ -s "$W/$o" ] || missing="$missing $o"
        done
        if [ -n "$missing" ]; then
            not_ok "README.md:$at: $cmd" "did not write:$missing"
        else
            ok "README.md:$at: $cmd"
        fi
    done
    for c in "$b"/check.*; do
        [ -e "$c" ] || continue
        if in_work "$c" "$T/out"; then
            ok "README.md:$at: documented: $(title "$c")"
        else
            not_ok "README.md:$at: documented: $(title "$c")" "$(tail -n 20 "$T/out")"
        fi
    done
done

stop_daemon
check "the daemon stopped cleanly" test "$drc" -eq 0
done_testing
