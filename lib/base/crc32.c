/*
 * crc32.c - gv_crc32 over zlib's crc32 (which takes uInt lengths).
 */
#include <zlib.h>

#include "base/crc32.h"

uint32_t gv_crc32(uint32_t crc, const void *data, size_t len)
{
    const uint8_t *p = data;
    /* zlib takes uInt lengths; feed large buffers in 1 GiB slices. */
    while (len > 0) {
        uInt n = len > (1u << 30) ? (1u << 30) : (uInt)len;
        crc = (uint32_t)crc32(crc, p, n);
        p += n;
        len -= n;
    }
    return crc;
}
