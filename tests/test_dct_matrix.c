/*
 * test_dct_matrix.c - layout D's matrix K (docs/FORMAT.md 4.3) has two
 * copies that must hold the same integers for the GPU decoders to stay
 * bit for bit with the CPU: gv_dct_matrix (lib/codec/tile_dct_pixels.c)
 * and the GLSL one, shaders/dct_matrix.glsl, which dct_rows.comp.glsl and
 * tile_decode.frag.glsl include.  This reads the 64 numbers out of the
 * embedded GLSL text (shaders.h, as the programs compile it) and compares
 * them with gv_dct_matrix, so that editing one copy alone fails make
 * check; it checks that both decode shaders carry the snippet verbatim,
 * and that the comparison catches one number changed or a number missing.
 * No GPU needed: only the embedded strings are read.
 */
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "codec/tile_dct.h"
#include "shaders.h"
#include "util.h"

#define INIT "int[64]("

/* The 64 integers of the only `int[64](...)` initializer in src into k,
 * row-major.  Returns 0, or -1 when src has none, more than one, or one
 * that is not 64 decimal integers separated by commas. */
static int parse_k(const char *src, int k[64])
{
    const char *p = strstr(src, INIT);
    if (!p || strstr(p + 1, INIT))
        return -1;
    p += strlen(INIT);
    for (int n = 0; n < 64; n++) {
        char *end;
        long v = strtol(p, &end, 10);
        if (end == p || v < -128 || v > 127)
            return -1;
        k[n] = (int)v;
        for (p = end; isspace((unsigned char)*p); p++)
            ;
        if (*p++ != (n == 63 ? ')' : ','))
            return -1;
    }
    return 0;
}

/* Entries where k differs from ref, the first named in *at. */
static int mismatches(const int k[64], const int32_t ref[64], int *at)
{
    int n = 0;
    for (int i = 63; i >= 0; i--)
        if (k[i] != ref[i])
            n++, *at = i;
    return n;
}

/* Occurrences of needle in hay. */
static int count(const char *hay, const char *needle)
{
    int n = 0;
    for (const char *p = hay; (p = strstr(p, needle)); p++)
        n++;
    return n;
}

static void test_same_numbers(void)
{
    int k[64], at = -1;
    if (!check(parse_k(gv_shader_dct_matrix, k) == 0,
               "dct_matrix.glsl holds one int[64] initializer of 64 integers"))
        return;
    int32_t cpu[64];
    for (int i = 0; i < 64; i++)
        cpu[i] = gv_dct_matrix[i / 8][i % 8];
    int n = mismatches(k, cpu, &at);
    check(n == 0, "dct_matrix.glsl's K is gv_dct_matrix, all 64 entries%s", n ? ":" : "");
    if (n)
        printf("# %d differ; first K[%d][%d]: GLSL %d, CPU %d\n", n, at / 8, at % 8,
               k[at], (int)cpu[at]);
}

static void test_included(void)
{
    const struct {
        const char *name, *src;
    } uses[] = {
        {"tile_decode.frag.glsl", gv_shader_tile_decode_frag},
        {"dct_rows.comp.glsl", gv_shader_dct_rows_comp},
    };
    for (size_t i = 0; i < sizeof uses / sizeof uses[0]; i++) {
        check(count(uses[i].src, gv_shader_dct_matrix) == 1 &&
                  count(uses[i].src, INIT) == 1 && !strstr(uses[i].src, "\n#include"),
              "%s as embedded carries dct_matrix.glsl once, its only K, "
              "no #include line left", uses[i].name);
    }
}

/* The comparison can fail: one number changed (against the text as
 * embedded), one missing. */
static void test_controls(void)
{
    char *s = strdup(gv_shader_dct_matrix);
    int k[64], at = -1;
    int32_t k0[64];
    char *p = s ? strstr(s, "89,  75") : NULL;
    if (!check(p != NULL && parse_k(s, k) == 0,
               "control: K[1][0] = 89 found in the text")) {
        free(s);
        return;
    }
    for (int i = 0; i < 64; i++)
        k0[i] = k[i];
    p[1] = '8';   /* 89 -> 88 */
    check(parse_k(s, k) == 0 && mismatches(k, k0, &at) == 1 && at == 8,
          "control: K[1][0] 89 -> 88 is caught, at [1][0]");
    memmove(p, p + 5, strlen(p + 5) + 1);   /* drop "88,  " */
    check(parse_k(s, k) == -1, "control: 63 numbers are refused");
    check(parse_k("const int K[64] = int[64](1, 2);", k) == -1 &&
              parse_k("no initializer", k) == -1,
          "control: a short or missing initializer is refused");
    free(s);
}

int main(void)
{
    test_same_numbers();
    test_included();
    test_controls();
    return tap_done();
}
