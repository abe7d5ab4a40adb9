/*
 * shard_merge.h - `gigaview merge`: shard files to a store.
 *
 * The merge reads the record headers of every shard, checks that the
 * shards belong together (the same shard count, each index once, the same
 * store header, options and root pixels) and that every tile of the
 * pyramid is there, then writes the store page by page in the order a
 * single encode writes it, through the same atomic writer
 * (store/store_write.h).  A tile that several shards encoded (an ancestor on a
 * cut) must be byte-identical in each; anything else means the shards
 * came from different inputs or options, and the merge fails.  Memory is
 * about 24 bytes per tile plus one page.
 */
#ifndef GV_SHARD_MERGE_H
#define GV_SHARD_MERGE_H

#include "encode/stream_encoder.h"
#include "base/error.h"

/*
 * Merge the `n` shard files `paths` (any order) into the store `output`.
 * Returns 0 and fills *res as gv_encode does (source.{width,height,
 * channels,src_bits,src_float,tone} from the header), or -1 with *err
 * filled; on failure no file exists under `output` (an existing one is
 * left as it was).
 */
int gv_shard_merge(const char *const *paths, int n, const char *output,
                   struct gv_encode_result *res, struct gv_error *err);

#endif
