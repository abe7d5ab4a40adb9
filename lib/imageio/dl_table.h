/*
 * dl_table.h - a table of a shared library's functions filled by dlopen
 * and dlsym, for the readers that open their library at the first file
 * they read instead of linking it (slide_openslide.c, raster_gdal.c):
 * OpenSlide and GDAL bring some 50 and 110 libraries, which every
 * gigaview process would otherwise load.  Internal to lib/imageio.
 */
#ifndef GV_DL_TABLE_H
#define GV_DL_TABLE_H

#include <stddef.h>

/* One function: where to store it, and its name. */
struct gv_dl_sym {
    void **slot;
    const char *name;
};

/* dlopen `soname` (RTLD_NOW | RTLD_LOCAL) and fill every slot of syms[n].
 * Returns 1 when all were found (the library then stays open for the life
 * of the process), else 0 with every slot NULL and the library closed.
 * Call once (pthread_once). */
int gv_dl_table(const char *soname, const struct gv_dl_sym *syms, size_t n);

#endif
