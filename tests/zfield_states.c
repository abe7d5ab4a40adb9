/*
 * zfield_states.c - a test helper: the CPU's enabled states
 * (gv_zfield_enable, lib/mesh/zfield.h) of a grid read from stdin, for
 * tests/browser/zfield.mjs, which checks the browser's WebGL2 sweep in
 * the view-dependent mode against them.
 *
 *   zfield_states N vertical THRESHOLD            < GRID > STATES
 *   zfield_states N screen THRESHOLD EX EY EZ K XY < GRID > STATES
 *
 * GRID: N x N float32, little-endian (the host's order), row-major;
 * STATES: N x N bytes, 1 enabled, 0 not.  The numbers are parsed with
 * strtof, so a float printed in its shortest round-trip form (as
 * JavaScript prints Math.fround values) arrives exactly.  Exit 0, or 1
 * with a message on stderr.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mesh/zfield.h"

static int num(const char *s, float *out)
{
    char *end;
    *out = strtof(s, &end);
    return end != s && !*end ? 0 : -1;
}

int main(int argc, char **argv)
{
    struct gv_zfield_params p = {0};
    struct gv_error err = {0};
    float *z = NULL;
    uint8_t *en = NULL;
    int rc = 1;
    const int screen = argc == 9 && !strcmp(argv[2], "screen");
    if (!(argc == 4 && !strcmp(argv[2], "vertical")) && !screen) {
        fprintf(stderr, "usage: zfield_states N vertical|screen THRESHOLD [EX EY EZ K XY]\n");
        return 1;
    }
    const unsigned long n = strtoul(argv[1], NULL, 10);
    if (!gv_zfield_side_ok((uint32_t)n) || num(argv[3], &p.threshold) < 0) {
        fprintf(stderr, "zfield_states: bad N or threshold\n");
        return 1;
    }
    p.mode = screen ? GV_ZFIELD_SCREEN : GV_ZFIELD_VERTICAL;
    if (screen && (num(argv[4], &p.eye[0]) < 0 || num(argv[5], &p.eye[1]) < 0 ||
                   num(argv[6], &p.eye[2]) < 0 || num(argv[7], &p.k) < 0 ||
                   num(argv[8], &p.xy_scale) < 0)) {
        fprintf(stderr, "zfield_states: bad camera\n");
        return 1;
    }
    const size_t cells = (size_t)n * n;
    z = malloc(cells * sizeof *z);
    en = malloc(cells);
    if (!z || !en) {
        fprintf(stderr, "zfield_states: out of memory\n");
        goto out;
    }
    if (fread(z, sizeof *z, cells, stdin) != cells) {
        fprintf(stderr, "zfield_states: short grid on stdin\n");
        goto out;
    }
    if (gv_zfield_enable(z, (uint32_t)n, &p, en, &err) < 0) {
        fprintf(stderr, "zfield_states: %s\n", err.text);
        goto out;
    }
    if (fwrite(en, 1, cells, stdout) != cells || fflush(stdout) != 0) {
        fprintf(stderr, "zfield_states: write failed\n");
        goto out;
    }
    rc = 0;
out:
    free(z);
    free(en);
    return rc;
}
