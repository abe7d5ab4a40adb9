/*
 * worker.h - the job protocol between gigaviewd and its filter worker
 * processes (gigaview-filter-worker, worker_main.c), and the worker's
 * loop.
 *
 * User GLSL is untrusted, so gigaviewd never runs it: a worker process
 * with its own EGL context does, under a memory limit, and gigaviewd
 * kills it when a job overruns its time limit (docs/FILTERS.md section 9,
 * server/filter_jobs.c).  The two talk over one connected stream socket.
 *
 * Every message is a frame: a 16-byte header, then `length` body bytes.
 *
 *     u32 magic   GV_WORKER_MAGIC
 *     u32 type    enum gv_worker_msg
 *     u64 length  of the body
 *
 * Integers are little-endian; doubles, floats and texels are the host's
 * own representation (both ends are one build on one machine, and the
 * hello carries the protocol version).  Bodies:
 *
 *   HELLO   (worker, once, first)  u32 version, u32 ok, u32 n, n bytes of
 *           text: "platform, API: renderer", or why the EGL context could
 *           not be made
 *   COMPILE (server)  limits, u32 n, n bytes of graph document
 *   RUN     (server)  limits, document as for COMPILE, u32 nparams,
 *           nparams f64, u32 w, h, roi_x, roi_y, roi_w, roi_h, i64 abs_x,
 *           abs_y, u32 viewport_w, viewport_h, then w*h*4 RGBA8 bytes
 *   SIMPLIFY (server)  u64 faces, f64 ratio, u32 interp mode, u32 mesh
 *           format, u64 max_bytes, u32 max_verts, u32 max_tris,
 *           u32 max_faces, f64 time_limit, u64 n, then n bytes of the
 *           uploaded mesh file (POST /v1/meshes/simplify)
 *   DONE    (worker)  COMPILE: empty.  RUN: u32 passes, merges,
 *           merges_skipped, line_copies, textures, f64 gpu_ms, u32 roi_w,
 *           roi_h, then roi_w*roi_h*4 f32.  SIMPLIFY: u32 in_verts,
 *           in_tris, out_verts, out_tris, u64 asked, u32 level, nnodes,
 *           f64 read_ms, build_ms, select_ms, write_ms, u64 n, then n
 *           bytes of the output mesh file
 *   FAILED  (worker)  u32 gv_code, u32 n, n bytes of message (n < 320)
 *   limits: u64 max_json_bytes, u32 max_json_depth, u32 max_modules,
 *           u64 max_glsl_bytes, u32 max_padding
 *
 * Both ends check every length against what the frame can hold before
 * allocating, and the server trusts nothing the worker sends: a DONE must
 * have exactly the size the job implies, a FAILED a known code and a
 * short message, which is reduced to printable ASCII; a SIMPLIFY answer
 * at most the job's max_out bytes of file and counts no larger than the
 * input's limits.
 *
 * A SIMPLIFY job runs lib/mesh/cluster_run.c's gv_simplify (the mesh
 * readers, the octree, the selection, the writer) in the worker, so that
 * a reader bug or a mesh that takes too long costs a worker, not
 * gigaviewd.  It selects on the worker's EGL context when it has one,
 * else on the CPU: the same file (Kanaya et al., section 3; the CPU
 * reference gives the same clusters).
 */
#ifndef GV_FILTER_WORKER_H
#define GV_FILTER_WORKER_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "filter.h"
#include "mesh/cluster_run.h"

struct gv_gpu;

#define GV_WORKER_MAGIC 0x57465647u  /* "GVFW" read as little-endian bytes */
#define GV_WORKER_VERSION 1
#define GV_WORKER_HEADER 16
#define GV_WORKER_MSG_MAX 319        /* a gv_error's text, without the NUL */

enum gv_worker_msg {
    GV_WORKER_HELLO = 1,
    GV_WORKER_COMPILE,
    GV_WORKER_RUN,
    GV_WORKER_DONE,
    GV_WORKER_FAILED,
    GV_WORKER_SIMPLIFY             /* mesh simplification */
};

/* Fixed parts of a SIMPLIFY job and of its DONE answer, in bytes. */
#define GV_WORKER_SIMPLIFY_FIXED 60
#define GV_WORKER_SIMPLIFIED_FIXED 72
/* Largest mesh file a SIMPLIFY frame carries (simplify_max_bytes is at
 * most this). */
#define GV_WORKER_MESH_MAX 4294967295ull

/* What the IO functions return besides 0. */
enum gv_worker_io {
    GV_WORKER_OK = 0,
    GV_WORKER_BAD = -1,      /* protocol violation or IO error (err says) */
    GV_WORKER_TIMEOUT = -2,  /* the deadline passed */
    GV_WORKER_EOF = -3       /* the peer closed before a whole frame */
};

/* One job.  For COMPILE only lim, doc and doc_len are used; for
 * SIMPLIFY only mesh, mesh_len, simplify and max_out. */
struct gv_worker_job {
    int op;                           /* GV_WORKER_COMPILE, _RUN, _SIMPLIFY */
    struct gv_filter_limits lim;
    const char *doc;                  /* graph document, doc_len bytes */
    size_t doc_len;
    int nparams;                      /* RUN: values in in.params */
    struct gv_filter_input in;        /* RUN: geometry, rgba and params */
    const uint8_t *mesh;              /* SIMPLIFY: the file, mesh_len bytes */
    size_t mesh_len;
    struct gv_simplify_opts simplify; /* SIMPLIFY: select is not sent */
    uint64_t max_out;                 /* SIMPLIFY: the largest answer file
                                         the server accepts */
};

/* A job's result as the server receives it. */
struct gv_worker_result {
    int failed;                       /* 1: the worker reported err */
    struct gv_error err;              /* failed: code and message */
    float *out;                       /* RUN, !failed: roi_w*roi_h*4, malloc'ed */
    struct gv_filter_stats stats;     /* RUN, !failed */
    uint8_t *mesh;                    /* SIMPLIFY, !failed: the output file,
                                         mesh_len bytes, malloc'ed */
    size_t mesh_len;
    struct gv_simplify_stats sstats;  /* SIMPLIFY, !failed */
};

/* Milliseconds on CLOCK_MONOTONIC, for deadlines. */
int64_t gv_worker_now_ms(void);

/* ---- server side: fd is non-blocking; deadline in gv_worker_now_ms()
 * terms, or -1 for none.  Each returns enum gv_worker_io. ---- */

/*
 * Read the worker's HELLO.  Returns 0 with *ok (1: the worker has a GPU
 * context) and text (the renderer, or the reason it has none; always
 * NUL-terminated, printable ASCII) filled, else an error.
 */
int gv_worker_recv_hello(int fd, int64_t deadline, int *ok, char *text,
                         size_t size, struct gv_error *err);

/* Send a job.  Returns 0 or an error. */
int gv_worker_send_job(int fd, const struct gv_worker_job *job,
                       int64_t deadline, struct gv_error *err);

/*
 * Read the answer to `job` (sent with gv_worker_send_job).  Returns 0 with
 * *res filled (res->out and res->mesh owned by the caller when set), or
 * an error; a
 * frame of the wrong type or size is GV_WORKER_BAD.
 */
int gv_worker_recv_result(int fd, const struct gv_worker_job *job,
                          int64_t deadline, struct gv_worker_result *res,
                          struct gv_error *err);

/* ---- worker side: blocking fd ---- */

/*
 * The worker's loop: send HELLO (ok when gpu is not NULL, with
 * `hello_text`), then answer jobs one at a time until the server closes
 * the connection.  A job's graph is parsed again here with the job's
 * limits; a run whose padded region exceeds max_pixels or whose geometry
 * is inconsistent is answered FAILED.  With no gpu every COMPILE and RUN
 * fails; SIMPLIFY runs on the CPU then.
 * Returns 0 at a clean end of input, -1 on a protocol or IO error (err).
 */
int gv_worker_serve(int fd, struct gv_gpu *gpu, const char *hello_text,
                    uint64_t max_pixels, struct gv_error *err);

#endif
