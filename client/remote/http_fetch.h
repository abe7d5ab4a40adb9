/*
 * http_fetch.h - the native client's side of the gigaviewd API
 * (docs/API.md) over libcurl: image list and metadata (JSON), the root
 * level as the store's lossless WebP or as raw samples, and compressed
 * tiles fetched in parallel (curl multi, keep-alive) with the on-disk
 * cache and ETag revalidation.
 *
 * Every failure becomes a one-line message in *err: the server cannot be
 * reached, a transfer timed out or was cut short, the server answered an
 * error (its JSON message is quoted), or a tile failed gv_tilebuf_check.
 */
#ifndef GV_HTTP_FETCH_H
#define GV_HTTP_FETCH_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "base/error.h"
#include "render/height_region.h"
#include "store/store_format.h"
#include "tile_cache_disk.h"

struct gv_http;

struct gv_http_stats {
    uint64_t requests;     /* HTTP requests made */
    uint64_t downloaded;   /* tiles that came with a body (200) */
    uint64_t revalidated;  /* tiles confirmed by 304 from the disk cache */
    uint64_t bytes;        /* body bytes received */
    uint64_t wait_us;      /* wall time spent waiting for transfers */
};

/* A client of the server at base: "http://host:port" or "https://..."
 * (trailing '/'s are dropped).  timeout_ms bounds every request,
 * connection included.  verbose: log each request to stderr.  Returns
 * NULL with *err filled when base is not an http(s) URL, is 1000 bytes or
 * longer, or memory runs out.  gv_http_free(NULL) does nothing. */
struct gv_http *gv_http_new(const char *base, long timeout_ms, int verbose,
                            struct gv_error *err);
void gv_http_free(struct gv_http *h);

/* Make every call in progress on h (on another thread) and every later
 * one fail at once with "http: stopped": their transfers are dropped.
 * The only function that may be called from any thread, while another
 * uses h; for shutting a client down without waiting out the request
 * timeout (gv_http_free still comes after the other thread is done). */
void gv_http_abort(struct gv_http *h);

/* on (the default): gv_http_tiles fetches in batch requests; off: one
 * request per tile. */
void gv_http_use_batches(struct gv_http *h, int on);

/* The base URL requests go to (without its trailing '/'s). */
const char *gv_http_base(const struct gv_http *h);

/* The counters since gv_http_new. */
void gv_http_stats(const struct gv_http *h, struct gv_http_stats *st);

/* Print the server's images (GET /v1/images) to out: the server and the
 * count, then a table with one line per image. */
int gv_http_print_images(struct gv_http *h, FILE *out, struct gv_error *err);

/* What the client needs of GET /v1/images/{id}. */
struct gv_remote_image {
    char id[129];
    uint32_t width, height;
    int channels;
    int levels_tiled;      /* = the root level */
    uint32_t root_w, root_h;
    uint32_t root_side;    /* the root is the first level within this */
    int root_mips;
    char window[256];      /* the default display window the server
                            * applies (render/window.h text; "" none) */
    /* Stores of 16-bit codes (docs/FORMAT.md sections 12 and 13): tiles
     * of height tile buffers, a root of 2 bytes a sample. */
    int kind;              /* GV_KIND_IMAGE, _HEIGHT or _SAMPLES (store_format.h) */
    double scale, offset;  /* value = code * scale + offset */
    double min, max;       /* a height store's range of values (its gray) */
    unsigned code_min, code_max;   /* a sample store's codes' range */
    char colours[96];      /* a sample store's display.colours ("" none) */
    double mpp;            /* microns per level-0 pixel (a slide's
                            * slide.mpp_x metadata), 0 when not given */
};

/* Bytes of one sample of img: 1, or 2 for a store of codes. */
int gv_remote_sample_bytes(const struct gv_remote_image *img);

/* The store header fields the display rules read (render/samples_region.h:
 * kind, channels, a sample store's codes' range) of img, the rest 0. */
struct gv_header gv_remote_header(const struct gv_remote_image *img);

/* A height store's value mapping and range (render/height_region.h) of
 * img: what its gray is made from. */
struct gv_height_meta gv_remote_height_meta(const struct gv_remote_image *img);

/* Fetch an image's metadata into *img.  An unknown image, or an id that
 * cannot be one, is GV_ENOTFOUND; metadata out of bounds is GV_ECORRUPT. */
int gv_http_image(struct gv_http *h, const char *id,
                  struct gv_remote_image *img, struct gv_error *err);

/* The size of root mip `mip` of img (0: the root itself; each mip halves
 * the one before, rounding up). */
void gv_remote_mip_size(const struct gv_remote_image *img, int mip, uint32_t *w,
                        uint32_t *h);

/* Root mip `mip` as raw samples (w x h x channels of
 * gv_remote_sample_bytes each, little-endian codes for a store of codes,
 * malloc'ed, the caller's), through the disk cache dc (may be NULL); a body of another
 * size than the metadata implies is GV_ECORRUPT. */
int gv_http_root(struct gv_http *h, const struct gv_remote_image *img, int mip,
                 struct gv_disk_cache *dc, uint8_t **pixels, uint32_t *w,
                 uint32_t *hh, struct gv_error *err);

/* The root level as the store keeps it: a lossless WebP (docs/API.md,
 * GET .../root?format=webp; a gray root has three equal channels), the
 * bytes malloc'ed into *webp (the caller's; not decoded here), through the
 * disk cache dc (may be NULL) with ETag revalidation.  Returns 0; 1 when
 * the server answers 400 or 404, as a server older than that form does
 * (the caller fetches gv_http_root's raw mips instead); -1 with *err on
 * any other failure. */
int gv_http_root_webp(struct gv_http *h, const struct gv_remote_image *img,
                      struct gv_disk_cache *dc, uint8_t **webp, size_t *len,
                      struct gv_error *err);

struct gv_tile_want {
    int level;
    uint32_t tx, ty;
    uint8_t *buf;          /* filled: malloc'ed tile buffer, checked */
    size_t len;
};

/* Fetch every tile of t[0..n) in parallel, through dc (may be NULL):
 * cached entries are revalidated with If-None-Match, in batch requests
 * of up to 64 tiles (304 frames) unless gv_http_use_batches said no, or
 * a batch is refused (413: then one request per tile).  Each buffer is
 * checked with gv_tilebuf_check (gv_samples_tile_check for codes).  On failure the buffers already filled
 * stay filled (the caller frees them all). */
int gv_http_tiles(struct gv_http *h, const struct gv_remote_image *img,
                  struct gv_tile_want *t, size_t n, struct gv_disk_cache *dc,
                  struct gv_error *err);

#endif
