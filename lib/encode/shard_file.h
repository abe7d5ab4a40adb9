/*
 * shard_file.h - the output of `gigaview encode --shard I/N`: the encoded
 * tiles of one shard, for `gigaview merge` to assemble into a store.
 *
 * Layout (little-endian; docs/FORMAT.md, appendix A, is normative):
 *
 *   0    64          shard header, CRC32 in its last 4 bytes
 *   64   128         the store header the merge will write (offsets and
 *                    level-0 PSNR zero), with its own CRC
 *   192  w*h*C + 4   the root level's pixels, then their CRC32
 *   ...              the store's metadata section, if any (its size and
 *                    CRC32 in the store header)
 *   ...              tile records: a 64-byte record header (CRC32 in its
 *                    last 4 bytes) and the tile buffer, padded to 4 bytes
 *
 * The writer publishes the file atomically (atomic_file.h), so a shard
 * file under its final name is complete.  The reader checks every CRC
 * before it hands out a byte.  Writer and reader are each used by one
 * thread at a time.
 */
#ifndef GV_SHARD_FILE_H
#define GV_SHARD_FILE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "store/store_format.h"
#include "codec/tile.h"

#define GV_SHARD_MAGIC "GVSHARD1"
#define GV_SHARD_HEADER 64
#define GV_SHARD_RECORD 64
#define GV_SHARD_FLAG_RD 1u   /* encoded with --rd */

/* What the shard header holds. */
struct gv_shard_info {
    int index, count;
    uint32_t flags;           /* GV_SHARD_FLAG_* */
    uint64_t records;         /* tile records in the file */
    uint64_t file_size;
    struct gv_header header;  /* the store header template, unpacked */
    uint8_t header_raw[GV_HEADER_SIZE];
};

/* One tile record. */
struct gv_shard_record {
    int level;
    uint32_t tx, ty;
    int rate;                 /* r of the buffer, 0..GV_MAX_RATE */
    uint32_t len;             /* buffer bytes */
    uint32_t crc;             /* CRC32 of the buffer */
    uint64_t sse, samples;    /* the encoder's gv_tile_stats */
    uint64_t sse0;            /* level 0: squared error over the pixels
                               * this tile is the source of (else 0) */
    uint64_t offset;          /* of the buffer in the file */
};

struct gv_shard_writer;

/* Start shard `index` of `count` at `path` for the store header *h (as
 * gv_store_writer_new takes it), the store's metadata section (meta,
 * meta_len bytes from gv_meta_pack; NULL, 0 for none) and flags. */
struct gv_shard_writer *gv_shard_writer_new(const char *path,
                                            const struct gv_header *h,
                                            const uint8_t *meta,
                                            size_t meta_len, int index,
                                            int count, uint32_t flags,
                                            struct gv_error *err);

/* Record the root level's pixels (root width x height x channels). */
int gv_shard_writer_root(struct gv_shard_writer *w, const uint8_t *pixels,
                         struct gv_error *err);

/* Append the buffer of tile (tx,ty) of `level` with its statistics. */
int gv_shard_writer_tile(struct gv_shard_writer *w, int level, uint32_t tx,
                         uint32_t ty, const uint8_t *buf, size_t len,
                         const struct gv_tile_stats *stats, uint64_t sse0,
                         struct gv_error *err);

/* Bytes written so far. */
uint64_t gv_shard_writer_bytes(const struct gv_shard_writer *w);

/* Write the header, publish under the final name and free w.  On failure
 * nothing is published and w is freed all the same. */
int gv_shard_writer_finish(struct gv_shard_writer *w, struct gv_error *err);

/* Abandon and free.  NULL does nothing. */
void gv_shard_writer_abort(struct gv_shard_writer *w);

struct gv_shard_reader;

/* Open and check a shard file: header CRCs, the store header, the file
 * size and the root's CRC. */
struct gv_shard_reader *gv_shard_open(const char *path, struct gv_error *err);

/* Close.  NULL does nothing. */
void gv_shard_close(struct gv_shard_reader *r);

const struct gv_shard_info *gv_shard_get_info(const struct gv_shard_reader *r);

/* The store's metadata section as the encoder packed it, CRC checked
 * (valid until close); NULL with *len 0 when there is none. */
const uint8_t *gv_shard_meta(const struct gv_shard_reader *r, size_t *len);

/* The root level's pixels (valid until close). */
const uint8_t *gv_shard_root(const struct gv_shard_reader *r, size_t *len);

/*
 * Read the next record header, in file order.  Returns 1 and fills *rec,
 * 0 after the last record (having checked that the count and the file
 * size agree), or -1 with *err filled.
 */
int gv_shard_next(struct gv_shard_reader *r, struct gv_shard_record *rec,
                  struct gv_error *err);

/* Read the buffer of *rec into buf (rec->len bytes) and check its CRC. */
int gv_shard_read_tile(struct gv_shard_reader *r,
                       const struct gv_shard_record *rec, uint8_t *buf,
                       struct gv_error *err);

#endif
