/*
 * filter.h - filter graphs (docs/FILTERS.md): parse and validate the JSON,
 * order the modules, plan the textures, pad the region of interest, and
 * run the graph on the EGL context with the point, log-reduce and
 * propagation templates (thesis sections 7.7 and 7.8).
 *
 * A graph is parsed once (graph.c: pure C, no GL, fuzzed by
 * tests/fuzz/fuzz_filter_graph.c) into an immutable struct gv_filter_graph
 * that holds the modules in topological order, the texture plan and the
 * padding.  gv_filter_run (run_gpu.c) evaluates it on a gv_gpu context
 * over one padded RGBA8 input region and returns the region of interest
 * as float RGBA; in a build configured --without-gpu, run_none.c stands
 * in and fails.  Running user GLSL is not safe in a process that serves
 * other requests: gigaviewd runs graphs in worker processes (worker.h).
 *
 * Errors: GV_EINVAL for anything wrong with the graph or the request (the
 * message names the module and, for GLSL, the line in the module's own
 * body), GV_ELIMIT for a configured limit, GV_ENOMEM, GV_EIO for a GPU
 * failure.
 */
#ifndef GV_FILTER_H
#define GV_FILTER_H

#include <stddef.h>
#include <stdint.h>

#include <jansson.h>

#include "base/error.h"
#include "base/ids.h"

struct gv_gpu;

#define GV_FILTER_ID_MAX (GV_FILTER_ID_LEN + 1) /* ids, names of parameters:
                                                  bytes+1 (base/ids.h) */
#define GV_FILTER_MAX_INPUTS 8     /* $(FilterInput1..8) */
#define GV_FILTER_MAX_PARAMS 16    /* $(1..16) per module */
#define GV_FILTER_KERNEL_MAX 63    /* kernel width/height, odd */

enum gv_filter_template {
    GV_FILTER_POINT = 0,
    GV_FILTER_LOGREDUCE,
    GV_FILTER_PROPAGATION
};

/* Texel format of a module's output.  Float formats read as vec4 in the
 * bodies of the modules that use them, the integer ones as uvec4/ivec4. */
enum gv_filter_format {
    GV_FILTER_RGBA32F = 0,  /* default */
    GV_FILTER_RGBA16F,
    GV_FILTER_RGBA8,
    GV_FILTER_RGBA32UI,
    GV_FILTER_RGBA32I
};

/* An input names a module (its index) or one of the reserved inputs
 * (negative): the source image as 8-bit RGBA in [0, 1], or the store's
 * samples as values in its unit (code * scale + offset), channels 1-4
 * (GV_FILTER_VALUES) and 5-8 (GV_FILTER_VALUES2). */
#define GV_FILTER_SOURCE (-1)
#define GV_FILTER_VALUES (-2)
#define GV_FILTER_VALUES2 (-3)
#define GV_FILTER_RESERVED_INPUTS 3    /* -1 .. -3 */

/* The name of reserved input `in` (GV_FILTER_SOURCE ...): "source",
 * "values", "values2". */
const char *gv_filter_reserved_name(int in);

struct gv_filter_param {
    char name[GV_FILTER_ID_MAX];
    double min, max, def;
};

struct gv_filter_module {
    char id[GV_FILTER_ID_MAX];
    char name[128];
    enum gv_filter_template tpl;
    enum gv_filter_format format;
    int max_passes;          /* logreduce: at most this many levels (>= 1) */
    int dir_x, dir_y;        /* propagation: (1,0) +x, (-1,0) -x, (0,1) +y,
                                (0,-1) -y */
    int ninputs;
    int input[GV_FILTER_MAX_INPUTS];   /* module index or a reserved input */
    int nparams;
    struct gv_filter_param param[GV_FILTER_MAX_PARAMS];
    int param_base;          /* index of $(1) in the run's flat value array */
    int support;             /* declared, or from the kernel: pixels */
    char *glsl;              /* the body; generated for kernel modules */
    int kernel_w, kernel_h;  /* 0 unless the module is a kernel */
    float *kernel;           /* kernel_w * kernel_h weights, row major */

    /* ---- planned (graph.c) ---- */
    int texture;             /* the texture slot holding the output */
    int last_use;            /* order position of the last reader, or the
                                module's own position if none */
    int skip_merge;          /* propagation: the only reader sweeps the
                                opposite way, so no merge pass */
};

struct gv_filter_graph {
    char name[128];
    char *description;       /* "" if none */
    int nmodules;
    struct gv_filter_module *module;  /* in topological order */
    int output;              /* index of the output module */
    int output_channels;     /* 1, 3 or 4 for encoded outputs */
    int nparams;             /* sum of the modules' nparams */
    int ntextures;           /* texture slots after greedy recycling */
    /* Padding of the region of interest: the largest sum of supports
     * along any path from the source to the output, per side. */
    int pad_left, pad_top, pad_right, pad_bottom;
    /* The store channels the graph reads as values: 0 (it reads no
     * values), 4 (values) or 8 (values2); the caller sends that many,
     * those past the store's own channels read 0. */
    int value_channels;
    /* The padded region's left and top edges must be multiples of this
     * in level coordinates (2^max_passes of the deepest log-reduce, else
     * 1), so that log-reduce blocks are aligned to the image. */
    int align;
};

struct gv_filter_limits {
    size_t max_json_bytes;     /* size of the graph document */
    int max_json_depth;        /* nesting of arrays and objects */
    int max_modules;
    size_t max_glsl_bytes;     /* per module body */
    int max_padding;           /* per side, after summing supports */
};

/* The defaults documented in docs/FILTERS.md. */
void gv_filter_limits_default(struct gv_filter_limits *lim);

/*
 * Parse and validate a graph document (len bytes, not necessarily NUL-
 * terminated).  Checks everything but GLSL compilation: syntax, the
 * schema, unknown templates and formats, missing or dangling inputs,
 * cycles, parameter ranges, kernel shapes, limits.  Orders the modules
 * topologically and plans textures and padding.  Returns the graph, or
 * NULL with *err (GV_EINVAL with a message naming the module and field,
 * GV_ELIMIT for a limit, GV_ENOMEM).
 */
struct gv_filter_graph *gv_filter_graph_parse(const char *json, size_t len,
                                              const struct gv_filter_limits *lim,
                                              struct gv_error *err);

void gv_filter_graph_free(struct gv_filter_graph *g);

/* Index of the module with this id, or -1. */
int gv_filter_graph_find(const struct gv_filter_graph *g, const char *id);

/*
 * The graph as seen by users (GET /v1/filters/{fid}, the viewer's panel):
 * name, description, output, modules in order with their template,
 * inputs, parameters and texture slot, the padding and the texture count.
 * New reference, or NULL on allocation failure.
 */
json_t *gv_filter_graph_describe(const struct gv_filter_graph *g);

/*
 * Fill values[g->nparams] with the defaults, then apply `given` (may be
 * NULL): an object {"module_id": {"param_name": number, ...}, ...}.  An
 * unknown module or parameter, a non-number or a value outside [min, max]
 * is GV_EINVAL naming it.  Returns 0 or -1.
 */
int gv_filter_params(const struct gv_filter_graph *g, const json_t *given,
                     double *values, struct gv_error *err);

/* How propagation modules run (docs/FILTERS.md section 4.3). */
enum gv_filter_path {
    GV_FILTER_PATH_AUTO = 0,    /* compute where the context has it */
    GV_FILTER_PATH_FRAGMENT,    /* the thesis's one draw per line */
    GV_FILTER_PATH_COMPUTE      /* 32 lines per dispatch */
};

/* One run's input: the padded region and where the ROI lies in it. */
struct gv_filter_input {
    uint32_t w, h;            /* padded region, >= 1 each */
    const uint8_t *rgba;      /* w*h RGBA8 texels, rows packed, top first */
    uint32_t roi_x, roi_y;    /* the ROI inside the padded region */
    uint32_t roi_w, roi_h;    /* >= 1, inside the padded region */
    int64_t abs_x, abs_y;     /* level coordinates of the padded region's
                                 top-left texel (abs_pos = these + texel) */
    uint32_t viewport_w, viewport_h;  /* backBufferSize; 0: the ROI size */
    /* The store's samples for the values inputs: w*h*nvalues codes, 2
     * bytes each little-endian, channel-interleaved, rows packed; the
     * value of a code is code * values_scale + values_offset, rounded to
     * float; channels past nvalues read 0.  nvalues 0 (values NULL): an
     * image's run, whose values are the source's RGBA bytes as 0..255
     * (values2 0).  At most 8. */
    const uint8_t *values;
    int nvalues;
    double values_scale, values_offset;
    const double *params;     /* g->nparams values (gv_filter_params) */
    enum gv_filter_path path;
};

struct gv_filter_stats {
    int passes;               /* draw calls or dispatches of module passes */
    int compute;              /* 1 if propagation ran as compute shaders */
    int merges;               /* propagation merge passes run */
    int merges_skipped;       /* merges skipped (section 7.8.5) */
    int line_copies;          /* single-line copies between ping-pong pairs */
    int textures;             /* texture slots used (= g->ntextures) */
    double gpu_ms;            /* wall time on the GL thread */
};

/*
 * Compile every module's program on `gpu` without running anything.
 * A compile error is GV_EINVAL: "module 'id' line N: <driver message>",
 * N counting lines of the module's own body from 1.  Returns 0 or -1.
 */
int gv_filter_compile(struct gv_gpu *gpu, const struct gv_filter_graph *g,
                      struct gv_error *err);

/*
 * Run g on `in` (compiling as gv_filter_compile does) and set *out to a
 * malloc'ed float array of in->roi_w * in->roi_h * 4 values, RGBA, rows
 * packed, top first: the output module's texels inside the ROI.  Integer
 * formats are converted to float as they are.  stats may be NULL.
 * Returns 0 or -1 with *err.
 */
int gv_filter_run(struct gv_gpu *gpu, const struct gv_filter_graph *g,
                  const struct gv_filter_input *in, float **out,
                  struct gv_filter_stats *stats, struct gv_error *err);

#endif
