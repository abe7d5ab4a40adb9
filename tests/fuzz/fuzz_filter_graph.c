/*
 * fuzz_filter_graph.c - libFuzzer target for gv_filter_graph_parse
 * (filters/graph.c) and the parameter parser.
 *
 * The input is a graph document, parsed under the default limits and under
 * tight ones.  A failure must carry a "filter: " message and one of the
 * codes users can get (GV_EINVAL, GV_ELIMIT, GV_ENOMEM).  A success must
 * describe a runnable plan: the output used, every used module's inputs
 * earlier in the order and used too, texture slots within the count, the
 * padding within the limit, bodies that pass their own check and expand,
 * defaults that gv_filter_params accepts, and a description.  Anything
 * else aborts.
 */
#include <stdlib.h>
#include <string.h>

#include "filter.h"
#include "fuzz.h"
#include "graph_body.h"

static void check_graph(const struct gv_filter_graph *g,
                        const struct gv_filter_limits *lim)
{
    if (g->nmodules < 1 || g->nmodules > lim->max_modules || g->output < 0 ||
        g->output >= g->nmodules || g->module[g->output].texture < 0)
        abort();
    if (g->pad_left > lim->max_padding || g->pad_left < 0 || g->align < 1 ||
        (g->align & (g->align - 1)))
        abort();
    if (g->ntextures < 1 || g->ntextures > 2 * g->nmodules)
        abort();
    if (g->value_channels != 0 && g->value_channels != 4 && g->value_channels != 8)
        abort();
    int nparams = 0;
    for (int i = 0; i < g->nmodules; i++) {
        const struct gv_filter_module *m = &g->module[i];
        if (m->param_base != nparams)
            abort();
        nparams += m->nparams;
        if (m->texture >= 2 * g->nmodules + 2)
            abort();
        for (int k = 0; k < m->ninputs; k++) {
            int in = m->input[k];
            if (in >= i || in < -GV_FILTER_RESERVED_INPUTS)
                abort();
            if (m->texture >= 0 && in >= 0 && g->module[in].texture < 0)
                abort();
        }
        struct gv_error err = {0};
        if (gv_filter_check_body(m, &err) != 0)
            abort();
        /* Registers are expanded everywhere; "$(" may stay in comments,
         * which gv_filter_check_body skips (a finding of the campaign). */
        char *x = gv_filter_expand_body(m->glsl);
        if (!x)
            abort();
        free(x);
        for (int p = 0; p < m->nparams; p++)
            if (!(m->param[p].min <= m->param[p].def && m->param[p].def <= m->param[p].max))
                abort();
    }
    if (nparams != g->nparams)
        abort();
    double *v = malloc(((size_t)g->nparams + 1) * sizeof *v);
    struct gv_error err = {0};
    if (!v || gv_filter_params(g, NULL, v, &err) != 0)
        abort();
    free(v);
    json_t *d = gv_filter_graph_describe(g);
    if (!d)
        abort();
    json_decref(d);
}

static void one(const uint8_t *data, size_t size, const struct gv_filter_limits *lim)
{
    struct gv_error err = {0};
    gv_error_clear(&err);
    struct gv_filter_graph *g =
        gv_filter_graph_parse((const char *)data, size, lim, &err);
    if (!g) {
        if (strncmp(err.text, "filter: ", 8) ||
            (err.code != GV_EINVAL && err.code != GV_ELIMIT && err.code != GV_ENOMEM))
            abort();
        return;
    }
    check_graph(g, lim);
    gv_filter_graph_free(g);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    struct gv_filter_limits lim;
    gv_filter_limits_default(&lim);
    one(data, size, &lim);
    lim.max_modules = 3;
    lim.max_glsl_bytes = 64;
    lim.max_json_depth = 5;
    lim.max_padding = 4;
    one(data, size, &lim);
    return 0;
}
