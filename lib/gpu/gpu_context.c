/*
 * gpu_context.c - EGL context creation and the GL-owner thread (gpu.h).
 *
 * Attempts are recorded as they fail and reported together only when all
 * of them fail (mpv's egl_helpers does the same): on a machine with a GPU
 * the first attempt wins and nothing is logged as an error.  With a
 * platform forced, only that platform is tried, and a missing extension
 * or device counts as a failed attempt (with auto it merely skips the
 * platform).  Extensions are matched as whole words (gv_has_extension).
 *
 * gv_gpu_open_shared takes the display, config, client API and version of
 * the EGL context current on the caller's thread and makes, on a GL thread
 * of its own, a context on that display sharing its objects (EGL 1.5
 * section 3.7.1, share_context), current without a surface
 * (EGL_KHR_surfaceless_context): the native viewer decodes there into
 * textures its window's context draws.
 */
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl31.h>

#include "gpu/gpu.h"

struct gv_gpu {
    enum gv_gpu_platform want;    /* what the caller asked for */
    pthread_t thread;
    pthread_mutex_t lock, call_lock;
    pthread_cond_t wake, done;
    int started, ok, stop, has_job, job_done;
    int (*job)(void *, struct gv_error *);
    void *job_arg;
    struct gv_error *job_err;
    int job_rc;
    EGLDisplay dpy;
    EGLContext ctx;
    int adopted;                  /* gv_gpu_adopt: no thread of our own */
    pthread_t owner;              /* gv_gpu_adopt: the caller's thread */
    /* gv_gpu_open_shared: the context to share with and how to match it */
    EGLContext share;
    EGLConfig share_cfg;
    EGLenum share_api;
    EGLint share_major, share_minor, share_profile;
    struct gv_gpu_info info;
    struct gv_error open_err;
};

/* Indexed by enum gv_gpu_platform. */
static const char *const platform_names[] = {"auto", "device", "surfaceless",
                                             "default"};
#define NPLATFORMS ((int)(sizeof platform_names / sizeof platform_names[0]))

int gv_gpu_platform_parse(const char *name)
{
    for (int i = 0; name && i < NPLATFORMS; i++)
        if (!strcmp(name, platform_names[i]))
            return i;
    return -1;
}

int gv_has_extension(const char *list, const char *name)
{
    const size_t n = strlen(name);
    for (const char *p = list; p && *p;) {
        while (*p == ' ')
            p++;
        size_t len = strcspn(p, " ");
        if (len == n && n > 0 && !memcmp(p, name, n))
            return 1;
        p += len;
    }
    return 0;
}

__attribute__((format(printf, 3, 4))) static void
note(char *log, size_t cap, const char *fmt, ...)
{
    size_t n = strlen(log);
    if (n + 2 >= cap)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(log + n, cap - n, fmt, ap);
    va_end(ap);
}

/* Try ES 3.2, ES 3.1, then GL 4.3 core on an initialized display. */
static int try_contexts(struct gv_gpu *g, const char *platform, char *log,
                        size_t cap)
{
    static const struct {
        EGLenum api;
        int major, minor, es;
        const char *name;
    } want[] = {
        {EGL_OPENGL_ES_API, 3, 2, 1, "OpenGL ES 3.2"},
        {EGL_OPENGL_ES_API, 3, 1, 1, "OpenGL ES 3.1"},
        {EGL_OPENGL_API, 4, 3, 0, "OpenGL 4.3 core"},
    };
    const char *ext = eglQueryString(g->dpy, EGL_EXTENSIONS);
    int no_config = gv_has_extension(ext, "EGL_KHR_no_config_context");
    int surfaceless = gv_has_extension(ext, "EGL_KHR_surfaceless_context");
    if (!surfaceless) {
        note(log, cap, "%s: no EGL_KHR_surfaceless_context; ", platform);
        return -1;
    }
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++) {
        if (!eglBindAPI(want[i].api)) {
            note(log, cap, "%s: %s: eglBindAPI failed (0x%x); ", platform,
                 want[i].name, (unsigned)eglGetError());
            continue;
        }
        EGLConfig cfg = (EGLConfig)0;
        if (!no_config) {
            EGLint attrs[] = {EGL_RENDERABLE_TYPE,
                              want[i].es ? EGL_OPENGL_ES3_BIT : EGL_OPENGL_BIT,
                              EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_NONE};
            EGLint n = 0;
            if (!eglChooseConfig(g->dpy, attrs, &cfg, 1, &n) || n < 1) {
                note(log, cap, "%s: %s: no config (0x%x); ", platform,
                     want[i].name, (unsigned)eglGetError());
                continue;
            }
        }
        EGLint cattrs[] = {EGL_CONTEXT_MAJOR_VERSION, want[i].major,
                           EGL_CONTEXT_MINOR_VERSION, want[i].minor,
                           want[i].es ? EGL_NONE : EGL_CONTEXT_OPENGL_PROFILE_MASK,
                           EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
        g->ctx = eglCreateContext(g->dpy, cfg, EGL_NO_CONTEXT, cattrs);
        if (g->ctx == EGL_NO_CONTEXT) {
            note(log, cap, "%s: %s: eglCreateContext failed (0x%x); ", platform,
                 want[i].name, (unsigned)eglGetError());
            continue;
        }
        if (!eglMakeCurrent(g->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, g->ctx)) {
            note(log, cap, "%s: %s: eglMakeCurrent failed (0x%x); ", platform,
                 want[i].name, (unsigned)eglGetError());
            eglDestroyContext(g->dpy, g->ctx);
            g->ctx = EGL_NO_CONTEXT;
            continue;
        }
        struct gv_gpu_info *in = &g->info;
        snprintf(in->platform, sizeof in->platform, "%s", platform);
        snprintf(in->api, sizeof in->api, "%s", want[i].name);
        snprintf(in->vendor, sizeof in->vendor, "%s", (const char *)glGetString(GL_VENDOR));
        snprintf(in->renderer, sizeof in->renderer, "%s", (const char *)glGetString(GL_RENDERER));
        snprintf(in->version, sizeof in->version, "%s", (const char *)glGetString(GL_VERSION));
        in->es = want[i].es;
        in->ssbo = 1;   /* ES 3.1+ and GL 4.3 both have SSBOs */
        return 0;
    }
    return -1;
}

static int try_display(struct gv_gpu *g, EGLDisplay dpy, const char *platform,
                       char *log, size_t cap)
{
    if (dpy == EGL_NO_DISPLAY) {
        note(log, cap, "%s: no display (0x%x); ", platform, (unsigned)eglGetError());
        return -1;
    }
    EGLint major, minor;
    if (!eglInitialize(dpy, &major, &minor)) {
        note(log, cap, "%s: eglInitialize failed (0x%x); ", platform,
             (unsigned)eglGetError());
        return -1;
    }
    g->dpy = dpy;
    if (try_contexts(g, platform, log, cap) == 0)
        return 0;
    eglTerminate(dpy);
    g->dpy = EGL_NO_DISPLAY;
    return -1;
}

/* eglGetPlatformDisplayEXT where the client extensions offer `ext`, else
 * NULL, noted in the log when the platform was forced (with auto a
 * platform the EGL library lacks is skipped silently). */
static PFNEGLGETPLATFORMDISPLAYEXTPROC platform_display_fn(const struct gv_gpu *g,
                                                           const char *ext,
                                                           const char *platform,
                                                           char *log, size_t cap)
{
    const char *cext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    PFNEGLGETPLATFORMDISPLAYEXTPROC get_platform_display =
        (PFNEGLGETPLATFORMDISPLAYEXTPROC)eglGetProcAddress("eglGetPlatformDisplayEXT");
    if (get_platform_display && gv_has_extension(cext, ext))
        return get_platform_display;
    if (g->want != GV_GPU_PLATFORM_AUTO)
        note(log, cap, "%s: no %s; ", platform, ext);
    return NULL;
}

/* Every EGL device in turn (EGL_EXT_platform_device): a GPU driver's, or
 * Mesa's software device. */
static int try_device(struct gv_gpu *g, char *log, size_t cap)
{
    PFNEGLGETPLATFORMDISPLAYEXTPROC get_platform_display =
        platform_display_fn(g, "EGL_EXT_platform_device", "device", log, cap);
    if (!get_platform_display)
        return -1;
    PFNEGLQUERYDEVICESEXTPROC query_devices =
        (PFNEGLQUERYDEVICESEXTPROC)eglGetProcAddress("eglQueryDevicesEXT");
    EGLDeviceEXT devs[16]; /* far more devices than one machine has */
    EGLint n = 0;
    if (query_devices && query_devices(16, devs, &n))
        for (EGLint i = 0; i < n; i++)
            if (try_display(g, get_platform_display(EGL_PLATFORM_DEVICE_EXT, devs[i], NULL),
                            "device", log, cap) == 0)
                return 0;
    if (n == 0 && g->want != GV_GPU_PLATFORM_AUTO)
        note(log, cap, "device: no EGL device; ");
    return -1;
}

/* Mesa's surfaceless platform (EGL_MESA_platform_surfaceless). */
static int try_surfaceless(struct gv_gpu *g, char *log, size_t cap)
{
    PFNEGLGETPLATFORMDISPLAYEXTPROC get_platform_display = platform_display_fn(
        g, "EGL_MESA_platform_surfaceless", "surfaceless", log, cap);
    if (!get_platform_display)
        return -1;
    return try_display(g, get_platform_display(EGL_PLATFORM_SURFACELESS_MESA,
                                               EGL_DEFAULT_DISPLAY, NULL),
                       "surfaceless", log, cap);
}

/* The EGL library's default display. */
static int try_default(struct gv_gpu *g, char *log, size_t cap)
{
    return try_display(g, eglGetDisplay(EGL_DEFAULT_DISPLAY), "default", log, cap);
}

/* A context sharing g->share's objects, on its display, with its config,
 * client API and version, current without a surface. */
static int create_shared(struct gv_gpu *g)
{
    if (!eglBindAPI(g->share_api))
        return gv_fail(&g->open_err, GV_EUNAVAIL, "gpu: shared context: "
                       "eglBindAPI failed (0x%x)", (unsigned)eglGetError());
    const int es = g->share_api == EGL_OPENGL_ES_API;
    EGLint attrs[] = {EGL_CONTEXT_MAJOR_VERSION, g->share_major,
                      EGL_CONTEXT_MINOR_VERSION, g->share_minor,
                      es || !g->share_profile ? EGL_NONE : EGL_CONTEXT_OPENGL_PROFILE_MASK,
                      g->share_profile, EGL_NONE};
    g->ctx = eglCreateContext(g->dpy, g->share_cfg, g->share, attrs);
    if (g->ctx == EGL_NO_CONTEXT)
        return gv_fail(&g->open_err, GV_EUNAVAIL, "gpu: shared context: "
                       "eglCreateContext failed (0x%x)", (unsigned)eglGetError());
    if (!eglMakeCurrent(g->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, g->ctx)) {
        gv_fail(&g->open_err, GV_EUNAVAIL, "gpu: shared context: eglMakeCurrent "
                "without a surface failed (0x%x)", (unsigned)eglGetError());
        eglDestroyContext(g->dpy, g->ctx);
        g->ctx = EGL_NO_CONTEXT;
        return -1;
    }
    struct gv_gpu_info *in = &g->info;
    snprintf(in->platform, sizeof in->platform, "shared");
    snprintf(in->api, sizeof in->api, "%s %d.%d", es ? "OpenGL ES" : "OpenGL",
             (int)g->share_major, (int)g->share_minor);
    snprintf(in->vendor, sizeof in->vendor, "%s", (const char *)glGetString(GL_VENDOR));
    snprintf(in->renderer, sizeof in->renderer, "%s", (const char *)glGetString(GL_RENDERER));
    snprintf(in->version, sizeof in->version, "%s", (const char *)glGetString(GL_VERSION));
    in->es = es;
    in->ssbo = 1;
    return 0;
}

static int create_context(struct gv_gpu *g)
{
    char log[1024] = "";
    if (g->share != EGL_NO_CONTEXT)
        return create_shared(g);
    const enum gv_gpu_platform w = g->want;
    if ((w == GV_GPU_PLATFORM_AUTO || w == GV_GPU_PLATFORM_DEVICE) &&
        try_device(g, log, sizeof log) == 0)
        return 0;
    if ((w == GV_GPU_PLATFORM_AUTO || w == GV_GPU_PLATFORM_SURFACELESS) &&
        try_surfaceless(g, log, sizeof log) == 0)
        return 0;
    if ((w == GV_GPU_PLATFORM_AUTO || w == GV_GPU_PLATFORM_DEFAULT) &&
        try_default(g, log, sizeof log) == 0)
        return 0;
    gv_fail(&g->open_err, GV_EUNAVAIL, "gpu: no usable EGL context: %s", log);
    return -1;
}

static void *gl_thread(void *arg)
{
    struct gv_gpu *g = arg;
    int ok = create_context(g) == 0;
    pthread_mutex_lock(&g->lock);
    g->started = 1;
    g->ok = ok;
    pthread_cond_broadcast(&g->done);
    while (ok) {
        while (!g->has_job && !g->stop)
            pthread_cond_wait(&g->wake, &g->lock);
        if (g->stop)
            break;
        g->has_job = 0;
        pthread_mutex_unlock(&g->lock);
        int rc = g->job(g->job_arg, g->job_err);
        pthread_mutex_lock(&g->lock);
        g->job_rc = rc;
        g->job_done = 1;
        pthread_cond_broadcast(&g->done);
    }
    pthread_mutex_unlock(&g->lock);
    if (g->ctx != EGL_NO_CONTEXT) {
        eglMakeCurrent(g->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        eglDestroyContext(g->dpy, g->ctx);
    }
    /* The display is not terminated: an EGL display is one per process and
     * platform, shared with any other context on it, so terminating it
     * here would pull the rug from under them.  (It also keeps Mesa from
     * unloading its driver, whose terminate path leaks.) */
    eglReleaseThread();
    return NULL;
}

/* Wait for the GL thread to end and free everything. */
static void join_and_free(struct gv_gpu *g)
{
    pthread_join(g->thread, NULL);
    pthread_mutex_destroy(&g->lock);
    pthread_mutex_destroy(&g->call_lock);
    pthread_cond_destroy(&g->wake);
    pthread_cond_destroy(&g->done);
    free(g);
}

/* Start g's GL thread and wait until its context is made.  Returns g, or
 * NULL with *err (g freed). */
static struct gv_gpu *start_thread(struct gv_gpu *g, struct gv_error *err)
{
    pthread_mutex_init(&g->lock, NULL);
    pthread_mutex_init(&g->call_lock, NULL);
    pthread_cond_init(&g->wake, NULL);
    pthread_cond_init(&g->done, NULL);
    if (pthread_create(&g->thread, NULL, gl_thread, g) != 0) {
        gv_fail(err, GV_ENOMEM, "gpu: cannot start the GL thread");
        pthread_mutex_destroy(&g->lock);
        pthread_mutex_destroy(&g->call_lock);
        pthread_cond_destroy(&g->wake);
        pthread_cond_destroy(&g->done);
        free(g);
        return NULL;
    }
    pthread_mutex_lock(&g->lock);
    while (!g->started)
        pthread_cond_wait(&g->done, &g->lock);
    int ok = g->ok;
    pthread_mutex_unlock(&g->lock);
    if (!ok) {
        if (err)
            *err = g->open_err;
        join_and_free(g);
        return NULL;
    }
    return g;
}

struct gv_gpu *gv_gpu_open(enum gv_gpu_platform platform, struct gv_error *err)
{
    struct gv_gpu *g = calloc(1, sizeof *g);
    if (!g) {
        gv_fail(err, GV_ENOMEM, "gpu: out of memory");
        return NULL;
    }
    g->want = platform;
    g->dpy = EGL_NO_DISPLAY;
    g->ctx = EGL_NO_CONTEXT;
    g->share = EGL_NO_CONTEXT;
    return start_thread(g, err);
}

/* Desktop GL's GL_CONTEXT_PROFILE_MASK (not in the ES headers). */
#define GV_GL_CONTEXT_PROFILE_MASK 0x9126

struct gv_gpu *gv_gpu_open_shared(struct gv_error *err)
{
    EGLDisplay dpy = eglGetCurrentDisplay();
    EGLContext share = eglGetCurrentContext();
    if (dpy == EGL_NO_DISPLAY || share == EGL_NO_CONTEXT) {
        gv_fail(err, GV_EUNAVAIL, "gpu: no current EGL context to share with "
                "(none is current, or it is not EGL's)");
        return NULL;
    }
    if (!gv_has_extension(eglQueryString(dpy, EGL_EXTENSIONS),
                          "EGL_KHR_surfaceless_context")) {
        gv_fail(err, GV_EUNAVAIL, "gpu: the window's EGL display has no "
                "EGL_KHR_surfaceless_context");
        return NULL;
    }
    EGLint cfg_id = 0, type = 0, n = 0;
    EGLConfig cfg = (EGLConfig)0;
    if (!eglQueryContext(dpy, share, EGL_CONTEXT_CLIENT_TYPE, &type) ||
        (type != EGL_OPENGL_ES_API && type != EGL_OPENGL_API)) {
        gv_fail(err, GV_EUNAVAIL, "gpu: the window's context is neither OpenGL "
                "ES nor OpenGL (0x%x)", (unsigned)type);
        return NULL;
    }
    eglQueryContext(dpy, share, EGL_CONFIG_ID, &cfg_id);
    if (cfg_id > 0) {
        const EGLint attrs[] = {EGL_CONFIG_ID, cfg_id, EGL_NONE};
        if (!eglChooseConfig(dpy, attrs, &cfg, 1, &n) || n < 1) {
            gv_fail(err, GV_EUNAVAIL, "gpu: the window's EGL config %d is not "
                    "found (0x%x)", (int)cfg_id, (unsigned)eglGetError());
            return NULL;
        }
    } else if (!gv_has_extension(eglQueryString(dpy, EGL_EXTENSIONS),
                                 "EGL_KHR_no_config_context")) {
        gv_fail(err, GV_EUNAVAIL, "gpu: the window's context has no EGL config");
        return NULL;
    }
    struct gv_gpu *g = calloc(1, sizeof *g);
    if (!g) {
        gv_fail(err, GV_ENOMEM, "gpu: out of memory");
        return NULL;
    }
    g->dpy = dpy;
    g->ctx = EGL_NO_CONTEXT;
    g->share = share;
    g->share_cfg = cfg;
    g->share_api = (EGLenum)type;
    GLint major = 0, minor = 0, profile = 0;
    glGetIntegerv(GL_MAJOR_VERSION, &major);
    glGetIntegerv(GL_MINOR_VERSION, &minor);
    if (type == EGL_OPENGL_API) {
        glGetIntegerv(GV_GL_CONTEXT_PROFILE_MASK, &profile);
        /* EGL's profile bits are GL's (EGL_KHR_create_context). */
        profile &= EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT |
                   EGL_CONTEXT_OPENGL_COMPATIBILITY_PROFILE_BIT;
    }
    while (glGetError() != GL_NO_ERROR)
        ;
    g->share_major = major;
    g->share_minor = minor;
    g->share_profile = profile;
    return start_thread(g, err);
}

struct gv_gpu *gv_gpu_adopt(struct gv_error *err)
{
    const char *version = (const char *)glGetString(GL_VERSION);
    if (!version) {
        gv_fail(err, GV_EUNAVAIL, "gpu: no current GL context to adopt");
        return NULL;
    }
    struct gv_gpu *g = calloc(1, sizeof *g);
    if (!g) {
        gv_fail(err, GV_ENOMEM, "gpu: out of memory");
        return NULL;
    }
    g->adopted = 1;
    g->owner = pthread_self();
    g->dpy = EGL_NO_DISPLAY;
    g->ctx = EGL_NO_CONTEXT;
    struct gv_gpu_info *in = &g->info;
    in->es = !strncmp(version, "OpenGL ES", 9);
    snprintf(in->platform, sizeof in->platform, "external");
    snprintf(in->api, sizeof in->api, "%s", in->es ? "OpenGL ES" : "OpenGL");
    snprintf(in->vendor, sizeof in->vendor, "%s", (const char *)glGetString(GL_VENDOR));
    snprintf(in->renderer, sizeof in->renderer, "%s", (const char *)glGetString(GL_RENDERER));
    snprintf(in->version, sizeof in->version, "%s", version);
    in->ssbo = 1;
    return g;
}

void gv_gpu_close(struct gv_gpu *g)
{
    if (!g)
        return;
    if (g->adopted) {
        free(g);
        return;
    }
    pthread_mutex_lock(&g->lock);
    g->stop = 1;
    pthread_cond_broadcast(&g->wake);
    pthread_mutex_unlock(&g->lock);
    join_and_free(g);
}

const struct gv_gpu_info *gv_gpu_info(const struct gv_gpu *g)
{
    return &g->info;
}

int gv_gpu_call(struct gv_gpu *g, int (*fn)(void *arg, struct gv_error *err),
                void *arg, struct gv_error *err)
{
    if (g->adopted) {
        if (!pthread_equal(pthread_self(), g->owner))
            return gv_fail(err, GV_EINVAL, "gpu: an adopted context is called "
                           "from another thread than its own");
        return fn(arg, err);
    }
    pthread_mutex_lock(&g->call_lock);
    pthread_mutex_lock(&g->lock);
    g->job = fn;
    g->job_arg = arg;
    g->job_err = err;
    g->job_done = 0;
    g->has_job = 1;
    pthread_cond_broadcast(&g->wake);
    while (!g->job_done)
        pthread_cond_wait(&g->done, &g->lock);
    int rc = g->job_rc;
    pthread_mutex_unlock(&g->lock);
    pthread_mutex_unlock(&g->call_lock);
    return rc;
}
