#!/bin/sh
# cli_bad_input.sh - `gigaview encode` on damaged input and hostile
# output locations.
#
# Every case must exit 1 with its exact message on stderr (where the text
# after the file name is a decoder library's, which varies between
# versions, only that part is a pattern), and leave nothing behind: no file at the output path and no temporary
# file beside it (the writer uses O_TMPFILE, so even a crash leaves none).
# A good store already at the output path survives a failed re-encode
# byte for byte.  Needs python3 (to craft a PNG header) and oiiotool.
. "$(dirname "$0")/lib.sh"

in="$T/in"
out="$T/out.d"
mkdir "$in" "$out" || bail "mkdir"
jpg="$TESTDATA/seeding-640x480.jpg"
png="$TESTDATA/seeding-700x520.png"

# bad_case DESCRIPTION MESSAGE ENCODE-ARGS...: encode into $out/x.gv must
# fail with exit 1, stderr exactly "gigaview encode: MESSAGE", and $out
# left empty.  bad_case_re: the same with stderr matching the extended
# regular expression PATTERN instead (for a decoder library's words).
bad_case() {
    desc=$1
    run_bad_case "$@"
    expect_err_is "$desc: message" "gigaview encode: $2"
    bad_case_left
}
bad_case_re() {
    desc=$1
    run_bad_case "$@"
    expect_err "$desc: message" "$2"
    bad_case_left
}
run_bad_case() {
    shift 2
    run encode "$@" -o "$out/x.gv"
    expect_rc "$desc" 1
}
# bad_case_both_ways DESCRIPTION MESSAGE FILE: bad_case on FILE with the
# native readers, then again through the OpenImageIO module
# (GIGAVIEW_NATIVE_READERS=0, DESCRIPTION ", through the module"): the
# same MESSAGE either way.
bad_case_both_ways() {
    bad_case "$1" "$2" "$3"
    export GIGAVIEW_NATIVE_READERS=0
    bad_case "$1, through the module" "$2" "$3"
    unset GIGAVIEW_NATIVE_READERS
}
bad_case_left() {
    left=$(listing "$out")
    if [ -z "$left" ]; then ok "$desc: nothing left in the output directory"; else
        not_ok "$desc: left behind in the output directory" "$left"; fi
    rm -rf "$out" && mkdir "$out"
}

# ----------------------------------------------------- damaged images
head -c 20000 "$jpg" >"$in/trunc.jpg"
bad_case_re "truncated JPEG" \
    "^gigaview encode: imageio: $in/trunc\\.jpg: JPEG error: .*(Premature end|truncat)" "$in/trunc.jpg"

head -c 20000 "$png" >"$in/trunc.png"
bad_case_re "truncated PNG" \
    "^gigaview encode: imageio: $in/trunc\\.png: .*(end of file|truncat)" "$in/trunc.png"

# 2 KiB of 0xFF in the middle of the entropy-coded data.
cp "$jpg" "$in/corrupt.jpg"
python3 -c 'import sys; f=open(sys.argv[1],"r+b"); f.seek(30000); f.write(b"\xff"*2048)' \
    "$in/corrupt.jpg" || bail "python3"
bad_case_re "corrupt JPEG" \
    "^gigaview encode: imageio: $in/corrupt\\.jpg: JPEG error: .*(Corrupt|corrupt)" "$in/corrupt.jpg"

# A PNG with its IDAT bytes flipped: zlib or the CRC must notice.
cp "$png" "$in/flipped.png"
python3 -c 'import sys; f=open(sys.argv[1],"r+b"); f.seek(5000); b=f.read(64); f.seek(5000); f.write(bytes(x ^ 0x5a for x in b))' \
    "$in/flipped.png" || bail "python3"
bad_case_re "PNG with flipped bytes" \
    "^gigaview encode: imageio: $in/flipped\\.png: PNG read error: " "$in/flipped.png"

: >"$in/empty.jpg"
bad_case "zero-byte file" "imageio: $in/empty.jpg: empty file" "$in/empty.jpg"

bad_case "nonexistent file" "imageio: $in/nothere.png: no such file" "$in/nothere.png"

echo "this is not a picture" >"$in/text.jpg"
bad_case_re "text file named .jpg" \
    "^gigaview encode: imageio: $in/text\\.jpg: .*not a JPEG" "$in/text.jpg"

bad_case "a directory as input" "imageio: $in: not a regular file" "$in"

bad_case "synth: of zero width" "source: synth:0x5: sizes must be 1 to 2147483647" "synth:0x5"
bad_case "synth: too wide" "source: synth:2147483648x1: sizes must be 1 to 2147483647" \
    "synth:2147483648x1"
bad_case "synth: garbage" \
    "source: synth:axb: expected synth:WIDTHxHEIGHT or synth:WIDTHxHEIGHT:gray" "synth:axb"

# A valid PNG signature and IHDR (correct CRC) claiming 100000x100000
# RGB, with one tiny IDAT: 10^10 pixels.
python3 - "$in/huge.png" <<'EOF' || bail "python3"
import struct, sys, zlib
def chunk(kind, data):
    return (struct.pack(">I", len(data)) + kind + data +
            struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff))
ihdr = struct.pack(">IIBBBBB", 100000, 100000, 8, 2, 0, 0, 0)
with open(sys.argv[1], "wb") as f:
    f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) +
            chunk(b"IDAT", zlib.compress(b"\0" * 1000)) + chunk(b"IEND", b""))
EOF
bad_case "PNG header claiming 100000x100000, --max-pixels 10^9" \
    "imageio: $in/huge.png: image of 100000x100000 pixels exceeds the limit of 1000000000 pixels" \
    --max-pixels 1000000000 "$in/huge.png"
# Under the default limit (2^40) the header is accepted, and the missing
# pixel data is what fails - quickly, without a 30 GB allocation.
bad_case_re "PNG header claiming 100000x100000, default limit" \
    "^gigaview encode: imageio: $in/huge\\.png: PNG read error: " "$in/huge.png"
bad_case "synth: above the default 2^40 pixel limit" \
    "source: synth:2000000x2000000: 4000000000000 pixels exceed the limit of 1099511627776" \
    "synth:2000000x2000000"
bad_case "--max-pixels 1000 on a 640x480 JPEG" \
    "imageio: $jpg: image of 640x480 pixels exceeds the limit of 1000 pixels" \
    --max-pixels 1000 "$jpg"
bad_case "--max-pixels 1000 on a mosaic" \
    "imageio: $jpg: image of 640x480 pixels exceeds the limit of 1000 pixels" \
    --max-pixels 1000 -m 2x1 "$jpg" "$jpg"
# A progressive JPEG of 863 bytes (tests/data/native/progressive.jpg)
# whose frame header claims 30000x30000: libjpeg would allocate and touch
# 2.5 GiB of coefficients before failing on the missing data.  Refused
# from the header, natively and before the OpenImageIO module; over the
# default --max-decoder-memory (1G) it is the limit that says no, under
# a larger one the file's size (its first scan's blocks need 2.6 MB).
python3 - "$TESTDATA/native/progressive.jpg" "$in/claims-huge.jpg" <<'EOF' || bail "python3"
import sys
p = bytearray(open(sys.argv[1], "rb").read())
i = 2
while p[i + 1] != 0xC2:
    i += 2 + (p[i + 2] << 8 | p[i + 3])
p[i + 5:i + 9] = (30000).to_bytes(2, "big") * 2
open(sys.argv[2], "wb").write(p)
EOF
huge_msg="imageio: $in/claims-huge.jpg: a progressive JPEG of 30000 x 30000 needs about 2.5 GiB of decoder memory, more than the limit of 1.0 GiB (--max-decoder-memory)"
bad_case_both_ways "progressive JPEG claiming 30000x30000" "$huge_msg" "$in/claims-huge.jpg"
bad_case "progressive JPEG claiming 30000x30000, --max-decoder-memory 4G" \
    "imageio: $in/claims-huge.jpg: a progressive JPEG of 30000 x 30000 is truncated: its first scan codes 21093750 blocks, at least 2636718 bytes, in a file of 863 bytes" \
    --max-decoder-memory 4G "$in/claims-huge.jpg"
bad_case "--max-decoder-memory 8K on a progressive JPEG of 61x45" \
    "imageio: $TESTDATA/native/progressive.jpg: a progressive JPEG of 61 x 45 needs about 9.0 KiB of decoder memory, more than the limit of 8.0 KiB (--max-decoder-memory)" \
    --max-decoder-memory 8K "$TESTDATA/native/progressive.jpg"
run encode --max-decoder-memory 9KiB "$TESTDATA/native/progressive.jpg" -o "$T/prog.gv" --quiet
expect_rc "--max-decoder-memory 9KiB: the progressive JPEG that needs 9 KiB" 0
run encode --max-decoder-memory 1 "$jpg" -o "$T/baseline.gv" --quiet
expect_rc "--max-decoder-memory 1: a baseline JPEG needs no decoder memory" 0
# --height reads its input under the same limits.
bad_case "--height --max-decoder-memory 1K on a gray progressive JPEG" \
    "imageio: $TESTDATA/native/gray-progressive.jpg: a progressive JPEG of 61 x 45 needs about 6.0 KiB of decoder memory, more than the limit of 1.0 KiB (--max-decoder-memory)" \
    --height --max-decoder-memory 1K "$TESTDATA/native/gray-progressive.jpg"
run encode --height --max-decoder-memory 6K "$TESTDATA/native/gray-progressive.jpg" -o "$T/prog-height.gv" --quiet
expect_rc "--height --max-decoder-memory 6K: the gray progressive JPEG that needs 6 KiB" 0
# An interlaced PNG of 1.5 KB (tests/data/native/rgb8-interlaced.png)
# whose IHDR claims 12000x12000 RGBA of 16 bits: held whole while it is
# read, 1.1 GiB, which OpenImageIO's reader allocated and zeroed before
# failing on the missing data.  Refused from the header under the default
# --max-decoder-memory, natively and before the module.
python3 - "$TESTDATA/native/rgb8-interlaced.png" "$in/claims-huge.png" <<'EOF' || bail "python3"
import struct, sys, zlib
p = bytearray(open(sys.argv[1], "rb").read())
p[16:29] = struct.pack(">IIBBBBB", 12000, 12000, 16, 6, 0, 0, 1)
p[29:33] = struct.pack(">I", zlib.crc32(bytes(p[12:29])))
open(sys.argv[2], "wb").write(p)
EOF
png_msg="imageio: $in/claims-huge.png: an interlaced PNG of 12000 x 12000 needs about 1.1 GiB of decoder memory, more than the limit of 1.0 GiB (--max-decoder-memory)"
bad_case_both_ways "interlaced PNG claiming 12000x12000" "$png_msg" "$in/claims-huge.png"
# TIFFs whose first directory claims what their 1 to 2 KB cannot hold
# (tests/data/native/limits, make-tiff-limits.py there): one YCbCr JPEG
# strip of 30000x30000 whose JPEG is progressive (8.9 GB of resident
# size before lib/imageio/tiff_limits.c: libtiff's RGBA image, its strip
# and libjpeg's coefficients), and one RGB strip of 15000x15000 whose
# progressive JPEG's coefficients alone pass the limit (1.5 GB before).
# Refused from the header, natively and before the module; a real JPEG
# TIFF (tiffcp -c jpeg) still encodes, and is refused one byte under
# what it needs.
lim="$TESTDATA/native/limits"
bad_case_both_ways "JPEG-compressed TIFF claiming 30000x30000 in one strip" \
    "imageio: $lim/jpeg-progressive-claims-30000.tif: a TIFF of 30000 x 30000 needs about 5.9 GiB of decoder memory (a strip of 30000 rows, the whole image as RGBA), more than the limit of 1.0 GiB (--max-decoder-memory)" \
    "$lim/jpeg-progressive-claims-30000.tif"
bad_case_both_ways "RGB JPEG TIFF whose progressive strip claims 15000x15000" \
    "imageio: $lim/jpeg-rgb-progressive-claims-15000.tif: a TIFF of 15000 x 15000 needs about 1.3 GiB of decoder memory (a progressive JPEG's coefficients), more than the limit of 1.0 GiB (--max-decoder-memory)" \
    "$lim/jpeg-rgb-progressive-claims-15000.tif"
run encode "$TESTDATA/native/rgb8-jpeg-declined.tif" -o "$T/jpeg-tiff.gv" --quiet
expect_rc "a JPEG-compressed TIFF from tiffcp -c jpeg encodes" 0
if command -v tiffcp >/dev/null 2>&1; then
    # 300x200 as one strip, in strips of 16 rows and in 64x64 tiles
    for o in "-r 200" "-r 16" "-t -w 64 -l 64"; do
        # shellcheck disable=SC2086 # $o is options
        tiffcp -c jpeg $o "$TESTDATA/seeding-300x200-striped.tif" "$in/jpeg.tif" 2>/dev/null
        run encode "$in/jpeg.tif" -o "$T/jpeg-tiff-cp.gv" --quiet
        expect_rc "tiffcp -c jpeg $o of a 300x200 TIFF encodes" 0
    done
else
    skip "tiffcp -c jpeg TIFFs" "no tiffcp (libtiff-tools)"
fi
run encode --max-decoder-memory 6068 "$TESTDATA/native/rgb8-jpeg-declined.tif" -o "$T/jpeg-tiff-6068.gv" --quiet
expect_rc "--max-decoder-memory 6068: the JPEG TIFF that needs 6068 bytes" 0
bad_case "--max-decoder-memory 6067 on a JPEG TIFF of 37x29" \
    "imageio: $TESTDATA/native/rgb8-jpeg-declined.tif: a TIFF of 37 x 29 needs about 5.9 KiB of decoder memory (a strip of 16 rows, the whole image as RGBA), more than the limit of 5.9 KiB (--max-decoder-memory)" \
    --max-decoder-memory 6067 "$TESTDATA/native/rgb8-jpeg-declined.tif"
bad_case_re "mosaic with one damaged tile" \
    "^gigaview encode: imageio: $in/trunc\\.jpg: JPEG error: " -m 2x1 "$jpg" "$in/trunc.jpg"

# ------------------------------------------------- the OpenImageIO module
# Image files the native readers do not take (JPEG, PNG and 8/16-bit
# TIFF have them; a 12-bit TIFF is declined) are read through
# gigaview-oiio.so, loaded on first use (lib/imageio/imageio_loader.c):
# without it such a file is refused in one line that says so, and what
# needs no module still works.
tif="$TESTDATA/gradient-64x4-u12.tif"
export GV_OIIO_MODULE="$T/no-such-module.so"
bad_case_re "the OpenImageIO module missing" \
    "^gigaview encode: imageio: cannot load the OpenImageIO module: .*no-such-module\\.so" "$tif"
run encode synth:300x200 -o "$T/synth-no-module.gv" --quiet
expect_rc "the OpenImageIO module missing: a synthetic input needs none" 0
run encode "$jpg" -o "$T/jpg-no-module.gv" --quiet
expect_rc "the OpenImageIO module missing: a JPEG needs none" 0
run encode "$png" -o "$T/png-no-module.gv" --quiet
expect_rc "the OpenImageIO module missing: a PNG needs none" 0
run encode "$TESTDATA/seeding-300x200-tiled.tif" -o "$T/tif-no-module.gv" --quiet
expect_rc "the OpenImageIO module missing: an 8-bit tiled TIFF needs none" 0
GIGAVIEW_NATIVE_READERS=0 bad_case_re "the OpenImageIO module missing, GIGAVIEW_NATIVE_READERS=0" \
    "^gigaview encode: imageio: cannot load the OpenImageIO module: .*no-such-module\\.so" "$jpg"
GV_OIIO_MODULE="$T" bad_case_re "a directory as the OpenImageIO module" \
    "^gigaview encode: imageio: cannot load the OpenImageIO module: " "$tif"
unset GV_OIIO_MODULE GIGAVIEW_NATIVE_READERS
# Found by searching, a module is taken only from a directory not everyone
# may write: a copy of the program in $T/shared/bin, the module in
# $T/shared, first writable by all, then not.
module=$(dirname "$GIGAVIEW")/gigaview-oiio.so
if [ -f "$module" ]; then
    mkdir -p "$T/shared/bin"
    cp "$GIGAVIEW" "$T/shared/bin/gigaview"
    cp "$module" "$T/shared/"
    chmod 777 "$T/shared"
    "$T/shared/bin/gigaview" encode "$tif" -o "$T/shared.gv" >"$T/out" 2>"$T/err"
    rc=$?
    expect_rc "a module in a directory anyone may write: refused" 1
    expect_err "a module in a directory anyone may write: the message" \
        "cannot load the OpenImageIO module: no gigaview-oiio.so beside the program"
    chmod 755 "$T/shared"
    "$T/shared/bin/gigaview" encode "$tif" -o "$T/shared.gv" --quiet >"$T/out" 2>"$T/err"
    rc=$?
    expect_rc "the same module once its directory is not writable by all: loaded" 0
else
    skip "a module in a directory anyone may write" "no $module"
fi

# ------------------------------------------------- output locations
# A path under a non-directory: no way to create anything.
run encode "$jpg" -o /dev/null/x.gv
expect_rc "output under /dev/null" 1
expect_err_is "output under /dev/null: message" \
    "gigaview encode: store: cannot create a file in /dev/null: Not a directory"

run encode "$jpg" -o "$out/nodir/x.gv"
expect_rc "output in a nonexistent directory" 1
expect_err_is "output in a nonexistent directory: message" \
    "gigaview encode: store: cannot create a file in $out/nodir: No such file or directory"
check "output in a nonexistent directory: nothing created" test -z "$(listing "$out")"

run encode "$jpg" -o "$out"
expect_rc "output path is a directory" 1
check "output path is a directory: it is left alone" test -d "$out" -a -z "$(listing "$out")"

# A read-only directory; root ignores the mode, so the case is skipped
# there (the /dev/null case above covers the error path).
ro="$T/ro"
mkdir "$ro" && chmod 555 "$ro"
if [ "$(id -u)" = 0 ]; then
    skip "output in a read-only directory" "running as root: the mode does not stop writes"
else
    run encode "$jpg" -o "$ro/x.gv"
    expect_rc "output in a read-only directory" 1
    expect_err_is "output in a read-only directory: message" \
        "gigaview encode: store: cannot create a file in $ro: Permission denied"
    check "output in a read-only directory: nothing created" test -z "$(listing "$ro")"
fi
chmod 755 "$ro"

# Disk full, simulated with a file size limit of 200 KiB (the store and
# the scratch file are both bigger): EFBIG, not a SIGXFSZ death.
(
    trap '' XFSZ
    ulimit -f 200
    gv encode "$jpg" -o "$out/x.gv" >"$T/out" 2>"$T/err"
)
rc=$?
expect_rc "file size limit (ulimit -f 200)" 1
expect_err_is "file size limit: the scratch file is too large" \
    "gigaview encode: spill: writing the scratch file in $out: File too large"
check "file size limit: nothing left in the output directory" test -z "$(listing "$out")"

# The same for a shard, whose scratch file is sized once at the start
# (fault_disk_full.sh fills a real disk during a shard's pass 1).
(
    trap '' XFSZ
    ulimit -f 200
    gv encode "$jpg" --shard 0/2 -o "$out/x.gvshard" >"$T/out" 2>"$T/err"
)
rc=$?
expect_rc "file size limit, a shard" 1
expect_err_is "file size limit, a shard: the scratch file is too large" \
    "gigaview encode: spill: writing the scratch file in $out: File too large"
check "file size limit, a shard: nothing left in the output directory" \
    test -z "$(listing "$out")"

# --tmpdir that does not exist.
run encode "$jpg" --tmpdir "$T/nothere" -o "$out/x.gv"
expect_rc "--tmpdir that does not exist" 1
expect_err_is "--tmpdir that does not exist: message" \
    "gigaview encode: spill: cannot create a scratch file in $T/nothere: No such file or directory"
check "--tmpdir that does not exist: nothing created" test -z "$(listing "$out")"

# ------------------------------- a good store survives a failed encode
run encode "$png" -o "$out/good.gv" --quiet
expect_rc "encode a good store" 0
cp "$out/good.gv" "$T/good.copy"
for bad in "$in/trunc.jpg" "$in/corrupt.jpg" "$in/empty.jpg" "$in/nothere.png"; do
    run encode "$bad" -o "$out/good.gv"
    expect_rc "re-encode from $(basename "$bad") over a good store" 1
    check "the good store is byte-identical after $(basename "$bad")" \
        cmp -s "$out/good.gv" "$T/good.copy"
done
(
    trap '' XFSZ
    ulimit -f 200
    gv encode synth:900x900 -o "$out/good.gv" >"$T/out" 2>"$T/err"
)
rc=$?
expect_rc "re-encode over a good store hitting the file size limit" 1
check "the good store is byte-identical after the size limit" \
    cmp -s "$out/good.gv" "$T/good.copy"
check "only the good store is in the directory" test "$(listing "$out")" = good.gv
run info "$out/good.gv"
expect_rc "the surviving store still opens" 0

# ----------------------------------------------- export failure paths
# An export that hits the size limit leaves no partial image.
(
    trap '' XFSZ
    ulimit -f 100
    gv export "$out/good.gv" -o "$out/big.png" >"$T/out" 2>"$T/err"
)
rc=$?
expect_rc "export hitting the file size limit" 1
# The image is encoded in memory and published by the atomic writer, so
# the error is the system's own.
expect_err_is "export hitting the file size limit: message" \
    "gigaview export: imageio: writing $out/big.png: File too large"
check "export hitting the file size limit: no image, no temporary" \
    test "$(listing "$out")" = good.gv

# A damaged store: every command fails cleanly.
cp "$T/good.copy" "$in/damaged.gv"
# 16 bytes of level 0's page (the last in the index) zeroed.
python3 -c 'import struct, sys; f=open(sys.argv[1],"r+b"); h=f.read(128)
ix, n = struct.unpack_from("<QQ", h, 56); f.seek(ix + 16 * (n - 1))
off = struct.unpack("<Q", f.read(8))[0]; f.seek(off + 72); f.write(b"\x00"*16)' \
    "$in/damaged.gv" || bail "python3"
run export "$in/damaged.gv" -o "$out/d.png"
check "export of a store with a damaged page fails" test "$rc" -eq 1
expect_err_is "export of a damaged store: message" \
    "gigaview export: store: CRC mismatch in page 0/0/0"
check "export of a damaged store: no image" test ! -e "$out/d.png"
head -c 100 "$T/good.copy" >"$in/short.gv"
run info "$in/short.gv"
expect_rc "info on a store cut to 100 bytes" 1
expect_err_is "info on a store cut to 100 bytes: message" \
    "gigaview info: store: $in/short.gv is too short to be a store"

done_testing
