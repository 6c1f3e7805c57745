/* The per-face kernel: signed-tetrahedron sums with rigorous error bounds (kernel.c, kernel_dd.c). */
#ifndef MASSPROPS_KERNEL_H
#define MASSPROPS_KERNEL_H

#include "core.h"

#include <math.h>

/* What to integrate.  Coordinates are used as y = (x - reference) * 2**-scale_exp, which the
 * caller has checked to be exact in the subtraction (frame.py); `radius` is max |y_i|. */
typedef struct {
    const double *vertices;       /* n x 3 */
    int64_t n;
    const void *faces;            /* m x 3, int32 if faces32 else int64 */
    int faces32;
    int64_t m;
    const double *weights;        /* m factors, taken as exact, or NULL */
    const double *scaled;         /* n x 3: the vertices already scaled as scaled() does, or NULL */
    double reference[3];
    int scale_exp;
    double radius;
    int order;                    /* 0: det only, 1: and first moments, 2: and second */
    int area_measure;             /* 1: |(b - a) x (c - a)| in place of det */
    int threads;
} KernelInput;

/* Sums in scaled units, each with an absolute bound on its error against exact arithmetic on
 * the scaled coordinates (the largest element's error for vectors and matrices). */
typedef struct {
    double det_sum, det_error;
    double first[3], first_error;         /* sum of det * (a + b + c) */
    double second[6], second_error;       /* sum of det * (s s' + a a' + b b' + c c'): xx yy zz xy yz zx */
    double area2;                         /* sum of |(b - a) x (c - a)| */
    double abs_sum;                       /* an upper bound on sum |det| (weighted) */
    int64_t refined, exact;               /* faces re-evaluated in double-double, and exactly */
    int64_t bad_face;                     /* the first face with an index out of range, or -1 */
} KernelResult;

int integrate_faces(const KernelInput *in, KernelResult *out, Failure *failure);
int integrate_faces_dd(const KernelInput *in, KernelResult *out, Failure *failure);

/* Six times the signed volume of each tetrahedron (p0, p1, p2, p3) in scaled coordinates, and
 * Shewchuk's bound on its error.  bad_tet: as bad_face. */
int tetra_determinants(const KernelInput *in, double *det, double *bound, int64_t *bad_tet, Failure *failure);

/* Per-shell sums of det with bounds (labels 0..shells-1 per face). */
int shell_determinants(const KernelInput *in, const int64_t *labels, int64_t shells, double *det_sum,
                       double *det_error, Failure *failure);

void bounding_box(const double *vertices, int64_t n, double low[3], double high[3]);
/* Whether x - centre[i] is exact for every coordinate x of axis i. */
void shift_is_exact(const double *vertices, int64_t n, const double centre[3], int exact[3]);
/* out = ldexp(x - reference[i], -scale_exp) per coordinate x of axis i (n x 3), with every non-zero
 * value below `smallest` in magnitude taken as zero; returns how many vertices had one taken so,
 * listed in `moved` (ascending). */
int64_t scale_snapped(const double *vertices, int64_t n, const double reference[3], int scale_exp, double smallest,
                      double *out, int64_t *moved);

/* ---- shared by kernel.c and kernel_dd.c --------------------------------------------------- */

#define KERNEL_BLOCK 4096         /* faces per block: results are stored per block, so per-block */
                                  /* work is the unit of determinism, whatever the thread count */

/* Shewchuk's o3derrboundA: the error of det = a . ((b - a) x (c - a)) evaluated in double is at
 * most DET_BOUND * permanent (the same products in absolute value). */
#define DET_BOUND ((7.0 + 56.0 * 0x1p-53) * 0x1p-53)
/* Per face and per sum, an absolute allowance for underflow: scaled coordinates are at most 1,
 * so a product or a scaled coordinate that underflows is off by at most 2**-1074 times a small
 * factor; 2**-1000 covers every such term with room to spare. */
#define UNDERFLOW_ALLOWANCE 0x1p-1000

typedef struct {
    double f1, f2;                /* y = ((x - reference) * f1) * f2, f2 == 1 unless scale_exp < -1023 */
    int two;
} Scaling;

void scaling_init(Scaling *s, int scale_exp);

static inline double scaled(double x, double reference, const Scaling *s)
{
    double y = (x - reference) * s->f1;
    return s->two ? y * s->f2 : y;
}

static inline int64_t face_vertex(const KernelInput *in, int64_t k)
{
    return in->faces32 ? ((const int32_t *)in->faces)[k] : ((const int64_t *)in->faces)[k];
}

/* Load the scaled corners of face f (rows a, b, c); 0, or -1 if an index is out of range. */
static inline int load_face(const KernelInput *in, const Scaling *s, int64_t f, double corner[3][3])
{
    int k, i;
    for (k = 0; k < 3; k++) {
        int64_t v = face_vertex(in, 3 * f + k);
        if ((uint64_t)v >= (uint64_t)in->n)
            return -1;
        for (i = 0; i < 3; i++)
            corner[k][i] = scaled(in->vertices[3 * v + i], in->reference[i], s);
    }
    return 0;
}

/* det and Shewchuk's bound from corners a, b, c; also the normal's length and Σ(|p| + |q|). */
static inline void det_and_bound(const double a[3], const double b[3], const double c[3], double *det,
                                 double *bound, double *area, double *products)
{
    double e1x = b[0] - a[0], e1y = b[1] - a[1], e1z = b[2] - a[2];
    double e2x = c[0] - a[0], e2y = c[1] - a[1], e2z = c[2] - a[2];
    double p0 = e1y * e2z, q0 = e1z * e2y, p1 = e1z * e2x, q1 = e1x * e2z, p2 = e1x * e2y, q2 = e1y * e2x;
    double n0 = p0 - q0, n1 = p1 - q1, n2 = p2 - q2;
    double s0 = fabs(p0) + fabs(q0), s1 = fabs(p1) + fabs(q1), s2 = fabs(p2) + fabs(q2);
    *det = (a[0] * n0 + a[1] * n1) + a[2] * n2;
    *bound = DET_BOUND * ((fabs(a[0]) * s0 + fabs(a[1]) * s1) + fabs(a[2]) * s2);
    *area = sqrt((n0 * n0 + n1 * n1) + n2 * n2);
    *products = (s0 + s1) + s2;
}

/* The start of a pass: `out` cleared, the scaling set, and one result per block of faces
 * allocated (*blocks of them); NULL and a failure when memory ran out. */
void *kernel_start(const KernelInput *in, KernelResult *out, Scaling *scaling, int64_t *blocks, size_t block_size,
                   Failure *failure);
/* The end of a pass: -1 and a failure if a face refers to a vertex that does not exist. */
int kernel_bad_face(const KernelResult *out, Failure *failure);

/* det[a b c] as a double-double from error-free products, and the permanent. */
void det_double_double(const double a[3], const double b[3], const double c[3], double *hi, double *lo,
                       double *permanent);
/* The error of det_double_double's hi + lo relative to its permanent. */
double det_double_double_error(void);

#endif
