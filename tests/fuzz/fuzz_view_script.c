/*
 * fuzz_view_script.c - libFuzzer target for the native viewer's script
 * files (`gigaview view --script FILE`, client/view/view_script.c).
 *
 * Byte 0 is a selector: bit 0 also loads the text through vs_load (a
 * memfd read as /proc/self/fd/N, as the viewer reads the file); with bit
 * 1, bits 3-7 (k) repeat the rest 2^k times (at most 1 MiB in all) so
 * that short inputs reach the command limit.  The text is given to vs_parse
 * up to its first NUL, as a C string; vs_load gets every byte and must
 * refuse a NUL, and agree with vs_parse otherwise.  The result must keep
 * view_script.h's contract: 0 with commands whose numbers are finite and
 * in their documented ranges, at most VS_MAX_CMDS of them, line numbers
 * rising within the text, text operands present and single-line; or -1
 * with GV_EINVAL (or GV_ENOMEM) and a message "NAME:LINE: ..." naming a
 * line of the text; parsing twice gives the same commands.  Anything
 * else aborts.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "fuzz.h"
#include "view_script.h"

#define MAX_TEXT (1u << 20)

static int in_range(double x, double lo, double hi)
{
    return isfinite(x) && x >= lo && x <= hi;
}

/* Lines of text as vs_parse counts them: a last line without '\n' too. */
static long count_lines(const char *t)
{
    long n = 0;
    for (const char *p = t; *p; n++) {
        const char *e = strchr(p, '\n');
        if (!e)
            return n + 1;
        p = e + 1;
    }
    return n;
}

static void check_cmd(const struct vs_cmd *c)
{
    for (int i = 0; i < 5; i++)
        if (!in_range(c->a[i], -1e9, 1e9))
            abort();
    switch (c->op) {
    case VS_WAIT: case VS_SETTLE: case VS_FRAMES:
        if (c->a[0] < 0)
            abort();
        if (c->op == VS_FRAMES && c->a[0] != floor(c->a[0]))
            abort();
        break;
    case VS_DRAG: case VS_TOUCH:
        if (c->a[4] < 1 || c->a[4] > 1000 || c->a[4] != floor(c->a[4]))
            abort();
        break;
    case VS_KEY:
        if (c->keycode == 0)
            abort();
        break;
    case VS_PAD_AXIS:
        if (fabs(c->a[0]) > 1 || c->code < 0)
            abort();
        break;
    case VS_PAD_BUTTON:
        if (c->code < 0)
            abort();
        break;
    case VS_PINCH:
        if (c->a[2] <= -0.25)
            abort();
        break;
    case VS_PARAM:
        if (c->a[0] != 1 && c->a[0] != -1)
            abort();
        break;
    case VS_VIEW:
        if (!isfinite(c->view.cx) || !isfinite(c->view.cy) || !isfinite(c->view.rot) ||
            !(fabs(c->view.zoom) <= 64) || !memchr(c->view_image, 0, sizeof c->view_image))
            abort();
        break;
    case VS_WAIT_FILE:
        if (c->a[0] < 0)
            abort();
        break;
    case VS_SHOT: case VS_IMAGE: case VS_PRINT: case VS_GRAPH: case VS_MESSAGE:
    case VS_DOWN: case VS_MOVE: case VS_UP: case VS_WHEEL: case VS_QUIT: case VS_FILTER:
        break;
    default:
        abort();
    }
    const int texty = c->op == VS_SHOT || c->op == VS_IMAGE || c->op == VS_WAIT_FILE ||
                      c->op == VS_PRINT || c->op == VS_GRAPH || c->op == VS_MESSAGE;
    if (texty != (c->text != NULL))
        abort();
    if (c->text && (strchr(c->text, '\n') || strlen(c->text) >= VS_MAX_LINE ||
                    (c->op != VS_PRINT && c->op != VS_MESSAGE && !c->text[0])))
        abort();
}

/* The result of one parse, checked; returns rc. */
static int check(int rc, const struct vs_script *s, const struct gv_error *err,
                 const char *name, long lines)
{
    if (rc == 0) {
        if (s->n > VS_MAX_CMDS || (s->n && !s->cmd))
            abort();
        for (size_t i = 0; i < s->n; i++) {
            const struct vs_cmd *c = &s->cmd[i];
            if (c->line < 1 || c->line > lines || (i && c->line <= s->cmd[i - 1].line))
                abort();
            check_cmd(c);
        }
        return 0;
    }
    if (rc != -1 || (err->code != GV_EINVAL && err->code != GV_ENOMEM))
        abort();
    size_t nl = strlen(name);
    if (err->code == GV_EINVAL && (strncmp(err->text, name, nl) || err->text[nl] != ':'))
        abort();
    /* "NAME:LINE: why", or vs_load's "NAME: why" (NUL, size). */
    char *end;
    long line = strtol(err->text + nl + 1, &end, 10);
    if (err->code == GV_EINVAL && end != err->text + nl + 1 &&
        (*end != ':' || line < 1 || line > (lines ? lines : 1)))
        abort();
    return -1;
}

static int same(const struct vs_script *a, const struct vs_script *b)
{
    if (a->n != b->n)
        return 0;
    for (size_t i = 0; i < a->n; i++) {
        const struct vs_cmd *x = &a->cmd[i], *y = &b->cmd[i];
        if (x->op != y->op || x->line != y->line || memcmp(x->a, y->a, sizeof x->a) ||
            x->shift != y->shift || x->ctrl != y->ctrl || x->keycode != y->keycode ||
            x->code != y->code || memcmp(&x->view, &y->view, sizeof x->view) ||
            strcmp(x->view_image, y->view_image) || !x->text != !y->text ||
            (x->text && strcmp(x->text, y->text)))
            return 0;
    }
    return 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size == 0)
        return 0;
    const unsigned sel = data[0];
    const uint8_t *body = data + 1;
    const size_t len = size - 1;
    size_t reps = 1;
    if ((sel & 2) && len)
        for (unsigned k = sel >> 3; k-- && reps * 2 * len <= MAX_TEXT;)
            reps *= 2;
    char *text = malloc(len * reps + 1);
    if (!text)
        abort();
    for (size_t r = 0; r < reps; r++)
        memcpy(text + r * len, body, len);
    const size_t total = len * reps;
    text[total] = 0;
    const long lines = count_lines(text);

    struct vs_script s, s2;
    struct gv_error err = {0};
    gv_error_clear(&err);
    int rc = check(vs_parse(text, "fuzz", &s, &err), &s, &err, "fuzz", lines);
    gv_error_clear(&err);
    int rc2 = check(vs_parse(text, "fuzz", &s2, &err), &s2, &err, "fuzz", lines);
    if (rc != rc2 || (rc == 0 && !same(&s, &s2)))
        abort();
    vs_free(&s2);

    if (sel & 1) {
        int fd = memfd_create("fuzz_view_script", MFD_CLOEXEC);
        if (fd < 0 || (total && write(fd, text, total) != (ssize_t)total)) {
            perror("memfd");
            abort();
        }
        char path[64];
        snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
        gv_error_clear(&err);
        int rl = check(vs_load(path, &s2, &err), &s2, &err, path, lines);
        const int nul = memchr(text, 0, total) != NULL;
        if (nul ? rl != -1 || !strstr(err.text, "not a text file")
                : rl != rc || (rc == 0 && !same(&s, &s2)))
            abort();
        vs_free(&s2);
        close(fd);
    }
    vs_free(&s);
    if (s.n || s.cmd)
        abort();
    free(text);
    return 0;
}
