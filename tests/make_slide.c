/*
 * make_slide.c - writes an Aperio-like whole-slide image for the tests
 * (tests/input_slide_geo.sh) and bench/slide-encode.sh: a tiled TIFF
 * pyramid of RGB levels, each a quarter of the one above (Aperio's
 * downsample), level 0 carrying an Aperio ImageDescription with AppMag and
 * MPP, so that OpenSlide detects the "aperio" vendor and reads
 * openslide.mpp-x, mpp-y and objective-power from it.
 *
 *   make_slide OUT.svs WIDTH HEIGHT none|jpeg [MPP [APPMAG]]
 *
 * The pixels are a deterministic pattern of stained-tissue-like blobs on
 * a light background with fine noise (the same for any run), so that
 * lossy codecs have real work.  Tiles are 256 x 256.  Level 1 onwards is
 * the 4 x 4 box average of level 0 computed by its own pass (the tests
 * read level 0 only).  Written with libtiff directly: nothing is
 * downloaded.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <tiffio.h>

#define TILE 256

static uint32_t mix(uint32_t h)
{
    h ^= h >> 16;
    h *= 0x7feb352dU;
    h ^= h >> 15;
    h *= 0x846ca68bU;
    h ^= h >> 16;
    return h;
}

/* Level 0's pixel (x, y), channel c. */
static uint8_t pixel(uint32_t x, uint32_t y, int c)
{
    static const double base[3] = {236, 228, 238};   /* background */
    static const double stain[3] = {120, 60, 150};   /* haematoxylin-ish */
    double fx = x / 97.0, fy = y / 89.0;
    double t = 0.5 + 0.25 * sin(fx) * cos(fy) + 0.25 * sin(0.37 * fx + 0.61 * fy);
    t = t > 0.62 ? (t - 0.62) / 0.38 : 0;
    double v = base[c] * (1 - t) + stain[c] * t;
    v += (double)(mix(x * 0x9E3779B1U ^ y * 0x85EBCA77U ^ (uint32_t)c) & 15) - 8;
    return (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
}

/* Level k's pixel: the mean of level 0's 4^k x 4^k block (clipped). */
static uint8_t level_pixel(uint32_t x, uint32_t y, int c, uint32_t f,
                           uint32_t w0, uint32_t h0)
{
    if (f == 1)
        return pixel(x, y, c);
    uint32_t sum = 0, n = 0;
    for (uint32_t j = y * f; j < (y + 1) * f && j < h0; j++)
        for (uint32_t i = x * f; i < (x + 1) * f && i < w0; i++, n++)
            sum += pixel(i, j, c);
    return (uint8_t)((sum + n / 2) / n);
}

static int write_level(TIFF *t, uint32_t w, uint32_t h, uint32_t f,
                       uint32_t w0, uint32_t h0, int jpeg, const char *desc)
{
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, w);
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, h);
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 8);
    TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, 3);
    TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_RGB);
    TIFFSetField(t, TIFFTAG_TILEWIDTH, TILE);
    TIFFSetField(t, TIFFTAG_TILELENGTH, TILE);
    TIFFSetField(t, TIFFTAG_IMAGEDESCRIPTION, desc);
    if (jpeg) {
        TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_JPEG);
        TIFFSetField(t, TIFFTAG_JPEGQUALITY, 90);
    } else {
        TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_NONE);
    }
    uint8_t *buf = malloc((size_t)TILE * TILE * 3);
    if (!buf)
        return -1;
    for (uint32_t ty = 0; ty < h; ty += TILE)
        for (uint32_t tx = 0; tx < w; tx += TILE) {
            memset(buf, 255, (size_t)TILE * TILE * 3);
            for (uint32_t y = ty; y < ty + TILE && y < h; y++)
                for (uint32_t x = tx; x < tx + TILE && x < w; x++)
                    for (int c = 0; c < 3; c++)
                        buf[((size_t)(y - ty) * TILE + (x - tx)) * 3 + c] =
                            level_pixel(x, y, c, f, w0, h0);
            if (TIFFWriteTile(t, buf, tx, ty, 0, 0) < 0) {
                free(buf);
                return -1;
            }
        }
    free(buf);
    return TIFFWriteDirectory(t) ? 0 : -1;
}

int main(int argc, char **argv)
{
    if (argc < 5 || argc > 7 || (strcmp(argv[4], "none") && strcmp(argv[4], "jpeg"))) {
        fprintf(stderr, "usage: make_slide OUT.svs WIDTH HEIGHT none|jpeg "
                "[MPP [APPMAG]]\n");
        return 2;
    }
    uint32_t w = (uint32_t)strtoul(argv[2], NULL, 10);
    uint32_t h = (uint32_t)strtoul(argv[3], NULL, 10);
    int jpeg = strcmp(argv[4], "jpeg") == 0;
    const char *mpp = argc > 5 ? argv[5] : "0.4990";
    const char *mag = argc > 6 ? argv[6] : "20";
    if (w < 1 || h < 1 || w > 200000 || h > 200000) {
        fprintf(stderr, "make_slide: sizes 1 to 200000\n");
        return 2;
    }
    TIFF *t = TIFFOpen(argv[1], (uint64_t)w * h * 3 > 0xC0000000u ? "w8" : "w");
    if (!t)
        return 1;
    char desc[512];
    uint32_t f = 1, lw = w, lh = h;
    for (int level = 0; level == 0 || (lw >= TILE / 2 && lh >= TILE / 2); level++) {
        if (level == 0)
            snprintf(desc, sizeof desc, "Aperio Image Library v11.2.1 \r\n"
                     "%ux%u [0,0 %ux%u] (%ux%u) %s Q=90|AppMag = %s|"
                     "MPP = %s|ScanScope ID = GIGAVIEW-TEST", w, h, w, h,
                     TILE, TILE, jpeg ? "JPEG/RGB" : "RAW", mag, mpp);
        else
            snprintf(desc, sizeof desc, "Aperio Image Library v11.2.1 \r\n"
                     "%ux%u -> %ux%u - |", w, h, lw, lh);
        if (write_level(t, lw, lh, f, w, h, jpeg, desc) < 0) {
            TIFFClose(t);
            return 1;
        }
        f *= 4;
        lw = (w + f - 1) / f;
        lh = (h + f - 1) / f;
    }
    TIFFClose(t);
    return 0;
}
