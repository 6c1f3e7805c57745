/* The arrangement's rounded corners in mesh units, and the terms of the volume their rounding may sweep.
 *
 * One pass for what massprops/mesh/shells.py (_with_pieces) and massprops/mesh/solid.py (swept_volume
 * with an apex, _unmatched_walls) compute element by element with numpy: the same operations on the same
 * doubles in the same order (built without contraction into fused multiply-adds), so every term is the
 * same double.  The sums of the terms stay with numpy's pairwise sum (mesh/solid.py), so the bound is
 * the same bit for bit.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "isect.h"

static const double WIDEN = 1 + 1e-9;

/* numpy's norm of a row of three: the squares summed left to right, then the square root */
static inline double norm3(double x, double y, double z) { return sqrt((x * x + y * y) + z * z); }

/* numpy's maximum: NaN wins */
static inline double nan_max(double a, double b) { return (a > b || a != a) ? a : b; }

static int cmp_i64(const void *a, const void *b)
{
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

int swept_pieces(const double *V, int64_t n, const double *Q, const double *R, int64_t q, double power,
                 const double *ref, const int64_t *F, int64_t k, double *points, double *largest_out,
                 double **face_terms, int64_t *n_faces, double **wall_terms, int64_t *n_walls)
{
    int64_t total = n + q;
    double *delta = calloc(total > 0 ? total : 1, sizeof(double));
    double *faces_out = malloc(sizeof(double) * (k > 0 ? k : 1));
    int64_t *codes = malloc(sizeof(int64_t) * (3 * k > 0 ? 3 * k : 1));
    int64_t *touched = malloc(sizeof(int64_t) * (k > 0 ? k : 1));
    double *walls_out = malloc(sizeof(double) * (3 * k > 0 ? 3 * k : 1));
    if (!delta || !faces_out || !codes || !touched || !walls_out) {
        free(delta), free(faces_out), free(codes), free(touched), free(walls_out);
        return -1;
    }
    memcpy(points, V, sizeof(double) * 3 * n);
    double largest = 0.0;
    for (int64_t i = 0; i < q; i++) {
        double sq[3];
        for (int d = 0; d < 3; d++) {
            double offset = Q[3 * i + d] * power;
            double p = ref[d] + offset;
            double back = p - ref[d];
            double added = fabs((ref[d] - (p - back)) + (offset - back));     /* two-sum: the addition's error */
            sq[d] = R[3 * i + d] * power + added;
            points[3 * (n + i) + d] = p;
        }
        double moved = norm3(sq[0], sq[1], sq[2]) * WIDEN;
        delta[n + i] = moved;
        largest = i == 0 ? moved : nan_max(largest, moved);
    }
    /* swept_volume: the faces around a moved corner, each with the sum of its corners' moves times its
     * enlarged area */
    int64_t kt = 0;
    for (int64_t t = 0; t < k; t++) {
        const int64_t *f = F + 3 * t;
        double d0 = delta[f[0]], d1 = delta[f[1]], d2 = delta[f[2]];
        if (!(nan_max(nan_max(d0, d1), d2) > 0))
            continue;
        const double *a = points + 3 * f[0], *b = points + 3 * f[1], *c = points + 3 * f[2];
        double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double w[3] = {c[0] - b[0], c[1] - b[1], c[2] - b[2]};
        double x[3] = {a[0] - c[0], a[1] - c[1], a[2] - c[2]};
        double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double nx = u[1] * v[2] - u[2] * v[1], ny = u[2] * v[0] - u[0] * v[2], nz = u[0] * v[1] - u[1] * v[0];
        double area = 0.5 * norm3(nx, ny, nz);
        double perimeter = (norm3(u[0], u[1], u[2]) + norm3(w[0], w[1], w[2])) + norm3(x[0], x[1], x[2]);
        double enlarged = ((area + largest * perimeter) + largest * largest) * WIDEN;
        faces_out[kt] = ((d0 + d1) + d2) * enlarged;
        touched[kt++] = t;
    }
    /* _unmatched_walls: each directed edge of those faces, less its reverse's uses, in the order of
     * start * total + end */
    for (int64_t s = 0; s < kt; s++)
        for (int e = 0; e < 3; e++) {
            const int64_t *f = F + 3 * touched[s];
            codes[3 * s + e] = f[e] * total + f[(e + 1) % 3];
        }
    int64_t nc = 3 * kt;
    qsort(codes, nc, sizeof(int64_t), cmp_i64);
    int64_t kw = 0;
    for (int64_t i = 0; i < nc;) {
        int64_t key = codes[i], j = i;
        while (j < nc && codes[j] == key)
            j++;
        int64_t count = j - i;
        i = j;
        int64_t a = key / total, b = key % total, reverse = b * total + a;
        /* the reverse's count: a binary search among the codes */
        int64_t lo = 0, hi = nc;
        while (lo < hi) {
            int64_t mid = lo + (hi - lo) / 2;
            if (codes[mid] < reverse)
                lo = mid + 1;
            else
                hi = mid;
        }
        int64_t back = 0;
        while (lo + back < nc && codes[lo + back] == reverse)
            back++;
        int64_t surplus = count - back;
        if (surplus <= 0)
            continue;
        const double *pi = points + 3 * a, *pj = points + 3 * b;
        double along = norm3(pj[0] - pi[0], pj[1] - pi[1], pj[2] - pi[2]);
        double ri = norm3(pi[0] - ref[0], pi[1] - ref[1], pi[2] - ref[2]);
        double rj = norm3(pj[0] - ref[0], pj[1] - ref[1], pj[2] - ref[2]);
        double wall = (along + largest) * (delta[a] + delta[b]);
        double reach = nan_max(ri, rj) + largest;
        walls_out[kw++] = ((double)surplus * wall) * reach;
    }
    free(delta), free(codes), free(touched);
    *largest_out = largest;
    *face_terms = faces_out, *n_faces = kt;
    *wall_terms = walls_out, *n_walls = kw;
    return 0;
}
