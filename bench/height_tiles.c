/*
 * height_tiles.c - writes the synth-height terrain (encode/synth_height.h)
 * as a mosaic of 16-bit TIFF tiles, the input of height-encode-speed.sh:
 * tile (c, r) holds columns c*T .. c*T+T-1 and rows r*T .. r*T+T-1 of
 * synth-height:(COLS*T)x(ROWS*T), so that the mosaic is that terrain.
 *
 *   height_tiles COLS ROWS T DIR     writes DIR/t-R-C.tif, R and C 3 digits
 */
#include <stdio.h>
#include <stdlib.h>

#include "encode/synth_height.h"
#include "imageio/imageio.h"

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: height_tiles COLS ROWS T DIR\n");
        return 2;
    }
    const int cols = atoi(argv[1]), rows = atoi(argv[2]), t = atoi(argv[3]);
    if (cols < 1 || rows < 1 || cols > 999 || rows > 999 || t < 1 || t > 65536) {
        fprintf(stderr, "height_tiles: bad sizes\n");
        return 2;
    }
    uint16_t *buf = malloc(sizeof *buf * (size_t)t * (size_t)t);
    if (!buf) {
        fprintf(stderr, "height_tiles: out of memory\n");
        return 1;
    }
    for (int r = 0; r < rows; r++)
        for (int c = 0; c < cols; c++) {
            for (int y = 0; y < t; y++)
                gv_synth_height_row((uint32_t)(r * t + y), (uint32_t)(c * t),
                                    (uint32_t)t, buf + (size_t)y * (size_t)t);
            char path[4096];
            snprintf(path, sizeof path, "%s/t-%03d-%03d.tif", argv[4], r, c);
            struct gv_error err = {0};
            if (gv_image_write_typed(path, (uint32_t)t, (uint32_t)t, 1,
                                     GV_SAMPLE_U16, buf, &err) < 0) {
                fprintf(stderr, "height_tiles: %s\n", err.text);
                free(buf);
                return 1;
            }
        }
    free(buf);
    return 0;
}
