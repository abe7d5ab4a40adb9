/*
 * psd_thumbnail.h - the decoder memory limit of imageio.h for the JPEG
 * thumbnail of a Photoshop file, which OpenImageIO's PSD reader decodes
 * whole when it opens the file (psd_thumbnail.c says why this matters).
 * Used by imageio_loader.c before it hands a PSD to the module; internal
 * to lib/imageio.
 */
#ifndef GV_PSD_THUMBNAIL_H
#define GV_PSD_THUMBNAIL_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "imageio/imageio.h"

/* Whether the first n bytes of a file are a PSD or PSB signature. */
int gv_psd_sniff(const uint8_t *head, size_t n);

/*
 * Check the thumbnails (image resources 1033 and 1036) of the Photoshop
 * file `path` against lim->max_decoder_bytes.  Returns -1 with *err
 * filled (GV_ELIMIT) for one that would need more, else 0 (also for a
 * file whose resources cannot be walked: the module then says what is
 * wrong with it).  err must not be NULL.
 */
int gv_psd_thumbnail_check(const char *path, const struct gv_image_limits *lim,
                           struct gv_error *err);

#endif
