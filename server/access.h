/*
 * access.h - gigaviewd's access control at run time: the policy in force
 * (access_policy.h, reread on SIGHUP), the token secret, the trusted
 * proxy header and the origins the IIIF token service serves
 * (docs/OPERATIONS.md "Access control").
 *
 * The policy is swapped whole on a reload: a request holds the snapshot
 * it started with (access_hold / access_release), so a reload never
 * changes the rules under a request.  The secret is read once at start:
 * access_token_secret_file's bytes less trailing newlines, at least
 * ACCESS_SECRET_MIN of them; with a trusted header and no secret file a
 * random secret is drawn (tokens then end with the process).  Every
 * function is thread-safe.
 */
#ifndef GV_SERVER_ACCESS_H
#define GV_SERVER_ACCESS_H

#include <stddef.h>
#include <stdint.h>

#include "access_policy.h"
#include "access_token.h"
#include "settings.h"

struct access;

/* Access control as cfg says (borrowed: it must outlive the result).
 * NULL with *err when the policy file or the secret is unusable: the
 * daemon must not start. */
struct access *access_new(const struct settings *cfg, struct gv_error *err);

/* NULL does nothing.  Every snapshot must have been released. */
void access_free(struct access *a);

/* Reread the policy file.  0, or -1 with *err: the policy in force stays. */
int access_reload(struct access *a, struct gv_error *err);

/* The policy in force (NULL: none, every image public), held until
 * access_release.  a may be NULL (no access control). */
const struct access_policy *access_hold(struct access *a);
void access_release(struct access *a, const struct access_policy *p);

/* 1 if tokens can be verified and minted (a secret is known). */
int access_has_secret(const struct access *a);

/* Verify a token under the secret at the current time (see
 * access_token_verify); ACCESS_TOKEN_MALFORMED without a secret. */
enum access_token_status access_verify(const struct access *a,
                                       const char *token,
                                       struct access_claims *c);

/* Mint a token for *c (c->exp is set here: now plus access_token_ttl)
 * into out (size bytes).  0, or -1 (no secret, invalid claims). */
int access_mint(const struct access *a, struct access_claims *c, char *out,
                size_t size);

/* Fill c->group from a trusted header's value: group names separated by
 * commas, semicolons or blanks; names that are not group names are
 * skipped, and at most ACCESS_GROUPS_MAX are kept.  Returns the count. */
int access_groups_from_header(const char *value, struct access_claims *c);

/* 1 if `origin` is a well-formed origin (http or https, a host of
 * [A-Za-z0-9.-] or a bracketed IPv6 literal, an optional port, nothing
 * after, at most 255 bytes), else 0. */
int access_origin_valid(const char *origin);

/* 1 if the token service may give a token to `origin`: well-formed, and
 * listed in access_origins when that is set. */
int access_origin_allowed(const struct access *a, const char *origin);

/* The trusted header's name, or NULL when off. */
const char *access_trusted_header(const struct access *a);

#endif
