/*
 * routes.h - the handler of every route: route_handlers[] maps each
 * enum route_id (router.h, which holds the {method, pattern, name} table
 * and the matcher) to its function.  GET routes also answer HEAD.  A path
 * that matches with another method gets 405 and an Allow header; OPTIONS
 * gets a CORS preflight answer.  One handler file per route group.
 */
#ifndef GV_SERVER_ROUTES_H
#define GV_SERVER_ROUTES_H

#include "http.h"
#include "router.h"

typedef enum MHD_Result (*route_fn)(struct req *r);

extern const route_fn route_handlers[ROUTE_COUNT];

/* route_home.c: the viewer page; route_static.c: its files */
enum MHD_Result route_home(struct req *r);
enum MHD_Result route_static(struct req *r);
/* route_images.c */
enum MHD_Result route_images_list(struct req *r);
enum MHD_Result route_image_info(struct req *r);
enum MHD_Result route_image_root(struct req *r);
/* route_tiles.c */
enum MHD_Result route_tile(struct req *r);
enum MHD_Result route_batch(struct req *r);
/* route_region.c */
enum MHD_Result route_region(struct req *r);
/* route_mesh.c */
enum MHD_Result route_mesh(struct req *r);
/* route_terrain.c: Cesium quantized-mesh tiles of height stores */
enum MHD_Result route_terrain_layer(struct req *r);
enum MHD_Result route_terrain_tile(struct req *r);
/* route_mesh_simplify.c */
enum MHD_Result route_mesh_simplify(struct req *r);
/* route_iiif.c */
enum MHD_Result route_iiif_base(struct req *r);
enum MHD_Result route_iiif_info(struct req *r);
enum MHD_Result route_iiif_image(struct req *r);
/* route_filters.c */
enum MHD_Result route_filters_list(struct req *r);
enum MHD_Result route_filters_post(struct req *r);
enum MHD_Result route_filter_get(struct req *r);
enum MHD_Result route_filter_delete(struct req *r);
enum MHD_Result route_image_filter(struct req *r);
/* route_auth.c: IIIF Authorization Flow 2.0 */
enum MHD_Result route_auth_probe(struct req *r);
enum MHD_Result route_auth_login(struct req *r);
enum MHD_Result route_auth_token(struct req *r);
enum MHD_Result route_auth_logout(struct req *r);
/* The info.json "service" array of image `id`'s authorization services
 * (probe, access, token, logout) with absolute ids; new reference. */
json_t *auth_services_json(struct req *r, const char *id);
/* route_health.c */
enum MHD_Result route_healthz(struct req *r);
enum MHD_Result route_metrics(struct req *r);

#endif
