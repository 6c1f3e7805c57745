/* Exact predicates and closed-set triangle tests for massprops' _intersect extension.
 *
 * orient3d and orient2d: a floating-point filter with Shewchuk's a-priori
 * bounds for these formulas, and, when the filter cannot decide, the
 * determinant as a nonoverlapping expansion of doubles (error-free sums and
 * products, fma); its sign is the sign of its largest component.  Exact
 * while no product of coordinate differences underflows: the caller passes
 * coordinates of about unit size with no non-zero magnitude below 2**-200.
 * Every test below is decided by the signs of these two predicates only.
 */
#ifndef MASSPROPS_PREDICATES_H
#define MASSPROPS_PREDICATES_H

#include <math.h>
#include <stdint.h>

#define EPS 1.1102230246251565e-16                 /* 2**-53, the unit roundoff */
#define O3_BOUND ((7.0 + 56.0 * EPS) * EPS)
#define O2_BOUND ((3.0 + 16.0 * EPS) * EPS)

typedef const double *P;

/* No NaN reaches these: the caller passes finite coordinates. */
static inline double dmin(double a, double b) { return a < b ? a : b; }
static inline double dmax(double a, double b) { return a > b ? a : b; }

/* ---- error-free transformations and expansions --------------------------------------------- */

static inline void two_sum(double a, double b, double *s, double *e)
{
    double x = a + b;
    double bv = x - a;
    double av = x - bv;
    *s = x;
    *e = (a - av) + (b - bv);
}

static inline void two_prod(double a, double b, double *p, double *e)
{
    double x = a * b;
    *p = x;
    *e = fma(a, b, -x);
}

/* Add b to the expansion h[0..n) (nonoverlapping, increasing magnitude, no zeros); new length. */
static int grow(double *h, int n, double b)
{
    double q = b;
    int k = 0;
    for (int i = 0; i < n; i++) {
        double s, e;
        two_sum(q, h[i], &s, &e);
        q = s;
        if (e != 0.0)
            h[k++] = e;
    }
    if (q != 0.0)
        h[k++] = q;
    return k;
}

static inline int expansion_sign(const double *h, int n)
{
    return n == 0 ? 0 : (h[n - 1] > 0.0 ? 1 : -1);
}

/* Grow h by the exact product x*y*z (four doubles). */
static int add_triple(double *h, int n, double x, double y, double z)
{
    double p, e, p2, e2;
    two_prod(y, z, &p, &e);
    two_prod(p, x, &p2, &e2);
    n = grow(h, n, p2);
    n = grow(h, n, e2);
    if (e != 0.0) {
        two_prod(e, x, &p2, &e2);
        n = grow(h, n, p2);
        n = grow(h, n, e2);
    }
    return n;
}

/* Grow h by s * x * y * z, each of x, y, z an exact two-term sum (hi, lo). */
static int add_triple2(double *h, int n, double s, const double *x, const double *y, const double *z)
{
    for (int i = 0; i < 2; i++) {
        if (x[i] == 0.0)
            continue;
        for (int j = 0; j < 2; j++) {
            if (y[j] == 0.0)
                continue;
            for (int k = 0; k < 2; k++)
                if (z[k] != 0.0)
                    n = add_triple(h, n, s * x[i], y[j], z[k]);
        }
    }
    return n;
}

static int orient3d_exact(P a, P b, P c, P d)
{
    double ad[3][2], bd[3][2], cd[3][2];
    double h[256];
    int n = 0;
    for (int k = 0; k < 3; k++) {
        two_sum(a[k], -d[k], &ad[k][0], &ad[k][1]);
        two_sum(b[k], -d[k], &bd[k][0], &bd[k][1]);
        two_sum(c[k], -d[k], &cd[k][0], &cd[k][1]);
    }
    /* adz (bdx cdy - cdx bdy) + bdz (cdx ady - adx cdy) + cdz (adx bdy - bdx ady) */
    n = add_triple2(h, n, 1.0, ad[2], bd[0], cd[1]);
    n = add_triple2(h, n, -1.0, ad[2], cd[0], bd[1]);
    n = add_triple2(h, n, 1.0, bd[2], cd[0], ad[1]);
    n = add_triple2(h, n, -1.0, bd[2], ad[0], cd[1]);
    n = add_triple2(h, n, 1.0, cd[2], ad[0], bd[1]);
    n = add_triple2(h, n, -1.0, cd[2], bd[0], ad[1]);
    return expansion_sign(h, n);
}

/* Sign of det[a - d; b - d; c - d]: negative when d is on the side the right-hand normal of
 * (a, b, c) points to, positive on the other side, zero when the four points are coplanar. */
static int orient3d(P a, P b, P c, P d)
{
    double adx = a[0] - d[0], bdx = b[0] - d[0], cdx = c[0] - d[0];
    double ady = a[1] - d[1], bdy = b[1] - d[1], cdy = c[1] - d[1];
    double adz = a[2] - d[2], bdz = b[2] - d[2], cdz = c[2] - d[2];
    double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
    double cdxady = cdx * ady, adxcdy = adx * cdy;
    double adxbdy = adx * bdy, bdxady = bdx * ady;
    double det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
    double permanent = (fabs(bdxcdy) + fabs(cdxbdy)) * fabs(adz) + (fabs(cdxady) + fabs(adxcdy)) * fabs(bdz)
                       + (fabs(adxbdy) + fabs(bdxady)) * fabs(cdz);
    double bound = O3_BOUND * permanent;
    if (det > bound)
        return 1;
    if (-det > bound)
        return -1;
    return orient3d_exact(a, b, c, d);
}

static int orient2d_exact(double ax, double ay, double bx, double by, double cx, double cy)
{
    double acx[2], bcy[2], acy[2], bcx[2], h[64];
    int n = 0;
    two_sum(ax, -cx, &acx[0], &acx[1]);
    two_sum(by, -cy, &bcy[0], &bcy[1]);
    two_sum(ay, -cy, &acy[0], &acy[1]);
    two_sum(bx, -cx, &bcx[0], &bcx[1]);
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++) {
            double p, e;
            if (acx[i] != 0.0 && bcy[j] != 0.0) {
                two_prod(acx[i], bcy[j], &p, &e);
                n = grow(h, n, p);
                n = grow(h, n, e);
            }
            if (acy[i] != 0.0 && bcx[j] != 0.0) {
                two_prod(-acy[i], bcx[j], &p, &e);
                n = grow(h, n, p);
                n = grow(h, n, e);
            }
        }
    return expansion_sign(h, n);
}

/* Positive when (a, b, c) turn counter-clockwise. */
static int orient2d(double ax, double ay, double bx, double by, double cx, double cy)
{
    double left = (ax - cx) * (by - cy), right = (ay - cy) * (bx - cx);
    double det = left - right;
    double bound = O2_BOUND * (fabs(left) + fabs(right));
    if (det > bound)
        return 1;
    if (-det > bound)
        return -1;
    return orient2d_exact(ax, ay, bx, by, cx, cy);
}

/* orient2d of the projection that drops axis k. */
static inline int porient(int k, P a, P b, P c)
{
    int u = k == 0 ? 1 : 0, v = k == 2 ? 1 : 2;
    return orient2d(a[u], a[v], b[u], b[v], c[u], c[v]);
}

/* An axis whose projection keeps (p, q, r) a proper triangle, or -1 when it has zero area. */
static int triangle_axis(P p, P q, P r)
{
    double ux = q[0] - p[0], uy = q[1] - p[1], uz = q[2] - p[2];
    double vx = r[0] - p[0], vy = r[1] - p[1], vz = r[2] - p[2];
    double n[3] = {fabs(uy * vz - uz * vy), fabs(uz * vx - ux * vz), fabs(ux * vy - uy * vx)};
    /* the axis a stable sort by decreasing |n| puts first: the common answer, without the sort */
    int first = n[0] >= n[1] ? (n[0] >= n[2] ? 0 : 2) : (n[1] >= n[2] ? 1 : 2);
    if (porient(first, p, q, r) != 0)
        return first;
    int order[3] = {0, 1, 2};
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2 - i; j++)
            if (n[order[j]] < n[order[j + 1]]) {
                int t = order[j];
                order[j] = order[j + 1];
                order[j + 1] = t;
            }
    for (int i = 0; i < 3; i++)
        if (porient(order[i], p, q, r) != 0)
            return order[i];
    return -1;
}

/* Whether p, q, r are not collinear (triangle_axis(p, q, r) >= 0), exactly: orient2d's filter
 * in the projection along z first (it settles almost every face), then triangle_axis. */
static inline int has_area(P p, P q, P r)
{
    double left = (p[0] - r[0]) * (q[1] - r[1]), right = (p[1] - r[1]) * (q[0] - r[0]);
    if (fabs(left - right) > O2_BOUND * (fabs(left) + fabs(right)))
        return 1;
    return triangle_axis(p, q, r) >= 0;
}

/* ---- closed-set tests ---------------------------------------------------------------------- */

/* c, known collinear with a and b in projection k, lies within the segment. */
static int within_segment(int k, P a, P b, P c)
{
    for (int axis = 0; axis < 3; axis++) {
        if (axis == k)
            continue;
        double lo = a[axis] < b[axis] ? a[axis] : b[axis], hi = a[axis] < b[axis] ? b[axis] : a[axis];
        if (c[axis] < lo || c[axis] > hi)
            return 0;
    }
    return 1;
}

/* Closed segments ab and cd, coplanar, meet (tested in projection k). */
static int segments_meet(int k, P a, P b, P c, P d)
{
    int o1 = porient(k, a, b, c), o2 = porient(k, a, b, d);
    int o3 = porient(k, c, d, a), o4 = porient(k, c, d, b);
    if (o1 * o2 < 0 && o3 * o4 < 0)
        return 1;
    return (o1 == 0 && within_segment(k, a, b, c)) || (o2 == 0 && within_segment(k, a, b, d))
           || (o3 == 0 && within_segment(k, c, d, a)) || (o4 == 0 && within_segment(k, c, d, b));
}

/* x lies in the closed triangle pqr, all coplanar (projection k keeps pqr proper). */
static int in_triangle(int k, P x, P p, P q, P r)
{
    int o = porient(k, p, q, r);
    return porient(k, p, q, x) * o >= 0 && porient(k, q, r, x) * o >= 0 && porient(k, r, p, x) * o >= 0;
}

static int segment_meets_triangle_2d(int k, P a, P b, P p, P q, P r)
{
    return in_triangle(k, a, p, q, r) || in_triangle(k, b, p, q, r) || segments_meet(k, a, b, p, q)
           || segments_meet(k, a, b, q, r) || segments_meet(k, a, b, r, p);
}

/* Closed segment ab meets closed triangle pqr (axis k); sa, sb: orient3d(p, q, r, a / b). */
static int segment_meets_triangle(P a, P b, int sa, int sb, P p, P q, P r, int k)
{
    if (sa == sb && sa != 0)
        return 0;
    if (sa == 0 && sb == 0)
        return segment_meets_triangle_2d(k, a, b, p, q, r);
    int s1 = orient3d(a, b, p, q), s2 = orient3d(a, b, q, r), s3 = orient3d(a, b, r, p);
    return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
}

static int same_strict_side(const int *s)
{
    return (s[0] > 0 && s[1] > 0 && s[2] > 0) || (s[0] < 0 && s[1] < 0 && s[2] < 0);
}

/* Closed triangles T1 = t1[0..2], T2 = t2[0..2] (proper, axes k1, k2) share a point. */
static int triangles_meet(P const *t1, int k1, P const *t2, int k2)
{
    int s1[3], s2[3];
    for (int i = 0; i < 3; i++)
        s1[i] = orient3d(t2[0], t2[1], t2[2], t1[i]);
    if (same_strict_side(s1))
        return 0;
    for (int i = 0; i < 3; i++)
        s2[i] = orient3d(t1[0], t1[1], t1[2], t2[i]);
    if (same_strict_side(s2))
        return 0;
    if (s1[0] == 0 && s1[1] == 0 && s1[2] == 0) {
        for (int i = 0; i < 3; i++)
            if (segment_meets_triangle_2d(k2, t1[i], t1[(i + 1) % 3], t2[0], t2[1], t2[2]))
                return 1;
        return in_triangle(k2, t2[0], t1[0], t1[1], t1[2]);
    }
    for (int i = 0; i < 3; i++) {
        int j = (i + 1) % 3;
        if (segment_meets_triangle(t1[i], t1[j], s1[i], s1[j], t2[0], t2[1], t2[2], k2))
            return 1;
        if (segment_meets_triangle(t2[i], t2[j], s2[i], s2[j], t1[0], t1[1], t1[2], k1))
            return 1;
    }
    return 0;
}

/* Direction x - p lies in the closed cone of the rays p->c and p->d (coplanar, projection k). */
static int in_cone(int k, P p, P x, P c, P d)
{
    int o = porient(k, p, c, d);
    return porient(k, p, c, x) * o >= 0 && porient(k, p, x, d) * o >= 0;
}

/* Triangles (p, a, b) and (p, c, d), sharing only the vertex p, meet elsewhere too. */
static int meet_beyond_vertex(P p, P a, P b, int k1, P c, P d, int k2)
{
    int sc = orient3d(p, a, b, c), sd = orient3d(p, a, b, d);
    if (sc == sd && sc != 0)
        return 0;
    int ta = orient3d(p, c, d, a), tb = orient3d(p, c, d, b);
    if (ta == tb && ta != 0)
        return 0;
    return segment_meets_triangle(a, b, ta, tb, p, c, d, k2) || segment_meets_triangle(c, d, sc, sd, p, a, b, k1)
           || (ta == 0 && in_cone(k2, p, a, c, d)) || (tb == 0 && in_cone(k2, p, b, c, d))
           || (sc == 0 && in_cone(k1, p, c, a, b)) || (sd == 0 && in_cone(k1, p, d, a, b));
}

/* Triangles (p, q, r) and (q, p, s) or (p, q, s), sharing the edge pq, fold onto each other. */
static int fold_over_edge(P p, P q, P r, P s, int k1)
{
    if (orient3d(p, q, r, s) != 0)
        return 0;
    return porient(k1, p, q, r) * porient(k1, p, q, s) > 0;
}

#endif
