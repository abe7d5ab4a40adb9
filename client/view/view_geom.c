/*
 * view_geom.c - view geometry and the browser's view hash (view_geom.h),
 * statement for statement client/web/view.js.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "view_geom.h"

#define DEG (M_PI / 180.0)

void vg_screen_to_image(const struct vg_view *v, double w, double h, double sx,
                        double sy, double *px, double *py)
{
    const double s = exp2(v->zoom), th = v->rot * DEG;
    const double cs = cos(th), sn = -sin(th);
    const double dx = (sx - w / 2) * s, dy = (sy - h / 2) * s;
    *px = v->cx + dx * cs - dy * sn;
    *py = v->cy + dx * sn + dy * cs;
}

void vg_image_to_screen(const struct vg_view *v, double w, double h, double px,
                        double py, double *sx, double *sy)
{
    const double s = exp2(-v->zoom), th = v->rot * DEG;
    const double cs = cos(th), sn = sin(th);
    const double dx = px - v->cx, dy = py - v->cy;
    *sx = w / 2 + (dx * cs - dy * sn) * s;
    *sy = h / 2 + (dx * sn + dy * cs) * s;
}

struct vg_view vg_anchored(const struct vg_view *v, double w, double h, double px,
                           double py, double sx, double sy)
{
    struct vg_view o = *v, z = *v;
    double qx, qy;
    z.cx = z.cy = 0;
    vg_screen_to_image(&z, w, h, sx, sy, &qx, &qy);
    o.cx = px - qx;
    o.cy = py - qy;
    return o;
}

struct vg_view vg_home(double iw, double ih, double w, double h)
{
    double z = log2(fmax(iw / fmax(1, w), ih / fmax(1, h)));
    return (struct vg_view){iw / 2, ih / 2, z, 0};
}

double vg_norm_rot(double r)
{
    r = fmod(fmod(r, 360) + 360, 360);
    return r > 180 ? r - 360 : r;
}

struct vg_view vg_clamp(const struct vg_view *v, double iw, double ih, double w,
                        double h)
{
    double home = vg_home(iw, ih, w, h).zoom;
    struct vg_view o;
    o.cx = fmin(fmax(v->cx, 0), iw);
    o.cy = fmin(fmax(v->cy, 0), ih);
    o.zoom = fmin(fmax(v->zoom, -6), fmax(home + 2, 0));
    o.rot = vg_norm_rot(v->rot);
    return o;
}

/* A finite number filling s[0..n) exactly. */
static int number(const char *s, size_t n, double *out)
{
    char buf[64], *end;
    if (n == 0 || n >= sizeof buf || s[0] == ' ' || (s[0] >= '\t' && s[0] <= '\r'))
        return -1;                      /* strtod would skip the space */
    memcpy(buf, s, n);
    buf[n] = 0;
    double x = strtod(buf, &end);
    if (*end || !isfinite(x))
        return -1;
    *out = x;
    return 0;
}

/* "CX,CY,ZOOM[,ROT]". */
static int parse_list(const char *s, struct vg_view *v)
{
    double x[4] = {0, 0, 0, 0};
    int n = 0;
    for (const char *p = s;; n++) {
        size_t len = strcspn(p, ",");
        if (n == 4 || number(p, len, &x[n]) < 0)
            return -1;
        p += len;
        if (!*p) {
            n++;
            break;
        }
        p++;
    }
    if (n < 3 || fabs(x[2]) > 64)
        return -1;
    *v = (struct vg_view){x[0], x[1], x[2], x[3]};
    return 0;
}

/* The hash after its '#'. */
static int parse_hash(const char *s, struct vg_view *v, char *image, size_t cap)
{
    struct vg_view o = {0, 0, 0, 0};
    int have = 0;
    const char *id = "";
    size_t idlen = 0;
    for (const char *p = s; *p;) {
        size_t len = strcspn(p, "&");
        const char *eq = memchr(p, '=', len);
        if (eq) {
            size_t kl = (size_t)(eq - p), vl = len - kl - 1;
            double *f = NULL;
            int bit = 0;
            if (kl == 1 && *p == 'x') f = &o.cx, bit = 1;
            else if (kl == 1 && *p == 'y') f = &o.cy, bit = 2;
            else if (kl == 1 && *p == 'z') f = &o.zoom, bit = 4;
            else if (kl == 1 && *p == 'r') f = &o.rot, bit = 8;
            else if (kl == 5 && !memcmp(p, "image", 5)) id = eq + 1, idlen = vl;
            if (f) {
                if (number(eq + 1, vl, f) < 0)
                    return -1;
                have |= bit;
            }
        }
        p += len;
        if (*p)
            p++;
    }
    if ((have & 7) != 7 || fabs(o.zoom) > 64 || (image && idlen >= cap))
        return -1;
    *v = o;
    if (image) {
        memcpy(image, id, idlen);
        image[idlen] = 0;
    }
    return 0;
}

int vg_parse(const char *s, struct vg_view *v, char *image, size_t cap)
{
    const char *hash = strchr(s, '#');
    if (hash)
        return parse_hash(hash + 1, v, image, cap);
    if (parse_list(s, v) < 0)
        return -1;
    if (image && cap)
        image[0] = 0;
    return 0;
}

/* x with `d` decimals, trailing zeros (and a bare point) dropped: what
 * String(+x.toFixed(d)) gives in JavaScript. */
static void fmt(char *out, size_t cap, double x, int d)
{
    snprintf(out, cap, "%.*f", d, x);
    char *dot = strchr(out, '.');
    if (dot) {
        char *e = out + strlen(out);
        while (e > dot && (e[-1] == '0'))
            *--e = 0;
        if (e[-1] == '.')
            e[-1] = 0;
    }
    if (!strcmp(out, "-0"))
        snprintf(out, cap, "0");
}

static int hexval(char c)
{
    return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 :
           c >= 'A' && c <= 'F' ? c - 'A' + 10 : -1;
}

/* Percent-decode s[0..n) into out (cap bytes): 0, or -1. */
static int unescape(const char *s, size_t n, char *out, size_t cap)
{
    size_t o = 0;
    for (size_t i = 0; i < n; i++) {
        char c = s[i];
        if (c == '+') {
            c = ' ';
        } else if (c == '%') {
            if (i + 2 >= n || hexval(s[i + 1]) < 0 || hexval(s[i + 2]) < 0)
                return -1;
            c = (char)(hexval(s[i + 1]) * 16 + hexval(s[i + 2]));
            i += 2;
        }
        if (c == 0 || o + 1 >= cap)
            return -1;
        out[o++] = c;
    }
    out[o] = 0;
    return 0;
}

int vg_hash_window(const char *s, char *out, size_t cap)
{
    const char *hash = strchr(s, '#');
    const char *val = NULL;
    size_t vl = 0;
    if (cap)
        out[0] = 0;
    if (!hash)
        return 0;
    for (const char *p = hash + 1; *p;) {
        size_t len = strcspn(p, "&");
        if (len >= 7 && !memcmp(p, "window=", 7))
            val = p + 7, vl = len - 7;
        p += len;
        if (*p)
            p++;
    }
    if (!val || !cap)
        return val ? -1 : 0;
    if (unescape(val, vl, out, cap) < 0) {
        out[0] = 0;
        return -1;
    }
    return 1;
}

void vg_format_hash(const char *image, const struct vg_view *v,
                    const char *window, char *out, size_t cap)
{
    char x[48], y[48], z[48], r[48];
    fmt(x, sizeof x, v->cx, 2);
    fmt(y, sizeof y, v->cy, 2);
    fmt(z, sizeof z, v->zoom, 4);
    fmt(r, sizeof r, v->rot, 2);
    int n = snprintf(out, cap, "#image=%s&x=%s&y=%s&z=%s&r=%s", image, x, y, z, r);
    if (!window || !*window || n < 0 || (size_t)n + 8 >= cap)
        return;
    size_t o = (size_t)n;
    memcpy(out + o, "&window=", 8);
    o += 8;
    for (const char *p = window; *p && o + 1 < cap; p++) {
        if (*p == ',' || *p == ';') {
            if (o + 4 > cap)
                break;
            o += (size_t)snprintf(out + o, 4, "%%%s", *p == ',' ? "2C" : "3B");
        } else {
            out[o++] = *p;
        }
    }
    out[o] = 0;
}

void vg_scale_bar(double zoom, double mpp, double max_px, double *bar_px,
                  char *label, int cap)
{
    /* Units (level-0 pixels or microns) per window pixel. */
    double per_px = exp2(zoom) * (mpp > 0 ? mpp : 1);
    double most = max_px * per_px;
    double p10 = pow(10, floor(log10(most)));
    double n = most >= 5 * p10 ? 5 * p10 : most >= 2 * p10 ? 2 * p10 : p10;
    *bar_px = n / per_px;
    if (mpp > 0 && n >= 1000)
        snprintf(label, (size_t)cap, "%g MM", n / 1000);
    else
        snprintf(label, (size_t)cap, n >= 1 ? "%.0f %s" : "%g %s", n,
                 mpp > 0 ? "UM" : "PX");
}
