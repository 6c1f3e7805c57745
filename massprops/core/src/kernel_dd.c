/* The double-double pass, tetrahedra, per-shell sums, the box and the exact-shift check.
 *
 * The double-double pass is for meshes whose tetrahedra cancel heavily
 * (Σ|det| ≫ |Σ det|): every term — det, det·s, det·Q — is formed as a
 * double-double (relative error O(u²)) from error-free products, and all high
 * and low parts are added exactly (ExactSum), so the sums are accurate to
 * O(u) of the answer itself whatever the cancellation.
 */
#include "kernel.h"
#include "expansion.h"

#include <stdlib.h>
#include <string.h>

/* The vertex passes below are also compiled for AVX-512 and AVX2 (x86-64 Linux), picked when the module
 * loads: the same IEEE operations, the same bits. */
#if defined(__x86_64__) && defined(__linux__) && defined(__GNUC__) && !defined(__clang__)
#define PASS_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define PASS_CLONES
#endif

/* The error of hi + lo relative to the permanent P = Σ|major| (≥ (1 − γ5) of the exact Σ|major|).
 * lo is a float sum of 17 values (γ16 of their magnitudes): the 5 exact TwoSum errors of the
 * tree over the six major terms (≤ u of its partial sums, over 3 levels: ≤ 3u(1 + γ3) Σ|major|),
 * the six exact product errors (≤ u |major|) and the six minor terms (≤ u(1 + γ2) |major|); the
 * minor terms' own roundings add ≤ u²(1 + γ2) Σ|major|. */
double det_double_double_error(void)
{
    return (5.0 * gamma_k(16) + UNIT_ROUNDOFF) * UNIT_ROUNDOFF * (1.0 + gamma_k(12));
}

void det_double_double(const double a[3], const double b[3], const double c[3], double *hi, double *lo,
                       double *permanent)
{
    det_dd(a, b, c, hi, lo, permanent);
}

/* ---- the double-double pass ------------------------------------------------------------- */

enum { D_DET, D_F0, D_F1, D_F2, D_XX, D_YY, D_ZZ, D_XY, D_YZ, D_ZX, D_SUMMED };

typedef struct {
    ExactSum sums[D_SUMMED];
    double abs_det, permanent, weight_max;
    int64_t bad_face;
} DdBlock;

typedef struct {
    const KernelInput *in;
    Scaling scaling;
    DdBlock *blocks;
} DdWork;

static inline void add_dd(ExactSum *sum, dd x)
{
    exact_add(sum, x.hi);
    exact_add(sum, x.lo);
}

static void dd_block(void *arg, int64_t block)
{
    static const int pairs[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {1, 2}, {2, 0}};
    DdWork *w = arg;
    const KernelInput *in = w->in;
    DdBlock *r = &w->blocks[block];
    int64_t f, first = block * KERNEL_BLOCK, last = first + KERNEL_BLOCK;
    int q;
    if (last > in->m)
        last = in->m;
    r->abs_det = r->permanent = r->weight_max = 0.0;
    r->bad_face = -1;
    for (q = 0; q < D_SUMMED; q++)
        exact_init(&r->sums[q]);
    for (f = first; f < last; f++) {
        double corner[3][3], hi, lo, permanent;
        dd det, s[3];
        int i, k;
        if (load_face(in, &w->scaling, f, corner) != 0) {
            r->bad_face = f;
            return;
        }
        det_double_double(corner[0], corner[1], corner[2], &hi, &lo, &permanent);
        det = dd_of(hi, lo);
        if (in->weights) {
            double weight = in->weights[f];
            det = dd_mul(det, dd_of(weight, 0.0));
            permanent *= fabs(weight);
            if (fabs(weight) > r->weight_max)
                r->weight_max = fabs(weight);
        }
        r->abs_det += fabs(det.hi);
        r->permanent += permanent;
        add_dd(&r->sums[D_DET], det);
        if (in->order < 1)
            continue;
        for (i = 0; i < 3; i++) {
            double sum, error;
            two_sum(corner[0][i], corner[1][i], &sum, &error);
            s[i] = dd_add(dd_of(sum, error), dd_of(corner[2][i], 0.0));
            add_dd(&r->sums[D_F0 + i], dd_mul(det, s[i]));
        }
        if (in->order < 2)
            continue;
        for (q = 0; q < 6; q++) {
            int a = pairs[q][0], b = pairs[q][1];
            dd product = dd_mul(s[a], s[b]);
            for (k = 0; k < 3; k++) {
                double p, e;
                two_product(corner[k][a], corner[k][b], &p, &e);
                product = dd_add(product, dd_of(p, e));
            }
            add_dd(&r->sums[D_XX + q], dd_mul(det, product));
        }
    }
}

int integrate_faces_dd(const KernelInput *in, KernelResult *out, Failure *failure)
{
    int64_t blocks, b;
    DdWork w = {in, {0}, NULL};
    ExactSum sums[D_SUMMED], abs_det, permanent;
    double det_term, r = in->radius, tiny, weight_max = 0.0, largest;
    int q;
    if (!(w.blocks = kernel_start(in, out, &w.scaling, &blocks, sizeof *w.blocks, failure)))
        return -1;
    parallel_blocks(in->threads, blocks, dd_block, &w);
    for (q = 0; q < D_SUMMED; q++)
        exact_init(&sums[q]);
    exact_init(&abs_det);
    exact_init(&permanent);
    for (b = 0; b < blocks; b++) {
        if (w.blocks[b].bad_face >= 0 && out->bad_face < 0)
            out->bad_face = w.blocks[b].bad_face;
        for (q = 0; q < D_SUMMED; q++)
            exact_merge(&sums[q], &w.blocks[b].sums[q]);
        exact_add(&abs_det, w.blocks[b].abs_det);
        exact_add(&permanent, w.blocks[b].permanent);
        if (w.blocks[b].weight_max > weight_max)
            weight_max = w.blocks[b].weight_max;
    }
    free(w.blocks);
    if (kernel_bad_face(out, failure) != 0)
        return -1;
    /* The per-block sums of |det| and of the permanents are plain: within γ(block) of exact. */
    out->abs_sum = exact_value(&abs_det) * (1.0 + 2.0 * gamma_k(KERNEL_BLOCK));
    tiny = (double)in->m * UNDERFLOW_ALLOWANCE * (1.0 + weight_max);
    /* Per term: det to det_double_double_error() · permanent; each dd product or sum adds at
     * most 8u² relative of its operands' magnitudes; the exact sums round once at the end. */
    det_term = det_double_double_error() * exact_value(&permanent) * (1.0 + 2.0 * gamma_k(KERNEL_BLOCK))
               + 64.0 * UNIT_ROUNDOFF * UNIT_ROUNDOFF * out->abs_sum + tiny;
    out->det_sum = exact_value(&sums[D_DET]);
    out->det_error = det_term + UNIT_ROUNDOFF * fabs(out->det_sum);
    largest = 0.0;
    for (q = 0; q < 3; q++) {
        out->first[q] = exact_value(&sums[D_F0 + q]);
        largest = fabs(out->first[q]) > largest ? fabs(out->first[q]) : largest;
    }
    if (in->order >= 1)
        out->first_error = 3.0 * r * det_term * 4.0 + UNIT_ROUNDOFF * largest + tiny;
    largest = 0.0;
    for (q = 0; q < 6; q++) {
        out->second[q] = exact_value(&sums[D_XX + q]);
        largest = fabs(out->second[q]) > largest ? fabs(out->second[q]) : largest;
    }
    if (in->order >= 2)
        out->second_error = 12.0 * r * r * det_term * 8.0 + UNIT_ROUNDOFF * largest + tiny;
    out->det_error *= 1.0 + 0x1p-40;
    out->first_error *= 1.0 + 0x1p-40;
    out->second_error *= 1.0 + 0x1p-40;
    out->refined = in->m;
    return 0;
}

/* ---- tetrahedra ------------------------------------------------------------------------ */

int tetra_determinants(const KernelInput *in, double *det, double *bound, int64_t *bad_tet, Failure *failure)
{
    Scaling scaling;
    int64_t t;
    (void)failure;
    scaling_init(&scaling, in->scale_exp);
    *bad_tet = -1;
    for (t = 0; t < in->m; t++) {
        double p[4][3], e[3][3], pp[3], qq[3];
        int k, i;
        for (k = 0; k < 4; k++) {
            int64_t v = in->faces32 ? ((const int32_t *)in->faces)[4 * t + k] : ((const int64_t *)in->faces)[4 * t + k];
            if ((uint64_t)v >= (uint64_t)in->n) {
                *bad_tet = t;
                return -1;
            }
            for (i = 0; i < 3; i++)
                p[k][i] = scaled(in->vertices[3 * v + i], in->reference[i], &scaling);
        }
        for (k = 0; k < 3; k++)
            for (i = 0; i < 3; i++)
                e[k][i] = p[k + 1][i] - p[0][i];
        for (i = 0; i < 3; i++) {
            pp[i] = e[1][(i + 1) % 3] * e[2][(i + 2) % 3];
            qq[i] = e[1][(i + 2) % 3] * e[2][(i + 1) % 3];
        }
        det[t] = (e[0][0] * (pp[0] - qq[0]) + e[0][1] * (pp[1] - qq[1])) + e[0][2] * (pp[2] - qq[2]);
        /* Shewchuk's orient3d bound (all nine entries are rounded differences), plus underflow. */
        bound[t] = DET_BOUND * ((fabs(e[0][0]) * (fabs(pp[0]) + fabs(qq[0])) + fabs(e[0][1]) * (fabs(pp[1]) + fabs(qq[1])))
                                + fabs(e[0][2]) * (fabs(pp[2]) + fabs(qq[2]))) + UNDERFLOW_ALLOWANCE;
    }
    return 0;
}

/* ---- per-shell sums ------------------------------------------------------------------- */

int shell_determinants(const KernelInput *in, const int64_t *labels, int64_t shells, double *det_sum,
                       double *det_error, Failure *failure)
{
    Scaling scaling;
    double *lo = calloc((size_t)(shells > 0 ? shells : 1), 4 * sizeof(double));
    double *abs_sum, *bound_sum, *count;
    int64_t f, k;
    if (!lo) {
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    abs_sum = lo + shells;
    bound_sum = abs_sum + shells;
    count = bound_sum + shells;
    scaling_init(&scaling, in->scale_exp);
    for (k = 0; k < shells; k++)
        det_sum[k] = 0.0;
    for (f = 0; f < in->m; f++) {
        double corner[3][3], d, e, area, products, s, bp;
        int64_t shell = labels[f];
        if (load_face(in, &scaling, f, corner) != 0 || shell < 0 || shell >= shells) {
            free(lo);
            fail(failure, ERR_INDEX, "re-export the mesh", "a face refers to a vertex that does not exist");
            return -1;
        }
        det_and_bound(corner[0], corner[1], corner[2], &d, &e, &area, &products);
        s = det_sum[shell] + d;                              /* Sum2 per shell */
        bp = s - det_sum[shell];
        lo[shell] += (det_sum[shell] - (s - bp)) + (d - bp);
        det_sum[shell] = s;
        abs_sum[shell] += fabs(d);
        bound_sum[shell] += e;
        count[shell] += 1.0;
    }
    for (k = 0; k < shells; k++) {
        double g = gamma_k(count[k]), total = det_sum[k] + lo[k];
        det_error[k] = (bound_sum[k] * (1.0 + 2.0 * g) + g * g * abs_sum[k] * (1.0 + 2.0 * g)
                        + UNIT_ROUNDOFF * fabs(total) + count[k] * UNDERFLOW_ALLOWANCE) * (1.0 + 0x1p-40);
        det_sum[k] = total;
    }
    free(lo);
    return 0;
}

/* ---- the box and the exact shift ---------------------------------------------------------- */

void bounding_box(const double *vertices, int64_t n, double low[3], double high[3])
{
    /* in locals (the outputs might alias the input, so the compiler would store them at every step); a NaN
     * never replaces a value, and of equal values the first stays */
    double lx = HUGE_VAL, ly = HUGE_VAL, lz = HUGE_VAL, hx = -HUGE_VAL, hy = -HUGE_VAL, hz = -HUGE_VAL;
    int64_t v;
    for (v = 0; v < n; v++) {
        const double *p = vertices + 3 * v;
        lx = p[0] < lx ? p[0] : lx;
        ly = p[1] < ly ? p[1] : ly;
        lz = p[2] < lz ? p[2] : lz;
        hx = p[0] > hx ? p[0] : hx;
        hy = p[1] > hy ? p[1] : hy;
        hz = p[2] > hz ? p[2] : hz;
    }
    low[0] = lx, low[1] = ly, low[2] = lz;
    high[0] = hx, high[1] = hy, high[2] = hz;
}

/* Two vertices (six coordinates) at a time, with no branch, so that the loop vectorises: TwoSum's error
 * is zero exactly when the difference is exact, and it is NaN when the sum is (the test before was
 * `error != 0.0 || sum != sum`), so a coordinate is inexact exactly when its error's bits other than
 * the sign are not all zero; those bits are or-ed into a word per coordinate, looked at every
 * SHIFT_CHUNK vertices to stop once every axis is inexact. */
#define SHIFT_CHUNK 512

static inline uint64_t magnitude_bits(double x)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    return bits & 0x7FFFFFFFFFFFFFFFULL;
}

PASS_CLONES void shift_is_exact(const double *vertices, int64_t n, const double centre[3], int exact[3])
{
    const double minus[6] = {-centre[0], -centre[1], -centre[2], -centre[0], -centre[1], -centre[2]};
    uint64_t inexact[6] = {0, 0, 0, 0, 0, 0};
    int64_t v = 0, start, last;
    int i, j;
    for (start = 0; start < n; start = last) {
        last = n - start > SHIFT_CHUNK ? start + SHIFT_CHUNK : n;
        for (v = start; v + 2 <= last; v += 2) {
            const double *p = vertices + 3 * v;
            for (j = 0; j < 6; j++) {
                double sum, error;
                two_sum(p[j], minus[j], &sum, &error);
                inexact[j] |= magnitude_bits(error);
            }
        }
        if (v < last)                                  /* an odd vertex at the end */
            for (i = 0; i < 3; i++) {
                double sum, error;
                two_sum(vertices[3 * v + i], minus[i], &sum, &error);
                inexact[i] |= magnitude_bits(error);
            }
        if ((inexact[0] | inexact[3]) && (inexact[1] | inexact[4]) && (inexact[2] | inexact[5]))
            break;
    }
    for (i = 0; i < 3; i++)
        exact[i] = !(inexact[i] | inexact[i + 3]);
}

/* One coordinate scaled, snapped to zero below `smallest`; *tiny set when it was. */
static inline double scaled_snapped(double x, double reference, int multiply, double factor, int scale_exp,
                                    double smallest, int *tiny)
{
    double d = x - reference, y = multiply ? d * factor : ldexp(d, -scale_exp);
    int snap = y != 0.0 && fabs(y) < smallest;
    *tiny |= snap;
    return snap ? 0.0 : y;
}

PASS_CLONES int64_t scale_snapped(const double *vertices, int64_t n, const double reference[3], int scale_exp,
                                  double smallest, double *out, int64_t *moved)
{
    int64_t v, count = 0;
    int i, j, multiply = scale_exp >= -1023 && scale_exp <= 1022, any = 0;
    /* 2**-scale_exp when it is a normal double: one multiplication rounds as ldexp does (once, correctly) */
    double factor = multiply ? ldexp(1.0, -scale_exp) : 1.0;
    if (multiply) {
        /* two vertices at a time with no branch (vectorised); which vertices were snapped is found after,
         * in the rare case that any was */
        const double r[6] = {reference[0], reference[1], reference[2], reference[0], reference[1], reference[2]};
        int tiny[6] = {0, 0, 0, 0, 0, 0};
        for (v = 0; v + 2 <= n; v += 2)
            for (j = 0; j < 6; j++)
                out[3 * v + j] = scaled_snapped(vertices[3 * v + j], r[j], 1, factor, scale_exp, smallest, &tiny[j]);
        for (j = 0; j < 6; j++)
            any |= tiny[j];
        for (; v < n; v++)
            for (i = 0; i < 3; i++)
                out[3 * v + i] = scaled_snapped(vertices[3 * v + i], reference[i], 1, factor, scale_exp, smallest,
                                                &any);
        if (!any)
            return 0;
    }
    for (v = 0; v < n; v++) {
        int tiny = 0;
        for (i = 0; i < 3; i++)
            out[3 * v + i] = scaled_snapped(vertices[3 * v + i], reference[i], multiply, factor, scale_exp, smallest,
                                            &tiny);
        if (tiny)
            moved[count++] = v;
    }
    return count;
}
