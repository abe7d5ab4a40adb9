/*
 * gpu_module.c - the GL housekeeping every GPU module shares
 * (gpu_module_int.h): the one wording of a GL error, and the deletion of
 * a module's GL objects from a table.  Building programs from tables of
 * stages is gpu_program.c's.
 */
#include <GLES3/gl31.h>

#include "gpu/gpu_module_int.h"

int gv_gpu_gl_check(struct gv_error *err, const char *what)
{
    const GLenum e = glGetError();
    if (e == GL_NO_ERROR)
        return 0;
    return gv_fail(err, GV_EIO, "gpu: %s failed (GL error 0x%04x)", what,
                   (unsigned)e);
}

int gv_gpu_gl_fail(struct gv_error *err, const char *what)
{
    if (gv_gpu_gl_check(err, what) < 0)
        return -1;
    return gv_fail(err, GV_EIO, "gpu: %s failed", what);
}

static void delete_one(enum gv_gpu_object kind, GLuint *name)
{
    switch (kind) {
    case GV_GPU_PROGRAMS:
        glDeleteProgram(*name);
        break;
    case GV_GPU_BUFFERS:
        glDeleteBuffers(1, name);
        break;
    case GV_GPU_TEXTURES:
        glDeleteTextures(1, name);
        break;
    case GV_GPU_FRAMEBUFFERS:
        glDeleteFramebuffers(1, name);
        break;
    case GV_GPU_VERTEX_ARRAYS:
        glDeleteVertexArrays(1, name);
        break;
    }
    *name = 0;
}

void gv_gpu_delete_objects(const struct gv_gpu_objects *t, size_t n)
{
    for (size_t i = 0; i < n; i++)
        for (size_t k = 0; k < t[i].count; k++)
            if (t[i].names[k])
                delete_one(t[i].kind, &t[i].names[k]);
}
