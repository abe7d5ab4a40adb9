/*
 * gpu.h - a headless GPU context on EGL, owned by one thread.
 *
 * gv_gpu_open starts a thread that creates the context, trying in order the
 * EGL device platform (EGL_EXT_platform_device: a real GPU, or Mesa's
 * software device), the Mesa surfaceless platform (llvmpipe where there is
 * no GPU) and the default display, or only the one platform the caller
 * forces; on each, OpenGL ES 3.2, 3.1, then desktop OpenGL 4.3 core.
 * Every GL call happens on that thread: other threads hand it work with
 * gv_gpu_call and wait for the result, so GL objects never cross threads.
 *
 * This header includes no GL header, and only lib/gpu/gpu_*.c,
 * filters/run_gpu.c and the native viewer's window code (client/view/view_*.c,
 * client/cmd/cmd_view.c, on a context it adopts) include EGL or GL headers:
 * everything else talks to
 * the GPU through this API, gpu_decode.h, gpu_cache.h and filter.h.  The
 * whole of lib/gpu is left out of a build configured --without-gpu
 * (config.h then lacks GV_HAVE_GPU), and its callers say so instead.
 */
#ifndef GV_GPU_H
#define GV_GPU_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

struct gv_gpu;

/*
 * The two ways every GPU module of lib/gpu can run its work (the decoders
 * of gpu_decode.h and gpu_height.h, the z-field sweep of gpu_zfield.h),
 * the same shader files either way:
 */
enum gv_gpu_path {
    /* GLSL ES 3.10 / GL 4.30: compute passes over shader storage buffers
     * (rANS streams, the sweep's levels), then fragment passes. */
    GV_GPU_PATH_COMPUTE = 0,
    /* GLSL ES 3.00 as WebGL2 runs it: fragment (and vertex) passes only,
     * what they cannot do done on the CPU, inputs in textures.  Needs an
     * OpenGL ES context; it checks on EGL what the browser runs. */
    GV_GPU_PATH_WEBGL2
};

/* Which EGL platform gv_gpu_open uses (gigaviewd's gpu_platform,
 * GIGAVIEW_GPU_PLATFORM for `gigaview render`). */
enum gv_gpu_platform {
    GV_GPU_PLATFORM_AUTO = 0,     /* device, then surfaceless, then default */
    GV_GPU_PLATFORM_DEVICE,       /* EGL_EXT_platform_device only */
    GV_GPU_PLATFORM_SURFACELESS,  /* EGL_MESA_platform_surfaceless only */
    GV_GPU_PLATFORM_DEFAULT       /* eglGetDisplay(EGL_DEFAULT_DISPLAY) only */
};

/* The platform called `name` ("auto", "device", "surfaceless" or
 * "default"), or -1 for any other string (NULL included). */
int gv_gpu_platform_parse(const char *name);

/*
 * Whether the space-separated extension list `list` (eglQueryString's or
 * glGetString's EXTENSIONS; NULL is an empty list) names extension `name`
 * as a whole word: "EGL_EXT_platform_device_foo" does not name
 * "EGL_EXT_platform_device".  Returns 1 or 0.  Any thread.
 */
int gv_has_extension(const char *list, const char *name);

struct gv_gpu_info {
    char platform[32];   /* "device", "surfaceless" or "default" */
    char api[32];        /* e.g. "OpenGL ES 3.2" */
    char vendor[128], renderer[128], version[128];
    int es;              /* 1 for OpenGL ES, 0 for desktop OpenGL */
    int ssbo;            /* shader storage buffers available */
};

/*
 * Open a context on `platform` (GV_GPU_PLATFORM_AUTO: the first of the
 * three that works).  Returns the context, to be closed with gv_gpu_close,
 * or NULL with *err: GV_EUNAVAIL, "gpu: no usable EGL context: " and every
 * failed attempt, each ending in "; ", when none works (no EGL, no driver,
 * the forced platform missing); GV_ENOMEM when memory or the thread
 * cannot be had.  Any thread.
 */
struct gv_gpu *gv_gpu_open(enum gv_gpu_platform platform, struct gv_error *err);

/*
 * Adopt the GL context current on the calling thread (made by someone
 * else: SDL's window context in `gigaview view`), which must be OpenGL ES
 * 3.1+ or OpenGL 4.3+ (the decoder needs compute shaders and storage
 * buffers).  No thread is started: gv_gpu_call runs its function at once,
 * on the calling thread, which must be the adopting thread (else -1 with
 * GV_EINVAL), and the GL state the function leaves (bound framebuffer,
 * program, textures, viewport) is the caller's to reset.  info's platform
 * is "external".  gv_gpu_close frees the wrapper and leaves the context
 * alone.  Returns NULL with GV_EUNAVAIL when no context is current, or
 * GV_ENOMEM.
 */
struct gv_gpu *gv_gpu_adopt(struct gv_error *err);

/*
 * Open a context that shares its objects (textures, buffers, sync objects)
 * with the EGL context current on the calling thread (`gigaview view`:
 * its window's, so that tiles decode off the render thread into textures
 * the window draws).  Same display, config, client API and version; it
 * lives on a GL thread of its own as gv_gpu_open's does, current without
 * a surface, and is used the same way (gv_gpu_call from any thread but
 * that one).  info's platform is "shared".  The caller synchronises the
 * two contexts (fences: OpenGL ES 3.2 section 5.3).  Close it with
 * gv_gpu_close before destroying the context it shares with; the display
 * is left initialised.  Returns NULL with GV_EUNAVAIL when no EGL context
 * is current (GLX, say), the display lacks EGL_KHR_surfaceless_context,
 * or EGL refuses the context; GV_ENOMEM.  Needs the caller's context
 * current for the call.
 */
struct gv_gpu *gv_gpu_open_shared(struct gv_error *err);

/* Stop the GL thread and destroy the context (an adopted one: only free
 * the wrapper).  NULL does nothing.  Not on
 * the GL thread itself, and not while another thread is in gv_gpu_call. */
void gv_gpu_close(struct gv_gpu *g);

/* What gv_gpu_open chose; valid until gv_gpu_close.  Any thread. */
const struct gv_gpu_info *gv_gpu_info(const struct gv_gpu *g);

/*
 * Run fn(arg, err) on the GL thread and return its result.  Callers from
 * any thread but the GL thread itself (fn must not call gv_gpu_call: it
 * would wait for itself); calls are serialized.  fn may use GL freely.
 */
int gv_gpu_call(struct gv_gpu *g, int (*fn)(void *arg, struct gv_error *err),
                void *arg, struct gv_error *err);

/*
 * Compile and link a program from a vertex and a fragment source, each
 * given as the shared GLSL body; the version line and defines suited to
 * this context are prepended.  GL thread only.  Returns the program, or 0
 * with *err; on a compile or link failure, if listing is not NULL, also
 * sets *listing to a malloc'ed text (the caller frees it) with the
 * numbered source and the driver's log.
 */
unsigned gv_gpu_program(const struct gv_gpu *g, const char *vertex,
                        const char *fragment, char **listing,
                        struct gv_error *err);

/*
 * The two steps every program here is built with (gv_gpu_program above,
 * the modules of lib/gpu and the filter templates, filters/run_gpu.c), for
 * callers that add their own version line and map the driver's log
 * themselves.  GL thread only.
 * gv_gpu_compile_stage compiles src as a shader of GL type `type`
 * (GL_VERTEX_SHADER, ...) and returns it, or 0 with the driver's log in
 * log (cap bytes, always terminated).  gv_gpu_link_stages links n compiled
 * stages into a program, deletes the stages whatever happens, and returns
 * the program, or 0 with the driver's log.
 */
unsigned gv_gpu_compile_stage(unsigned type, const char *src, char *log, size_t cap);
unsigned gv_gpu_link_stages(const unsigned *stages, int n, char *log, size_t cap);

#endif
