/*
 * slide_openslide.h - whole-slide images through OpenSlide: level 0 of an
 * Aperio SVS, Hamamatsu NDPI or VMS, MIRAX, Leica SCN, Philips, Sakura,
 * Trestle or Ventana slide, read in strips as 8-bit RGB, with the
 * scanner's metadata.  Used by imageio_loader.c behind gv_image_open /
 * gv_image_read / gv_image_close; internal to lib/imageio.  Built when
 * configure found OpenSlide (GV_HAVE_OPENSLIDE).
 */
#ifndef GV_SLIDE_OPENSLIDE_H
#define GV_SLIDE_OPENSLIDE_H

#include <stdint.h>

#include "base/error.h"
#include "imageio/imageio.h"

struct gv_slide;

/*
 * Open `path` if OpenSlide recognises a scanner's format in it
 * (openslide_detect_vendor names a vendor other than "generic-tiff": a
 * plain tiled TIFF is left to the TIFF readers, which deliver the same
 * level 0 and keep 16-bit and grey samples).  Returns the reader; NULL
 * with err->code GV_OK when it declines (no vendor, or OpenSlide cannot
 * be loaded); NULL with *err filled when the slide is refused (GV_ELIMIT
 * past lim, GV_ECORRUPT when OpenSlide fails to open it).  info: 3
 * channels, 8 bits, format "openslide".  err must not be NULL.
 */
struct gv_slide *gv_slide_open(const char *path,
                               const struct gv_image_limits *lim,
                               struct gv_image_info *info,
                               struct gv_error *err);

/* The next `rows` rows as 8-bit RGB, as gv_image_read. */
int gv_slide_read(struct gv_slide *s, uint32_t rows, void *out,
                  struct gv_error *err);

/* The scanner's metadata as store metadata JSON (store/store_meta.h:
 * slide.vendor, slide.mpp_x, slide.mpp_y, slide.objective_power,
 * slide.levels), valid until close; never NULL for an open slide. */
const char *gv_slide_meta(const struct gv_slide *s);

/* Close.  NULL does nothing. */
void gv_slide_close(struct gv_slide *s);

#endif
