/*
 * test_geometry.c - level, tile and page arithmetic for the sizes the
 * format must handle: 1x1, 512, 513, 514, 1x70000, 70000x1, 2^31-1.
 */
#include "base/error.h"
#include "store/geometry.h"
#include "store/store_format.h"
#include "util.h"

int main(void)
{
    struct gv_geometry g;

    check(gv_geometry_init(&g, 1, 1, 3, GV_ROOT_MAX) == 0 && g.root == 0 && g.pages == 0 &&
          g.root_mips == 1, "1x1 is its own root, no pages");
    check(gv_geometry_init(&g, 512, 512, 3, GV_ROOT_MAX) == 0 && g.root == 0,
          "512x512 fits the root");
    check(gv_geometry_init(&g, 513, 513, 3, GV_ROOT_MAX) == 0 && g.root == 1 &&
          g.level[0].tiles_x == 1 && g.level[0].tiles_y == 1 &&
          g.level[1].width == 257, "513x513: one tile and a 257^2 root");
    check(gv_geometry_init(&g, 514, 514, 3, GV_ROOT_MAX) == 0 && g.level[0].tiles_x == 2 &&
          g.level[0].tiles_y == 2, "514x514 needs 2x2 tiles");
    check(gv_tiles_for(1025) == 2 && gv_tiles_for(1026) == 3,
          "tiles overlap by one pixel: 1025 px = 2 tiles, 1026 px = 3");
    check(gv_geometry_init(&g, 70000, 1, 3, GV_ROOT_MAX) == 0 && g.root == 8 &&
          g.level[0].tiles_x == 137 && g.level[0].tiles_y == 1 &&
          g.level[8].width == 274 && g.level[8].height == 1,
          "70000x1: 8 tiled levels, 137 tiles wide, 274x1 root");
    uint32_t lw = 0, lh = 0;
    check(gv_level_size(&g, 3, &lw, &lh) == 0 && lw == 8750 && lh == 1 &&
          gv_level_size(&g, 9, &lw, &lh) == 0 && lw == 137 && lh == 1,
          "level sizes: tiled level 3 is 8750x1, the root's first mip 137x1");
    check(g.root_mips == 10 && gv_level_size(&g, 17, &lw, &lh) == 0 &&
          lw == 1 && lh == 1, "the last mip (level 17) is 1x1");
    lw = lh = 7;
    check(gv_level_size(&g, 18, &lw, &lh) < 0 && gv_level_size(&g, -1, &lw, &lh) < 0 &&
          lw == 7 && lh == 7, "no level 18 or -1; sizes untouched");
    check(gv_geometry_init(&g, 1, 70000, 1, GV_ROOT_MAX) == 0 && g.root == 8 &&
          g.level[0].tiles_y == 137 && g.channels == 1, "1x70000 gray");
    check(gv_geometry_init(&g, 0, 5, 3, GV_ROOT_MAX) < 0, "zero width is refused");
    check(gv_geometry_init(&g, 5, 5, 9, GV_ROOT_MAX) < 0 &&
          gv_geometry_init(&g, 5, 5, 0, GV_ROOT_MAX) < 0, "0 and 9 channels are refused");
    check(gv_geometry_init(&g, 5, 5, 8, GV_ROOT_MAX) == 0 && g.channels == 8,
          "8 channels (a sample store) are taken");
    check(gv_geometry_init(&g, 0x80000000u, 5, 3, GV_ROOT_MAX) < 0, "2^31 wide is refused");
    check(gv_geometry_init(&g, 0x7fffffffu, 0x7fffffffu, 3, GV_ROOT_MAX) == 0 &&
          g.root < GV_MAX_LEVELS && g.level[g.root].width <= 512,
          "2^31-1 square fits in %d levels (root %d)", GV_MAX_LEVELS, g.root);

    /* A smaller root side (format version 6): more tiled levels, one tile
     * each above the level that needs two. */
    check(gv_geometry_init(&g, 1632, 1224, 3, 32) == 0 && g.root == 6 &&
          g.root_side == 32 && g.level[6].width == 26 && g.level[6].height == 20 &&
          g.level[5].tiles_x == 1 && g.level[1].tiles_x == 2 &&
          g.level[0].tiles_x == 4 && g.root_mips == 6 && g.pages == 6,
          "1632x1224 with root side 32: root 6 (%ux%u), %d mips, %llu pages",
          g.level[g.root].width, g.level[g.root].height, g.root_mips,
          (unsigned long long)g.pages);
    check(gv_geometry_init(&g, 32, 20, 3, 32) == 0 && g.root == 0,
          "an image within the root side is all root");
    check(gv_geometry_init(&g, 33, 20, 1, 32) == 0 && g.root == 1 &&
          g.level[1].width == 17 && g.level[0].tiles_x == 1,
          "33 pixels over a root side of 32: one tiled level");
    check(gv_geometry_init(&g, 70000, 1, 3, 1) == 0 && g.root == 17 &&
          g.level[17].width == 1, "root side 1: down to one pixel (root %d)",
          g.root);
    check(gv_geometry_init(&g, 5, 5, 3, 0) < 0 &&
          gv_geometry_init(&g, 5, 5, 3, GV_ROOT_MAX + 1) < 0,
          "root sides 0 and 513 are refused");

    /* Page numbering: coarse levels first, row-major. */
    check(gv_geometry_init(&g, 40000, 20000, 3, GV_ROOT_MAX) == 0, "40000x20000");
    int ok = 1;
    uint64_t expect = 0;
    for (int k = g.root - 1; k >= 0; k--)
        for (uint32_t py = 0; py < g.level[k].pages_y; py++)
            for (uint32_t px = 0; px < g.level[k].pages_x; px++)
                ok &= gv_page_number(&g, k, px, py) == expect++;
    check(ok && expect == g.pages, "pages numbered densely, coarse to fine (%llu)",
          (unsigned long long)g.pages);
    check(g.level[0].tiles_x == 79 && g.level[0].pages_x == 10,
          "40000 px: 79 tiles, 10 pages wide");

    /* Box filter: odd edges replicate, rounding to nearest. */
    uint8_t src[3 * 3] = {0, 1, 2, 3, 4, 5, 6, 7, 8}, dst[4];
    gv_box_reduce(src, 3, 3, 1, dst);
    check(dst[0] == (0 + 1 + 3 + 4 + 2) / 4 && dst[1] == (2 + 2 + 5 + 5 + 2) / 4 &&
          dst[2] == (6 + 7 + 6 + 7 + 2) / 4 && dst[3] == 8,
          "3x3 box reduce replicates the odd edge");
    uint8_t one = 200, out1;
    gv_box_reduce(&one, 1, 1, 1, &out1);
    check(out1 == 200, "1x1 reduces to itself");
    /* Rows of every width up to 140 (past the 64-pixel spans of the
     * vectorized form, odd and even), 1, 2 and 3 channels, random and
     * extreme samples, against the formula written out here. */
    {
        static uint8_t r0[140 * 3], r1[140 * 3], out[70 * 3];
        uint64_t st = 12345;
        int bad = 0;
        for (int c = 1; c <= 3; c++)
            for (uint32_t w = 1; w <= 140; w++) {
                for (uint32_t i = 0; i < w * (uint32_t)c; i++) {
                    r0[i] = (uint8_t)(w % 5 == 0 ? 255 : test_rand(&st));
                    r1[i] = (uint8_t)(w % 7 == 0 ? 255 : test_rand(&st));
                }
                gv_box_reduce_row(r0, r1, w, c, out);
                for (uint32_t x = 0; x < (w + 1) / 2; x++)
                    for (int ch = 0; ch < c; ch++) {
                        uint32_t a = 2 * x, b = 2 * x + 1 < w ? 2 * x + 1 : 2 * x;
                        int want = (r0[a * c + ch] + r0[b * c + ch] +
                                    r1[a * c + ch] + r1[b * c + ch] + 2) / 4;
                        bad += out[x * c + ch] != want;
                    }
            }
        check(bad == 0, "box reduce rows of widths 1-140, 1-3 channels, "
              "equal the formula (%d samples differ)", bad);
    }
    check(gv_root_pixels_size(4, 2, 3) == (8 + 2 + 1) * 3, "root mip chain size");

    /* Header round trip and CRC. */
    struct gv_header h = {0}, back;
    h.version = GV_VERSION;
    h.width = 1234;
    h.height = 567;
    h.channels = 3;
    h.root_offset = 99;
    h.file_size = 1ull << 40;
    uint8_t hb[GV_HEADER_SIZE];
    gv_header_pack(&h, hb);
    check(gv_header_unpack(hb, &back, NULL) == 0 && back.width == 1234 &&
          back.file_size == (1ull << 40), "header round trip");
    hb[13] ^= 1;
    struct gv_error err = {0};
    check(gv_header_unpack(hb, &back, &err) < 0 && err.code == GV_ECORRUPT,
          "header CRC catches a flipped bit: %s", err.text);
    hb[13] ^= 1;
    hb[8] = GV_VERSION_MAX + 1;
    gv_error_clear(&err);
    check(gv_header_unpack(hb, &back, &err) < 0 && err.code == GV_EFORMAT,
          "version %d is refused: %s", GV_VERSION_MAX + 1, err.text);
    hb[8] = GV_VERSION_MIN - 1;
    gv_error_clear(&err);
    check(gv_header_unpack(hb, &back, &err) < 0 && err.code == GV_EFORMAT,
          "version %d is refused: %s", GV_VERSION_MIN - 1, err.text);
    hb[0] = 'X';
    gv_error_clear(&err);
    check(gv_header_unpack(hb, &back, &err) < 0 && err.code == GV_EFORMAT,
          "bad magic is refused");
    check(gv_crc32(0, "123456789", 9) == 0xcbf43926u, "CRC-32 check value");
    return tap_done();
}
