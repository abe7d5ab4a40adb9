/*
 * test_ids.c - the one rule for image ids and filter ids (lib/base/ids.h)
 * that gigaview, gigaviewd's catalog and filter store and the filter
 * graphs share: what each accepts at and past its limits.
 */
#include <string.h>

#include "base/ids.h"
#include "util.h"

int main(void)
{
    char s[GV_IMAGE_ID_MAX + 2];

    check(gv_image_id_valid("x"), "image: one letter");
    check(gv_image_id_valid("A-z_0.9.tif"), "image: letters, digits, . _ -");
    check(gv_image_id_valid("a.b"), "image: a single dot inside");
    check(!gv_image_id_valid(""), "image: empty refused");
    check(!gv_image_id_valid(".hidden"), "image: leading dot refused");
    check(!gv_image_id_valid("a..b"), "image: \"..\" refused");
    check(!gv_image_id_valid("a/b"), "image: slash refused");
    check(!gv_image_id_valid("a b"), "image: space refused");
    check(!gv_image_id_valid("caf\xc3\xa9"), "image: non-ASCII refused");
    memset(s, 'a', GV_IMAGE_ID_MAX);
    s[GV_IMAGE_ID_MAX] = 0;
    check(gv_image_id_valid(s), "image: %d bytes accepted", GV_IMAGE_ID_MAX);
    s[GV_IMAGE_ID_MAX] = 'a';
    s[GV_IMAGE_ID_MAX + 1] = 0;
    check(!gv_image_id_valid(s), "image: %d bytes refused", GV_IMAGE_ID_MAX + 1);
    check(gv_image_id_valid_n("ab..", 2), "image: only n bytes are read");

    check(gv_filter_id_valid("edges-3_x"), "filter: letters, digits, _ -");
    check(!gv_filter_id_valid(""), "filter: empty refused");
    check(!gv_filter_id_valid("a.b"), "filter: dot refused");
    check(!gv_filter_id_valid("a:b"), "filter: colon refused");
    memset(s, 'f', GV_FILTER_ID_LEN);
    s[GV_FILTER_ID_LEN] = 0;
    check(gv_filter_id_valid(s), "filter: %d bytes accepted", GV_FILTER_ID_LEN);
    s[GV_FILTER_ID_LEN] = 'f';
    s[GV_FILTER_ID_LEN + 1] = 0;
    check(!gv_filter_id_valid(s), "filter: %d bytes refused", GV_FILTER_ID_LEN + 1);
    check(gv_filter_id_valid_n("edge.json", 4), "filter: only n bytes are read");
    return tap_done();
}
