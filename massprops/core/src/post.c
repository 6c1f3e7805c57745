/* The compiled steps of the post-processing (from the moments to the reported numbers):
 *
 * - cyclic Jacobi on a symmetric 3x3, the eigen-decomposition behind the principal axes;
 * - the largest squared distance of a vertex from the center of mass (the input resolution's bound);
 * - the integration frame (the box, the exact reference, the scale: core/frame.py's frame_of).
 *
 * Jacobi:
 * The same operations, in the same order, as the Python formulation it replaced
 * (massprops/model/principal.py, docs/speed.md): only +, -, *, / and sqrt, each
 * correctly rounded (built without contraction into fused multiply-adds), an exact
 * power-of-two scaling (frexp, ldexp), and pow(x, 2.0) from the C library where
 * Python squared with `**` (called through a pointer, so the compiler does not
 * turn it into x * x: the two may differ in the last bit).  So the moments, the
 * axes and the bound are the same bits on every machine. */
#include "core.h"
#include "kernel.h"

#include <math.h>
#include <string.h>

#define U_ROUND 0x1p-53
#define MAX_SWEEPS 32
#define ROTATION_ERROR 32.0

static double (*volatile power)(double, double) = pow;

/* a: the 3x3 row-major.  moments: ascending; vectors: row-major 3x3 whose column k is the unit axis of
 * moments[k]; *bound: the backward error (spectral norm) the moments are exact for.  A matrix with a
 * non-finite element or all zero is returned as its diagonal and the identity, with bound 0. */
void jacobi3(const double in[9], double moments[3], double vectors[9], double *bound)
{
    double a[3][3], v[3][3] = {{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}};
    double size = fabs(in[0]), norm = 0.0, dropped = 0.0, remainder, total;
    int i, j, k, shift, sweep, rotations = 0, order[3] = {0, 1, 2};
    static const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    int finite = 1;

    for (k = 0; k < 9; k++)
        finite &= isfinite(in[k]) != 0;
    for (k = 1; k < 9; k++)
        if (fabs(in[k]) > size)
            size = fabs(in[k]);
    if (size == 0.0 || !finite) {
        for (k = 0; k < 3; k++) {
            moments[k] = in[4 * k];
            for (j = 0; j < 3; j++)
                vectors[3 * k + j] = k == j ? 1.0 : 0.0;
        }
        *bound = 0.0;
        return;
    }
    frexp(size, &shift);
    shift = -shift;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++)
            a[i][j] = ldexp(in[3 * i + j], shift);
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++)
            norm += a[i][j] * a[i][j];
    norm = sqrt(norm);
    for (sweep = 0; sweep < MAX_SWEEPS; sweep++) {
        if (a[0][1] == 0.0 && a[0][2] == 0.0 && a[1][2] == 0.0)
            break;
        for (k = 0; k < 3; k++) {
            int p = pairs[k][0], q = pairs[k][1], r = 3 - p - q;
            double apq = a[p][q], app, aqq, theta, t, c, s, tau, arp, arq;
            if (apq == 0.0)
                continue;
            app = a[p][p];
            aqq = a[q][q];
            if (fabs(apq) <= 0.25 * U_ROUND * fmin(fabs(app), fabs(aqq)) || fabs(apq) <= U_ROUND * U_ROUND * norm) {
                dropped += fabs(apq);
                a[p][q] = a[q][p] = 0.0;
                continue;
            }
            theta = (aqq - app) / (2.0 * apq);
            if (fabs(theta) > 0x1p500)
                t = 0.5 / theta;
            else {
                t = 1.0 / (fabs(theta) + sqrt(theta * theta + 1.0));
                t = theta >= 0 ? t : -t;
            }
            c = 1.0 / sqrt(t * t + 1.0);
            s = t * c;
            tau = s / (1.0 + c);
            a[p][p] = app - t * apq;
            a[q][q] = aqq + t * apq;
            a[p][q] = a[q][p] = 0.0;
            arp = a[r][p];
            arq = a[r][q];
            a[r][p] = a[p][r] = arp - s * (arq + tau * arp);
            a[r][q] = a[q][r] = arq + s * (arp - tau * arq);
            for (i = 0; i < 3; i++) {
                double vrp = v[i][p], vrq = v[i][q];
                v[i][p] = vrp - s * (vrq + tau * vrp);
                v[i][q] = vrq + s * (vrp - tau * vrq);
            }
            rotations++;
        }
    }
    remainder = sqrt(2.0 * ((power(a[0][1], 2.0) + power(a[0][2], 2.0)) + power(a[1][2], 2.0)));
    /* a stable sort of the diagonal, ascending (every entry finite) */
    for (i = 1; i < 3; i++)
        for (j = i; j > 0 && a[order[j]][order[j]] < a[order[j - 1]][order[j - 1]]; j--) {
            k = order[j];
            order[j] = order[j - 1];
            order[j - 1] = k;
        }
    for (k = 0; k < 3; k++) {
        moments[k] = ldexp(a[order[k]][order[k]], -shift);
        for (i = 0; i < 3; i++)
            vectors[3 * i + k] = v[i][order[k]];
    }
    total = ((ROTATION_ERROR * (double)rotations) * U_ROUND) * norm;
    total = (total + 2.0 * dropped + remainder) * (1.0 + 4.0 * U_ROUND);
    *bound = ldexp(total, -shift);
}

/* max over the vertices (n x 3, row-major) of (dx*dx + dz*dz) + dy*dy, d = x - centre, each operation rounded:
 * the order numpy's einsum("ij,ij->i") used on the rows before (its paired accumulation), so the bound keeps
 * its bits.  0 for no vertex; a NaN distance never wins (as Python's max(largest, nan) keeps largest). */
double largest_squared_distance(const double *vertices, int64_t n, const double centre[3])
{
    double largest = 0.0;
    int64_t v;
    for (v = 0; v < n; v++) {
        double dx = vertices[3 * v] - centre[0], dy = vertices[3 * v + 1] - centre[1];
        double dz = vertices[3 * v + 2] - centre[2], d = (dx * dx + dz * dz) + dy * dy;
        if (d > largest)
            largest = d;
    }
    return largest;
}

/* ---- the integration frame (massprops/core/frame.py's frame_of, the same operations in the same order) ---- */

static int ceil_log2(double x)          /* x finite, > 0: k with 2**(k-1) < x <= 2**k */
{
    int exponent;
    double mantissa = frexp(x, &exponent);
    return mantissa == 0.5 ? exponent - 1 : exponent;
}

static double short_centre(double low, double high)
{
    double extent = high - low, r, y;
    int k;
    if (!(extent > 0) || !isfinite(extent))
        return low;
    k = ceil_log2(extent);
    r = nearbyint(ldexp(low * 0.5 + high * 0.5, 8 - k));     /* Python's round(): to nearest, ties to even */
    if (r == 0.0)
        r = 0.0;                                               /* round() gives the integer 0: no sign */
    y = ldexp(r, k - 8);
    return isinf(y) ? low : y;                                 /* rounded up past the largest double */
}

static double reference_coordinate(double low, double high)
{
    double extent = high - low, big;
    int k;
    if (!(extent > 0))
        return low;
    k = ceil_log2(extent);
    big = k < 1024 ? ldexp(1.0, k) : HUGE_VAL;
    if (low >= big || high <= -big)
        return short_centre(low, high);
    if (0 < low && high <= 2 * low)
        return low;
    if (high < 0 && low >= 2 * high)
        return high;
    return 0.0;
}

/* Python's max(a, b): a unless b > a (so a NaN first stays, a NaN second never wins). */
static double python_max(double a, double b)
{
    return b > a ? b : a;
}

int frame_choice(const double *vertices, int64_t n, double low[3], double high[3], double reference[3],
                 int *scale_exp, double *radius)
{
    double largest, centre[3], far;
    int i, exact[3], differ = 0;
    bounding_box(vertices, n, low, high);
    largest = python_max(python_max(high[0] - low[0], high[1] - low[1]), high[2] - low[2]);
    if (isinf(largest))
        return 1;
    for (i = 0; i < 3; i++) {
        reference[i] = reference_coordinate(low[i], high[i]);
        centre[i] = short_centre(low[i], high[i]);
        differ |= centre[i] != reference[i];
    }
    if (differ) {
        shift_is_exact(vertices, n, centre, exact);
        for (i = 0; i < 3; i++)
            if (exact[i])
                reference[i] = centre[i];
    }
    *scale_exp = largest > 0 ? ceil_log2(largest) : 0;
    far = 0.0;
    for (i = 0; i < 3; i++) {
        double reach = python_max(fabs(high[i] - reference[i]), fabs(low[i] - reference[i]));
        far = i == 0 ? reach : python_max(far, reach);
    }
    *radius = ldexp(far, -*scale_exp);
    if (high[0] - low[0] > 0 && high[1] - low[1] > 0 && high[2] - low[2] > 0
            && log2(high[0] - low[0]) + log2(high[1] - low[1]) + log2(high[2] - low[2]) - 3.0 * *scale_exp < -890.0)
        return 2;                            /* near the scaled range's limit: frame.py decides, in Python's logs */
    return 0;
}

/* Whether every coordinate is finite (no NaN, no infinity): surface.py's check before the edges are trusted. */
int all_finite(const double *values, int64_t count)
{
    /* x - x is +0.0 (no bit set) for a finite x, NaN for a NaN or an infinity: the bits or-ed (vectorised) */
    uint64_t bits = 0;
    int64_t i;
    for (i = 0; i < count; i++) {
        double difference = values[i] - values[i];
        uint64_t b;
        memcpy(&b, &difference, sizeof b);
        bits |= b;
    }
    return bits == 0;
}
