/*
 * filter_ref_elevation.c - CPU references of the elevation graphs
 * (filters/library/{hillshade,slope,aspect,contours}.json,
 * docs/FILTERS.md section 8.5), declared in filter_ref.h.
 *
 * Written from the formulas of docs/FILTERS.md, which are those of GDAL's
 * gdaldem (Horn's 3 x 3 gradient; hillshade after Burrough & McDonnell),
 * in double precision.  Heights are the 8-bit gray levels of the red
 * channel times metres_per_level, so Horn's sums are exact integers on
 * both sides and "flat" (a zero gradient) is decided identically.  Two
 * decisions depend on float rounding and may legitimately differ from the
 * GPU's: a contour band boundary that a height meets almost exactly, and a
 * slope almost equal to aspect's flat_slope; ref_elevation_ambiguous()
 * names those pixels so that the tests can set them aside and count them.
 */
#include <math.h>
#include <stdlib.h>

#include "filter_ref.h"

#define PI 3.14159265358979323846
#define DEG (180.0 / PI)

/* The 8-bit gray level of the red channel at (x, y), edges clamped. */
static int gray(const struct ref_image *im, int x, int y)
{
    x = x < 0 ? 0 : x >= im->w ? im->w - 1 : x;
    y = y < 0 ? 0 : y >= im->h ? im->h - 1 : y;
    return (int)floor(im->px[((size_t)y * (size_t)im->w + (size_t)x) * 4] * 255.0 + 0.5);
}

/* Horn's gradient at ROI pixel (i, j) in gray levels, times 8: ex towards
 * the east (+x), ny towards the north (-y, rows run south). */
static void horn(const struct ref_region *r, int i, int j, int *ex, int *ny)
{
    const int x = r->roi_x + i, y = r->roi_y + j;
    int z[9];
    for (int v = 0; v < 3; v++)
        for (int u = 0; u < 3; u++)
            z[3 * v + u] = gray(&r->img, x + u - 1, y + v - 1);
    *ex = (z[2] + 2 * z[5] + z[8]) - (z[0] + 2 * z[3] + z[6]);
    *ny = (z[0] + 2 * z[1] + z[2]) - (z[6] + 2 * z[7] + z[8]);
}

static void put(const struct ref_region *r, float *out, int i, int j, double v)
{
    float *o = out + ((size_t)j * (size_t)r->roi_w + (size_t)i) * 4;
    o[0] = o[1] = o[2] = (float)v;
    o[3] = 1.0f;
}

int ref_hillshade(const struct ref_region *r, const double *p, float *out,
                  uint32_t *state)
{
    (void)state;
    const double az = (float)p[0] / DEG, alt = (float)p[1] / DEG;
    const double k = (double)(float)p[2] * (float)p[3] / (8.0 * (float)p[4]);
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            int ex, ny;
            horn(r, i, j, &ex, &ny);
            const double dx = ex * k, dy = ny * k;   /* dz/d(east), dz/d(north) */
            /* normal (-dx, -dy, 1) against the unit vector to the sun */
            const double c = (-dx * sin(az) * cos(alt) - dy * cos(az) * cos(alt) + sin(alt)) /
                             sqrt(1.0 + dx * dx + dy * dy);
            put(r, out, i, j, (1.0 + 254.0 * (c > 0 ? c : 0.0)) / 255.0);
        }
    return 0;
}

/* tan of the slope at (i, j): |grad z| in metres per metre. */
static double grade(const struct ref_region *r, int i, int j, double mpl, double px,
                    int *ex, int *ny)
{
    horn(r, i, j, ex, ny);
    return hypot(*ex, *ny) * mpl / (8.0 * px);
}

int ref_slope(const struct ref_region *r, const double *p, float *out,
              uint32_t *state)
{
    (void)state;
    const int percent = (float)p[0] >= 0.5f;
    const double full = (float)p[1], mpl = (float)p[2], px = (float)p[3];
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            int ex, ny;
            const double s = grade(r, i, j, mpl, px, &ex, &ny);
            put(r, out, i, j, (percent ? 100.0 * s : atan(s) * DEG) / full);
        }
    return 0;
}

/* The aspect in degrees clockwise from north, or -1 where flat. */
static double aspect_at(const struct ref_region *r, int i, int j, const double *p,
                        double *slope_deg)
{
    int ex, ny;
    const double s = atan(grade(r, i, j, (float)p[1], (float)p[2], &ex, &ny)) * DEG;
    *slope_deg = s;
    if ((ex == 0 && ny == 0) || s < (float)p[0])
        return -1;
    /* the downhill direction (-ex, -ny) in (east, north) */
    double a = atan2(-ex, -ny) * DEG;
    a = a < 0 ? a + 360.0 : a;
    return a >= 360.0 ? 0.0 : a;
}

int ref_aspect(const struct ref_region *r, const double *p, float *out,
               uint32_t *state)
{
    (void)state;
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            double s;
            const double a = aspect_at(r, i, j, p, &s);
            put(r, out, i, j, a < 0 ? 0.0 : (1.0 + 254.0 * a / 360.0) / 255.0);
        }
    return 0;
}

/* (height - offset) / interval at (x, y), height = base + gray * m. */
static double band_pos(const struct ref_region *r, int x, int y, const double *p)
{
    const double h = (float)p[2] + gray(&r->img, x, y) * (double)(float)p[3];
    return (h - (float)p[1]) / (float)p[0];
}

static const int nb[5][2] = {{0, 0}, {-1, 0}, {1, 0}, {0, -1}, {0, 1}};

int ref_contours(const struct ref_region *r, const double *p, float *out,
                 uint32_t *state)
{
    (void)state;
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            const int x = r->roi_x + i, y = r->roi_y + j;
            const double me = floor(band_pos(r, x, y, p));
            int line = 0;
            for (int n = 1; n < 5; n++)
                line |= floor(band_pos(r, x + nb[n][0], y + nb[n][1], p)) < me;
            put(r, out, i, j, line ? 0.0 : (float)p[4] >= 0.5f ? gray(&r->img, x, y) / 255.0
                                                                : 1.0);
        }
    return 0;
}

int ref_elevation_ambiguous(ref_fn which, const struct ref_region *r, const double *p,
                            int i, int j)
{
    if (which == ref_contours) {
        for (int n = 0; n < 5; n++) {
            const double t = band_pos(r, r->roi_x + i + nb[n][0], r->roi_y + j + nb[n][1], p);
            if (fabs(t - floor(t + 0.5)) <= 1e-5 * (fabs(t) > 1 ? fabs(t) : 1))
                return 1;
        }
        return 0;
    }
    if (which == ref_aspect) {
        double s;
        aspect_at(r, i, j, p, &s);
        return (float)p[0] > 0 && fabs(s - (float)p[0]) <= 1e-3;
    }
    return 0;
}
