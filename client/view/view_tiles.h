/*
 * view_tiles.h - the tiles of `gigaview view`: which ones a frame needs,
 * fetching them (through view_fetch.h, never waiting), decoding them on
 * the GPU (lib/gpu's decoder and its cache, which pulls missing parents
 * and evicts the least recently used, thesis section 7.5) within a
 * per-frame budget, and the resident set the display shader reads.
 *
 * Resident tiles live in one texture array (the atlas: 513 x 513 RGBA8UI
 * layers, as the decoder makes them, copied there; for a store of 16-bit
 * codes R16UI layers, a channel each, C a tile), found through a page
 * table (an R32UI texture, one texel per tile of every level: layer + 1,
 * or 0 when not resident), so the display shader can take each bilinear
 * tap from the tile that owns its pixel (docs/FORMAT.md section 2: the
 * same rule as `gigaview render`, hence no seams) and fall back per pixel
 * to the nearest resident ancestor.  The levels above the tiled ones (the
 * root and its mips) are uploaded once and pinned: a picture never has a
 * hole.
 *
 * Decoding runs on the decode thread (view_decode.h), on a GL context
 * sharing the atlas with the window's, when vt_options.decode_gpu is
 * given: the render thread reserves a layer, posts the job, and publishes
 * the layer in the page table once the job's fence has signalled; at most
 * `budget` jobs are in flight.  Without it (no shared context could be
 * made, or --decode-thread off) tiles are decoded in the frame, as many as
 * `budget` a frame.  Everything here but the decode thread runs on the
 * render thread, which owns the window's GL context.
 */
#ifndef GV_VIEW_TILES_H
#define GV_VIEW_TILES_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "gpu/gpu.h"
#include "store/geometry.h"
#include "view_fetch.h"
#include "view_geom.h"

#define VT_MAX_LEVELS GV_MAX_LEVELS

/* How a view maps window pixels to level-0 pixels (as cmd_render.c's
 * plan_view): levels f (weight 1 - t) and f + 1 (weight t). */
struct vt_plan {
    int f;
    double t;
    double scale, cs, sn;      /* 2^zoom; the rotation from window to image */
    double box[4];             /* level-0 bounding box of the window, clipped */
    int visible;               /* 0: the window shows none of the image */
};

struct vt_options {
    size_t atlas_bytes;        /* resident tiles (the atlas) */
    size_t decode_bytes;       /* the decoder's own cache (parents) */
    size_t buffer_bytes;       /* compressed tile buffers kept in memory */
    int budget;                /* tile decodes per frame (in the frame), or
                                  decode jobs in flight (decode thread) */
    double budget_ms;          /* and no new decode (job) after this much of
                                  a frame's decode work (one always runs) */
    struct gv_gpu *decode_gpu; /* a context sharing the window's
                                  (gv_gpu_open_shared), borrowed: decode on
                                  the decode thread; NULL: in the frame */
    int prefetch;              /* 0: no prefetching */
    int verbose;
};

struct vt_stats {
    size_t needed, missing;    /* tiles the frame needs; of which not resident */
    size_t wanted;             /* tiles asked of the network this frame */
    uint64_t decodes;          /* decodes so far (ancestors included) */
    uint64_t fetched, failures;/* tile buffers received; failed fetches */
    uint64_t evictions;        /* atlas layers reused */
    int layers;                /* atlas layers */
    uint64_t prefetched;       /* tiles decoded ahead of the view */
    uint64_t published;        /* tiles made resident (page table set) */
    int threaded;              /* decoding on the decode thread */
    int inflight;              /* decode jobs posted, not yet published */
    double decode_ms;          /* this frame's render-thread time on decode
                                  work: decodes (in the frame), or posting
                                  jobs, testing fences, publishing */
    uint64_t errors;           /* decode failures so far */
    char error[200];           /* the last one */
};

struct vt;

/*
 * The tiles of image `res` (a VF_IMAGE result: its metadata and root mips,
 * moved into the new object on success) over GPU g (adopted context,
 * current on this thread).  Returns NULL with *err (GL or memory failure,
 * an image too large for the page table).
 */
struct vt *vt_new(struct gv_gpu *g, struct vf_result *res,
                  const struct vt_options *o, struct gv_error *err);
void vt_free(struct vt *t);

const struct gv_geometry *vt_geometry(const struct vt *t);
const char *vt_image(const struct vt *t);
int vt_top(const struct vt *t);      /* the last level: root + root_mips - 1 */

/* The plan of view v in a w x h window. */
void vt_plan_view(const struct vt *t, const struct vg_view *v, int w, int h,
                  struct vt_plan *p);

/* Take a tile result from the fetch thread (its buffer is moved). */
void vt_take(struct vt *t, struct vf_result *r, double now);

/*
 * One frame's work: mark what plan p needs, decode what can be decoded
 * within the budget (nearest the centre first, coarse levels first),
 * prefetch ahead of the motion (vx, vy: the centre's motion in level-0
 * pixels per frame) once the view is complete, and post the wanted tiles
 * to f.  now: seconds (for retries).  Fills *st.
 */
void vt_frame(struct vt *t, const struct vt_plan *p, double vx, double vy,
              struct vf *f, double now, struct vt_stats *st);

/* GL names and geometry the display shader reads. */
struct vt_gl {
    unsigned atlas, page_table;
    int codes;                      /* 1: 16-bit codes, a layer a channel */
    int nlevels;                    /* top + 1 */
    int root;
    int lv[VT_MAX_LEVELS][4];       /* width, height, tiles_x, tiles_y */
    int row[VT_MAX_LEVELS];         /* first page-table row of each level */
};
const struct vt_gl *vt_gl(const struct vt *t);

#endif
