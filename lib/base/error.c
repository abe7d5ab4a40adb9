/*
 * error.c - struct gv_error helpers.  See error.h for the model: the
 * first failure written into an error stays until it is cleared.
 */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "base/error.h"

int gv_fail(struct gv_error *err, enum gv_code code, const char *fmt, ...)
{
    if (err && err->code == GV_OK) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->text, sizeof err->text, fmt, ap);
        va_end(ap);
        err->code = code;
    }
    return -1;
}

int gv_fail_errno(struct gv_error *err, int errnum, const char *fmt, ...)
{
    if (err && err->code == GV_OK) {
        va_list ap;
        char head[256];
        va_start(ap, fmt);
        vsnprintf(head, sizeof head, fmt, ap);
        va_end(ap);
        snprintf(err->text, sizeof err->text, "%s: %s", head, strerror(errnum));
        err->code = (errnum == ENOSPC || errnum == EFBIG || errnum == EDQUOT)
                        ? GV_ENOSPC : GV_EIO;
    }
    return -1;
}

void gv_error_clear(struct gv_error *err)
{
    if (err) {
        err->code = GV_OK;
        err->text[0] = '\0';
    }
}

int gv_error_recode(struct gv_error *err, enum gv_code from, enum gv_code to)
{
    if (!err || err->code != from)
        return 0;
    err->code = to;
    return 1;
}
