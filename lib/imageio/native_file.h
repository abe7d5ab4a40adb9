/*
 * native_file.h - opening an input file for the native readers
 * (native_jpeg.c, native_png.c) and the loader's look at its first bytes
 * (imageio_loader.c): regular files only, checked on the open descriptor,
 * and opened without blocking, so that a FIFO or a device named as an
 * image is never waited on (the module then refuses it: "not a regular
 * file").  Internal to lib/imageio.
 */
#ifndef GV_NATIVE_FILE_H
#define GV_NATIVE_FILE_H

#include <fcntl.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

/* `path` opened for reading if it is a regular file, else NULL. */
static inline FILE *gv_native_open_regular(const char *path)
{
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return NULL;
    struct stat st;
    FILE *f = NULL;
    if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode))
        f = fdopen(fd, "rb");
    if (!f)
        close(fd);
    return f;
}

#endif
