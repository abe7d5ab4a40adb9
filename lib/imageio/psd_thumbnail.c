/*
 * psd_thumbnail.c - a Photoshop file's JPEG thumbnail against the decoder
 * memory limit, before OpenImageIO opens the file.
 *
 * Why: OpenImageIO 2.4's PSD reader decodes the thumbnail (image resource
 * 1036, or 1033 from Photoshop 4) whole while it opens the file, though
 * gigaview never uses it: into an image of the size the embedded JPEG's
 * own header claims, with libjpeg's coefficients besides when that JPEG
 * is progressive.  A 4 x 4 PSD of 1 KB whose thumbnail claims 30000 x
 * 30000 took 8 GB and 53 s in `gigaview encode` (13 GB and 250 s in
 * oiiotool --info).  Photoshop's own thumbnails are at most 160 pixels
 * wide, so no real file comes near the limit.
 *
 * The layout walked (Adobe Photoshop File Formats Specification, "File
 * Header Section", "Color Mode Data Section", "Image Resources Section"):
 * a 26-byte header starting "8BPS" (version 1, or 2 for PSB), the colour
 * mode data (a 4-byte length, then that many bytes), then the image
 * resources: a 4-byte length, then blocks of a 4-byte signature, a 2-byte
 * id, a Pascal name padded to an even length, a 4-byte size and that many
 * bytes of data padded to even.  A thumbnail's data is a 28-byte header
 * (format, sizes, bits) followed by the JPEG file, whose header
 * native_jpeg.c reads with libjpeg.  All big-endian.  A file that does
 * not follow this is left to the module, which says what is wrong.
 */
#include <stdio.h>
#include <string.h>

#include "imageio/native_file.h"
#include "imageio/native_jpeg.h"
#include "imageio/psd_thumbnail.h"

int gv_psd_sniff(const uint8_t *head, size_t n)
{
    return n >= 6 && memcmp(head, "8BPS", 4) == 0 && head[4] == 0
           && (head[5] == 1 || head[5] == 2);
}

/* The big-endian 4-byte value at `at`, or -1. */
static int64_t be32_at(FILE *f, int64_t at)
{
    uint8_t b[4];
    if (fseeko(f, (off_t)at, SEEK_SET) != 0 || fread(b, 1, 4, f) != 4)
        return -1;
    return (int64_t)((uint32_t)b[0] << 24 | (uint32_t)b[1] << 16
                     | (uint32_t)b[2] << 8 | b[3]);
}

int gv_psd_thumbnail_check(const char *path, const struct gv_image_limits *lim,
                           struct gv_error *err)
{
    gv_error_clear(err);
    FILE *f = gv_native_open_regular(path);
    if (!f)
        return 0;
    int rc = 0;
    int64_t mode_len = be32_at(f, 26);
    if (mode_len < 0)
        goto out;
    int64_t at = 26 + 4 + mode_len;   /* the resources' length */
    int64_t res_len = be32_at(f, at);
    if (res_len < 0)
        goto out;
    int64_t end = at + 4 + res_len;
    at += 4;
    while (at + 12 <= end) {
        uint8_t b[7];   /* signature, id, the name's length */
        if (fseeko(f, (off_t)at, SEEK_SET) != 0 || fread(b, 1, 7, f) != 7)
            break;
        unsigned id = (unsigned)b[4] << 8 | b[5];
        int64_t name = 1 + (int64_t)b[6];
        name += name & 1;
        int64_t size = be32_at(f, at + 6 + name);
        if (size < 0)
            break;
        int64_t data = at + 6 + name + 4;
        if ((id == 1033 || id == 1036) && size > 28) {
            rc = gv_native_jpeg_check_embedded(f, (long)(data + 28), path,
                                               "its thumbnail", lim, err);
            if (rc < 0)
                break;
        }
        at = data + size + (size & 1);
    }
out:
    fclose(f);
    return rc;
}
