/* Error-free transformations and exact sums of doubles.
 *
 * two_sum (Knuth) and two_product (Dekker, with Veltkamp's split) return a
 * rounded result and its exact rounding error, provided nothing overflows and
 * (for the product) nothing underflows; both need plain IEEE double
 * operations, which the build guarantees (-ffp-contract=off, no fast-math).
 * ExactSum keeps Shewchuk's non-overlapping partials, as Python's math.fsum
 * does, so its total is the correctly rounded value of the exact sum of
 * everything added, in any order.
 */
#ifndef MASSPROPS_EXPANSION_H
#define MASSPROPS_EXPANSION_H

#include <math.h>

#define UNIT_ROUNDOFF 0x1p-53

static inline double gamma_k(double k) { return k * UNIT_ROUNDOFF / (1.0 - k * UNIT_ROUNDOFF); }

static inline void two_sum(double a, double b, double *s, double *e)
{
    double sum = a + b;
    double bb = sum - a;
    *e = (a - (sum - bb)) + (b - bb);
    *s = sum;
}

static inline void fast_two_sum(double a, double b, double *s, double *e)
{
    double sum = a + b;
    *e = b - (sum - a);
    *s = sum;
}

static inline void split(double a, double *high, double *low)
{
    double t = 134217729.0 * a;          /* 2**27 + 1 */
    *high = t - (t - a);
    *low = a - *high;
}

static inline void two_product(double a, double b, double *p, double *e)
{
    double ah, al, bh, bl;
    double product = a * b;
    split(a, &ah, &al);
    split(b, &bh, &bl);
    *e = ((ah * bh - product) + ah * bl + al * bh) + al * bl;
    *p = product;
}

/* Double-double arithmetic (hi + lo, |lo| <= ulp(hi)/2). */
typedef struct { double hi, lo; } dd;

static inline dd dd_add(dd x, dd y)
{
    dd r;
    double s, e;
    two_sum(x.hi, y.hi, &s, &e);
    fast_two_sum(s, e + (x.lo + y.lo), &r.hi, &r.lo);
    return r;
}

static inline dd dd_mul(dd x, dd y)
{
    dd r;
    double p, e;
    two_product(x.hi, y.hi, &p, &e);
    fast_two_sum(p, e + (x.hi * y.lo + x.lo * y.hi), &r.hi, &r.lo);
    return r;
}

static inline dd dd_of(double hi, double lo) { dd r = {hi, lo}; return r; }

/* det[a b c] = Σ sign · a_i b_j c_k over the six permutations (i, j, k), as a double-double hi + lo
 * from error-free products, and the permanent Σ|major| (the error is det_double_double_error()'s,
 * kernel_dd.c).  Inline: the kernel's lanes (kernel.c) call it lane by lane in a loop the compiler
 * vectorises; the same operations in the same order, the same bits. */
static inline __attribute__((always_inline)) void det_dd(const double a[3], const double b[3], const double c[3],
                                                         double *hi, double *lo, double *permanent)
{
    static const int I[6] = {0, 1, 2, 0, 1, 2}, J[6] = {1, 2, 0, 2, 0, 1}, K[6] = {2, 0, 1, 1, 2, 0};
    double major[6], rest[17], t01, t2, root, sum = 0.0;
    int t, n = 0;
    for (t = 0; t < 6; t++) {
        double p, pe, ck = t < 3 ? c[K[t]] : -c[K[t]];
        two_product(a[I[t]], b[J[t]], &p, &pe);
        two_product(p, ck, &major[t], &rest[n++]);
        rest[n++] = pe * ck;
        sum += fabs(major[t]);
    }
    /* the tree: (m0 + m3), (m1 + m4), (m2 + m5); then the first two; then the third */
    two_sum(major[0], major[3], &major[0], &rest[n++]);
    two_sum(major[1], major[4], &major[1], &rest[n++]);
    two_sum(major[2], major[5], &major[2], &rest[n++]);
    two_sum(major[0], major[1], &t01, &rest[n++]);
    two_sum(t01, major[2], &root, &rest[n++]);
    t2 = 0.0;
    for (t = 0; t < 17; t++)
        t2 += rest[t];
    fast_two_sum(root, t2, hi, lo);
    *permanent = sum;
}

/* Exact running sum: non-overlapping partials in increasing magnitude (Shewchuk, as
 * CPython's math.fsum).  At most ~40 partials can be non-overlapping for finite doubles;
 * a non-finite input makes the sum special (NaN or the infinity, as IEEE addition). */
#define EXACT_PARTIALS 64

typedef struct {
    double partials[EXACT_PARTIALS];
    int n;
    double special;           /* 0 while every input is finite; else the IEEE sum of the non-finite ones */
    int has_special;
} ExactSum;

static inline void exact_init(ExactSum *s) { s->n = 0; s->special = 0.0; s->has_special = 0; }

static inline void exact_add(ExactSum *s, double x)
{
    int i, j = 0;
    if (!isfinite(x)) {
        s->special = s->has_special ? s->special + x : x;
        s->has_special = 1;
        return;
    }
    for (i = 0; i < s->n; i++) {
        double y = s->partials[i];
        double hi, lo;
        if (fabs(x) < fabs(y)) { double t = x; x = y; y = t; }
        hi = x + y;
        if (!isfinite(hi)) {         /* the partial sums overflow: so does the rounded total */
            s->special = s->has_special ? s->special + hi : hi;
            s->has_special = 1;
            s->n = 0;
            return;
        }
        lo = y - (hi - x);
        if (lo != 0.0)
            s->partials[j++] = lo;
        x = hi;
    }
    s->partials[j++] = x;            /* j <= EXACT_PARTIALS: partials never overlap */
    s->n = j;
}

static inline void exact_merge(ExactSum *into, const ExactSum *from)
{
    int i;
    for (i = 0; i < from->n; i++)
        exact_add(into, from->partials[i]);
    if (from->has_special)
        exact_add(into, from->special);
}

/* The exact sum rounded to nearest, ties to even (CPython's math.fsum, step for step). */
static inline double exact_value(const ExactSum *s)
{
    double hi = 0.0, lo = 0.0, x, y;
    int n = s->n;
    if (s->has_special)
        return s->special;
    if (n > 0) {
        hi = s->partials[--n];
        while (n > 0) {
            x = hi;
            y = s->partials[--n];
            hi = x + y;
            lo = y - (hi - x);
            if (lo != 0.0)
                break;
        }
        /* Round half-even when the rest has the same sign as the rounding error. */
        if (n > 0 && ((lo < 0.0 && s->partials[n - 1] < 0.0) || (lo > 0.0 && s->partials[n - 1] > 0.0))) {
            y = lo * 2.0;
            x = hi + y;
            if (y == x - hi)
                hi = x;
        }
    }
    return hi;
}

#endif
