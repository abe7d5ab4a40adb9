#!/usr/bin/env bash
# edt-speed.sh - distance transform speed and accuracy, everything in one
# run on the same inputs: gigaview's CPU propagation path
# (filters/edt_cpu.c: 1 thread, every core, and every core with sites and
# ids too) against OpenCV cv2.distanceTransform(DIST_L2, DIST_MASK_PRECISE)
# and SciPy scipy.ndimage.distance_transform_edt (bench/edt_anchor.py).
# Each size gets one random image with DENSITY sites, written once as a
# .npy that every method reads.  At ERROR_SIZES it also compares our
# distances and OpenCV's with an exact EDT (tests/edt_exact.c).  Prints
# figures and ratios; asserts nothing.
#
#   bench/edt-speed.sh [SIZE...]          (default: 512 1024 2048 4096 8192)
#
# Environment: THREADS (default: every core), REPS (best of, default 3),
# SCIPY_REPS (default 1 from 4096 up, else REPS: SciPy takes seconds),
# DENSITY (default 0.001), SEED (default 1), ERROR_SIZES (default 8192),
# EDT_METHODS (default cpu1,cpu,cpu+sites, plus egl-frag,egl-compute when
# BUILD, default build/, holds a built tree: the rows of methods[] in
# bench/edt_bench.c).
# About 2 minutes on the 2-core machine with the defaults.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
top=$(cd "$here/.." && pwd)
# shellcheck source=bench/lib.sh
. "$here/lib.sh"

sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(512 1024 2048 4096 8192)
threads=${THREADS:-$(nproc)}
reps=${REPS:-3}
density=${DENSITY:-0.001}
seed=${SEED:-1}
error_sizes=" ${ERROR_SIZES:-8192} "
methods=${EDT_METHODS:-cpu1,cpu,cpu+sites}

# A Python 3 that has cv2 and scipy: Debian's (python3-opencv,
# python3-scipy), installed when missing.
py=
for c in /usr/bin/python3 python3; do
	if command -v "$c" >/dev/null 2>&1 &&
	   "$c" -c 'import cv2, scipy.ndimage' >/dev/null 2>&1; then
		py=$c
		break
	fi
done
if [ -z "$py" ]; then
	echo "# installing Debian packages python3-opencv python3-scipy" >&2
	if [ "$(id -u)" -eq 0 ]; then
		apt-get install -y python3-opencv python3-scipy >&2
	else
		sudo apt-get install -y python3-opencv python3-scipy >&2
	fi
	py=/usr/bin/python3
	"$py" -c 'import cv2, scipy.ndimage' || die "cv2 or scipy still missing"
fi
need_cmd cc gcc

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# With a built tree in BUILD (default build/), bench/edt_bench is built by
# the tree's own rules (Makefile.am, bench section) with the EGL methods;
# without one, the CPU methods alone are compiled here with the default
# build's flags (configure: -g -O3).
build=${BUILD:-$top/build}
if [ -f "$build/Makefile" ]; then
	make -s -C "$build" bench/edt_bench >&2
	ln -s "$build/bench/edt_bench" "$work/edt_bench"
	export GV_EDT_GRAPH="$top/filters/library/distance-transform.json"
	methods=${EDT_METHODS:-cpu1,cpu,cpu+sites,egl-frag,egl-compute}
else
	cc -std=c11 -D_GNU_SOURCE -g -O3 -pthread -I"$top/lib" -I"$top/filters" \
		-I"$top/tests" "$here/edt_bench.c" "$top/filters/edt_cpu.c" \
		"$top/tests/edt_exact.c" "$top/lib/base/error.c" -lm -o "$work/edt_bench"
fi

echo "# edt-speed: $(date '+%F %T'), $(machine_line)"
echo "# source tree $(git -C "$top" rev-parse --short HEAD 2>/dev/null || echo unknown), edt_cpu.c + edt_kernel.h md5 $(cat "$top/filters/edt_cpu.c" "$top/filters/edt_kernel.h" | md5sum | cut -c1-12); load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "# sites: each pixel with probability $density (seed $seed); best of $reps (SciPy: ${SCIPY_REPS:-1 from 4096 up}); Mpx = 10^6 pixels"
results=$work/results
: >"$results"
for s in "${sizes[@]}"; do
	mask=$work/mask-$s.npy
	"$work/edt_bench" gen "$s" "$density" "$seed" "$mask"
	srep=${SCIPY_REPS:-$reps}
	[ -n "${SCIPY_REPS:-}" ] || [ "$s" -lt 4096 ] || srep=1
	extra=()
	cmp=()
	case $error_sizes in
	*" $s "*)
		extra=(--save-opencv "$work/opencv-$s.npy")
		cmp=(-e -c "opencv=$work/opencv-$s.npy")
		;;
	esac
	echo "== ${s}x${s}"
	"$py" "$here/edt_anchor.py" "$mask" "$reps" --scipy-reps "$srep" \
		"${extra[@]}" | tee -a "$results"
	"$work/edt_bench" run "$mask" -t "$threads" -r "$reps" -m "$methods" \
		"${cmp[@]}" | tee -a "$results"
	rm -f "$mask" "$work/opencv-$s.npy"
done
echo "# done $(date '+%T'), load average $(cut -d' ' -f1-3 /proc/loadavg)"

echo
echo "== Mpixel/s, wall clock (ratio to OpenCV precise; to SciPy)"
table() {
	awk -v methods="$methods" -v col="$1" '
	$1 == "method" {
		x = col == "wall" ? $5 : ($6 > 0 ? $3 * 0 + wh($3) / ($6 * 1e3) : 0)
		v[$3, $2] = x
		if (!($3 in seen)) { seen[$3] = 1; order[++n] = $3 }
	}
	function wh(s,   a) { split(s, a, "x"); return a[1] * a[2] }
	END {
		m = split(methods, ms, ",")
		printf "%-11s %9s %9s", "size", "opencv", "scipy"
		for (i = 1; i <= m; i++) printf " %24s", ms[i]
		printf "\n"
		for (k = 1; k <= n; k++) {
			s = order[k]; cv = v[s, "opencv"]; sp = v[s, "scipy"]
			printf "%-11s %9.1f %9.1f", s, cv, sp
			for (i = 1; i <= m; i++) {
				x = v[s, ms[i]]
				if (x == "") { printf " %24s", "-"; continue }
				printf " %8.1f (%5.2fx;%6.1fx)", x, cv ? x / cv : 0, sp ? x / sp : 0
			}
			printf "\n"
		}
	}' "$results"
}
table wall
echo
echo "== Mpixel per CPU-second, every thread counted (same ratios)"
table cpu
if grep -q '^error ' "$results"; then
	echo
	echo "== errors against the exact EDT (a pixel errs when off by > 1e-3 px)"
	awk '$1 == "error" { printf "%-10s max %.4f px, %d of %d pixels\n", $2, $3, $4, $5 }' "$results"
fi
