# Shared helpers for the bench/*.sh scripts. Sourced, not run.
# shellcheck shell=bash

BENCH_DIR=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
top=$(cd "$BENCH_DIR/.." && pwd)
# The benchmark images: shared/data beside the checkout, unless DATA_DIR says.
DATA_DIR=${DATA_DIR:-$top/../shared/data}

die() { echo "$(basename "$0"): $*" >&2; exit 1; }

# need_cmd COMMAND DEBIAN-PACKAGE: installs the package only when the command
# is missing (the scripts never touch the network otherwise).
need_cmd() {
	command -v "$1" >/dev/null 2>&1 && return 0
	echo "# $1 not found: installing Debian package $2" >&2
	if [ "$(id -u)" -eq 0 ]; then
		apt-get install -y "$2" >&2 || die "apt-get install $2 failed"
	else
		sudo apt-get install -y "$2" >&2 || die "apt-get install $2 failed"
	fi
	command -v "$1" >/dev/null 2>&1 || die "$1 still missing after installing $2"
}

# find_gigaview [PATH]: prints the gigaview binary to use: the argument, else
# $GIGAVIEW, else ../gigaview next to this directory, else gigaview on PATH.
find_gigaview() {
	local c
	for c in "${1:-}" "${GIGAVIEW:-}" "$BENCH_DIR/../gigaview"; do
		if [ -n "$c" ] && [ -x "$c" ] && [ -f "$c" ]; then
			echo "$c"; return 0
		fi
	done
	c=$(command -v gigaview 2>/dev/null) && { echo "$c"; return 0; }
	die "no gigaview binary: pass --gigaview PATH or set GIGAVIEW (e.g. GIGAVIEW=/path/to/build/gigaview)"
}

# bench_args ARG...: the command line of the scripts that run gigaview
# binaries: --gigaview PATH, --gigaviewd PATH and --baseline PATH (also as
# --opt=PATH) into gv_arg, gvd_arg and base_arg, the other arguments (the
# inputs, in order) into the array inputs; -h or --help prints the
# script's opening comment; another option dies.
# shellcheck disable=SC2034 # gv_arg, gvd_arg, base_arg and inputs are the caller's
bench_args() {
	gv_arg="" gvd_arg="" base_arg=""
	inputs=()
	while [ $# -gt 0 ]; do
		case $1 in
		--gigaview) gv_arg=$2; shift 2 ;;
		--gigaview=*) gv_arg=${1#*=}; shift ;;
		--gigaviewd) gvd_arg=$2; shift 2 ;;
		--gigaviewd=*) gvd_arg=${1#*=}; shift ;;
		--baseline) base_arg=$2; shift 2 ;;
		--baseline=*) base_arg=${1#*=}; shift ;;
		-h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1' "$0"; exit 0 ;;
		-*) die "unknown option $1" ;;
		*) inputs+=("$1"); shift ;;
		esac
	done
}

# bench_no_inputs: die unless bench_args found no input (a script that
# takes none).
bench_no_inputs() {
	[ ${#inputs[@]} -eq 0 ] || die "unknown argument ${inputs[0]}"
}

# best_wall N PREP CMD...: the least wall time, in seconds, of N runs of
# CMD, each after an untimed run of PREP (a command, : for none; e.g. the
# removal of the last run's output); CMD's output is dropped, and a failed
# run dies with its standard error.
best_wall() {
	local n=$1 prep=$2 b="" t0 t err
	shift 2
	for _ in $(seq "$n"); do
		"$prep"
		sync
		t0=$(now)
		err=$("$@" 2>&1 >/dev/null) || { printf '%s\n' "$err" >&2; die "failed: $*"; }
		t=$(echo "$(now) - $t0" | bc -l)
		if [ -z "$b" ] || [ "$(echo "$t < $b" | bc)" = 1 ]; then b=$t; fi
	done
	echo "$b"
}

# snapshot_gigaview SRC DIR: copies the binary into DIR so a rebuild during
# the run cannot change it half-way, with the OpenImageIO module beside it
# where SRC has one (lib/imageio/imageio_loader.c looks there); prints the
# copy's path.
snapshot_gigaview() {
	cp "$1" "$2/gigaview"
	chmod +x "$2/gigaview"
	snapshot_module "$1" "$2"
	echo "$2/gigaview"
}

# snapshot_module BINARY DIR: copies gigaview-oiio.so from beside BINARY
# into DIR, if there is one there.
snapshot_module() {
	if [ -f "$(dirname "$1")/gigaview-oiio.so" ]; then
		cp "$(dirname "$1")/gigaview-oiio.so" "$2/"
	fi
}

# describe_build BINARY: one line naming the binary, its checksum and the tree.
describe_build() {
	local sum rev=""
	sum=$(md5sum "$1" | cut -c1-12)
	if git -C "$BENCH_DIR/.." rev-parse --short HEAD >/dev/null 2>&1; then
		rev=$(git -C "$BENCH_DIR/.." rev-parse --short HEAD)
		git -C "$BENCH_DIR/.." diff --quiet HEAD -- 2>/dev/null || rev="$rev+dirty"
	fi
	echo "gigaview $1 (md5 $sum, mtime $(date -r "$1" '+%F %T'), source tree ${rev:-unknown})"
}

machine_line() {
	local cpu
	cpu=$(awk -F': ' '/^model name/ {print $2; exit}' /proc/cpuinfo 2>/dev/null || true)
	echo "machine: $(nproc) cores, ${cpu:-unknown CPU}, $(uname -sr)"
}

now() { date +%s.%N; }

# pixels FILE: width*height of an image, read by vips.
img_w() { vipsheader -f width "$1"; }
img_h() { vipsheader -f height "$1"; }
img_bands() { vipsheader -f bands "$1"; }

# to_pnm IN OUT.ppm: 8-bit binary PNM (P6 or P5) of IN, alpha dropped.
to_pnm() {
	local b
	b=$(img_bands "$1")
	case $b in
	2) vips extract_band "$1" "$2" 0 --n 1 ;;
	4) vips extract_band "$1" "$2" 0 --n 3 ;;
	*) vips copy "$1" "$2" ;;
	esac
}

# build_imgcompare DIR: compiles imgcompare.c into DIR, prints its path.
build_imgcompare() {
	need_cmd cc gcc
	cc -std=c11 -O2 -Wall -Wextra -o "$1/imgcompare" "$BENCH_DIR/imgcompare.c" -lm \
		|| die "cannot build imgcompare"
	echo "$1/imgcompare"
}
