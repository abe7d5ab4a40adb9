/*
 * view_input.c - input to view changes (view_input.h).
 *
 * The bindings: drag pans; the wheel zooms by half a level a notch about
 * the pointer, a double click zooms in by one (Shift: out); two fingers
 * pinch and turn about their midpoint; arrows pan by a fifth of the
 * window (Shift: half); + and - zoom by half a level; R and Shift-R (also
 * ] and [, e and q) rotate by 15 degrees; Backspace turns back to 0;
 * Home and 0 show the whole image; 1..9 recall a preset view (unset:
 * level N-1 at 1:1 about the centre), Ctrl+1..9 store one; F (F11)
 * fullscreen; P (F12) screenshot; C prints the view as a browser link;
 * Tab / Shift-Tab the next / previous image; I the image list; O the
 * overlay; Shift-drag a region to filter, Delete clears it, and Page Up /
 * Page Down change its first parameter, G chooses the next graph; Esc
 * quits, except during a Shift-drag, which it cancels (the button's
 * release then filters nothing).  A gamepad (SDL GameController): left stick pans, right stick
 * zooms (up/down) and rotates (left/right), the right / left trigger
 * zooms in / out, shoulders rotate by 15 degrees, A / B zoom in / out,
 * Start goes home, with a dead zone.  The sticks are read from the axis
 * events (not polled), so that a script's synthetic events drive them.
 */
#include <math.h>
#include <string.h>

#include "view_input.h"

#define DEAD 0.2                 /* gamepad dead zone (of full deflection) */

static void clamp_goal(struct vi *s)
{
    s->goal = vg_clamp(&s->goal, s->iw, s->ih, s->w, s->h);
    /* Keep the rotation path short: the goal's rotation near cur's. */
    while (s->goal.rot - s->cur.rot > 180)
        s->goal.rot -= 360;
    while (s->goal.rot - s->cur.rot < -180)
        s->goal.rot += 360;
}

void vi_init(struct vi *s, const struct vg_view *v, double iw, double ih, int w, int h)
{
    SDL_GameController *pad = s->pad;
    double ax[SDL_CONTROLLER_AXIS_MAX];
    memcpy(ax, s->axis, sizeof ax);
    memset(s, 0, sizeof *s);
    s->pad = pad;
    memcpy(s->axis, ax, sizeof ax);
    s->iw = iw;
    s->ih = ih;
    s->w = w;
    s->h = h;
    s->ratio = 1;
    s->goal = *v;
    s->cur = *v;
}

void vi_set_image(struct vi *s, double iw, double ih)
{
    s->iw = iw;
    s->ih = ih;
    s->cur = s->goal = vg_home(iw, ih, s->w, s->h);
}

void vi_jump(struct vi *s, const struct vg_view *v)
{
    s->cur = s->goal = *v;
}

/* Zoom the goal by dz levels keeping the image point under (sx, sy). */
static void zoom_about(struct vi *s, double dz, double sx, double sy)
{
    double px, py;
    vg_screen_to_image(&s->goal, s->w, s->h, sx, sy, &px, &py);
    s->goal.zoom -= dz;
    s->goal = vg_anchored(&s->goal, s->w, s->h, px, py, sx, sy);
    clamp_goal(s);
}

/* Pan the goal by (dx, dy) window pixels (the image moves the other way). */
static void pan_by(struct vg_view *v, int w, int h, double dx, double dy)
{
    double ax, ay, bx, by;
    vg_screen_to_image(v, w, h, 0, 0, &ax, &ay);
    vg_screen_to_image(v, w, h, dx, dy, &bx, &by);
    v->cx += bx - ax;
    v->cy += by - ay;
}

static enum vi_action key(struct vi *s, const SDL_KeyboardEvent *k)
{
    const int shift = (k->keysym.mod & KMOD_SHIFT) != 0;
    const int ctrl = (k->keysym.mod & KMOD_CTRL) != 0;
    const SDL_Keycode c = k->keysym.sym;
    const double step = shift ? 0.5 : 0.2;
    switch (c) {
    case SDLK_ESCAPE:
        if (s->selecting) {
            s->selecting = 0;
            return VI_REDRAW;
        }
        return VI_QUIT;
    case SDLK_LEFT: pan_by(&s->goal, s->w, s->h, -s->w * step, 0); break;
    case SDLK_RIGHT: pan_by(&s->goal, s->w, s->h, s->w * step, 0); break;
    case SDLK_UP: pan_by(&s->goal, s->w, s->h, 0, -s->h * step); break;
    case SDLK_DOWN: pan_by(&s->goal, s->w, s->h, 0, s->h * step); break;
    case SDLK_PLUS: case SDLK_EQUALS: case SDLK_KP_PLUS:
        zoom_about(s, 0.5, s->w / 2.0, s->h / 2.0); return VI_NONE;
    case SDLK_MINUS: case SDLK_KP_MINUS:
        zoom_about(s, -0.5, s->w / 2.0, s->h / 2.0); return VI_NONE;
    case SDLK_r: s->goal.rot += shift ? -15 : 15; break;
    case SDLK_RIGHTBRACKET: case SDLK_e: s->goal.rot += 15; break;
    case SDLK_LEFTBRACKET: case SDLK_q: s->goal.rot -= 15; break;
    case SDLK_BACKSPACE: s->goal.rot = 0; break;
    case SDLK_HOME: case SDLK_0: s->goal = vg_home(s->iw, s->ih, s->w, s->h); break;
    case SDLK_f: case SDLK_F11: return VI_FULLSCREEN;
    case SDLK_p: case SDLK_F12: return VI_SCREENSHOT;
    case SDLK_c: return VI_COPY_VIEW;
    case SDLK_TAB: return shift ? VI_PREV_IMAGE : VI_NEXT_IMAGE;
    case SDLK_i: return VI_TOGGLE_LIST;
    case SDLK_o: return VI_TOGGLE_OVERLAY;
    case SDLK_PAGEUP: return VI_PARAM_UP;
    case SDLK_PAGEDOWN: return VI_PARAM_DOWN;
    case SDLK_DELETE: return VI_ROI_CLEAR;
    case SDLK_g: return VI_NEXT_FILTER;
    /* The display window: black point b/B, white point w/W, gamma
     * y/Y (up/down), a auto, x back to the starting one, Shift+X none;
     * k/K the channel they move (every one, then each in turn). */
    case SDLK_b: return shift ? VI_WIN_BLACK_DOWN : VI_WIN_BLACK_UP;
    case SDLK_w: return shift ? VI_WIN_WHITE_UP : VI_WIN_WHITE_DOWN;
    case SDLK_y: return shift ? VI_WIN_GAMMA_DOWN : VI_WIN_GAMMA_UP;
    case SDLK_a: return VI_WIN_AUTO;
    case SDLK_x: return shift ? VI_WIN_NONE : VI_WIN_RESET;
    case SDLK_k: return shift ? VI_WIN_CHANNEL_PREV : VI_WIN_CHANNEL_NEXT;
    default:
        if (c >= SDLK_1 && c <= SDLK_9) {
            int n = (int)(c - SDLK_0);
            if (ctrl) {
                s->preset[n] = s->goal;
                s->have_preset[n] = 1;
            } else if (s->have_preset[n]) {
                s->goal = s->preset[n];
            } else {
                s->goal.zoom = n - 1;
                s->goal.rot = 0;
            }
            break;
        }
        return VI_NONE;
    }
    clamp_goal(s);
    return VI_NONE;
}

static enum vi_action mouse_button(struct vi *s, const SDL_MouseButtonEvent *b)
{
    s->mx = b->x * s->ratio;
    s->my = b->y * s->ratio;
    if (b->button != SDL_BUTTON_LEFT)
        return VI_NONE;
    const int shift = (SDL_GetModState() & KMOD_SHIFT) != 0;
    if (b->type == SDL_MOUSEBUTTONDOWN) {
        if (b->clicks == 2 && !shift) {
            zoom_about(s, 1, s->mx, s->my);
            return VI_NONE;
        }
        if (b->clicks == 2) {
            zoom_about(s, -1, s->mx, s->my);
            return VI_NONE;
        }
        if (shift) {
            s->selecting = 1;
            s->sel[0] = s->sel[2] = s->mx;
            s->sel[1] = s->sel[3] = s->my;
            return VI_REDRAW;
        }
        s->dragging = 1;
        return VI_NONE;
    }
    s->dragging = 0;
    if (s->selecting) {
        s->selecting = 0;
        s->sel[2] = s->mx;
        s->sel[3] = s->my;
        if (fabs(s->sel[2] - s->sel[0]) >= 4 && fabs(s->sel[3] - s->sel[1]) >= 4)
            return VI_ROI;
        return VI_REDRAW;        /* too small to filter: just hide it */
    }
    return VI_NONE;
}

static enum vi_action mouse_motion(struct vi *s, const SDL_MouseMotionEvent *m)
{
    double x = m->x * s->ratio, y = m->y * s->ratio;
    if (s->dragging) {
        /* The image point under the pointer stays under it. */
        pan_by(&s->cur, s->w, s->h, s->mx - x, s->my - y);
        s->cur = vg_clamp(&s->cur, s->iw, s->ih, s->w, s->h);
        s->goal = s->cur;
    }
    s->mx = x;
    s->my = y;
    if (s->selecting && (s->sel[2] != x || s->sel[3] != y)) {
        s->sel[2] = x;
        s->sel[3] = y;
        return VI_REDRAW;
    }
    return VI_NONE;
}

enum vi_action vi_event(struct vi *s, const SDL_Event *e)
{
    switch (e->type) {
    case SDL_QUIT: return VI_QUIT;
    case SDL_KEYDOWN: return key(s, &e->key);
    case SDL_MOUSEBUTTONDOWN:
    case SDL_MOUSEBUTTONUP: return mouse_button(s, &e->button);
    case SDL_MOUSEMOTION: return mouse_motion(s, &e->motion);
    case SDL_MOUSEWHEEL: {
        double dy = e->wheel.preciseY != 0 ? e->wheel.preciseY : e->wheel.y;
        if (e->wheel.direction == SDL_MOUSEWHEEL_FLIPPED)
            dy = -dy;
        zoom_about(s, 0.5 * dy, s->mx, s->my);
        return VI_NONE;
    }
    case SDL_MULTIGESTURE: {
        /* Pinch and turn about the fingers' midpoint (normalized coords). */
        double sx = e->mgesture.x * s->w, sy = e->mgesture.y * s->h, px, py;
        vg_screen_to_image(&s->cur, s->w, s->h, sx, sy, &px, &py);
        s->cur.zoom -= log2(1 + e->mgesture.dDist * 4);
        s->cur.rot += e->mgesture.dTheta * 180 / M_PI;
        s->cur = vg_anchored(&s->cur, s->w, s->h, px, py, sx, sy);
        s->cur = vg_clamp(&s->cur, s->iw, s->ih, s->w, s->h);
        s->goal = s->cur;
        return VI_NONE;
    }
    case SDL_FINGERDOWN: s->fingers++; return VI_NONE;
    case SDL_FINGERUP: if (s->fingers) s->fingers--; return VI_NONE;
    case SDL_FINGERMOTION:
        if (s->fingers == 1) {
            pan_by(&s->cur, s->w, s->h, -e->tfinger.dx * s->w, -e->tfinger.dy * s->h);
            s->cur = vg_clamp(&s->cur, s->iw, s->ih, s->w, s->h);
            s->goal = s->cur;
        }
        return VI_NONE;
    case SDL_CONTROLLERDEVICEADDED:
        if (!s->pad)
            s->pad = SDL_GameControllerOpen(e->cdevice.which);
        return VI_NONE;
    case SDL_CONTROLLERDEVICEREMOVED:
        if (s->pad && SDL_JoystickInstanceID(SDL_GameControllerGetJoystick(s->pad)) ==
                          e->cdevice.which) {
            SDL_GameControllerClose(s->pad);
            s->pad = NULL;
            memset(s->axis, 0, sizeof s->axis);
        }
        return VI_NONE;
    case SDL_CONTROLLERAXISMOTION:
        if (e->caxis.axis < SDL_CONTROLLER_AXIS_MAX)
            s->axis[e->caxis.axis] = e->caxis.value / 32767.0;
        return VI_NONE;
    case SDL_CONTROLLERBUTTONDOWN:
        switch (e->cbutton.button) {
        case SDL_CONTROLLER_BUTTON_LEFTSHOULDER: s->goal.rot -= 15; break;
        case SDL_CONTROLLER_BUTTON_RIGHTSHOULDER: s->goal.rot += 15; break;
        case SDL_CONTROLLER_BUTTON_A: zoom_about(s, 0.5, s->w / 2.0, s->h / 2.0); break;
        case SDL_CONTROLLER_BUTTON_B: zoom_about(s, -0.5, s->w / 2.0, s->h / 2.0); break;
        case SDL_CONTROLLER_BUTTON_START: s->goal = vg_home(s->iw, s->ih, s->w, s->h); break;
        case SDL_CONTROLLER_BUTTON_BACK: return VI_QUIT;
        default: return VI_NONE;
        }
        clamp_goal(s);
        return VI_NONE;
    default:
        return VI_NONE;
    }
}

/* A stick axis in [-1, 1] (a trigger in [0, 1]) with the dead zone
 * removed. */
static double axis(const struct vi *s, SDL_GameControllerAxis a)
{
    double v = fmax(-1, fmin(1, s->axis[a]));
    if (fabs(v) < DEAD)
        return 0;
    return (v - copysign(DEAD, v)) / (1 - DEAD);
}

int vi_step(struct vi *s, double dt)
{
    {
        double lx = axis(s, SDL_CONTROLLER_AXIS_LEFTX);
        double ly = axis(s, SDL_CONTROLLER_AXIS_LEFTY);
        double rx = axis(s, SDL_CONTROLLER_AXIS_RIGHTX);
        double ry = axis(s, SDL_CONTROLLER_AXIS_RIGHTY);
        double tz = axis(s, SDL_CONTROLLER_AXIS_TRIGGERLEFT) -
                    axis(s, SDL_CONTROLLER_AXIS_TRIGGERRIGHT);
        if (lx || ly || rx || ry || tz) {
            /* A window per second at full deflection, a level per second. */
            pan_by(&s->goal, s->w, s->h, lx * s->w * dt, ly * s->h * dt);
            s->goal.zoom += (ry + tz) * dt;
            s->goal.rot += rx * 90 * dt;
            clamp_goal(s);
            s->cur = s->goal;
            return 1;
        }
    }
    struct vg_view *c = &s->cur, *g = &s->goal;
    double dz = g->zoom - c->zoom, dr = g->rot - c->rot;
    double dpx = hypot(g->cx - c->cx, g->cy - c->cy) / exp2(c->zoom);
    if (fabs(dz) < 1e-3 && fabs(dr) < 1e-2 && dpx < 0.05) {
        int moved = memcmp(c, g, sizeof *c) != 0;
        *c = *g;
        c->rot = g->rot = vg_norm_rot(g->rot);
        return moved;
    }
    /* Close a fixed share of the gap per 1/60 s: about 120 ms to settle. */
    double a = 1 - pow(0.75, dt * 60);
    c->cx += (g->cx - c->cx) * a;
    c->cy += (g->cy - c->cy) * a;
    c->zoom += dz * a;
    c->rot += dr * a;
    return 1;
}
