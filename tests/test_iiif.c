/*
 * test_iiif.c - iiif_parse against a table of requests: every level-2 form
 * of region, size, rotation, quality and format, the specification's own
 * examples (a 300x200 image), rounding, cropping, limits and hostile
 * input.  Each row gives the four segments, the image size and the limits,
 * and either the exact canonical request or the error class (400, 501 or
 * a limit) with the exact message.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "iiif.h"
#include "util.h"

enum want { OK, BAD, NI, LIM };   /* 200, 400, 501, limit (400/413) */

/* Limit sets: 0 none (no upscaling at all), 1 generous, 2 tight. */
static const struct iiif_limits limits[] = {
    {0, 0, 0, 0.0},
    {1000, 1000, 0, 4.0},
    {400, 300, 100000, 2.0},
    {0, 0, 1, 1.0},
    {0, 0, 0, NAN},            /* NaN upscale limit: no upscaling */
};

struct row {
    const char *region, *size, *rotation, *qf;
    uint32_t W, H;
    int lim;
    enum want want;
    /* for OK */
    uint32_t x, y, w, h, ow, oh;
    int rot, mirror;
    enum gv_quality q;
    const char *fmt;
    /* for errors: the exact message */
    const char *msg;
};

#define D GV_QUALITY_DEFAULT
#define C GV_QUALITY_COLOR
#define G GV_QUALITY_GRAY
#define B GV_QUALITY_BITONAL
#define R(reg, sz, rot, qf, W, H, lim, x, y, w, h, ow, oh, r, m, q, f) \
    {reg, sz, rot, qf, W, H, lim, OK, x, y, w, h, ow, oh, r, m, q, f, NULL}
#define E(reg, sz, rot, qf, W, H, lim, want, msg) \
    {reg, sz, rot, qf, W, H, lim, want, 0, 0, 0, 0, 0, 0, 0, 0, D, NULL, msg}

static const struct row rows[] = {
    /* region: every form */
    R("full", "max", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, D, "jpg"),
    R("square", "max", "0", "default.png", 300, 200, 0, 50, 0, 200, 200, 200, 200, 0, 0, D, "png"),
    R("square", "max", "0", "default.png", 200, 300, 0, 0, 50, 200, 200, 200, 200, 0, 0, D, "png"),
    R("square", "max", "0", "default.png", 301, 200, 0, 50, 0, 200, 200, 200, 200, 0, 0, D, "png"),
    R("square", "max", "0", "default.png", 100, 100, 0, 0, 0, 100, 100, 100, 100, 0, 0, D, "png"),
    R("125,15,120,140", "max", "0", "default.jpg", 300, 200, 0, 125, 15, 120, 140, 120, 140, 0, 0, D, "jpg"),
    R("pct:41.6,7.5,40,70", "max", "0", "default.jpg", 300, 200, 0, 125, 15, 120, 140, 120, 140, 0, 0, D, "jpg"),
    R("125,15,200,200", "max", "0", "default.jpg", 300, 200, 0, 125, 15, 175, 185, 175, 185, 0, 0, D, "jpg"),
    R("pct:41.6,7.5,66.6,100", "max", "0", "default.jpg", 300, 200, 0, 125, 15, 175, 185, 175, 185, 0, 0, D, "jpg"),
    R("pct:0,0,100,100", "max", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, D, "jpg"),
    /* pct rounding: halves up, each value on its own, then cropped */
    R("pct:50,50,50,50", "max", "0", "default.jpg", 301, 201, 0, 151, 101, 150, 100, 150, 100, 0, 0, D, "jpg"),
    R("pct:.5,0,50.,100", "max", "0", "default.jpg", 1000, 100, 0, 5, 0, 500, 100, 500, 100, 0, 0, D, "jpg"),
    R("pct:0.0000000001,0,100,100", "max", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, D, "jpg"),
    R("pct:33.3333,0,33.3333,100", "max", "0", "default.jpg", 3, 1, 0, 1, 0, 1, 1, 1, 1, 0, 0, D, "jpg"),
    E("pct:0.1,0,0.1,100", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"pct:0.1,0,0.1,100\": zero width or height"),
    E("pct:99.99,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"pct:99.99,0,1,1\" is outside the image (300x200)"),
    E("pct:1000000000,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"pct:1000000000,0,1,1\": field 1 is not a decimal number of at most 9 integer digits"),
    R("pct:000000000050,0,50,100", "max", "0", "default.jpg", 300, 200, 0, 150, 0, 150, 200, 150, 200, 0, 0, D, "jpg"),
    /* edges */
    R("0,0,1,1", "max", "0", "default.jpg", 300, 200, 0, 0, 0, 1, 1, 1, 1, 0, 0, D, "jpg"),
    R("299,199,10,10", "max", "0", "default.jpg", 300, 200, 0, 299, 199, 1, 1, 1, 1, 0, 0, D, "jpg"),
    R("0,0,2147483647,1", "max", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 1, 300, 1, 0, 0, D, "jpg"),
    R("007,0,10,10", "max", "0", "default.jpg", 300, 200, 0, 7, 0, 10, 10, 10, 10, 0, 0, D, "jpg"),
    E("300,0,10,10", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"300,0,10,10\" is outside the image (300x200)"),
    E("0,200,10,10", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"0,200,10,10\" is outside the image (300x200)"),
    E("0,0,0,10", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"0,0,0,10\": zero width or height"),
    E("0,0,10,0", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"0,0,10,0\": zero width or height"),
    /* hostile regions */
    E("-1,0,10,10", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"-1,0,10,10\": field 1 is not an integer in 0..2147483647"),
    E("+1,0,10,10", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"+1,0,10,10\": field 1 is not an integer in 0..2147483647"),
    E("0,0,99999999999999999999,1", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"0,0,99999999999999999999,1\": field 3 is not an integer in 0..2147483647"),
    E("0,0,4294967296,1", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"0,0,4294967296,1\": field 3 is not an integer in 0..2147483647"),
    E("2147483648,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"2147483648,0,1,1\": field 1 is not an integer in 0..2147483647"),
    E("pct:nan,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"pct:nan,0,1,1\": field 1 is not a decimal number of at most 9 integer digits"),
    E("pct:inf,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"pct:inf,0,1,1\": field 1 is not a decimal number of at most 9 integer digits"),
    E("pct:1e2,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"pct:1e2,0,1,1\": field 1 is not a decimal number of at most 9 integer digits"),
    E("pct:+1,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"pct:+1,0,1,1\": field 1 is not a decimal number of at most 9 integer digits"),
    E("pct:1..2,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"pct:1..2,0,1,1\": field 1 is not a decimal number of at most 9 integer digits"),
    E("pct:.,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"pct:.,0,1,1\": field 1 is not a decimal number of at most 9 integer digits"),
    E("pct:1,2,3", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"pct:1,2,3\": pct: needs four numbers x,y,w,h"),
    E("full ", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"full \": expected full, square, x,y,w,h or pct:x,y,w,h"),
    E(" full", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \" full\": expected full, square, x,y,w,h or pct:x,y,w,h"),
    E("Full", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"Full\": expected full, square, x,y,w,h or pct:x,y,w,h"),
    E("1,2,3", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"1,2,3\": expected full, square, x,y,w,h or pct:x,y,w,h"),
    E("1,2,3,4,5", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"1,2,3,4,5\": expected full, square, x,y,w,h or pct:x,y,w,h"),
    E("1,,3,4", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"1,,3,4\": field 2 is not an integer in 0..2147483647"),
    E("1,2,3,4,", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"1,2,3,4,\": expected full, square, x,y,w,h or pct:x,y,w,h"),
    E("1, 2,3,4", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"1, 2,3,4\": field 2 is not an integer in 0..2147483647"),
    E("", "max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: region \"\": expected full, square, x,y,w,h or pct:x,y,w,h"),
    E("full", "max", "0", "default.jpg", 0, 200, 0, BAD,
      "iiif: bad image size 0x200"),
    /* size: every form, the specification's examples */
    R("full", "150,", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 150, 100, 0, 0, D, "jpg"),
    R("full", ",150", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 225, 150, 0, 0, D, "jpg"),
    R("full", "pct:50", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 150, 100, 0, 0, D, "jpg"),
    R("full", "225,100", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 225, 100, 0, 0, D, "jpg"),
    R("full", "!225,100", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 150, 100, 0, 0, D, "jpg"),
    R("full", "^!360,360", "0", "default.jpg", 300, 200, 1, 0, 0, 300, 200, 360, 240, 0, 0, D, "jpg"),
    R("full", "^360,", "0", "default.jpg", 300, 200, 1, 0, 0, 300, 200, 360, 240, 0, 0, D, "jpg"),
    R("full", "^,240", "0", "default.jpg", 300, 200, 1, 0, 0, 300, 200, 360, 240, 0, 0, D, "jpg"),
    R("full", "^pct:120", "0", "default.jpg", 300, 200, 1, 0, 0, 300, 200, 360, 240, 0, 0, D, "jpg"),
    R("full", "^360,360", "0", "default.jpg", 300, 200, 1, 0, 0, 300, 200, 360, 360, 0, 0, D, "jpg"),
    R("full", "^max", "0", "default.jpg", 300, 200, 1, 0, 0, 300, 200, 1000, 666, 0, 0, D, "jpg"),
    R("full", "^max", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, D, "jpg"),
    R("full", "^max", "0", "default.jpg", 300, 200, 4, 0, 0, 300, 200, 300, 200, 0, 0, D, "jpg"),
    R("full", "^150,", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 150, 100, 0, 0, D, "jpg"),
    R("full", "max", "0", "default.jpg", 300, 200, 2, 0, 0, 300, 200, 300, 200, 0, 0, D, "jpg"),
    R("full", "max", "0", "default.jpg", 1000, 800, 2, 0, 0, 1000, 800, 353, 282, 0, 0, D, "jpg"),
    R("full", "max", "0", "default.jpg", 100000, 80000, 1, 0, 0, 100000, 80000, 1000, 800, 0, 0, D, "jpg"),
    R("full", "max", "0", "default.jpg", 300, 200, 3, 0, 0, 300, 200, 1, 1, 0, 0, D, "jpg"),
    R("full", "^!1000,1000", "0", "default.jpg", 300, 200, 2, 0, 0, 300, 200, 387, 258, 0, 0, D, "jpg"),
    R("full", "!300,300", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, D, "jpg"),
    R("full", "!1000,50", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 75, 50, 0, 0, D, "jpg"),
    R("full", "!50,1000", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 50, 33, 0, 0, D, "jpg"),
    R("full", "!1000,1000", "0", "default.jpg", 1000, 800, 2, 0, 0, 1000, 800, 353, 282, 0, 0, D, "jpg"),
    R("full", "1,1", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 1, 1, 0, 0, D, "jpg"),
    R("full", "1,", "0", "default.jpg", 1000000, 3, 0, 0, 0, 1000000, 3, 1, 1, 0, 0, D, "jpg"),
    R("full", "1,", "0", "default.jpg", 3, 1000000, 0, 0, 0, 3, 1000000, 1, 333333, 0, 0, D, "jpg"),
    R("full", "pct:50", "0", "default.jpg", 3, 3, 0, 0, 0, 3, 3, 2, 2, 0, 0, D, "jpg"),
    R("full", "pct:100", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, D, "jpg"),
    R("full", "pct:0.1", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 1, 1, 0, 0, D, "jpg"),
    R("10,10,100,50", "50,25", "0", "default.jpg", 300, 200, 0, 10, 10, 100, 50, 50, 25, 0, 0, D, "jpg"),
    /* size errors */
    E("full", "400,", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"400,\": 400x267 is larger than the region (300x200); use ^ to upscale"),
    E("full", ",201", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \",201\": 302x201 is larger than the region (300x200); use ^ to upscale"),
    E("full", "301,200", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"301,200\": 301x200 is larger than the region (300x200); use ^ to upscale"),
    E("full", "pct:101", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"pct:101\": above 100% needs ^ to upscale"),
    E("full", "pct:100.000001", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"pct:100.000001\": above 100% needs ^ to upscale"),
    E("full", "^400,", "0", "default.jpg", 300, 200, 0, LIM,
      "iiif: size \"^400,\": 400x267 enlarges the region (300x200) more than the allowed 1x"),
    E("full", "^400,", "0", "default.jpg", 300, 200, 4, LIM,
      "iiif: size \"^400,\": 400x267 enlarges the region (300x200) more than the allowed 1x"),
    E("full", "^1300,", "0", "default.jpg", 300, 200, 1, LIM,
      "iiif: size \"^1300,\": 1300x867 enlarges the region (300x200) more than the allowed 4x"),
    E("full", "^1100,", "0", "default.jpg", 300, 200, 1, LIM,
      "iiif: size \"^1100,\": 1100x733 is past the limits (maxWidth 1000, maxHeight 1000)"),
    E("full", "^pct:999999999", "0", "default.jpg", 300, 200, 1, LIM,
      "iiif: size \"^pct:999999999\": 2999999997x1999999998 enlarges the region (300x200) more than the allowed 4x"),
    E("full", "^pct:1000000000", "0", "default.jpg", 300, 200, 1, BAD,
      "iiif: size \"^pct:1000000000\": pct: needs a decimal number of at most 9 integer digits"),
    E("full", "^pct:0", "0", "default.jpg", 300, 200, 1, BAD,
      "iiif: size \"^pct:0\": zero size"),
    E("full", "pct:0", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"pct:0\": zero size"),
    E("full", "0,", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"0,\": zero size"),
    E("full", "0,0", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"0,0\": zero size"),
    E("full", "!100,", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"!100,\": !w,h needs both a width and a height"),
    E("full", "!,100", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"!,100\": !w,h needs both a width and a height"),
    E("full", "max,", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"max,\": width is not an integer in 0..2147483647"),
    E("full", ",", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \",\": no width or height"),
    E("full", "^", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"^\": expected max, w,  ,h  w,h  !w,h or pct:n, each optionally after ^"),
    E("full", "^^max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"^^max\": expected max, w,  ,h  w,h  !w,h or pct:n, each optionally after ^"),
    E("full", "!^100,100", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"!^100,100\": width is not an integer in 0..2147483647"),
    E("full", "full", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"full\": expected max, w,  ,h  w,h  !w,h or pct:n, each optionally after ^"),
    E("full", "Max", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"Max\": expected max, w,  ,h  w,h  !w,h or pct:n, each optionally after ^"),
    E("full", "10,10,", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"10,10,\": expected max, w,  ,h  w,h  !w,h or pct:n, each optionally after ^"),
    E("full", "-10,", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"-10,\": width is not an integer in 0..2147483647"),
    E("full", "10 ,", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"10 ,\": width is not an integer in 0..2147483647"),
    E("full", "pct:nan", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"pct:nan\": pct: needs a decimal number of at most 9 integer digits"),
    E("full", "pct:", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"pct:\": pct: needs a decimal number of at most 9 integer digits"),
    E("full", "", "0", "default.jpg", 300, 200, 0, BAD,
      "iiif: size \"\": expected max, w,  ,h  w,h  !w,h or pct:n, each optionally after ^"),
    /* rotation */
    R("full", "max", "90", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 90, 0, D, "jpg"),
    R("full", "max", "180", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 180, 0, D, "jpg"),
    R("full", "max", "270", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 270, 0, D, "jpg"),
    R("full", "max", "!0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 1, D, "jpg"),
    R("full", "max", "!90", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 90, 1, D, "jpg"),
    R("full", "max", "!270", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 270, 1, D, "jpg"),
    R("full", "max", "360", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, D, "jpg"),
    R("full", "max", "!360", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 1, D, "jpg"),
    R("full", "max", "90.0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 90, 0, D, "jpg"),
    R("full", "max", "090", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 90, 0, D, "jpg"),
    R("full", "max", "90.", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 90, 0, D, "jpg"),
    R("full", "max", "0.0", "default.jpg", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, D, "jpg"),
    E("full", "max", "22.5", "default.png", 300, 200, 0, NI,
      "iiif: rotation \"22.5\": only multiples of 90 degrees are supported"),
    E("full", "max", "!45", "default.png", 300, 200, 0, NI,
      "iiif: rotation \"!45\": only multiples of 90 degrees are supported"),
    E("full", "max", "90.5", "default.png", 300, 200, 0, NI,
      "iiif: rotation \"90.5\": only multiples of 90 degrees are supported"),
    E("full", "max", "361", "default.jpg", 300, 200, 0, BAD,
      "iiif: rotation \"361\": above 360 degrees"),
    E("full", "max", "360.5", "default.jpg", 300, 200, 0, BAD,
      "iiif: rotation \"360.5\": above 360 degrees"),
    E("full", "max", "!", "default.jpg", 300, 200, 0, BAD,
      "iiif: rotation \"!\": expected a number of degrees 0..360, optionally after !"),
    E("full", "max", "!!90", "default.jpg", 300, 200, 0, BAD,
      "iiif: rotation \"!!90\": expected a number of degrees 0..360, optionally after !"),
    E("full", "max", "-90", "default.jpg", 300, 200, 0, BAD,
      "iiif: rotation \"-90\": expected a number of degrees 0..360, optionally after !"),
    E("full", "max", "", "default.jpg", 300, 200, 0, BAD,
      "iiif: rotation \"\": expected a number of degrees 0..360, optionally after !"),
    E("full", "max", " 90", "default.jpg", 300, 200, 0, BAD,
      "iiif: rotation \" 90\": expected a number of degrees 0..360, optionally after !"),
    E("full", "max", "9e1", "default.jpg", 300, 200, 0, BAD,
      "iiif: rotation \"9e1\": expected a number of degrees 0..360, optionally after !"),
    E("full", "max", "nan", "default.jpg", 300, 200, 0, BAD,
      "iiif: rotation \"nan\": expected a number of degrees 0..360, optionally after !"),
    E("full", "max", "90!", "default.jpg", 300, 200, 0, BAD,
      "iiif: rotation \"90!\": expected a number of degrees 0..360, optionally after !"),
    E("full", "max", "1e400", "default.jpg", 300, 200, 0, BAD,
      "iiif: rotation \"1e400\": expected a number of degrees 0..360, optionally after !"),
    E("full", "max", "99999999999999999999999", "default.jpg", 300, 200, 0, BAD,
      "iiif: rotation \"99999999999999999999999\": expected a number of degrees 0..360, optionally after !"),
    /* quality and format */
    R("full", "max", "0", "color.png", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, C, "png"),
    R("full", "max", "0", "gray.webp", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, G, "webp"),
    R("full", "max", "0", "bitonal.tif", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, B, "tif"),
    E("full", "max", "0", "grey.jpg", 300, 200, 0, BAD,
      "iiif: quality \"grey\": expected default, color, gray or bitonal"),
    E("full", "max", "0", "Default.jpg", 300, 200, 0, BAD,
      "iiif: quality \"Default\": expected default, color, gray or bitonal"),
    E("full", "max", "0", ".jpg", 300, 200, 0, BAD,
      "iiif: quality \"\": expected default, color, gray or bitonal"),
    E("full", "max", "0", "default.JPG", 300, 200, 0, BAD,
      "iiif: format \"JPG\": expected jpg, png, webp or tif"),
    E("full", "max", "0", "color.jpg.png", 300, 200, 0, BAD,
      "iiif: format \"jpg.png\": expected jpg, png, webp or tif"),
    E("full", "max", "0", "default", 300, 200, 0, BAD,
      "iiif: quality.format \"default\": no format"),
    E("full", "max", "0", "default.", 300, 200, 0, BAD,
      "iiif: format \"\": expected jpg, png, webp or tif"),
    E("full", "max", "0", "default.jpeg", 300, 200, 0, BAD,
      "iiif: format \"jpeg\": expected jpg, png, webp or tif"),
    E("full", "max", "0", "default.tiff", 300, 200, 0, BAD,
      "iiif: format \"tiff\": expected jpg, png, webp or tif"),
    E("full", "max", "0", "default.jpg ", 300, 200, 0, BAD,
      "iiif: format \"jpg \": expected jpg, png, webp or tif"),
    E("full", "max", "0", "default.gif", 300, 200, 0, BAD,
      "iiif: format \"gif\" is not supported (jpg, png, webp, tif)"),
    E("full", "max", "0", "default.jp2", 300, 200, 0, BAD,
      "iiif: format \"jp2\" is not supported (jpg, png, webp, tif)"),
    E("full", "max", "0", "default.pdf", 300, 200, 0, BAD,
      "iiif: format \"pdf\" is not supported (jpg, png, webp, tif)"),
    /* the first error in URI order is the one reported */
    E("bad", "max", "22.5", "default.gif", 300, 200, 0, BAD,
      "iiif: region \"bad\": expected full, square, x,y,w,h or pct:x,y,w,h"),
    E("full", "bad", "22.5", "default.gif", 300, 200, 0, BAD,
      "iiif: size \"bad\": expected max, w,  ,h  w,h  !w,h or pct:n, each optionally after ^"),
    E("full", "max", "22.5", "bad.gif", 300, 200, 0, NI,
      "iiif: rotation \"22.5\": only multiples of 90 degrees are supported"),
    /* the specification's order-of-implementation example */
    R("125,15,120,140", "90,", "!90", "gray.jpg", 300, 200, 0, 125, 15, 120, 140, 90, 105, 90, 1, G, "jpg"),
};

static const char *want_name(enum want w)
{
    static const char *const n[] = {"OK", "400", "501", "limit"};
    return n[w];
}

static enum want classify(int rc, const struct gv_error *err)
{
    if (rc == 0)
        return OK;
    switch (err->code) {
    case GV_EINVAL: return BAD;
    case GV_EFORMAT: return NI;
    case GV_ELIMIT: return LIM;
    default: return OK;   /* never expected: reported as a mismatch */
    }
}

int main(void)
{
    const size_t n = sizeof rows / sizeof rows[0];
    for (size_t i = 0; i < n; i++) {
        const struct row *t = &rows[i];
        struct iiif_request r;
        struct gv_error err = {0};
        memset(&r, 0xA5, sizeof r);
        gv_error_clear(&err);
        int rc = iiif_parse(t->region, t->size, t->rotation, t->qf, t->W,
                            t->H, &limits[t->lim], &r, &err);
        enum want got = classify(rc, &err);
        const struct gv_render_req *q = &r.render;
        int ok;
        if (t->want == OK)
            ok = rc == 0 && q->x == t->x && q->y == t->y && q->w == t->w
                 && q->h == t->h && q->out_w == t->ow && q->out_h == t->oh
                 && q->rotation == t->rot && q->mirror == t->mirror
                 && q->quality == t->q && strcmp(r.format, t->fmt) == 0
                 && q->max_decode_pixels == 0;
        else
            ok = rc != 0 && got == t->want && strcmp(err.text, t->msg) == 0;
        check(ok, "%s/%s/%s/%s on %ux%u (limits %d): %s", t->region,
              t->size, t->rotation, t->qf, t->W, t->H, t->lim,
              want_name(t->want));
        if (!ok) {
            if (rc == 0)
                printf("# got OK: %u,%u,%u,%u -> %ux%u rot %d mirror %d "
                       "quality %d format %s\n", q->x, q->y, q->w, q->h,
                       q->out_w, q->out_h, q->rotation, q->mirror,
                       (int)q->quality, r.format);
            else
                printf("# got %s (code %d): %s\n# wanted: %s\n",
                       want_name(got), (int)err.code, err.text,
                       t->want == OK ? "OK" : t->msg);
        }
    }
    /* Hostile input is echoed in messages only as printable ASCII: control
     * characters and quotes become '?'. */
    {
        struct iiif_request r;
        struct gv_error err = {0};
        int rc = iiif_parse("\x1b[31m\n\"x\"", "max", "0", "default.jpg", 10,
                            10, &limits[0], &r, &err);
        int clean = 1;
        for (const char *p = err.text; *p; p++)
            if ((unsigned char)*p < 0x20 || (unsigned char)*p >= 0x7f)
                clean = 0;
        check(rc != 0 && clean, "control characters in input are not echoed");
        check_str(err.text, "iiif: region \"?[31m??x?\": expected full, square, "
                  "x,y,w,h or pct:x,y,w,h", "control characters: the message");
    }
    return tap_done();
}
