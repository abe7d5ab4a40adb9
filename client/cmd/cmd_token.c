/*
 * cmd_token.c - `gigaview token --secret-file F --groups a,b [--ttl S]
 * [--sub NAME]`: mint an access token for gigaviewd (docs/OPERATIONS.md
 * "Access control") and print it.
 *
 * The token is the one server/access_token.c verifies (the same code
 * signs it), under the secret gigaviewd reads from
 * access_token_secret_file: the file's bytes less trailing newlines, at
 * least 32 of them.  scripts/gigaview-token does the same in Python.
 */
#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "access_token.h"
#include "commands.h"
#include "options.h"

#define ME "gigaview token"

struct token_args {
    const char *secret_file;
    const char *groups;
    int ttl;
    const char *sub;
};

static const struct opt_spec token_opts[] = {
    {.name = "secret-file", .kind = OPT_STRING, .arg = "FILE",
     .field = offsetof(struct token_args, secret_file),
     .help = "the secret (gigaviewd's access_token_secret_file)"},
    {.name = "groups", .kind = OPT_STRING, .arg = "A,B",
     .field = offsetof(struct token_args, groups),
     .help = "comma-separated access groups"},
    {.name = "ttl", .kind = OPT_INT, .arg = "S", .min = 1, .max = 31536000,
     .field = offsetof(struct token_args, ttl),
     .help = "seconds the token stays valid (default 3600)"},
    {.name = "sub", .kind = OPT_STRING, .arg = "NAME",
     .field = offsetof(struct token_args, sub),
     .help = "who the token is for (informational)"},
};

static const struct opt_command token_command = {
    .me = ME,
    .synopsis = "usage: gigaview token --secret-file FILE --groups A,B "
                "[--ttl S] [--sub NAME]\n"
                "\n"
                "Mint an access token for gigaviewd and print it: send it as\n"
                "\"Authorization: Bearer TOKEN\".\n",
    .opts = token_opts,
    .nopts = sizeof token_opts / sizeof token_opts[0],
};

/* The secret as gigaviewd reads it: 0, or -1 after a message. */
static int read_secret(const char *path, uint8_t *buf, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, ME ": %s: %s\n", path, strerror(errno));
        return -1;
    }
    size_t n = fread(buf, 1, ACCESS_SECRET_MAX + 2, f);
    fclose(f);
    while (n > 0 && (buf[n - 1] == '\n' || buf[n - 1] == '\r'))
        n--;
    if (n < ACCESS_SECRET_MIN || n > ACCESS_SECRET_MAX) {
        fprintf(stderr, ME ": %s: %zu bytes; a secret has %d to %d\n", path,
                n, ACCESS_SECRET_MIN, ACCESS_SECRET_MAX);
        return -1;
    }
    *len = n;
    return 0;
}

int cmd_token(int argc, char **argv)
{
    struct token_args a = {.ttl = 3600, .groups = "", .sub = ""};
    int first, rc = opt_parse(&token_command, argc, argv, &a, &first);
    if (rc != OPT_GO_ON)
        return rc;
    if (!a.secret_file || first != argc) {
        opt_usage(&token_command, stderr);
        return 2;
    }
    struct access_claims c;
    memset(&c, 0, sizeof c);
    if (strlen(a.sub) > ACCESS_SUB_MAX) {
        fprintf(stderr, ME ": --sub: more than %d bytes\n", ACCESS_SUB_MAX);
        return 2;
    }
    memcpy(c.sub, a.sub, strlen(a.sub) + 1);
    for (const char *p = a.groups; *p;) {
        size_t n = strcspn(p, ",");
        if (n) {
            if (!access_group_valid(p, n) || c.ngroups == ACCESS_GROUPS_MAX) {
                fprintf(stderr, ME ": --groups: at most %d names of 1 to %d of "
                        "A-Z a-z 0-9 . _ -\n", ACCESS_GROUPS_MAX, ACCESS_GROUP_MAX);
                return 2;
            }
            memcpy(c.group[c.ngroups], p, n);
            c.group[c.ngroups++][n] = '\0';
        }
        p += n + (p[n] == ',');
    }
    c.iat = (int64_t)time(NULL);
    c.exp = c.iat + a.ttl;
    uint8_t secret[ACCESS_SECRET_MAX + 2];
    size_t slen;
    char tok[ACCESS_TOKEN_MAX + 1];
    if (read_secret(a.secret_file, secret, &slen) < 0)
        return 1;
    rc = access_token_sign(secret, slen, &c, tok, sizeof tok);
    memset(secret, 0, sizeof secret);
    if (rc < 0) {
        fprintf(stderr, ME ": cannot sign (a --sub with control characters "
                "or invalid UTF-8?)\n");
        return 1;
    }
    printf("%s\n", tok);
    return 0;
}
