#!/usr/bin/env bash
# simplify-speed.sh - mesh simplification by vertex clustering (`gigaview
# simplify`, Kanaya et al.; CPU and GPU selection) against Open3D's
# simplify_vertex_clustering and meshoptimizer's meshopt_simplifySloppy
# (time; both vertex clustering) and meshopt_simplify (quadric edge
# collapse: error), every method at the same face count, in one run on
# the same meshes: Debian's assimp-testmodels (WusonOBJ.obj, spider.obj),
# a dense TIN of a height field (`gigaview mesh` of ETOPO), and a
# marching-tetrahedra surface of a synthetic volume (bench/simplify_volume.c:
# N = 300, 2.1M triangles, and N = 650, 10.0M).  Error: symmetric Hausdorff and RMS surface
# distance to the input by bench/mesh_distance.c, in % of the input's
# bounding-box diagonal.  Prints the figures and the ratios to the
# anchors (time / meshopt_simplifySloppy's, Hausdorff / Open3D's);
# asserts nothing.  Writes bench/results/simplify-DATE.tsv and,
# with gnuplot, bench/simplify-DATE.png.  CGAL's edge collapse is not run
# (libcgal-dev not installed; left for later).
#
#   bench/simplify-speed.sh [RATIO...]     (default: 0.2 0.05 0.01)
#
# Environment: BUILD (the build directory, default ../build), VOLUME_N
# (the volumes' N, default "300 650"), SAMPLES (distance samples per mesh, default 100000).
# Needs python3-open3d and assimp-testmodels (scripts/install-deps.sh) and
# `make bench` in BUILD.  The times are the simplification alone, read and
# write excluded: ours = octree build + selection ("gpu": the build on the
# CPU, the selection, upload included, on the EGL context, llvmpipe here).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=${BUILD:-$here/../build}
ratios=("$@")
[ ${#ratios[@]} -gt 0 ] || ratios=(0.2 0.05 0.01)
gv=$build/gigaview
dist=$build/bench/mesh_distance
anchor=$build/bench/simplify_anchor
py=/usr/bin/python3
samples=${SAMPLES:-100000}
for f in "$gv" "$dist" "$anchor"; do
	[ -x "$f" ] || { echo "simplify-speed: no $f (make -C BUILD bench)" >&2; exit 1; }
done
$py -c 'import open3d' 2>/dev/null || { echo "simplify-speed: no python3-open3d" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
models=/usr/share/assimp/models
meshes=()
for m in OBJ/WusonOBJ.obj OBJ/spider.obj; do
	[ -f "$models/$m" ] && meshes+=("$models/$m")
done
"$gv" mesh "$here/../tests/data/etopo-600x400-u16.png" --max-triangles 300000 \
	-o "$work/etopo-tin.ply" >/dev/null
meshes+=("$work/etopo-tin.ply")
cc -O2 -o "$work/volume" "$here/simplify_volume.c" -lm
for vn in ${VOLUME_N:-300 650}; do
	"$work/volume" "$vn" "$work/volume$vn.ply" >/dev/null
	meshes+=("$work/volume$vn.ply")
done

date=$(date -u +%Y-%m-%d)
mkdir -p "$here/results"
tsv=$here/results/simplify-$date.tsv
printf 'mesh\tin_faces\tasked\tmethod\tfaces\tms\thausdorff_pct\trms_pct\n' >"$tsv"
printf '%-14s %9s %8s %-14s %8s %6s %9s %8s %9s %8s %8s\n' mesh in asked method \
	faces dev% ms "x sloppy" "haus%" "x o3d" "rms%"
for m in "${meshes[@]}"; do
	name=$(basename "$m"); name=${name%.*}
	nin=$("$gv" simplify "$m" --ratio 1 --cpu -o "$work/in.ply" | sed 's/.*vertices, \([0-9]*\) triangles -> .*/\1/')
	for r in "${ratios[@]}"; do
		asked=$(python3 -c "print(round($r * $nin))")
		[ "$asked" -ge 4 ] || continue
		declare -A ms faces
		line=$("$gv" simplify "$m" --faces "$asked" --cpu -o "$work/ours.ply")
		ms[ours-cpu]=$(echo "$line" | sed 's/.*build \([0-9.]*\) ms, select \([0-9.]*\) ms.*/\1 \2/' | awk '{print $1 + $2}')
		faces[ours-cpu]=$(echo "$line" | sed 's/.*vertices, \([0-9]*\) triangles (asked.*/\1/')
		line=$("$gv" simplify "$m" --faces "$asked" --gpu -o "$work/ours-gpu.ply")
		ms[ours-gpu]=$(echo "$line" | sed 's/.*build \([0-9.]*\) ms, select \([0-9.]*\) ms.*/\1 \2/' | awk '{print $1 + $2}')
		faces[ours-gpu]=${faces[ours-cpu]}
		cmp -s "$work/ours.ply" "$work/ours-gpu.ply" || echo "simplify-speed: GPU file differs from CPU file" >&2
		ms[ours-select]=$(echo "$line" | sed 's/.*select \([0-9.]*\) ms.*/\1/')
		faces[ours-select]=${faces[ours-cpu]}
		out=$("$anchor" sloppy "$m" "$asked" "$work/sloppy.ply" | grep '^sloppy ms')
		read -r _ _ ms[sloppy] _ faces[sloppy] <<<"$out"
		out=$("$anchor" quadric "$m" "$asked" "$work/quadric.ply" | grep '^quadric ms')
		read -r _ _ ms[quadric] _ faces[quadric] <<<"$out"
		out=$($py "$here/simplify_open3d.py" "$m" "$asked" "$work/open3d.ply" 2>/dev/null | grep '^open3d ms')
		read -r _ _ ms[open3d] _ faces[open3d] _ _ <<<"$out"
		declare -A hs rms
		for meth in ours-cpu ours-gpu ours-select sloppy open3d quadric; do
			case $meth in
			ours-cpu) out=$work/ours.ply ;;
			ours-gpu|ours-select) out= ;;
			*) out=$work/$meth.ply ;;
			esac
			hs[$meth]=- rms[$meth]=-
			if [ -n "$out" ]; then
				dl=$("$dist" "$work/in.ply" "$out" "$samples")
				read -r _ hd _ rr _ _ _ _ _ dg <<<"$dl"
				hs[$meth]=$(python3 -c "print('%.4f' % (100 * $hd / $dg))")
				rms[$meth]=$(python3 -c "print('%.4f' % (100 * $rr / $dg))")
			fi
		done
		for meth in ours-cpu ours-gpu ours-select sloppy open3d quadric; do
			h=${hs[$meth]} rm=${rms[$meth]} hrel=-
			[ "$h" = - ] || hrel=$(python3 -c "print('%.2f' % ($h / max(${hs[open3d]}, 1e-9)))")
			dev=$(python3 -c "print('%+.2f' % (100 * (${faces[$meth]} - $asked) / $asked))")
			rel=$(python3 -c "print('%.2f' % (${ms[$meth]} / max(${ms[sloppy]}, 1e-3)))")
			printf '%-14s %9s %8s %-14s %8s %6s %9.2f %8s %9s %8s %8s\n' "$name" "$nin" \
				"$asked" "$meth" "${faces[$meth]}" "$dev" "${ms[$meth]}" "$rel" "$h" "$hrel" "$rm"
			printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$nin" "$asked" \
				"$meth" "${faces[$meth]}" "${ms[$meth]}" "$h" "$rm" >>"$tsv"
		done
	done
done
echo "wrote $tsv"
[ -x "$here/simplify-plot.sh" ] && "$here/simplify-plot.sh" "$tsv" "$here/simplify-$date.png" || true
