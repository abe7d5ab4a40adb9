#!/bin/bash
# browser-viewer.sh: the browser viewer (client/web/, served by gigaviewd at
# /) in headless Chromium: time to the first complete view on loopback, and
# tiles decoded per second in the browser (bench/browser-viewer.mjs says
# exactly what is timed).
#
#   bench/browser-viewer.sh [--gigaview PATH] [--gigaviewd PATH] [IMAGE...]
#
# Each image is encoded into a store (gigaview encode, default settings);
# gigaviewd serves them on 127.0.0.1.  The browser is Debian's
# /usr/bin/chromium driven by playwright-core from tests/browser/node_modules
# (cd tests/browser && npm ci); WebGL2 runs on SwiftShader, Chrome's CPU
# Vulkan, unless GPU=host.  Every figure is printed with the renderer
# string.  Nothing is asserted: the script only reports.
#
# Environment:
#   GIGAVIEW, GIGAVIEWD  binaries (default: next to bench/, or on PATH)
#   REPS=N        runs per figure (default 3): median for first views, best
#                 for decoding
#   SIZE=WxH      browser viewport (default 1280x800)
#   GPU=host      use the machine's GPU instead of SwiftShader
#   QUICK=1       REPS=1 and only the first image
#   TMPDIR=DIR    scratch space (default /tmp)
# Default images: Picos de Europa (3264x2448 photo) and the 58 MP SRTM
# relief (10800x5400 gray) from $DATA_DIR (default: shared/data beside the
# checkout).
set -euo pipefail

# shellcheck source=SCRIPTDIR/http-lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/http-lib.sh"

bench_args "$@"
[ ${#inputs[@]} -gt 0 ] || inputs=("$DATA_DIR/photos/picosdeeuropa_by_Aitzol_Berasategi.jpg"
	"$DATA_DIR/large/marble-srtm-relief-10800x5400.png")
REPS=${REPS:-3}
if [ "${QUICK:-0}" = 1 ]; then
	REPS=1
	inputs=("${inputs[0]}")
fi
[ -x /usr/bin/chromium ] || die "no /usr/bin/chromium (apt-get install chromium)"
[ -d "$BENCH_DIR/../tests/browser/node_modules/playwright-core" ] ||
	die "no playwright-core: cd tests/browser && npm ci"
command -v node >/dev/null 2>&1 || die "no node (apt-get install nodejs)"

GV=$(find_gigaview "$gv_arg")
GVD=$(find_gigaviewd "$gvd_arg")
WORK=$(mktemp -d "${TMPDIR:-/tmp}/gv-browser-bench.XXXXXX")
trap 'http_cleanup; rm -rf "$WORK"' EXIT
cp "$GV" "$WORK/gigaview"
cp "$GVD" "$WORK/gigaviewd"
# the OpenImageIO module beside the copies, as beside the build's binaries
snapshot_module "$GVD" "$WORK"
echo "# $(describe_build "$GV")"
echo "# $(machine_line)"
echo "# chromium: $(/usr/bin/chromium --version 2>/dev/null | head -1)"

mkdir "$WORK/stores"
ids=()
for f in "${inputs[@]}"; do
	id=$(basename "${f%.*}" | tr -c 'A-Za-z0-9._\n-' '_' | cut -c1-60)
	"$WORK/gigaview" encode "$f" -o "$WORK/stores/$id.gv" >/dev/null ||
		die "encode $f failed"
	echo "# $id: $("$WORK/gigaview" info "$WORK/stores/$id.gv" | sed -n 's/^image *//p'), \
$(stat -c %s "$WORK/stores/$id.gv") bytes"
	ids+=("$id")
done

start_browser_gigaviewd "$WORK/gigaviewd" "$WORK"
echo "# gigaviewd on port $GVD_PORT; REPS=$REPS SIZE=${SIZE:-1280x800} GPU=${GPU:-swiftshader}"
node "$BENCH_DIR/browser-viewer.mjs" --base "http://127.0.0.1:$GVD_PORT" \
	--images "$(IFS=,; echo "${ids[*]}")" --reps "$REPS" --size "${SIZE:-1280x800}" \
	--gpu "$(browser_gpu)"
