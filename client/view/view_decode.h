/*
 * view_decode.h - the decode thread of `gigaview view`: tiles decoded on a
 * GL context that shares its objects with the window's (gv_gpu_open_shared),
 * so that the render thread only schedules, publishes and draws.
 *
 * The render thread (view_tiles.c) posts a job per tile: the tile, the
 * compressed buffers of the tile and of every tiled ancestor (copies: the
 * decode thread never reads the render thread's tables), the atlas layer
 * reserved for it (no frame draws or reuses that layer meanwhile), and a
 * fence made on the render context after the layer was taken out of the
 * page table.  The decode thread waits for that fence on the GPU
 * (glWaitSync: the draws that read the layer's old tile are done), decodes
 * with lib/gpu's batch decoder and its own gpu_cache (parents), copies the
 * tile into the layer, makes a fence and flushes, and posts back (layer,
 * fence).  The render thread polls results without blocking, tests the
 * fence with glClientWaitSync and a timeout of 0, and only once it has
 * signalled points the page table at the layer and binds the atlas again
 * before drawing (OpenGL ES 3.2 section 5.3, "Propagating Changes to
 * Objects": changes made in one context are complete once a fence after
 * them has signalled, and are seen in another context once the object is
 * bound there again).  The render thread never waits for this thread, and
 * the queue's lock is only ever held to move a job or a result.
 */
#ifndef GV_VIEW_DECODE_H
#define GV_VIEW_DECODE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "gpu/gpu.h"
#include "store/geometry.h"

/* One tiled level's buffer of a job (moved in: the thread frees it). */
struct vdt_buf {
    int level;
    uint32_t tx, ty;
    uint8_t *buf;
    size_t len;
};

struct vdt_job {
    int level;
    uint32_t tx, ty;
    int slot;                        /* the atlas layer reserved */
    void *fence;                     /* GLsync made on the render context */
    struct vdt_buf chain[GV_MAX_LEVELS]; /* the tile, then its ancestors */
    int nchain;
};

struct vdt_done {
    int level;
    uint32_t tx, ty;
    int slot;                        /* -1: no job (the thread failed to start) */
    int ok;                          /* 0: msg says why; fence is NULL */
    void *fence;                     /* GLsync after the copy: the caller's */
    uint64_t decodes;                /* the thread's decodes so far */
    char msg[320];
};

struct vdt;

/*
 * Start the decode thread over shared context g (borrowed: close it after
 * vdt_free) for an image of geometry geo (copied) whose root level image is
 * root (root_w x root_h x geo->channels, copied), decoding into atlas
 * texture `atlas` (a GL_TEXTURE_2D_ARRAY of GV_TILE x GV_TILE RGBA8UI
 * layers, or with `codes` R16UI layers, geo->channels a tile, made on the
 * render context and complete before the first job's fence); root: the
 * root level, bytes or (codes) host-order 16-bit codes.  decode_bytes bounds the thread's decoded-tile cache.  The
 * decoder is made on the thread, so its failure comes back as a result
 * with slot -1.  Returns NULL with *err (memory, no thread).
 */
struct vdt *vdt_new(struct gv_gpu *g, const struct gv_geometry *geo, int codes,
                    const void *root, uint32_t root_w, uint32_t root_h,
                    size_t decode_bytes, unsigned atlas, struct gv_error *err);

/* Post job j (its buffers and fence are moved in, whatever happens).
 * Returns 0, or -1 when memory is short (the job is then dropped: its
 * fence deleted, on the calling thread, which must have a context of the
 * share group current). */
int vdt_post(struct vdt *d, struct vdt_job *j);

/* Take one finished job into *out without blocking.  Returns 1, or 0 when
 * none is ready. */
int vdt_poll(struct vdt *d, struct vdt_done *out);

/* Stop the thread (after the job it is on, if any), join it, and delete
 * the fences of jobs not done and results not taken (on the calling
 * thread, which must have a context of the share group current).  NULL
 * does nothing. */
void vdt_free(struct vdt *d);

#endif
