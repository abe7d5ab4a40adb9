/*
 * run_none.c - gv_filter_compile and gv_filter_run (filter.h) in a build
 * configured --without-gpu, in place of run_gpu.c: there is no EGL to run
 * a graph on, so both fail, saying so.  Parsing, planning and the CPU
 * distance transform are built all the same; gigaviewd never starts a
 * filter worker in such a build (server/main.c), so in practice only the
 * worker protocol code (worker.c) links these.
 */
#include "filter.h"

static int no_gpu(struct gv_error *err)
{
    return gv_fail(err, GV_EIO, "filter: running a graph needs GPU support, "
                   "which this build lacks (configured --without-gpu)");
}

int gv_filter_compile(struct gv_gpu *gpu, const struct gv_filter_graph *g,
                      struct gv_error *err)
{
    (void)gpu;
    (void)g;
    return no_gpu(err);
}

int gv_filter_run(struct gv_gpu *gpu, const struct gv_filter_graph *g,
                  const struct gv_filter_input *in, float **out,
                  struct gv_filter_stats *stats, struct gv_error *err)
{
    (void)gpu;
    (void)g;
    (void)in;
    (void)stats;
    *out = NULL;
    return no_gpu(err);
}
