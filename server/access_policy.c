/*
 * access_policy.c - the access policy file (see access_policy.h).
 *
 * jansson reads the file (duplicates refused, so that a second "hide"
 * cannot silently win); every member is then checked against its type
 * and limits, and unknown members are refused.  jansson keeps no
 * positions of values, so a bad value is named by its JSON path.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "access_policy.h"

static const struct {
    const char *key;
    const char *def;
} messages[ACCESS_MSG_COUNT] = {
    [ACCESS_MSG_LABEL] = {"label", "Log in to see this image"},
    [ACCESS_MSG_HEADING] = {"heading", "This image is restricted"},
    [ACCESS_MSG_NOTE] = {"note", "Log in with your institution's account "
                                 "to see it."},
    [ACCESS_MSG_CONFIRM] = {"confirm_label", "Log in"},
    [ACCESS_MSG_DENIED_HEADING] = {"denied_heading", "Access denied"},
    [ACCESS_MSG_DENIED_NOTE] = {"denied_note", "Your account does not give "
                                               "access to this image."},
};

void access_policy_free(struct access_policy *p)
{
    if (!p)
        return;
    free(p->rule);
    free(p->revoked);
    for (int i = 0; i < ACCESS_MSG_COUNT; i++)
        free(p->message[i]);
    free(p);
}

int access_glob(const char *pattern, const char *s)
{
    /* The classic greedy matcher: on a mismatch, the last '*' takes one
     * more character; no recursion, O(len(pattern) * len(s)). */
    const char *star = NULL, *resume = NULL;
    while (*s) {
        if (*pattern == '*') {
            star = pattern++;
            resume = s;
        } else if (*pattern && *pattern == *s) {
            pattern++;
            s++;
        } else if (star) {
            pattern = star + 1;
            s = ++resume;
        } else {
            return 0;
        }
    }
    while (*pattern == '*')
        pattern++;
    return *pattern == '\0';
}

/* 1 if s[0..n-1] is a pattern: 1..ACCESS_PATTERN_MAX bytes of an image
 * id's characters ([A-Za-z0-9._-], catalog.h) or '*'. */
static int pattern_valid(const char *s, size_t n)
{
    if (n < 1 || n > ACCESS_PATTERN_MAX)
        return 0;
    for (size_t i = 0; i < n; i++)
        if (s[i] != '*' && !access_group_valid(s + i, 1))
            return 0;
    return 1;
}

static int group_index(const struct access_policy *p, const char *g)
{
    for (int i = 0; i < p->ngroups; i++)
        if (!strcmp(p->group[i], g))
            return i;
    return -1;
}

/* Refuse members of object o not in the NULL-terminated list `known`. */
static int only_known(json_t *o, const char *const *known, const char *name,
                      const char *where, struct gv_error *err)
{
    const char *key;
    json_t *v;
    json_object_foreach(o, key, v) {
        int found = 0;
        for (const char *const *k = known; *k && !found; k++)
            found = !strcmp(*k, key);
        if (!found) {
            char esc[80];
            size_t i = 0;
            for (const char *c = key; *c && i + 5 < sizeof esc; c++)
                esc[i++] = (*c >= 0x20 && *c < 0x7f) ? *c : '?';
            esc[i] = '\0';
            return gv_fail(err, GV_EINVAL, "%s: %sunknown member \"%s\"", name,
                           where, esc);
        }
    }
    return 0;
}

static int parse_groups(struct access_policy *p, json_t *g, const char *name,
                        struct gv_error *err)
{
    if (!g)
        return 0;
    if (!json_is_array(g))
        return gv_fail(err, GV_EINVAL, "%s: groups: not an array", name);
    if (json_array_size(g) > ACCESS_POLICY_MAX_GROUPS)
        return gv_fail(err, GV_ELIMIT, "%s: groups: more than %d", name,
                       ACCESS_POLICY_MAX_GROUPS);
    for (size_t i = 0; i < json_array_size(g); i++) {
        json_t *s = json_array_get(g, i);
        if (!json_is_string(s) ||
            !access_group_valid(json_string_value(s), json_string_length(s)))
            return gv_fail(err, GV_EINVAL, "%s: groups[%zu]: not a group name "
                           "(1..%d of A-Z a-z 0-9 . _ -)", name, i,
                           ACCESS_GROUP_MAX);
        if (!strcmp(json_string_value(s), "public"))
            return gv_fail(err, GV_EINVAL, "%s: groups[%zu]: \"public\" is "
                           "not a group: it means no group", name, i);
        if (group_index(p, json_string_value(s)) >= 0)
            return gv_fail(err, GV_EINVAL, "%s: groups[%zu]: \"%s\" twice",
                           name, i, json_string_value(s));
        memcpy(p->group[p->ngroups++], json_string_value(s),
               json_string_length(s) + 1);
    }
    return 0;
}

static int parse_rules(struct access_policy *p, json_t *a, int hide,
                       const char *name, struct gv_error *err)
{
    static const char *const known[] = {"id", "access", "hide", NULL};
    if (!a)
        return 0;
    if (!json_is_array(a))
        return gv_fail(err, GV_EINVAL, "%s: images: not an array", name);
    size_t n = json_array_size(a);
    if (n > ACCESS_POLICY_MAX_RULES)
        return gv_fail(err, GV_ELIMIT, "%s: images: more than %d rules", name,
                       ACCESS_POLICY_MAX_RULES);
    p->rule = calloc(n ? n : 1, sizeof *p->rule);
    if (!p->rule)
        return gv_fail(err, GV_ENOMEM, "%s: out of memory", name);
    for (size_t i = 0; i < n; i++) {
        json_t *r = json_array_get(a, i);
        char where[48];
        snprintf(where, sizeof where, "images[%zu]: ", i);
        if (!json_is_object(r))
            return gv_fail(err, GV_EINVAL, "%s: %snot an object", name, where);
        if (only_known(r, known, name, where, err) < 0)
            return -1;
        json_t *id = json_object_get(r, "id"), *acc = json_object_get(r, "access"),
               *h = json_object_get(r, "hide");
        if (!json_is_string(id) ||
            !pattern_valid(json_string_value(id), json_string_length(id)))
            return gv_fail(err, GV_EINVAL, "%s: %sid: not an image id or "
                           "pattern (1..%d of A-Z a-z 0-9 . _ - *)", name,
                           where, ACCESS_PATTERN_MAX);
        if (!json_is_string(acc))
            return gv_fail(err, GV_EINVAL, "%s: %saccess: not a string", name,
                           where);
        struct access_rule *rule = &p->rule[p->nrules];
        memcpy(rule->pattern, json_string_value(id), json_string_length(id) + 1);
        rule->group = -1;
        if (strcmp(json_string_value(acc), "public") &&
            (rule->group = group_index(p, json_string_value(acc))) < 0)
            return gv_fail(err, GV_EINVAL, "%s: %saccess: neither \"public\" "
                           "nor a group listed in \"groups\"", name, where);
        if (h && !json_is_boolean(h))
            return gv_fail(err, GV_EINVAL, "%s: %shide: not true or false",
                           name, where);
        rule->hide = h ? json_is_true(h) : hide;
        p->nrules++;
    }
    return 0;
}

static int parse_messages(struct access_policy *p, json_t *m, const char *name,
                          struct gv_error *err)
{
    const char *known[ACCESS_MSG_COUNT + 1];
    for (int i = 0; i < ACCESS_MSG_COUNT; i++)
        known[i] = messages[i].key;
    known[ACCESS_MSG_COUNT] = NULL;
    if (m && !json_is_object(m))
        return gv_fail(err, GV_EINVAL, "%s: messages: not an object", name);
    if (m && only_known(m, known, name, "messages: ", err) < 0)
        return -1;
    for (int i = 0; i < ACCESS_MSG_COUNT; i++) {
        json_t *s = m ? json_object_get(m, messages[i].key) : NULL;
        if (s && (!json_is_string(s) || json_string_length(s) > ACCESS_MESSAGE_MAX ||
                  strlen(json_string_value(s)) != json_string_length(s)))
            return gv_fail(err, GV_EINVAL, "%s: messages: %s: not a string of "
                           "at most %d bytes", name, messages[i].key,
                           ACCESS_MESSAGE_MAX);
        p->message[i] = strdup(s ? json_string_value(s) : messages[i].def);
        if (!p->message[i])
            return gv_fail(err, GV_ENOMEM, "%s: out of memory", name);
    }
    return 0;
}

static int subject_cmp(const void *a, const void *b)
{
    return strcmp(a, b);
}

static int parse_revoked(struct access_policy *p, json_t *r, const char *name,
                         struct gv_error *err)
{
    static const char *const known[] = {"subjects", "issued_before", NULL};
    if (!r)
        return 0;
    if (!json_is_object(r))
        return gv_fail(err, GV_EINVAL, "%s: revoked: not an object", name);
    if (only_known(r, known, name, "revoked: ", err) < 0)
        return -1;
    json_t *before = json_object_get(r, "issued_before"),
           *subs = json_object_get(r, "subjects");
    if (before && (!json_is_integer(before) || json_integer_value(before) < 0 ||
                   json_integer_value(before) > ACCESS_EXP_MAX))
        return gv_fail(err, GV_EINVAL, "%s: revoked: issued_before: not a time "
                       "in UNIX seconds", name);
    p->issued_before = before ? (long long)json_integer_value(before) : 0;
    if (!subs)
        return 0;
    if (!json_is_array(subs))
        return gv_fail(err, GV_EINVAL, "%s: revoked: subjects: not an array", name);
    if (json_array_size(subs) > ACCESS_POLICY_MAX_REVOKED)
        return gv_fail(err, GV_ELIMIT, "%s: revoked: more than %d subjects", name,
                       ACCESS_POLICY_MAX_REVOKED);
    size_t k;
    json_t *s;
    if (json_array_size(subs) &&
        !(p->revoked = calloc(json_array_size(subs), sizeof *p->revoked)))
        return gv_fail(err, GV_ENOMEM, "%s: out of memory", name);
    json_array_foreach(subs, k, s) {
        const char *v = json_is_string(s) ? json_string_value(s) : NULL;
        if (!v || !*v || json_string_length(s) > ACCESS_SUB_MAX ||
            strlen(v) != json_string_length(s))
            return gv_fail(err, GV_EINVAL, "%s: revoked: subjects[%zu]: not a "
                           "subject (1 to %d bytes)", name, k, ACCESS_SUB_MAX);
        memcpy(p->revoked[p->nrevoked++], v, json_string_length(s) + 1);
    }
    qsort(p->revoked, (size_t)p->nrevoked, sizeof *p->revoked, subject_cmp);
    return 0;
}

int access_policy_revoked(const struct access_policy *p, const struct access_claims *c)
{
    if (!p || !c)
        return 0;
    if (p->issued_before && c->iat < p->issued_before)
        return 1;
    return c->sub[0] && p->nrevoked &&
           bsearch(c->sub, p->revoked, (size_t)p->nrevoked, sizeof *p->revoked,
                   subject_cmp) != NULL;
}

struct access_policy *access_policy_parse(const char *text, size_t n,
                                          const char *name,
                                          struct gv_error *err)
{
    static const char *const known[] = {"groups", "hide", "images", "messages",
                                        "revoked", NULL};
    if (n > ACCESS_POLICY_MAX_BYTES) {
        gv_fail(err, GV_ELIMIT, "%s: larger than %u bytes", name,
                ACCESS_POLICY_MAX_BYTES);
        return NULL;
    }
    json_error_t jerr;
    json_t *j = json_loadb(text, n, JSON_REJECT_DUPLICATES, &jerr);
    if (!j) {
        gv_fail(err, GV_EINVAL, "%s:%d:%d: %s", name, jerr.line, jerr.column,
                jerr.text);
        return NULL;
    }
    struct access_policy *p = calloc(1, sizeof *p);
    int rc = -1;
    if (!p) {
        gv_fail(err, GV_ENOMEM, "%s: out of memory", name);
        goto out;
    }
    if (!json_is_object(j)) {
        gv_fail(err, GV_EINVAL, "%s: not a JSON object", name);
        goto out;
    }
    if (only_known(j, known, name, "", err) < 0)
        goto out;
    json_t *hide = json_object_get(j, "hide");
    if (hide && !json_is_boolean(hide)) {
        gv_fail(err, GV_EINVAL, "%s: hide: not true or false", name);
        goto out;
    }
    if (parse_groups(p, json_object_get(j, "groups"), name, err) < 0 ||
        parse_rules(p, json_object_get(j, "images"), hide && json_is_true(hide),
                    name, err) < 0 ||
        parse_messages(p, json_object_get(j, "messages"), name, err) < 0 ||
        parse_revoked(p, json_object_get(j, "revoked"), name, err) < 0)
        goto out;
    rc = 0;
out:
    json_decref(j);
    if (rc < 0) {
        access_policy_free(p);
        return NULL;
    }
    return p;
}

struct access_policy *access_policy_load(const char *path, struct gv_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        int e = errno;
        if (e == ENOENT)
            gv_fail(err, GV_ENOTFOUND, "%s: no such file", path);
        else
            gv_fail_errno(err, e, "%s", path);
        return NULL;
    }
    char *buf = malloc(ACCESS_POLICY_MAX_BYTES + 1);
    size_t n = buf ? fread(buf, 1, ACCESS_POLICY_MAX_BYTES + 1, f) : 0;
    int bad = ferror(f);
    fclose(f);
    struct access_policy *p = NULL;
    if (!buf)
        gv_fail(err, GV_ENOMEM, "%s: out of memory", path);
    else if (bad)
        gv_fail(err, GV_EIO, "%s: read error", path);
    else
        p = access_policy_parse(buf, n, path, err);
    free(buf);
    return p;
}

enum access_verdict access_judge(const struct access_policy *p,
                                 const struct access_claims *c,
                                 const char *id, const char **group)
{
    if (group)
        *group = NULL;
    if (!p)
        return ACCESS_PUBLIC;
    for (int i = 0; i < p->nrules; i++) {
        const struct access_rule *r = &p->rule[i];
        if (!access_glob(r->pattern, id))
            continue;
        if (r->group < 0)
            return ACCESS_PUBLIC;
        if (group)
            *group = p->group[r->group];
        if (c && access_claims_has_group(c, p->group[r->group]))
            return ACCESS_GRANTED;
        return r->hide ? ACCESS_HIDDEN : ACCESS_DENIED;
    }
    return ACCESS_PUBLIC;
}
