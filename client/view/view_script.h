/*
 * view_script.h - `gigaview view --script FILE`: timed input replayed into
 * the viewer, and frames written to PNG, for tests and benchmarks (under
 * SDL_VIDEODRIVER=offscreen no window is shown).
 *
 * One command a line; '#' starts a comment (view's SPEC may hold one:
 * there a comment is a later word starting with '#'); numbers are decimal,
 * finite and at most 1e9 in size (counts: whole numbers); X Y are window
 * pixels from the top left; lines end in LF or CRLF.  Commands run in order, each as soon
 * as the one before is done; the program exits 0 after the last one (1
 * when a limit below runs out, with a message naming the line).
 *
 *   wait MS                 let MS milliseconds of frames pass
 *   frames N                let N frame ticks pass (a tick draws only
 *                           when something changed)
 *   key NAME                press and release a key: an SDL key name
 *                           ("Right", "+", "Home", "R"), optionally after
 *                           "shift+" and/or "ctrl+"
 *   down X Y [shift]        left button pressed at (X, Y)
 *   move X Y                the pointer moved to (X, Y)
 *   up X Y                  left button released at (X, Y)
 *   drag X0 Y0 X1 Y1 [N]    down, N moves (default 8) and up
 *   wheel X Y N             N wheel notches at (X, Y), positive zooms in
 *   view SPEC               jump to a view: CX,CY,ZOOM[,ROT] or a
 *                           browser link's "#image=..." hash
 *   image ID                switch to image ID
 *   settle [MS]             wait until the view is at rest and every tile
 *                           it needs is drawn; fails after MS (default
 *                           60000) with no tile fetched or decoded
 *   shot FILE               write the picture (no overlay) to FILE
 *   wait-file PATH [MS]     wait until PATH exists (default 60000)
 *   print TEXT              print TEXT and the view's link on stdout
 *   message TEXT            print TEXT and the overlay's error line
 *   counters TEXT           print TEXT, the tiles fetched and decoded so
 *                           far and the display window on stdout
 *   window SPEC|none        set the display window (as --window)
 *   quit                    exit now
 *
 * Filters (a region filtered by the server, shown in place):
 *   filter X0 Y0 X1 Y1      as a Shift-drag from (X0, Y0) to (X1, Y1)
 *   graph ID|next           choose graph ID (one the server may lack),
 *                           or the next of GET /v1/filters (as G)
 *   param +|-               step the graph's first parameter (as Page
 *                           Up / Page Down)
 *   settle also waits for the filter job in flight.
 *
 * Gamepad and touch (synthetic SDL events, handled as real ones):
 *   pad-axis NAME V         an SDL_CONTROLLERAXISMOTION of axis NAME
 *                           (SDL's names: leftx, lefty, rightx, righty,
 *                           lefttrigger, righttrigger) to V in [-1, 1];
 *                           it stays there until the next pad-axis
 *   pad-button NAME         press and release button NAME (a, b, start,
 *                           leftshoulder, rightshoulder, ...)
 *   pinch X Y DDIST DDEG    an SDL_MULTIGESTURE about (X, Y): the
 *                           fingers' distance grew by DDIST (of the
 *                           window's size) and turned DDEG degrees
 *   touch X0 Y0 X1 Y1 [N]   one finger down, N moves (default 8), up
 */
#ifndef GV_VIEW_SCRIPT_H
#define GV_VIEW_SCRIPT_H

#include <stddef.h>

#include "base/error.h"
#include "view_geom.h"

enum vs_op {
    VS_WAIT, VS_FRAMES, VS_KEY, VS_DOWN, VS_MOVE, VS_UP, VS_DRAG, VS_WHEEL,
    VS_VIEW, VS_IMAGE, VS_SETTLE, VS_SHOT, VS_WAIT_FILE, VS_PRINT, VS_QUIT,
    VS_FILTER, VS_GRAPH, VS_PARAM, VS_PAD_AXIS, VS_PAD_BUTTON, VS_PINCH, VS_TOUCH, VS_MESSAGE,
    VS_COUNTERS, VS_WINDOW
};

struct vs_cmd {
    enum vs_op op;
    int line;
    double a[5];                 /* numbers, in the order of the syntax */
    int shift, ctrl;             /* key, down */
    int keycode;                 /* key: SDL_Keycode */
    int code;                    /* pad-axis, pad-button: SDL's axis or button */
    char *text;                  /* shot, wait-file, image, print, message, graph (malloc'ed) */
    struct vg_view view;         /* view */
    char view_image[129];        /* view: the hash's image, "" if none */
};

/* Limits on a script: bytes a line (its '\n' not counted) and commands
 * (comment and blank lines not counted); vs_load also takes files of at
 * most 16 MiB. */
#define VS_MAX_LINE 4096
#define VS_MAX_CMDS 100000

struct vs_script {
    struct vs_cmd *cmd;
    size_t n;
};

/* Read and check the whole script at path.  Returns 0, or -1 with *err
 * ("FILE:LINE: what is wrong"); vs_free frees *s either way. */
int vs_load(const char *path, struct vs_script *s, struct gv_error *err);

/* The same from text (NUL-terminated), `name` used in messages. */
int vs_parse(const char *text, const char *name, struct vs_script *s,
             struct gv_error *err);

void vs_free(struct vs_script *s);

#endif
