/*
 * test_gpu_shared.c - gv_gpu_open_shared (lib/gpu/gpu_context.c): a
 * context on a GL thread of its own that shares the objects of the context
 * current on the caller's thread (the native viewer's decode thread).
 *
 * Without a current context it is refused (GV_EUNAVAIL).  Called on a
 * context's own thread (inside gv_gpu_call) it opens a context reported as
 * "shared", on the same driver; a tile uploaded there and read back there
 * (glReadPixels into client memory returns once the upload is complete)
 * reads back the same from the first context under the same name (bound
 * there afresh to a framebuffer: OpenGL ES 3.2 section 5.3).
 * Checks that need EGL are skipped (TAP SKIP) where no context can be made.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gpu/gpu.h"
#include "gpu/gpu_decode.h"
#include "util.h"

#define N (513 * 513 * 3)

struct open_arg {
    struct gv_gpu *shared;
    struct gv_error err;
};

/* On the first context's GL thread, where it is current. */
static int open_shared(void *arg, struct gv_error *err)
{
    (void)err;
    struct open_arg *a = arg;
    gv_error_clear(&a->err);
    a->shared = gv_gpu_open_shared(&a->err);
    return 0;
}

int main(void)
{
    struct gv_error err = {0};
    struct gv_gpu *none = gv_gpu_open_shared(&err);
    check(!none && err.code == GV_EUNAVAIL,
          "without a current context: refused (%s)", err.text);
    gv_gpu_close(none);

    gv_error_clear(&err);
    struct gv_gpu *g = gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err);
    if (!g) {
        printf("# %s\n", err.text);
        check(1, "a shared context opens # SKIP no EGL context here");
        check(1, "a tile uploaded on the shared context reads back from the first "
                 "# SKIP no EGL context here");
        return tap_done();
    }
    struct open_arg a = {0};
    gv_gpu_call(g, open_shared, &a, &err);
    if (!a.shared)
        printf("# %s\n", a.err.text);
    check(a.shared && !strcmp(gv_gpu_info(a.shared)->platform, "shared") &&
              !strcmp(gv_gpu_info(a.shared)->renderer, gv_gpu_info(g)->renderer),
          "a shared context opens, on the same driver (%s)",
          a.shared ? gv_gpu_info(a.shared)->renderer : a.err.text);
    if (!a.shared) {
        gv_gpu_close(g);
        return tap_done();
    }
    uint8_t *px = malloc(N), *back = malloc(N), *first = malloc(N);
    for (size_t i = 0; px && i < N; i++)
        px[i] = (uint8_t)(i * 7 + i / 1539);
    const struct gv_gpu_decoder_opts three = {.channels = 3};
    struct gv_gpu_decoder *d1 = gv_gpu_decoder_new(g, &three, &err);
    struct gv_gpu_decoder *d2 = d1 ? gv_gpu_decoder_new(a.shared, &three, &err) : NULL;
    uint32_t h = 0;
    int ok = px && back && first && d1 && d2 &&
             gv_gpu_upload_tile(d2, px, &h, &err) == 0 &&
             gv_gpu_read_tile(d2, h, 0, back, &err) == 0 &&
             gv_gpu_read_tile(d1, h, 0, first, &err) == 0;
    if (!ok)
        printf("# %s\n", err.text);
    check(ok && !memcmp(back, px, N) && !memcmp(first, px, N),
          "a tile uploaded on the shared context reads back from the first");
    if (d2 && h)
        gv_gpu_release(d2, h);
    gv_gpu_decoder_free(d2);
    gv_gpu_decoder_free(d1);
    free(px);
    free(back);
    free(first);
    gv_gpu_close(a.shared);
    gv_gpu_close(g);
    return tap_done();
}
