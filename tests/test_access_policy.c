/*
 * test_access_policy.c - the access policy (server/access_policy.c): the
 * glob matcher, first-match-wins verdicts with and without a token of the
 * group, hiding (the file's default and a rule's own), the messages, and
 * the exact error of each kind of bad file.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "access_policy.h"
#include "util.h"

static void test_glob(void)
{
    static const struct { const char *p, *s; int want; } g[] = {
        {"*", "", 1}, {"*", "abc", 1}, {"abc", "abc", 1}, {"abc", "abcd", 0},
        {"a*", "a", 1}, {"a*", "ba", 0}, {"*c", "abc", 1}, {"*c", "abcd", 0},
        {"a*c", "ac", 1}, {"a*c", "abbbc", 1}, {"a*c", "abbbcd", 0},
        {"a*b*c", "a-b-b-c", 1}, {"a*b*c", "a-c-b", 0}, {"**", "x", 1},
        {"*a*a*a*a*a*a*b", "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa", 0},
        {"minutes-*-draft", "minutes-2026-01-draft", 1},
        {"minutes-*-draft", "minutes-2026-01-final", 0},
    };
    for (size_t i = 0; i < sizeof g / sizeof g[0]; i++)
        check(access_glob(g[i].p, g[i].s) == g[i].want, "glob '%s' on '%s': %d",
              g[i].p, g[i].s, g[i].want);
}

static struct access_policy *parse(const char *text, struct gv_error *err)
{
    return access_policy_parse(text, strlen(text), "p.json", err);
}

static void test_verdicts(void)
{
    struct gv_error err = {0};
    struct access_policy *p = parse(
        "{\"groups\": [\"staff\", \"board\"], \"hide\": true,\n"
        " \"images\": [\n"
        "  {\"id\": \"staff-open\", \"access\": \"public\"},\n"
        "  {\"id\": \"staff-*\", \"access\": \"staff\", \"hide\": false},\n"
        "  {\"id\": \"board-*\", \"access\": \"board\"}],\n"
        " \"messages\": {\"heading\": \"Members only\"}}", &err);
    if (!check(p != NULL, "a good policy parses")) {
        printf("# %s\n", err.text);
        return;
    }
    struct access_claims staff;
    memset(&staff, 0, sizeof staff);
    staff.ngroups = 1;
    strcpy(staff.group[0], "staff");
    const char *g;
    check(access_judge(p, NULL, "staff-open", &g) == ACCESS_PUBLIC && !g,
          "first match wins: staff-open is public");
    check(access_judge(p, NULL, "staff-x", &g) == ACCESS_DENIED && !strcmp(g, "staff"),
          "staff-x without a token: denied (the rule's hide: false)");
    check(access_judge(p, &staff, "staff-x", NULL) == ACCESS_GRANTED,
          "staff-x with staff: granted");
    check(access_judge(p, NULL, "board-y", NULL) == ACCESS_HIDDEN,
          "board-y without a token: hidden (the file's hide: true)");
    check(access_judge(p, &staff, "board-y", NULL) == ACCESS_HIDDEN,
          "board-y with staff: hidden");
    check(access_judge(p, NULL, "other", &g) == ACCESS_PUBLIC && !g,
          "an id no rule matches: public");
    check(access_judge(NULL, NULL, "staff-x", NULL) == ACCESS_PUBLIC,
          "no policy: public");
    check(!strcmp(p->message[ACCESS_MSG_HEADING], "Members only") &&
          !strcmp(p->message[ACCESS_MSG_CONFIRM], "Log in"),
          "messages: given ones and defaults");
    access_policy_free(p);
    p = parse("{}", &err);
    check(p && p->nrules == 0 && p->ngroups == 0, "an empty object: no rules");
    access_policy_free(p);
    access_policy_free(NULL);
}

static void test_errors(void)
{
    static const struct { const char *text, *want; } bad[] = {
        {"", "p.json:1:0: '[' or '{' expected near end of file"},
        {"{\"groups\": [\"a\"],\n \"images\": [}", "p.json:2:13: unexpected token near '}'"},
        {"[]", "p.json: not a JSON object"},
        {"{\"hidden\": true}", "p.json: unknown member \"hidden\""},
        {"{\"hide\": 1}", "p.json: hide: not true or false"},
        {"{\"groups\": \"a\"}", "p.json: groups: not an array"},
        {"{\"groups\": [\"a b\"]}", "p.json: groups[0]: not a group name (1..64 of A-Z a-z 0-9 . _ -)"},
        {"{\"groups\": [\"public\"]}", "p.json: groups[0]: \"public\" is not a group: it means no group"},
        {"{\"groups\": [\"a\", \"a\"]}", "p.json: groups[1]: \"a\" twice"},
        {"{\"images\": {}}", "p.json: images: not an array"},
        {"{\"images\": [1]}", "p.json: images[0]: not an object"},
        {"{\"images\": [{\"id\": \"x\", \"access\": \"public\", \"acess\": 1}]}",
         "p.json: images[0]: unknown member \"acess\""},
        {"{\"images\": [{\"id\": \"../x\", \"access\": \"public\"}]}",
         "p.json: images[0]: id: not an image id or pattern (1..128 of A-Z a-z 0-9 . _ - *)"},
        {"{\"images\": [{\"access\": \"public\"}]}",
         "p.json: images[0]: id: not an image id or pattern (1..128 of A-Z a-z 0-9 . _ - *)"},
        {"{\"images\": [{\"id\": \"x\", \"access\": 3}]}", "p.json: images[0]: access: not a string"},
        {"{\"groups\": [\"staff\"], \"images\": [{\"id\": \"x\", \"access\": \"staf\"}]}",
         "p.json: images[0]: access: neither \"public\" nor a group listed in \"groups\""},
        {"{\"images\": [{\"id\": \"x\", \"access\": \"public\", \"hide\": \"yes\"}]}",
         "p.json: images[0]: hide: not true or false"},
        {"{\"messages\": {\"title\": \"x\"}}", "p.json: messages: unknown member \"title\""},
        {"{\"messages\": {\"note\": 5}}", "p.json: messages: note: not a string of at most 1024 bytes"},
        {"{\"hide\": true, \"hide\": false}", "p.json:1:21: duplicate object key near '\"hide\"'"},
        {"{\"revoked\": []}", "p.json: revoked: not an object"},
        {"{\"revoked\": {\"subject\": [\"a\"]}}", "p.json: revoked: unknown member \"subject\""},
        {"{\"revoked\": {\"subjects\": [\"a\", 3]}}",
         "p.json: revoked: subjects[1]: not a subject (1 to 128 bytes)"},
        {"{\"revoked\": {\"issued_before\": 1.5}}",
         "p.json: revoked: issued_before: not a time in UNIX seconds"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        struct gv_error err;
        gv_error_clear(&err);
        struct access_policy *p = parse(bad[i].text, &err);
        check(!p, "bad policy %zu refused", i);
        check_str(err.text, bad[i].want, "bad policy %zu: %s", i, bad[i].want);
        access_policy_free(p);
    }
    struct gv_error err = {0};
    /* The limits: a file one byte over, one rule too many. */
    size_t big = ACCESS_POLICY_MAX_BYTES + 1;
    char *text = malloc(big);
    if (!text)
        fail("out of memory");
    memset(text, ' ', big);
    text[0] = '{';
    text[big - 1] = '}';
    check(!access_policy_parse(text, big, "p.json", &err) && err.code == GV_ELIMIT,
          "a file over %u bytes: GV_ELIMIT", ACCESS_POLICY_MAX_BYTES);
    size_t n = (size_t)snprintf(text, big, "{\"images\":[");
    for (int i = 0; i <= ACCESS_POLICY_MAX_RULES; i++)
        n += (size_t)snprintf(text + n, big - n, "%s{\"id\":\"a\",\"access\":\"public\"}",
                              i ? "," : "");
    n += (size_t)snprintf(text + n, big - n, "]}");
    check(!access_policy_parse(text, n, "p.json", &err) && err.code == GV_ELIMIT,
          "%d rules: GV_ELIMIT", ACCESS_POLICY_MAX_RULES + 1);
    free(text);
    gv_error_clear(&err);
    check(!access_policy_load("/nonexistent/policy.json", &err) &&
          err.code == GV_ENOTFOUND, "a missing file: GV_ENOTFOUND");
}

/* Revocation: by subject (sorted, found by bsearch) and by issue time. */
static void test_revoked(void)
{
    struct gv_error err = {0};
    struct access_policy *p = parse("{\"revoked\": {\"subjects\": [\"zed\", \"ann\", \"bob\"], "
                                    "\"issued_before\": 1000}}", &err);
    if (!p)
        fail("%s", err.text);
    struct access_claims c = {.iat = 2000, .exp = 3000};
    static const struct { const char *sub; long long iat; int want; } cases[] = {
        {"ann", 2000, 1}, {"bob", 2000, 1}, {"zed", 2000, 1}, {"amy", 2000, 0},
        {"", 2000, 0}, {"amy", 999, 1}, {"amy", 1000, 0}, {"amy", 0, 1},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        snprintf(c.sub, sizeof c.sub, "%s", cases[i].sub);
        c.iat = cases[i].iat;
        check(access_policy_revoked(p, &c) == cases[i].want, "sub '%s' iat %lld: %s",
              cases[i].sub, cases[i].iat, cases[i].want ? "revoked" : "good");
    }
    check(!access_policy_revoked(NULL, &c), "no policy revokes nothing");
    access_policy_free(p);
    p = parse("{}", &err);
    c.iat = 0;
    check(p && !access_policy_revoked(p, &c), "a policy without revoked: a token "
          "without iat is good");
    access_policy_free(p);
}

int main(void)
{
    test_glob();
    test_verdicts();
    test_errors();
    test_revoked();
    return tap_done();
}
