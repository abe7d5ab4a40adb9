/*
 * error.h - error reporting shared by every gigaview module.
 *
 * Functions that can fail return 0 / -1 (or a pointer / NULL) and fill a
 * struct gv_error that the caller owns, in the jansson style: no global
 * buffer, so it is safe across threads.  Messages start with the module
 * name ("store: bad magic in page 12").  The code classifies the failure so
 * that the HTTP layer can map it to a status with one table (server/http.c;
 * the statuses are noted below).
 *
 * The first failure is the one reported: gv_fail and gv_fail_errno fill
 * *err only while it holds GV_OK, so a caller that goes on after a
 * failure (cleanup that fails too, a wrapper adding its own message)
 * never overwrites the cause.  Hence a struct gv_error starts zeroed
 * (`struct gv_error err = {0};`) or cleared with gv_error_clear, and one
 * reused after a failure that was handled (a loop, a fallback that tries
 * something else) is cleared before its next use.  A caller that means to
 * report a failure differently says so: gv_error_recode changes the code
 * and keeps the message; gv_error_clear then gv_fail replaces both.
 */
#ifndef GV_ERROR_H
#define GV_ERROR_H

#ifdef __cplusplus
extern "C" {
#endif

enum gv_code {
    GV_OK = 0,
    GV_EINVAL,   /* bad argument or bad user input, GLSL that does not
                    compile included (400) */
    GV_ENOTFOUND,/* missing file, image, tile (404) */
    GV_ELIMIT,   /* a configured limit was exceeded (413; 400 on IIIF routes) */
    GV_EFORMAT,  /* a valid request for a format or feature this build
                    does not support (501) */
    GV_ECORRUPT, /* data failed validation: CRC, sizes, truncation (500) */
    GV_EIO,      /* operating-system I/O failure (500) */
    GV_ENOSPC,   /* disk full or file size limit (507) */
    GV_ENOMEM,   /* allocation failure (503) */
    GV_EUNAVAIL, /* something it needs is not there: no usable EGL context,
                    no filter worker, the server is stopping (503) */
    GV_EBUSY,    /* too much work queued already; try again (503) */
    GV_ETIMEOUT, /* a time limit ran out (504) */
    GV_ECRASH,   /* a helper process died during the work (500) */
    GV_EPERM,    /* not allowed by the configuration (403) */
    GV_EAUTH,    /* needs credentials that were not given (401) */
    GV_CODE_MAX = GV_EAUTH /* the highest code: codes that cross a process
                              boundary (filters/worker.h) are checked
                              against it */
};

struct gv_error {
    enum gv_code code;
    char text[320];
};

/*
 * Fill *err (which may be NULL) with code and a printf-style message,
 * unless *err already holds a failure (code != GV_OK): then it is left as
 * it is.  Always returns -1 so that callers can write
 * `return gv_fail(...)`.
 */
int gv_fail(struct gv_error *err, enum gv_code code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Like gv_fail (a failure already in *err stays), appending
 * ": strerror(errnum)" and choosing GV_ENOSPC for ENOSPC/EFBIG/EDQUOT and
 * GV_EIO otherwise. */
int gv_fail_errno(struct gv_error *err, int errnum, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Reset *err (which may be NULL) to GV_OK with an empty message. */
void gv_error_clear(struct gv_error *err);

/* The one sanctioned way to re-map a failure: where *err (which may be
 * NULL) holds code from, it holds code to after, with its message
 * unchanged; any other *err is left as it is.  For a layer that knows
 * better what a failure means to its caller (a 413 limit in a filter
 * graph is a 400 bad graph; a missing file is GV_ENOTFOUND, not GV_EIO).
 * Returns 1 if the code was changed, else 0. */
int gv_error_recode(struct gv_error *err, enum gv_code from, enum gv_code to);

#ifdef __cplusplus
}
#endif

#endif
