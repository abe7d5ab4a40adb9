/*
 * tiff_sniff.c - which reader a TIFF wants, from its first directory
 * (tiff_sniff.h).
 *
 * Why not libtiff or the libraries themselves: asking OpenSlide
 * (openslide_detect_vendor) or GDAL about every TIFF would load them for
 * every TIFF a process reads (measured with dlopen: 13 to 17 ms for
 * OpenSlide, 140 ms for GDAL), and libtiff warns about the private tags
 * of scanners.  The marks looked for are those OpenSlide 3.4's and GDAL's
 * detection use: Hamamatsu's tag 65420 (NDPI), an ImageDescription that
 * begins "Aperio" or holds Leica's SCN namespace or Philips'
 * "DPUfsImport", a Software tag that begins "MedScan" (Trestle), an XMP
 * packet, tag 700 (Ventana BIF); the GeoTIFF tags 33550, 33922, 34264 and
 * 34735.  A mark only sends the file to the library, which decides.
 *
 * Layout as TIFF 6.0 section 2 and BigTIFF: 8- or 16-byte header, IFD of
 * 12- or 20-byte entries, values inline when they fit in 4 or 8 bytes.
 */
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>

#include "imageio/tiff_sniff.h"

#define MAX_ENTRIES 4096   /* real first directories hold 10 to 40 */
#define TEXT_MAX 1024      /* what of a string is looked at */

struct reader {
    FILE *f;
    uint64_t size;
    int big, le;
};

static int read_at(const struct reader *r, uint64_t off, void *buf, size_t n)
{
    if (off > r->size || n > r->size - off || fseeko(r->f, (off_t)off, SEEK_SET) != 0)
        return -1;
    return fread(buf, 1, n, r->f) == n ? 0 : -1;
}

static uint64_t get(const struct reader *r, const uint8_t *p, int n)
{
    uint64_t v = 0;
    for (int i = 0; i < n; i++)
        v |= (uint64_t)p[i] << (8 * (r->le ? i : n - 1 - i));
    return v;
}

/* The first TEXT_MAX - 1 bytes of an ASCII entry, NUL-terminated. */
static void text(const struct reader *r, const uint8_t *e, char *out)
{
    out[0] = '\0';
    const int inl = r->big ? 8 : 4;
    uint64_t count = get(r, e + 4, r->big ? 8 : 4);
    if (get(r, e + 2, 2) != 2 || count == 0)   /* type ASCII */
        return;
    size_t n = count < TEXT_MAX - 1 ? (size_t)count : TEXT_MAX - 1;
    const uint8_t *val = e + (r->big ? 12 : 8);
    if (count <= (uint64_t)inl)
        memcpy(out, val, n);
    else if (read_at(r, get(r, val, inl), out, n) < 0)
        n = 0;
    out[n] = '\0';
}

static int starts(const char *s, const char *prefix)
{
    return strncmp(s, prefix, strlen(prefix)) == 0;
}

void gv_tiff_sniff(FILE *f, struct gv_tiff_sniff *out)
{
    memset(out, 0, sizeof *out);
    struct stat st;
    if (fstat(fileno(f), &st) < 0)
        return;
    struct reader r = {.f = f, .size = (uint64_t)st.st_size};
    uint8_t h[16];
    if (read_at(&r, 0, h, 8) < 0)
        return;
    if (h[0] == 'I' && h[1] == 'I')
        r.le = 1;
    else if (!(h[0] == 'M' && h[1] == 'M'))
        return;
    uint64_t version = get(&r, h + 2, 2), ifd;
    if (version == 43) {
        if (read_at(&r, 0, h, 16) < 0 || get(&r, h + 4, 2) != 8)
            return;
        r.big = 1;
        ifd = get(&r, h + 8, 8);
    } else if (version == 42) {
        ifd = get(&r, h + 4, 4);
    } else {
        return;
    }
    uint8_t c[8];
    if (read_at(&r, ifd, c, r.big ? 8 : 2) < 0)
        return;
    uint64_t n = get(&r, c, r.big ? 8 : 2);
    if (n > MAX_ENTRIES)
        n = MAX_ENTRIES;
    const size_t esize = r.big ? 20 : 12;
    uint64_t at = ifd + (r.big ? 8 : 2);
    char s[TEXT_MAX];
    for (uint64_t i = 0; i < n; i++, at += esize) {
        uint8_t e[20];
        if (read_at(&r, at, e, esize) < 0)
            return;
        switch (get(&r, e, 2)) {
        case 33550: case 33922: case 34264: case 34735:
            out->geo = 1;
            break;
        case 65420: case 700:
            out->slide = 1;
            break;
        case 270:
            text(&r, e, s);
            if (starts(s, "Aperio") || strstr(s, "leica-microsystems.com/scn") ||
                strstr(s, "DPUfsImport"))
                out->slide = 1;
            break;
        case 305:
            text(&r, e, s);
            if (starts(s, "MedScan"))
                out->slide = 1;
            break;
        default:
            break;
        }
    }
}
