/*
 * mesh_read_glb.c - glTF 2.0 binary (GLB; glTF 2.0 specification,
 * "Binary glTF Layout"): the 12-byte header, a JSON chunk and a BIN chunk.
 * Every primitive of every mesh whose mode is TRIANGLES (4, the default)
 * is appended: its POSITION accessor (float VEC3, tightly packed or with a
 * byteStride) and its indices (unsigned byte, short or int SCALAR), or,
 * without indices, each three vertices a triangle.  Node transforms are
 * not applied (every primitive in its mesh's own frame).  Buffers other
 * than the BIN chunk (a uri), sparse accessors and other modes are
 * refused or skipped as the messages say.  Every offset and length is
 * checked against the chunk before it is read.
 */
#include <jansson.h>
#include <math.h>
#include <string.h>

#include "mesh/io/mesh_read_int.h"

#define MAX_JSON (64u << 20)

static uint32_t rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
           (uint32_t)p[3] << 24;
}

static int get_uint(json_t *o, const char *k, uint64_t dflt, uint64_t *v)
{
    json_t *x = json_object_get(o, k);
    if (!x) {
        *v = dflt;
        return 0;
    }
    if (!json_is_integer(x) || json_integer_value(x) < 0)
        return -1;
    *v = (uint64_t)json_integer_value(x);
    return 0;
}

struct view {             /* an accessor resolved into the BIN chunk */
    const uint8_t *p;     /* first element */
    uint64_t count, stride, elem;
    int ctype;
};

/* Resolve accessor `ai` expecting type `type` ("VEC3", "SCALAR"). */
static int accessor(json_t *root, uint64_t ai, const char *type,
                    const uint8_t *bin, uint64_t bin_len, struct view *v,
                    struct gv_error *err)
{
    json_t *acc = json_array_get(json_object_get(root, "accessors"), ai);
    if (!json_is_object(acc))
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: no accessor %llu",
                       (unsigned long long)ai);
    if (json_object_get(acc, "sparse"))
        return gv_fail(err, GV_EFORMAT, "mesh: glb: sparse accessors are not "
                       "supported");
    uint64_t bvi, off, count, ctype;
    const char *t = json_string_value(json_object_get(acc, "type"));
    if (get_uint(acc, "bufferView", UINT64_MAX, &bvi) < 0 || bvi == UINT64_MAX ||
        get_uint(acc, "byteOffset", 0, &off) < 0 ||
        get_uint(acc, "count", UINT64_MAX, &count) < 0 ||
        count == UINT64_MAX ||
        get_uint(acc, "componentType", 0, &ctype) < 0 || !t ||
        strcmp(t, type) != 0)
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: bad accessor %llu",
                       (unsigned long long)ai);
    json_t *bv = json_array_get(json_object_get(root, "bufferViews"), bvi);
    uint64_t buf, bvoff, bvlen, stride;
    if (!json_is_object(bv) || get_uint(bv, "buffer", 0, &buf) < 0 ||
        get_uint(bv, "byteOffset", 0, &bvoff) < 0 ||
        get_uint(bv, "byteLength", UINT64_MAX, &bvlen) < 0 ||
        bvlen == UINT64_MAX || get_uint(bv, "byteStride", 0, &stride) < 0)
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: bad bufferView %llu",
                       (unsigned long long)bvi);
    json_t *b = json_array_get(json_object_get(root, "buffers"), buf);
    if (buf != 0 || !json_is_object(b) || json_object_get(b, "uri"))
        return gv_fail(err, GV_EFORMAT, "mesh: glb: only the BIN chunk's "
                       "buffer 0 is supported");
    uint64_t csize;
    switch (ctype) {
    case 5121: csize = 1; break;
    case 5123: csize = 2; break;
    case 5125: case 5126: csize = 4; break;
    default:
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: componentType %llu",
                       (unsigned long long)ctype);
    }
    uint64_t elem = csize * (strcmp(type, "VEC3") == 0 ? 3 : 1);
    if (strcmp(type, "VEC3") == 0 ? ctype != 5126 : ctype == 5126)
        return gv_fail(err, GV_EFORMAT, "mesh: glb: positions must be float "
                       "and indices unsigned integers");
    if (!stride)
        stride = elem;
    if (stride < elem || stride > 252)
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: byteStride %llu",
                       (unsigned long long)stride);
    if (bvoff > bin_len || bvlen > bin_len - bvoff || off > bvlen ||
        count > (1ull << 32))
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: bufferView %llu outside "
                       "the BIN chunk", (unsigned long long)bvi);
    if (count && (count - 1) * stride + elem > bvlen - off)
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: accessor %llu outside "
                       "its bufferView", (unsigned long long)ai);
    v->p = bin + bvoff + off;
    v->count = count;
    v->stride = stride;
    v->elem = elem;
    v->ctype = (int)ctype;
    return 0;
}

static int primitive(json_t *root, json_t *prim, const uint8_t *bin,
                     uint64_t bin_len, struct mesh_grow *g,
                     struct gv_error *err)
{
    uint64_t mode, pa, ia;
    if (get_uint(prim, "mode", 4, &mode) < 0)
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: bad mode");
    if (mode != 4)
        return 0;   /* points, lines, strips, fans: skipped */
    json_t *attrs = json_object_get(prim, "attributes");
    if (!json_is_object(attrs) || get_uint(attrs, "POSITION", UINT64_MAX,
                                           &pa) < 0 || pa == UINT64_MAX)
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: primitive without "
                       "POSITION");
    struct view pv, iv;
    if (accessor(root, pa, "VEC3", bin, bin_len, &pv, err) < 0)
        return -1;
    int has_idx = json_object_get(prim, "indices") != NULL;
    if (has_idx && (get_uint(prim, "indices", 0, &ia) < 0 ||
                    accessor(root, ia, "SCALAR", bin, bin_len, &iv, err) < 0))
        return json_is_integer(json_object_get(prim, "indices"))
                   ? -1 : gv_fail(err, GV_ECORRUPT, "mesh: glb: bad indices");
    uint64_t ni = has_idx ? iv.count : pv.count;
    if (ni % 3)
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: %llu indices, not a "
                       "multiple of 3", (unsigned long long)ni);
    uint32_t base = g->m->nverts;
    if (mesh_grow_reserve(g, pv.count, ni / 3, err) < 0)
        return -1;
    for (uint64_t i = 0; i < pv.count; i++) {
        const uint8_t *q = pv.p + i * pv.stride;
        float f[3];
        for (int k = 0; k < 3; k++) {
            uint32_t u = rd32(q + 4 * k);
            memcpy(&f[k], &u, 4);
            if (!isfinite(f[k]))
                return gv_fail(err, GV_ECORRUPT, "mesh: glb: a position is "
                               "not finite");
        }
        if (mesh_grow_vert(g, f[0], f[1], f[2], err) < 0)
            return -1;
    }
    for (uint64_t t = 0; t < ni / 3; t++) {
        uint32_t c[3];
        for (int k = 0; k < 3; k++) {
            uint64_t i = 3 * t + (uint64_t)k, v;
            if (!has_idx) {
                v = i;
            } else {
                const uint8_t *q = iv.p + i * iv.stride;
                v = iv.ctype == 5121 ? q[0]
                    : iv.ctype == 5123 ? (uint64_t)(q[0] | q[1] << 8)
                                       : rd32(q);
            }
            if (v >= pv.count)
                return gv_fail(err, GV_ECORRUPT, "mesh: glb: index %llu of "
                               "%llu vertices", (unsigned long long)v,
                               (unsigned long long)pv.count);
            c[k] = base + (uint32_t)v;
        }
        if (mesh_grow_tri(g, c[0], c[1], c[2], err) < 0)
            return -1;
    }
    return 0;
}

int gv_mesh_read_glb(const uint8_t *buf, size_t len,
                     const struct gv_mesh_limits *lim, struct gv_mesh *out,
                     struct gv_error *err)
{
    if (len < 20 || rd32(buf) != 0x46546C67u)
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: no glTF header");
    if (rd32(buf + 4) != 2)
        return gv_fail(err, GV_EFORMAT, "mesh: glb: version %u (only 2)",
                       rd32(buf + 4));
    uint64_t total = rd32(buf + 8);
    if (total > len)
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: length %llu over the "
                       "%zu bytes given", (unsigned long long)total, len);
    uint64_t jlen = rd32(buf + 12);
    if (rd32(buf + 16) != 0x4E4F534Au || jlen > total - 20 || jlen > MAX_JSON)
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: bad JSON chunk");
    const uint8_t *bin = NULL;
    uint64_t bin_len = 0, at = 20 + jlen;
    at = (at + 3) & ~3ull;
    if (at + 8 <= total) {
        uint64_t bl = rd32(buf + at);
        if (rd32(buf + at + 4) == 0x004E4942u) {
            if (bl > total - at - 8)
                return gv_fail(err, GV_ECORRUPT, "mesh: glb: BIN chunk past "
                               "the end");
            bin = buf + at + 8;
            bin_len = bl;
        }
    }
    json_error_t je;
    json_t *root = json_loadb((const char *)buf + 20, (size_t)jlen,
                              JSON_REJECT_DUPLICATES, &je);
    if (!root)
        return gv_fail(err, GV_ECORRUPT, "mesh: glb: JSON: %s", je.text);
    struct mesh_grow g = {.m = out, .lim = lim};
    int rc = 0;
    json_t *meshes = json_object_get(root, "meshes");
    if (!json_is_array(meshes) || json_array_size(meshes) == 0) {
        rc = gv_fail(err, GV_ECORRUPT, "mesh: glb: no meshes");
        goto done;
    }
    for (size_t mi = 0; mi < json_array_size(meshes) && rc == 0; mi++) {
        json_t *prims = json_object_get(json_array_get(meshes, mi),
                                        "primitives");
        if (!json_is_array(prims)) {
            rc = gv_fail(err, GV_ECORRUPT, "mesh: glb: mesh %zu without "
                         "primitives", mi);
            break;
        }
        for (size_t pi = 0; pi < json_array_size(prims) && rc == 0; pi++) {
            json_t *p = json_array_get(prims, pi);
            if (!json_is_object(p))
                rc = gv_fail(err, GV_ECORRUPT, "mesh: glb: bad primitive");
            else
                rc = primitive(root, p, bin, bin_len, &g, err);
        }
    }
done:
    json_decref(root);
    return rc;
}
