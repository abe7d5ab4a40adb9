/*
 * store_meta.c - the metadata section of an image store (store_meta.h).
 *
 * The JSON is parsed with jansson after the size check, duplicates
 * refused, then walked once against the rules: one flat object, bounded
 * keys and values.  Nothing in it is interpreted here; readers hand the
 * text on (gigaview info prints it, gigaviewd embeds it).
 */
#include <jansson.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/byteorder.h"
#include "store/store_meta.h"

static int key_ok(const char *k)
{
    size_t n = strlen(k);
    if (n == 0 || n > GV_META_MAX_KEY)
        return 0;
    for (size_t i = 0; i < n; i++) {
        char c = k[i];
        if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
              c == '.' || c == '-'))
            return 0;
    }
    return 1;
}

static int number_ok(const json_t *v)
{
    return json_is_integer(v) || (json_is_real(v) && isfinite(json_real_value(v)));
}

/* The rules of store_meta.h on a parsed value; code for the failure. */
static int check_value(const char *key, const json_t *v, enum gv_code code,
                       struct gv_error *err)
{
    if (json_is_string(v)) {
        if (json_string_length(v) > GV_META_MAX_STRING)
            return gv_fail(err, code, "store: metadata: %s: string longer "
                           "than %d bytes", key, GV_META_MAX_STRING);
        if (strlen(json_string_value(v)) != json_string_length(v))
            return gv_fail(err, code, "store: metadata: %s: string holds a "
                           "NUL", key);
        return 0;
    }
    if (number_ok(v))
        return 0;
    if (json_is_array(v)) {
        if (json_array_size(v) > GV_META_MAX_ARRAY)
            return gv_fail(err, code, "store: metadata: %s: more than %d "
                           "values", key, GV_META_MAX_ARRAY);
        for (size_t i = 0; i < json_array_size(v); i++)
            if (!number_ok(json_array_get(v, i)))
                return gv_fail(err, code, "store: metadata: %s: arrays hold "
                               "finite numbers only", key);
        return 0;
    }
    return gv_fail(err, code, "store: metadata: %s: a value is a string, a "
                   "finite number or an array of them", key);
}

static int check(const char *json, size_t len, enum gv_code code,
                 struct gv_error *err)
{
    if (len > GV_META_MAX_JSON)
        return gv_fail(err, code == GV_EINVAL ? GV_ELIMIT : code,
                       "store: metadata of %zu bytes exceeds %d", len,
                       GV_META_MAX_JSON);
    json_error_t je;
    json_t *root = json_loadb(json, len, JSON_REJECT_DUPLICATES, &je);
    if (!root)
        return gv_fail(err, code, "store: metadata: line %d column %d: %s",
                       je.line, je.column, je.text);
    int rc = 0;
    if (!json_is_object(root)) {
        rc = gv_fail(err, code, "store: metadata is not a JSON object");
        goto out;
    }
    if (json_object_size(root) > GV_META_MAX_KEYS) {
        rc = gv_fail(err, code, "store: metadata: more than %d keys",
                     GV_META_MAX_KEYS);
        goto out;
    }
    const char *k;
    json_t *v;
    json_object_foreach(root, k, v) {
        if (!key_ok(k)) {
            rc = gv_fail(err, code, "store: metadata: a key is 1 to %d "
                         "characters of a-z 0-9 _ . -", GV_META_MAX_KEY);
            goto out;
        }
        if ((rc = check_value(k, v, code, err)) < 0)
            goto out;
    }
out:
    json_decref(root);
    return rc;
}

int gv_meta_check(const char *json, size_t len, struct gv_error *err)
{
    return check(json, len, GV_EINVAL, err);
}

int gv_meta_pack(const char *json, size_t len, uint8_t **out, size_t *outlen,
                 struct gv_error *err)
{
    if (gv_meta_check(json, len, err) < 0)
        return -1;
    uint8_t *b = malloc(GV_META_HEAD + len);
    if (!b)
        return gv_fail(err, GV_ENOMEM, "store: out of memory for metadata");
    memcpy(b, GV_META_MAGIC, 4);
    gv_put32(b + 4, GV_META_VERSION);
    gv_put32(b + 8, (uint32_t)len);
    memcpy(b + GV_META_HEAD, json, len);
    *out = b;
    *outlen = GV_META_HEAD + len;
    return 0;
}

int gv_meta_unpack(const uint8_t *in, size_t len, char **json,
                   struct gv_error *err)
{
    *json = NULL;
    if (len < GV_META_HEAD || memcmp(in, GV_META_MAGIC, 4) != 0)
        return gv_fail(err, GV_ECORRUPT, "store: metadata section: bad magic");
    uint32_t version = gv_get32(in + 4);
    if (version == 0)
        return gv_fail(err, GV_ECORRUPT, "store: metadata section: version 0");
    if (version > GV_META_VERSION)
        return 0;   /* newer: optional, ignored */
    uint32_t n = gv_get32(in + 8);
    if (n != len - GV_META_HEAD)
        return gv_fail(err, GV_ECORRUPT, "store: metadata section: length "
                       "%u does not match the section's %zu bytes", n,
                       len - GV_META_HEAD);
    const char *text = (const char *)(in + GV_META_HEAD);
    if (check(text, n, GV_ECORRUPT, err) < 0)
        return -1;
    char *copy = malloc((size_t)n + 1);
    if (!copy)
        return gv_fail(err, GV_ENOMEM, "store: out of memory for metadata");
    memcpy(copy, text, n);
    copy[n] = '\0';
    *json = copy;
    return 0;
}

char *gv_meta_set_string(const char *json, const char *key, const char *value,
                         struct gv_error *err)
{
    json_t *root = json && *json ? json_loads(json, JSON_REJECT_DUPLICATES, NULL)
                                 : json_object();
    if (!json_is_object(root)) {
        json_decref(root);
        gv_fail(err, GV_EINVAL, "store: metadata is not a JSON object");
        return NULL;
    }
    char *out = NULL;
    if (json_object_set_new(root, key, json_string(value)) == 0)
        out = json_dumps(root, JSON_COMPACT | JSON_SORT_KEYS);
    json_decref(root);
    if (!out)
        gv_fail(err, GV_ENOMEM, "store: out of memory for metadata");
    return out;
}

int gv_meta_get_string(const char *json, const char *key, char *buf,
                       size_t size, struct gv_error *err)
{
    if (!json)
        return 0;
    json_t *root = json_loads(json, JSON_REJECT_DUPLICATES, NULL);
    if (!root)
        return gv_fail(err, GV_ECORRUPT, "store: metadata is not JSON");
    json_t *v = json_object_get(root, key);
    int rc = 0;
    if (v && (!json_is_string(v) || json_string_length(v) >= size))
        rc = gv_fail(err, GV_ECORRUPT, "store: metadata %s is not a string "
                     "of under %zu bytes", key, size);
    else if (v) {
        memcpy(buf, json_string_value(v), json_string_length(v) + 1);
        rc = 1;
    }
    json_decref(root);
    return rc;
}
