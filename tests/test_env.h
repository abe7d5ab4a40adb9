/*
 * test_env.h - where the C unit tests find their data and keep their
 * files: the set-up that eleven tests each wrote out, once.
 *
 * The test data directory is $TESTDATA (which `make check` exports as an
 * absolute path, so out-of-tree builds work), else tests/data (a run by
 * hand from the top of the source tree).  A test's temporary directory is
 * made under $TMPDIR (/tmp when it is unset or empty) with mkdtemp, and
 * removed with everything in it at the end; a test that stops with fail()
 * leaves it behind for a look.  Static inline, like util.h, which must be
 * included too.
 */
#ifndef GV_TESTS_TEST_ENV_H
#define GV_TESTS_TEST_ENV_H

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "util.h"

/* The test data directory: $TESTDATA if set (even to ""), else
 * "tests/data".  Never NULL. */
static inline const char *test_data_dir(void)
{
    const char *d = getenv("TESTDATA");
    return d ? d : "tests/data";
}

/* test_data_dir(), and fail() unless its LICENSES.md is there: for the
 * tests that would otherwise report every missing file one by one. */
static inline const char *test_data_dir_found(void)
{
    const char *d = test_data_dir();
    char probe[4096];
    struct stat st;
    snprintf(probe, sizeof probe, "%s/LICENSES.md", d);
    if (stat(probe, &st) != 0)
        fail("test data not found in %s (set TESTDATA)", d);
    return d;
}

/* DIR/NAME in one of four static buffers, so that up to four such paths
 * can be in use at once; fail() when it does not fit. */
static inline const char *test_path_in(const char *dir, const char *name)
{
    static char buf[4][4096];
    static int k;
    k = (k + 1) % 4;
    if ((size_t)snprintf(buf[k], sizeof buf[k], "%s/%s", dir, name)
        >= sizeof buf[k])
        fail("path too long: %s/%s", dir, name);
    return buf[k];
}

/* Write n bytes to path (created or truncated); fail() if that fails. */
static inline void test_write_file(const char *path, const uint8_t *p,
                                   size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(p, 1, n, f) != n || fclose(f) != 0)
        fail("%s: cannot write", path);
}

/* The whole file at path, malloc'ed (free it) with a NUL after its *len
 * bytes, or NULL when it cannot be opened or read. */
static inline uint8_t *test_read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    uint8_t *p = NULL;
    long n = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
    if (n >= 0 && fseek(f, 0, SEEK_SET) == 0 &&
        (p = malloc((size_t)n + 1)) != NULL &&
        fread(p, 1, (size_t)n, f) == (size_t)n) {
        p[n] = 0;
        *len = (size_t)n;
    } else {
        free(p);
        p = NULL;
    }
    fclose(f);
    return p;
}

/* test_read_file, and fail() when the file cannot be read: for the data
 * a test is built on. */
static inline uint8_t *test_read_file_found(const char *path, size_t *len)
{
    uint8_t *p = test_read_file(path, len);
    if (!p)
        fail("%s: cannot read: %s", path, strerror(errno));
    return p;
}

/* A field of /proc/self/status in kB ("VmHWM", "VmRSS"), or -1. */
static inline long long test_status_kb(const char *key)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long long v = -1;
    size_t n = strlen(key);
    while (f && fgets(line, sizeof line, f))
        if (strncmp(line, key, n) == 0 && line[n] == ':')
            v = atoll(line + n + 1);
    if (f)
        fclose(f);
    return v;
}

/* Reset the peak resident size to the current one (Linux 4.0's
 * /proc/self/clear_refs "5"); 0 when that cannot be done. */
static inline int test_peak_reset(void)
{
    FILE *f = fopen("/proc/self/clear_refs", "w");
    if (!f)
        return 0;
    int ok = fputs("5", f) >= 0;
    return fclose(f) == 0 && ok;
}

/* Make $TMPDIR/PREFIX-XXXXXX (/tmp when TMPDIR is unset or empty) into
 * dir (size bytes); fail() when the name does not fit or mkdtemp fails. */
static inline void test_tmpdir_new(char *dir, size_t size, const char *prefix)
{
    const char *t = getenv("TMPDIR");
    int n = snprintf(dir, size, "%s/%s-XXXXXX", t && *t ? t : "/tmp", prefix);
    if (n < 0 || (size_t)n >= size)
        fail("temporary directory name too long: %s/%s-XXXXXX",
             t && *t ? t : "/tmp", prefix);
    if (!mkdtemp(dir))
        fail("mkdtemp %s: %s", dir, strerror(errno));
}

/* Remove everything in the open directory dfd (which it closes), without
 * following links: names relative to it, so no path is ever composed.
 * Returns the number of entries left, each reported on a "#" line (a
 * diagnostic, not a failed check). */
static inline int test_empty_dir(int dfd)
{
    DIR *d = fdopendir(dfd);
    int left = 0;
    if (!d) {
        close(dfd);
        return 1;
    }
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        if (unlinkat(dirfd(d), e->d_name, 0) == 0)
            continue;
        int sub = openat(dirfd(d), e->d_name,
                         O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
        if (sub >= 0)
            left += test_empty_dir(sub);
        if (unlinkat(dirfd(d), e->d_name, AT_REMOVEDIR) != 0) {
            printf("# could not remove %s: %s\n", e->d_name, strerror(errno));
            left++;
        }
    }
    closedir(d);
    return left;
}

/* Remove a test's temporary directory and everything in it, without
 * following links. */
static inline void test_tmpdir_free(const char *dir)
{
    int dfd = open(dir, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (dfd >= 0)
        test_empty_dir(dfd);
    if (rmdir(dir) != 0)
        printf("# could not remove %s: %s\n", dir, strerror(errno));
}

#endif
