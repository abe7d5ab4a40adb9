/*
 * view_script.c - reading `gigaview view --script` files (view_script.h).
 * The file is outside input: lines and numbers are bounded, every number
 * must be finite and in range, and the first fault stops the parse with
 * its line number.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <SDL.h>

#include "view_script.h"

#define VS_STR_(x) #x
#define VS_STR(x) VS_STR_(x)

#define MAX_SIZE (16 << 20)

static const struct {
    const char *name;
    enum vs_op op;
    int nmin, nmax;              /* numbers taken (text commands: -1) */
} ops[] = {
    {"wait", VS_WAIT, 1, 1},         {"frames", VS_FRAMES, 1, 1},
    {"key", VS_KEY, -1, -1},         {"down", VS_DOWN, 2, 2},
    {"move", VS_MOVE, 2, 2},         {"up", VS_UP, 2, 2},
    {"drag", VS_DRAG, 4, 5},         {"wheel", VS_WHEEL, 3, 3},
    {"view", VS_VIEW, -1, -1},       {"image", VS_IMAGE, -1, -1},
    {"settle", VS_SETTLE, 0, 1},     {"shot", VS_SHOT, -1, -1},
    {"wait-file", VS_WAIT_FILE, -1, -1}, {"print", VS_PRINT, -1, -1},
    {"quit", VS_QUIT, 0, 0},
    {"filter", VS_FILTER, 4, 4},     {"graph", VS_GRAPH, -1, -1},
    {"param", VS_PARAM, -1, -1},     {"pad-axis", VS_PAD_AXIS, -1, -1},
    {"pad-button", VS_PAD_BUTTON, -1, -1}, {"pinch", VS_PINCH, 4, 4},
    {"touch", VS_TOUCH, 4, 5},       {"message", VS_MESSAGE, -1, -1},
    {"counters", VS_COUNTERS, -1, -1}, {"window", VS_WINDOW, -1, -1},
};

void vs_free(struct vs_script *s)
{
    for (size_t i = 0; i < s->n; i++)
        free(s->cmd[i].text);
    free(s->cmd);
    s->cmd = NULL;
    s->n = 0;
}

/* Split off the next word of *p (spaces and tabs between words). */
static char *word(char **p)
{
    char *s = *p + strspn(*p, " \t");
    if (!*s)
        return NULL;
    char *e = s + strcspn(s, " \t");
    if (*e)
        *e++ = 0;
    *p = e;
    return s;
}

/* A decimal number ("-12", "0.5", "1e3"): strtod alone would also take
 * leading white space, hex, "infinity" and "nan". */
static int num(const char *w, double *out)
{
    char *end;
    if (w[strspn(w, "0123456789+-.eE")])
        return -1;
    errno = 0;
    double x = strtod(w, &end);
    if (end == w || *end || !isfinite(x) || fabs(x) > 1e9)
        return -1;
    *out = x;
    return 0;
}

/* "shift+ctrl+Right" -> keycode and modifiers. */
static int key_name(const char *w, struct vs_cmd *c)
{
    for (;;) {
        if (!SDL_strncasecmp(w, "shift+", 6))
            c->shift = 1, w += 6;
        else if (!SDL_strncasecmp(w, "ctrl+", 5))
            c->ctrl = 1, w += 5;
        else
            break;
    }
    SDL_Keycode k = SDL_GetKeyFromName(w);
    if (k == SDLK_UNKNOWN && strlen(w) == 1 && (unsigned char)w[0] < 128)
        k = (SDL_Keycode)(unsigned char)w[0];
    if (k == SDLK_UNKNOWN)
        return -1;
    if (k >= 'A' && k <= 'Z')
        k += 'a' - 'A';
    c->keycode = (int)k;
    return 0;
}

/* The text argument of shot, image, wait-file, print, graph, message,
 * counters and window (print, message and counters: the rest of the line) from *p into c->text.
 * Returns 1, or -1 with *why. */
static int parse_text(char *p, struct vs_cmd *c, const char **why)
{
    const int rest = c->op == VS_PRINT || c->op == VS_MESSAGE ||
                     c->op == VS_COUNTERS;
    char *t = rest ? p + strspn(p, " \t") : word(&p);
    if (!t || (!*t && !rest)) {
        *why = "a name is missing";
        return -1;
    }
    if (c->op == VS_WAIT_FILE) {
        c->a[0] = 60000;
        char *ms = word(&p);
        if (ms && (num(ms, &c->a[0]) < 0 || c->a[0] < 0)) {
            *why = "wait-file wants PATH [MS]";
            return -1;
        }
    }
    if (!rest && word(&p)) {
        *why = "too many arguments";
        return -1;
    }
    if (!(c->text = strdup(t))) {
        *why = "out of memory";
        return -1;
    }
    return 1;
}

/* Parse one line (modified in place) into c.  Returns 1 for a command, 0
 * for a blank or comment line, -1 with *why. */
static int parse_line(char *line, struct vs_cmd *c, const char **why)
{
    char *hash = strchr(line, '#');
    char *p = line;
    char *w = word(&p);
    if (!w || *w == '#')
        return 0;
    size_t i;
    for (i = 0; i < sizeof ops / sizeof ops[0]; i++)
        if (!strcmp(w, ops[i].name))
            break;
    if (i == sizeof ops / sizeof ops[0]) {
        *why = "unknown command";
        return -1;
    }
    c->op = ops[i].op;
    if (c->op == VS_VIEW) {
        /* The hash's '#' is not a comment here. */
        char *spec = word(&p);
        if (!spec || vg_parse(spec, &c->view, c->view_image, sizeof c->view_image) < 0) {
            *why = "view wants CX,CY,ZOOM[,ROT] or a #image=... hash";
            return -1;
        }
        char *more = word(&p);
        return more && *more != '#' ? (*why = "view takes one argument", -1) : 1;
    }
    if (hash)
        *hash = 0;
    if (c->op == VS_KEY) {
        char *k = word(&p);
        if (!k || word(&p) || key_name(k, c) < 0) {
            *why = "key wants one SDL key name";
            return -1;
        }
        return 1;
    }
    if (c->op == VS_PARAM) {
        char *sgn = word(&p);
        if (!sgn || word(&p) || (strcmp(sgn, "+") && strcmp(sgn, "-"))) {
            *why = "param wants + or -";
            return -1;
        }
        c->a[0] = *sgn == '+' ? 1 : -1;
        return 1;
    }
    if (c->op == VS_PAD_AXIS || c->op == VS_PAD_BUTTON) {
        char *name = word(&p), *v = c->op == VS_PAD_AXIS ? word(&p) : NULL;
        c->code = c->op == VS_PAD_AXIS ? (int)SDL_GameControllerGetAxisFromString(name ? name : "")
                                       : (int)SDL_GameControllerGetButtonFromString(name ? name : "");
        if (!name || c->code < 0 || word(&p) ||
            (c->op == VS_PAD_AXIS && (!v || num(v, &c->a[0]) < 0 || fabs(c->a[0]) > 1))) {
            *why = c->op == VS_PAD_AXIS ? "pad-axis wants an SDL axis name and -1..1"
                                        : "pad-button wants an SDL button name";
            return -1;
        }
        return 1;
    }
    if (c->op == VS_SHOT || c->op == VS_IMAGE || c->op == VS_WAIT_FILE ||
        c->op == VS_PRINT || c->op == VS_GRAPH || c->op == VS_MESSAGE ||
        c->op == VS_COUNTERS || c->op == VS_WINDOW)
        return parse_text(p, c, why);
    int n = 0;
    if (c->op == VS_SETTLE)
        c->a[0] = 60000;
    if (c->op == VS_DRAG || c->op == VS_TOUCH)
        c->a[4] = 8;
    while ((w = word(&p))) {
        if (c->op == VS_DOWN && n == 2 && !c->shift && !strcmp(w, "shift")) {
            c->shift = 1;
            continue;
        }
        if (n == ops[i].nmax || num(w, &c->a[n]) < 0) {
            *why = n == ops[i].nmax ? "too many arguments" : "not a number";
            return -1;
        }
        n++;
    }
    if (n < ops[i].nmin) {
        *why = "too few arguments";
        return -1;
    }
    if ((c->op == VS_WAIT || c->op == VS_SETTLE || c->op == VS_FRAMES) && c->a[0] < 0) {
        *why = "a negative count";
        return -1;
    }
    if (c->op == VS_FRAMES && c->a[0] != floor(c->a[0])) {
        *why = "frames wants a whole number";
        return -1;
    }
    if ((c->op == VS_DRAG || c->op == VS_TOUCH) &&
        (c->a[4] < 1 || c->a[4] > 1000 || c->a[4] != floor(c->a[4]))) {
        *why = "drag and touch take 1 to 1000 moves";
        return -1;
    }
    if (c->op == VS_PINCH && (c->a[2] <= -0.25)) {
        *why = "pinch's DDIST must be above -0.25";
        return -1;
    }
    return 1;
}

int vs_parse(const char *text, const char *name, struct vs_script *s,
             struct gv_error *err)
{
    memset(s, 0, sizeof *s);
    size_t cap = 0;
    int lineno = 0;
    for (const char *p = text; *p;) {
        size_t len = strcspn(p, "\n");
        lineno++;
        if (len >= VS_MAX_LINE)
            return gv_fail(err, GV_EINVAL, "%s:%d: line too long", name, lineno);
        char line[VS_MAX_LINE];
        memcpy(line, p, len);
        line[len] = 0;
        if (len && line[len - 1] == '\r')
            line[len - 1] = 0;
        p += len + (p[len] == '\n');
        struct vs_cmd c;
        memset(&c, 0, sizeof c);
        c.line = lineno;
        const char *why = NULL;
        int rc = parse_line(line, &c, &why);
        if (rc > 0 && s->n == VS_MAX_CMDS)
            rc = -1, why = "more than " VS_STR(VS_MAX_CMDS) " commands";
        if (rc < 0) {
            free(c.text);
            return gv_fail(err, GV_EINVAL, "%s:%d: %s", name, lineno, why);
        }
        if (rc == 0)
            continue;
        if (s->n == cap) {
            /* Grown by half, so that a script near the limit holds
             * little spare room. */
            size_t nc = cap ? cap + cap / 2 : 32;
            struct vs_cmd *m = realloc(s->cmd, nc * sizeof *m);
            if (!m) {
                free(c.text);
                return gv_fail(err, GV_ENOMEM, "out of memory");
            }
            s->cmd = m;
            cap = nc;
        }
        s->cmd[s->n++] = c;
    }
    return 0;
}

int vs_load(const char *path, struct vs_script *s, struct gv_error *err)
{
    memset(s, 0, sizeof *s);
    FILE *f = fopen(path, "rb");
    if (!f)
        return gv_fail(err, GV_EIO, "%s: %s", path, strerror(errno));
    /* Read in a buffer that grows to what the file holds (a script is
     * usually a few KiB), one byte past the limit to see it exceeded. */
    char *buf = NULL;
    size_t n = 0, cap = 0;
    int rc = 0;
    for (;;) {
        if (n == cap) {
            size_t nc = cap ? 2 * cap : 1 << 16;
            if (nc > MAX_SIZE + 1)
                nc = MAX_SIZE + 1;
            char *m = nc > cap ? realloc(buf, nc + 1) : NULL;
            if (!m) {
                rc = nc > cap ? gv_fail(err, GV_ENOMEM, "out of memory")
                              : gv_fail(err, GV_EINVAL, "%s: larger than 16 MiB", path);
                goto done;
            }
            buf = m;
            cap = nc;
        }
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (got == 0)
            break;
    }
    if (ferror(f)) {
        rc = gv_fail(err, GV_EIO, "%s: %s", path, strerror(errno));
        goto done;
    }
    if (n > MAX_SIZE) {
        rc = gv_fail(err, GV_EINVAL, "%s: larger than 16 MiB", path);
        goto done;
    }
    buf[n] = 0;
    if (memchr(buf, 0, n)) {
        rc = gv_fail(err, GV_EINVAL, "%s: not a text file", path);
        goto done;
    }
    rc = vs_parse(buf, path, s, err);
done:
    fclose(f);
    free(buf);
    return rc;
}
