/*
 * encode_int.h - what the single encode (stream_encoder.c) and the shard
 * merge (shard_merge.c) share and nothing else uses: the clock of the
 * summary, and the last step, which must be the same in both so that a
 * merge writes the store byte for byte as a single encode does.
 */
#ifndef GV_ENCODE_INT_H
#define GV_ENCODE_INT_H

#include <stdint.h>

#include "base/error.h"
#include "encode/stream_encoder.h"
#include "store/store_write.h"

/* Monotonic seconds, for gv_encode_result.seconds. */
double gv_encode_now(void);

/* The level-0 PSNR in dB that a store header records, from the squared
 * error summed over level 0 and the sample count (99 when lossless). */
double gv_encode_psnr0(uint64_t sse0, uint64_t samples0);

/*
 * The last step of writing a store, its root already appended: record
 * res->psnr0 in the header, publish the store under `output`
 * (gv_store_writer_finish, which frees w), then read it back (its header
 * and page index must verify) and fill res->file_bytes and res->bpp from
 * res->geometry.  Returns 0, or -1 with *err filled.
 */
int gv_encode_publish_store(struct gv_store_writer *w, const char *output,
                            struct gv_encode_result *res,
                            struct gv_error *err);

/* File bits per pixel of level 0: 8 * res->file_bytes / (width * height). */
double gv_encode_bpp(const struct gv_encode_result *res);

#endif
