/*
 * store_meta.h - the optional metadata section of an image store: a
 * small, versioned, bounded JSON object of keys and values that says what
 * the pixels measure (a slide scanner's microns per pixel, a raster's
 * georeference), written by the encoder from its input and returned by
 * `gigaview info` and gigaviewd.  docs/FORMAT.md section 6 is normative.
 *
 * The section is "GVMD", a u32 section version (GV_META_VERSION), a u32
 * length, then that many bytes of JSON; the store header holds its
 * offset, size and CRC32.  The JSON is one object of at most
 * GV_META_MAX_KEYS keys ([a-z0-9_.-], 1 to GV_META_MAX_KEY bytes), each
 * value a string of at most GV_META_MAX_STRING bytes, a finite number, or
 * an array of at most GV_META_MAX_ARRAY finite numbers; the whole at most
 * GV_META_MAX_JSON bytes.  A section of a newer version is ignored (the
 * store reads as one without metadata), so later versions may say more.
 */
#ifndef GV_STORE_META_H
#define GV_STORE_META_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

#define GV_META_MAGIC "GVMD"
#define GV_META_VERSION 1
#define GV_META_HEAD 12           /* magic, version, length */
#define GV_META_MAX_JSON 65536    /* a CRS's WKT is 1 to 4 KB: room for many */
#define GV_META_MAX_KEYS 64
#define GV_META_MAX_KEY 64
#define GV_META_MAX_STRING 16384  /* the longest WKT of the EPSG registry
                                   * is under 8 KB */
#define GV_META_MAX_ARRAY 16      /* a geotransform has 6 */
#define GV_META_MAX_SECTION (GV_META_HEAD + GV_META_MAX_JSON)

/*
 * Check that json (len bytes, no NUL needed) is metadata as above.
 * Returns 0, or -1 with *err filled (GV_EINVAL for what a writer gave,
 * GV_ELIMIT past a bound), the message starting "store: metadata".
 */
int gv_meta_check(const char *json, size_t len, struct gv_error *err);

/* The section for json (checked first).  *out is malloc'ed, *outlen
 * bytes.  0, or -1 with *err filled. */
int gv_meta_pack(const char *json, size_t len, uint8_t **out, size_t *outlen,
                 struct gv_error *err);

/*
 * Parse a section read from a store (in, len bytes, its CRC already
 * checked).  Returns 0 with *json a malloc'ed, NUL-terminated copy of its
 * JSON (caller frees), or 0 with *json NULL for a section of a newer
 * version; -1 with *err filled (GV_ECORRUPT) for anything malformed,
 * oversized or outside the rules above.
 */
int gv_meta_unpack(const uint8_t *in, size_t len, char **json,
                   struct gv_error *err);

/* json (NULL or "" for {}) with string key `key` set to `value`: a new
 * malloc'ed string (compact, keys sorted, as the encoder writes
 * metadata), or NULL with *err (GV_EINVAL for json that is not an
 * object, GV_ENOMEM).  What `--window` and `--colours` add. */
char *gv_meta_set_string(const char *json, const char *key, const char *value,
                         struct gv_error *err);

/* The string value of `key` in json (NULL: none): 1 with it copied into
 * buf (size bytes), 0 when json or the key is absent, -1 with
 * GV_ECORRUPT when json is not JSON or the value is not a string that
 * fits. */
int gv_meta_get_string(const char *json, const char *key, char *buf,
                       size_t size, struct gv_error *err);

#endif
