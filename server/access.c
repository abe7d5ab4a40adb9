/*
 * access.c - access control at run time (see access.h).
 *
 * One mutex guards the pointer to the policy in force and the reference
 * counts of the snapshots; the policy itself is immutable, so requests
 * read it without the lock.
 */
#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <time.h>

#include "access.h"
#include "log.h"

struct access {
    const struct settings *cfg;
    pthread_mutex_t lock;
    struct access_policy *cur;  /* NULL: no policy; refs counts this
                                   pointer and every snapshot held */
    uint8_t secret[ACCESS_SECRET_MAX];
    size_t secret_len;          /* 0: none */
};

static int read_secret(struct access *a, const char *path, struct gv_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return gv_fail_errno(err, errno, "access_token_secret_file: %s", path);
    struct stat st;
    if (fstat(fileno(f), &st) == 0 && (st.st_mode & 077))
        log_msg(LOG_WARN, "access", "%s may be read by other users than its "
                "owner (chmod 600 it)", path);
    uint8_t buf[ACCESS_SECRET_MAX + 2];
    size_t n = fread(buf, 1, sizeof buf, f);
    int bad = ferror(f);
    fclose(f);
    if (bad)
        return gv_fail(err, GV_EIO, "access_token_secret_file: %s: read error",
                       path);
    while (n > 0 && (buf[n - 1] == '\n' || buf[n - 1] == '\r'))
        n--;
    if (n > ACCESS_SECRET_MAX)
        return gv_fail(err, GV_EINVAL, "access_token_secret_file: %s: more "
                       "than %d bytes", path, ACCESS_SECRET_MAX);
    if (n < ACCESS_SECRET_MIN)
        return gv_fail(err, GV_EINVAL, "access_token_secret_file: %s: %zu "
                       "bytes; a secret needs at least %d (e.g. head -c 48 "
                       "/dev/urandom | base64 > FILE)", path, n,
                       ACCESS_SECRET_MIN);
    memcpy(a->secret, buf, n);
    a->secret_len = n;
    memset(buf, 0, sizeof buf);
    return 0;
}

static int load_policy(struct access *a, struct gv_error *err)
{
    struct access_policy *p = access_policy_load(a->cfg->access_policy, err);
    if (!p)
        return -1;
    p->refs = 1;
    pthread_mutex_lock(&a->lock);
    struct access_policy *old = a->cur;
    a->cur = p;
    int last = old && --old->refs == 0;
    pthread_mutex_unlock(&a->lock);
    if (last)
        access_policy_free(old);
    int protected = 0;
    for (int i = 0; i < p->nrules; i++)
        protected += p->rule[i].group >= 0;
    log_msg(LOG_INFO, "access", "%s: %d rules (%d protected), %d groups",
            a->cfg->access_policy, p->nrules, protected, p->ngroups);
    return 0;
}

struct access *access_new(const struct settings *cfg, struct gv_error *err)
{
    struct access *a = calloc(1, sizeof *a);
    if (!a) {
        gv_fail(err, GV_ENOMEM, "access: out of memory");
        return NULL;
    }
    a->cfg = cfg;
    pthread_mutex_init(&a->lock, NULL);
    if (cfg->access_trusted_header[0] &&
        !access_group_valid(cfg->access_trusted_header,
                            strlen(cfg->access_trusted_header))) {
        gv_fail(err, GV_EINVAL, "access_trusted_header: '%s' is not a header "
                "name", cfg->access_trusted_header);
        goto fail;
    }
    if (cfg->access_token_secret_file[0]) {
        if (read_secret(a, cfg->access_token_secret_file, err) < 0)
            goto fail;
    } else if (cfg->access_trusted_header[0]) {
        /* Tokens only this process mints and reads: any secret will do. */
        if (getrandom(a->secret, 32, 0) != 32) {
            gv_fail_errno(err, errno, "access: getrandom");
            goto fail;
        }
        a->secret_len = 32;
        log_msg(LOG_INFO, "access", "no access_token_secret_file: tokens "
                "minted at login are signed with a random secret and end "
                "with this process");
    }
    if (cfg->access_policy[0]) {
        if (load_policy(a, err) < 0)
            goto fail;
        if (!a->secret_len)
            log_msg(LOG_WARN, "access", "neither access_token_secret_file nor "
                    "access_trusted_header is set: nobody can be granted "
                    "access to the protected images");
    }
    return a;
fail:
    access_free(a);
    return NULL;
}

void access_free(struct access *a)
{
    if (!a)
        return;
    access_policy_free(a->cur);
    pthread_mutex_destroy(&a->lock);
    memset(a->secret, 0, sizeof a->secret);
    free(a);
}

int access_reload(struct access *a, struct gv_error *err)
{
    if (!a || !a->cfg->access_policy[0])
        return 0;
    return load_policy(a, err);
}

const struct access_policy *access_hold(struct access *a)
{
    if (!a)
        return NULL;
    pthread_mutex_lock(&a->lock);
    struct access_policy *p = a->cur;
    if (p)
        p->refs++;
    pthread_mutex_unlock(&a->lock);
    return p;
}

void access_release(struct access *a, const struct access_policy *p)
{
    if (!a || !p)
        return;
    struct access_policy *q = (struct access_policy *)(uintptr_t)p;
    pthread_mutex_lock(&a->lock);
    int last = --q->refs == 0;
    pthread_mutex_unlock(&a->lock);
    if (last)
        access_policy_free(q);
}

int access_has_secret(const struct access *a)
{
    return a && a->secret_len > 0;
}

enum access_token_status access_verify(const struct access *a,
                                       const char *token,
                                       struct access_claims *c)
{
    memset(c, 0, sizeof *c);
    if (!access_has_secret(a))
        return ACCESS_TOKEN_MALFORMED;
    return access_token_verify(token, a->secret, a->secret_len,
                               (int64_t)time(NULL), c);
}

int access_mint(const struct access *a, struct access_claims *c, char *out,
                size_t size)
{
    if (!access_has_secret(a))
        return -1;
    c->iat = (int64_t)time(NULL);
    c->exp = c->iat + (int64_t)a->cfg->access_token_ttl;
    return access_token_sign(a->secret, a->secret_len, c, out, size);
}

int access_groups_from_header(const char *value, struct access_claims *c)
{
    c->ngroups = 0;
    const char *p = value;
    while (*p && c->ngroups < ACCESS_GROUPS_MAX) {
        p += strspn(p, ",; \t");
        size_t n = strcspn(p, ",; \t");
        if (n && access_group_valid(p, n) &&
            !(n == 6 && !memcmp(p, "public", 6))) {
            memcpy(c->group[c->ngroups], p, n);
            c->group[c->ngroups++][n] = '\0';
        }
        p += n;
    }
    return c->ngroups;
}

int access_origin_valid(const char *o)
{
    size_t n = strnlen(o, 256);
    const char *h;
    if (n > 255)
        return 0;
    if (!strncmp(o, "https://", 8))
        h = o + 8;
    else if (!strncmp(o, "http://", 7))
        h = o + 7;
    else
        return 0;
    size_t hl;
    if (*h == '[') {
        hl = strspn(h + 1, "0123456789abcdefABCDEF:.");
        if (h[1 + hl] != ']' || hl == 0)
            return 0;
        hl += 2;
    } else {
        hl = strspn(h, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                       "0123456789.-");
        if (hl == 0)
            return 0;
    }
    const char *rest = h + hl;
    if (*rest == ':') {
        size_t d = strspn(rest + 1, "0123456789");
        if (d < 1 || d > 5)
            return 0;
        rest += 1 + d;
    }
    return *rest == '\0';
}

int access_origin_allowed(const struct access *a, const char *origin)
{
    if (!access_origin_valid(origin))
        return 0;
    const char *list = a ? a->cfg->access_origins : "";
    if (!list[0])
        return 1;
    size_t n = strlen(origin);
    for (const char *p = list; *p;) {
        p += strspn(p, ", \t");
        size_t k = strcspn(p, ", \t");
        if (k == n && !memcmp(p, origin, n))
            return 1;
        p += k;
    }
    return 0;
}

const char *access_trusted_header(const struct access *a)
{
    return a && a->cfg->access_trusted_header[0] ? a->cfg->access_trusted_header
                                                 : NULL;
}
