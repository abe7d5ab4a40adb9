/*
 * routes.c - the handler of every route (see routes.h); the patterns are
 * in router.c.
 */
#include "routes.h"

const route_fn route_handlers[ROUTE_COUNT] = {
    [ROUTE_HOME] = route_home,
    [ROUTE_HEALTHZ] = route_healthz,
    [ROUTE_METRICS] = route_metrics,
    [ROUTE_IMAGES] = route_images_list,
    [ROUTE_IMAGE] = route_image_info,
    [ROUTE_ROOT] = route_image_root,
    [ROUTE_TILE] = route_tile,
    [ROUTE_BATCH_GET] = route_batch,
    [ROUTE_BATCH_POST] = route_batch,
    [ROUTE_REGION] = route_region,
    [ROUTE_IIIF_BASE] = route_iiif_base,
    [ROUTE_IIIF_INFO] = route_iiif_info,
    [ROUTE_IIIF_IMAGE] = route_iiif_image,
    [ROUTE_FILTERS] = route_filters_list,
    [ROUTE_FILTERS_POST] = route_filters_post,
    [ROUTE_FILTER] = route_filter_get,
    [ROUTE_FILTER_DELETE] = route_filter_delete,
    [ROUTE_IMAGE_FILTER] = route_image_filter,
    [ROUTE_MESH] = route_mesh,
    [ROUTE_TERRAIN_LAYER] = route_terrain_layer,
    [ROUTE_TERRAIN_TILE] = route_terrain_tile,
    [ROUTE_MESH_SIMPLIFY] = route_mesh_simplify,
    [ROUTE_WEB] = route_static,
    [ROUTE_AUTH_PROBE] = route_auth_probe,
    [ROUTE_AUTH_LOGIN] = route_auth_login,
    [ROUTE_AUTH_TOKEN] = route_auth_token,
    [ROUTE_AUTH_LOGOUT] = route_auth_logout,
};
