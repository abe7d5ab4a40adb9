/*
 * output_format.c - the table of output formats (see output_format.h).
 */
#include <stddef.h>
#include <string.h>
#include <strings.h>

#include "imageio/output_format.h"

static const struct gv_output_format formats[] = {
    {"png", NULL, "image/png", "png"},
    {"jpg", "jpeg", "image/jpeg", "jpeg"},
    {"webp", NULL, "image/webp", "webp"},
    {"tif", "tiff", "image/tiff", "tiff"},
    {"raw", NULL, "application/octet-stream", NULL},
};

#define NFORMATS (sizeof formats / sizeof formats[0])

const struct gv_output_format *gv_output_format_find(const char *name)
{
    for (size_t i = 0; name && i < NFORMATS; i++)
        if (!strcmp(name, formats[i].name) ||
            (formats[i].alias && !strcmp(name, formats[i].alias)))
            return &formats[i];
    return NULL;
}

const struct gv_output_format *gv_output_format_image(const char *name)
{
    const struct gv_output_format *f = gv_output_format_find(name);
    return f && f->oiio && !strcmp(name, f->name) ? f : NULL;
}

const struct gv_output_format *gv_output_format_for_extension(const char *ext)
{
    for (size_t i = 0; ext && i < NFORMATS; i++)
        if (formats[i].oiio &&
            (!strcasecmp(ext, formats[i].name) ||
             (formats[i].alias && !strcasecmp(ext, formats[i].alias))))
            return &formats[i];
    return NULL;
}
