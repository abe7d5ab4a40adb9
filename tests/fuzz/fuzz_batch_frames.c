/*
 * fuzz_batch_frames.c - libFuzzer target for the native client's reader
 * of batch answers (client/remote/batch_frames.c): GVB1 and GVB2 frames as a
 * server, or anything pretending to be one, sends them.
 *
 * Byte 0 is the number of tiles the client asked for (0..255); the rest
 * is the body.  Checked:
 *  - success: the frames tile the body exactly (8 bytes, then per frame
 *    20 + the ETag and the data, each padded to 4), every pointer lies in
 *    the body, ETags only in GVB2, data only with status 200;
 *  - failure: GV_ECORRUPT with a "batch: " message.
 * Anything else aborts.
 */
#include <stdlib.h>
#include <string.h>

#include "batch_frames.h"
#include "fuzz.h"

#define MAX_INPUT (1u << 20)

static size_t pad4(size_t n)
{
    return (n + 3) / 4 * 4;
}

static void check_frames(const uint8_t *body, size_t len, size_t count,
                         const struct gv_batch_frame *f)
{
    size_t off = 8;
    int v2 = body[3] == '2';
    for (size_t i = 0; i < count; i++) {
        const uint8_t *e = (const uint8_t *)f[i].etag;
        if (e != body + off + 20 || f[i].data != e + pad4(f[i].etag_len))
            abort();
        if ((f[i].etag_len && !v2) || f[i].etag_len > 255 ||
            (f[i].len && f[i].status != 200))
            abort();
        off += 20 + pad4(f[i].etag_len) + pad4(f[i].len);
        if (off > len)
            abort();
    }
    if (off != len)
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || size > MAX_INPUT)
        return 0;
    size_t count = data[0];
    const uint8_t *body = data + 1;
    size_t len = size - 1;
    struct gv_batch_frame *f = calloc(count ? count : 1, sizeof *f);
    if (!f)
        abort();
    struct gv_error err = {0};
    if (gv_batch_frames_parse(body, len, count, f, &err) == 0)
        check_frames(body, len, count, f);
    else if (err.code != GV_ECORRUPT || strncmp(err.text, "batch: ", 7))
        abort();
    free(f);
    return 0;
}
