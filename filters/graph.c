/*
 * graph.c - filter graph documents: parse, validate, order, plan
 * (filter.h, docs/FILTERS.md sections 2-5 and 7).
 *
 * Pure C over jansson, no GL: the fuzz target drives it directly.  The
 * steps, each failing with a message that names the module and field:
 *
 *   1. a bracket scan bounds the nesting depth before jansson sees the
 *      text (jansson's own limit is 2048 levels);
 *   2. the schema: every key checked for type and range, unknown keys
 *      rejected;
 *   3. bodies: registers $(FilterInputN) and $(N) checked against the
 *      module's inputs and parameters, and the words that would let a
 *      body reach outside its function rejected; kernel modules get a
 *      generated body;
 *   4. order: the thesis's selection sort (section 7.7.3) - repeatedly
 *      the first module in document order whose inputs are all done; when
 *      none is, the rest hold a cycle, which is reported;
 *   5. plan: which modules the output needs, the padding (largest sum of
 *      supports along a path), merge skipping (section 7.8.5), and
 *      texture slots recycled greedily by liveness.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/ids.h"
#include "filter.h"
#include "graph_body.h"

static const char *const reserved_names[GV_FILTER_RESERVED_INPUTS] = {
    "source", "values", "values2"};

const char *gv_filter_reserved_name(int in)
{
    return in < 0 && in >= -GV_FILTER_RESERVED_INPUTS ? reserved_names[-in - 1] : "?";
}

/* The reserved input (GV_FILTER_SOURCE ...) named `name`, else 0. */
static int reserved_input(const char *name)
{
    for (int k = 0; k < GV_FILTER_RESERVED_INPUTS; k++)
        if (!strcmp(name, reserved_names[k]))
            return -k - 1;
    return 0;
}

static int fail_m(struct gv_error *err, const char *mod, enum gv_code code,
                  const char *fmt, const char *what)
{
    if (mod)
        return gv_fail(err, code, "filter: module '%s': %s%s", mod, fmt,
                       what ? what : "");
    return gv_fail(err, code, "filter: %s%s", fmt, what ? what : "");
}

/* Deepest nesting of [ and { outside strings; stops counting past cap. */
static int json_depth(const char *s, size_t len, int cap)
{
    int depth = 0, max = 0, in_str = 0;
    for (size_t i = 0; i < len; i++) {
        char c = s[i];
        if (in_str) {
            if (c == '\\')
                i++;
            else if (c == '"')
                in_str = 0;
        } else if (c == '"') {
            in_str = 1;
        } else if (c == '[' || c == '{') {
            if (++depth > max)
                max = depth;
            if (max > cap)
                return max;
        } else if (c == ']' || c == '}') {
            depth--;
        }
    }
    return max;
}

static int check_keys(const json_t *obj, const char *const *allowed,
                      const char *mod, struct gv_error *err)
{
    const char *key;
    json_t *v;
    json_object_foreach((json_t *)obj, key, v) {
        int ok = 0;
        for (const char *const *a = allowed; *a; a++)
            if (!strcmp(key, *a))
                ok = 1;
        if (!ok) {
            char msg[96];
            snprintf(msg, sizeof msg, "unknown key \"%.60s\"", key);
            return fail_m(err, mod, GV_EINVAL, msg, NULL);
        }
    }
    return 0;
}

/* An optional string member: 0 absent (out untouched), 1 copied, -1. */
static int get_string(const json_t *obj, const char *key, char *out,
                      size_t cap, const char *mod, struct gv_error *err)
{
    json_t *v = json_object_get(obj, key);
    if (!v)
        return 0;
    if (!json_is_string(v) || json_string_length(v) >= cap ||
        json_string_length(v) != strlen(json_string_value(v))) {
        char msg[96];
        snprintf(msg, sizeof msg, "\"%s\" must be a string of at most %zu bytes",
                 key, cap - 1);
        return fail_m(err, mod, GV_EINVAL, msg, NULL);
    }
    memcpy(out, json_string_value(v), json_string_length(v) + 1);
    return 1;
}

/* An integer member in [lo, hi]; absent leaves *out as it is. */
static int get_int(const json_t *obj, const char *key, int lo, int hi,
                   int *out, const char *mod, struct gv_error *err)
{
    json_t *v = json_object_get(obj, key);
    if (!v)
        return 0;
    if (!json_is_integer(v) || json_integer_value(v) < lo ||
        json_integer_value(v) > hi) {
        char msg[96];
        snprintf(msg, sizeof msg, "\"%s\" must be an integer in [%d, %d]", key,
                 lo, hi);
        return fail_m(err, mod, GV_EINVAL, msg, NULL);
    }
    *out = (int)json_integer_value(v);
    return 1;
}

static int get_number(const json_t *v, double *out)
{
    if (!json_is_number(v))
        return -1;
    *out = json_number_value(v);
    return isfinite(*out) ? 0 : -1;
}

static int parse_params(struct gv_filter_module *m, const json_t *arr,
                        struct gv_error *err)
{
    static const char *const keys[] = {"name", "min", "max", "default", NULL};
    if (!json_is_array(arr))
        return fail_m(err, m->id, GV_EINVAL, "\"params\" must be an array", NULL);
    if (json_array_size(arr) > GV_FILTER_MAX_PARAMS)
        return fail_m(err, m->id, GV_ELIMIT, "more than 16 params", NULL);
    size_t i;
    json_t *p;
    json_array_foreach(arr, i, p) {
        struct gv_filter_param *q = &m->param[i];
        if (!json_is_object(p))
            return fail_m(err, m->id, GV_EINVAL, "a param must be an object", NULL);
        if (check_keys(p, keys, m->id, err) < 0)
            return -1;
        q->name[0] = 0;
        if (get_string(p, "name", q->name, sizeof q->name, m->id, err) < 0)
            return -1;
        if (!gv_filter_id_valid(q->name))
            return fail_m(err, m->id, GV_EINVAL,
                          "a param needs a \"name\" of [A-Za-z0-9_-], 1-63 bytes",
                          NULL);
        for (size_t k = 0; k < i; k++)
            if (!strcmp(m->param[k].name, q->name))
                return fail_m(err, m->id, GV_EINVAL, "duplicate param ", q->name);
        if (get_number(json_object_get(p, "min"), &q->min) < 0 ||
            get_number(json_object_get(p, "max"), &q->max) < 0 ||
            get_number(json_object_get(p, "default"), &q->def) < 0)
            return fail_m(err, m->id, GV_EINVAL,
                          "min, max and default must be finite numbers: param ",
                          q->name);
        if (!(q->min <= q->max))
            return fail_m(err, m->id, GV_EINVAL, "min > max: param ", q->name);
        if (q->def < q->min || q->def > q->max)
            return fail_m(err, m->id, GV_EINVAL,
                          "default outside [min, max]: param ", q->name);
        m->nparams = (int)i + 1;
    }
    return 0;
}

static int parse_kernel(struct gv_filter_module *m, const json_t *k,
                        struct gv_error *err)
{
    static const char *const keys[] = {"width", "height", "weights", "scale",
                                       "bias", NULL};
    if (!json_is_object(k))
        return fail_m(err, m->id, GV_EINVAL, "\"kernel\" must be an object", NULL);
    if (check_keys(k, keys, m->id, err) < 0)
        return -1;
    int w = 0, h = 0;
    if (get_int(k, "width", 1, GV_FILTER_KERNEL_MAX, &w, m->id, err) < 0 ||
        get_int(k, "height", 1, GV_FILTER_KERNEL_MAX, &h, m->id, err) < 0)
        return -1;
    if (w % 2 == 0 || h % 2 == 0)
        return fail_m(err, m->id, GV_EINVAL,
                      "kernel width and height must be odd, 1-63", NULL);
    double scale = 1, bias = 0;
    json_t *v;
    if ((v = json_object_get(k, "scale")) && get_number(v, &scale) < 0)
        return fail_m(err, m->id, GV_EINVAL, "kernel scale must be a number", NULL);
    if ((v = json_object_get(k, "bias")) && get_number(v, &bias) < 0)
        return fail_m(err, m->id, GV_EINVAL, "kernel bias must be a number", NULL);
    json_t *wv = json_object_get(k, "weights");
    if (!json_is_array(wv) || json_array_size(wv) != (size_t)w * (size_t)h) {
        char msg[96];
        snprintf(msg, sizeof msg, "kernel \"weights\" must hold width x height = %d numbers",
                 w * h);
        return fail_m(err, m->id, GV_EINVAL, msg, NULL);
    }
    m->kernel = malloc((size_t)w * h * sizeof *m->kernel);
    if (!m->kernel)
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    for (size_t i = 0; i < (size_t)w * h; i++) {
        double d;
        if (get_number(json_array_get(wv, i), &d) < 0)
            return fail_m(err, m->id, GV_EINVAL, "kernel weights must be numbers",
                          NULL);
        m->kernel[i] = (float)d;
    }
    m->kernel_w = w;
    m->kernel_h = h;
    int r = (w > h ? w : h) / 2;
    if (m->support < r)
        m->support = r;
    m->glsl = gv_filter_kernel_body(m->kernel, w, h, (float)scale, (float)bias);
    if (!m->glsl)
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    return 0;
}

static int parse_format(const char *s, enum gv_filter_format *f)
{
    static const char *const names[] = {"rgba32f", "rgba16f", "rgba8",
                                        "rgba32ui", "rgba32i"};
    for (int i = 0; i < 5; i++)
        if (!strcmp(s, names[i])) {
            *f = (enum gv_filter_format)i;
            return 0;
        }
    return -1;
}

const char *gv_filter_format_name(enum gv_filter_format f)
{
    static const char *const names[] = {"rgba32f", "rgba16f", "rgba8",
                                        "rgba32ui", "rgba32i"};
    return (unsigned)f < 5 ? names[f] : "?";
}

/* Everything about one module except its inputs (resolved later). */
static int parse_module(struct gv_filter_module *m, const json_t *o,
                        const struct gv_filter_limits *lim, struct gv_error *err)
{
    static const char *const keys[] = {"id", "name", "template", "max_passes",
                                       "direction", "inputs", "params",
                                       "support", "format", "glsl", "kernel",
                                       NULL};
    if (!json_is_object(o))
        return fail_m(err, NULL, GV_EINVAL, "each module must be an object", NULL);
    if (get_string(o, "id", m->id, sizeof m->id, NULL, err) < 0)
        return -1;
    if (!gv_filter_id_valid(m->id))
        return fail_m(err, NULL, GV_EINVAL,
                      "each module needs an \"id\" of [A-Za-z0-9_-], 1-63 bytes",
                      NULL);
    if (reserved_input(m->id)) {
        char msg[GV_FILTER_ID_MAX + 32];
        snprintf(msg, sizeof msg, "the id \"%s\" is reserved", m->id);
        return fail_m(err, m->id, GV_EINVAL, msg, NULL);
    }
    if (check_keys(o, keys, m->id, err) < 0)
        return -1;
    snprintf(m->name, sizeof m->name, "%s", m->id);
    if (get_string(o, "name", m->name, sizeof m->name, m->id, err) < 0)
        return -1;

    char tpl[32] = "";
    if (get_string(o, "template", tpl, sizeof tpl, m->id, err) < 0)
        return -1;
    if (!strcmp(tpl, "point"))
        m->tpl = GV_FILTER_POINT;
    else if (!strcmp(tpl, "logreduce"))
        m->tpl = GV_FILTER_LOGREDUCE;
    else if (!strcmp(tpl, "propagation"))
        m->tpl = GV_FILTER_PROPAGATION;
    else
        return fail_m(err, m->id, GV_EINVAL,
                      tpl[0] ? "unknown template (point, logreduce, propagation): "
                             : "\"template\" is required (point, logreduce, propagation)",
                      tpl);

    m->max_passes = 16;
    if (json_object_get(o, "max_passes") && m->tpl != GV_FILTER_LOGREDUCE)
        return fail_m(err, m->id, GV_EINVAL,
                      "\"max_passes\" is for the logreduce template only", NULL);
    if (get_int(o, "max_passes", 1, 16, &m->max_passes, m->id, err) < 0)
        return -1;

    char dir[8] = "";
    if (get_string(o, "direction", dir, sizeof dir, m->id, err) < 0)
        return -1;
    if (m->tpl == GV_FILTER_PROPAGATION) {
        if (!strcmp(dir, "+x"))
            m->dir_x = 1;
        else if (!strcmp(dir, "-x"))
            m->dir_x = -1;
        else if (!strcmp(dir, "+y"))
            m->dir_y = 1;
        else if (!strcmp(dir, "-y"))
            m->dir_y = -1;
        else
            return fail_m(err, m->id, GV_EINVAL,
                          "propagation needs \"direction\": \"+x\", \"-x\", \"+y\" or \"-y\"",
                          NULL);
    } else if (dir[0]) {
        return fail_m(err, m->id, GV_EINVAL,
                      "\"direction\" is for the propagation template only", NULL);
    }

    if (get_int(o, "support", 0, 1 << 20, &m->support, m->id, err) < 0)
        return -1;
    char fmt[16] = "rgba32f";
    if (get_string(o, "format", fmt, sizeof fmt, m->id, err) < 0)
        return -1;
    if (parse_format(fmt, &m->format) < 0)
        return fail_m(err, m->id, GV_EINVAL,
                      "unknown format (rgba32f, rgba16f, rgba8, rgba32ui, rgba32i): ",
                      fmt);

    json_t *params = json_object_get(o, "params");
    if (params && parse_params(m, params, err) < 0)
        return -1;

    json_t *glsl = json_object_get(o, "glsl"), *kernel = json_object_get(o, "kernel");
    if (!!glsl == !!kernel)
        return fail_m(err, m->id, GV_EINVAL,
                      "exactly one of \"glsl\" and \"kernel\" is required", NULL);
    if (glsl) {
        if (!json_is_string(glsl) ||
            json_string_length(glsl) != strlen(json_string_value(glsl)))
            return fail_m(err, m->id, GV_EINVAL, "\"glsl\" must be a string", NULL);
        if (json_string_length(glsl) > lim->max_glsl_bytes) {
            char msg[96];
            snprintf(msg, sizeof msg, "GLSL body of %zu bytes exceeds the limit of %zu",
                     json_string_length(glsl), lim->max_glsl_bytes);
            return fail_m(err, m->id, GV_ELIMIT, msg, NULL);
        }
        m->glsl = strdup(json_string_value(glsl));
        if (!m->glsl)
            return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    } else {
        if (params && json_array_size(params))
            return fail_m(err, m->id, GV_EINVAL, "a kernel module takes no params",
                          NULL);
        if (m->format == GV_FILTER_RGBA32UI || m->format == GV_FILTER_RGBA32I)
            return fail_m(err, m->id, GV_EINVAL,
                          "a kernel module needs a float format", NULL);
        if (parse_kernel(m, kernel, err) < 0)
            return -1;
    }
    return 0;
}

static int find(const struct gv_filter_module *m, int n, const char *id)
{
    for (int i = 0; i < n; i++)
        if (!strcmp(m[i].id, id))
            return i;
    return -1;
}

static int resolve_inputs(struct gv_filter_module *mods, int n,
                          const json_t *arr_of_modules, struct gv_error *err)
{
    for (int i = 0; i < n; i++) {
        struct gv_filter_module *m = &mods[i];
        json_t *in = json_object_get(json_array_get(arr_of_modules, (size_t)i),
                                     "inputs");
        if (!json_is_array(in) || json_array_size(in) < 1 ||
            json_array_size(in) > GV_FILTER_MAX_INPUTS)
            return fail_m(err, m->id, GV_EINVAL,
                          "\"inputs\" must be an array of 1 to 8 names", NULL);
        size_t k;
        json_t *v;
        json_array_foreach(in, k, v) {
            if (!json_is_string(v))
                return fail_m(err, m->id, GV_EINVAL, "inputs must be strings", NULL);
            const char *name = json_string_value(v);
            int idx = reserved_input(name);
            if (!idx)
                idx = find(mods, n, name);
            if (idx == i)
                return fail_m(err, m->id, GV_EINVAL,
                              "a module cannot read its own output (cycle)", NULL);
            if (idx == -1 && reserved_input(name) != GV_FILTER_SOURCE) {
                char msg[128];
                snprintf(msg, sizeof msg, "input %zu names no module: \"%.60s\"",
                         k + 1, name);
                return fail_m(err, m->id, GV_EINVAL, msg, NULL);
            }
            m->input[k] = idx;
        }
        m->ninputs = (int)json_array_size(in);
        const int integer = m->format == GV_FILTER_RGBA32UI ||
                            m->format == GV_FILTER_RGBA32I;
        if (m->tpl != GV_FILTER_POINT && m->input[0] >= 0) {
            /* The state of a sweep or a mip chain has the module's own
             * format, so input 1 must have it too. */
            enum gv_filter_format f = mods[m->input[0]].format;
            int in_int = f == GV_FILTER_RGBA32UI || f == GV_FILTER_RGBA32I;
            if (in_int != integer || (integer && f != m->format))
                return fail_m(err, m->id, GV_EINVAL,
                              "input 1 of a logreduce or propagation module must "
                              "have the module's format family", NULL);
        } else if (m->tpl != GV_FILTER_POINT && integer) {
            return fail_m(err, m->id, GV_EINVAL,
                          "an integer logreduce or propagation module cannot start "
                          "from the source or values (add a point module that "
                          "converts it)",
                          NULL);
        }
        if (m->kernel) {
            if (m->ninputs != 1)
                return fail_m(err, m->id, GV_EINVAL,
                              "a kernel module takes exactly one input", NULL);
            int src = m->input[0];
            if (src >= 0 &&
                (mods[src].format == GV_FILTER_RGBA32UI ||
                 mods[src].format == GV_FILTER_RGBA32I))
                return fail_m(err, m->id, GV_EINVAL,
                              "a kernel module needs a float-format input", NULL);
        }
    }
    return 0;
}

/* Report a cycle among the modules not yet ordered. */
static int report_cycle(const struct gv_filter_module *mods, int n,
                        const int *done, struct gv_error *err)
{
    int start = -1;
    for (int i = 0; i < n && start < 0; i++)
        if (!done[i])
            start = i;
    /* Walk to an unfinished input until a module repeats. */
    int *seen = calloc((size_t)n, sizeof *seen);
    if (!seen)
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    int cur = start, step = 1;
    while (!seen[cur]) {
        seen[cur] = step++;
        int next = -1;
        for (int k = 0; k < mods[cur].ninputs && next < 0; k++) {
            int in = mods[cur].input[k];
            if (in >= 0 && !done[in])
                next = in;
        }
        cur = next;
    }
    char list[256] = "";
    size_t len = 0;
    int first = cur, at = cur;
    do {
        len += (size_t)snprintf(list + len, len < sizeof list ? sizeof list - len : 0,
                                "%s%s", len ? " <- " : "", mods[at].id);
        int next = -1;
        for (int k = 0; k < mods[at].ninputs && next < 0; k++) {
            int in = mods[at].input[k];
            if (in >= 0 && !done[in] && seen[in])
                next = in;
        }
        at = next;
    } while (at >= 0 && at != first && len < sizeof list);
    free(seen);
    return gv_fail(err, GV_EINVAL, "filter: the graph has a cycle: %s <- %s",
                   list, mods[first].id);
}

/* Reorder mods topologically (document order among ready modules), with
 * input indices remapped.  Returns 0 or -1 (cycle, reported). */
static int order_modules(struct gv_filter_graph *g, struct gv_error *err)
{
    int n = g->nmodules;
    struct gv_filter_module *mods = g->module;
    int *done = calloc((size_t)n, sizeof *done);
    int *pos = malloc((size_t)n * sizeof *pos);   /* old -> new */
    struct gv_filter_module *out = calloc((size_t)n, sizeof *out);
    if (!done || !pos || !out) {
        free(done);
        free(pos);
        free(out);
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    }
    for (int k = 0; k < n; k++) {
        int pick = -1;
        for (int i = 0; i < n && pick < 0; i++) {
            if (done[i])
                continue;
            int ready = 1;
            for (int j = 0; j < mods[i].ninputs; j++)
                if (mods[i].input[j] >= 0 && !done[mods[i].input[j]])
                    ready = 0;
            if (ready)
                pick = i;
        }
        if (pick < 0) {
            int rc = report_cycle(mods, n, done, err);
            free(done);
            free(pos);
            free(out);
            return rc;
        }
        done[pick] = 1;
        pos[pick] = k;
        out[k] = mods[pick];
    }
    for (int k = 0; k < n; k++)
        for (int j = 0; j < out[k].ninputs; j++)
            if (out[k].input[j] >= 0)
                out[k].input[j] = pos[out[k].input[j]];
    g->output = pos[g->output];
    free(g->module);
    g->module = out;
    free(done);
    free(pos);
    return 0;
}

static int is_reader_of(const struct gv_filter_module *r, int m)
{
    for (int k = 0; k < r->ninputs; k++)
        if (r->input[k] == m)
            return 1;
    return 0;
}

/* Which modules the output depends on (used[]), and the padding of the
 * source: the largest sum of supports along any path to the output, a
 * log-reduce counting at least its block.  Sets the graph's padding and
 * alignment. */
static int plan_padding(struct gv_filter_graph *g, const struct gv_filter_limits *lim,
                        int *used, struct gv_error *err)
{
    int n = g->nmodules;
    const struct gv_filter_module *m = g->module;
    long *need = calloc((size_t)n, sizeof *need); /* padding of i's output */
    if (!need)
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    used[g->output] = 1;
    long src_need = 0;
    int align_log = 0;
    for (int i = n - 1; i >= 0; i--) {
        if (!used[i])
            continue;
        long s = m[i].support;
        if (m[i].tpl == GV_FILTER_LOGREDUCE) {
            if (m[i].max_passes > align_log)
                align_log = m[i].max_passes;
            long block = (1L << m[i].max_passes) - 1;
            if (s < block)
                s = block;
        }
        long want = need[i] + s;
        for (int k = 0; k < m[i].ninputs; k++) {
            int in = m[i].input[k];
            if (in < 0) {
                if (want > src_need)
                    src_need = want;
                if (in == GV_FILTER_VALUES && g->value_channels < 4)
                    g->value_channels = 4;
                if (in == GV_FILTER_VALUES2)
                    g->value_channels = 8;
            } else {
                used[in] = 1;
                if (want > need[in])
                    need[in] = want;
            }
        }
    }
    free(need);
    if (src_need > lim->max_padding)
        return gv_fail(err, GV_ELIMIT,
                       "filter: the supports sum to a padding of %ld pixels, over "
                       "the limit of %d", src_need, lim->max_padding);
    g->pad_left = g->pad_top = g->pad_right = g->pad_bottom = (int)src_need;
    g->align = 1 << align_log;
    return 0;
}

/* Last reader of each module (a module nobody reads lives until its own
 * position: the output, or an unused module). */
static void plan_last_use(struct gv_filter_graph *g, const int *used)
{
    struct gv_filter_module *m = g->module;
    for (int i = 0; i < g->nmodules; i++) {
        m[i].last_use = i;
        m[i].skip_merge = 0;
        m[i].texture = -1;
    }
    for (int i = 0; i < g->nmodules; i++)
        for (int k = 0; k < m[i].ninputs && used[i]; k++)
            if (m[i].input[k] >= 0 && m[m[i].input[k]].last_use < i)
                m[m[i].input[k]].last_use = i;
}

/* Merge skipping (thesis section 7.8.5): a used propagation module whose
 * only reader is one propagation module sweeping the opposite way on the
 * same axis and reading it as input 1 only. */
static void plan_skipped_merges(struct gv_filter_graph *g, const int *used)
{
    struct gv_filter_module *m = g->module;
    int n = g->nmodules;
    for (int i = 0; i < n; i++) {
        if (!used[i] || m[i].tpl != GV_FILTER_PROPAGATION || i == g->output)
            continue;
        int readers = 0, r = -1;
        for (int j = i + 1; j < n; j++)
            if (used[j] && is_reader_of(&m[j], i)) {
                readers++;
                r = j;
            }
        if (readers != 1 || m[r].tpl != GV_FILTER_PROPAGATION ||
            m[r].input[0] != i || m[r].dir_x != -m[i].dir_x ||
            m[r].dir_y != -m[i].dir_y || m[r].format != m[i].format)
            continue;
        int other = 0;
        for (int k = 1; k < m[r].ninputs; k++)
            if (m[r].input[k] == i)
                other = 1;
        if (!other)
            m[i].skip_merge = 1;
    }
}

/* The texture pool of plan_textures: slots of a kind (format, mipmapped),
 * busy or free, and the most ever busy at once. */
enum { MAX_SLOTS = 2 * 64 + 2 };
struct slot_pool {
    int kind[MAX_SLOTS], busy[MAX_SLOTS];
    int nslots, nbusy, peak;
};

/* A free slot of `kind`, not `except`, or a new one; -1 past MAX_SLOTS. */
static int slot_take(struct slot_pool *p, int kind, int except)
{
    int s = 0;
    while (s < p->nslots && (p->busy[s] || p->kind[s] != kind || s == except))
        s++;
    if (s == p->nslots) {
        if (p->nslots >= MAX_SLOTS)
            return -1;
        p->kind[p->nslots++] = kind;
    }
    p->busy[s] = 1;
    if (++p->nbusy > p->peak)
        p->peak = p->nbusy;
    return s;
}

static void slot_give(struct slot_pool *p, int s)
{
    if (p->busy[s]) {
        p->busy[s] = 0;
        p->nbusy--;
    }
}

/* Free the slots of the inputs whose last reader is module i (a
 * skipped-merge predecessor's slots now belong to i). */
static void release_inputs(struct slot_pool *p, const struct gv_filter_module *m,
                           int i)
{
    for (int k = 0; k < m[i].ninputs; k++) {
        int in = m[i].input[k];
        if (in < 0 || m[in].last_use != i || m[in].texture < 0 ||
            m[in].texture == m[i].texture)
            continue;
        int dup = 0;
        for (int q = 0; q < k; q++)
            if (m[i].input[q] == in)
                dup = 1;
        if (!dup)
            slot_give(p, m[in].texture);
    }
}

/* Texture slots, greedily by liveness.  Propagation modules hold two
 * slots of the same kind, the second (the ping-pong partner) freed when
 * the module ends unless its merge is skipped, in which case the reader
 * takes over both.  Sets g->ntextures to the peak. */
static int plan_textures(struct gv_filter_graph *g, const int *used,
                         struct gv_error *err)
{
    struct gv_filter_module *m = g->module;
    struct slot_pool pool = {.nslots = 0};
    int partner[64];
    for (int i = 0; i < g->nmodules && i < 64; i++)
        partner[i] = -1;
    for (int i = 0; i < g->nmodules; i++) {
        if (!used[i])
            continue;
        int kind = (int)m[i].format * 2 + (m[i].tpl == GV_FILTER_LOGREDUCE);
        int prev = m[i].input[0];
        if (m[i].tpl == GV_FILTER_PROPAGATION && prev >= 0 && m[prev].skip_merge) {
            /* In place on the predecessor's pair. */
            m[i].texture = m[prev].texture;
            partner[i] = partner[prev];
            partner[prev] = -1;
        } else {
            int pair = m[i].tpl == GV_FILTER_PROPAGATION;
            m[i].texture = slot_take(&pool, kind, -1);
            int second = pair && m[i].texture >= 0
                         ? slot_take(&pool, kind, m[i].texture) : -1;
            if (m[i].texture < 0 || (pair && second < 0))
                return gv_fail(err, GV_ELIMIT, "filter: too many textures");
            if (i < 64)
                partner[i] = second;
        }
        /* The partner goes back to the pool once the module has merged. */
        if (i < 64 && partner[i] >= 0 && !m[i].skip_merge) {
            slot_give(&pool, partner[i]);
            partner[i] = -1;
        }
        release_inputs(&pool, m, i);
    }
    g->ntextures = pool.peak;
    return 0;
}

/* Padding, merge skipping and texture slots, on the ordered graph.
 * Unused modules keep texture -1 and are neither compiled nor run beyond
 * validation. */
static int plan(struct gv_filter_graph *g, const struct gv_filter_limits *lim,
                struct gv_error *err)
{
    int *used = calloc((size_t)g->nmodules, sizeof *used);
    if (!used)
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    int rc = plan_padding(g, lim, used, err);
    if (rc == 0) {
        plan_last_use(g, used);
        plan_skipped_merges(g, used);
        rc = plan_textures(g, used, err);
    }
    free(used);
    return rc;
}

void gv_filter_graph_free(struct gv_filter_graph *g)
{
    if (!g)
        return;
    for (int i = 0; i < g->nmodules; i++) {
        free(g->module[i].glsl);
        free(g->module[i].kernel);
    }
    free(g->module);
    free(g->description);
    free(g);
}

int gv_filter_graph_find(const struct gv_filter_graph *g, const char *id)
{
    return find(g->module, g->nmodules, id);
}

struct gv_filter_graph *gv_filter_graph_parse(const char *json, size_t len,
                                              const struct gv_filter_limits *lim,
                                              struct gv_error *err)
{
    static const char *const keys[] = {"name", "description", "output",
                                       "output_channels", "modules", NULL};
    struct gv_filter_limits dflt;
    if (!lim) {
        gv_filter_limits_default(&dflt);
        lim = &dflt;
    }
    if (len > lim->max_json_bytes) {
        gv_fail(err, GV_ELIMIT,
                "filter: graph document of %zu bytes exceeds the limit of %zu", len,
                lim->max_json_bytes);
        return NULL;
    }
    int depth = json_depth(json, len, lim->max_json_depth);
    if (depth > lim->max_json_depth) {
        gv_fail(err, GV_ELIMIT, "filter: JSON nested deeper than the limit of %d",
                lim->max_json_depth);
        return NULL;
    }
    json_error_t jerr;
    json_t *root = json_loadb(json, len, JSON_REJECT_DUPLICATES, &jerr);
    if (!root) {
        gv_fail(err, GV_EINVAL, "filter: JSON: %s at line %d column %d", jerr.text,
                jerr.line, jerr.column);
        return NULL;
    }
    struct gv_filter_graph *g = calloc(1, sizeof *g);
    if (!g) {
        json_decref(root);
        gv_fail(err, GV_ENOMEM, "filter: out of memory");
        return NULL;
    }
    if (!json_is_object(root)) {
        fail_m(err, NULL, GV_EINVAL, "a graph must be a JSON object", NULL);
        goto fail;
    }
    if (check_keys(root, keys, NULL, err) < 0)
        goto fail;
    if (get_string(root, "name", g->name, sizeof g->name, NULL, err) < 0)
        goto fail;
    if (!g->name[0]) {
        fail_m(err, NULL, GV_EINVAL, "\"name\" is required (1-127 bytes)", NULL);
        goto fail;
    }
    json_t *d = json_object_get(root, "description");
    if (d && (!json_is_string(d) || json_string_length(d) > 4096)) {
        fail_m(err, NULL, GV_EINVAL, "\"description\" must be a string of at most 4096 bytes",
               NULL);
        goto fail;
    }
    g->description = strdup(d ? json_string_value(d) : "");
    if (!g->description) {
        gv_fail(err, GV_ENOMEM, "filter: out of memory");
        goto fail;
    }
    g->output_channels = 3;
    if (get_int(root, "output_channels", 1, 4, &g->output_channels, NULL, err) < 0)
        goto fail;
    if (g->output_channels == 2) {
        fail_m(err, NULL, GV_EINVAL, "\"output_channels\" must be 1, 3 or 4", NULL);
        goto fail;
    }
    json_t *mods = json_object_get(root, "modules");
    if (!json_is_array(mods) || json_array_size(mods) < 1) {
        fail_m(err, NULL, GV_EINVAL, "\"modules\" must be a non-empty array", NULL);
        goto fail;
    }
    if (json_array_size(mods) > (size_t)lim->max_modules || json_array_size(mods) > 64) {
        gv_fail(err, GV_ELIMIT, "filter: %zu modules exceed the limit of %d",
                json_array_size(mods), lim->max_modules < 64 ? lim->max_modules : 64);
        goto fail;
    }
    g->nmodules = (int)json_array_size(mods);
    g->module = calloc((size_t)g->nmodules, sizeof *g->module);
    if (!g->module) {
        g->nmodules = 0;
        gv_fail(err, GV_ENOMEM, "filter: out of memory");
        goto fail;
    }
    for (int i = 0; i < g->nmodules; i++) {
        if (parse_module(&g->module[i], json_array_get(mods, (size_t)i), lim, err) < 0)
            goto fail;
        if (find(g->module, i, g->module[i].id) >= 0) {
            fail_m(err, g->module[i].id, GV_EINVAL, "duplicate id", NULL);
            goto fail;
        }
    }
    if (resolve_inputs(g->module, g->nmodules, mods, err) < 0)
        goto fail;
    for (int i = 0; i < g->nmodules; i++)
        if (gv_filter_check_body(&g->module[i], err) < 0)
            goto fail;
    char out[GV_FILTER_ID_MAX] = "";
    if (get_string(root, "output", out, sizeof out, NULL, err) < 0)
        goto fail;
    g->output = find(g->module, g->nmodules, out);
    if (g->output < 0) {
        fail_m(err, NULL, GV_EINVAL,
               out[0] ? "\"output\" names no module: " : "\"output\" is required",
               out);
        goto fail;
    }
    if (order_modules(g, err) < 0 || plan(g, lim, err) < 0)
        goto fail;
    int base = 0;
    for (int i = 0; i < g->nmodules; i++) {
        g->module[i].param_base = base;
        base += g->module[i].nparams;
    }
    g->nparams = base;
    json_decref(root);
    return g;
fail:
    json_decref(root);
    gv_filter_graph_free(g);
    return NULL;
}

int gv_filter_params(const struct gv_filter_graph *g, const json_t *given,
                     double *values, struct gv_error *err)
{
    for (int i = 0; i < g->nmodules; i++)
        for (int p = 0; p < g->module[i].nparams; p++)
            values[g->module[i].param_base + p] = g->module[i].param[p].def;
    if (!given || json_is_null(given))
        return 0;
    if (!json_is_object(given))
        return gv_fail(err, GV_EINVAL,
                       "filter: \"params\" must be an object {module: {param: value}}");
    const char *mid;
    json_t *obj;
    json_object_foreach((json_t *)given, mid, obj) {
        int i = gv_filter_graph_find(g, mid);
        if (i < 0)
            return gv_fail(err, GV_EINVAL, "filter: params: no module \"%.60s\"", mid);
        if (!json_is_object(obj))
            return gv_fail(err, GV_EINVAL,
                           "filter: params: \"%s\" must be an object {param: value}", mid);
        const char *pname;
        json_t *v;
        json_object_foreach(obj, pname, v) {
            const struct gv_filter_module *m = &g->module[i];
            int p = -1;
            for (int q = 0; q < m->nparams; q++)
                if (!strcmp(m->param[q].name, pname))
                    p = q;
            if (p < 0)
                return gv_fail(err, GV_EINVAL,
                               "filter: params: module '%s' has no param \"%.60s\"", mid,
                               pname);
            double x;
            if (get_number(v, &x) < 0)
                return gv_fail(err, GV_EINVAL,
                               "filter: params: %s.%s must be a finite number", mid, pname);
            if (x < m->param[p].min || x > m->param[p].max)
                return gv_fail(err, GV_EINVAL,
                               "filter: params: %s.%s = %g is outside [%g, %g]", mid,
                               pname, x, m->param[p].min, m->param[p].max);
            values[m->param_base + p] = x;
        }
    }
    return 0;
}

json_t *gv_filter_graph_describe(const struct gv_filter_graph *g)
{
    static const char *const tpl[] = {"point", "logreduce", "propagation"};
    json_t *mods = json_array();
    if (!mods)
        return NULL;
    for (int i = 0; i < g->nmodules; i++) {
        const struct gv_filter_module *m = &g->module[i];
        json_t *in = json_array(), *params = json_array();
        for (int k = 0; k < m->ninputs; k++)
            json_array_append_new(in, json_string(m->input[k] < 0
                                                      ? gv_filter_reserved_name(m->input[k])
                                                      : g->module[m->input[k]].id));
        for (int p = 0; p < m->nparams; p++)
            json_array_append_new(params,
                                  json_pack("{s:s, s:f, s:f, s:f}", "name",
                                            m->param[p].name, "min", m->param[p].min,
                                            "max", m->param[p].max, "default",
                                            m->param[p].def));
        json_t *o = json_pack("{s:s, s:s, s:s, s:s, s:o, s:o, s:i, s:i, s:b}", "id",
                              m->id, "name", m->name, "template", tpl[m->tpl], "format",
                              gv_filter_format_name(m->format), "inputs", in, "params",
                              params, "support", m->support, "texture", m->texture,
                              "used", m->texture >= 0);
        if (!o) {
            json_decref(mods);
            return NULL;
        }
        if (m->tpl == GV_FILTER_LOGREDUCE)
            json_object_set_new(o, "max_passes", json_integer(m->max_passes));
        if (m->tpl == GV_FILTER_PROPAGATION) {
            json_object_set_new(o, "direction",
                                json_string(m->dir_x > 0   ? "+x"
                                            : m->dir_x < 0 ? "-x"
                                            : m->dir_y > 0 ? "+y"
                                                           : "-y"));
            json_object_set_new(o, "skip_merge", json_boolean(m->skip_merge));
        }
        if (m->kernel)
            json_object_set_new(o, "kernel",
                                json_pack("{s:i, s:i}", "width", m->kernel_w, "height",
                                          m->kernel_h));
        json_array_append_new(mods, o);
    }
    return json_pack("{s:s, s:s, s:s, s:i, s:o, s:i, s:[i,i,i,i], s:i, s:i}", "name",
                     g->name, "description", g->description, "output",
                     g->module[g->output].id, "output_channels", g->output_channels,
                     "modules", mods, "textures", g->ntextures, "padding",
                     g->pad_left, g->pad_top, g->pad_right, g->pad_bottom, "align",
                     g->align, "params", g->nparams);
}
