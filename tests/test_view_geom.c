/*
 * test_view_geom.c - the native viewer's view geometry and view links
 * (client/view/view_geom.c): the browser's formulas (client/web/view.js), the
 * link round trip, and hostile --view arguments and hashes, which come
 * from the command line and from pasted links.
 */
#include <math.h>
#include <string.h>

#include "util.h"
#include "view_geom.h"

static void geometry(void)
{
    struct vg_view v = {1000, 700, 1, 30}, o;
    double px, py, sx, sy;
    vg_screen_to_image(&v, 640, 480, 100, 50, &px, &py);
    vg_image_to_screen(&v, 640, 480, px, py, &sx, &sy);
    check(fabs(sx - 100) < 1e-9 && fabs(sy - 50) < 1e-9, "image_to_screen inverts");
    vg_screen_to_image(&v, 640, 480, 320, 240, &px, &py);
    check(px == 1000 && py == 700, "the window centre shows the view centre");
    o = vg_anchored(&v, 640, 480, 10, 20, 0, 0);
    vg_screen_to_image(&o, 640, 480, 0, 0, &px, &py);
    check(fabs(px - 10) < 1e-9 && fabs(py - 20) < 1e-9, "anchored keeps the point");
    o = vg_home(3000, 2000, 640, 480);
    check(o.cx == 1500 && o.cy == 1000 && fabs(o.zoom - log2(3000 / 640.0)) < 1e-12,
          "home fits the image");
    check(vg_norm_rot(540) == 180 && vg_norm_rot(-190) == 170, "rotation normalized");
    struct vg_view wild = {-5, 1e9, -100, 725};
    o = vg_clamp(&wild, 3000, 2000, 640, 480);
    check(o.cx == 0 && o.cy == 2000 && o.zoom == -6 && o.rot == 5, "clamp");
}

static void links(void)
{
    struct vg_view v;
    char id[129], out[256];
    check(vg_parse("1500,1000,0", &v, id, sizeof id) == 0 && v.cx == 1500 &&
          v.cy == 1000 && v.zoom == 0 && v.rot == 0 && !id[0], "list of three");
    check(vg_parse("1.5,-2,0.25,30", &v, id, sizeof id) == 0 && v.rot == 30, "list of four");
    check(vg_parse("http://h:1/?renderer=region#image=x&x=1.5&y=2&z=-1&r=15",
                   &v, id, sizeof id) == 0 && !strcmp(id, "x") && v.cx == 1.5 &&
          v.zoom == -1 && v.rot == 15, "a whole link");
    check(vg_parse("#z=1&y=2&x=3&roi=1,2,3,4&filter=f", &v, id, sizeof id) == 0 &&
          v.cx == 3 && !id[0], "keys in any order, others ignored");
    struct vg_view w = {1234.567, 0.001, -0.5, -15.25};
    vg_format_hash("img", &w, NULL, out, sizeof out);
    check_str(out, "#image=img&x=1234.57&y=0&z=-0.5&r=-15.25", "the browser's rounding");
    check(vg_parse(out, &v, id, sizeof id) == 0 && !strcmp(id, "img") &&
          v.cx == 1234.57 && v.zoom == -0.5, "round trip");
    static const char *bad[] = {
        "", ",", "1,2", "1,2,3,4,5", "1,,3", "a,b,c", "1,2,nan", "1,2,inf",
        "1,2,65", "1,2,3 ", " 1,2,3", "#", "#x=1&y=2", "#x=1&y=2&z=", "#x=1&y=2&z=q",
        "#x=1&y=2&z=1e999", "#x=1&y=2&z=100", "1e999,2,3",
        "#x=1&y=2&z=0&image=0123456789012345678901234567890123456789012345678901234567890123"
        "4567890123456789012345678901234567890123456789012345678901234567890123456789",
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        struct vg_view keep = {7, 8, 9, 10};
        v = keep;
        strcpy(id, "unchanged");
        check(vg_parse(bad[i], &v, id, sizeof id) < 0 && !memcmp(&v, &keep, sizeof v) &&
                  !strcmp(id, "unchanged"), "refused, nothing changed: '%.40s'", bad[i]);
    }
    char small[4];
    check(vg_parse("#image=long&x=1&y=2&z=0", &v, small, sizeof small) < 0,
          "an id longer than the room is refused");
}

/* The display window in a link: written as URLSearchParams writes it,
 * read back percent-decoded; hostile values refused. */
static void window_links(void)
{
    struct vg_view w = {550, 350, 0, 0};
    char out[256], win[64];
    vg_format_hash("picos", &w, "10,250,1.000;50,150,0.500", out, sizeof out);
    check_str(out, "#image=picos&x=550&y=350&z=0&r=0&window=10%2C250%2C1.000%3B50%2C150%2C0.500",
              "the window as the browser writes it");
    check(vg_hash_window(out, win, sizeof win) == 1 &&
              !strcmp(win, "10,250,1.000;50,150,0.500"), "and read back (%s)", win);
    vg_format_hash("picos", &w, "", out, sizeof out);
    check_str(out, "#image=picos&x=550&y=350&z=0&r=0", "no window: no key");
    vg_format_hash("picos", &w, "none", out, sizeof out);
    check_str(out, "#image=picos&x=550&y=350&z=0&r=0&window=none", "window=none");
    char tiny[40];
    vg_format_hash("picos", &w, "10,250,1.000", tiny, sizeof tiny);
    check(strlen(tiny) < sizeof tiny, "a small buffer stays terminated");
    check(vg_hash_window("http://h/#image=a&window=30,200,0.7&x=1", win, sizeof win) == 1 &&
              !strcmp(win, "30,200,0.7"), "raw commas are read too");
    check(vg_hash_window("#window=1,2&window=3%2c4", win, sizeof win) == 1 && !strcmp(win, "3,4"),
          "the last key wins, lower-case escapes");
    check(vg_hash_window("#image=a&x=1&y=2&z=0", win, sizeof win) == 0 && !win[0], "no window key");
    check(vg_hash_window("30,200,1", win, sizeof win) == 0 && !win[0], "no hash");
    check(vg_hash_window("#xwindow=1,2&windows=3", win, sizeof win) == 0, "only the key window");
    static const char *bad[] = {"#window=1%2", "#window=%", "#window=1%zz2", "#window=%00",
        "#window=0123456789012345678901234567890123456789012345678901234567890123456789"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        strcpy(win, "x");
        check(vg_hash_window(bad[i], win, sizeof win) < 0 && !win[0], "refused: '%.30s'", bad[i]);
    }
}

/* The scale bar: round lengths of pixels, or of microns for a slide. */
static void scale_bars(void)
{
    double bar;
    char label[32];
    vg_scale_bar(0, 0, 128, &bar, label, sizeof label);
    check(bar == 100 && !strcmp(label, "100 PX"), "1:1, 128 px at most: 100 PX over 100 px (%g, %s)", bar, label);
    vg_scale_bar(3, 0, 128, &bar, label, sizeof label);
    check(bar == 125 && !strcmp(label, "1000 PX"), "zoom 3: 1000 PX over 125 px (%g, %s)", bar, label);
    vg_scale_bar(0, 0.25, 128, &bar, label, sizeof label);
    check(bar == 80 && !strcmp(label, "20 UM"), "0.25 um a pixel at 1:1: 20 UM over 80 px (%g, %s)", bar, label);
    vg_scale_bar(6, 0.25, 128, &bar, label, sizeof label);
    check(bar == 125 && !strcmp(label, "2 MM"), "zoom 6: 2 MM over 125 px (%g, %s)", bar, label);
    vg_scale_bar(-3, 0.5, 100, &bar, label, sizeof label);
    check(bar == 80 && !strcmp(label, "5 UM"), "magnified 8x: 5 UM over 80 px (%g, %s)", bar, label);
    vg_scale_bar(-6, 0, 100, &bar, label, sizeof label);
    check(fabs(bar - 64) < 1e-9 && !strcmp(label, "1 PX"), "magnified 64x: 1 PX over 64 px (%g, %s)", bar, label);
}

int main(void)
{
    scale_bars();
    geometry();
    links();
    window_links();
    return tap_done();
}
