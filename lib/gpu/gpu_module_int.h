/*
 * gpu_module_int.h - what every GPU module of lib/gpu is built from
 * (internal to lib/gpu: gpu_decode.c, gpu_height.c, gpu_zfield.c,
 * gpu_cluster.c).
 *
 * A module is an opaque struct made by one constructor, gv_gpu_X_new (its
 * choices in an options struct whose zeros are the defaults, among them
 * enum gv_gpu_path where it runs either way), whose set-up runs on the GL
 * thread: it builds its programs from a table
 * of stages and uniform names (gv_gpu_build_programs, gpu_program.c),
 * makes its buffers and textures, and ends with gv_gpu_gl_check.  Its
 * gv_gpu_X_free deletes every GL object named in a table
 * (gv_gpu_delete_objects, gpu_module.c).  So every module reports a shader
 * that does not build the same way (the numbered source and the driver's
 * log on stderr, the log in *err) and a GL error with the same words.
 * Everything here runs on the GL thread only.
 */
#ifndef GV_GPU_MODULE_INT_H
#define GV_GPU_MODULE_INT_H

#include <stddef.h>

#include "base/error.h"
#include "gpu/gpu.h"

/* Source parts of one stage at most: the version head comes first, then
 * these, concatenated (a module's #define lines, shared rules, the body). */
#define GV_GPU_STAGE_PARTS 4

/* One shader stage: its GL type (GL_VERTEX_SHADER, GL_FRAGMENT_SHADER,
 * GL_COMPUTE_SHADER; 0 ends a program's list) and its source parts, unused
 * ones NULL. */
struct gv_gpu_stage {
    unsigned type;
    const char *parts[GV_GPU_STAGE_PARTS];
};

/* A uniform to look up once the program links: *loc receives
 * glGetUniformLocation (-1 where the program lacks it). */
struct gv_gpu_uniform {
    const char *name;
    int *loc;
};

/* One program of a module: where its name goes, its stages (a vertex and
 * a fragment stage, or a compute stage alone), and its uniforms (a list
 * ended by a NULL name, or NULL). */
struct gv_gpu_program_def {
    unsigned *prog;
    struct gv_gpu_stage stage[2];
    const struct gv_gpu_uniform *uniforms;
};

/*
 * Build the n programs of defs in order for `path` (the version head of
 * gv_gpu_program for GV_GPU_PATH_COMPUTE; "#version 300 es" for
 * GV_GPU_PATH_WEBGL2, whose programs have no compute stage) and look up
 * their uniforms.  Returns 0, or -1 at the first failure with *err:
 * GV_EINVAL "gpu: <stage> shader does not compile: <driver's log>" or
 * "gpu: program does not link: <log>", the numbered source and the whole
 * log then printed on stderr (our own shaders failing is a bug or a broken
 * driver); GV_EFORMAT when the WebGL2 path meets a context that is not
 * OpenGL ES; GV_ENOMEM.  The programs built before a failure stay in
 * their *prog for the module's teardown.
 */
int gv_gpu_build_programs(const struct gv_gpu *g, enum gv_gpu_path path,
                          const struct gv_gpu_program_def *defs, size_t n,
                          struct gv_error *err);

/* 0 when GL reports no error, else -1 with GV_EIO "gpu: <what> failed (GL
 * error 0x....)", the one wording of a GL failure in lib/gpu. */
int gv_gpu_gl_check(struct gv_error *err, const char *what);

/* Always -1: as gv_gpu_gl_check, or "gpu: <what> failed" (GV_EIO) when
 * GL reports no error (a map that returned NULL, say). */
int gv_gpu_gl_fail(struct gv_error *err, const char *what);

/* The kinds of GL object a module's teardown deletes. */
enum gv_gpu_object {
    GV_GPU_PROGRAMS,
    GV_GPU_BUFFERS,
    GV_GPU_TEXTURES,
    GV_GPU_FRAMEBUFFERS,
    GV_GPU_VERTEX_ARRAYS
};

/* `count` names of one kind, at `names`. */
struct gv_gpu_objects {
    enum gv_gpu_object kind;
    unsigned *names;
    size_t count;
};

/* Delete every nonzero name of the n entries of t and set it to 0 (so a
 * set-up that failed halfway tears down what it made). */
void gv_gpu_delete_objects(const struct gv_gpu_objects *t, size_t n);

#endif
