/*
 * iiif.c - IIIF Image API 3.0 request parameters (compliance level 2), see
 * iiif.h.
 *
 * Design.  Each of the four segments has a strict hand-written grammar;
 * nothing is trimmed or case-folded, and no number is read with
 * strtol/strtod (locale, whitespace, signs, exponents, "nan" and "inf"
 * would all slip through).  Anything outside the grammar is GV_EINVAL
 * (400) with a message naming the parameter; a well-formed request this
 * server cannot honour (arbitrary rotation) is GV_EFORMAT (501, "a valid
 * IIIF request that is not implemented", section 7.3); a format of the
 * specification's table that this server does not produce (gif, jp2,
 * pdf) is 400, like any other format it does not list.  No allocation.
 *
 * Numbers (section 4 and 4.7):
 *  - pixel values are one or more ASCII digits (leading zeros allowed),
 *    at most 2^31-1 (the largest image side); larger values are refused
 *    as out of range rather than saturated (section 10: early rejection
 *    of out-of-range values);
 *  - percentages and the rotation are decimal numbers made only of digits
 *    and at most one '.', with at least one digit ("0.5", "5", ".5" and
 *    "5." are accepted; "+1", "1e3", "nan", "inf", " 1" are not).  At most
 *    9 digits before the point are allowed; digits after the 9th decimal
 *    are checked but ignored.  Values are kept exactly as integers scaled
 *    by 10^9, so "90.0" is exactly 90 and pct arithmetic is exact.
 *
 * Rounding (the specification leaves it to the implementation, 4.7): a
 * pct: region value is rounded to the nearest pixel, halves up, each of
 * x, y, w, h on its own (this reproduces the specification's example:
 * pct:41.6,7.5,40,70 of 300x200 is 125,15,120,140), and the region is then
 * cropped at the image edge like a pixel region.  Sizes derived from the
 * aspect ratio (the other side of w, and ,h, both sides of pct:n and of
 * !w,h) are rounded to nearest, halves up, and are at least 1 pixel; a
 * requested width, height or percentage of zero is a 400.
 *
 * Limits: max_width, max_height and max_area of 0 mean "no limit" (the
 * output is still capped at 2^31-1 pixels a side).  max_upscale is the
 * largest factor a '^' size may enlarge the region by on either axis;
 * below 1 (0 included, or NaN) no enlargement at all is allowed.  The
 * forms that ask for "as large as possible" (max, ^max, !w,h, ^!w,h) are
 * shrunk to fit every limit, keeping the aspect ratio; the forms that
 * name exact pixels (w,  ,h  w,h  pct:n and their ^ forms) fail with
 * GV_ELIMIT when they pass a limit.
 *
 * Rotation: 0..360 inclusive with an optional leading '!' (mirror first).
 * 0, 90, 180, 270 and 360 (= 0) are supported; other angles in range are
 * valid but not implemented (501); above 360 is a 400.  Quality and format
 * are case-sensitive, as in the specification's tables: "default.JPG" is a
 * 400.  The last segment is split at its first '.', so "color.jpg.png" has
 * the format "jpg.png" (400).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "iiif.h"
#include "imageio/output_format.h"
#include "store/geometry.h"

#define FRAC_DIGITS 9                     /* decimals kept in a decimal */
#define FRAC_ONE 1000000000ull            /* 10^FRAC_DIGITS */
#define INT_DIGITS 9                      /* digits allowed before '.' */

/* Copy at most 40 characters of s into buf, replacing anything that is
 * not printable ASCII by '?', for error messages that echo client input
 * (the message may end up in a log line or a response body). */
static const char *show(const char *s, size_t n, char *buf, size_t size)
{
    size_t i = 0, lim = size - 4;
    for (; i < n && s[i] && i < lim; i++) {
        unsigned char c = (unsigned char)s[i];
        buf[i] = c >= 0x20 && c < 0x7f && c != '"' && c != '\\' ? (char)c
                                                                 : '?';
    }
    if (i < n && s[i]) {
        memcpy(buf + i, "...", 3);
        i += 3;
    }
    buf[i] = '\0';
    return buf;
}

#define SHOW(s) show((s), strlen(s), shown, sizeof shown)

/* Parse digits [s, e) as an unsigned integer <= GV_MAX_DIM (2^31 - 1, the
 * largest image side a store can have, so no sum of two overflows 32
 * bits). */
/* Same shape as http_parse_u32 in http.c: deliberately separate, this one
 * parses a span [s, e) and keeps iiif.c free of http.c. */
static int parse_uint(const char *s, const char *e, uint32_t *out)
{
    if (s == e)
        return -1;
    uint64_t v = 0;
    for (; s < e; s++) {
        if (*s < '0' || *s > '9')
            return -1;
        v = v * 10 + (uint64_t)(*s - '0');
        if (v > GV_MAX_DIM)
            return -1;
    }
    *out = (uint32_t)v;
    return 0;
}

/* Parse a decimal [s, e) as its value times 10^9 (see the header
 * comment): digits and at most one '.', at least one digit. */
static int parse_decimal(const char *s, const char *e, uint64_t *out)
{
    uint64_t ip = 0, fp = 0;
    int digits = 0, idigits = 0, fdigits = 0, dot = 0;
    for (; s < e; s++) {
        if (*s == '.') {
            if (dot++)
                return -1;
            continue;
        }
        if (*s < '0' || *s > '9')
            return -1;
        unsigned d = (unsigned)(*s - '0');
        digits++;
        if (!dot) {
            /* leading zeros do not count towards the limit */
            if ((ip || d) && ++idigits > INT_DIGITS)
                return -1;
            ip = ip * 10 + d;
        } else if (fdigits < FRAC_DIGITS) {
            fp = fp * 10 + d;
            fdigits++;
        }
    }
    if (!digits)
        return -1;
    for (; fdigits < FRAC_DIGITS; fdigits++)
        fp *= 10;
    *out = ip * FRAC_ONE + fp;   /* < 10^18 */
    return 0;
}

/* round(a * b / c), halves up, for a < 2^63 / b; all of them nonnegative,
 * c > 0.  The product is formed in 128 bits where available. */
static uint64_t mul_div_round(uint64_t a, uint64_t b, uint64_t c)
{
#ifdef __SIZEOF_INT128__
    unsigned __int128 p = (unsigned __int128)a * b;
    unsigned __int128 r = (p + c / 2) / c;
    return r > UINT64_MAX ? UINT64_MAX : (uint64_t)r;
#else
    long double r = floorl((long double)a * b / c + 0.5L);
    return r >= 18446744073709551615.0L ? UINT64_MAX : (uint64_t)r;
#endif
}

/* Split [s, e) at commas into exactly n fields. */
static int split(const char *s, const char *e, int n, const char **fs,
                 const char **fe)
{
    int i = 0;
    fs[0] = s;
    for (const char *p = s; p < e; p++)
        if (*p == ',') {
            if (i + 1 >= n)
                return -1;
            fe[i] = p;
            fs[++i] = p + 1;
        }
    if (i + 1 != n)
        return -1;
    fe[i] = e;
    return 0;
}

static int parse_region(const char *region, uint32_t W, uint32_t H,
                        struct gv_render_req *r, struct gv_error *err)
{
    char shown[48];
    const char *s = region, *e = region + strlen(region);
    const char *fs[4], *fe[4];
    uint64_t x, y, w, h;

    if (strcmp(region, "full") == 0) {
        r->x = r->y = 0;
        r->w = W;
        r->h = H;
        return 0;
    }
    if (strcmp(region, "square") == 0) {
        /* centred in the longer dimension (the specification's
         * suggestion), flooring the offset */
        uint32_t side = W < H ? W : H;
        r->x = (W - side) / 2;
        r->y = (H - side) / 2;
        r->w = r->h = side;
        return 0;
    }
    if (strncmp(region, "pct:", 4) == 0) {
        uint64_t v[4];
        if (split(s + 4, e, 4, fs, fe) != 0)
            return gv_fail(err, GV_EINVAL, "iiif: region \"%s\": pct: needs "
                           "four numbers x,y,w,h", SHOW(region));
        for (int i = 0; i < 4; i++)
            if (parse_decimal(fs[i], fe[i], &v[i]) != 0)
                return gv_fail(err, GV_EINVAL, "iiif: region \"%s\": "
                               "field %d is not a decimal number of at most "
                               "%d integer digits", SHOW(region), i + 1,
                               INT_DIGITS);
        /* pixels = round(v / 10^9 / 100 * size) */
        x = mul_div_round(v[0], W, 100 * FRAC_ONE);
        y = mul_div_round(v[1], H, 100 * FRAC_ONE);
        w = mul_div_round(v[2], W, 100 * FRAC_ONE);
        h = mul_div_round(v[3], H, 100 * FRAC_ONE);
    } else {
        uint32_t v[4];
        if (split(s, e, 4, fs, fe) != 0)
            return gv_fail(err, GV_EINVAL, "iiif: region \"%s\": expected "
                           "full, square, x,y,w,h or pct:x,y,w,h",
                           SHOW(region));
        for (int i = 0; i < 4; i++)
            if (parse_uint(fs[i], fe[i], &v[i]) != 0)
                return gv_fail(err, GV_EINVAL, "iiif: region \"%s\": "
                               "field %d is not an integer in 0..%u",
                               SHOW(region), i + 1, GV_MAX_DIM);
        x = v[0];
        y = v[1];
        w = v[2];
        h = v[3];
    }
    if (w == 0 || h == 0)
        return gv_fail(err, GV_EINVAL, "iiif: region \"%s\": zero width or "
                       "height", SHOW(region));
    if (x >= W || y >= H)
        return gv_fail(err, GV_EINVAL, "iiif: region \"%s\" is outside the "
                       "image (%ux%u)", SHOW(region), W, H);
    /* crop at the image's edge (4.1) */
    if (w > W - x)
        w = W - x;
    if (h > H - y)
        h = H - y;
    r->x = (uint32_t)x;
    r->y = (uint32_t)y;
    r->w = (uint32_t)w;
    r->h = (uint32_t)h;
    return 0;
}

/* Limits with 0 meaning "none", and the hard cap on a side. */
struct caps {
    uint64_t mw, mh, area;
    double up;          /* max enlargement, >= 1 */
};

static int within(uint64_t ow, uint64_t oh, const struct caps *c)
{
    return ow <= c->mw && oh <= c->mh && ow * oh <= c->area;
}

/*
 * Largest size of aspect (bw, bh) at most `scale` times it that fits the
 * limits c (each side at least 1).
 */
static void fit(uint64_t bw, uint64_t bh, double scale, const struct caps *c,
                uint64_t *ow, uint64_t *oh)
{
    double s = scale;
    if ((double)c->mw / (double)bw < s)
        s = (double)c->mw / (double)bw;
    if ((double)c->mh / (double)bh < s)
        s = (double)c->mh / (double)bh;
    double a = sqrt((double)c->area / ((double)bw * (double)bh));
    if (a < s)
        s = a;
    uint64_t w, h;
    if (s == 1.0) {
        w = bw;
        h = bh;
    } else {
        /* 1e-9 absorbs s * bw landing a hair below an integer */
        double fw = floor((double)bw * s + 1e-9);
        double fh = floor((double)bh * s + 1e-9);
        w = fw < 1 ? 1 : (uint64_t)fw;
        h = fh < 1 ? 1 : (uint64_t)fh;
    }
    if (w > c->mw)
        w = c->mw;
    if (h > c->mh)
        h = c->mh;
    /* floating point may leave the area a pixel row over: trim the longer
     * side until it fits (a few steps at most) */
    while (w * h > c->area && (w > 1 || h > 1)) {
        if (w >= h)
            w--;
        else
            h--;
    }
    *ow = w;
    *oh = h;
}

/* The limits as caps: 0 means none, sides stop at GV_MAX_DIM, and the
 * upscaling factor is at least 1 (NaN included) and at most 1e9. */
static void caps_of(const struct iiif_limits *lim, struct caps *c)
{
    c->mw = lim->max_width ? lim->max_width : GV_MAX_DIM;
    c->mh = lim->max_height ? lim->max_height : GV_MAX_DIM;
    if (c->mw > GV_MAX_DIM)
        c->mw = GV_MAX_DIM;
    if (c->mh > GV_MAX_DIM)
        c->mh = GV_MAX_DIM;
    c->area = lim->max_area ? lim->max_area : UINT64_MAX;
    c->up = lim->max_upscale >= 1.0 ? lim->max_upscale : 1.0; /* NaN -> 1 */
    if (c->up > 1e9)     /* beyond any side cap; keeps the products finite */
        c->up = 1e9;
}

/* pct:n (the number at [s, e)) of the region rw x rh, each side at
 * least 1; above 100 only with ^ (up). */
static int size_pct(const char *size, const char *s, const char *e, int up,
                    uint32_t rw, uint32_t rh, uint64_t *ow, uint64_t *oh,
                    struct gv_error *err)
{
    char shown[48];
    uint64_t n;
    if (parse_decimal(s, e, &n) != 0)
        return gv_fail(err, GV_EINVAL, "iiif: size \"%s\": pct: needs a "
                       "decimal number of at most %d integer digits",
                       SHOW(size), INT_DIGITS);
    if (n == 0)
        return gv_fail(err, GV_EINVAL, "iiif: size \"%s\": zero size",
                       SHOW(size));
    if (!up && n > 100 * FRAC_ONE)
        return gv_fail(err, GV_EINVAL, "iiif: size \"%s\": above 100%% "
                       "needs ^ to upscale", SHOW(size));
    *ow = mul_div_round(n, rw, 100 * FRAC_ONE);
    *oh = mul_div_round(n, rh, 100 * FRAC_ONE);
    if (*ow == 0)
        *ow = 1;
    if (*oh == 0)
        *oh = 1;
    return 0;
}

/* The "w,h" of the w,  ,h  w,h and !w,h forms at [s, e): v[i] where
 * have[i]; at least one, both for !w,h (bang), none of them zero. */
static int parse_wh(const char *size, const char *s, const char *e, int bang,
                    uint32_t *v, int *have, struct gv_error *err)
{
    char shown[48];
    const char *fs[2], *fe[2];
    v[0] = v[1] = 0;
    if (split(s, e, 2, fs, fe) != 0)
        return gv_fail(err, GV_EINVAL, "iiif: size \"%s\": expected max, "
                       "w,  ,h  w,h  !w,h or pct:n, each optionally after ^",
                       SHOW(size));
    for (int i = 0; i < 2; i++) {
        have[i] = fs[i] != fe[i];
        if (have[i] && parse_uint(fs[i], fe[i], &v[i]) != 0)
            return gv_fail(err, GV_EINVAL, "iiif: size \"%s\": %s is not an "
                           "integer in 0..%u", SHOW(size),
                           i ? "height" : "width", GV_MAX_DIM);
    }
    if (!have[0] && !have[1])
        return gv_fail(err, GV_EINVAL, "iiif: size \"%s\": no width or "
                       "height", SHOW(size));
    if (bang && (!have[0] || !have[1]))
        return gv_fail(err, GV_EINVAL, "iiif: size \"%s\": !w,h needs both "
                       "a width and a height", SHOW(size));
    if ((have[0] && v[0] == 0) || (have[1] && v[1] == 0))
        return gv_fail(err, GV_EINVAL, "iiif: size \"%s\": zero size",
                       SHOW(size));
    return 0;
}

/* !w,h: the largest size of the region's aspect within a w x h box (not
 * above the region's size without ^), shrunk to fit the limits. */
static void size_best_fit(const uint32_t *v, uint32_t rw, uint32_t rh, int up,
                          const struct caps *c, uint64_t *ow, uint64_t *oh)
{
    /* scale = min(w/rw, h/rh): compare w*rh with h*rw exactly */
    uint64_t bw = v[0], bh = v[1];
    if (bw * rh <= bh * rw) {   /* width-limited */
        *ow = bw;
        *oh = mul_div_round(rh, bw, rw);
    } else {
        *oh = bh;
        *ow = mul_div_round(rw, bh, rh);
    }
    if (*ow == 0)
        *ow = 1;
    if (*oh == 0)
        *oh = 1;
    double want = bw * (double)rh <= bh * (double)rw
                      ? (double)bw / rw : (double)bh / rh;
    if (!up && (*ow > rw || *oh > rh)) {
        /* not larger than the region */
        *ow = rw;
        *oh = rh;
    }
    if (!within(*ow, *oh, c)
        || (up && (*ow > rw * c->up || *oh > rh * c->up)))
        fit(rw, rh, want < (up ? c->up : 1.0) ? want : (up ? c->up : 1.0),
            c, ow, oh);
}

/* w,  ,h and w,h: the sides given, the missing one from the aspect ratio
 * (at least 1). */
static void size_exact(const uint32_t *v, const int *have, uint32_t rw,
                       uint32_t rh, uint64_t *ow, uint64_t *oh)
{
    if (have[0] && have[1]) {
        *ow = v[0];
        *oh = v[1];
    } else if (have[0]) {
        *ow = v[0];
        *oh = mul_div_round(rh, v[0], rw);
        if (*oh == 0)
            *oh = 1;
    } else {
        *oh = v[1];
        *ow = mul_div_round(rw, v[1], rh);
        if (*ow == 0)
            *ow = 1;
    }
}

/* A size that names exact pixels: larger than the region only with ^
 * (up) and within the upscaling cap (GV_ELIMIT), and within the limits
 * (GV_ELIMIT). */
static int check_exact(const char *size, uint64_t ow, uint64_t oh, uint32_t rw,
                       uint32_t rh, int up, const struct caps *c,
                       struct gv_error *err)
{
    char shown[48];
    if (ow > rw || oh > rh) {
        if (!up)
            return gv_fail(err, GV_EINVAL, "iiif: size \"%s\": %llux%llu is "
                           "larger than the region (%ux%u); use ^ to "
                           "upscale", SHOW(size), (unsigned long long)ow,
                           (unsigned long long)oh, rw, rh);
        if ((double)ow > rw * c->up || (double)oh > rh * c->up)
            return gv_fail(err, GV_ELIMIT, "iiif: size \"%s\": %llux%llu "
                           "enlarges the region (%ux%u) more than the "
                           "allowed %gx", SHOW(size), (unsigned long long)ow,
                           (unsigned long long)oh, rw, rh, c->up);
    }
    if (!within(ow, oh, c)) {
        char area[40] = ""; /* no maxArea without an area limit */
        if (c->area != UINT64_MAX)
            snprintf(area, sizeof area, ", maxArea %llu", (unsigned long long)c->area);
        return gv_fail(err, GV_ELIMIT, "iiif: size \"%s\": %llux%llu is past "
                       "the limits (maxWidth %llu, maxHeight %llu%s)", SHOW(size),
                       (unsigned long long)ow, (unsigned long long)oh,
                       (unsigned long long)c->mw, (unsigned long long)c->mh, area);
    }
    return 0;
}

/* The size segment for a region of rw x rh: r->out_w, r->out_h.  The
 * "as large as possible" forms (max, !w,h) are fitted to the limits; the
 * exact forms (pct:n, w,  ,h  w,h) are checked against them. */
static int parse_size(const char *size, uint32_t rw, uint32_t rh,
                      const struct iiif_limits *lim, struct gv_render_req *r,
                      struct gv_error *err)
{
    const char *s = size, *e = size + strlen(size);
    struct caps c;
    caps_of(lim, &c);
    int up = *s == '^';
    s += up;
    uint64_t ow = 0, oh = 0;
    if (strcmp(s, "max") == 0) {
        fit(rw, rh, up ? c.up : 1.0, &c, &ow, &oh);
    } else if (strncmp(s, "pct:", 4) == 0) {
        if (size_pct(size, s + 4, e, up, rw, rh, &ow, &oh, err) != 0 ||
            check_exact(size, ow, oh, rw, rh, up, &c, err) != 0)
            return -1;
    } else {
        int bang = *s == '!', have[2];
        uint32_t v[2];
        s += bang;
        if (parse_wh(size, s, e, bang, v, have, err) != 0)
            return -1;
        if (bang) {
            size_best_fit(v, rw, rh, up, &c, &ow, &oh);
        } else {
            size_exact(v, have, rw, rh, &ow, &oh);
            if (check_exact(size, ow, oh, rw, rh, up, &c, err) != 0)
                return -1;
        }
    }
    r->out_w = (uint32_t)ow;
    r->out_h = (uint32_t)oh;
    return 0;
}

static int parse_rotation(const char *rot, struct gv_render_req *r,
                          struct gv_error *err)
{
    char shown[48];
    const char *s = rot, *e = rot + strlen(rot);
    uint64_t v;
    r->mirror = 0;
    if (*s == '!') {
        r->mirror = 1;
        s++;
    }
    if (parse_decimal(s, e, &v) != 0)
        return gv_fail(err, GV_EINVAL, "iiif: rotation \"%s\": expected a "
                       "number of degrees 0..360, optionally after !",
                       SHOW(rot));
    if (v > 360 * FRAC_ONE)
        return gv_fail(err, GV_EINVAL, "iiif: rotation \"%s\": above 360 "
                       "degrees", SHOW(rot));
    if (v % (90 * FRAC_ONE) != 0)
        return gv_fail(err, GV_EFORMAT, "iiif: rotation \"%s\": only "
                       "multiples of 90 degrees are supported", SHOW(rot));
    r->rotation = (int)(v / FRAC_ONE % 360);
    return 0;
}

static int parse_quality_format(const char *qf, struct iiif_request *out,
                                struct gv_error *err)
{
    static const char *const qualities[] = {"default", "color", "gray",
                                            "bitonal"};
    static const enum gv_quality qvals[] = {
        GV_QUALITY_DEFAULT, GV_QUALITY_COLOR, GV_QUALITY_GRAY,
        GV_QUALITY_BITONAL};
    /* in the specification's table (4.5) but not produced here; the
     * formats produced are the image formats of output_format.h */
    static const char *const known[] = {"gif", "jp2", "pdf"};
    char shown[48];
    const char *dot = strchr(qf, '.');
    if (!dot)
        return gv_fail(err, GV_EINVAL, "iiif: quality.format \"%s\": no "
                       "format", SHOW(qf));
    size_t qlen = (size_t)(dot - qf);
    const char *fmt = dot + 1;
    int q = -1;
    for (int i = 0; i < 4; i++)
        if (strlen(qualities[i]) == qlen && memcmp(qf, qualities[i], qlen) == 0)
            q = i;
    if (q < 0)
        return gv_fail(err, GV_EINVAL, "iiif: quality \"%s\": expected "
                       "default, color, gray or bitonal",
                       show(qf, qlen, shown, sizeof shown));
    const struct gv_output_format *f = gv_output_format_image(fmt);
    if (f) {
        out->render.quality = qvals[q];
        snprintf(out->format, sizeof out->format, "%s", f->name);
        return 0;
    }
    for (int i = 0; i < 3; i++)
        if (strcmp(fmt, known[i]) == 0)
            return gv_fail(err, GV_EINVAL, "iiif: format \"%s\" is not "
                           "supported (jpg, png, webp, tif)", fmt);
    return gv_fail(err, GV_EINVAL, "iiif: format \"%s\": expected jpg, png, "
                   "webp or tif", SHOW(fmt));
}

int iiif_parse(const char *region, const char *size, const char *rotation,
               const char *quality_format, uint32_t width, uint32_t height,
               const struct iiif_limits *limits, struct iiif_request *out,
               struct gv_error *err)
{
    struct iiif_request r;
    memset(&r, 0, sizeof r);
    if (width == 0 || height == 0 || width > GV_MAX_DIM
        || height > GV_MAX_DIM)
        return gv_fail(err, GV_EINVAL, "iiif: bad image size %ux%u", width,
                       height);
    /* Parsed in the specification's order, so that the first error in
     * the URI is the one reported. */
    if (parse_region(region, width, height, &r.render, err) != 0
        || parse_size(size, r.render.w, r.render.h, limits, &r.render, err)
               != 0
        || parse_rotation(rotation, &r.render, err) != 0
        || parse_quality_format(quality_format, &r, err) != 0)
        return -1;
    r.render.max_decode_pixels = 0; /* the caller's policy */
    *out = r;
    return 0;
}
