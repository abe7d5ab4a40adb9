/*
 * output_format.h - the formats gigaview writes, in one table: each
 * format's names, its MIME type and the OpenImageIO writer behind it.
 *
 * Every place that names an output format looks it up here: the server's
 * Content-Type headers (regions, IIIF images, roots, filter results),
 * the IIIF format segment, and gv_image_write's choice of format by file
 * extension.  A format's extensions are its name and its alias
 * (".jpg" and ".jpeg", ".tif" and ".tiff").  Plain C with no state: any
 * thread, no allocation.
 */
#ifndef GV_OUTPUT_FORMAT_H
#define GV_OUTPUT_FORMAT_H

#ifdef __cplusplus
extern "C" {
#endif

struct gv_output_format {
    const char *name;   /* as gv_image_encode and IIIF name it: "png", "jpg",
                           "webp", "tif"; "raw" for bare samples */
    const char *alias;  /* the other accepted spelling ("jpeg", "tiff"), or
                           NULL */
    const char *mime;   /* the Content-Type of its bytes */
    const char *oiio;   /* OpenImageIO's writer, or NULL when this is no
                           image file (raw): gv_image_encode refuses it */
};

/* The format whose name or alias is `name` (case-sensitive), or NULL. */
const struct gv_output_format *gv_output_format_find(const char *name);

/* The image format (one gv_image_encode writes) whose name is exactly
 * `name`, no alias: "png", "jpg", "webp" or "tif".  NULL otherwise. */
const struct gv_output_format *gv_output_format_image(const char *name);

/* The image format for a file extension given without its dot, matched
 * against names and aliases ignoring ASCII case ("JPEG" finds jpg).  NULL
 * for anything else, "raw" included. */
const struct gv_output_format *gv_output_format_for_extension(const char *ext);

#ifdef __cplusplus
}
#endif

#endif
