/*
 * fuzz_access_policy.c - libFuzzer target for the access policy parser
 * (server/access_policy.c, access_policy_parse).
 *
 * The input is a whole policy file.  Checked:
 *  - failure: NULL, a message that starts with the file's name, and code
 *    GV_EINVAL, GV_ELIMIT or GV_ENOMEM;
 *  - success: the counts within their limits, every rule's pattern a
 *    valid pattern and its group an index of groups[], every message
 *    set, the revoked subjects sorted and each one revoked; parsing the same bytes again gives the same rules; and the
 *    verdicts agree with the rules: for every rule's pattern taken as an
 *    id, a caller holding every group is never refused, and a caller
 *    with no token is refused exactly when the first rule that matches
 *    names a group (hidden exactly when that rule hides).
 * Anything else aborts.
 */
#include <stdlib.h>
#include <string.h>

#include "access_policy.h"
#include "fuzz.h"

#define MAX_INPUT (ACCESS_POLICY_MAX_BYTES + 16) /* just past the limit */
#define NAME "fuzz.json"

static void check_policy(const struct access_policy *p)
{
    if (p->ngroups < 0 || p->ngroups > ACCESS_POLICY_MAX_GROUPS ||
        p->nrules < 0 || p->nrules > ACCESS_POLICY_MAX_RULES)
        abort();
    for (int i = 0; i < p->ngroups; i++)
        if (!access_group_valid(p->group[i], strlen(p->group[i])))
            abort();
    for (int i = 0; i < ACCESS_MSG_COUNT; i++)
        if (!p->message[i] || strlen(p->message[i]) > ACCESS_MESSAGE_MAX)
            abort();
    /* Revoked subjects: within limits, sorted, each one found. */
    if (p->nrevoked < 0 || p->nrevoked > ACCESS_POLICY_MAX_REVOKED ||
        p->issued_before < 0 || p->issued_before > ACCESS_EXP_MAX)
        abort();
    for (int i = 0; i < p->nrevoked; i++) {
        struct access_claims c;
        memset(&c, 0, sizeof c);
        size_t n = strlen(p->revoked[i]);
        if (n < 1 || n > ACCESS_SUB_MAX ||
            (i && strcmp(p->revoked[i - 1], p->revoked[i]) > 0))
            abort();
        memcpy(c.sub, p->revoked[i], n + 1);
        c.iat = ACCESS_EXP_MAX;
        if (!access_policy_revoked(p, &c))
            abort();
    }
    struct access_claims all;
    memset(&all, 0, sizeof all);
    for (int i = 0; i < p->ngroups && i < ACCESS_GROUPS_MAX; i++) {
        memcpy(all.group[i], p->group[i], sizeof all.group[i]);
        all.ngroups++;
    }
    for (int i = 0; i < p->nrules; i++) {
        const struct access_rule *r = &p->rule[i];
        size_t n = strlen(r->pattern);
        if (n < 1 || n > ACCESS_PATTERN_MAX || r->group < -1 ||
            r->group >= p->ngroups || (r->hide != 0 && r->hide != 1))
            abort();
        /* The pattern as an id ('*' taken as itself matches itself). */
        const struct access_rule *first = NULL;
        for (int k = 0; k <= i && !first; k++)
            if (access_glob(p->rule[k].pattern, r->pattern))
                first = &p->rule[k];
        if (!first)
            abort(); /* a pattern always matches itself */
        enum access_verdict v = access_judge(p, NULL, r->pattern, NULL);
        enum access_verdict want = first->group < 0 ? ACCESS_PUBLIC
                                   : first->hide ? ACCESS_HIDDEN : ACCESS_DENIED;
        if (v != want)
            abort();
        v = access_judge(p, &all, r->pattern, NULL);
        if (first->group >= 0 && first->group < ACCESS_GROUPS_MAX &&
            v != ACCESS_GRANTED)
            abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > MAX_INPUT)
        return 0;
    struct gv_error err;
    gv_error_clear(&err);
    struct access_policy *p = access_policy_parse((const char *)data, size,
                                                  NAME, &err);
    if (!p) {
        if (strncmp(err.text, NAME, strlen(NAME)) ||
            (err.code != GV_EINVAL && err.code != GV_ELIMIT && err.code != GV_ENOMEM))
            abort();
        return 0;
    }
    check_policy(p);
    struct access_policy *q = access_policy_parse((const char *)data, size,
                                                  NAME, &err);
    if (!q || q->nrules != p->nrules || q->ngroups != p->ngroups ||
        (p->nrules && memcmp(q->rule, p->rule, (size_t)p->nrules * sizeof *p->rule)))
        abort();
    access_policy_free(q);
    access_policy_free(p);
    return 0;
}
