/*
 * tile_cache_disk.c - the client's on-disk tile cache (tile_cache_disk.h).
 */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "base/atomic_file.h"
#include "store/store_format.h"
#include "tile_cache_disk.h"

#define MAX_ENTRY (64u << 20)

struct gv_disk_cache {
    char dir[4096];
};

static void sanitize(const char *in, char *out, size_t cap)
{
    size_t i = 0;
    for (; *in && i + 1 < cap; in++) {
        char ch = *in;
        int okc = (ch >= 'A' && ch <= 'Z') || (ch >= 'a' && ch <= 'z') ||
                  (ch >= '0' && ch <= '9') || ch == '.' || ch == '-';
        out[i++] = okc ? ch : '_';
    }
    out[i] = 0;
    if (out[0] == '.')
        out[0] = '_';
}

/* mkdir -p for an absolute path; returns 0 if it exists afterwards. */
static int make_dirs(char *path)
{
    for (char *p = path + 1; *p; p++)
        if (*p == '/') {
            *p = 0;
            if (mkdir(path, 0700) < 0 && errno != EEXIST) {
                *p = '/';
                return -1;
            }
            *p = '/';
        }
    if (mkdir(path, 0700) < 0 && errno != EEXIST)
        return -1;
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode) ? 0 : -1;
}

struct gv_disk_cache *gv_disk_cache_open(const char *dir, const char *server,
                                         const char *image)
{
    char base[3072];
    const char *xdg = getenv("XDG_CACHE_HOME"), *home = getenv("HOME");
    if (dir && *dir)
        snprintf(base, sizeof base, "%s", dir);
    else if (xdg && xdg[0] == '/')
        snprintf(base, sizeof base, "%s/gigaview", xdg);
    else if (home && home[0] == '/')
        snprintf(base, sizeof base, "%s/.cache/gigaview", home);
    else
        return NULL;
    if (base[0] != '/') {
        char cwd[2048];
        if (!getcwd(cwd, sizeof cwd))
            return NULL;
        char rel[3072];
        snprintf(rel, sizeof rel, "%s", base);
        if (snprintf(base, sizeof base, "%s/%s", cwd, rel) >= (int)sizeof base)
            return NULL;
    }
    struct gv_disk_cache *dc = calloc(1, sizeof *dc);
    if (!dc)
        return NULL;
    char s[256], im[256];
    sanitize(server, s, sizeof s);
    sanitize(image, im, sizeof im);
    if (snprintf(dc->dir, sizeof dc->dir, "%s/%s/%s", base, s, im) >=
            (int)sizeof dc->dir ||
        make_dirs(dc->dir) < 0) {
        free(dc);
        return NULL;
    }
    return dc;
}

void gv_disk_cache_free(struct gv_disk_cache *dc)
{
    free(dc);
}

const char *gv_disk_cache_dir(const struct gv_disk_cache *dc)
{
    return dc->dir;
}

static uint32_t rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
           (uint32_t)p[3] << 24;
}

static void wr32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

int gv_disk_cache_get(struct gv_disk_cache *dc, const char *name,
                      uint8_t **data, size_t *len, char *etag, size_t etag_cap)
{
    if (!dc)
        return -1;
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", dc->dir, name);
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return -1;
    struct stat st;
    uint8_t *b = NULL;
    if (fstat(fd, &st) < 0 || st.st_size < 20 || st.st_size > MAX_ENTRY ||
        !(b = malloc((size_t)st.st_size))) {
        close(fd);
        return -1;
    }
    size_t n = (size_t)st.st_size, got = 0;
    while (got < n) {
        ssize_t r = read(fd, b + got, n - got);
        if (r <= 0)
            break;
        got += (size_t)r;
    }
    close(fd);
    if (got != n || memcmp(b, "GVC1", 4) != 0 ||
        gv_crc32(0, b, n - 4) != rd32(b + n - 4))
        goto bad;
    uint32_t elen = rd32(b + 4);
    if (elen >= etag_cap || (size_t)elen + 20 > n)
        goto bad;
    const uint8_t *p = b + 8 + elen;
    uint64_t dlen = rd32(p) | (uint64_t)rd32(p + 4) << 32;
    if (dlen != n - 20 - elen)
        goto bad;
    memcpy(etag, b + 8, elen);
    etag[elen] = 0;
    /* Move the data to the front of the buffer handed out. */
    memmove(b, p + 8, (size_t)dlen);
    *data = b;
    *len = (size_t)dlen;
    return 0;
bad:
    free(b);
    return -1;
}

void gv_disk_cache_put(struct gv_disk_cache *dc, const char *name,
                       const uint8_t *data, size_t len, const char *etag)
{
    if (!dc || !etag || !*etag || len > MAX_ENTRY)
        return;
    const size_t elen = strlen(etag);
    const size_t n = 20 + elen + len;
    uint8_t *b = malloc(n);
    if (!b)
        return;
    memcpy(b, "GVC1", 4);
    wr32(b + 4, (uint32_t)elen);
    memcpy(b + 8, etag, elen);
    wr32(b + 8 + elen, (uint32_t)len);
    wr32(b + 12 + elen, (uint32_t)((uint64_t)len >> 32));
    memcpy(b + 16 + elen, data, len);
    wr32(b + n - 4, gv_crc32(0, b, n - 4));
    /* Published like every file (atomic_file.h), but without fsync: an
     * entry lost in a crash is fetched again, and one damaged is caught by
     * its CRC.  Mode 0600, as the cache directories are 0700. */
    static const struct gv_atomic_opts entry_file = {
        .module = "cache", .mode = 0600, .no_sync = 1};
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", dc->dir, name);
    gv_atomic_file_write(path, b, n, &entry_file, NULL);
    free(b);
}
