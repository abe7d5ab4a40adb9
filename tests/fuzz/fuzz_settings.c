/*
 * fuzz_settings.c - libFuzzer target for gigaviewd's configuration file
 * parser (server/settings.c, settings_load).
 *
 * The input is a whole configuration file, put in a memfd and loaded
 * through /proc/self/fd/N (settings_load takes a path, as gigaviewd -c
 * does) over the defaults.  Checked:
 *  - failure: a message of the form "PATH:LINE: ..." naming a line that
 *    exists in the input (or the path alone when the file cannot be
 *    read), and code GV_EINVAL;
 *  - success: every string field is NUL-terminated inside its array;
 *    the enumerated and bounded keys hold values the table allows
 *    (spot checks: port, threads, log_level, gpu, jpeg_quality,
 *    max_upscale, filter_max_json_depth), and terrain_water_below parses;
 *  - loading the same file again over the result changes nothing, and
 *    over fresh defaults gives the same struct byte for byte.
 * Anything else aborts.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "fuzz.h"
#include "log.h"
#include "settings.h"

#define MAX_INPUT (256u << 10) /* a config file is a few KiB */

static int write_all(int fd, const uint8_t *p, size_t n)
{
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w <= 0)
            return -1;
        p += w;
        n -= (size_t)w;
    }
    return 0;
}

#define TERMINATED(field) (memchr((field), '\0', sizeof(field)) != NULL)

static void check_values(const struct settings *c)
{
    if (!TERMINATED(c->listen) || !TERMINATED(c->store_dir) ||
        !TERMINATED(c->cors_origin) || !TERMINATED(c->auth_token) ||
        !TERMINATED(c->public_url) || !TERMINATED(c->log_level) ||
        !TERMINATED(c->access_log) || !TERMINATED(c->gpu) ||
        !TERMINATED(c->filter_worker) || !TERMINATED(c->filter_dir) ||
        !TERMINATED(c->filter_library_dir) || !TERMINATED(c->access_policy) ||
        !TERMINATED(c->access_token_secret_file) ||
        !TERMINATED(c->access_trusted_header) || !TERMINATED(c->access_origins) ||
        !TERMINATED(c->terrain_water_below))
        abort();
    double water; /* a loaded terrain_water_below always parses */
    if (settings_water_below(c->terrain_water_below, "x", &water) < 0)
        abort();
    if (c->access_token_ttl < 60 || c->access_token_ttl > 31536000)
        abort();
    if (c->port > 65535 || c->threads < 1 || c->threads > 256)
        abort();
    if (log_level_parse(c->log_level) < 0)
        abort();
    if (strcmp(c->gpu, "auto") && strcmp(c->gpu, "off"))
        abort();
    if (c->jpeg_quality < 1 || c->jpeg_quality > 100)
        abort();
    if (!(c->max_upscale >= 1 && c->max_upscale <= 64))
        abort();
    if (c->filter_max_json_depth < 4 || c->filter_max_json_depth > 64)
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > MAX_INPUT)
        return 0;
    int fd = memfd_create("fuzz_settings", MFD_CLOEXEC);
    if (fd < 0 || write_all(fd, data, size) < 0) {
        perror("memfd");
        abort();
    }
    char path[64];
    snprintf(path, sizeof path, "/proc/self/fd/%d", fd);

    /* Both structs are heap copies so that ASan sees their exact bounds. */
    struct settings *a = malloc(sizeof *a), *b = malloc(sizeof *b);
    if (!a || !b)
        abort();
    settings_defaults(a);
    struct gv_error err = {0};
    gv_error_clear(&err);
    if (settings_load(a, path, &err) < 0) {
        if (err.code != GV_EINVAL || strncmp(err.text, path, strlen(path)))
            abort();
        const char *p = err.text + strlen(path);
        if (*p == ':') {
            long line = strtol(p + 1, NULL, 10);
            long lines = 1;
            for (size_t i = 0; i < size; i++)
                lines += data[i] == '\n';
            if (line < 1 || line > lines)
                abort();
        }
    } else {
        check_values(a);
        memcpy(b, a, sizeof *a);
        if (settings_load(b, path, &err) < 0 || memcmp(a, b, sizeof *a))
            abort();
        settings_defaults(b);
        if (settings_load(b, path, &err) < 0 || memcmp(a, b, sizeof *a))
            abort();
    }
    free(a);
    free(b);
    close(fd);
    return 0;
}
