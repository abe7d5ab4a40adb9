/*
 * progress.c - terminal progress bar (see progress.h).
 */
#include <stdlib.h>
#include <time.h>
#include <unistd.h>

#include "progress.h"

struct progress {
    FILE *out;
    int active;
    double start, last;
    int drawn;
};

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

struct progress *progress_new(FILE *out, int force)
{
    struct progress *p = calloc(1, sizeof *p);
    if (!p)
        return NULL;
    p->out = out;
    p->active = force || isatty(fileno(out));
    p->start = now();
    p->last = -1.0;
    return p;
}

void progress_update(struct progress *p, double fraction, uint64_t total_pixels,
                     const char *phase)
{
    if (!p || !p->active)
        return;
    double t = now();
    if (fraction < 1.0 && p->last >= 0 && t - p->last < 0.1)
        return;
    p->last = t;
    double el = t - p->start;
    double mps = el > 0 ? fraction * (double)total_pixels / el / 1e6 : 0.0;
    enum { WIDTH = 30 };
    int fill = (int)(fraction * WIDTH + 0.5);
    char bar[WIDTH + 1];
    for (int i = 0; i < WIDTH; i++)
        bar[i] = i < fill ? '#' : '.';
    bar[WIDTH] = '\0';
    fprintf(p->out, "\r%-8s [%s] %5.1f%%  %7.1f MP/s", phase, bar, 100.0 * fraction, mps);
    if (fraction > 0.001 && fraction < 1.0) {
        double left = el * (1.0 - fraction) / fraction;
        fprintf(p->out, "  %2d:%02d left ", (int)left / 60, (int)left % 60);
    } else {
        fprintf(p->out, "  %2d:%02d total", (int)el / 60, (int)el % 60);
    }
    fflush(p->out);
    p->drawn = 1;
}

void progress_free(struct progress *p)
{
    if (!p)
        return;
    if (p->drawn)
        fputc('\n', p->out);
    free(p);
}
