/*
 * samples_region.c - the display of sample stores (see samples_region.h):
 * the window's tables on codes, then gray or the additive colours.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/samples_region.h"
#include "store/store_meta.h"

static const uint8_t colours[GV_SAMPLES_MAX_CHANNELS][3] = {
    {255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 0, 255},
    {0, 255, 255}, {255, 255, 0}, {255, 128, 0}, {255, 255, 255},
};

void gv_samples_colour(const struct gv_colours *c, int k, uint8_t rgb[3])
{
    memcpy(rgb, c && c->count ? c->rgb[k & 7] : colours[k & 7], 3);
}

static int hex(char ch)
{
    return ch >= '0' && ch <= '9' ? ch - '0'
         : ch >= 'a' && ch <= 'f' ? ch - 'a' + 10
         : ch >= 'A' && ch <= 'F' ? ch - 'A' + 10 : -1;
}

/* gv_colours_parse into *c, which a failure may leave half filled. */
static int colours_parse(const char *s, struct gv_colours *c, struct gv_error *err)
{
    if (strlen(s) > GV_COLOURS_MAX_TEXT)
        return gv_fail(err, GV_EINVAL, "colours: longer than %d bytes",
                       GV_COLOURS_MAX_TEXT);
    for (;;) {
        if (c->count == GV_SAMPLES_MAX_CHANNELS)
            return gv_fail(err, GV_EINVAL, "colours: more than %d",
                           GV_SAMPLES_MAX_CHANNELS);
        for (int j = 0; j < 3; j++) {
            int hi = hex(s[0]), lo = hi < 0 ? -1 : hex(s[1]);
            if (hi < 0 || lo < 0)
                return gv_fail(err, GV_EINVAL, "colours: colour %d: want "
                               "RRGGBB in hexadecimal, ';' between them",
                               c->count + 1);
            c->rgb[c->count][j] = (uint8_t)(hi * 16 + lo);
            s += 2;
        }
        c->count++;
        if (*s == '\0')
            return 0;
        if (*s++ != ';')
            return gv_fail(err, GV_EINVAL, "colours: colour %d: want RRGGBB "
                           "in hexadecimal, ';' between them", c->count);
    }
}

int gv_colours_parse(const char *s, struct gv_colours *c, struct gv_error *err)
{
    memset(c, 0, sizeof *c);
    if (colours_parse(s, c, err) < 0) {
        memset(c, 0, sizeof *c);
        return -1;
    }
    return 0;
}

int gv_colours_format(const struct gv_colours *c, char *buf, size_t size)
{
    int n = 0;
    if (size)
        buf[0] = '\0';
    for (int k = 0; k < c->count; k++)
        n += snprintf(buf + (n < (int)size ? n : (int)size),
                      (size_t)n < size ? size - (size_t)n : 0, "%s%02x%02x%02x",
                      k ? ";" : "", c->rgb[k][0], c->rgb[k][1], c->rgb[k][2]);
    return n;
}

int gv_colours_check(const struct gv_colours *c, int channels,
                     struct gv_error *err)
{
    if (c->count == 0)
        return 0;
    if (channels < 2)
        return gv_fail(err, GV_EINVAL, "colours: a one-channel image is "
                       "shown in gray");
    if (c->count != channels)
        return gv_fail(err, GV_EINVAL, "colours: %d colours for an image of "
                       "%d channels (give one per channel)", c->count, channels);
    return 0;
}

int gv_display_check(const struct gv_header *h, const struct gv_window *w,
                     const struct gv_colours *c, struct gv_error *err)
{
    if (h->kind != GV_KIND_SAMPLES && gv_window_check_max(w, 255, err) < 0)
        return -1;
    if (w->count > 1 && w->count != h->channels)
        return gv_fail(err, GV_EINVAL, "window: %d windows for an image of "
                       "%d channels (give one, or one per channel)",
                       w->count, h->channels);
    if (c->count && h->kind != GV_KIND_SAMPLES)
        return gv_fail(err, GV_EINVAL, "colours: for sample stores only");
    return gv_colours_check(c, h->channels, err);
}

void gv_display_key(const struct gv_window *w, const struct gv_colours *c,
                    char buf[GV_DISPLAY_KEY_MAX])
{
    size_t at = 0;
    buf[0] = '\0';
    if (w->count) {
        memcpy(buf, " w", 3);
        gv_window_format(w, buf + 2, GV_DISPLAY_KEY_MAX - 2);
        at = strlen(buf);
    }
    if (c->count) {
        memcpy(buf + at, " c", 3);
        gv_colours_format(c, buf + at + 2, GV_DISPLAY_KEY_MAX - at - 2);
    }
}

int gv_colours_from_meta(const char *json, int channels, struct gv_colours *c,
                         struct gv_error *err)
{
    char text[GV_COLOURS_MAX_TEXT + 1];
    memset(c, 0, sizeof *c);
    struct gv_error why = {0};
    int rc = gv_meta_get_string(json, GV_COLOURS_META_KEY, text, sizeof text, &why);
    if (rc < 0)
        return gv_fail(err, GV_ECORRUPT, "colours: %s", why.text);
    if (rc == 0)
        return 0;
    if (gv_colours_parse(text, c, &why) < 0 || gv_colours_check(c, channels, &why) < 0) {
        memset(c, 0, sizeof *c);
        return gv_fail(err, GV_ECORRUPT, "colours: metadata %s: %s",
                       GV_COLOURS_META_KEY, why.text);
    }
    return 1;
}

char *gv_colours_meta_set(const char *json, const struct gv_colours *c,
                          struct gv_error *err)
{
    char text[GV_COLOURS_MAX_TEXT];
    gv_colours_format(c, text, sizeof text);
    return gv_meta_set_string(json, GV_COLOURS_META_KEY, text, err);
}

int gv_display_channels(const struct gv_header *h)
{
    if (h->kind == GV_KIND_HEIGHT)
        return 1;
    if (h->kind == GV_KIND_SAMPLES)
        return h->channels == 1 ? 1 : 3;
    return h->channels;
}

void gv_samples_default_window(const struct gv_header *h, struct gv_window *w)
{
    memset(w, 0, sizeof *w);
    w->count = 1;
    uint32_t lo = h->samples_lo, hi = h->samples_hi;
    if (hi <= lo) {
        if (lo == 65535)
            lo--;
        hi = lo + 1;
    }
    w->ch[0].black = lo;
    w->ch[0].white = hi;
    w->ch[0].gamma_milli = 1000;
}

int gv_samples_display(const uint16_t *codes, size_t n, int c,
                       const struct gv_window *w, const struct gv_colours *col,
                       uint8_t *tables, uint8_t *out, struct gv_error *err)
{
    if (c < 1 || c > GV_SAMPLES_MAX_CHANNELS || (w->count != 1 && w->count != c))
        return gv_fail(err, GV_EINVAL, "window: %d windows for an image of "
                       "%d channels (give one, or one per channel)",
                       w->count, c);
    if (col && gv_colours_check(col, c, err) < 0)
        return -1;
    uint8_t rgb[GV_SAMPLES_MAX_CHANNELS][3];
    for (int k = 0; k < c; k++)
        gv_samples_colour(col, k, rgb[k]);
    for (int k = 0; k < c; k++)
        if (k < w->count)
            gv_window_table(gv_window_of(w, k), 65535, tables + (size_t)k * 65536);
        else   /* one window for all: the same table */
            memcpy(tables + (size_t)k * 65536, tables, 65536);
    if (c == 1) {
        for (size_t i = 0; i < n; i++)
            out[i] = tables[codes[i]];
        return 0;
    }
    for (size_t i = 0; i < n; i++) {
        uint32_t acc[3] = {0, 0, 0};
        for (int k = 0; k < c; k++) {
            uint32_t t = tables[(size_t)k * 65536 + codes[i * (size_t)c + (size_t)k]];
            for (int j = 0; j < 3; j++)
                acc[j] += t * rgb[k][j];
        }
        for (int j = 0; j < 3; j++) {
            uint32_t v = (acc[j] + 127) / 255;
            out[3 * i + (size_t)j] = (uint8_t)(v > 255 ? 255 : v);
        }
    }
    return 0;
}

int gv_samples_region8(struct gv_decoder *d, int level, uint32_t x,
                       uint32_t y, uint32_t w, uint32_t h,
                       const struct gv_window *win,
                       const struct gv_colours *col, uint8_t *out,
                       struct gv_error *err)
{
    const struct gv_header *hd = &gv_store_info(gv_decoder_store(d))->header;
    if (hd->kind != GV_KIND_SAMPLES)
        return gv_fail(err, GV_EINVAL, "samples: not a sample store");
    const int c = hd->channels;
    const size_t n = (size_t)w * h;
    if (n > SIZE_MAX / (2 * (size_t)c))
        return gv_fail(err, GV_ELIMIT, "samples: region too large");
    struct gv_window dw;
    if (!win || win->count == 0) {
        struct gv_error ignored = {0};
        if (win || gv_window_from_meta(gv_store_meta(gv_decoder_store(d)),
                                       65535, c, &dw, &ignored) != 1)
            gv_samples_default_window(hd, &dw);
        win = &dw;
    }
    struct gv_colours dc;
    if (!col) {   /* the store's, else the palette */
        struct gv_error ignored = {0};
        gv_colours_from_meta(gv_store_meta(gv_decoder_store(d)), c, &dc, &ignored);
        col = &dc;
    }
    uint16_t *codes = malloc(n * (size_t)c * sizeof *codes);
    uint8_t *tables = malloc((size_t)c * 65536);
    int rc = -1;
    if (!codes || !tables)
        gv_fail(err, GV_ENOMEM, "samples: out of memory for a region");
    else if (gv_decoder_copy_region(d, "samples", level, x, y, w, h, codes,
                                    err) == 0)
        rc = gv_samples_display(codes, n, c, win, col, tables, out, err);
    free(codes);
    free(tables);
    return rc;
}
