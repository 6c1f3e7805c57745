/* Winding numbers of points about a closed surface, by exact ray crossings. */
#include "isect.h"

#include <math.h>
#include <stdlib.h>

/* Signed crossings of the segment p -> q with the faces, or a degeneracy. */
static int crossings(const double *V, const int64_t *F, int64_t m, const double *lo, const double *hi,
                     const int8_t *axis, P p, P q, int64_t *count)
{
    double slo[3], shi[3];
    for (int k = 0; k < 3; k++) {
        slo[k] = dmin(p[k], q[k]);
        shi[k] = dmax(p[k], q[k]);
    }
    int64_t total = 0;
    for (int64_t t = 0; t < m; t++) {
        if (axis[t] < 0)
            continue;
        int outside = 0;
        for (int k = 0; k < 3; k++)
            outside |= lo[3 * t + k] > shi[k] || hi[3 * t + k] < slo[k];
        if (outside)
            continue;
        P a = V + 3 * F[3 * t], b = V + 3 * F[3 * t + 1], c = V + 3 * F[3 * t + 2];
        int sp = orient3d(a, b, c, p);
        if (sp == 0) {
            if (in_triangle(axis[t], p, a, b, c))
                return RAY_ON_SURFACE;
            if (orient3d(a, b, c, q) == 0)
                return RAY_DEGENERATE;          /* the segment lies in the face's plane */
            continue;                            /* meets the plane at p only, off the face */
        }
        int sq = orient3d(a, b, c, q);
        if (sq == 0)
            return RAY_DEGENERATE;
        if (sp == sq)
            continue;
        int o1 = orient3d(p, q, a, b), o2 = orient3d(p, q, b, c), o3 = orient3d(p, q, c, a);
        if ((o1 > 0 && o2 > 0 && o3 > 0) || (o1 < 0 && o2 < 0 && o3 < 0))
            total += sp > 0 ? 1 : -1;
        else if ((o1 >= 0 && o2 >= 0 && o3 >= 0) || (o1 <= 0 && o2 <= 0 && o3 <= 0))
            return RAY_DEGENERATE;              /* through an edge or a vertex */
    }
    *count = total;
    return RAY_OK;
}

int winding_numbers(const double *V, const int64_t *F, int64_t m, const double *points, int64_t k, int64_t *out,
                    int64_t *bad)
{
    double *lo = malloc(sizeof(double) * 3 * (m ? m : 1)), *hi = malloc(sizeof(double) * 3 * (m ? m : 1));
    int8_t *axis = malloc(m ? m : 1);
    int status = RAY_OK;
    if (!lo || !hi || !axis) {
        free(lo), free(hi), free(axis);
        return RAY_MEMORY;
    }
    double glo[3] = {INFINITY, INFINITY, INFINITY}, ghi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int64_t t = 0; t < m; t++) {
        P a = V + 3 * F[3 * t], b = V + 3 * F[3 * t + 1], c = V + 3 * F[3 * t + 2];
        axis[t] = (int8_t)triangle_axis(a, b, c);
        for (int j = 0; j < 3; j++) {
            lo[3 * t + j] = dmin(a[j], dmin(b[j], c[j]));
            hi[3 * t + j] = dmax(a[j], dmax(b[j], c[j]));
            glo[j] = dmin(glo[j], lo[3 * t + j]);
            ghi[j] = dmax(ghi[j], hi[3 * t + j]);
        }
    }
    double extent = 0.0;
    for (int j = 0; j < 3; j++)
        extent = dmax(extent, ghi[j] - glo[j]);
    for (int64_t i = 0; i < k && status == RAY_OK; i++) {
        P p = points + 3 * i;
        status = RAY_DEGENERATE;
        for (int attempt = 0; attempt < 64 && status == RAY_DEGENERATE; attempt++) {
            /* Nearly along an axis (few faces meet the segment's box), tilted a little, and
             * ending beyond the faces' box; a degenerate ray is retried with another. */
            int along = attempt % 3, sign = (attempt / 3) % 2 ? -1 : 1;
            double tilt = 1e-3 * (1 + attempt / 6);
            double q[3];
            for (int j = 0; j < 3; j++) {
                double golden = fmod(0.6180339887498949 * (1 + j + 7 * attempt), 1.0) - 0.5;
                q[j] = p[j] + tilt * extent * golden;
            }
            double reach = sign > 0 ? ghi[along] - p[along] : p[along] - glo[along];
            q[along] = p[along] + sign * (dmax(reach, 0.0) + extent + 1.0);
            int64_t count = 0;
            status = crossings(V, F, m, lo, hi, axis, p, q, &count);
            out[i] = count;
        }
        if (status != RAY_OK)
            *bad = i;
    }
    free(lo), free(hi), free(axis);
    return status;
}
