/*
 * limits.c - the default resource limits of filter graphs
 * (docs/FILTERS.md section 7; gigaviewd overrides them from its
 * configuration file).
 */
#include "filter.h"

void gv_filter_limits_default(struct gv_filter_limits *lim)
{
    lim->max_json_bytes = 64 * 1024;
    lim->max_json_depth = 16;
    lim->max_modules = 32;
    lim->max_glsl_bytes = 16 * 1024;
    lim->max_padding = 512;
}
