/*
 * store_fixture.h - the synthetic stores the C tests decode: encode an
 * input (synth:WxH, a file) into a store with the defaults or given
 * options, open it, and read one tile's coded bytes out of its page.
 * Every failure here is a set-up failure: fail() (util.h) bails out.
 */
#ifndef GV_TESTS_STORE_FIXTURE_H
#define GV_TESTS_STORE_FIXTURE_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "encode/stream_encoder.h"
#include "store/store_read.h"
#include "util.h"

/* Encode `input` into the store `path` with the options o (NULL: the
 * defaults, on 2 threads; the bytes are the same for any thread count). */
static inline void fixture_encode(const char *path, const char *input,
                                  const struct gv_encode_opts *o)
{
    struct gv_encode_opts def;
    if (!o) {
        gv_encode_opts_default(&def);
        def.threads = 2;
        o = &def;
    }
    struct gv_encode_result res;
    struct gv_error err = {0};
    const char *in[1] = {input};
    if (gv_encode(in, 1, path, o, &res, &err) != 0)
        fail("encode %s: %s", input, err.text);
}

/* The store at `path`, open. */
static inline struct gv_store *fixture_open(const char *path)
{
    struct gv_error err = {0};
    struct gv_store *s = gv_store_open(path, &err);
    if (!s)
        fail("open %s: %s", path, err.text);
    return s;
}

/* The store dir/name, encoded from `input` with the defaults and opened;
 * with unlink_after the file is removed once open (the store stays
 * readable through its descriptor). */
static inline struct gv_store *fixture_store(const char *dir, const char *name,
                                             const char *input, int unlink_after)
{
    char path[256];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    fixture_encode(path, input, NULL);
    struct gv_store *s = fixture_open(path);
    if (unlink_after)
        unlink(path);
    return s;
}

/* The coded bytes of tile (level, tx, ty): *buf, *len point into *page,
 * which the caller frees. */
static inline void fixture_tile(const struct gv_store *s, int level, uint32_t tx,
                                uint32_t ty, uint8_t **page, const uint8_t **buf,
                                size_t *len)
{
    struct gv_error err = {0};
    size_t plen;
    if (gv_store_read_page(s, level, tx / 8, ty / 8, page, &plen, &err) < 0 ||
        gv_page_tile(*page, plen, gv_store_info(s)->geometry.channels, (int)(tx % 8),
                     (int)(ty % 8), buf, len, &err) < 0)
        fail("tile %d/%u/%u: %s", level, tx, ty, err.text);
}

#endif
