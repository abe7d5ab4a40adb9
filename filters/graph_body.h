/*
 * graph_body.h - module bodies as text: checking registers and forbidden
 * words (docs/FILTERS.md section 3), expanding registers into the names
 * the templates define, and writing the body of a kernel module.
 * Internal to filters/.
 */
#ifndef GV_FILTER_GRAPH_BODY_H
#define GV_FILTER_GRAPH_BODY_H

#include "filter.h"

/* Check m->glsl: every $(...) register names an input or parameter the
 * module has; no '#', no `uniform`, `layout`, `in`, `out`, `buffer`,
 * `shared` or `precision` word; braces never close the body's function.
 * Returns 0, or -1 with GV_EINVAL "module 'id' line N: ...". */
int gv_filter_check_body(const struct gv_filter_module *m, struct gv_error *err);

/* The body with $(FilterInputN) replaced by gv_inN and $(N) by
 * gv_p[N-1]; line breaks are kept, so lines still count from the body's
 * first.  malloc'ed, NULL when out of memory.  The body must have passed
 * gv_filter_check_body. */
char *gv_filter_expand_body(const char *glsl);

/* The body of a kernel module (FILTERS.md section 3.4): malloc'ed. */
char *gv_filter_kernel_body(const float *w, int kw, int kh, float scale,
                            float bias);

/* "rgba32f" etc. */
const char *gv_filter_format_name(enum gv_filter_format f);

#endif
