/*
 * view_input.h - what input does to the view in `gigaview view`: mouse,
 * wheel, keys, touch and gamepad (SDL events, live or replayed by
 * --script), as the browser viewer does it (docs/VIEWER.md, "Moving
 * around").  Drags follow the pointer; keys, the wheel and the gamepad
 * set a goal the view moves to smoothly (vi_step), and snaps to exactly
 * when close, so a replayed script ends on the same view whatever the
 * frame rate.
 */
#ifndef GV_VIEW_INPUT_H
#define GV_VIEW_INPUT_H

#include <SDL.h>

#include "view_geom.h"

/* What an event asks of the program besides moving the view. */
enum vi_action {
    VI_NONE, VI_QUIT, VI_FULLSCREEN, VI_SCREENSHOT, VI_NEXT_IMAGE, VI_PREV_IMAGE,
    VI_TOGGLE_OVERLAY, VI_TOGGLE_LIST, VI_COPY_VIEW, VI_ROI, VI_PARAM_UP,
    VI_PARAM_DOWN, VI_ROI_CLEAR, VI_NEXT_FILTER,
    /* the display window: b (black up), Shift+B, w (white down), Shift+W,
     * y (gamma up), Shift+Y, a (auto), x (reset), Shift+X (none) */
    VI_WIN_BLACK_UP, VI_WIN_BLACK_DOWN, VI_WIN_WHITE_DOWN, VI_WIN_WHITE_UP,
    VI_WIN_GAMMA_UP, VI_WIN_GAMMA_DOWN, VI_WIN_AUTO, VI_WIN_RESET, VI_WIN_NONE,
    VI_WIN_CHANNEL_NEXT, VI_WIN_CHANNEL_PREV,  /* which channel the window keys move */
    VI_REDRAW                    /* the selection changed: draw again */
};

struct vi {
    struct vg_view cur, goal;
    double iw, ih;               /* the image (level 0) */
    int w, h;                    /* the window (drawable pixels) */
    double ratio;                /* drawable pixels per window coordinate */
    int dragging, selecting;     /* selecting: a Shift-drag in progress */
    double mx, my;               /* pointer (drawable pixels) */
    double sel[4];               /* Shift-drag rectangle: x0, y0, x1, y1 */
    struct vg_view preset[10];
    int have_preset[10];
    SDL_GameController *pad;
    double axis[SDL_CONTROLLER_AXIS_MAX]; /* last axis events, -1..1 (triggers 0..1) */
    int fingers;
};

/* Start at view v (already clamped or not) for an iw x ih image. */
void vi_init(struct vi *s, const struct vg_view *v, double iw, double ih, int w, int h);

/* A new image: keep presets, go home. */
void vi_set_image(struct vi *s, double iw, double ih);

/* Jump to v (no animation). */
void vi_jump(struct vi *s, const struct vg_view *v);

/* Handle one event.  Returns what else it asks for (VI_NONE mostly). */
enum vi_action vi_event(struct vi *s, const SDL_Event *e);

/* Advance the animation and the gamepad by dt seconds.  Returns 1 while
 * the view is still moving. */
int vi_step(struct vi *s, double dt);

#endif
