/*
 * cmd_view.c - `gigaview view URL`: the native viewer.  A window (SDL2,
 * with an OpenGL ES 3.2 context, else OpenGL 4.3 core, made through EGL
 * where SDL can) shows an image of gigaviewd at URL that you pan, zoom and
 * rotate smoothly at the display's rate: tiles are fetched on a thread of
 * their own (view_fetch.h), decoded on this machine's GPU with the shared
 * decode shader (lib/gpu, whose context here is the window's:
 * gv_gpu_adopt) and drawn from the resident set (view_tiles.h) by one
 * full-window pass that blends two levels of detail (view_draw.h).
 * Height and sample stores decode to 16-bit codes and are drawn through
 * tables of their window (codes_set), as gigaviewd draws them.
 *
 * The frame loop: events (view_input.h) and the script's commands
 * (view_script.h), results from the fetch thread, the view's animation,
 * the tiles' work for this frame (a bounded number of decodes; never a
 * wait for the network), the draw, a screenshot if one is due, the
 * overlay (view_overlay.h), the swap (vsync where the driver has it).
 * Filter graphs run on a thread of their own as well (view_filter.h):
 * a Shift-drag asks the server to filter that region, and the result is
 * drawn over the picture in place (view_roi.h) until cleared.
 * At rest with nothing to do it sleeps in SDL_WaitEventTimeout.
 *
 * A build without SDL2 (or --without-gpu) has a cmd_view that says so.
 */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "config.h" /* GV_HAVE_GPU, GV_HAVE_SDL2 */

#include "commands.h"

#define ME "gigaview view"

#if defined(GV_HAVE_GPU) && defined(GV_HAVE_SDL2)

#include <SDL.h>
#include <GLES3/gl32.h>

#include "gpu/gpu.h"
#include "imageio/imageio.h"
#include "options.h"
#include "remote/http_fetch.h"
#include "remote_opts.h"
#include "view/view_draw.h"
#include "view/view_fetch.h"
#include "view/view_filter.h"
#include "view/view_geom.h"
#include "view/view_input.h"
#include "view/view_overlay.h"
#include "view/view_roi.h"
#include "view/view_script.h"
#include "view/view_select.h"
#include "view/view_tiles.h"
#include "render/height_region.h"
#include "render/samples_region.h"
#include "render/window.h"

struct view_args {
    struct remote_opts remote; /* --timeout, --cache-dir, --no-cache, --gpu-cache */
    const char *image, *size, *view, *script, *stats, *window;
    int fullscreen, no_batch, no_prefetch, no_vsync, no_overlay, verbose;
    int no_decode_thread;
    int budget;
    double budget_ms;
};

#define F(field) offsetof(struct view_args, field)
static const struct opt_spec view_opts[] = {
    {.name = "image", .short_name = 'i', .kind = OPT_STRING, .arg = "ID",
     .field = F(image), .help = "the image to show first (default: the view's,\n"
                                "else the server's first)"},
    {.name = "size", .short_name = 's', .kind = OPT_STRING, .arg = "WxH",
     .field = F(size), .help = "window size (default 1280x720)"},
    {.name = "fullscreen", .kind = OPT_FLAG, .field = F(fullscreen),
     .help = "start fullscreen (F toggles)"},
    {.name = "view", .kind = OPT_STRING, .arg = "SPEC", .field = F(view),
     .help = "start at CX,CY,ZOOM[,ROT] (level-0 centre, level of\n"
             "detail, degrees clockwise) or a browser link's\n"
             "#image=ID&x=..&y=..&z=..&r=.. (default: the whole image)"},
    {.name = "window", .kind = OPT_STRING, .arg = "B,W,G[;...]|none",
     .field = F(window),
     .help = "start with this display window: black, white,\n"
             "gamma, one or one a channel (default: the\n"
             "store's; keys b B w W y Y a x X change it)"},
    {.name = "script", .kind = OPT_STRING, .arg = "FILE", .field = F(script),
     .help = "replay the input in FILE, then exit (docs/VIEWER.md)"},
    REMOTE_OPT_TIMEOUT(F(remote)),
    REMOTE_OPT_CACHE(F(remote)),
    {.name = "no-batch", .kind = OPT_FLAG, .field = F(no_batch),
     .help = "fetch each tile with a request of its own"},
    REMOTE_OPT_GPU_CACHE(F(remote)),
    {.name = "budget", .kind = OPT_INT, .arg = "N", .field = F(budget), .min = 1,
     .max = 4096, .help = "tile decodes in flight at most (default 4; in\n"
                          "the frame: decodes per frame)"},
    {.name = "budget-ms", .kind = OPT_DOUBLE, .arg = "MS", .field = F(budget_ms),
     .min = 0, .max = 10000, .flags = OPT_FINITE,
     .help = "no new decode once a frame's decode work took this\n"
             "long (default 6; one decode always starts)"},
    {.name = "no-decode-thread", .kind = OPT_FLAG, .field = F(no_decode_thread),
     .help = "decode tiles in the frame, on the render thread\n"
             "(default: on a thread of their own, on a GL\n"
             "context shared with the window's, where EGL can)"},
    {.name = "no-prefetch", .kind = OPT_FLAG, .field = F(no_prefetch),
     .help = "no prefetching ahead of the motion"},
    {.name = "no-vsync", .kind = OPT_FLAG, .field = F(no_vsync),
     .help = "do not wait for the display's refresh"},
    {.name = "no-overlay", .kind = OPT_FLAG, .field = F(no_overlay),
     .help = "start with the overlay hidden (O toggles)"},
    {.name = "stats", .kind = OPT_STRING, .arg = "FILE", .field = F(stats),
     .help = "write each frame's time and work to FILE (TSV)\n"
             "and a summary to stderr at exit"},
    {.name = "verbose", .short_name = 'v', .kind = OPT_FLAG, .field = F(verbose),
     .help = "log requests, failures and statistics to stderr"},
};
#undef F

static const struct opt_command view_command = {
    .me = ME,
    .synopsis =
        "usage: gigaview view URL [--image ID] [--size WxH] [--fullscreen]\n"
        "                         [--view CX,CY,ZOOM[,ROT]] [--script FILE]\n"
        "\n"
        "Show the images of the gigaviewd at URL in a window: drag to pan, wheel\n"
        "to zoom, R to rotate, Esc to quit (docs/VIEWER.md lists every key).\n"
        "Tiles are decoded on this machine's GPU.  SDL_VIDEODRIVER=offscreen\n"
        "runs without a display (with --script).  GIGAVIEW_TOKEN, if set, is\n"
        "sent as the access token of restricted images.\n",
    .opts = view_opts,
    .nopts = sizeof view_opts / sizeof view_opts[0],
};

#define MAX_IMAGES 256

/* Everything the loop works on. */
struct app {
    const struct view_args *a;
    SDL_Window *win;
    SDL_GLContext glc;
    struct gv_gpu *gpu;
    struct gv_gpu *dgpu;         /* the decode thread's shared context, or NULL */
    struct vd *draw;
    struct vo *overlay;
    struct vf *fetch;
    struct vt *tiles;            /* NULL until the image has come */
    struct vi in;
    /* filters */
    struct vx *filt;
    struct vr *roi;
    struct vsel *sel;            /* the Shift-drag being made */
    struct vx_graph graphs[VX_MAX_GRAPHS];
    int ngraphs, graph;          /* graph: index into graphs, -1 none chosen */
    struct vx_graph named;       /* a graph chosen by id that is not listed */
    int use_named, have_job, have_roi;
    struct vx_job job;           /* the last job asked for */
    double params[VX_MAX_GRAPHS + 1]; /* each graph's parameter (last: named) */
    int param_set[VX_MAX_GRAPHS + 1];
    char ids[MAX_IMAGES][129];
    int nids, cur_id;
    char want_image[129];        /* asked of the fetch thread */
    int have_start_view;
    struct vg_view start_view;
    /* the display window (render/window.h): now, and the image's start */
    struct gv_window dwin, dwin_start;
    int win_ch;               /* the channel the window keys move, from 1; 0 every one */
    int store_window;            /* the image has a store default window */
    char link_window[GV_WINDOW_MAX_TEXT]; /* --view link's, for its image */
    uint8_t *root_px;            /* the root level's samples, for auto: bytes
                                  * (a height store's gray), or a sample
                                  * store's codes (uint16_t) */
    size_t root_n;
    int channels;
    /* Stores of codes: what the window applies to, and the picture. */
    struct gv_remote_image img;
    uint32_t wmax;               /* a window point's largest value */
    uint8_t *tables;             /* channels x 65536 (vd_set_codes) */
    double mpp;                  /* microns per level-0 pixel, 0: unknown */
    int show_overlay, show_list, fullscreen, quit, rc, vsync;
    int w, h;
    char message[VO_LINE];       /* last error worth showing */
    uint64_t frames;
    double t_start;
    /* script */
    struct vs_script script;
    size_t pc;                   /* next command */
    double pc_since;             /* when the current command started (settle:
                                  * or last saw a tile fetched or decoded) */
    uint64_t settle_progress;    /* tiles fetched + decoded, as settle last saw */
    uint64_t pc_frame;
    const char *shot_path;       /* due at the next draw */
    int shot_done, shot_no;
    /* what the last drawn frame showed */
    const struct vt *drawn_tiles;
    struct vg_view drawn_view;
    uint64_t drawn_published, draws;
    int drawn_w, drawn_h, drawn_overlay, force_draw;
    struct vo_content drawn_content;
    /* stats */
    FILE *stats;
    double *ft;
    size_t nft, capft;
    uint64_t decodes0;
    double moving_time;
    double decode_ms;            /* render-thread time on decode work, in all */
    uint64_t errors_shown;       /* decode errors of app->tiles on the overlay */
    struct vt_stats st;
};

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec / 1e9;
}

/* The server's image ids (GET /v1/images, through the table that
 * gv_http_print_images prints). */
static int list_images(struct app *app, const char *url, struct gv_error *err)
{
    struct gv_http *h = gv_http_new(url, remote_timeout_ms(&app->a->remote), 0, err);
    if (!h)
        return -1;
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    int rc = f ? gv_http_print_images(h, f, err) : gv_fail(err, GV_ENOMEM, "out of memory");
    if (f)
        fclose(f);
    gv_http_free(h);
    int table = 0;
    for (char *line = text, *next; rc == 0 && line && *line; line = next) {
        next = strchr(line, '\n');
        if (next)
            *next++ = 0;
        char id[129];
        if (sscanf(line, "%128s", id) != 1)
            continue;
        if (!table) {
            table = !strcmp(id, "id");
            continue;
        }
        if (app->nids < MAX_IMAGES)
            snprintf(app->ids[app->nids++], sizeof app->ids[0], "%s", id);
    }
    free(text);
    return rc;
}

static void open_image(struct app *app, const char *id)
{
    if (app->roi)                /* a filtered region is of one image */
        vr_clear(app->roi);
    app->have_roi = app->have_job = 0;
    snprintf(app->want_image, sizeof app->want_image, "%s", id);
    for (int i = 0; i < app->nids; i++)
        if (!strcmp(app->ids[i], id))
            app->cur_id = i;
    vf_open(app->fetch, id);
}

/* ---------------------------------------------------------------- window */

/* The codes' tables of a store of codes under window w: a sample
 * store's window on its codes (none: the codes' range), with its colours
 * (the store's, else the palette); a height store's gray, its window then
 * applied to the composed gray as an image's.  Returns the window left
 * for the 8-bit pass. */
static const struct gv_window *codes_set(struct app *app, const struct gv_window *w)
{
    static const struct gv_window none = {0};
    const struct gv_remote_image *im = &app->img;
    const int c = app->channels;
    if (!app->tables && !(app->tables = malloc((size_t)c * 65536)))
        return &none;
    uint8_t rgb[GV_SAMPLES_MAX_CHANNELS][3] = {{0}};
    struct gv_colours col = {0};
    if (im->kind == GV_KIND_HEIGHT) {
        const struct gv_height_meta m = gv_remote_height_meta(im);
        for (uint32_t v = 0; v < 65536; v++)
            app->tables[v] = gv_height_gray(&m, (uint16_t)v);
        vd_set_codes(app->draw, app->tables, (const uint8_t (*)[3])rgb, 1);
        return w;
    }
    struct gv_window dw;
    if (!w->count) {
        const struct gv_header h = gv_remote_header(im);
        gv_samples_default_window(&h, &dw);
        w = &dw;
    }
    for (int k = 0; k < c; k++)
        gv_window_table(gv_window_of(w, k), 65535, app->tables + (size_t)k * 65536);
    struct gv_error ignored = {0};
    if (*im->colours && (gv_colours_parse(im->colours, &col, &ignored) < 0 ||
                         gv_colours_check(&col, c, &ignored) < 0))
        memset(&col, 0, sizeof col);
    for (int k = 0; k < c; k++)
        gv_samples_colour(&col, k, rgb[k]);
    vd_set_codes(app->draw, app->tables, (const uint8_t (*)[3])rgb, c);
    return &none;
}

/* Show window w (count 0: none) from the next frame: a new table, no tile
 * fetched or decoded again. */
static void window_set(struct app *app, const struct gv_window *w)
{
    app->dwin = *w;
    const struct gv_header hdr = gv_remote_header(&app->img);
    const struct gv_window *w8 = gv_header_codes(&hdr) ? codes_set(app, &app->dwin) : &app->dwin;
    vd_set_window(app->draw, w8, gv_display_channels(&hdr));
    app->force_draw = 1;
}

/* The window an image opens with: --window (where it fits the image's
 * channels), else the window of the --view link (the first image opened
 * only), else the store's default; and the root's samples for auto. */
static void window_start(struct app *app, const struct vf_result *r)
{
    struct gv_error err = {0};
    struct gv_window w = {0};
    const char *text = app->a->window ? app->a->window :
                       app->link_window[0] ? app->link_window : r->img.window;
    app->store_window = r->img.window[0] != 0;
    if (app->channels != r->img.channels) {
        free(app->tables);
        app->tables = NULL;
    }
    app->win_ch = 0;   /* the window keys move every channel of a new image */
    app->channels = r->img.channels;
    app->mpp = r->img.mpp;
    app->img = r->img;
    app->wmax = r->img.kind == GV_KIND_SAMPLES ? 65535 : 255;
    if (*text && strcmp(text, "none") != 0 &&
        (gv_window_parse(text, app->wmax, &w, &err) < 0 ||
         (w.count != 1 && w.count != app->channels))) {
        if (!err.text[0])
            snprintf(err.text, sizeof err.text, "window: %d windows for an "
                     "image of %d channels", w.count, app->channels);
        fprintf(stderr, ME ": %s\n", err.text);
        snprintf(app->message, sizeof app->message, "%.90s", err.text);
        memset(&w, 0, sizeof w);
    }
    app->dwin_start = w;
    app->link_window[0] = 0;
    window_set(app, &w);
    /* The root's samples the window's auto points come from: an image's
     * bytes, a height store's gray, a sample store's codes. */
    free(app->root_px);
    const size_t n = app->root_n = (size_t)r->mip_w[0] * r->mip_h[0];
    const size_t c = (size_t)app->channels;
    app->root_px = malloc(n * c * (r->img.kind == GV_KIND_SAMPLES ? 2 : 1));
    if (!app->root_px) {
        app->root_n = 0;
    } else if (r->img.kind == GV_KIND_SAMPLES) {
        uint16_t *codes = (uint16_t *)(void *)app->root_px;
        for (size_t i = 0; i < n * c; i++)
            codes[i] = (uint16_t)(r->mip[0][2 * i] | r->mip[0][2 * i + 1] << 8);
    } else if (r->img.kind != GV_KIND_IMAGE) {
        for (size_t i = 0; i < n; i++)
            app->root_px[i] = app->tables[r->mip[0][2 * i] | r->mip[0][2 * i + 1] << 8];
    } else {
        memcpy(app->root_px, r->mip[0], n * c);
    }
}

/* The channels a window has one of each: a sample store's or an image's
 * own, one for a height store's gray. */
static int window_channels(const struct app *app)
{
    return app->img.kind == GV_KIND_HEIGHT ? 1 : app->channels;
}

/* A window key (view_input.h's VI_WIN_*): black and white move by 5
 * sample values, gamma by a factor of 1.1, on every channel alike or, once
 * k has picked one (app->win_ch), on that channel alone; auto likewise
 * sets every channel's points from the root or that channel's. */
static void window_key(struct app *app, enum vi_action a)
{
    const uint32_t max = app->wmax, step = max == 255 ? 5 : 5 * 257;
    const int nc = window_channels(app), sel = app->win_ch;
    struct gv_window w = app->dwin;
    if (w.count == 0 && app->img.kind == GV_KIND_SAMPLES) {
        const struct gv_header h = gv_remote_header(&app->img);
        gv_samples_default_window(&h, &w);
    } else if (w.count == 0) {
        w = (struct gv_window){.count = 1, .ch = {{0, 255, 1000}}};
    }
    if (sel && w.count == 1 && nc > 1) {   /* one window becomes one a channel */
        for (int k = 1; k < nc; k++)
            w.ch[k] = w.ch[0];
        w.count = nc;
    }
    if (a == VI_WIN_AUTO) {
        struct gv_window au = w;
        const uint32_t gamma = w.ch[sel ? sel - 1 : 0].gamma_milli;
        if (app->root_n && app->img.kind == GV_KIND_SAMPLES)
            gv_window_auto16((const uint16_t *)(void *)app->root_px, app->root_n,
                             app->channels, !sel, gamma, &au);
        else if (app->root_n)
            gv_window_auto8(app->root_px, app->root_n, nc, !sel, gamma, &au);
        if (sel && au.count == nc)
            w.ch[sel - 1] = au.ch[sel - 1];
        else if (!sel)
            w = au;
        window_set(app, &w);
        return;
    }
    if (a == VI_WIN_RESET || a == VI_WIN_NONE) {
        struct gv_window none = {0};
        window_set(app, a == VI_WIN_RESET ? &app->dwin_start : &none);
        return;
    }
    for (int k = 0; k < w.count; k++) {
        if (sel && k != sel - 1)
            continue;
        struct gv_window_channel *c = &w.ch[k];
        switch (a) {
        case VI_WIN_BLACK_UP: c->black = c->black + step < c->white ? c->black + step : c->white - 1; break;
        case VI_WIN_BLACK_DOWN: c->black = c->black > step ? c->black - step : 0; break;
        case VI_WIN_WHITE_DOWN: c->white = c->white > c->black + step ? c->white - step : c->black + 1; break;
        case VI_WIN_WHITE_UP: c->white = c->white + step < max ? c->white + step : max; break;
        case VI_WIN_GAMMA_UP: {
            uint32_t g = (uint32_t)lround(c->gamma_milli * 1.1);
            c->gamma_milli = g > GV_WINDOW_GAMMA_MAX ? GV_WINDOW_GAMMA_MAX : g;
            break;
        }
        case VI_WIN_GAMMA_DOWN: {
            uint32_t g = (uint32_t)lround(c->gamma_milli / 1.1);
            c->gamma_milli = g < GV_WINDOW_GAMMA_MIN ? GV_WINDOW_GAMMA_MIN : g;
            break;
        }
        default: break;
        }
    }
    window_set(app, &w);
}

/* A result of the fetch thread. */
static void take_result(struct app *app, struct vf_result *r, double now)
{
    if (r->kind == VF_TILE) {
        if (app->tiles)
            vt_take(app->tiles, r, now);
        else
            vf_result_free(r);
        return;
    }
    struct gv_error err = {0};
    if (!r->ok) {
        fprintf(stderr, ME ": %s\n", r->msg);
        snprintf(app->message, sizeof app->message, "%.90s", r->msg);
        vf_result_free(r);
        if (!app->tiles) {       /* nothing to show */
            app->quit = 1;
            app->rc = 1;
        }
        return;
    }
    struct vt_options o = {
        .atlas_bytes = (size_t)(app->a->remote.gpu_mib * 1048576.0 * 0.75),
        .decode_bytes = (size_t)(app->a->remote.gpu_mib * 1048576.0 * 0.25),
        .buffer_bytes = (size_t)256 << 20,
        .budget = app->a->budget,
        .budget_ms = app->a->budget_ms,
        .prefetch = !app->a->no_prefetch,
        .verbose = app->a->verbose,
        .decode_gpu = app->dgpu,
    };
    double iw = r->img.width, ih = r->img.height;
    window_start(app, r);
    struct vt *t = vt_new(app->gpu, r, &o, &err);
    vf_result_free(r);
    if (!t) {
        fprintf(stderr, ME ": %s\n", err.text);
        snprintf(app->message, sizeof app->message, "%.90s", err.text);
        if (!app->tiles) {
            app->quit = 1;
            app->rc = 1;
        }
        return;
    }
    vt_free(app->tiles);
    app->tiles = t;
    app->message[0] = 0;
    app->errors_shown = 0;
    if (app->have_start_view) {
        vi_init(&app->in, &app->start_view, iw, ih, app->w, app->h);
        app->have_start_view = 0;
    } else {
        vi_set_image(&app->in, iw, ih);
    }
    if (app->a->verbose)
        fprintf(stderr, "view: image %s %gx%g\n", vt_image(t), iw, ih);
}

/* A screenshot file name that does not exist yet. */
static void shot_name(struct app *app, char *out, size_t cap)
{
    do
        snprintf(out, cap, "gigaview-%s-%03d.png", app->want_image, ++app->shot_no);
    while (access(out, F_OK) == 0 && app->shot_no < 999);
}

/* The link's window text (as the browser writes it): the window shown;
 * "none" when none is shown but the store has a default (which the link
 * would otherwise bring back); "" when there is neither. */
static void link_window(const struct app *app, char *out, size_t cap)
{
    if (app->dwin.count)
        gv_window_format(&app->dwin, out, cap);
    else
        snprintf(out, cap, "%s", app->store_window ? "none" : "");
}

static void copy_view(struct app *app)
{
    char link[1024], win[GV_WINDOW_MAX_CHANNELS * 32];
    link_window(app, win, sizeof win);
    vg_format_hash(app->want_image, &app->in.goal, win, link, sizeof link);
    printf("%s\n", link);
    fflush(stdout);
    SDL_SetClipboardText(link);
}

static void toggle_fullscreen(struct app *app)
{
    app->fullscreen = !app->fullscreen;
    SDL_SetWindowFullscreen(app->win, app->fullscreen ? SDL_WINDOW_FULLSCREEN_DESKTOP : 0);
}

/* ---------------------------------------------------------------- filters */

/* The graph list, once the filter thread has it. */
static void filter_graphs(struct app *app)
{
    if (!app->ngraphs)
        app->ngraphs = vx_graphs(app->filt, app->graphs, VX_MAX_GRAPHS);
}

/* The chosen graph (the stock "negate" until one is chosen), or NULL. */
static const struct vx_graph *filter_graph(struct app *app, int *slot)
{
    filter_graphs(app);
    if (app->use_named) {
        *slot = VX_MAX_GRAPHS;
        return &app->named;
    }
    if (app->graph < 0)
        for (int i = 0; i < app->ngraphs; i++)
            if (!strcmp(app->graphs[i].id, "negate"))
                app->graph = i;
    if (app->graph < 0 && app->ngraphs)
        app->graph = 0;
    *slot = app->graph;
    return app->graph >= 0 ? &app->graphs[app->graph] : NULL;
}

/* Ask for the chosen graph over the last region (app->job's). */
static void filter_send(struct app *app)
{
    int slot;
    const struct vx_graph *g = filter_graph(app, &slot);
    if (!g) {
        snprintf(app->message, sizeof app->message, "FILTER: THE SERVER LISTS NO GRAPHS");
        return;
    }
    if (!app->param_set[slot]) {
        app->params[slot] = g->def;
        app->param_set[slot] = 1;
    }
    app->job.g = *g;
    app->job.param = app->params[slot];
    snprintf(app->job.image, sizeof app->job.image, "%s", app->want_image);
    app->have_job = 1;
    app->message[0] = 0;
    if (app->a->verbose)
        fprintf(stderr, "view: filter %s level %d region %u,%u,%u,%u param %s=%g\n", g->id,
                app->job.level, app->job.x, app->job.y, app->job.w, app->job.h,
                g->has_param ? g->name : "-", g->has_param ? app->job.param : 0.0);
    vx_run(app->filt, &app->job);
}

/* A Shift-drag ended: filter the level the view shows, over the region
 * of the image under the rectangle (its bounding box when turned), as
 * vsel_region finds it and vsel_draw showed it during the drag. */
static void filter_region(struct app *app)
{
    if (!app->tiles)
        return;
    struct vsel_region r;
    if (vsel_region(&app->in.cur, app->w, app->h, app->in.sel, vt_geometry(app->tiles),
                    vt_top(app->tiles), &r) < 0) {
        snprintf(app->message, sizeof app->message, "FILTER: THE REGION IS OUTSIDE THE IMAGE");
        return;
    }
    app->job.level = r.level;
    app->job.x = r.x;
    app->job.y = r.y;
    app->job.w = r.w;
    app->job.h = r.h;
    filter_send(app);
}

/* Step the chosen graph's first parameter by a tenth of its range (up:
 * +1 or -1) and filter the last region again. */
static void filter_param(struct app *app, int up)
{
    int slot;
    const struct vx_graph *g = filter_graph(app, &slot);
    if (!g || !g->has_param) {
        snprintf(app->message, sizeof app->message, "FILTER %.60s HAS NO PARAMETER",
                 g ? g->id : "");
        return;
    }
    double p = app->param_set[slot] ? app->params[slot] : g->def;
    p += up * (g->max - g->min) / 10;
    app->params[slot] = fmin(g->max, fmax(g->min, p));
    app->param_set[slot] = 1;
    if (app->have_job)
        filter_send(app);
}

/* The next graph of the server's list; the region is filtered again. */
static void filter_next(struct app *app)
{
    int slot;
    filter_graph(app, &slot);
    app->use_named = 0;
    if (app->ngraphs)
        app->graph = (app->graph + 1) % app->ngraphs;
    if (app->have_job)
        filter_send(app);
}

/* Choose graph `id` (script): a listed one, else one the list lacks
 * (whose job the server then refuses or runs); the region is filtered
 * again. */
static void filter_choose(struct app *app, const char *id)
{
    filter_graphs(app);
    app->use_named = 1;
    for (int i = 0; i < app->ngraphs; i++)
        if (!strcmp(app->graphs[i].id, id)) {
            app->graph = i;
            app->use_named = 0;
        }
    if (app->use_named) {
        memset(&app->named, 0, sizeof app->named);
        snprintf(app->named.id, sizeof app->named.id, "%s", id);
        app->param_set[VX_MAX_GRAPHS] = 0;
    }
    if (app->have_job)
        filter_send(app);
}

/* A result of the filter thread. */
static void filter_take(struct app *app, struct vx_result *r)
{
    if (!app->have_job || strcmp(r->job.image, app->want_image)) {
        free(r->rgba);           /* cleared, or another image since */
        return;
    }
    if (!r->ok) {
        fprintf(stderr, ME ": %s\n", r->msg);
        snprintf(app->message, sizeof app->message, "%.90s", r->msg);
    } else {
        const double s = exp2(r->job.level);
        vr_set(app->roi, r->rgba, r->w, r->h, r->job.x * s, r->job.y * s,
               (r->job.x + r->w) * s, (r->job.y + r->h) * s);
        app->have_roi = 1;
        if (app->a->verbose)
            fprintf(stderr, "view: filter %s: %ux%u shown\n", r->job.g.id, r->w, r->h);
    }
    free(r->rgba);
    app->force_draw = 1;
}

static void act(struct app *app, enum vi_action a)
{
    switch (a) {
    case VI_QUIT: app->quit = 1; break;
    case VI_FULLSCREEN: toggle_fullscreen(app); break;
    case VI_SCREENSHOT: {
        static char name[300];
        shot_name(app, name, sizeof name);
        app->shot_path = name;
        break;
    }
    case VI_NEXT_IMAGE:
    case VI_PREV_IMAGE:
        if (app->nids > 1)
            open_image(app, app->ids[(app->cur_id + (a == VI_NEXT_IMAGE ? 1 : app->nids - 1)) %
                                     app->nids]);
        break;
    case VI_TOGGLE_OVERLAY: app->show_overlay = !app->show_overlay; break;
    case VI_TOGGLE_LIST: app->show_list = !app->show_list; break;
    case VI_COPY_VIEW: copy_view(app); break;
    case VI_ROI: filter_region(app); app->force_draw = 1; break;
    case VI_REDRAW: app->force_draw = 1; break;
    case VI_PARAM_UP: filter_param(app, 1); break;
    case VI_PARAM_DOWN: filter_param(app, -1); break;
    case VI_NEXT_FILTER: filter_next(app); break;
    case VI_ROI_CLEAR:
        vr_clear(app->roi);
        app->have_roi = app->have_job = 0;
        app->force_draw = 1;
        break;
    case VI_WIN_BLACK_UP: case VI_WIN_BLACK_DOWN: case VI_WIN_WHITE_DOWN:
    case VI_WIN_WHITE_UP: case VI_WIN_GAMMA_UP: case VI_WIN_GAMMA_DOWN:
    case VI_WIN_AUTO: case VI_WIN_RESET: case VI_WIN_NONE:
        window_key(app, a);
        break;
    case VI_WIN_CHANNEL_NEXT: case VI_WIN_CHANNEL_PREV: {
        const int n = window_channels(app) + 1;   /* every one, then each */
        app->win_ch = (app->win_ch + (a == VI_WIN_CHANNEL_NEXT ? 1 : n - 1)) % n;
        app->force_draw = 1;
        break;
    }
    case VI_NONE: break;
    }
}

/* ---------------------------------------------------------------- script */

static void script_fail(struct app *app, const struct vs_cmd *c, const char *what)
{
    fprintf(stderr, ME ": %s:%d: %s\n", app->a->script, c->line, what);
    app->quit = 1;
    app->rc = 1;
}

static void fake_button(struct app *app, int down, double x, double y, int shift)
{
    SDL_Event e;
    memset(&e, 0, sizeof e);
    e.type = down ? SDL_MOUSEBUTTONDOWN : SDL_MOUSEBUTTONUP;
    e.button.button = SDL_BUTTON_LEFT;
    e.button.clicks = 1;
    e.button.x = (int)lround(x);
    e.button.y = (int)lround(y);
    SDL_SetModState(shift ? KMOD_LSHIFT : KMOD_NONE);
    act(app, vi_event(&app->in, &e));
    SDL_SetModState(KMOD_NONE);
}

static void fake_move(struct app *app, double x, double y)
{
    SDL_Event e;
    memset(&e, 0, sizeof e);
    e.type = SDL_MOUSEMOTION;
    e.motion.x = (int)lround(x);
    e.motion.y = (int)lround(y);
    act(app, vi_event(&app->in, &e));
}

/* Whether the picture is final: at rest, the image the script asked for,
 * and every tile the view needs resident. */
static int settled(const struct app *app)
{
    return app->tiles && !strcmp(vt_image(app->tiles), app->want_image) &&
           !memcmp(&app->in.cur, &app->in.goal, sizeof app->in.cur) &&
           app->st.missing == 0 && app->frames > app->pc_frame + 1 &&
           !vx_busy(app->filt);
}

/* A script command that waits (wait, frames, settle, wait-file, shot):
 * 1 while it still has to wait for later frames, else 0 (also for every
 * other command). */
static int script_blocked(struct app *app, const struct vs_cmd *c, double waited)
{
    switch (c->op) {
    case VS_WAIT:
        if (waited < c->a[0])
            return 1;
        break;
    case VS_FRAMES:
        if (app->frames < app->pc_frame + (uint64_t)c->a[0])
            return 1;
        break;
    case VS_SETTLE:
        if (!settled(app)) {
            if (waited > c->a[0]) {
                char why[160];
                snprintf(why, sizeof why, "the view did not settle: nothing fetched or "
                         "decoded for %.0f ms (%s, %s, %llu tiles missing%s)", waited,
                         app->tiles ? "image open" : "no image",
                         memcmp(&app->in.cur, &app->in.goal, sizeof app->in.cur)
                             ? "moving" : "at rest",
                         (unsigned long long)app->st.missing,
                         vx_busy(app->filt) ? ", a filter job in flight" : "");
                script_fail(app, c, why);
            }
            return 1;
        }
        break;
    case VS_WAIT_FILE:
        if (access(c->text, F_OK) != 0) {
            if (waited > c->a[0])
                script_fail(app, c, "the file did not appear in time");
            return 1;
        }
        break;
    case VS_SHOT:
        if (!app->shot_done) {
            app->shot_path = c->text;
            return 1;          /* written by the next draw */
        }
        app->shot_done = 0;
        break;
    default:
        break;
    }
    return 0;
}

/* A script command that fakes input (keys, mouse, wheel, gamepad, touch):
 * fed to view_input as the live event would be.  Returns 1, or 0 for a
 * command of another kind. */
static int script_input(struct app *app, const struct vs_cmd *c)
{
    switch (c->op) {
    case VS_KEY: {
        SDL_Event e;
        memset(&e, 0, sizeof e);
        e.type = SDL_KEYDOWN;
        e.key.state = SDL_PRESSED;
        e.key.keysym.sym = c->keycode;
        e.key.keysym.mod = (Uint16)((c->shift ? KMOD_LSHIFT : 0) |
                                    (c->ctrl ? KMOD_LCTRL : 0));
        act(app, vi_event(&app->in, &e));
        break;
    }
    case VS_DOWN: fake_button(app, 1, c->a[0], c->a[1], c->shift); break;
    case VS_MOVE: fake_move(app, c->a[0], c->a[1]); break;
    case VS_UP: fake_button(app, 0, c->a[0], c->a[1], 0); break;
    case VS_DRAG: {
        int n = (int)c->a[4];
        fake_button(app, 1, c->a[0], c->a[1], 0);
        for (int i = 1; i <= n; i++)
            fake_move(app, c->a[0] + (c->a[2] - c->a[0]) * i / n,
                      c->a[1] + (c->a[3] - c->a[1]) * i / n);
        fake_button(app, 0, c->a[2], c->a[3], 0);
        break;
    }
    case VS_WHEEL: {
        fake_move(app, c->a[0], c->a[1]);
        SDL_Event e;
        memset(&e, 0, sizeof e);
        e.type = SDL_MOUSEWHEEL;
        e.wheel.y = (Sint32)c->a[2];
        e.wheel.preciseY = (float)c->a[2];
        act(app, vi_event(&app->in, &e));
        break;
    }
    case VS_PAD_AXIS:
    case VS_PAD_BUTTON: {
        SDL_Event e;
        memset(&e, 0, sizeof e);
        if (c->op == VS_PAD_AXIS) {
            e.type = SDL_CONTROLLERAXISMOTION;
            e.caxis.axis = (Uint8)c->code;
            e.caxis.value = (Sint16)lround(c->a[0] * 32767);
            act(app, vi_event(&app->in, &e));
        } else {
            e.type = SDL_CONTROLLERBUTTONDOWN;
            e.cbutton.button = (Uint8)c->code;
            e.cbutton.state = SDL_PRESSED;
            act(app, vi_event(&app->in, &e));
            e.type = SDL_CONTROLLERBUTTONUP;
            e.cbutton.state = SDL_RELEASED;
            act(app, vi_event(&app->in, &e));
        }
        break;
    }
    case VS_PINCH: {
        SDL_Event e;
        memset(&e, 0, sizeof e);
        e.type = SDL_MULTIGESTURE;
        e.mgesture.x = (float)(c->a[0] * app->in.ratio / app->w);
        e.mgesture.y = (float)(c->a[1] * app->in.ratio / app->h);
        e.mgesture.dDist = (float)c->a[2];
        e.mgesture.dTheta = (float)(c->a[3] * M_PI / 180);
        e.mgesture.numFingers = 2;
        act(app, vi_event(&app->in, &e));
        break;
    }
    case VS_TOUCH: {
        /* One finger down at (a0, a1), N moves to (a2, a3), up. */
        SDL_Event e;
        memset(&e, 0, sizeof e);
        const double ww = app->w / app->in.ratio, wh = app->h / app->in.ratio;
        int n = (int)c->a[4];
        e.type = SDL_FINGERDOWN;
        e.tfinger.x = (float)(c->a[0] / ww);
        e.tfinger.y = (float)(c->a[1] / wh);
        act(app, vi_event(&app->in, &e));
        for (int i = 1; i <= n; i++) {
            e.type = SDL_FINGERMOTION;
            e.tfinger.dx = (float)((c->a[2] - c->a[0]) / n / ww);
            e.tfinger.dy = (float)((c->a[3] - c->a[1]) / n / wh);
            e.tfinger.x = (float)((c->a[0] + (c->a[2] - c->a[0]) * i / n) / ww);
            e.tfinger.y = (float)((c->a[1] + (c->a[3] - c->a[1]) * i / n) / wh);
            act(app, vi_event(&app->in, &e));
        }
        e.type = SDL_FINGERUP;
        e.tfinger.dx = e.tfinger.dy = 0;
        act(app, vi_event(&app->in, &e));
        break;
    }
    default:
        return 0;
    }
    return 1;
}

/* Any other script command: views, images, prints, quit, filters. */
static void script_action(struct app *app, const struct vs_cmd *c)
{
    switch (c->op) {
    case VS_VIEW:
        if (c->view_image[0] && strcmp(c->view_image, app->want_image))
            open_image(app, c->view_image);
        if (!app->tiles || strcmp(vt_image(app->tiles), app->want_image)) {
            /* Taken when the image comes. */
            app->have_start_view = 1;
            app->start_view = c->view;
        } else {
            vi_jump(&app->in, &c->view);
        }
        break;
    case VS_IMAGE: open_image(app, c->text); break;
    case VS_PRINT: {
        char link[1024], win[GV_WINDOW_MAX_CHANNELS * 32];
        link_window(app, win, sizeof win);
        vg_format_hash(app->want_image, &app->in.cur, win, link, sizeof link);
        printf("%s %s\n", c->text, link);
        fflush(stdout);
        break;
    }
    case VS_QUIT: app->quit = 1; break;
    case VS_MESSAGE:
        printf("%s %s\n", c->text, app->message);
        fflush(stdout);
        break;
    case VS_FILTER:
        app->in.sel[0] = c->a[0] * app->in.ratio;
        app->in.sel[1] = c->a[1] * app->in.ratio;
        app->in.sel[2] = c->a[2] * app->in.ratio;
        app->in.sel[3] = c->a[3] * app->in.ratio;
        filter_region(app);
        break;
    case VS_GRAPH:
        if (!strcmp(c->text, "next"))
            filter_next(app);
        else
            filter_choose(app, c->text);
        break;
    case VS_PARAM: filter_param(app, c->a[0] > 0 ? 1 : -1); break;
    case VS_COUNTERS: {
        char win[GV_WINDOW_MAX_CHANNELS * 32] = "none";
        if (app->dwin.count)
            gv_window_format(&app->dwin, win, sizeof win);
        printf("%s fetched=%llu decodes=%llu window=%s\n", c->text,
               (unsigned long long)app->st.fetched,
               (unsigned long long)app->st.decodes, win);
        fflush(stdout);
        break;
    }
    case VS_WINDOW: {
        struct gv_error err = {0};
        struct gv_window w = {0};
        if (strcmp(c->text, "none") != 0 &&
            gv_window_parse(c->text, app->wmax ? app->wmax : 255, &w, &err) < 0) {
            fprintf(stderr, ME ": script line %d: %s\n", c->line, err.text);
            app->quit = 1;
            app->rc = 2;
        } else {
            window_set(app, &w);
        }
        break;
    }
    default:
        break;
    }
}

/* Run script commands until one has to wait for later frames. */
static void script_step(struct app *app, double now)
{
    while (app->pc < app->script.n && !app->quit) {
        const struct vs_cmd *c = &app->script.cmd[app->pc];
        if (c->op == VS_SETTLE) {
            /* settle's bound is on time without progress: a tile fetched
             * or decoded starts it again, so that a loaded machine, slow
             * but not stuck, still settles. */
            const uint64_t p = app->st.fetched + app->st.decodes;
            if (p != app->settle_progress) {
                app->settle_progress = p;
                app->pc_since = now;
            }
        }
        double waited = (now - app->pc_since) * 1000;
        if (script_blocked(app, c, waited))
            return;
        if (!script_input(app, c))
            script_action(app, c);
        app->pc++;
        app->pc_since = now;
        app->pc_frame = app->frames;
    }
    if (app->pc >= app->script.n)
        app->quit = 1;
}

/* ---------------------------------------------------------------- frames */

static void overlay_content(struct app *app, const struct vt_plan *p,
                            struct vo_content *c)
{
    memset(c, 0, sizeof *c);
    const struct vg_view *v = &app->in.cur;
    const struct gv_gpu_info *gi = gv_gpu_info(app->gpu);
    double mag = exp2(-v->zoom);
    char win[GV_WINDOW_MAX_CHANNELS * 32] = "";
    if (app->dwin.count)
        gv_window_format(&app->dwin, win, sizeof win);
    char keys_on[16] = "";
    if (app->win_ch)
        snprintf(keys_on, sizeof keys_on, "  KEYS CH %d", app->win_ch);
    snprintf(c->bottom[0], VO_LINE, "ZOOM %s%.3g  LEVEL %d%s  ROT %.1f%s%.40s%s",
             mag >= 1 ? "" : "1:", mag >= 1 ? mag : 1 / mag, p->f,
             p->t > 0 ? "+" : "", vg_norm_rot(v->rot), win[0] ? "  WINDOW " : "",
             win, keys_on);
    if (app->tiles) {
        const struct gv_geometry *g = vt_geometry(app->tiles);
        snprintf(c->bottom[1], VO_LINE, "%.40s  %ux%u  [%d/%d]", vt_image(app->tiles),
                 g->width, g->height, app->cur_id + 1, app->nids);
    }
    size_t flight = vf_in_flight(app->fetch);
    if (!app->tiles || app->st.missing || flight) {
        static const char spin[] = "|/-*";
        snprintf(c->bottom[2], VO_LINE, "LOADING %c %zu TILES", spin[(app->frames / 8) % 4],
                 app->st.missing + flight);
    }
    snprintf(c->bottom[3], VO_LINE, "%.70s  DECODE %s", gi->renderer,
             app->dgpu ? "THREAD" : "IN FRAME");
    if (app->message[0])
        snprintf(c->bottom[4], VO_LINE, "%.90s", app->message);
    if (app->have_job) {
        const struct vx_graph *g = &app->job.g;
        char prm[100] = "";
        if (g->has_param)
            snprintf(prm, sizeof prm, "  %.30s %.4g (PGUP/PGDN)", g->name, app->job.param);
        snprintf(c->bottom[5], VO_LINE, "FILTER %.30s%s%s", g->id, prm,
                 vx_busy(app->filt) ? "  RUNNING" : "");
    }
    vg_scale_bar(v->zoom, app->mpp, app->w / 5.0, &c->bar_px, c->bar_label,
                 sizeof c->bar_label);
    if (app->show_list) {
        snprintf(c->panel[c->npanel++], VO_LINE, "IMAGES (TAB: NEXT)");
        for (int i = 0; i < app->nids && c->npanel < VO_LINES; i++)
            snprintf(c->panel[c->npanel++], VO_LINE, "%s %.60s",
                     i == app->cur_id ? ">" : " ", app->ids[i]);
    }
}

static void write_shot(struct app *app)
{
    const struct gv_header hdr = gv_remote_header(&app->img);
    const int ch = app->tiles ? gv_display_channels(&hdr) : 3;
    uint8_t *px = malloc((size_t)app->w * app->h * ch);
    struct gv_error err = {0};
    if (!px) {
        fprintf(stderr, ME ": out of memory for a screenshot\n");
    } else {
        vd_read(app->w, app->h, ch, px);
        if (gv_image_write(app->shot_path, (uint32_t)app->w, (uint32_t)app->h, ch, px,
                           &err) < 0) {
            fprintf(stderr, ME ": %s\n", err.text);
            if (app->script.n) {
                app->quit = 1;
                app->rc = 1;
            }
        } else if (app->a->verbose || !app->script.n) {
            fprintf(stderr, "view: wrote %s\n", app->shot_path);
        }
    }
    free(px);
    app->shot_path = NULL;
    app->shot_done = 1;
}

static void record(struct app *app, double ms, int moving)
{
    if (app->stats)
        fprintf(app->stats, "%llu\t%.3f\t%d\t%zu\t%zu\t%llu\t%.3f\t%llu\t%d\n",
                (unsigned long long)app->frames, ms, moving, app->st.needed,
                app->st.missing, (unsigned long long)app->st.decodes,
                app->st.decode_ms, (unsigned long long)app->st.published,
                app->st.inflight);
    if (!moving)
        return;
    if (app->nft == app->capft) {
        size_t cap = app->capft ? 2 * app->capft : 1024;
        double *n = realloc(app->ft, cap * sizeof *n);
        if (!n)
            return;
        app->ft = n;
        app->capft = cap;
    }
    app->ft[app->nft++] = ms;
}

/* One frame.  Returns whether anything is still to do (animation,
 * tiles, a script): the loop sleeps otherwise. */
static int frame(struct app *app, double *last)
{
    const double t0 = now_s();
    double dt = t0 - *last;
    *last = t0;
    const struct vg_view before = app->in.cur;   /* events and the script move it */
    SDL_Event e;
    while (SDL_PollEvent(&e)) {
        if (e.type == SDL_WINDOWEVENT) {
            app->force_draw = 1;     /* exposed, resized, shown */
            continue;
        }
        act(app, vi_event(&app->in, &e));
    }
    if (app->script.n)
        script_step(app, t0);
    struct vf_result r;
    while (vf_poll(app->fetch, &r))
        take_result(app, &r, t0);
    struct vx_result fr;
    while (vx_poll(app->filt, &fr))
        filter_take(app, &fr);
    if (app->quit)
        return 0;
    int ww, wh;
    SDL_GL_GetDrawableSize(app->win, &app->w, &app->h);
    SDL_GetWindowSize(app->win, &ww, &wh);
    app->in.w = app->w;
    app->in.h = app->h;
    app->in.ratio = ww > 0 ? (double)app->w / ww : 1;
    int moving = vi_step(&app->in, dt > 0.1 ? 0.1 : dt);
    /* A drag moves the view without an animation. */
    moving |= memcmp(&before, &app->in.cur, sizeof before) != 0;
    struct vt_plan p = {0};
    if (app->tiles) {
        vt_plan_view(app->tiles, &app->in.cur, app->w, app->h, &p);
        vt_frame(app->tiles, &p, app->in.cur.cx - before.cx, app->in.cur.cy - before.cy,
                 app->fetch, t0, &app->st);
        app->decode_ms += app->st.decode_ms;
        if (app->st.errors > app->errors_shown)   /* as fetch errors are */
            snprintf(app->message, sizeof app->message, "%.90s", app->st.error);
        app->errors_shown = app->st.errors;
    }
    struct vo_content c;
    if (app->show_overlay)
        overlay_content(app, &p, &c);
    /* Draw only what changed: the view, the resident tiles, the image,
     * the window, the overlay, or a screenshot due. */
    int dirty = app->force_draw || app->shot_path || app->tiles != app->drawn_tiles ||
                memcmp(&app->in.cur, &app->drawn_view, sizeof app->drawn_view) ||
                app->st.published != app->drawn_published || app->w != app->drawn_w ||
                app->h != app->drawn_h || app->show_overlay != app->drawn_overlay ||
                (app->show_overlay && memcmp(&c, &app->drawn_content, sizeof c));
    if (dirty) {
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        glViewport(0, 0, app->w, app->h);
        glClearColor(0, 0, 0, 1);
        glClear(GL_COLOR_BUFFER_BIT);
        if (app->tiles && p.visible)
            vd_draw(app->draw, app->tiles, &p, &app->in.cur, app->w, app->h);
        if (app->tiles && app->have_roi)
            vr_draw(app->roi, &app->in.cur, app->w, app->h);
        struct vsel_region sr;
        if (app->tiles && app->in.selecting &&
            vsel_region(&app->in.cur, app->w, app->h, app->in.sel, vt_geometry(app->tiles),
                        vt_top(app->tiles), &sr) == 0)
            vsel_draw(app->sel, &app->in.cur, app->w, app->h, &sr);
        if (app->shot_path && app->tiles)
            write_shot(app);
        if (app->show_overlay)
            vo_draw(app->overlay, app->w, app->h, &c);
        SDL_GL_SwapWindow(app->win);
        if (app->stats)
            glFinish();          /* time the frame's GPU work too */
        app->drawn_tiles = app->tiles;
        app->drawn_view = app->in.cur;
        app->drawn_published = app->st.published;
        app->drawn_w = app->w;
        app->drawn_h = app->h;
        app->drawn_overlay = app->show_overlay;
        if (app->show_overlay)
            app->drawn_content = c;
        app->force_draw = 0;
        app->draws++;
    }
    app->frames++;
    record(app, (now_s() - t0) * 1000, moving);
    if (moving)
        app->moving_time += dt;
    return moving || !app->tiles || app->st.missing || app->st.wanted || app->st.inflight ||
           vf_in_flight(app->fetch) || app->script.n || app->shot_path ||
           vx_busy(app->filt);
}

/* ---------------------------------------------------------------- setup */

static int parse_size(const char *s, int *w, int *h)
{
    char x;
    int n = 0;
    if (sscanf(s, "%d%c%d%n", w, &x, h, &n) != 3 || x != 'x' || s[n] || *w < 16 ||
        *h < 16 || *w > 16384 || *h > 16384)
        return -1;
    return 0;
}

/* The window and its GL context: OpenGL ES 3.2, else OpenGL 4.3 core. */
static int open_window(struct app *app, int w, int h)
{
    static const int want[][3] = {{SDL_GL_CONTEXT_PROFILE_ES, 3, 2},
                                  {SDL_GL_CONTEXT_PROFILE_CORE, 4, 3}};
    SDL_SetHint(SDL_HINT_VIDEO_X11_FORCE_EGL, "1");
    SDL_SetHint(SDL_HINT_VIDEO_HIGHDPI_DISABLED, "0");
    if (SDL_Init(SDL_INIT_VIDEO | SDL_INIT_EVENTS) != 0) {
        fprintf(stderr, ME ": cannot start SDL video: %s\n", SDL_GetError());
        return -1;
    }
    if (SDL_InitSubSystem(SDL_INIT_GAMECONTROLLER) != 0 && app->a->verbose)
        fprintf(stderr, "view: no gamepad support: %s\n", SDL_GetError());
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++) {
        SDL_GL_ResetAttributes();
        SDL_GL_SetAttribute(SDL_GL_CONTEXT_PROFILE_MASK, want[i][0]);
        SDL_GL_SetAttribute(SDL_GL_CONTEXT_MAJOR_VERSION, want[i][1]);
        SDL_GL_SetAttribute(SDL_GL_CONTEXT_MINOR_VERSION, want[i][2]);
        SDL_GL_SetAttribute(SDL_GL_DOUBLEBUFFER, 1);
        SDL_GL_SetAttribute(SDL_GL_RED_SIZE, 8);
        SDL_GL_SetAttribute(SDL_GL_GREEN_SIZE, 8);
        SDL_GL_SetAttribute(SDL_GL_BLUE_SIZE, 8);
        Uint32 flags = SDL_WINDOW_OPENGL | SDL_WINDOW_RESIZABLE | SDL_WINDOW_ALLOW_HIGHDPI |
                       (app->fullscreen ? SDL_WINDOW_FULLSCREEN_DESKTOP : 0);
        app->win = SDL_CreateWindow("gigaview", SDL_WINDOWPOS_CENTERED,
                                    SDL_WINDOWPOS_CENTERED, w, h, flags);
        if (app->win && (app->glc = SDL_GL_CreateContext(app->win)))
            break;
        if (app->win)
            SDL_DestroyWindow(app->win);
        app->win = NULL;
    }
    if (!app->win) {
        fprintf(stderr, ME ": no window with OpenGL ES 3.2 or OpenGL 4.3: %s\n",
                SDL_GetError());
        return -1;
    }
    /* The offscreen driver accepts a swap interval but never waits. */
    app->vsync = !app->a->no_vsync && SDL_GL_SetSwapInterval(1) == 0 &&
                 strcmp(SDL_GetCurrentVideoDriver(), "offscreen") != 0;
    if (!app->vsync)
        SDL_GL_SetSwapInterval(0);
    struct gv_error err = {0};
    if (!(app->gpu = gv_gpu_adopt(&err)) || !(app->draw = vd_new(app->gpu, &err)) ||
        !(app->overlay = vo_new(app->gpu, &err)) || !(app->roi = vr_new(app->gpu, &err)) ||
        !(app->sel = vsel_new(app->gpu, &err))) {
        fprintf(stderr, ME ": %s\n", err.text);
        return -1;
    }
    /* The decode thread's context, sharing the window's objects; where
     * none can be made (no EGL behind the window, no surfaceless
     * contexts), tiles are decoded in the frame. */
    if (!app->a->no_decode_thread && !(app->dgpu = gv_gpu_open_shared(&err)))
        fprintf(stderr, "view: decoding tiles in the frame (no decode thread): %s\n",
                err.text);
    SDL_SetWindowTitle(app->win, "gigaview");
    if (app->a->verbose)
        fprintf(stderr, "view: %s, %s%s\n", gv_gpu_info(app->gpu)->renderer,
                gv_gpu_info(app->gpu)->version, app->vsync ? ", vsync" : "");
    return 0;
}

static void close_app(struct app *app)
{
    vf_free(app->fetch);         /* first: no more results */
    vx_free(app->filt);
    vr_free(app->roi);
    vsel_free(app->sel);
    vt_free(app->tiles);
    free(app->root_px);
    free(app->tables);
    vo_free(app->overlay);
    vd_free(app->draw);
    gv_gpu_close(app->dgpu);     /* after vt_free joined the decode thread */
    gv_gpu_close(app->gpu);
    if (app->in.pad)
        SDL_GameControllerClose(app->in.pad);
    if (app->glc)
        SDL_GL_DeleteContext(app->glc);
    if (app->win)
        SDL_DestroyWindow(app->win);
    SDL_Quit();
    vs_free(&app->script);
    if (app->stats)
        fclose(app->stats);
    free(app->ft);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* --stats: the summary of the frames drawn while the view moved. */
static void summary(struct app *app, double elapsed)
{
    struct gv_http_stats hs;
    vf_stats(app->fetch, &hs);
    qsort(app->ft, app->nft, sizeof *app->ft, cmp_double);
    double p50 = app->nft ? app->ft[app->nft / 2] : 0;
    double p99 = app->nft ? app->ft[(size_t)((app->nft - 1) * 0.99)] : 0;
    double mx = app->nft ? app->ft[app->nft - 1] : 0;
    fprintf(stderr, "view: %llu frames (%llu drawn) in %.2f s, %zu while moving: p50 %.2f ms, "
            "p99 %.2f ms, max %.2f ms; %llu tiles decoded (%.1f/s), %llu "
            "prefetched, %llu atlas evictions, %llu failed fetches; decode %s, "
            "%.1f ms of it on the render thread; http: %llu "
            "requests, %llu bytes; renderer %s\n",
            (unsigned long long)app->frames, (unsigned long long)app->draws, elapsed,
            app->nft, p50, p99, mx,
            (unsigned long long)app->st.decodes,
            elapsed > 0 ? app->st.decodes / elapsed : 0,
            (unsigned long long)app->st.prefetched,
            (unsigned long long)app->st.evictions,
            (unsigned long long)app->st.failures,
            app->dgpu ? "thread" : "in frame", app->decode_ms,
            (unsigned long long)hs.requests, (unsigned long long)hs.bytes,
            gv_gpu_info(app->gpu)->renderer);
}

static int start(struct app *app, const char *url, struct view_args *a)
{
    struct gv_error err = {0};
    int w = 1280, h = 720;
    if (a->size && parse_size(a->size, &w, &h) < 0) {
        fprintf(stderr, ME ": --size wants WxH (16 to 16384 each), not '%s'\n", a->size);
        return 2;
    }
    char view_image[129] = "";
    if (a->view) {
        if (vg_parse(a->view, &app->start_view, view_image, sizeof view_image) < 0) {
            fprintf(stderr, ME ": --view wants CX,CY,ZOOM[,ROT] or a browser link's "
                    "#image=ID&x=..&y=..&z=..&r=.., not '%s'\n", a->view);
            return 2;
        }
        app->have_start_view = 1;
        /* The link's window, unless --window says otherwise. */
        struct gv_window lw;
        int lr = vg_hash_window(a->view, app->link_window, sizeof app->link_window);
        if (lr < 0 || (lr > 0 && app->link_window[0] && strcmp(app->link_window, "none") != 0 &&
                       gv_window_parse(app->link_window, 65535, &lw, &err) < 0)) {
            fprintf(stderr, ME ": --view: the link's window: %s\n",
                    err.text[0] ? err.text : "malformed or too long");
            return 2;
        }
        if (a->window)
            app->link_window[0] = 0;
    }
    if (a->script && vs_load(a->script, &app->script, &err) < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
        return 2;
    }
    if (a->stats && !(app->stats = fopen(a->stats, "w"))) {
        fprintf(stderr, ME ": cannot write %s\n", a->stats);
        return 1;
    }
    if (app->stats)
        fprintf(app->stats, "frame\tms\tmoving\tneeded\tmissing\tdecodes\t"
                "decode_ms\tpublished\tinflight\n");
    if (list_images(app, url, &err) < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
        return 1;
    }
    const char *id = a->image ? a->image : view_image[0] ? view_image : app->nids ? app->ids[0] : NULL;
    if (!id) {
        fprintf(stderr, ME ": the server at %s has no images\n", url);
        return 1;
    }
    struct vf_options fo = {.url = url, .timeout_ms = remote_timeout_ms(&a->remote),
                            .cache_dir = a->remote.cache_dir, .no_cache = a->remote.no_cache,
                            .no_batch = a->no_batch, .verbose = a->verbose};
    if (!(app->fetch = vf_new(&fo, &err))) {
        fprintf(stderr, ME ": %s\n", err.text);
        return 1;
    }
    if (!(app->filt = vx_new(url, remote_timeout_ms(&a->remote), a->verbose, &err))) {
        fprintf(stderr, ME ": %s\n", err.text);
        return 1;
    }
    app->graph = -1;
    if (open_window(app, w, h) < 0)
        return 1;
    SDL_GL_GetDrawableSize(app->win, &app->w, &app->h);
    struct vg_view v0 = {0, 0, 0, 0};
    vi_init(&app->in, &v0, 1, 1, app->w, app->h);
    open_image(app, id);
    return OPT_GO_ON;
}

int cmd_view(int argc, char **argv)
{
    struct view_args a = {.budget = 4, .budget_ms = 6};
    remote_opts_init(&a.remote);
    int first, rc = opt_parse(&view_command, argc, argv, &a, &first);
    if (rc != OPT_GO_ON)
        return rc;
    if (argc - first != 1) {
        opt_usage(&view_command, stderr);
        return 2;
    }
    struct gv_window w;
    struct gv_error werr = {0};
    if (a.window && strcmp(a.window, "none") != 0 &&
        gv_window_parse(a.window, 255, &w, &werr) < 0) {
        fprintf(stderr, ME ": --window: %s\n", werr.text);
        return 2;
    }
    struct app *app = calloc(1, sizeof *app);
    if (!app) {
        fprintf(stderr, ME ": out of memory\n");
        return 1;
    }
    app->a = &a;
    app->show_overlay = !a.no_overlay;
    app->fullscreen = a.fullscreen;
    rc = start(app, argv[first], &a);
    if (rc == OPT_GO_ON) {
        double t0 = now_s(), last = t0;
        app->t_start = t0;
        app->pc_since = t0;
        while (!app->quit) {
            int busy = frame(app, &last);
            if (!busy && !app->quit)
                SDL_WaitEventTimeout(NULL, 100);
            else if (!app->vsync && !app->quit) {
                /* No vsync: pace at about 60 frames a second. */
                double left = 1.0 / 60 - (now_s() - last);
                if (left > 0)
                    SDL_Delay((Uint32)(left * 1000));
            }
        }
        if (app->stats || a.verbose)
            summary(app, now_s() - t0);
        rc = app->rc;
    }
    close_app(app);
    free(app);
    return rc;
}

#else /* no GPU or no SDL2 */

int cmd_view(int argc, char **argv)
{
    (void)argc;
    (void)argv;
#ifndef GV_HAVE_GPU
    fprintf(stderr, ME ": needs a build with GPU support (this gigaview was "
            "configured --without-gpu)\n");
#else
    fprintf(stderr, ME ": needs a build with SDL2 (this gigaview was built without "
            "it: install libsdl2-dev and configure again)\n");
#endif
    return 1;
}

#endif
