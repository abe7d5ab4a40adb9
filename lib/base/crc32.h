/*
 * crc32.h - the one CRC-32 of gigaview's file formats (headers, pages,
 * page index, root, shards): ISO-HDLC, as zlib and PNG compute it.
 */
#ifndef GV_CRC32_H
#define GV_CRC32_H

#include <stddef.h>
#include <stdint.h>

/* CRC-32 of len bytes at data, continuing from crc (start with 0).  Any
 * length: buffers above 1 GiB are fed to zlib in slices. */
uint32_t gv_crc32(uint32_t crc, const void *data, size_t len);

#endif
