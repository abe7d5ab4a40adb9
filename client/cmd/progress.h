/*
 * progress.h - a one-line progress bar on a terminal: percent, speed in
 * megapixels per second and estimated time left.  Prints nothing when the
 * stream is not a terminal, so logs and pipes stay clean.
 */
#ifndef GV_PROGRESS_H
#define GV_PROGRESS_H

#include <stdint.h>
#include <stdio.h>

struct progress;

/* A bar on `out` if it is a terminal (or force is set), else a silent one.
 * Returns NULL only when out of memory. */
struct progress *progress_new(FILE *out, int force);

/* Show `fraction` (0..1) of `total_pixels` done, in phase `phase`.  Redraws
 * at most 10 times a second. */
void progress_update(struct progress *p, double fraction, uint64_t total_pixels,
                     const char *phase);

/* End the line.  NULL does nothing. */
void progress_free(struct progress *p);

#endif
