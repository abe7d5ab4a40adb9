/*
 * graph_body.c - checking, expanding and generating module bodies
 * (graph_body.h).  A small scanner that knows GLSL comments and
 * identifiers; it does not parse GLSL (the driver does that, and its log
 * is mapped back to the body's lines by run_gpu.c).
 */
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "graph_body.h"

static int line_at(const char *s, const char *p)
{
    int line = 1;
    for (; s < p; s++)
        if (*s == '\n')
            line++;
    return line;
}

/* Parse a register starting at p ("$(" already seen at p[0..1]): sets
 * *input (1-based, FilterInputN) or *param (1-based $(N)); returns the
 * length of the whole register, or 0 if malformed. */
static size_t parse_register(const char *p, int *input, int *param)
{
    const char *q = p + 2;
    *input = *param = 0;
    int is_input = 0;
    if (!strncmp(q, "FilterInput", 11)) {
        is_input = 1;
        q += 11;
    }
    if (!isdigit((unsigned char)*q) || *q == '0')
        return 0;
    long v = 0;
    while (isdigit((unsigned char)*q) && v < 1000)
        v = v * 10 + (*q++ - '0');
    if (*q != ')')
        return 0;
    if (is_input)
        *input = (int)v;
    else
        *param = (int)v;
    return (size_t)(q + 1 - p);
}

int gv_filter_check_body(const struct gv_filter_module *m, struct gv_error *err)
{
    static const char *const forbidden[] = {"uniform", "layout", "in", "out",
                                            "buffer", "shared", "precision",
                                            NULL};
    const char *s = m->glsl, *p = s;
    int depth = 0;
    while (*p) {
        if (p[0] == '/' && p[1] == '/') {
            while (*p && *p != '\n')
                p++;
            continue;
        }
        if (p[0] == '/' && p[1] == '*') {
            const char *e = strstr(p + 2, "*/");
            if (!e)
                return gv_fail(err, GV_EINVAL,
                               "filter: module '%s' line %d: unterminated comment",
                               m->id, line_at(s, p));
            p = e + 2;
            continue;
        }
        if (*p == '#')
            return gv_fail(err, GV_EINVAL,
                           "filter: module '%s' line %d: preprocessor directives are "
                           "not allowed in a body", m->id, line_at(s, p));
        if (*p == '$') {
            int in, par;
            size_t n = p[1] == '(' ? parse_register(p, &in, &par) : 0;
            if (!n)
                return gv_fail(err, GV_EINVAL,
                               "filter: module '%s' line %d: unknown register (use "
                               "$(FilterInputN) or $(N))", m->id, line_at(s, p));
            if (in > m->ninputs)
                return gv_fail(err, GV_EINVAL,
                               "filter: module '%s' line %d: $(FilterInput%d) but the "
                               "module has %d input%s", m->id, line_at(s, p), in,
                               m->ninputs, m->ninputs == 1 ? "" : "s");
            if (par > m->nparams)
                return gv_fail(err, GV_EINVAL,
                               "filter: module '%s' line %d: $(%d) but the module has "
                               "%d param%s", m->id, line_at(s, p), par, m->nparams,
                               m->nparams == 1 ? "" : "s");
            p += n;
            continue;
        }
        if (isalpha((unsigned char)*p) || *p == '_') {
            const char *b = p;
            while (isalnum((unsigned char)*p) || *p == '_')
                p++;
            for (const char *const *f = forbidden; *f; f++)
                if ((size_t)(p - b) == strlen(*f) && !strncmp(b, *f, (size_t)(p - b)))
                    return gv_fail(err, GV_EINVAL,
                                   "filter: module '%s' line %d: '%s' is not allowed in "
                                   "a body (the template owns the interface)",
                                   m->id, line_at(s, b), *f);
            continue;
        }
        if (*p == '{')
            depth++;
        else if (*p == '}' && --depth < 0)
            return gv_fail(err, GV_EINVAL,
                           "filter: module '%s' line %d: unbalanced '}'", m->id,
                           line_at(s, p));
        p++;
    }
    if (depth != 0)
        return gv_fail(err, GV_EINVAL, "filter: module '%s': unbalanced '{'", m->id);
    return 0;
}

char *gv_filter_expand_body(const char *glsl)
{
    size_t cap = strlen(glsl) * 2 + 64, len = 0;
    char *out = malloc(cap);
    if (!out)
        return NULL;
    for (const char *p = glsl; *p;) {
        int in = 0, par = 0;
        size_t n = p[0] == '$' && p[1] == '(' ? parse_register(p, &in, &par) : 0;
        char buf[32];
        const char *piece = p;
        size_t plen = 1;
        if (n) {
            plen = (size_t)(in ? snprintf(buf, sizeof buf, "gv_in%d", in)
                               : snprintf(buf, sizeof buf, "gv_p[%d]", par - 1));
            piece = buf;
        } else {
            n = 1;
        }
        if (len + plen + 1 > cap) {
            cap = cap * 2 + plen;
            char *t = realloc(out, cap);
            if (!t) {
                free(out);
                return NULL;
            }
            out = t;
        }
        memcpy(out + len, piece, plen);
        len += plen;
        p += n;
    }
    out[len] = 0;
    return out;
}

/* A GLSL float literal for v: always with a '.' or an exponent. */
static void float_literal(char *buf, size_t cap, float v)
{
    snprintf(buf, cap, "%.9g", (double)v);
    if (!strpbrk(buf, ".eE"))
        strncat(buf, ".0", cap - strlen(buf) - 1);
}

char *gv_filter_kernel_body(const float *w, int kw, int kh, float scale,
                            float bias)
{
    size_t cap = 128 + (size_t)kw * kh * 96, len = 0;
    char *s = malloc(cap);
    if (!s)
        return NULL;
    len += (size_t)snprintf(s + len, cap - len, "vec4 gv_acc = vec4(0.0);\n");
    for (int j = 0; j < kh; j++)
        for (int i = 0; i < kw; i++) {
            float v = w[j * kw + i];
            if (v == 0.0f)
                continue;
            char lit[48];
            float_literal(lit, sizeof lit, v);
            len += (size_t)snprintf(s + len, cap - len,
                                    "gv_acc += %s * $(FilterInput1)(rel_pos + ivec2(%d, %d));\n",
                                    lit, i - kw / 2, j - kh / 2);
        }
    char ls[48], lb[48];
    float_literal(ls, sizeof ls, scale);
    float_literal(lb, sizeof lb, bias);
    snprintf(s + len, cap - len, "return vec4(%s) + %s * gv_acc;\n", lb, ls);
    return s;
}
