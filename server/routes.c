/*
 * routes.c - the table of every route gigaviewd answers (see routes.h).
 * Order matters only between patterns of the same shape: the first match
 * wins.
 */
#include "routes.h"

const struct route routes[] = {
    {"GET", "/", route_home, "home", 0},
    {"GET", "/healthz", route_healthz, "healthz", 0},
    {"GET", "/metrics", route_metrics, "metrics", 0},
    {"GET", "/v1/images", route_images_list, "images", 0},
    {"GET", "/v1/images/*", route_image_info, "image", 0},
    {"GET", "/v1/images/*/root", route_image_root, "root", 0},
    {"GET", "/v1/images/*/tiles/*/*/*", route_tile, "tile", 0},
    {"GET", "/v1/images/*/batch", route_batch, "batch", 0},
    {"POST", "/v1/images/*/batch", route_batch, "batch", 0},
    {"GET", "/v1/images/*/region", route_region, "region", 0},
    {"GET", "/iiif/3/*", route_iiif_base, "iiif_base", 1},
    {"GET", "/iiif/3/*/info.json", route_iiif_info, "iiif_info", 1},
    {"GET", "/iiif/3/*/*/*/*/*", route_iiif_image, "iiif_image", 1},
};

const int nroutes = sizeof routes / sizeof routes[0];
