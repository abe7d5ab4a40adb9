/*
 * summary.h - the summary `gigaview encode` and `gigaview merge` print
 * after writing a store.
 */
#ifndef GV_SUMMARY_H
#define GV_SUMMARY_H

#include "encode/stream_encoder.h"

/* Print the store summary of *r for `output` on stdout: size, levels,
 * tiles by rate, bits per source pixel, level-0 PSNR against `target`
 * (dB: the whole image's, or every tile's when r->per_tile), time. */
void print_store_summary(const char *output, const struct gv_encode_result *r,
                         double target);

#endif
