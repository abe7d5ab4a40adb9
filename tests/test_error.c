/*
 * test_error.c - the contract of struct gv_error (lib/base/error.h): the
 * first failure is the one reported, later gv_fail and gv_fail_errno
 * calls leave it alone, gv_error_clear makes the error reusable, and
 * gv_error_recode is the one way to change a failure's code.
 */
#include <errno.h>
#include <string.h>

#include "base/error.h"
#include "util.h"

int main(void)
{
    struct gv_error err = {0};

    check(gv_fail(&err, GV_ECORRUPT, "store: bad magic in page %d", 12) == -1,
          "gv_fail returns -1");
    check(err.code == GV_ECORRUPT, "the first failure sets the code");
    check_str(err.text, "store: bad magic in page 12", "the first failure sets the message");

    check(gv_fail(&err, GV_ELIMIT, "later: %s", "overwrite") == -1,
          "a second gv_fail still returns -1");
    check(err.code == GV_ECORRUPT && strcmp(err.text, "store: bad magic in "
          "page 12") == 0, "a second gv_fail leaves the first failure");
    check(gv_fail_errno(&err, ENOSPC, "later: write") == -1 &&
          err.code == GV_ECORRUPT && strcmp(err.text, "store: bad magic in "
          "page 12") == 0, "so does gv_fail_errno");

    check(gv_error_recode(&err, GV_ELIMIT, GV_EINVAL) == 0 &&
          err.code == GV_ECORRUPT, "recode from another code changes nothing");
    check(gv_error_recode(&err, GV_ECORRUPT, GV_EINVAL) == 1 &&
          err.code == GV_EINVAL, "recode from the held code changes it");
    check_str(err.text, "store: bad magic in page 12", "recode keeps the message");
    check(gv_error_recode(NULL, GV_ECORRUPT, GV_EINVAL) == 0,
          "recode of NULL is a no-op");

    gv_error_clear(&err);
    check(err.code == GV_OK && err.text[0] == '\0', "clear resets the error");
    check(gv_fail_errno(&err, ENOSPC, "spill: write %s", "x") == -1 &&
          err.code == GV_ENOSPC, "after clear, gv_fail_errno fills it again");
    char want[320];
    snprintf(want, sizeof want, "spill: write x: %s", strerror(ENOSPC));
    check_str(err.text, want, "gv_fail_errno appends strerror");

    /* A failure re-said in the caller's terms: clear, then fail. */
    gv_error_clear(&err);
    gv_fail(&err, GV_ENOTFOUND, "http: 404");
    gv_error_clear(&err);
    gv_fail(&err, GV_ENOTFOUND, "no image '%s' on %s", "a", "b");
    check_str(err.text, "no image 'a' on b", "clear then gv_fail replaces a failure");

    check(gv_fail(NULL, GV_EIO, "nowhere") == -1 &&
          gv_fail_errno(NULL, EIO, "nowhere") == -1, "NULL errors are allowed");
    return tap_done();
}
