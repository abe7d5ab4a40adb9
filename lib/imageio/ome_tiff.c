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

struct gv_ome *gv_ome_take(const char *path, struct gv_native_tiff *first,
                           uint64_t max_pixels, struct gv_image_info *info)
{
    const char *xml = gv_native_tiff_description(first);
    const char *tag, *end;
    if (!xml || !strstr(xml, "<OME") || !element(xml, "Pixels", &tag, &end) ||
        info->channels != 1)
        return NULL;
    const long c = int_attr(tag, end, "SizeC");
    if (c < 2 || c > MAX_CHANNELS || int_attr(tag, end, "SizeZ") != 1 ||
        int_attr(tag, end, "SizeT") != 1)
        return NULL;
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
    for (int k = 1; k < o->c; k++) {
        struct gv_image_info ki;
        struct gv_error e = {0};
        o->t[k] = gv_native_tiff_open_dir(path, (uint32_t)k, max_pixels, &ki, &e);
        if (!o->t[k] || ki.width != info->width || ki.height != info->height ||
            ki.channels != 1 || ki.bits != info->bits) {
            for (int j = 1; j <= k; j++)
                gv_native_tiff_close(o->t[j]);
            free(o);
            return NULL;
        }
    }
    o->t[0] = first;
    o->meta = channel_meta(xml, end, o->c);
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
