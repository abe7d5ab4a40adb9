/*
 * ome_tiff.c - OME-TIFF channels as one image (see ome_tiff.h).  The
 * OME-XML is not parsed as a whole: only the first Pixels element's
 * attributes and its Channel elements' are read, by scanning the tags'
 * text, which is all this reader needs; anything it does not understand
 * declines.
 */
#include <jansson.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "imageio/ome_tiff.h"

#define MAX_CHANNELS 8
#define NAME_MAX_BYTES 256
#define MAX_PLANES 1000000   /* of Z, of T */

struct gv_ome {
    int c;
    struct gv_native_tiff *t[MAX_CHANNELS];
    uint32_t width;
    size_t sample_bytes;
    uint8_t *plane;       /* rows of one channel, read before interleaving */
    uint32_t plane_rows;
    char *meta;
};

/* The value of attribute `name` inside the tag text [tag, end) into buf
 * (size bytes, NUL-terminated): 1, or 0 when absent or too long. */
static int attr(const char *tag, const char *end, const char *name, char *buf,
                size_t size)
{
    const size_t n = strlen(name);
    for (const char *p = tag; p + n + 2 < end; p++) {
        if ((p[-1] != ' ' && p[-1] != '\t' && p[-1] != '\n' && p[-1] != '\r') ||
            strncmp(p, name, n) != 0 || p[n] != '=' || (p[n + 1] != '"' && p[n + 1] != '\''))
            continue;
        const char q = p[n + 1], *v = p + n + 2, *e = memchr(v, q, (size_t)(end - v));
        if (!e || (size_t)(e - v) >= size)
            return 0;
        memcpy(buf, v, (size_t)(e - v));
        buf[e - v] = '\0';
        return 1;
    }
    return 0;
}

/* The next element <name ...> at or after s: its text [*tag, *end) with
 * *end at its '>'; 0 when there is none. */
static int element(const char *s, const char *name, const char **tag,
                   const char **end)
{
    const size_t n = strlen(name);
    for (const char *p = strchr(s, '<'); p; p = strchr(p + 1, '<')) {
        /* a namespace prefix ("ome:Pixels") is allowed */
        const char *q = p + 1, *colon = strpbrk(q, ": \t\r\n/>");
        if (colon && *colon == ':')
            q = colon + 1;
        if (strncmp(q, name, n) == 0 && strchr(" \t\r\n/>", q[n])) {
            const char *e = strchr(q, '>');
            if (!e)
                return 0;
            *tag = q + n;
            *end = e;
            return 1;
        }
    }
    return 0;
}

/* A decimal integer attribute, or -1. */
static long int_attr(const char *tag, const char *end, const char *name)
{
    char v[32], *e;
    if (!attr(tag, end, name, v, sizeof v))
        return -1;
    long x = strtol(v, &e, 10);
    return e != v && !*e ? x : -1;
}

/* The metadata of the channels' names and colours, or NULL. */
static char *channel_meta(const char *xml, const char *from, int c)
{
    char names[MAX_CHANNELS * (NAME_MAX_BYTES + 1)] = "", colours[MAX_CHANNELS * 7 + 1] = "";
    int named = 0, coloured = 0;
    const char *s = from, *tag, *end;
    for (int k = 0; k < c && element(s, "Channel", &tag, &end); k++, s = end) {
        char v[NAME_MAX_BYTES];
        if (attr(tag, end, "Name", v, sizeof v)) {
            for (char *p = v; *p; p++)
                *p = *p == ';' ? ',' : *p;
            snprintf(names + strlen(names), sizeof names - strlen(names), "%s%s",
                     k ? ";" : "", v);
            named++;
        }
        char *e;
        if (attr(tag, end, "Color", v, sizeof v)) {
            long long x = strtoll(v, &e, 10);
            if (e != v && !*e && x >= -2147483648LL && x <= 4294967295LL) {
                unsigned long u = (unsigned long)(x & 0xffffffffLL);
                snprintf(colours + strlen(colours), sizeof colours - strlen(colours),
                         "%s%02lx%02lx%02lx", k ? ";" : "", (u >> 24) & 255,
                         (u >> 16) & 255, (u >> 8) & 255);
                coloured++;
            }
        }
    }
    (void)xml;
    json_t *o = json_object();
    if (!o)
        return NULL;
    if (named == c)
        json_object_set_new(o, "ome.channels", json_string(names));
    if (coloured == c)
        json_object_set_new(o, "display.colours", json_string(colours));
    char *text = json_object_size(o) ? json_dumps(o, JSON_COMPACT | JSON_SORT_KEYS) : NULL;
    json_decref(o);
    return text;
}

/* Directory of channel c of plane (z, t) in a file whose planes follow
 * dimension order `order` (validated: "XY" then Z, C and T, fastest
 * first) with sizes n[] for Z, C, T. */
static long ifd_of(const char *order, long z, long c, long t, const long n[3])
{
    long idx = 0, mul = 1;
    for (int i = 2; i < 5; i++) {
        const int d = order[i] == 'Z' ? 0 : order[i] == 'C' ? 1 : 2;
        idx += (d == 0 ? z : d == 1 ? c : t) * mul;
        mul *= n[d];
    }
    return idx;
}

static int order_valid(const char *o)
{
    return strlen(o) == 5 && o[0] == 'X' && o[1] == 'Y' && strchr(o + 2, 'Z') &&
           strchr(o + 2, 'C') && strchr(o + 2, 'T');
}

/* The plane's metadata beside the channels' (the JSON of channel_meta, or
 * NULL), for a stack. */
static char *plane_meta(char *meta, long z, long t, long nz, long nt)
{
    json_error_t je;
    json_t *o = meta ? json_loads(meta, 0, &je) : json_object();
    free(meta);
    if (!o)
        return NULL;
    json_object_set_new(o, "ome.plane_z", json_integer(z));
    json_object_set_new(o, "ome.plane_t", json_integer(t));
    json_object_set_new(o, "ome.size_z", json_integer(nz));
    json_object_set_new(o, "ome.size_t", json_integer(nt));
    char *text = json_dumps(o, JSON_COMPACT | JSON_SORT_KEYS);
    json_decref(o);
    return text;
}

static void close_taken(struct gv_ome *o, struct gv_native_tiff *first)
{
    for (int k = 0; k < o->c; k++)
        if (o->t[k] != first)
            gv_native_tiff_close(o->t[k]);
    free(o);
}

struct gv_ome *gv_ome_take(const char *path, struct gv_native_tiff *first,
                           const struct gv_image_limits *lim, struct gv_image_info *info,
                           struct gv_error *err)
{
    const char *xml = gv_native_tiff_description(first);
    const char *tag, *end;
    if (!xml || !strstr(xml, "<OME") || !element(xml, "Pixels", &tag, &end) ||
        info->channels != 1)
        return NULL;
    const long c = int_attr(tag, end, "SizeC"), nz = int_attr(tag, end, "SizeZ"),
               nt = int_attr(tag, end, "SizeT");
    char order[16] = "XYZCT";
    if (c < 1 || c > MAX_CHANNELS || nz < 1 || nt < 1 || nz > MAX_PLANES ||
        nt > MAX_PLANES || (attr(tag, end, "DimensionOrder", order, sizeof order) &&
                            !order_valid(order)))
        return NULL;
    const int stack = nz * nt > 1;
    if (c == 1 && !stack && !lim->plane.set)
        return NULL;   /* one page: read as any TIFF */
    if (stack && !lim->plane.set) {
        gv_fail(err, GV_EINVAL, "imageio: %s: an OME-TIFF stack of %ld Z plane%s and "
                "%ld time point%s: choose a plane with --plane Z[,T] (from 0)", path, nz,
                nz == 1 ? "" : "s", nt, nt == 1 ? "" : "s");
        return NULL;
    }
    const long z = lim->plane.set ? (long)lim->plane.z : 0,
               t = lim->plane.set ? (long)lim->plane.t : 0;
    if (z >= nz || t >= nt) {
        gv_fail(err, GV_EINVAL, "imageio: %s: --plane %ld,%ld is outside the stack "
                "(Z 0..%ld, T 0..%ld)", path, z, t, nz - 1, nt - 1);
        return NULL;
    }
    /* Every channel one sample (SamplesPerPixel absent means 1). */
    const char *s = end, *ct, *ce;
    for (long k = 0; k < c; k++, s = ce) {
        if (!element(s, "Channel", &ct, &ce))
            return NULL;
        long spp = int_attr(ct, ce, "SamplesPerPixel");
        if (spp > 1)
            return NULL;
    }
    struct gv_ome *o = calloc(1, sizeof *o);
    if (!o)
        return NULL;
    o->c = (int)c;
    o->width = info->width;
    o->sample_bytes = info->bits == 16 ? 2 : 1;
    const long n[3] = {nz, c, nt};
    for (int k = 0; k < o->c; k++) {
        const long dir = ifd_of(order, z, k, t, n);
        if (dir == 0) {
            o->t[k] = first;
            continue;
        }
        struct gv_image_info ki;
        struct gv_error e = {0};
        o->t[k] = gv_native_tiff_open_dir(path, (uint32_t)dir, lim->max_pixels, &ki, &e);
        if (!o->t[k] || ki.width != info->width || ki.height != info->height ||
            ki.channels != 1 || ki.bits != info->bits) {
            if (stack)   /* no page of a stack is the image: refuse */
                gv_fail(err, e.code != GV_OK ? e.code : GV_EFORMAT,
                        "imageio: %s: OME-TIFF directory %ld (channel %d of plane "
                        "%ld,%ld) %s", path, dir, k, z, t,
                        o->t[k] ? "differs from the first in size or samples"
                                : "cannot be read");
            if (o->t[k])
                gv_native_tiff_close(o->t[k]);
            o->t[k] = NULL;
            close_taken(o, first);
            return NULL;
        }
    }
    o->meta = channel_meta(xml, end, o->c);
    if (stack)
        o->meta = plane_meta(o->meta, z, t, nz, nt);
    /* The first directory is ours now (xml with it): closed here when the
     * plane does not start with it. */
    int uses_first = 0;
    for (int k = 0; k < o->c; k++)
        uses_first |= o->t[k] == first;
    if (!uses_first)
        gv_native_tiff_close(first);
    info->channels = o->c;
    return o;
}

int gv_ome_read(struct gv_ome *o, uint32_t rows, void *out, struct gv_error *err)
{
    const size_t row = (size_t)o->width * o->sample_bytes;
    if (rows > o->plane_rows) {
        free(o->plane);
        o->plane_rows = 0;
        if (!(o->plane = malloc(row * rows)))
            return gv_fail(err, GV_ENOMEM, "imageio: out of memory for OME rows");
        o->plane_rows = rows;
    }
    const size_t n = (size_t)o->width * rows, sb = o->sample_bytes;
    uint8_t *dst = out;
    for (int k = 0; k < o->c; k++) {
        if (gv_native_tiff_read(o->t[k], rows, o->plane, err) < 0)
            return -1;
        for (size_t i = 0; i < n; i++)
            memcpy(dst + (i * (size_t)o->c + (size_t)k) * sb, o->plane + i * sb, sb);
    }
    return 0;
}

const char *gv_ome_meta(const struct gv_ome *o)
{
    return o->meta;
}

void gv_ome_close(struct gv_ome *o)
{
    if (!o)
        return;
    for (int k = 0; k < o->c; k++)
        gv_native_tiff_close(o->t[k]);
    free(o->plane);
    free(o->meta);
    free(o);
}
