/*
 * fuzz_store_meta.c - libFuzzer target for the metadata section of an
 * image store (lib/store/store_meta.c, docs/FORMAT.md section 6).
 *
 * The input is a whole section as a reader finds it after its CRC:
 * "GVMD", version, length, JSON.  gv_meta_unpack must either refuse it
 * with a "store: metadata" message and GV_ECORRUPT (GV_ENOMEM aside), or
 * accept it; an accepted section of the current version must hold at
 * most GV_META_MAX_JSON bytes of JSON, pass gv_meta_check, and pack back
 * to the very same bytes (gv_meta_pack), so that writer and reader agree
 * on every rule and the size limit is enforced on both sides.  An
 * accepted section's default display window (display.window,
 * render/window.h) is read as a reader does: refused with a "window:"
 * message, or a window of 1 or 3 channels whose canonical text parses
 * back to the same window; its channel colours (display.colours,
 * render/samples_region.h) likewise: refused with a "colours:" message,
 * or four colours whose canonical text parses back to the same.  Input
 * is also tried as bare JSON through gv_meta_check.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "render/samples_region.h"
#include "render/window.h"
#include "store/store_meta.h"

#define MAX_INPUT (GV_META_MAX_SECTION + 4096)   /* just past the limit */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > MAX_INPUT)
        return 0;
    struct gv_error err = {0};
    char *json = NULL;
    int rc = gv_meta_unpack(data, size, &json, &err);
    if (rc < 0) {
        if (json || (err.code != GV_ECORRUPT && err.code != GV_ENOMEM) ||
            strncmp(err.text, "store: metadata", 15) != 0) {
            fprintf(stderr, "refusal without its code or message: %d %s\n",
                    err.code, err.text);
            abort();
        }
    } else if (json) {
        size_t n = strlen(json);
        uint8_t *packed = NULL;
        size_t plen = 0;
        if (n > GV_META_MAX_JSON || n + GV_META_HEAD != size ||
            gv_meta_check(json, n, &err) < 0 ||
            gv_meta_pack(json, n, &packed, &plen, &err) < 0 || plen != size ||
            memcmp(packed, data, size) != 0) {
            fprintf(stderr, "accepted section does not round-trip: %s\n",
                    err.text);
            abort();
        }
        free(packed);
        struct gv_window w, back;
        char text[GV_WINDOW_MAX_CHANNELS * 32];
        gv_error_clear(&err);
        int wrc = gv_window_from_meta(json, 255, 3, &w, &err);
        if ((wrc < 0 && (w.count != 0 || strncmp(err.text, "window:", 7) != 0)) ||
            (wrc == 0 && w.count != 0) ||
            (wrc == 1 && ((w.count != 1 && w.count != 3) ||
                          gv_window_format(&w, text, sizeof text) >= (int)sizeof text ||
                          gv_window_parse(text, 255, &back, &err) < 0 ||
                          memcmp(&w, &back, sizeof w) != 0))) {
            fprintf(stderr, "default window misread: %d %s\n", wrc, err.text);
            abort();
        }
        struct gv_colours col, cback;
        char ctext[GV_COLOURS_MAX_TEXT + 1];
        gv_error_clear(&err);
        int crc = gv_colours_from_meta(json, 4, &col, &err);
        if ((crc < 0 && (col.count != 0 || strncmp(err.text, "colours:", 8) != 0)) ||
            (crc == 0 && col.count != 0) ||
            (crc == 1 && (col.count != 4 ||
                          gv_colours_format(&col, ctext, sizeof ctext) >= (int)sizeof ctext ||
                          gv_colours_parse(ctext, &cback, &err) < 0 ||
                          memcmp(&col, &cback, sizeof col) != 0))) {
            fprintf(stderr, "colours misread: %d %s\n", crc, err.text);
            abort();
        }
        free(json);
    }
    gv_error_clear(&err);
    if (gv_meta_check((const char *)data, size, &err) == 0 &&
        size > GV_META_MAX_JSON) {
        fprintf(stderr, "check accepted %zu bytes\n", size);
        abort();
    }
    return 0;
}
