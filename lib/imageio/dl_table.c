/*
 * dl_table.c - filling a table of functions from a library opened with
 * dlopen (dl_table.h).
 */
#include <dlfcn.h>

#include "imageio/dl_table.h"

int gv_dl_table(const char *soname, const struct gv_dl_sym *syms, size_t n)
{
    void *h = dlopen(soname, RTLD_NOW | RTLD_LOCAL);
    if (!h)
        return 0;
    for (size_t i = 0; i < n; i++) {
        /* POSIX: a function pointer may be stored through void *. */
        *syms[i].slot = dlsym(h, syms[i].name);
        if (!*syms[i].slot) {
            for (size_t j = 0; j < n; j++)
                *syms[j].slot = NULL;
            dlclose(h);
            return 0;
        }
    }
    return 1;
}
