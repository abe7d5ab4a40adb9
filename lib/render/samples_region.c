/*
 * samples_region.c - the display of sample stores (see samples_region.h):
 * the window's tables on codes, then gray or the additive colours.
 */
#include <stdlib.h>
#include <string.h>

#include "render/samples_region.h"

static const uint8_t colours[GV_SAMPLES_MAX_CHANNELS][3] = {
    {255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 0, 255},
    {0, 255, 255}, {255, 255, 0}, {255, 128, 0}, {255, 255, 255},
};

void gv_samples_colour(int c, uint8_t rgb[3])
{
    memcpy(rgb, colours[c & 7], 3);
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
                       const struct gv_window *w, uint8_t *tables,
                       uint8_t *out, struct gv_error *err)
{
    if (c < 1 || c > GV_SAMPLES_MAX_CHANNELS || (w->count != 1 && w->count != c))
        return gv_fail(err, GV_EINVAL, "window: %d windows for an image of "
                       "%d channels (give one, or one per channel)",
                       w->count, c);
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
                acc[j] += t * colours[k][j];
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
                       const struct gv_window *win, uint8_t *out,
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
    uint16_t *codes = malloc(n * (size_t)c * sizeof *codes);
    uint8_t *tables = malloc((size_t)c * 65536);
    int rc = -1;
    if (!codes || !tables)
        gv_fail(err, GV_ENOMEM, "samples: out of memory for a region");
    else if (gv_decoder_copy_region(d, "samples", level, x, y, w, h, codes,
                                    err) == 0)
        rc = gv_samples_display(codes, n, c, win, tables, out, err);
    free(codes);
    free(tables);
    return rc;
}
