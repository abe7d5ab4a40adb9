/*
 * terrain_ext.h - which quantized-mesh extensions a terrain tile request
 * asks for (server/route_terrain.c).
 *
 * CesiumJS names them in the tile request's Accept header,
 *   Accept: application/vnd.quantized-mesh;extensions=octvertexnormals-
 *           watermask-metadata,application/octet-stream;q=0.9,...
 * and Cesium ion's form in the query, ?extensions=octvertexnormals-metadata.
 * Both are outside input: each is read up to TERRAIN_EXT_SCAN bytes, the
 * names are matched whole, and unknown names are ignored.
 */
#ifndef GV_SERVER_TERRAIN_EXT_H
#define GV_SERVER_TERRAIN_EXT_H

#define TERRAIN_EXT_NORMALS 1u    /* "octvertexnormals" (id 1) */
#define TERRAIN_EXT_WATERMASK 2u  /* "watermask" (id 2) */
#define TERRAIN_EXT_METADATA 4u   /* "metadata" (id 4) */
#define TERRAIN_EXT_SCAN 4096     /* bytes of a header or query value read */

/* The extensions (TERRAIN_EXT_* bits) asked for by Accept header value
 * accept (the extensions= parameter of its application/vnd.quantized-mesh
 * media ranges) and by query value query; either may be NULL.  Pure; any
 * thread. */
unsigned terrain_extensions(const char *accept, const char *query);

#endif
