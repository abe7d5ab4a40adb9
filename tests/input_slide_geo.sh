#!/bin/sh
# input_slide_geo.sh - whole-slide images through OpenSlide and rasters
# through GDAL (lib/imageio/slide_openslide.c, raster_gdal.c), made here,
# nothing downloaded:
#  - an Aperio-like slide (tests/make_slide.c: a tiled TIFF pyramid with
#    AppMag and MPP in its ImageDescription), small enough to be its own
#    lossless root, and a JPEG-compressed one of 1500 x 1100 with two
#    levels: encoded, `gigaview info` (text and --json) shows the vendor,
#    microns per pixel and objective power; the small one's level 0 is
#    exactly OpenSlide's own read (openslide-write-png), and the large
#    one's decoded PSNR against OpenSlide's read equals the PSNR the
#    encoder measured against its input (so that input was OpenSlide's
#    pixels exactly);
#  - a 16-bit GeoTIFF (gdal_translate of a generated grid, EPSG:32633,
#    10 m pixels) and a three-band 8-bit COG: the geotransform, EPSG code
#    and WKT are in the metadata; the 16-bit one's level 0 is exactly
#    GDAL's own read brought to 8 bits by the documented rule (oiiotool
#    -d uint8 gives that rule, as in cli_basic.sh);
#  - sharded encodes merge to the very bytes of the unsharded store,
#    metadata section included;
#  - gigaviewd returns the metadata in GET /v1/images/{id} and a slide's
#    scale as the IIIF Physical Dimensions service of info.json.
# Skipped (1..0 # SKIP) in a build without OpenSlide and GDAL; each half
# skips without its library or its command-line tools.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
need_tool oiiotool idiff

builddir=$(cd "${top_builddir:-.}" && pwd)
have() { grep -q "^#define GV_HAVE_$1 1" "$builddir/config.h"; }
if ! have OPENSLIDE && ! have GDAL; then
    echo "1..0 # SKIP built without OpenSlide and GDAL (apt-get install libopenslide-dev libgdal-dev)"
    exit 0
fi
MAKE_SLIDE=$builddir/tests/make_slide
S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
cd "$T/w" || bail "cd"

# json_has FILE TEXT: FILE contains TEXT (fixed string).
json_has() {
    grep -qF -- "$2" "$1"
}

# same_store A B DESC: byte-identical files.
same_store() {
    if cmp -s "$1" "$2"; then ok "$3"; else not_ok "$3" "$1 and $2 differ"; fi
}

# shard_check INPUT STORE DESC: shards 0/2 and 1/2 merged give STORE.
shard_check() {
    run encode --shard 0/2 "$1" -o s0.shard --quiet
    run encode --shard 1/2 "$1" -o s1.shard --quiet
    run merge -o merged.gv s0.shard s1.shard --quiet
    expect_rc "merge of $1's shards" 0
    same_store merged.gv "$2" "$3"
    rm -f s0.shard s1.shard merged.gv
}

# ------------------------------------------------------------ slides
if ! have OPENSLIDE; then
    skip "whole-slide images" "built without OpenSlide"
elif ! command -v openslide-write-png >/dev/null 2>&1; then
    skip "whole-slide images" "no openslide-write-png (apt-get install openslide-tools)"
else
    "$MAKE_SLIDE" small.svs 500 380 none 0.2527 40 || bail "make_slide small"
    "$MAKE_SLIDE" big.svs 1500 1100 jpeg || bail "make_slide big"

    run encode small.svs -o "$S/small.gv" --quiet
    expect_rc "encode a small Aperio slide" 0
    run info "$S/small.gv"
    check "info shows the vendor" grep -q 'slide.vendor = aperio' "$T/out"
    check "info shows microns per pixel" grep -q 'slide.mpp_x = 0.2527' "$T/out"
    check "info shows the objective power" \
        grep -q 'slide.objective_power = 40' "$T/out"
    gv info --json "$S/small.gv" >small.json
    check "info --json carries the metadata object" json_has small.json \
        '"metadata":{"slide.levels":1,"slide.mpp_x":0.2527,"slide.mpp_y":0.2527,"slide.objective_power":40.0,"slide.vendor":"aperio"}'
    openslide-write-png small.svs 0 0 0 500 380 ref4.png || bail "openslide-write-png"
    oiiotool ref4.png --ch R,G,B -o ref.png || bail "oiiotool --ch"
    run export "$S/small.gv" -o back.png
    # The store is lossy (level 0 is tiled under a 128-pixel root): the
    # export's PSNR against OpenSlide's read is the one the encoder
    # measured against its input, so that input was OpenSlide's read.
    check "level 0 against OpenSlide's read: the PSNR the encoder measured" \
        close_to "$(idiff_psnr ref.png back.png)" "$(gv info --json "$S/small.gv" | sed -n 's/.*"psnr0":\([0-9.]*\).*/\1/p')" 0.01

    run encode big.svs -o "$S/big.gv" --quiet
    expect_rc "encode a JPEG slide of two levels" 0
    gv info --json "$S/big.gv" >big.json
    check "two levels seen by OpenSlide" json_has big.json '"slide.levels":2'
    check "default MPP and AppMag" json_has big.json \
        '"slide.mpp_x":0.499,"slide.mpp_y":0.499,"slide.objective_power":20.0'
    psnr0=$(json_field big.json psnr0)
    openslide-write-png big.svs 0 0 0 1500 1100 ref4.png || bail "openslide-write-png"
    oiiotool ref4.png --ch R,G,B -o ref.png || bail "oiiotool --ch"
    run export "$S/big.gv" -o back.png
    p=$(idiff ref.png back.png 2>/dev/null | sed -n 's/.*Peak SNR = *//p')
    if [ -n "$p" ] && awk -v a="$p" -v b="$psnr0" 'BEGIN { d = a - b; exit !(d < 0.01 && d > -0.01) }'; then
        ok "lossy store: PSNR against OpenSlide's read $p = the encoder's $psnr0"
    else
        not_ok "lossy store: PSNR against OpenSlide's read '$p' != the encoder's '$psnr0'"
    fi
    run export "$S/big.gv" --region 700,500,300,200 -o region.png
    oiiotool back.png --cut 300x200+700+500 -o cut.png
    check "a region of the slide is the same pixels" idiff -q -fail 0 cut.png region.png
    shard_check big.svs "$S/big.gv" "sharded slide encode = unsharded, metadata included"
fi

# ---------------------------------------------------------- GeoTIFFs
if ! have GDAL; then
    skip "georeferenced rasters" "built without GDAL"
elif ! command -v gdal_translate >/dev/null 2>&1; then
    skip "georeferenced rasters" "no gdal_translate (apt-get install gdal-bin)"
else
    # A 300 x 200 grid of 16-bit values over the whole range, 10 m cells
    # of UTM zone 33N, in 128 x 128 deflate tiles.
    awk 'BEGIN { print "ncols 300"; print "nrows 200"; print "xllcorner 500000";
        print "yllcorner 4598000"; print "cellsize 10";
        for (y = 0; y < 200; y++) { l = "";
            for (x = 0; x < 300; x++) l = l (x ? " " : "") (x * y * 37 + x * 113 + y * 59) % 65536;
            print l } }' >grid.asc
    gdal_translate -q -ot UInt16 -a_srs EPSG:32633 -co TILED=YES \
        -co BLOCKXSIZE=128 -co BLOCKYSIZE=128 -co COMPRESS=DEFLATE \
        grid.asc geo16.tif || bail "gdal_translate geo16.tif"
    run encode geo16.tif -o "$S/geo16.gv" --quiet
    expect_rc "encode a 16-bit GeoTIFF" 0
    gv info --json "$S/geo16.gv" >geo.json
    check "the EPSG code" json_has geo.json '"geo.epsg":32633'
    check "the geotransform" json_has geo.json \
        '"geo.transform":[500000.0,10.0,0.0,4600000.0,0.0,-10.0]'
    check "the CRS as WKT" json_has geo.json '"geo.crs_wkt":"PROJCS[\"WGS 84 / UTM zone 33N\"'
    run info "$S/geo16.gv"
    check "info says 16-bit scaled" grep -q '16-bit, scaled to 8 bits' "$T/out"
    gdal_translate -q -co COMPRESS=NONE geo16.tif gdal16.tif || bail "gdal_translate read"
    oiiotool gdal16.tif -d uint8 -o ref8.png || bail "oiiotool -d uint8"
    run export "$S/geo16.gv" -o back.png
    check "level 0 against GDAL's read brought to 8 bits: the PSNR the encoder measured" \
        close_to "$(idiff_psnr ref8.png back.png)" "$(sed -n 's/.*"psnr0":\([0-9.]*\).*/\1/p' geo.json)" 0.01
    shard_check geo16.tif "$S/geo16.gv" "sharded GeoTIFF encode = unsharded, metadata included"

    # Three 8-bit bands as a Cloud-Optimized GeoTIFF in WGS 84.
    gdal_translate -q -of COG -a_srs EPSG:4326 -a_ullr -5 44 -4 43.25 \
        "$TESTDATA/seeding-700x520.png" cog.tif || bail "gdal_translate cog.tif"
    run encode cog.tif -o "$S/cog.gv" --quiet
    expect_rc "encode a three-band COG" 0
    gv info --json "$S/cog.gv" >cog.json
    check "COG: EPSG 4326, three bands" json_has cog.json '"geo.bands":3'
    check "COG: EPSG 4326" json_has cog.json '"geo.epsg":4326'
    psnr0=$(json_field cog.json psnr0)
    run export "$S/cog.gv" -o back.png
    p=$(idiff "$TESTDATA/seeding-700x520.png" back.png 2>/dev/null | sed -n 's/.*Peak SNR = *//p')
    if [ -n "$p" ] && awk -v a="$p" -v b="$psnr0" 'BEGIN { d = a - b; exit !(d < 0.01 && d > -0.01) }'; then
        ok "COG: PSNR against the bands $p = the encoder's $psnr0"
    else
        not_ok "COG: PSNR against the bands '$p' != the encoder's '$psnr0'"
    fi
fi

# ---------------------------------------------------------- gigaviewd
cat >"$T/d.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 2
access_log = stderr
EOF2
start_daemon "$T/d.conf"
if have OPENSLIDE && [ -f "$S/small.gv" ]; then
    req "$(url /v1/images/small)"
    check "GET /v1/images/{id}: the slide's metadata" json_has "$T/b" \
        '"slide.mpp_x":0.2527'
    req "$(url /iiif/3/small/info.json)"
    scale=$(sed -n 's/.*"physicalScale": *\([-0-9.e]*\).*/\1/p' "$T/b")
    check "info.json: the Physical Dimensions service, $scale mm per pixel (as written, no float noise)" \
        [ "$scale" = 0.0002527 ]
    check "info.json: the service's profile" json_has "$T/b" \
        '"profile": "http://iiif.io/api/annex/services/physdim"'
fi
if have GDAL && [ -f "$S/geo16.gv" ]; then
    req "$(url /v1/images/geo16)"
    check "GET /v1/images/{id}: the raster's EPSG code" json_has "$T/b" \
        '"geo.epsg":32633'
    req "$(url /iiif/3/geo16/info.json)"
    if json_has "$T/b" 'service'; then
        not_ok "info.json of a raster names no service" "$(cat "$T/b")"
    else
        ok "info.json of a raster names no service"
    fi
fi
stop_daemon
no_sanitizer_report

done_testing
