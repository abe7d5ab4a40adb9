/*
 * window.c - the display window (window.h): its text, parsed strictly,
 * and its lookup table.
 *
 * The table is the definition.  Entry v of channel window (B, W, G) is 0
 * up to B, 255 from W, and between them floor(255 * p + 0.500000001)
 * with t = (v - B) / (W - B) and p = t when G is 1, else pow(t, 1000 /
 * Gmilli): IEEE double, each operation once and in this order, as
 * client/web/window.js does it.  The constant above a half rounds exact
 * ties up (t = 1/2 at gamma 1 gives 128) whatever the last bit of pow,
 * so that the C library's pow and the browser's Math.pow, which may
 * differ in their last bit, give the same byte; a value closer than
 * 1e-9 to a half without being one would need integers far past 16 bits.
 */
#include "render/window.h"
#include "store/store_meta.h"

#include <math.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

/* Decimal digits at *p into *v, at most max; advances *p.  0, -1 when
 * there are none, or -2 when they are past max. */
static int parse_int(const char **p, uint32_t max, uint32_t *v)
{
    const char *s = *p;
    uint64_t x = 0;
    if (*s < '0' || *s > '9')
        return -1;
    while (*s >= '0' && *s <= '9') {
        x = x * 10 + (uint64_t)(*s - '0');
        if (x > max)
            return -2;
        s++;
    }
    *p = s;
    *v = (uint32_t)x;
    return 0;
}

/* A gamma, "D[.D[D[D]]]", into thousandths.  0 or -1. */
static int parse_gamma(const char **p, uint32_t *milli)
{
    uint32_t whole;
    if (parse_int(p, GV_WINDOW_GAMMA_MAX / 1000, &whole) < 0)
        return -1;
    uint32_t frac = 0, scale = 100;
    const char *s = *p;
    if (*s == '.') {
        s++;
        if (*s < '0' || *s > '9')
            return -1;
        for (int i = 0; *s >= '0' && *s <= '9'; i++, s++) {
            if (i == 3)
                return -1;
            frac += (uint32_t)(*s - '0') * scale;
            scale /= 10;
        }
    }
    *p = s;
    *milli = whole * 1000 + frac;
    return *milli >= GV_WINDOW_GAMMA_MIN && *milli <= GV_WINDOW_GAMMA_MAX ? 0 : -1;
}

int gv_window_parse(const char *s, uint32_t max, struct gv_window *w,
                    struct gv_error *err)
{
    memset(w, 0, sizeof *w);
    size_t len = strnlen(s, GV_WINDOW_MAX_TEXT + 1);
    if (len > GV_WINDOW_MAX_TEXT)
        return gv_fail(err, GV_EINVAL, "window: longer than %d bytes",
                       GV_WINDOW_MAX_TEXT);
    const char *p = s;
    for (int n = 0;; n++) {
        if (n == GV_WINDOW_MAX_CHANNELS) {
            memset(w, 0, sizeof *w);
            return gv_fail(err, GV_EINVAL, "window: more than %d channels",
                           GV_WINDOW_MAX_CHANNELS);
        }
        struct gv_window_channel *c = &w->ch[n];
        c->gamma_milli = 1000;
        int rb = 0, rw = 0;
        if ((rb = parse_int(&p, max, &c->black)) < 0 || *p++ != ','
            || (rw = parse_int(&p, max, &c->white)) < 0
            || (*p == ',' && (p++, parse_gamma(&p, &c->gamma_milli) < 0))
            || (*p != ';' && *p != '\0')) {
            memset(w, 0, sizeof *w);
            if (rb == -2 || rw == -2)
                return gv_fail(err, GV_EINVAL, "window: channel %d: a point "
                               "past %u", n + 1, max);
            return gv_fail(err, GV_EINVAL, "window: channel %d: want B,W[,G]: "
                           "integers B < W, and a gamma G from 0.1 to 10 with "
                           "at most three decimals", n + 1);
        }
        if (c->black >= c->white) {
            const uint32_t b = c->black, wh = c->white;
            memset(w, 0, sizeof *w);
            return gv_fail(err, GV_EINVAL, "window: channel %d: black %u is "
                           "not below white %u", n + 1, b, wh);
        }
        w->count = n + 1;
        if (*p == '\0')
            return 0;
        p++;       /* ';' */
    }
}

int gv_window_format(const struct gv_window *w, char *buf, size_t size)
{
    int len = 0;
    if (size)
        buf[0] = '\0';
    for (int i = 0; i < w->count; i++) {
        const struct gv_window_channel *c = &w->ch[i];
        size_t at = (size_t)len < size ? (size_t)len : size;
        int k = snprintf(buf + at, size - at, "%s%u,%u,%u.%03u",
                         i ? ";" : "", c->black, c->white,
                         c->gamma_milli / 1000, c->gamma_milli % 1000);
        if (k < 0)
            return k;
        len += k;
    }
    return len;
}

const struct gv_window_channel *gv_window_of(const struct gv_window *w, int c)
{
    return &w->ch[w->count == 1 ? 0 : c];
}

void gv_window_table(const struct gv_window_channel *c, uint32_t max,
                     uint8_t *table)
{
    const double range = (double)c->white - (double)c->black;
    const double e = 1000.0 / (double)c->gamma_milli;
    for (uint32_t v = 0; v <= max; v++) {
        if (v <= c->black) {
            table[v] = 0;
            continue;
        }
        if (v >= c->white) {
            table[v] = 255;
            continue;
        }
        double t = ((double)v - (double)c->black) / range;
        double p = c->gamma_milli == 1000 ? t : pow(t, e);
        double y = floor(255.0 * p + 0.500000001);
        table[v] = y >= 255.0 ? 255 : y <= 0.0 ? 0 : (uint8_t)y;
    }
}

void gv_window_table8(const struct gv_window_channel *c, uint8_t table[256])
{
    gv_window_table(c, 255, table);
}

int gv_window_check_max(const struct gv_window *w, uint32_t max,
                        struct gv_error *err)
{
    for (int k = 0; k < w->count; k++)
        if (w->ch[k].white > max)
            return gv_fail(err, GV_EINVAL, "window: white point %u is past "
                           "this image's largest sample, %u", w->ch[k].white,
                           max);
    return 0;
}

int gv_window_apply8(const struct gv_window *w, uint8_t *pix, size_t n,
                     int channels, struct gv_error *err)
{
    if (channels < 1 || channels > GV_WINDOW_MAX_CHANNELS
        || (w->count != 1 && w->count != channels))
        return gv_fail(err, GV_EINVAL, "window: %d windows for an image of "
                       "%d channels (give one, or one per channel)",
                       w->count, channels);
    uint8_t table[GV_WINDOW_MAX_CHANNELS][256];
    for (int c = 0; c < channels; c++)
        gv_window_table8(gv_window_of(w, c), table[c]);
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < channels; c++, pix++)
            *pix = table[c][*pix];
    return 0;
}

int gv_window_from_meta(const char *json, uint32_t max, int channels,
                        struct gv_window *w, struct gv_error *err)
{
    char text[GV_WINDOW_MAX_TEXT + 1];
    memset(w, 0, sizeof *w);
    struct gv_error why = {0};
    int rc = gv_meta_get_string(json, GV_WINDOW_META_KEY, text, sizeof text, &why);
    if (rc < 0)
        return gv_fail(err, GV_ECORRUPT, "window: %s", why.text);
    if (rc == 0)
        return 0;
    if (gv_window_parse(text, max, w, err) < 0)
        rc = -1;
    else if (w->count != 1 && w->count != channels)
        rc = gv_fail(err, GV_ECORRUPT, "window: metadata %s has %d windows "
                     "for an image of %d channels", GV_WINDOW_META_KEY,
                     w->count, channels);
    if (rc < 0)
        memset(w, 0, sizeof *w);
    return rc;
}

char *gv_window_meta_set(const char *json, const struct gv_window *w,
                         struct gv_error *err)
{
    char text[GV_WINDOW_MAX_CHANNELS * 32];
    gv_window_format(w, text, sizeof text);
    return gv_meta_set_string(json, GV_WINDOW_META_KEY, text, err);
}

/* The 0.5 % and 99.5 % points of histogram h (max + 1 bins, n samples):
 * white above black, within 0 .. max. */
static void auto_points(const size_t *h, uint32_t max, size_t n, uint32_t *black,
                        uint32_t *white)
{
    const double low = (double)n * 0.005, high = (double)n * 0.995;
    uint32_t lo = 0, hi = max;
    size_t acc = 0;
    for (uint32_t v = 0; v <= max; v++)
        if ((double)(acc += h[v]) > low) {
            lo = v;
            break;
        }
    acc = 0;
    for (uint32_t v = 0; v <= max; v++)
        if ((double)(acc += h[v]) >= high) {
            hi = v;
            break;
        }
    if (hi <= lo) {
        if (lo >= max)
            lo = max - 1;
        hi = lo + 1;
    }
    *black = lo;
    *white = hi;
}

/* One window for every channel of w when linked (or for one channel):
 * the lowest black and the highest white. */
static void auto_link(struct gv_window *w, int channels, int linked)
{
    w->count = channels;
    if (!linked && channels > 1)
        return;
    for (int k = 1; k < channels; k++) {
        if (w->ch[k].black < w->ch[0].black)
            w->ch[0].black = w->ch[k].black;
        if (w->ch[k].white > w->ch[0].white)
            w->ch[0].white = w->ch[k].white;
    }
    w->count = 1;
}

void gv_window_auto8(const uint8_t *px, size_t n, int channels, int linked,
                     uint32_t gamma_milli, struct gv_window *w)
{
    memset(w, 0, sizeof *w);
    if (channels < 1 || channels > GV_WINDOW_MAX_CHANNELS)
        return;
    for (int k = 0; k < channels; k++) {
        size_t h[256] = {0};
        for (size_t i = 0; i < n; i++)
            h[px[i * (size_t)channels + (size_t)k]]++;
        w->ch[k].gamma_milli = gamma_milli;
        auto_points(h, 255, n, &w->ch[k].black, &w->ch[k].white);
    }
    auto_link(w, channels, linked);
}

int gv_window_auto16(const uint16_t *px, size_t n, int channels, int linked,
                     uint32_t gamma_milli, struct gv_window *w)
{
    memset(w, 0, sizeof *w);
    if (channels < 1 || channels > GV_WINDOW_MAX_CHANNELS)
        return 0;
    size_t *h = malloc(sizeof *h * 65536);
    if (!h)
        return -1;
    for (int k = 0; k < channels; k++) {
        memset(h, 0, sizeof *h * 65536);
        for (size_t i = 0; i < n; i++)
            h[px[i * (size_t)channels + (size_t)k]]++;
        w->ch[k].gamma_milli = gamma_milli;
        auto_points(h, 65535, n, &w->ch[k].black, &w->ch[k].white);
    }
    free(h);
    auto_link(w, channels, linked);
    return 0;
}
