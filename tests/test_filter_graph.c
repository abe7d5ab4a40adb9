/*
 * test_filter_graph.c - filter graph documents without a GPU
 * (filters/graph.c): every validation failure with its message, the
 * topological order, texture recycling counts, padding and alignment,
 * merge skipping, parameter values, and the description.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "filter.h"
#include "util.h"

static struct gv_filter_graph *try_parse(const char *json, struct gv_error *err)
{
    return gv_filter_graph_parse(json, strlen(json), NULL, err);
}

/* Expect a failure with `code` and exactly the message `want`. */
static void bad(const char *json, enum gv_code code, const char *want, const char *what)
{
    struct gv_error err = {0};
    struct gv_filter_graph *g = try_parse(json, &err);
    check_str(!g && err.code == code ? err.text : NULL, want, "%s (code %d)", what,
              (int)err.code);
    gv_filter_graph_free(g);
}

#define PT(id, in) \
    "{\"id\":\"" id "\",\"template\":\"point\",\"inputs\":[" in "],\"glsl\":\"return vec4(0.0);\"}"

static void test_errors(void)
{
    bad("{\"name\":", GV_EINVAL,
        "filter: JSON: unexpected token near end of file at line 1 column 8",
        "malformed JSON");
    bad("[1]", GV_EINVAL, "filter: a graph must be a JSON object", "not an object");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[" PT("a", "\"source\"") "],\"extra\":1}",
        GV_EINVAL, "filter: unknown key \"extra\"", "unknown top-level key");
    bad("{\"output\":\"a\",\"modules\":[" PT("a", "\"source\"") "]}", GV_EINVAL,
        "filter: \"name\" is required (1-127 bytes)", "missing name");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"blur\","
        "\"inputs\":[\"source\"],\"glsl\":\"return vec4(0.0);\"}]}",
        GV_EINVAL,
        "filter: module 'a': unknown template (point, logreduce, propagation): blur",
        "unknown template");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[" PT("a", "\"nothere\"") "]}",
        GV_EINVAL, "filter: module 'a': input 1 names no module: \"nothere\"", "missing input");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[" PT("a", "\"b\"") "," PT("b", "\"c\"")
        "," PT("c", "\"a\"") "]}",
        GV_EINVAL, "filter: the graph has a cycle: a <- b <- c <- a", "a cycle");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[" PT("a", "\"a\"") "]}", GV_EINVAL,
        "filter: module 'a': a module cannot read its own output (cycle)", "a self-loop");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[" PT("a", "\"source\"") ","
        PT("a", "\"source\"") "]}",
        GV_EINVAL, "filter: module 'a': duplicate id", "a duplicate id");
    bad("{\"name\":\"x\",\"output\":\"zz\",\"modules\":[" PT("a", "\"source\"") "]}",
        GV_EINVAL, "filter: \"output\" names no module: zz", "a dangling output");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"params\":[{\"name\":\"g\",\"min\":0,\"max\":1,\"default\":2}],"
        "\"glsl\":\"return vec4($(1));\"}]}",
        GV_EINVAL,
        "filter: module 'a': default outside [min, max]: param g",
        "a default out of range");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"params\":[{\"name\":\"g\",\"min\":2,\"max\":1,\"default\":1}],"
        "\"glsl\":\"return vec4($(1));\"}]}",
        GV_EINVAL, "filter: module 'a': min > max: param g", "min above max");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"glsl\":\"return vec4($(2));\"}]}",
        GV_EINVAL, "filter: module 'a' line 1: $(2) but the module has 0 params",
        "a parameter register past the count");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"glsl\":\"vec4 v = $(FilterInput1)(rel_pos);\\n"
        "return $(FilterInput2)(rel_pos);\"}]}",
        GV_EINVAL, "filter: module 'a' line 2: $(FilterInput2) but the module has 1 input",
        "an input register past the count");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"glsl\":\"return $(Foo);\"}]}",
        GV_EINVAL,
        "filter: module 'a' line 1: unknown register (use $(FilterInputN) or $(N))",
        "an unknown register");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"glsl\":\"uniform float q;\\nreturn vec4(0.0);\"}]}",
        GV_EINVAL,
        "filter: module 'a' line 1: 'uniform' is not allowed in a body "
        "(the template owns the interface)",
        "a body declaring a uniform");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"glsl\":\"#define X 1\\nreturn vec4(0.0);\"}]}",
        GV_EINVAL,
        "filter: module 'a' line 1: preprocessor directives are not allowed in a body",
        "a preprocessor directive");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"propagation\","
        "\"inputs\":[\"source\"],\"glsl\":\"return vec4(0.0);\"}]}",
        GV_EINVAL,
        "filter: module 'a': propagation needs \"direction\": \"+x\", \"-x\", \"+y\" or \"-y\"",
        "propagation without a direction");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
        "\"direction\":\"+x\",\"inputs\":[\"source\"],\"glsl\":\"return vec4(0.0);\"}]}",
        GV_EINVAL,
        "filter: module 'a': \"direction\" is for the propagation template only",
        "a direction on a point module");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"kernel\":{\"width\":3,\"height\":3,\"weights\":[1,2]}}]}",
        GV_EINVAL,
        "filter: module 'a': kernel \"weights\" must hold width x height = 9 numbers",
        "a kernel of the wrong size");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"kernel\":{\"width\":2,\"height\":3,\"weights\":[1,2,3,4,5,6]}}]}",
        GV_EINVAL,
        "filter: module 'a': kernel width and height must be odd, 1-63",
        "an even kernel");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
        "\"format\":\"rgb9\",\"inputs\":[\"source\"],\"glsl\":\"return vec4(0.0);\"}]}",
        GV_EINVAL,
        "filter: module 'a': unknown format (rgba32f, rgba16f, rgba8, rgba32ui, rgba32i): rgb9",
        "an unknown format");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"source\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"glsl\":\"return vec4(0.0);\"}]}",
        GV_EINVAL,
        "filter: module 'source': the id \"source\" is reserved",
        "the reserved id source");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"propagation\","
        "\"direction\":\"+x\",\"format\":\"rgba32ui\",\"inputs\":[\"source\"],"
        "\"glsl\":\"return uvec4(0u);\"}]}",
        GV_EINVAL,
        "filter: module 'a': an integer logreduce or propagation module cannot start "
        "from the source or values (add a point module that converts it)",
        "an integer sweep over the source");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"values2\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"glsl\":\"return vec4(0.0);\"}]}",
        GV_EINVAL,
        "filter: module 'values2': the id \"values2\" is reserved",
        "the reserved id values2");
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[" PT("a", "\"values3\"") "]}",
        GV_EINVAL, "filter: module 'a': input 1 names no module: \"values3\"",
        "values3 is no input");

    /* Limits. */
    char deep[256] = "";
    for (int i = 0; i < 20; i++)
        strcat(deep, "[");
    bad(deep, GV_ELIMIT,
        "filter: JSON nested deeper than the limit of 16",
        "JSON depth over the limit");
    char *many = malloc(64 * 1024);
    strcpy(many, "{\"name\":\"x\",\"output\":\"m0\",\"modules\":[");
    for (int i = 0; i < 33; i++)
        sprintf(many + strlen(many), "%s{\"id\":\"m%d\",\"template\":\"point\",\"inputs\":[\"source\"],"
                "\"glsl\":\"return vec4(0.0);\"}", i ? "," : "", i);
    strcat(many, "]}");
    bad(many, GV_ELIMIT, "filter: 33 modules exceed the limit of 32", "too many modules");
    free(many);
    char *big = malloc(40 * 1024);
    strcpy(big, "{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
                "\"inputs\":[\"source\"],\"glsl\":\"");
    size_t n = strlen(big);
    memset(big + n, ' ', 17 * 1024);
    strcpy(big + n + 17 * 1024, "return vec4(0.0);\"}]}");
    bad(big, GV_ELIMIT,
        "filter: module 'a': GLSL body of 17425 bytes exceeds the limit of 16384",
        "a GLSL body over the limit");
    free(big);
    bad("{\"name\":\"x\",\"output\":\"a\",\"modules\":[{\"id\":\"a\",\"template\":\"point\","
        "\"support\":600,\"inputs\":[\"source\"],\"glsl\":\"return vec4(0.0);\"}]}",
        GV_ELIMIT,
        "filter: the supports sum to a padding of 600 pixels, over the limit of 512",
        "padding over the limit");
    struct gv_filter_limits lim;
    gv_filter_limits_default(&lim);
    lim.max_json_bytes = 10;
    struct gv_error err = {0};
    const char *small = "{\"name\":\"xxxxxxxxxxxxxxxxxxxx\"}";
    struct gv_filter_graph *g = gv_filter_graph_parse(small, strlen(small), &lim, &err);
    check_str(!g && err.code == GV_ELIMIT ? err.text : NULL,
              "filter: graph document of 31 bytes exceeds the limit of 10",
              "document size over a configured limit");
}

static void test_order_and_plan(void)
{
    /* Listed out of order: c reads b reads a; d reads source and c. */
    const char *doc =
        "{\"name\":\"chain\",\"output\":\"d\",\"modules\":["
        PT("c", "\"b\"") "," PT("d", "\"source\",\"c\"") "," PT("b", "\"a\"") ","
        PT("a", "\"source\"") "," PT("unused", "\"a\"") "]}";
    struct gv_error err = {0};
    struct gv_filter_graph *g = try_parse(doc, &err);
    if (!g)
        fail("%s", err.text);
    char order[64] = "";
    for (int i = 0; i < g->nmodules; i++)
        strcat(strcat(order, g->module[i].id), " ");
    check(!strcmp(order, "a b c d unused "),
          "topological order: %s", order);
    /* a -> b -> c -> d is a chain: two textures alternate. */
    check(g->ntextures == 2, "a chain of four point modules needs 2 textures (%d)",
          g->ntextures);
    check(g->module[4].texture == -1, "a module the output does not need is not run");
    gv_filter_graph_free(g);

    /* A fan: a feeds b, c and d, which all feed e: a's texture lives
     * until d has run, so 4 are in use at the peak. */
    doc = "{\"name\":\"fan\",\"output\":\"e\",\"modules\":[" PT("a", "\"source\"") ","
          PT("b", "\"a\"") "," PT("c", "\"a\"") "," PT("d", "\"a\"") ","
          PT("e", "\"b\",\"c\",\"d\"") "]}";
    g = try_parse(doc, &err);
    check(g && g->ntextures == 4, "fan-out of 3 readers: 4 textures (%d)",
          g ? g->ntextures : -1);
    gv_filter_graph_free(g);

    /* Padding: supports 2 then 3 on one path, 4 then 3 on the other: 7. */
    doc = "{\"name\":\"pad\",\"output\":\"c\",\"modules\":["
          "{\"id\":\"a\",\"template\":\"point\",\"support\":2,\"inputs\":[\"source\"],\"glsl\":\"return vec4(0.0);\"},"
          "{\"id\":\"b\",\"template\":\"point\",\"support\":4,\"inputs\":[\"source\"],\"glsl\":\"return vec4(0.0);\"},"
          "{\"id\":\"c\",\"template\":\"point\",\"support\":3,\"inputs\":[\"a\",\"b\"],\"glsl\":\"return vec4(0.0);\"}]}";
    g = try_parse(doc, &err);
    check(g && g->pad_left == 7 && g->pad_right == 7 && g->align == 1,
          "padding is the largest sum of supports along a path: 7 (%d)",
          g ? g->pad_left : -1);
    gv_filter_graph_free(g);

    /* A kernel's support comes from its size. */
    doc = "{\"name\":\"k\",\"output\":\"k\",\"modules\":[{\"id\":\"k\",\"template\":\"point\","
          "\"inputs\":[\"source\"],\"kernel\":{\"width\":7,\"height\":3,\"weights\":"
          "[1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1]}}]}";
    g = try_parse(doc, &err);
    check(g && g->pad_left == 3, "a 7x3 kernel pads 3 (%d)", g ? g->pad_left : -1);
    gv_filter_graph_free(g);

    /* Merge skipping only for the opposite sweep on the same axis. */
#define SW(id, dir, in) \
    "{\"id\":\"" id "\",\"template\":\"propagation\",\"direction\":\"" dir \
    "\",\"inputs\":[" in "],\"glsl\":\"return $(FilterInput1)(rel_pos);\"}"
    doc = "{\"name\":\"sw\",\"output\":\"d\",\"modules\":[" SW("a", "+x", "\"source\"") ","
          SW("b", "-x", "\"a\"") "," SW("c", "-y", "\"b\"") "," SW("d", "-y", "\"c\"") "]}";
    g = try_parse(doc, &err);
    check(g && g->module[0].skip_merge && !g->module[1].skip_merge &&
              !g->module[2].skip_merge,
          "merge skipped before an opposite sweep only (+x -> -x yes, -x -> -y no, -y -> -y no)");
    /* a and b share a pair; c and d each need a new pair while their
     * input is alive: 1 + 2 at the peak. */
    check(g && g->ntextures == 3, "a sweep chain needs 3 textures (%d)",
          g ? g->ntextures : -1);
    gv_filter_graph_free(g);
    doc = "{\"name\":\"sw2\",\"output\":\"c\",\"modules\":[" SW("a", "+x", "\"source\"") ","
          SW("b", "-x", "\"a\"") ","
          "{\"id\":\"c\",\"template\":\"point\",\"inputs\":[\"a\",\"b\"],\"glsl\":\"return vec4(0.0);\"}]}";
    g = try_parse(doc, &err);
    check(g && !g->module[0].skip_merge,
          "no merge skipping when another module also reads the sweep");
    gv_filter_graph_free(g);

    /* Log-reduce alignment. */
    doc = "{\"name\":\"lr\",\"output\":\"s\",\"modules\":["
          "{\"id\":\"r\",\"template\":\"logreduce\",\"max_passes\":5,\"inputs\":[\"source\"],"
          "\"glsl\":\"return $(FilterInput1)(2 * texel_pos);\"},"
          PT("s", "\"r\"") "]}";
    g = try_parse(doc, &err);
    check(g && g->align == 32 && g->pad_left == 31, "logreduce of 5 passes: align 32, pad 31");
    gv_filter_graph_free(g);
}

static void test_params(void)
{
    const char *doc =
        "{\"name\":\"p\",\"output\":\"b\",\"modules\":["
        "{\"id\":\"a\",\"template\":\"point\",\"inputs\":[\"source\"],\"params\":["
        "{\"name\":\"x\",\"min\":0,\"max\":1,\"default\":0.25},"
        "{\"name\":\"y\",\"min\":-5,\"max\":5,\"default\":1}],\"glsl\":\"return vec4($(1), $(2), 0.0, 1.0);\"},"
        "{\"id\":\"b\",\"template\":\"point\",\"inputs\":[\"a\"],\"params\":["
        "{\"name\":\"z\",\"min\":0,\"max\":10,\"default\":3}],\"glsl\":\"return vec4($(1));\"}]}";
    struct gv_error err = {0};
    struct gv_filter_graph *g = try_parse(doc, &err);
    if (!g)
        fail("%s", err.text);
    double v[3];
    json_t *given = json_loads("{\"a\":{\"y\":-2},\"b\":{\"z\":10}}", 0, NULL);
    int rc = gv_filter_params(g, given, v, &err);
    check(rc == 0 && g->nparams == 3 && v[0] == 0.25 && v[1] == -2 && v[2] == 10,
          "params: defaults and given values in module order");
    json_decref(given);
    const char *badp[][2] = {
        {"{\"a\":{\"y\":6}}", "filter: params: a.y = 6 is outside [-5, 5]"},
        {"{\"q\":{\"y\":1}}", "filter: params: no module \"q\""},
        {"{\"a\":{\"w\":1}}", "filter: params: module 'a' has no param \"w\""},
        {"{\"a\":{\"y\":\"1\"}}", "filter: params: a.y must be a finite number"}};
    for (int i = 0; i < 4; i++) {
        given = json_loads(badp[i][0], 0, NULL);
        gv_error_clear(&err);
        rc = gv_filter_params(g, given, v, &err);
        check_str(rc < 0 && err.code == GV_EINVAL ? err.text : NULL, badp[i][1],
                  "bad params %s", badp[i][0]);
        json_decref(given);
    }
    /* The whole description, in jansson's insertion order. */
    json_t *d = gv_filter_graph_describe(g);
    char *s = json_dumps(d, JSON_COMPACT);
    check_str(s,
              "{\"name\":\"p\",\"description\":\"\",\"output\":\"b\",\"output_channels\":3,"
              "\"modules\":[{\"id\":\"a\",\"name\":\"a\",\"template\":\"point\","
              "\"format\":\"rgba32f\",\"inputs\":[\"source\"],\"params\":["
              "{\"name\":\"x\",\"min\":0.0,\"max\":1.0,\"default\":0.25},"
              "{\"name\":\"y\",\"min\":-5.0,\"max\":5.0,\"default\":1.0}],"
              "\"support\":0,\"texture\":0,\"used\":true},"
              "{\"id\":\"b\",\"name\":\"b\",\"template\":\"point\",\"format\":\"rgba32f\","
              "\"inputs\":[\"a\"],\"params\":[{\"name\":\"z\",\"min\":0.0,\"max\":10.0,"
              "\"default\":3.0}],\"support\":0,\"texture\":1,\"used\":true}],"
              "\"textures\":2,\"padding\":[0,0,0,0],\"align\":1,\"params\":3}",
              "describe: the whole description");
    free(s);
    json_decref(d);
    gv_filter_graph_free(g);
}

/* The values inputs: which store channels a graph reads (only those of
 * modules the output needs), padding from them as from the source, and
 * their names in the description. */
static void test_values(void)
{
    static const struct {
        const char *doc;
        int channels;
        const char *what;
    } cases[] = {
        {"{\"name\":\"v\",\"output\":\"a\",\"modules\":[" PT("a", "\"source\"") "]}", 0,
         "a graph of the source reads no values"},
        {"{\"name\":\"v\",\"output\":\"a\",\"modules\":[" PT("a", "\"values\"") "]}", 4,
         "values: channels 1-4"},
        {"{\"name\":\"v\",\"output\":\"b\",\"modules\":[" PT("a", "\"values2\"") ","
         PT("b", "\"a\",\"values\"") "]}", 8, "values2 through a module: channels 1-8"},
        {"{\"name\":\"v\",\"output\":\"b\",\"modules\":[" PT("a", "\"values2\"") ","
         PT("b", "\"source\"") "]}", 0, "values read only by an unused module: none"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        struct gv_error err = {0};
        struct gv_filter_graph *g = try_parse(cases[i].doc, &err);
        check(g && g->value_channels == cases[i].channels, "%s (%d)", cases[i].what,
              g ? g->value_channels : -1);
        gv_filter_graph_free(g);
    }
    const char *doc = "{\"name\":\"v\",\"output\":\"b\",\"modules\":["
                      "{\"id\":\"a\",\"template\":\"point\",\"support\":3,"
                      "\"inputs\":[\"values\"],\"glsl\":\"return vec4(0.0);\"},"
                      PT("b", "\"a\",\"values2\",\"source\"") "]}";
    struct gv_error err = {0};
    struct gv_filter_graph *g = try_parse(doc, &err);
    if (!g)
        fail("%s", err.text);
    check(g->pad_left == 3 && g->pad_bottom == 3, "a support over values pads (%d)",
          g->pad_left);
    json_t *d = gv_filter_graph_describe(g);
    char *s = d ? json_dumps(json_object_get(json_array_get(json_object_get(d, "modules"),
                                                            1), "inputs"), JSON_COMPACT)
                : NULL;
    check_str(s, "[\"a\",\"values2\",\"source\"]", "describe names the reserved inputs");
    free(s);
    json_decref(d);
    gv_filter_graph_free(g);
}

int main(void)
{
    test_errors();
    test_order_and_plan();
    test_params();
    test_values();
    return tap_done();
}
