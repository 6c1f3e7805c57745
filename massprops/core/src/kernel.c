/* The fast pass: each face's determinant with a certified bound, and the moment sums.
 *
 * For a face (a, b, c) of scaled coordinates, det = a . ((b - a) x (c - a)) =
 * det[a b c] with Shewchuk's bound DET_BOUND * permanent.  A face whose bound
 * exceeds 64 u |det| (a needle, a plate seen edge-on, a plane through the
 * reference point) is re-evaluated: from its other two corner rotations
 * (det is the same, the bound is not: a sliver's cross product cancels at
 * one corner, not at all), then in double-double, then exactly (expansion
 * arithmetic, correctly rounded).
 *
 * With the pair sums u = a + b, b + c, c + a (Σ u = 2 s, Σ u uᵀ = s sᵀ +
 * a aᵀ + b bᵀ + c cᵀ), each face adds
 *     det,   F_i = det (Σ_p u_p,i),   S_ij = det (Σ_p u_p,i u_p,j)
 * with relative rounding γ4 (F) and γ6 (S) of |det| Σ_p |u_p,i u_p,j| (at
 * most 6r and 12r² times |det|, r the largest scaled coordinate).  Faces are
 * processed eight at a time in lanes (so the compiler vectorises), and each
 * lane adds its terms with Sum2 (Ogita, Rump and Oishi: TwoSum into a high
 * part, the errors into a low part), whose error over N terms is at most
 * γ(N)² Σ|term|.  Lane results are stored per block and added exactly at the
 * end (ExactSum), so the totals are correctly rounded sums of the lane
 * results and do not depend on the thread count.
 */
#include "kernel.h"
#include "expansion.h"

#include <stdlib.h>
#include <string.h>

#define LANES 8

/* On x86-64 Linux the block loop and the hard faces' rotations are also compiled for AVX-512 (the
 * eight lanes in one vector) and AVX2 (four a vector instead of two), and the best the CPU has is
 * picked when the module loads; all do the same IEEE operations in the same order (no contraction,
 * no reassociation), so the results are the same bits. */
#if defined(__x86_64__) && defined(__linux__) && defined(__GNUC__) && !defined(__clang__)
#define VECTOR_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define VECTOR_CLONES
#endif

#define REFINE_ABOVE (64.0 * UNIT_ROUNDOFF)

enum { Q_DET, Q_F0, Q_F1, Q_F2, Q_XX, Q_YY, Q_ZZ, Q_XY, Q_YZ, Q_ZX, SUMMED };
enum { P_ABS, P_BOUND, P_AREA, PLAIN };

typedef struct {
    double hi[SUMMED][LANES], lo[SUMMED][LANES];
    double plain[PLAIN][LANES];
    double weight_max;                /* the largest |weight| in the block (underflow allowance) */
    int64_t refined, exact, bad_face;
} BlockResult;

typedef struct {
    const KernelInput *in;
    Scaling scaling;
    BlockResult *blocks;
    const double *scaled;             /* n x 3: the vertices in the frame, computed once (or given) */
} Work;

#define VERTEX_BLOCK 65536

static void scale_block(void *arg, int64_t block)
{
    Work *w = arg;
    double *out = (double *)w->scaled;
    int64_t v, last = (block + 1) * VERTEX_BLOCK < w->in->n ? (block + 1) * VERTEX_BLOCK : w->in->n;
    int i;
    for (v = block * VERTEX_BLOCK; v < last; v++)
        for (i = 0; i < 3; i++)
            out[3 * v + i] = scaled(w->in->vertices[3 * v + i], w->in->reference[i], &w->scaling);
}

void *kernel_start(const KernelInput *in, KernelResult *out, Scaling *scaling, int64_t *blocks, size_t block_size,
                   Failure *failure)
{
    void *results;
    *blocks = (in->m + KERNEL_BLOCK - 1) / KERNEL_BLOCK;
    memset(out, 0, sizeof *out);
    out->bad_face = -1;
    scaling_init(scaling, in->scale_exp);
    results = malloc((size_t)(*blocks > 0 ? *blocks : 1) * block_size);
    if (!results)
        fail(failure, ERR_MEMORY, NULL, "out of memory");
    return results;
}

int kernel_bad_face(const KernelResult *out, Failure *failure)
{
    if (out->bad_face < 0)
        return 0;
    fail(failure, ERR_INDEX, "re-export the mesh", "a face refers to a vertex that does not exist (face %lld)",
         (long long)out->bad_face);
    return -1;
}

void scaling_init(Scaling *s, int scale_exp)
{
    s->two = -scale_exp > 1023;            /* 2**-scale_exp would overflow: two exact steps */
    s->f1 = s->two ? 0x1p1000 : ldexp(1.0, -scale_exp);
    s->f2 = s->two ? ldexp(1.0, -scale_exp - 1000) : 1.0;
}

/* The exact det[a b c] rounded to nearest: 24 error-free terms added exactly. */
static double exact_det(const double a[3], const double b[3], const double c[3])
{
    static const int I[6] = {0, 1, 2, 0, 1, 2}, J[6] = {1, 2, 0, 2, 0, 1}, K[6] = {2, 0, 1, 1, 2, 0};
    ExactSum sum;
    int t;
    exact_init(&sum);
    for (t = 0; t < 6; t++) {
        double p, pe, x1, x2, x3, x4, ck = t < 3 ? c[K[t]] : -c[K[t]];
        two_product(a[I[t]], b[J[t]], &p, &pe);
        two_product(p, ck, &x1, &x2);
        two_product(pe, ck, &x3, &x4);
        exact_add(&sum, x1);
        exact_add(&sum, x2);
        exact_add(&sum, x3);
        exact_add(&sum, x4);
    }
    return exact_value(&sum);
}

/* Lane accumulators of one block: Sum2 (hi, lo) per summed quantity, plain sums for the rest. */
typedef struct {
    double hi[SUMMED][LANES], lo[SUMMED][LANES];
    double plain[PLAIN][LANES];
} Lanes;

static inline void sum2(double *restrict hi, double *restrict lo, const double *restrict x)
{
    int l;
    for (l = 0; l < LANES; l++) {
        double h = hi[l], s = h + x[l], b = s - h;
        lo[l] += (h - (s - b)) + (x[l] - b);
        hi[l] = s;
    }
}

/* det · Σ_p u_p,i u_p,j over the three pairs, added to quantity q. */
static inline void second_term(Lanes *acc, int q, const double *restrict det, double u[3][3][LANES], int i, int j)
{
    double x[LANES];
    int l;
    for (l = 0; l < LANES; l++)
        x[l] = det[l] * ((u[0][i][l] * u[0][j][l] + u[1][i][l] * u[1][j][l]) + u[2][i][l] * u[2][j][l]);
    sum2(acc->hi[q], acc->lo[q], x);
}

/* The scaled corners of LANES faces, one array per corner and axis (structure of arrays). */
typedef struct {
    double p[3][3][LANES];                   /* [corner][axis][lane] */
} Corners;

/* det_and_bound (kernel.h) of the lanes' faces taken from corner `first` on ((first, first + 1, first + 2)
 * mod 3), lane by lane so that it vectorises (inlined: the same bits as the function's). */
static inline __attribute__((always_inline)) void lanes_det_and_bound(const Corners *restrict c, int first,
                                                                    double *restrict det, double *restrict bound,
                                                                    double *restrict area, double *restrict products)
{
    const int j = (first + 1) % 3, k = (first + 2) % 3;
    for (int l = 0; l < LANES; l++) {
        const double a[3] = {c->p[first][0][l], c->p[first][1][l], c->p[first][2][l]};
        const double b[3] = {c->p[j][0][l], c->p[j][1][l], c->p[j][2][l]};
        const double d[3] = {c->p[k][0][l], c->p[k][1][l], c->p[k][2][l]};
        double x, e, n, s;
        det_and_bound(a, b, d, &x, &e, &n, &s);
        det[l] = x, bound[l] = e, area[l] = n, products[l] = s;
    }
}

/* det_double_double (kernel_dd.c) of every lane's face, lane by lane so that it vectorises (det_dd
 * inlined: the same bits as the function's). */
static inline __attribute__((always_inline)) void lanes_det_double_double(const Corners *restrict c,
                                                                        double *restrict hi, double *restrict lo,
                                                                        double *restrict permanent)
{
    for (int l = 0; l < LANES; l++) {
        const double a[3] = {c->p[0][0][l], c->p[0][1][l], c->p[0][2][l]};
        const double b[3] = {c->p[1][0][l], c->p[1][1][l], c->p[1][2][l]};
        const double d[3] = {c->p[2][0][l], c->p[2][1][l], c->p[2][2][l]};
        double h, e, sum;
        det_dd(a, b, d, &h, &e, &sum);
        hi[l] = h, lo[l] = e, permanent[l] = sum;
    }
}

/* The hard faces among `count` lanes: each takes the best of its three rotations (the first with the
 * least bound), and double-double or exact arithmetic if that is still hard (the double-double
 * determinant of all lanes at once when any needs it).  The other two rotations are
 * found for all lanes at once (hard faces come in runs: slivers, flat parts). */
VECTOR_CLONES static __attribute__((noinline)) void hard_faces(const Corners *restrict c, int count, double *restrict det,
                                                double *restrict bound, BlockResult *r)
{
    double det1[LANES], bound1[LANES], det2[LANES], bound2[LANES], hi[LANES], lo[LANES], permanent[LANES];
    double area[LANES], products[LANES];       /* not used here */
    int l, k, i, still = 0, hard[LANES] = {0};
    lanes_det_and_bound(c, 1, det1, bound1, area, products);
    lanes_det_and_bound(c, 2, det2, bound2, area, products);
    for (l = 0; l < count; l++)
        if (bound[l] > REFINE_ABOVE * fabs(det[l])) {
            if (bound1[l] < bound[l]) {
                det[l] = det1[l];
                bound[l] = bound1[l];
            }
            if (bound2[l] < bound[l]) {
                det[l] = det2[l];
                bound[l] = bound2[l];
            }
            hard[l] = bound[l] > REFINE_ABOVE * fabs(det[l]);
            still |= hard[l];
        }
    if (!still)
        return;
    lanes_det_double_double(c, hi, lo, permanent);
    for (l = 0; l < count; l++)
        if (hard[l]) {
            /* hi + lo is within det_double_double_error() * permanent; rounding it adds u |d|. */
            double d = hi[l] + lo[l], e = UNIT_ROUNDOFF * fabs(d) + det_double_double_error() * permanent[l];
            r->refined++;
            if (e <= REFINE_ABOVE * fabs(d) && e < bound[l]) {
                det[l] = d;
                bound[l] = e;
            } else {
                double corner[3][3];
                for (k = 0; k < 3; k++)
                    for (i = 0; i < 3; i++)
                        corner[k][i] = c->p[k][i][l];
                det[l] = exact_det(corner[0], corner[1], corner[2]);
                bound[l] = UNIT_ROUNDOFF * fabs(det[l]);
                r->exact++;
            }
        }
}

/* LANES faces from f0 (count of them real; the rest contribute zeros).  Returns 0, or -1 and
 * the bad face in r->bad_face when an index is out of range. */
static inline __attribute__((always_inline)) int lane_batch(const Work *w, int64_t f0, int count, Lanes *acc,
                                                         BlockResult *r)
{
    const KernelInput *in = w->in;
    Corners c;
    double det[LANES], bound[LANES], area[LANES], products[LANES], x[LANES];
    int l, k, i, hard = 0;
    for (l = 0; l < LANES; l++) {
        int64_t v[3] = {0, 0, 0};
        if (l < count) {
            for (k = 0; k < 3; k++) {
                v[k] = face_vertex(in, 3 * (f0 + l) + k);
                if ((uint64_t)v[k] >= (uint64_t)in->n) {
                    r->bad_face = f0 + l;
                    return -1;
                }
            }
        }
        for (k = 0; k < 3; k++)
            for (i = 0; i < 3; i++)
                c.p[k][i][l] = l < count ? w->scaled[3 * v[k] + i] : 0.0;
    }
    lanes_det_and_bound(&c, 0, det, bound, area, products);
    for (l = 0; l < LANES; l++)
        hard |= bound[l] > REFINE_ABOVE * fabs(det[l]);
    if (in->area_measure) {
        for (l = 0; l < LANES; l++) {
            /* |n| from the rounded cross product: γ3 of its components' products, γ3 for the length. */
            bound[l] = gamma_k(6) * products[l] + gamma_k(3) * area[l];
            det[l] = area[l];
        }
    } else if (hard) {
        hard_faces(&c, count, det, bound, r);
    }
    if (in->weights)
        for (l = 0; l < LANES; l++) {
            double weight = l < count ? in->weights[f0 + l] : 0.0;
            if (fabs(weight) > r->weight_max)
                r->weight_max = fabs(weight);
            det[l] *= weight;
            bound[l] = fabs(weight) * bound[l] * (1.0 + 2.0 * UNIT_ROUNDOFF) + 2.0 * UNIT_ROUNDOFF * fabs(det[l]);
        }
    sum2(acc->hi[Q_DET], acc->lo[Q_DET], det);
    for (l = 0; l < LANES; l++) {
        acc->plain[P_ABS][l] += fabs(det[l]);
        acc->plain[P_BOUND][l] += bound[l];
        acc->plain[P_AREA][l] += area[l];
    }
    if (in->order >= 1) {
        /* the pair sums u = a + b, b + c, c + a, per axis */
        double u[3][3][LANES];                /* [pair][axis][lane] */
        for (i = 0; i < 3; i++)
            for (l = 0; l < LANES; l++) {
                u[0][i][l] = c.p[0][i][l] + c.p[1][i][l];
                u[1][i][l] = c.p[1][i][l] + c.p[2][i][l];
                u[2][i][l] = c.p[2][i][l] + c.p[0][i][l];
            }
        for (i = 0; i < 3; i++) {
            for (l = 0; l < LANES; l++)
                x[l] = det[l] * ((u[0][i][l] + u[1][i][l]) + u[2][i][l]);
            sum2(acc->hi[Q_F0 + i], acc->lo[Q_F0 + i], x);
        }
        if (in->order >= 2) {
            second_term(acc, Q_XX, det, u, 0, 0);
            second_term(acc, Q_YY, det, u, 1, 1);
            second_term(acc, Q_ZZ, det, u, 2, 2);
            second_term(acc, Q_XY, det, u, 0, 1);
            second_term(acc, Q_YZ, det, u, 1, 2);
            second_term(acc, Q_ZX, det, u, 2, 0);
        }
    }
    return 0;
}

VECTOR_CLONES static void run_block(void *arg, int64_t block)
{
    Work *w = arg;
    BlockResult *r = &w->blocks[block];
    Lanes acc;
    int64_t f, first = block * KERNEL_BLOCK, last = first + KERNEL_BLOCK;
    if (last > w->in->m)
        last = w->in->m;
    memset(r, 0, sizeof *r);
    memset(&acc, 0, sizeof acc);
    r->bad_face = -1;
    for (f = first; f < last; f += LANES)
        if (lane_batch(w, f, (int)(last - f < LANES ? last - f : LANES), &acc, r) != 0)
            break;
    memcpy(r->hi, acc.hi, sizeof acc.hi);
    memcpy(r->lo, acc.lo, sizeof acc.lo);
    memcpy(r->plain, acc.plain, sizeof acc.plain);
}

static double largest(const double *values, int count)
{
    double m = 0.0;
    int k;
    for (k = 0; k < count; k++)
        if (fabs(values[k]) > m)
            m = fabs(values[k]);
    return m;
}

int integrate_faces(const KernelInput *in, KernelResult *out, Failure *failure)
{
    int64_t blocks, b;
    Work w = {in, {0}, NULL, NULL};
    ExactSum summed[SUMMED], plain[PLAIN];
    double g, sum2, abs_up, bound_up, r = in->radius, tiny, F[3], weight_max = 0.0;
    int q, l;
    if (!(w.blocks = kernel_start(in, out, &w.scaling, &blocks, sizeof *w.blocks, failure)))
        return -1;
    /* the caller's copy when it has one (the exact checks scale the same vertices the same way) */
    double *own = in->scaled ? NULL : malloc((size_t)(in->n > 0 ? in->n : 1) * 3 * sizeof(double));
    if (!in->scaled && !own) {
        free(w.blocks);
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    w.scaled = in->scaled ? in->scaled : own;
    if (own)
        parallel_blocks(in->threads, (in->n + VERTEX_BLOCK - 1) / VERTEX_BLOCK, scale_block, &w);
    parallel_blocks(in->threads, blocks, run_block, &w);
    free(own);
    for (q = 0; q < SUMMED; q++)
        exact_init(&summed[q]);
    for (q = 0; q < PLAIN; q++)
        exact_init(&plain[q]);
    for (b = 0; b < blocks; b++) {
        const BlockResult *r_ = &w.blocks[b];
        if (r_->bad_face >= 0 && out->bad_face < 0)
            out->bad_face = r_->bad_face;
        out->refined += r_->refined;
        if (r_->weight_max > weight_max)
            weight_max = r_->weight_max;
        out->exact += r_->exact;
        for (l = 0; l < LANES; l++) {
            for (q = 0; q < SUMMED; q++) {
                exact_add(&summed[q], r_->hi[q][l]);
                exact_add(&summed[q], r_->lo[q][l]);
            }
            for (q = 0; q < PLAIN; q++)
                exact_add(&plain[q], r_->plain[q][l]);
        }
    }
    free(w.blocks);
    if (kernel_bad_face(out, failure) != 0)
        return -1;
    /* Each lane adds at most N = KERNEL_BLOCK / LANES terms per block, plainly (abs, bound)
     * or by Sum2 (the rest): plain sums of non-negative terms are within γ(N) of exact. */
    g = gamma_k(KERNEL_BLOCK / LANES);
    sum2 = g * g;
    abs_up = exact_value(&plain[P_ABS]) * (1.0 + 2.0 * g);
    bound_up = exact_value(&plain[P_BOUND]) * (1.0 + 2.0 * g);
    tiny = (double)in->m * UNDERFLOW_ALLOWANCE * (1.0 + weight_max);
    out->abs_sum = abs_up;
    out->area2 = exact_value(&plain[P_AREA]);
    out->det_sum = exact_value(&summed[Q_DET]);
    out->det_error = bound_up + sum2 * abs_up + UNIT_ROUNDOFF * fabs(out->det_sum) + tiny;
    for (q = 0; q < 3; q++)
        F[q] = exact_value(&summed[Q_F0 + q]);
    for (q = 0; q < 6; q++)
        out->second[q] = exact_value(&summed[Q_XX + q]);
    if (in->order >= 1) {
        /* F = Σ det (Σ_p u_p) = 2 Σ det s; first = F / 2 (exact). */
        double error = 6.0 * r * (bound_up + gamma_k(4) * abs_up) + sum2 * 6.0 * r * (1.0 + gamma_k(4)) * abs_up
                       + UNIT_ROUNDOFF * largest(F, 3) + tiny * (6.0 * r + 1.0);
        for (q = 0; q < 3; q++)
            out->first[q] = 0.5 * F[q];
        out->first_error = 0.5 * error;
    }
    if (in->order >= 2)
        out->second_error = 12.0 * r * r * (bound_up + gamma_k(6) * abs_up)
                            + sum2 * 12.0 * r * r * (1.0 + gamma_k(6)) * abs_up
                            + UNIT_ROUNDOFF * largest(out->second, 6) + tiny * (12.0 * r * r + 1.0);
    /* The bounds are themselves computed in floating point: a margin for their own roundings. */
    out->det_error *= 1.0 + 0x1p-40;
    out->first_error *= 1.0 + 0x1p-40;
    out->second_error *= 1.0 + 0x1p-40;
    return 0;
}
