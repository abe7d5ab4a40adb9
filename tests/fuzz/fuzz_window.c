/*
 * fuzz_window.c - libFuzzer target for gv_window_parse (lib/render/window.c),
 * the `window` query parameter of regions and IIIF images, and for
 * gv_colours_parse (lib/render/samples_region.c), their `colours`.
 *
 * The input, cut at 4 KiB and NUL-terminated (the HTTP layer refuses a
 * longer target long before), is parsed for 8-bit and 16-bit sample
 * maxima.  A failure must carry a "window: " message with GV_EINVAL and
 * leave the window empty.  A success must be 1 .. GV_WINDOW_MAX_CHANNELS
 * channels, each black < white <= max and a gamma in range, whose
 * canonical text parses back to the same window; its 8-bit table must be
 * 0 up to black, 255 from white, and never decrease.  The same input as
 * colours: a failure carries "colours: " and GV_EINVAL with no colours, a
 * success 1 .. 8 colours whose canonical text parses back to the same.
 * Anything else aborts.
 */
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "render/samples_region.h"
#include "render/window.h"

#define MAX_TEXT 4096

static void check_one(const char *s, uint32_t max)
{
    struct gv_window w, back;
    struct gv_error err = {0};
    if (gv_window_parse(s, max, &w, &err) != 0) {
        if (err.code != GV_EINVAL || strncmp(err.text, "window: ", 8) != 0
            || w.count != 0)
            abort();
        return;
    }
    if (w.count < 1 || w.count > GV_WINDOW_MAX_CHANNELS)
        abort();
    for (int i = 0; i < w.count; i++) {
        const struct gv_window_channel *c = &w.ch[i];
        if (c->black >= c->white || c->white > max
            || c->gamma_milli < GV_WINDOW_GAMMA_MIN
            || c->gamma_milli > GV_WINDOW_GAMMA_MAX)
            abort();
        uint8_t t[256];
        gv_window_table8(c, t);
        for (uint32_t v = 0; v < 256; v++) {
            if ((v <= c->black && t[v]) || (v >= c->white && t[v] != 255)
                || (v && t[v] < t[v - 1]))
                abort();
        }
    }
    char text[GV_WINDOW_MAX_TEXT + 1];
    int n = gv_window_format(&w, text, sizeof text);
    if (n < 0 || (size_t)n >= sizeof text)
        abort();
    gv_error_clear(&err);
    if (gv_window_parse(text, max, &back, &err) != 0
        || memcmp(&w, &back, sizeof w) != 0)
        abort();
}

static void check_colours(const char *s)
{
    struct gv_colours c, back;
    struct gv_error err = {0};
    if (gv_colours_parse(s, &c, &err) != 0) {
        if (err.code != GV_EINVAL || strncmp(err.text, "colours: ", 9) != 0
            || c.count != 0)
            abort();
        return;
    }
    if (c.count < 1 || c.count > GV_SAMPLES_MAX_CHANNELS)
        abort();
    char text[GV_COLOURS_MAX_TEXT + 1];
    int n = gv_colours_format(&c, text, sizeof text);
    if (n < 0 || (size_t)n >= sizeof text)
        abort();
    gv_error_clear(&err);
    if (gv_colours_parse(text, &back, &err) != 0 || memcmp(&c, &back, sizeof c) != 0)
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static char buf[MAX_TEXT + 1];
    size_t n = size < MAX_TEXT ? size : MAX_TEXT;
    memcpy(buf, data, n);
    buf[n] = '\0';
    check_one(buf, 255);
    check_one(buf, 65535);
    check_colours(buf);
    return 0;
}
