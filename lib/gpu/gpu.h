/*
 * gpu.h - a headless GPU context on EGL, owned by one thread.
 *
 * gv_gpu_open starts a thread that creates the context, trying in order the
 * EGL device platform (EGL_EXT_platform_device: a real GPU), the Mesa
 * surfaceless platform (llvmpipe where there is no GPU) and the default
 * display; on each, OpenGL ES 3.2, 3.1, then desktop OpenGL 4.3 core.
 * Every GL call happens on that thread: other threads hand it work with
 * gv_gpu_call and wait for the result, so GL objects never cross threads.
 * Only the gpu_*.c files include EGL and GL headers.
 */
#ifndef GV_GPU_H
#define GV_GPU_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

struct gv_gpu;

struct gv_gpu_info {
    char platform[32];   /* "device", "surfaceless" or "default" */
    char api[32];        /* e.g. "OpenGL ES 3.2" */
    char vendor[128], renderer[128], version[128];
    int es;              /* 1 for OpenGL ES, 0 for desktop OpenGL */
    int ssbo;            /* shader storage buffers available */
};

/* Open a context.  Returns NULL with *err (GV_EUNAVAIL) describing every
 * attempt when none works (no EGL, no driver). */
struct gv_gpu *gv_gpu_open(struct gv_error *err);

/* Stop the GL thread and destroy the context.  NULL does nothing. */
void gv_gpu_close(struct gv_gpu *g);

const struct gv_gpu_info *gv_gpu_info(const struct gv_gpu *g);

/*
 * Run fn(arg, err) on the GL thread and return its result.  Callers from
 * any thread; calls are serialized.  fn may use GL freely.
 */
int gv_gpu_call(struct gv_gpu *g, int (*fn)(void *arg, struct gv_error *err),
                void *arg, struct gv_error *err);

/*
 * Compile and link a program from a vertex and a fragment source, each
 * given as the shared GLSL body; the version line and defines suited to
 * this context are prepended.  GL thread only.  On a compile or link
 * failure returns 0 and, if listing is not NULL, sets *listing to a
 * malloc'ed text with the numbered source and the driver's log.
 */
unsigned gv_gpu_program(const struct gv_gpu *g, const char *vertex,
                        const char *fragment, char **listing,
                        struct gv_error *err);

/* The same as GLSL ES 3.00 without storage buffers ("#version 300 es"),
 * the language of WebGL2: used to test the browser's variant of the shared
 * shaders on EGL.  Needs an OpenGL ES context. */
unsigned gv_gpu_program_es300(const struct gv_gpu *g, const char *vertex,
                              const char *fragment, char **listing,
                              struct gv_error *err);

/* Compile and link a compute program from a shared GLSL body, as
 * gv_gpu_program does.  GL thread only; returns 0 on failure. */
unsigned gv_gpu_compute_program(const struct gv_gpu *g, const char *compute,
                                char **listing, struct gv_error *err);

#endif
