/*
 * access_policy.h - which images are public and which belong to an
 * access group: the file named by the access_policy key (docs/OPERATIONS.md
 * "Access control").
 *
 *     {
 *       "groups": ["staff", "researchers"],
 *       "hide": false,
 *       "images": [
 *         {"id": "minutes-*", "access": "staff", "hide": true},
 *         {"id": "letters-1923", "access": "researchers"},
 *         {"id": "*", "access": "public"}
 *       ],
 *       "messages": {"label": "...", "heading": "...", "note": "...",
 *                    "confirm_label": "...", "denied_heading": "...",
 *                    "denied_note": "..."},
 *       "revoked": {"subjects": ["ann"], "issued_before": 1764720000}
 *     }
 *
 * "groups" names every access group (a rule naming another is an error,
 * so that a typo cannot lock an image away or open it); each rule's "id"
 * is an image id or a glob whose '*' matches any run of characters; the
 * first rule that matches decides, and an id no rule matches is public.
 * "hide" (the file's, or a rule's own) makes a protected image answer
 * like an absent one (404) to those without access instead of 401.
 * "messages" (optional) are the texts of the IIIF access service and of
 * a refused probe.  "revoked" (optional) refuses good tokens: those of
 * the listed subjects ("sub"), and with "issued_before" (UNIX seconds)
 * those issued before it, a token that does not say when it was issued
 * ("iat") counting as issued before any time: the way to end one
 * reader's access, or everyone's, without a new secret or a restart
 * (the policy is reread on SIGHUP).  Unknown members are errors, so is anything past the
 * limits below.  Parsing is pure (tests/fuzz/fuzz_access_policy.c); a
 * policy is immutable once parsed and may be read by any thread.
 */
#ifndef GV_SERVER_ACCESS_POLICY_H
#define GV_SERVER_ACCESS_POLICY_H

#include <stddef.h>

#include "access_token.h"
#include "base/error.h"
#include "base/ids.h"

#define ACCESS_POLICY_MAX_BYTES (1u << 20) /* 1 MiB: tens of thousands of rules */
#define ACCESS_POLICY_MAX_RULES 20000
#define ACCESS_POLICY_MAX_GROUPS 64
#define ACCESS_PATTERN_MAX GV_IMAGE_ID_MAX /* an image id's longest */
#define ACCESS_MESSAGE_MAX 1024  /* bytes of one message */
#define ACCESS_POLICY_MAX_REVOKED 10000  /* subjects revoked */

struct access_rule {
    char pattern[ACCESS_PATTERN_MAX + 1];
    int group;              /* index in groups[]; -1: public */
    int hide;
};

enum access_message {
    ACCESS_MSG_LABEL,           /* the access service's label */
    ACCESS_MSG_HEADING,         /* its heading */
    ACCESS_MSG_NOTE,            /* its note */
    ACCESS_MSG_CONFIRM,         /* its confirmLabel */
    ACCESS_MSG_DENIED_HEADING,  /* a refused probe's heading */
    ACCESS_MSG_DENIED_NOTE,     /* and note */
    ACCESS_MSG_COUNT
};

struct access_policy {
    int ngroups;
    char group[ACCESS_POLICY_MAX_GROUPS][ACCESS_GROUP_MAX + 1];
    int nrules;
    struct access_rule *rule;
    char *message[ACCESS_MSG_COUNT]; /* never NULL: defaults filled in */
    int nrevoked;
    char (*revoked)[ACCESS_SUB_MAX + 1]; /* subjects, sorted (strcmp) */
    long long issued_before; /* 0: none */
    int refs;               /* access.c's snapshot count, 0 after parsing */
};

/*
 * Parse n bytes of policy JSON; `name` (the file's path) prefixes every
 * message: "NAME:LINE:COLUMN: ..." for a JSON syntax error, "NAME:
 * images[3].access: ..." for a value.  Returns a new policy (free with
 * access_policy_free), or NULL with *err (GV_EINVAL, GV_ELIMIT beyond the
 * limits, GV_ENOMEM).
 */
struct access_policy *access_policy_parse(const char *text, size_t n,
                                          const char *name,
                                          struct gv_error *err);

/* Read and parse the file at path (at most ACCESS_POLICY_MAX_BYTES).
 * NULL with *err (also GV_ENOTFOUND, GV_EIO) on failure. */
struct access_policy *access_policy_load(const char *path, struct gv_error *err);

/* NULL does nothing. */
void access_policy_free(struct access_policy *p);

/* 1 if glob `pattern` ('*' any run, possibly empty; every other byte
 * itself) matches the whole of s, else 0.  Linear in the product of the
 * lengths at worst. */
int access_glob(const char *pattern, const char *s);

/* 1 if policy p (NULL: none) revokes a token with claims c, else 0. */
int access_policy_revoked(const struct access_policy *p, const struct access_claims *c);

enum access_verdict {
    ACCESS_PUBLIC,   /* no group needed: answer as always */
    ACCESS_GRANTED,  /* protected, and the caller holds its group */
    ACCESS_DENIED,   /* protected, not hidden: 401 */
    ACCESS_HIDDEN,   /* protected and hidden: 404 as if absent */
};

/* The verdict of policy p (NULL: everything public) for image `id` and a
 * caller with claims c (NULL: no valid token).  *group (may be NULL) is
 * set to the group the image needs, or NULL when public. */
enum access_verdict access_judge(const struct access_policy *p,
                                 const struct access_claims *c,
                                 const char *id, const char **group);

#endif
