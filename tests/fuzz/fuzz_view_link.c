/*
 * fuzz_view_link.c - libFuzzer target for the browser links the native
 * viewer reads (`gigaview view --view LINK`, client/view/view_geom.c):
 * vg_parse (the view and the image id) and vg_hash_window (the display
 * window, percent-decoded).
 *
 * The input is the link text up to its first NUL.  The results must keep
 * view_geom.h's contracts: vg_parse returns 0 with a finite view and a
 * terminated image id, or -1; vg_hash_window returns 1 with a terminated
 * text that fits, 0 or -1 with "" (a smaller buffer never turns a -1
 * into a 1, and where both fit the texts agree); and a link the viewer
 * writes back (vg_format_hash) from what was read reads again as the same
 * image and window.  Anything else aborts.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "view_geom.h"

#define MAX_TEXT (1u << 16)

/* A window or image text vg_format_hash writes back unchanged: no byte
 * that a link would have to escape other than the ',' and ';' it does. */
static int plain(const char *s)
{
    for (; *s; s++)
        if (*s == '&' || *s == '#' || *s == '%' || *s == '+' || *s == '=' ||
            (unsigned char)*s <= ' ')
            return 0;
    return 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > MAX_TEXT)
        return 0;
    char *s = malloc(size + 1);
    if (!s)
        return 0;
    memcpy(s, data, size);
    s[size] = 0;

    struct vg_view v = {0, 0, 0, 0};
    char image[64];
    memset(image, 'x', sizeof image);
    const int pr = vg_parse(s, &v, image, sizeof image);
    if (pr != 0 && pr != -1)
        abort();
    if (pr == 0 && (!isfinite(v.cx) || !isfinite(v.cy) || !isfinite(v.zoom) ||
                    !isfinite(v.rot) || !memchr(image, 0, sizeof image)))
        abort();

    char big[512], small[8];
    const int wb = vg_hash_window(s, big, sizeof big);
    const int ws = vg_hash_window(s, small, sizeof small);
    if (wb < -1 || wb > 1 || ws < -1 || ws > 1)
        abort();
    if ((wb != 1 && big[0]) || (ws != 1 && small[0]))
        abort();   /* "" unless a window was read */
    if (wb == 1 && strlen(big) >= sizeof big)
        abort();
    if (ws == 1 && (wb != 1 || strcmp(small, big)))
        abort();   /* what fits the small buffer is the same text */
    if (wb == 0 && ws != 0)
        abort();   /* no window key is the same in every buffer */

    /* Written back as the viewer's link, it reads as the same (an empty
     * window, which the viewer takes as none given, is left out). */
    if (pr == 0 && wb == 1 && big[0] && plain(image) && plain(big) &&
        strlen(big) < 200) {
        char link[1024], again[512], img2[64];
        struct vg_view v2;
        vg_format_hash(image, &v, big, link, sizeof link);
        if (vg_hash_window(link, again, sizeof again) != 1 || strcmp(again, big))
            abort();
        if (*image && (vg_parse(link, &v2, img2, sizeof img2) != 0 ||
                       strcmp(img2, image)))
            abort();
    }
    free(s);
    return 0;
}
