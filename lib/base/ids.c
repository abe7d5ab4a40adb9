/*
 * ids.c - the rule for image ids and filter ids (ids.h), shared by the
 * client, the server and the filter graphs.
 */
#include "ids.h"

#include <string.h>

/* [A-Za-z0-9_-], and '.' where dot is set. */
static int id_char(char c, int dot)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
           (c >= '0' && c <= '9') || c == '_' || c == '-' || (dot && c == '.');
}

int gv_image_id_valid_n(const char *id, size_t n)
{
    if (n == 0 || n > GV_IMAGE_ID_MAX || id[0] == '.')
        return 0;
    for (size_t i = 0; i < n; i++) {
        if (!id_char(id[i], 1))
            return 0;
        if (id[i] == '.' && i + 1 < n && id[i + 1] == '.')
            return 0;
    }
    return 1;
}

int gv_image_id_valid(const char *id)
{
    return gv_image_id_valid_n(id, strlen(id));
}

int gv_filter_id_valid_n(const char *id, size_t n)
{
    if (n == 0 || n > GV_FILTER_ID_LEN)
        return 0;
    for (size_t i = 0; i < n; i++)
        if (!id_char(id[i], 0))
            return 0;
    return 1;
}

int gv_filter_id_valid(const char *id)
{
    return gv_filter_id_valid_n(id, strlen(id));
}
