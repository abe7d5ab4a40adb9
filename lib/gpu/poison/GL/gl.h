/*
 * GL/gl.h - a stand-in that stops a build configured --without-gpu when
 * anything outside the GPU parts includes the EGL or GL header of this
 * name (Makefile.am puts lib/gpu/poison first on the include path of such
 * a build).  Only lib/gpu/gpu_*.c and filters/run_gpu.c include GL, and
 * they are not compiled without the GPU.
 */
#error "GL/gl.h included in a build configured --without-gpu: only lib/gpu/gpu_*.c and filters/run_gpu.c may include EGL or GL headers"
