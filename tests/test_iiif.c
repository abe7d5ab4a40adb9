/*
 * test_iiif.c - iiif_parse against a table of requests: every level-2 form
 * of region, size, rotation, quality and format, the specification's own
 * examples (a 300x200 image), rounding, cropping, limits and hostile
 * input.  Each row gives the four segments, the image size and the limits,
 * and either the exact canonical request or the error class (400, 501 or
 * a limit) with a word the message must contain.
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
    /* for errors: a word the message must contain (the parameter) */
    const char *word;
};

#define D GV_QUALITY_DEFAULT
#define C GV_QUALITY_COLOR
#define G GV_QUALITY_GRAY
#define B GV_QUALITY_BITONAL
#define R(reg, sz, rot, qf, W, H, lim, x, y, w, h, ow, oh, r, m, q, f) \
    {reg, sz, rot, qf, W, H, lim, OK, x, y, w, h, ow, oh, r, m, q, f, NULL}
#define E(reg, sz, rot, qf, W, H, lim, want, word) \
    {reg, sz, rot, qf, W, H, lim, want, 0, 0, 0, 0, 0, 0, 0, 0, D, NULL, word}

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
    E("pct:0.1,0,0.1,100", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("pct:99.99,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("pct:1000000000,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    R("pct:000000000050,0,50,100", "max", "0", "default.jpg", 300, 200, 0, 150, 0, 150, 200, 150, 200, 0, 0, D, "jpg"),
    /* edges */
    R("0,0,1,1", "max", "0", "default.jpg", 300, 200, 0, 0, 0, 1, 1, 1, 1, 0, 0, D, "jpg"),
    R("299,199,10,10", "max", "0", "default.jpg", 300, 200, 0, 299, 199, 1, 1, 1, 1, 0, 0, D, "jpg"),
    R("0,0,4294967295,1", "max", "0", "default.jpg", 300, 200, 0, 0, 0, 300, 1, 300, 1, 0, 0, D, "jpg"),
    R("007,0,10,10", "max", "0", "default.jpg", 300, 200, 0, 7, 0, 10, 10, 10, 10, 0, 0, D, "jpg"),
    E("300,0,10,10", "max", "0", "default.jpg", 300, 200, 0, BAD, "outside"),
    E("0,200,10,10", "max", "0", "default.jpg", 300, 200, 0, BAD, "outside"),
    E("0,0,0,10", "max", "0", "default.jpg", 300, 200, 0, BAD, "zero"),
    E("0,0,10,0", "max", "0", "default.jpg", 300, 200, 0, BAD, "zero"),
    /* hostile regions */
    E("-1,0,10,10", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("+1,0,10,10", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("0,0,99999999999999999999,1", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("0,0,4294967296,1", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("pct:nan,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("pct:inf,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("pct:1e2,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("pct:+1,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("pct:1..2,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("pct:.,0,1,1", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("pct:1,2,3", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("full ", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E(" full", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("Full", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("1,2,3", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("1,2,3,4,5", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("1,,3,4", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("1,2,3,4,", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("1, 2,3,4", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("", "max", "0", "default.jpg", 300, 200, 0, BAD, "region"),
    E("full", "max", "0", "default.jpg", 0, 200, 0, BAD, "image size"),
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
    E("full", "400,", "0", "default.jpg", 300, 200, 0, BAD, "^"),
    E("full", ",201", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "301,200", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "pct:101", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "pct:100.000001", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "^400,", "0", "default.jpg", 300, 200, 0, LIM, "size"),
    E("full", "^400,", "0", "default.jpg", 300, 200, 4, LIM, "size"),
    E("full", "^1300,", "0", "default.jpg", 300, 200, 1, LIM, "size"),
    E("full", "^1100,", "0", "default.jpg", 300, 200, 1, LIM, "limits"),
    E("full", "^pct:999999999", "0", "default.jpg", 300, 200, 1, LIM, "size"),
    E("full", "^pct:1000000000", "0", "default.jpg", 300, 200, 1, BAD, "size"),
    E("full", "^pct:0", "0", "default.jpg", 300, 200, 1, BAD, "zero"),
    E("full", "pct:0", "0", "default.jpg", 300, 200, 0, BAD, "zero"),
    E("full", "0,", "0", "default.jpg", 300, 200, 0, BAD, "zero"),
    E("full", "0,0", "0", "default.jpg", 300, 200, 0, BAD, "zero"),
    E("full", "!100,", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "!,100", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "max,", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", ",", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "^", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "^^max", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "!^100,100", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "full", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "Max", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "10,10,", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "-10,", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "10 ,", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "pct:nan", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "pct:", "0", "default.jpg", 300, 200, 0, BAD, "size"),
    E("full", "", "0", "default.jpg", 300, 200, 0, BAD, "size"),
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
    E("full", "max", "22.5", "default.png", 300, 200, 0, NI, "rotation"),
    E("full", "max", "!45", "default.png", 300, 200, 0, NI, "rotation"),
    E("full", "max", "90.5", "default.png", 300, 200, 0, NI, "rotation"),
    E("full", "max", "361", "default.jpg", 300, 200, 0, BAD, "rotation"),
    E("full", "max", "360.5", "default.jpg", 300, 200, 0, BAD, "rotation"),
    E("full", "max", "!", "default.jpg", 300, 200, 0, BAD, "rotation"),
    E("full", "max", "!!90", "default.jpg", 300, 200, 0, BAD, "rotation"),
    E("full", "max", "-90", "default.jpg", 300, 200, 0, BAD, "rotation"),
    E("full", "max", "", "default.jpg", 300, 200, 0, BAD, "rotation"),
    E("full", "max", " 90", "default.jpg", 300, 200, 0, BAD, "rotation"),
    E("full", "max", "9e1", "default.jpg", 300, 200, 0, BAD, "rotation"),
    E("full", "max", "nan", "default.jpg", 300, 200, 0, BAD, "rotation"),
    E("full", "max", "90!", "default.jpg", 300, 200, 0, BAD, "rotation"),
    E("full", "max", "1e400", "default.jpg", 300, 200, 0, BAD, "rotation"),
    E("full", "max", "99999999999999999999999", "default.jpg", 300, 200, 0, BAD, "rotation"),
    /* quality and format */
    R("full", "max", "0", "color.png", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, C, "png"),
    R("full", "max", "0", "gray.webp", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, G, "webp"),
    R("full", "max", "0", "bitonal.tif", 300, 200, 0, 0, 0, 300, 200, 300, 200, 0, 0, B, "tif"),
    E("full", "max", "0", "grey.jpg", 300, 200, 0, BAD, "quality"),
    E("full", "max", "0", "Default.jpg", 300, 200, 0, BAD, "quality"),
    E("full", "max", "0", ".jpg", 300, 200, 0, BAD, "quality"),
    E("full", "max", "0", "default.JPG", 300, 200, 0, BAD, "format"),
    E("full", "max", "0", "color.jpg.png", 300, 200, 0, BAD, "format"),
    E("full", "max", "0", "default", 300, 200, 0, BAD, "format"),
    E("full", "max", "0", "default.", 300, 200, 0, BAD, "format"),
    E("full", "max", "0", "default.jpeg", 300, 200, 0, BAD, "format"),
    E("full", "max", "0", "default.tiff", 300, 200, 0, BAD, "format"),
    E("full", "max", "0", "default.jpg ", 300, 200, 0, BAD, "format"),
    E("full", "max", "0", "default.gif", 300, 200, 0, NI, "format"),
    E("full", "max", "0", "default.jp2", 300, 200, 0, NI, "format"),
    E("full", "max", "0", "default.pdf", 300, 200, 0, NI, "format"),
    /* the first error in URI order is the one reported */
    E("bad", "max", "22.5", "default.gif", 300, 200, 0, BAD, "region"),
    E("full", "bad", "22.5", "default.gif", 300, 200, 0, BAD, "size"),
    E("full", "max", "22.5", "bad.gif", 300, 200, 0, NI, "rotation"),
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
    tap_plan((int)n + 1);
    for (size_t i = 0; i < n; i++) {
        const struct row *t = &rows[i];
        struct iiif_request r;
        struct gv_error err;
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
            ok = rc != 0 && got == t->want && strstr(err.text, "iiif:")
                 && strstr(err.text, t->word);
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
                printf("# got %s (code %d): %s\n", want_name(got),
                       (int)err.code, err.text);
        }
    }
    /* Hostile input is echoed in messages only as printable ASCII. */
    {
        struct iiif_request r;
        struct gv_error err;
        int rc = iiif_parse("\x1b[31m\n\"x\"", "max", "0", "default.jpg", 10,
                            10, &limits[0], &r, &err);
        int clean = 1;
        for (const char *p = err.text; *p; p++)
            if ((unsigned char)*p < 0x20 || (unsigned char)*p >= 0x7f)
                clean = 0;
        check(rc != 0 && clean, "control characters in input are not echoed");
    }
    return tap_done();
}
