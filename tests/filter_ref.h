/*
 * filter_ref.h - CPU reference implementations of the stock filter graphs
 * (filters/library/NAME.json, docs/FILTERS.md section 8), for
 * tests/test_filter_library.c.
 *
 * Each reference is written from the formula the graph documents, in plain
 * C on an RGBA float image with edge clamping; none of them interprets the
 * graphs' GLSL.  A reference sees a region (an image whose reads clamp at
 * its edges, the ROI inside it and the level coordinates of its corner),
 * which is either the whole test image (the result must then not depend on
 * the engine's padding) or exactly the padded region the engine got (for
 * the propagation filters, whose result is defined on that region).
 *
 * Parameters are floats on the GPU, so every reference converts its
 * double parameters to float before use.
 */
#ifndef GV_TESTS_FILTER_REF_H
#define GV_TESTS_FILTER_REF_H

#include <stdint.h>

/* An RGBA float image, rows packed, top first, values in [0, 1]. */
struct ref_image {
    int w, h;
    const float *px;
};

struct ref_region {
    struct ref_image img;        /* what the filter reads, clamped */
    int roi_x, roi_y, roi_w, roi_h;
    int64_t abs_x, abs_y;        /* level coordinates of img's (0, 0) */
};

/*
 * A reference: writes roi_w * roi_h RGBA floats to out.  The propagation
 * filters also write, when state is not NULL, their final sweep state over
 * the whole region (img.w * img.h * 4 uint32: (site x, site y, id, valid),
 * or (x1, y1, x2, y2) for the 2-NN diagram).  p holds the parameters in
 * the order listed next to each function.  Returns 0, or -1 when out of
 * memory.
 */
typedef int (*ref_fn)(const struct ref_region *r, const double *p, float *out,
                      uint32_t *state);

int ref_threshold(const struct ref_region *r, const double *p, float *out,
                  uint32_t *state);                  /* a, b */
int ref_negate(const struct ref_region *r, const double *p, float *out,
               uint32_t *state);                     /* none */
int ref_gamma(const struct ref_region *r, const double *p, float *out,
              uint32_t *state);                      /* gamma */
int ref_sine_window(const struct ref_region *r, const double *p, float *out,
                    uint32_t *state);                /* none */
int ref_grayscale(const struct ref_region *r, const double *p, float *out,
                  uint32_t *state);                  /* none */
int ref_box3(const struct ref_region *r, const double *p, float *out,
             uint32_t *state);                       /* none */
int ref_box7(const struct ref_region *r, const double *p, float *out,
             uint32_t *state);                       /* none */
int ref_gauss1(const struct ref_region *r, const double *p, float *out,
               uint32_t *state);                     /* none */
int ref_gauss2(const struct ref_region *r, const double *p, float *out,
               uint32_t *state);                     /* none */
int ref_gauss4(const struct ref_region *r, const double *p, float *out,
               uint32_t *state);                     /* none */
int ref_sobel(const struct ref_region *r, const double *p, float *out,
              uint32_t *state);                      /* gain */
int ref_detail(const struct ref_region *r, const double *p, float *out,
               uint32_t *state);                     /* amount */
int ref_block_max(const struct ref_region *r, const double *p, float *out,
                  uint32_t *state);                  /* level */
int ref_block_min(const struct ref_region *r, const double *p, float *out,
                  uint32_t *state);                  /* level */
int ref_block_mean(const struct ref_region *r, const double *p, float *out,
                   uint32_t *state);                 /* level */
int ref_distance(const struct ref_region *r, const double *p, float *out,
                 uint32_t *state);      /* channel, threshold, invert */
int ref_distance_display(const struct ref_region *r, const double *p,
                         float *out, uint32_t *state);
                                        /* channel, threshold, invert, scale */
int ref_voronoi_grid(const struct ref_region *r, const double *p, float *out,
                     uint32_t *state);               /* spacing, boundaries */
int ref_voronoi_mosaic(const struct ref_region *r, const double *p, float *out,
                       uint32_t *state);             /* density, boundaries */
int ref_voronoi_generalized(const struct ref_region *r, const double *p,
                            float *out, uint32_t *state);
                     /* channel, threshold, invert, levels, boundaries */
int ref_voronoi_knn(const struct ref_region *r, const double *p, float *out,
                    uint32_t *state);                /* density, scale */

/*
 * Elevation (docs/FILTERS.md section 8.5; tests/filter_ref_elevation.c):
 * the region's red channel is a DEM in 8-bit gray levels.
 */
int ref_hillshade(const struct ref_region *r, const double *p, float *out,
                  uint32_t *state);
            /* azimuth, altitude, z_factor, metres_per_level, pixel_size */
int ref_slope(const struct ref_region *r, const double *p, float *out,
              uint32_t *state);
            /* percent, full_scale, metres_per_level, pixel_size */
int ref_aspect(const struct ref_region *r, const double *p, float *out,
               uint32_t *state);
            /* flat_slope, metres_per_level, pixel_size */
int ref_contours(const struct ref_region *r, const double *p, float *out,
                 uint32_t *state);
            /* interval, offset, base, metres_per_level, show_dem */

/*
 * Whether the GPU may decide ROI pixel (i, j) of elevation reference
 * `which` differently for float rounding alone: a contour band boundary
 * within 1e-5 (relative) of a height of the pixel or a 4-neighbour, or a
 * slope within 0.001 degree of aspect's flat_slope (when it is not 0).
 * 0 for the other references.
 */
int ref_elevation_ambiguous(ref_fn which, const struct ref_region *r, const double *p,
                            int i, int j);

/*
 * The feature mask of the distance transforms: 1 where the channel
 * (0 R, 1 G, 2 B, 3 BT.709 luma) of the 8-bit value of px (an RGBA float
 * texel) is >= threshold, flipped when invert >= 0.5.
 */
int ref_is_feature(const float *px, double channel, double threshold,
                   double invert);

/*
 * The initial site ids over the whole region (img.w * img.h, 0 where no
 * site) of the one-site propagation reference `which` (ref_distance,
 * ref_distance_display, ref_voronoi_grid, ref_voronoi_mosaic or
 * ref_voronoi_generalized), for filters/edt_cpu.h.  Returns 0, or -1 for
 * another reference or when out of memory.
 */
int ref_initial_ids(ref_fn which, const struct ref_region *r, const double *p,
                    uint32_t *ids);

/* Whether the level pixel (ax, ay) is a random site of voronoi-mosaic and
 * voronoi-knn at this density. */
int ref_random_site(uint32_t ax, uint32_t ay, double density);

/*
 * Exact Euclidean distance from (x, y) to the nearest nonzero pixel of the
 * w x h mask, by a search in growing square rings; -1 if the mask is
 * empty.
 */
double ref_exact_distance(const uint8_t *mask, int w, int h, int x, int y);

#endif
