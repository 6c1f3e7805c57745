/* The cut stage of the arrangement (massprops/mesh/arrangement.py), in C.
 *
 * For every pair of faces that meet, the segment where they meet (as `_crossing`); for every
 * face with segments, its convex cells (as `_cells` / `_split`: each segment cuts, along its
 * whole line, the cells it enters).  Intersection points are never rounded for a decision:
 * they stay implicit, as in Cherchi et al. 2020 ("Fast and robust mesh arrangements using
 * floating-point arithmetic"):
 *
 *   LPI(P, Q, g)    the line through input vertices P, Q with the plane of face g;
 *   EE(P, Q, R, S)  two lines through input vertices, in the plane of the face being cut;
 *   TPI(t, g, h)    the planes of three faces;
 *   PROJ(x, y)      the point of the cut face's plane over (x, y) (its projection's axes).
 *
 * In the face being cut, every line is the line through two input vertices (E) or the plane of
 * another face (U), kept once per face (lines equal exactly are one).  Every decision is the sign
 * of a point against a line.  Input vertices are decided exactly (orient2d, orient3d of
 * predicates.h); a point built on a line is on it (symbolically); an LPI against a plane is
 * decided from the exact sides of P and Q where these settle it; everything else is a
 * floating-point evaluation carrying a certified absolute error bound (type `fx`).  When a sign
 * is not certain, the face (or both faces of a pair) is handed back: the caller cuts it with its
 * exact rational path.  So every cell returned is the one the exact path would find.
 *
 * Cells are returned with their corners (input vertices by index, new points rounded once with
 * a certified bound on each coordinate's error, and their definitions, so that the points the
 * solid keeps are rounded again from their exact values: refine_points, with error-free
 * expansions) and, for the labels, points strictly inside: PROJ points over double (x, y),
 * certified inside every edge, which the caller rebuilds exactly in rationals.
 *
 * Also here: the labels' ray counts (label_queries: winding numbers at those points, by the exact
 * path's rules, with the same filter and hand-back) and the patches of uncut faces (patch_labels).
 */
#include "isect.h"

#include <stdlib.h>
#include <string.h>

/* ---- numbers with a certified absolute error ------------------------------------------------ */

/* v approximates the exact value within e.  Each operation adds its rounding (|result| u), the
 * propagated errors and 2**-1000 (which covers underflow); the bound's own rounding (at most a
 * few relative u over a few operations) is covered by the factor 1 + 16u. */
typedef struct {
    double v, e;
} fx;

#define FX_GROW (1.0 + 0x1p-49)
#define FX_TINY 0x1p-1000

static inline fx fx_c(double x)
{
    fx r = {x, 0.0};
    return r;
}

static inline fx fx_add(fx a, fx b)
{
    double s = a.v + b.v;
    fx r = {s, (a.e + b.e + fabs(s) * EPS) * FX_GROW + FX_TINY};
    return r;
}

static inline fx fx_sub(fx a, fx b)
{
    double s = a.v - b.v;
    fx r = {s, (a.e + b.e + fabs(s) * EPS) * FX_GROW + FX_TINY};
    return r;
}

static inline fx fx_mul(fx a, fx b)
{
    double p = a.v * b.v;
    fx r = {p, (fabs(a.v) * b.e + fabs(b.v) * a.e + a.e * b.e + fabs(p) * EPS) * FX_GROW + FX_TINY};
    return r;
}

static inline fx fx_neg(fx a)
{
    a.v = -a.v;
    return a;
}

/* The exact value's sign, or 0 when the bound does not settle it (also for NaN and infinities). */
static inline int fx_sign(fx a) { return a.v > a.e ? 1 : (-a.v > a.e ? -1 : 0); }

static inline fx fx_diff(double a, double b) { return fx_sub(fx_c(a), fx_c(b)); }

/* ---- the shared input ----------------------------------------------------------------------- */

typedef struct {
    int8_t kind;              /* 0: vertex a; 1: LPI(a, b, plane of g) */
    int64_t a, b, g;
} End;

enum { PAIR_NONE = 0, PAIR_SEGMENT = 1, PAIR_COPLANAR = 2, PAIR_UNSURE = -1 };

typedef struct {
    const double *V;
    const int64_t *F;
    int64_t n, m, p;
    const int64_t *pairs;     /* 2 per pair */
    fx *normal;               /* 3 per face: (b - a) x (c - a) */
    int8_t *kind;             /* per pair */
    End *ends;                /* 2 per pair: the segment's ends */
    int64_t *begin, *list;    /* faces' pairs (CSR, in pair order) */
    int8_t *status;           /* per face: 0 not cut, 1 cut here, 2 handed back */
    int8_t *drop;             /* per face: the axis its projection drops */
} Shared;

static inline const double *vx(const Shared *s, int64_t v) { return s->V + 3 * v; }
static inline const double *corner(const Shared *s, int64_t f, int k) { return s->V + 3 * s->F[3 * f + k]; }

/* Exact side of an input point against the plane of face f: the sign of n_f . (x - a_f). */
static inline int plane_side(const Shared *s, int64_t f, const double *x)
{
    return -orient3d(corner(s, f, 0), corner(s, f, 1), corner(s, f, 2), x);
}

/* n_f . (x - a_f), certified. */
static fx plane_level(const Shared *s, int64_t f, const double *x)
{
    const fx *n = s->normal + 3 * f;
    const double *a = corner(s, f, 0);
    fx r = fx_mul(n[0], fx_diff(x[0], a[0]));
    r = fx_add(r, fx_mul(n[1], fx_diff(x[1], a[1])));
    return fx_add(r, fx_mul(n[2], fx_diff(x[2], a[2])));
}

static void face_normal(const Shared *s, int64_t f)
{
    const double *a = corner(s, f, 0), *b = corner(s, f, 1), *c = corner(s, f, 2);
    fx u[3], w[3];
    for (int k = 0; k < 3; k++) {
        u[k] = fx_diff(b[k], a[k]);
        w[k] = fx_diff(c[k], a[k]);
    }
    fx *n = s->normal + 3 * f;
    n[0] = fx_sub(fx_mul(u[1], w[2]), fx_mul(u[2], w[1]));
    n[1] = fx_sub(fx_mul(u[2], w[0]), fx_mul(u[0], w[2]));
    n[2] = fx_sub(fx_mul(u[0], w[1]), fx_mul(u[1], w[0]));
}

/* ---- points ---------------------------------------------------------------------------------- */

enum { PT_V, PT_LPI, PT_EE, PT_TPI, PT_PROJ };

typedef struct {
    int8_t kind;
    int8_t flip;              /* W was negated to make it positive */
    int8_t sg[2];             /* LPI: exact sides of a, b against plane g */
    int l1, l2;               /* lines of the face it is known to lie on (-1: none) */
    int64_t a, b, c, d;       /* V: a; LPI: a, b, plane g = c; EE: a, b, c, d; TPI: faces a, b, c */
    fx s[2];                  /* LPI: levels of a, b against plane g */
    fx X[3], W;               /* homogeneous, W > 0 certified (not for V) */
    fx D[3];                  /* X - W * (input vertex `origin`): the offset from a nearby vertex, times W */
    int64_t origin;
    int64_t out;              /* index among the points returned, -1 until it is */
} Pt;

/* Make W positive; 0 when its sign is not certain. */
static int normalise(Pt *p)
{
    int sw = fx_sign(p->W);
    if (sw == 0)
        return 0;
    p->flip = sw < 0;
    if (sw < 0) {
        p->W = fx_neg(p->W);
        for (int k = 0; k < 3; k++) {
            p->X[k] = fx_neg(p->X[k]);
            p->D[k] = fx_neg(p->D[k]);
        }
    }
    return 1;
}

/* A fresh point of this kind on lines l1, l2, not yet output. */
static void start_point(Pt *p, int kind, int l1, int l2)
{
    memset(p, 0, sizeof(*p));
    p->kind = (int8_t)kind;
    p->l1 = l1, p->l2 = l2;
    p->out = -1;
}

/* The point o + D / W, o the coordinates of input vertex `origin` (W and D set): X = o W + D, normalised. */
static int finish_point(Pt *p, int64_t origin, const double *o)
{
    p->origin = origin;
    for (int k = 0; k < 3; k++)
        p->X[k] = fx_add(fx_mul(fx_c(o[k]), p->W), p->D[k]);
    return normalise(p);
}

static void make_vertex(Pt *p, int64_t v, int l1, int l2)
{
    start_point(p, PT_V, l1, l2);
    p->a = v;
}

/* The line through P, Q with the plane of g: X = P W + sP (Q - P), W = sP - sQ. */
static int make_lpi(const Shared *s, Pt *p, int64_t P, int64_t Q, int64_t g, int l1, int l2)
{
    start_point(p, PT_LPI, l1, l2);
    p->a = P, p->b = Q, p->c = g;
    const double *x = vx(s, P), *y = vx(s, Q);
    p->sg[0] = (int8_t)plane_side(s, g, x);
    p->sg[1] = (int8_t)plane_side(s, g, y);
    if (p->sg[0] == 0 && p->sg[1] == 0)
        return 0;             /* in the plane: no one point (P and Q may lie on one side: the line still meets it) */
    p->s[0] = plane_level(s, g, x);
    p->s[1] = plane_level(s, g, y);
    p->W = fx_sub(p->s[0], p->s[1]);
    for (int k = 0; k < 3; k++)
        p->D[k] = fx_mul(p->s[0], fx_diff(y[k], x[k]));
    return finish_point(p, P, x);
}

/* Lines PQ and RS of one plane, met in the projection on axes i, j. */
static int make_ee(const Shared *s, Pt *p, int64_t P, int64_t Q, int64_t R, int64_t S, int i, int j, int l1, int l2)
{
    start_point(p, PT_EE, l1, l2);
    p->a = P, p->b = Q, p->c = R, p->d = S;
    const double *x = vx(s, P), *y = vx(s, Q), *r = vx(s, R), *q = vx(s, S);
    fx di = fx_diff(y[i], x[i]), dj = fx_diff(y[j], x[j]);
    fx ei = fx_diff(q[i], r[i]), ej = fx_diff(q[j], r[j]);
    fx ri = fx_diff(r[i], x[i]), rj = fx_diff(r[j], x[j]);
    p->W = fx_sub(fx_mul(di, ej), fx_mul(dj, ei));
    fx num = fx_sub(fx_mul(ri, ej), fx_mul(rj, ei));
    for (int k = 0; k < 3; k++)
        p->D[k] = fx_mul(num, fx_diff(y[k], x[k]));
    return finish_point(p, P, x);
}

static void fx_cross(const fx *u, const fx *w, fx *out)
{
    out[0] = fx_sub(fx_mul(u[1], w[2]), fx_mul(u[2], w[1]));
    out[1] = fx_sub(fx_mul(u[2], w[0]), fx_mul(u[0], w[2]));
    out[2] = fx_sub(fx_mul(u[0], w[1]), fx_mul(u[1], w[0]));
}

static fx fx_dot(const fx *u, const fx *w)
{
    return fx_add(fx_add(fx_mul(u[0], w[0]), fx_mul(u[1], w[1])), fx_mul(u[2], w[2]));
}

/* The planes of faces f, g, h, about the origin a_f (so the offsets are small where the faces are). */
static int make_tpi(const Shared *s, Pt *p, int64_t f, int64_t g, int64_t h, int l1, int l2)
{
    start_point(p, PT_TPI, l1, l2);
    p->a = f, p->b = g, p->c = h;
    const double *o = corner(s, f, 0);
    const fx *n1 = s->normal + 3 * f, *n2 = s->normal + 3 * g, *n3 = s->normal + 3 * h;
    fx d2 = plane_level(s, g, o), d3 = plane_level(s, h, o);
    /* planes n . (x - o) = -level(o) for g, h, and 0 for f */
    d2 = fx_neg(d2), d3 = fx_neg(d3);
    fx c23[3], c31[3], c12[3];
    fx_cross(n2, n3, c23);
    fx_cross(n3, n1, c31);
    fx_cross(n1, n2, c12);
    p->W = fx_dot(n1, c23);
    for (int k = 0; k < 3; k++)
        p->D[k] = fx_add(fx_mul(d2, c31[k]), fx_mul(d3, c12[k]));
    return finish_point(p, s->F[3 * f], o);
}

/* The point of the plane n . (q - a) = 0 over (x, y) on axes i, j (dropping axis `drop`). */
static int make_proj_n(Pt *p, const fx *n, const double *a, int drop, int i, int j, double x, double y)
{
    start_point(p, PT_PROJ, -1, -1);
    p->W = n[drop];
    p->X[i] = fx_mul(fx_c(x), n[drop]);
    p->X[j] = fx_mul(fx_c(y), n[drop]);
    /* n_d q_d = n_d a_d - n_i (x - a_i) - n_j (y - a_j) */
    p->X[drop] = fx_sub(fx_sub(fx_mul(n[drop], fx_c(a[drop])), fx_mul(n[i], fx_diff(x, a[i]))),
                        fx_mul(n[j], fx_diff(y, a[j])));
    return normalise(p);
}

/* The point of face f's plane over (x, y). */
static int make_proj(const Shared *s, Pt *p, int64_t f, int drop, int i, int j, double x, double y)
{
    return make_proj_n(p, s->normal + 3 * f, corner(s, f, 0), drop, i, j, x, y);
}

/* ---- lines of one face ------------------------------------------------------------------------ */

enum { LN_E, LN_U };

typedef struct {
    int8_t kind;
    int64_t a, b;             /* E: vertices; U: face a */
} Ln;

typedef struct {
    const Shared *s;
    int64_t t;
    int drop, i, j;
    int fail;
    Pt *pts;
    int n_pts, cap_pts;
    Ln *lns;
    int n_lns, cap_lns;
    /* corners of every cell made: pt, ln, in in parallel pools */
    int *c_pt, *c_ln;
    int8_t *c_in;
    int n_c, cap_c;
    struct Exact *exact;      /* scratch for signs the filter leaves open (NULL: such a face is handed back) */
} Face;

/* The sign of a point against a line from exact expansions: -1, 0, 1, or 2 when it cannot be found. */
static int exact_side(Face *c, const Pt *p, const Ln *l);

static int face_reserve(void **data, int *cap, int want, size_t item)
{
    if (want <= *cap)
        return 0;
    int grown = *cap ? *cap : 16;
    while (grown < want)
        grown *= 2;
    void *p = realloc(*data, item * (size_t)grown);
    if (!p)
        return -1;
    *data = p;
    *cap = grown;
    return 0;
}

static int new_pt(Face *c)
{
    if (face_reserve((void **)&c->pts, &c->cap_pts, c->n_pts + 1, sizeof(Pt)) < 0) {
        c->fail = 2;
        return -1;
    }
    return c->n_pts++;
}

/* Side of an input point against a line of the face: exact. */
static int vertex_side(const Face *c, const Ln *l, const double *x)
{
    const Shared *s = c->s;
    if (l->kind == LN_U)
        return plane_side(s, l->a, x);
    const double *p = vx(s, l->a), *q = vx(s, l->b);
    return orient2d(p[c->i], p[c->j], q[c->i], q[c->j], x[c->i], x[c->j]);
}

/* Side of point p against line li: -1, 0, 1; an unsure sign sets c->fail and gives 0. */
static int side(Face *c, const Pt *p, int li)
{
    if (p->l1 == li || p->l2 == li)
        return 0;
    const Shared *s = c->s;
    const Ln *l = c->lns + li;
    if (p->kind == PT_V)
        return vertex_side(c, l, vx(s, p->a));
    if (p->kind == PT_LPI && l->kind == LN_U) {
        /* level_h(X) = (sP hQ - sQ hP) / (sP - sQ) */
        const double *x = vx(s, p->a), *y = vx(s, p->b);
        int hp = plane_side(s, l->a, x), hq = plane_side(s, l->a, y);
        int t1 = p->sg[0] * hq, t2 = -p->sg[1] * hp, num;
        if (t1 == 0 || t2 == 0 || t1 == t2)
            num = t1 ? t1 : t2;
        else {
            fx value = fx_sub(fx_mul(p->s[0], plane_level(s, l->a, y)), fx_mul(p->s[1], plane_level(s, l->a, x)));
            num = fx_sign(value);
            if (num == 0) {
                int exact = exact_side(c, p, l);
                if (exact == 2)
                    c->fail = 1;
                return exact == 2 ? 0 : exact;
            }
        }
        return p->flip ? -num : num;
    }
    fx value;
    if (l->kind == LN_U) {
        const fx *n = s->normal + 3 * l->a;
        const double *o = corner(s, l->a, 0);
        value = fx_c(0.0);
        for (int k = 0; k < 3; k++)
            value = fx_add(value, fx_mul(n[k], fx_sub(p->X[k], fx_mul(fx_c(o[k]), p->W))));
    } else {
        const double *a = vx(s, l->a), *b = vx(s, l->b);
        int i = c->i, j = c->j;
        fx xi = fx_sub(p->X[i], fx_mul(fx_c(a[i]), p->W)), xj = fx_sub(p->X[j], fx_mul(fx_c(a[j]), p->W));
        value = fx_sub(fx_mul(fx_diff(b[i], a[i]), xj), fx_mul(fx_diff(b[j], a[j]), xi));
    }
    int sign = fx_sign(value);
    if (sign == 0) {
        /* The line PQ crossing this face's plane meets the line RS of this plane exactly when the four
         * points are coplanar (the lines are not parallel): a zero the filter cannot see. */
        if (p->kind == PT_LPI && p->c == c->t && l->kind == LN_E
            && orient3d(vx(s, p->a), vx(s, p->b), vx(s, l->a), vx(s, l->b)) == 0)
            return 0;
        sign = exact_side(c, p, l);
        if (sign == 2) {
            c->fail = 1;
            sign = 0;
        }
    }
    return sign;
}

/* Whether two lines of the face are the same line (exact: both are defined by input points). */
static int same_line(const Face *c, const Ln *x, const Ln *y)
{
    const Shared *s = c->s;
    if (x->kind == LN_E)
        return vertex_side(c, y, vx(s, x->a)) == 0 && vertex_side(c, y, vx(s, x->b)) == 0;
    if (y->kind == LN_E)
        return vertex_side(c, x, vx(s, y->a)) == 0 && vertex_side(c, x, vx(s, y->b)) == 0;
    /* two planes meeting this face's plane: the same plane */
    for (int k = 0; k < 3; k++)
        if (plane_side(s, y->a, corner(s, x->a, k)) != 0)
            return 0;
    return 1;
}

/* The face's line equal to `l`, added when new. */
static int line_of(Face *c, int8_t kind, int64_t a, int64_t b)
{
    Ln l = {kind, a, b};
    for (int k = 0; k < c->n_lns; k++) {
        const Ln *o = c->lns + k;
        if (o->kind == kind && o->a == a && o->b == b)
            return k;
    }
    for (int k = 0; k < c->n_lns; k++)
        if (same_line(c, c->lns + k, &l))
            return k;
    if (face_reserve((void **)&c->lns, &c->cap_lns, c->n_lns + 1, sizeof(Ln)) < 0) {
        c->fail = 2;
        return -1;
    }
    c->lns[c->n_lns] = l;
    return c->n_lns++;
}

/* The point where lines la and lb of the face meet. */
static int meet(Face *c, int la, int lb)
{
    /* the same two lines met before (in a neighbouring cell): the same point */
    for (int q = 3; q < c->n_pts; q++) {
        const Pt *p = c->pts + q;
        if (p->kind != PT_V && ((p->l1 == la && p->l2 == lb) || (p->l1 == lb && p->l2 == la)))
            return q;
    }
    int k = new_pt(c);
    if (k < 0)
        return -1;
    const Ln *x = c->lns + la, *y = c->lns + lb;
    Pt *p = c->pts + k;
    int ok;
    if (x->kind == LN_E && y->kind == LN_U)
        ok = make_lpi(c->s, p, x->a, x->b, y->a, la, lb);
    else if (x->kind == LN_U && y->kind == LN_E)
        ok = make_lpi(c->s, p, y->a, y->b, x->a, la, lb);
    else if (x->kind == LN_E)
        ok = make_ee(c->s, p, x->a, x->b, y->a, y->b, c->i, c->j, la, lb);
    else
        ok = make_tpi(c->s, p, c->t, x->a, y->a, la, lb);
    if (!ok) {
        c->fail = 1;
        return -1;
    }
    return k;
}

/* ---- cutting a face ---------------------------------------------------------------------------- */

/* Append one corner to the pools. */
static int push_corner(Face *c, int pt, int ln, int8_t in)
{
    if (c->n_c == c->cap_c) {
        int cap = c->cap_c ? 2 * c->cap_c : 64;
        int *a = realloc(c->c_pt, sizeof(int) * cap), *b = a ? realloc(c->c_ln, sizeof(int) * cap) : NULL;
        int8_t *d = b ? realloc(c->c_in, cap) : NULL;
        if (a)
            c->c_pt = a;
        if (b)
            c->c_ln = b;
        if (!d) {
            c->fail = 2;
            return -1;
        }
        c->c_in = d;
        c->cap_c = cap;
    }
    c->c_pt[c->n_c] = pt, c->c_ln[c->n_c] = ln, c->c_in[c->n_c] = in;
    return c->n_c++;
}

/* A cell: corners [start, start + n) of the pools (offsets: the pools move when they grow).  Edge k
 * (corner k to k + 1) lies on line c_ln[k]; the cell's interior is on side c_in[k] of it. */
typedef struct {
    int start, n;
} CellRef;

typedef struct {
    int line, e1, e2;         /* the segment: its line and its two ends (points of the face) */
} Segment;

/* Cut cell `cell` by segment `g` where the segment enters it: 0 (not cut), 1 (cut: two halves
 * appended to out), or -1 (a sign was unsure, or memory ran out). */
static int split(Face *c, CellRef cell, const Segment *g, CellRef *out)
{
    enum { SMALL = 64 };
    int values_small[SMALL], *values = cell.n <= SMALL ? values_small : malloc(sizeof(int) * cell.n);
    if (!values) {
        c->fail = 2;
        return -1;
    }
    int positive = 0, negative = 0, result = 0;
    for (int k = 0; k < cell.n; k++) {
        values[k] = side(c, c->pts + c->c_pt[cell.start + k], g->line);
        if (c->fail)
            goto done;
        positive |= values[k] > 0;
        negative |= values[k] < 0;
    }
    if (!(positive && negative))
        goto done;
    for (int k = 0; k < cell.n; k++) {
        int line = c->c_ln[cell.start + k], in = c->c_in[cell.start + k];
        int s1 = side(c, c->pts + g->e1, line);
        if (c->fail)
            goto done;
        if (in * s1 > 0)
            continue;
        int s2 = side(c, c->pts + g->e2, line);
        if (c->fail)
            goto done;
        if (in * s2 <= 0)
            goto done;        /* the segment stays outside this edge: it misses the cell */
    }
    /* the crossing points, one per edge whose ends are strictly on both sides */
    int cross_small[SMALL], *cross = cell.n <= SMALL ? cross_small : malloc(sizeof(int) * cell.n);
    if (!cross) {
        c->fail = 2;
        result = -1;
        goto done;
    }
    for (int k = 0; k < cell.n; k++) {
        int next = (k + 1) % cell.n;
        cross[k] = -1;
        if ((long)values[k] * values[next] < 0) {
            cross[k] = meet(c, c->c_ln[cell.start + k], g->line);
            if (cross[k] < 0)
                break;
        }
    }
    if (!c->fail)
        for (int half = 0; half < 2 && !c->fail; half++) {
            int sg = half == 0 ? 1 : -1;
            int start = c->n_c;
            for (int k = 0; k < cell.n && !c->fail; k++) {
                int next = (k + 1) % cell.n;
                int line = c->c_ln[cell.start + k], in = c->c_in[cell.start + k];
                int pt = c->c_pt[cell.start + k];
                if (values[k] * sg >= 0) {
                    if (values[k] == 0 && values[next] * sg < 0)
                        push_corner(c, pt, g->line, (int8_t)sg);
                    else
                        push_corner(c, pt, line, (int8_t)in);
                }
                if (cross[k] >= 0) {
                    if (values[k] * sg > 0)
                        push_corner(c, cross[k], g->line, (int8_t)sg);
                    else
                        push_corner(c, cross[k], line, (int8_t)in);
                }
            }
            out[half].start = start;
            out[half].n = c->n_c - start;
        }
    if (cross != cross_small)
        free(cross);
    result = c->fail ? -1 : 1;
done:
    if (values != values_small)
        free(values);
    if (c->fail)
        result = -1;
    return result;
}

/* ---- exact rounding of the new points ------------------------------------------------------------ */

/* Expansions (predicates.h's `grow`: nonoverlapping, increasing magnitude), kept short by Shewchuk's
 * compress; after it the largest component is within one ulp of the exact value.  Lengths are checked
 * against XN: a longer one (never seen) falls back to the certified bound of the filter. */
#define XN 1024

typedef struct {
    int n;
    double h[XN];
} Xp;

static void x_compress(Xp *x)
{
    int n = x->n;
    if (n <= 1)
        return;
    double g[XN], *e = x->h;
    int bottom = n - 1;
    double q = e[n - 1];
    for (int i = n - 2; i >= 0; i--) {
        double sum = q + e[i], low = e[i] - (sum - q);
        if (low != 0.0) {
            g[bottom--] = sum;
            q = low;
        } else
            q = sum;
    }
    int top = 0;
    for (int i = bottom + 1; i < n; i++) {
        double sum = g[i] + q, low = q - (sum - g[i]);
        if (low != 0.0)
            e[top++] = low;
        q = sum;
    }
    if (q != 0.0 || top == 0)
        e[top++] = q;
    x->n = (top == 1 && e[0] == 0.0) ? 0 : top;
}

static void x_of(Xp *x, double a) { x->n = a != 0.0, x->h[0] = a; }

/* dst = src (only the components used: an Xp is large) */
static void x_copy(Xp *dst, const Xp *src)
{
    dst->n = src->n;
    memcpy(dst->h, src->h, sizeof(double) * src->n);
}

static void x_diff(Xp *x, double a, double b)
{
    double s, e;
    two_sum(a, -b, &s, &e);
    x->n = 0;
    if (e != 0.0)
        x->h[x->n++] = e;
    if (s != 0.0)
        x->h[x->n++] = s;
}

/* out = a * b (+ out when add); 0, or -1 when too long. */
static int x_mul(Xp *out, const Xp *a, const Xp *b, double sign, int add)
{
    if (!add)
        out->n = 0;
    for (int j = 0; j < b->n; j++)
        for (int i = 0; i < a->n; i++) {
            double p, e;
            if (out->n + 2 > XN)
                return -1;
            two_prod(a->h[i], sign * b->h[j], &p, &e);
            if (fabs(p) < 0x1p-900)
                return -1;                      /* its rounding error might underflow: not exact */
            out->n = grow(out->h, out->n, e);
            out->n = grow(out->h, out->n, p);
            if (out->n > 24)
                x_compress(out);                /* short, so each grow stays cheap */
        }
    x_compress(out);
    return 0;
}

static int x_add(Xp *out, const Xp *a, double sign)
{
    for (int i = 0; i < a->n; i++) {
        if (out->n + 1 > XN)
            return -1;
        out->n = grow(out->h, out->n, sign * a->h[i]);
        if (out->n > 24)
            x_compress(out);
    }
    x_compress(out);
    return 0;
}

static inline double x_top(const Xp *x) { return x->n ? x->h[x->n - 1] : 0.0; }

/* a * b - c * d */
static int x_det2(Xp *out, const Xp *a, const Xp *b, const Xp *c, const Xp *d)
{
    return x_mul(out, a, b, 1.0, 0) < 0 || x_mul(out, c, d, -1.0, 1) < 0 ? -1 : 0;
}

/* Scratch for the exact rounding of one point (large: one per thread, on the heap). */
typedef struct Exact {
    Xp u[3], w[3], n1[3], n2[3], n3[3], c[3], t, t2, W, D[3], N;
} Exact;

static int x_normal(const Shared *s, int64_t f, Exact *x, Xp *n)
{
    const double *a = corner(s, f, 0), *b = corner(s, f, 1), *c = corner(s, f, 2);
    for (int k = 0; k < 3; k++) {
        x_diff(x->u + k, b[k], a[k]);
        x_diff(x->w + k, c[k], a[k]);
    }
    for (int k = 0; k < 3; k++)
        if (x_det2(n + k, x->u + (k + 1) % 3, x->w + (k + 2) % 3, x->u + (k + 2) % 3, x->w + (k + 1) % 3) < 0)
            return -1;
    return 0;
}

/* out = n . (x - a_f) for the normal n of face f (exact). */
static int x_level(const Shared *s, int64_t f, const Xp *n, const double *x, Exact *e, Xp *out)
{
    const double *a = corner(s, f, 0);
    out->n = 0;
    for (int k = 0; k < 3; k++) {
        x_diff(&e->t, x[k], a[k]);
        if (x_mul(out, n + k, &e->t, 1.0, 1) < 0)
            return -1;
    }
    return 0;
}

static int x_cross(Xp *out, const Xp *u, const Xp *w)
{
    for (int k = 0; k < 3; k++)
        if (x_det2(out + k, u + (k + 1) % 3, w + (k + 2) % 3, u + (k + 2) % 3, w + (k + 1) % 3) < 0)
            return -1;
    return 0;
}

/* The point's W and D (x = origin + D / W) as exact expansions; 0, or -1. */
static int exact_parts(const Face *c, const Pt *p, Exact *e)
{
    const Shared *s = c->s;
    if (p->kind == PT_LPI) {
        /* W = sP - sQ, D = sP (Q - P) */
        const double *x = vx(s, p->a), *y = vx(s, p->b);
        if (x_normal(s, p->c, e, e->n1) < 0 || x_level(s, p->c, e->n1, x, e, &e->t2) < 0
            || x_level(s, p->c, e->n1, y, e, &e->W) < 0)
            return -1;
        if (x_add(&e->W, &e->t2, -1.0) < 0)          /* W = sQ - sP, negated below */
            return -1;
        for (int k = 0; k < e->W.n; k++)
            e->W.h[k] = -e->W.h[k];
        for (int k = 0; k < 3; k++) {
            x_diff(&e->t, y[k], x[k]);
            if (x_mul(e->D + k, &e->t2, &e->t, 1.0, 0) < 0)
                return -1;
        }
        return 0;
    }
    if (p->kind == PT_EE) {
        const double *x = vx(s, p->a), *y = vx(s, p->b), *r = vx(s, p->c), *q = vx(s, p->d);
        int i = c->i, j = c->j;
        Xp *di = e->u, *dj = e->u + 1, *ei = e->w, *ej = e->w + 1, *ri = e->n1, *rj = e->n1 + 1;
        x_diff(di, y[i], x[i]), x_diff(dj, y[j], x[j]);
        x_diff(ei, q[i], r[i]), x_diff(ej, q[j], r[j]);
        x_diff(ri, r[i], x[i]), x_diff(rj, r[j], x[j]);
        if (x_det2(&e->W, di, ej, dj, ei) < 0 || x_det2(&e->t2, ri, ej, rj, ei) < 0)
            return -1;
        for (int k = 0; k < 3; k++) {
            x_diff(&e->t, y[k], x[k]);
            if (x_mul(e->D + k, &e->t2, &e->t, 1.0, 0) < 0)
                return -1;
        }
        return 0;
    }
    /* TPI: planes of f (through o), g, h: D = d2 (n3 x n1) + d3 (n1 x n2), W = n1 . (n2 x n3) */
    const double *o = corner(s, p->a, 0);
    if (x_normal(s, p->a, e, e->n1) < 0 || x_normal(s, p->b, e, e->n2) < 0 || x_normal(s, p->c, e, e->n3) < 0)
        return -1;
    Xp *d2 = &e->t2, *d3 = &e->N;
    if (x_level(s, p->b, e->n2, o, e, d2) < 0 || x_level(s, p->c, e->n3, o, e, d3) < 0)
        return -1;
    if (x_cross(e->c, e->n2, e->n3) < 0)
        return -1;
    e->W.n = 0;
    for (int k = 0; k < 3; k++)
        if (x_mul(&e->W, e->n1 + k, e->c + k, 1.0, 1) < 0)
            return -1;
    /* c = n3 x n1; D = -d2 c */
    if (x_cross(e->c, e->n3, e->n1) < 0)
        return -1;
    for (int k = 0; k < 3; k++)
        if (x_mul(e->D + k, d2, e->c + k, -1.0, 0) < 0)
            return -1;
    if (x_cross(e->c, e->n1, e->n2) < 0)
        return -1;
    for (int k = 0; k < 3; k++)
        if (x_mul(e->D + k, d3, e->c + k, -1.0, 1) < 0)
            return -1;
    return 0;
}

/* Each coordinate of point p rounded (origin + D / W, then once more to the nearest double when the
 * exact error says so), with its exact error rounded up.  0, or -1 (then the caller keeps the
 * filter's bound). */
static int exact_round(const Face *c, const Pt *p, Exact *e, double *q, double *err)
{
    if (exact_parts(c, p, e) < 0)
        return -1;
    double w = x_top(&e->W);
    if (w == 0.0)
        return -1;
    const double *origin = vx(c->s, p->origin);
    Xp one;
    for (int d = 0; d < 3; d++) {
        /* N = (origin - q) W + D: the error x - q = N / W */
        for (int pass = 0; pass < 2; pass++) {
            x_diff(&one, origin[d], q[d]);
            x_copy(&e->N, e->D + d);
            if (x_mul(&e->N, &e->W, &one, 1.0, 1) < 0)
                return -1;
            double step = x_top(&e->N) / w;
            if (pass == 0 && step != 0.0) {
                double better = q[d] + step;            /* one correction: to within an ulp or so */
                if (better != q[d] && isfinite(better)) {
                    q[d] = better;
                    continue;
                }
            }
            err[d] = fabs(step) * (1.0 + 16 * EPS) + (e->N.n ? FX_TINY : 0.0);
            break;
        }
    }
    return 0;
}

static int exact_side(Face *c, const Pt *p, const Ln *l)
{
    Exact *e = c->exact;
    if (!e || p->kind == PT_PROJ || p->kind == PT_V || exact_parts(c, p, e) < 0)
        return 2;
    const Shared *s = c->s;
    int w = (x_top(&e->W) > 0) - (x_top(&e->W) < 0);
    if (w == 0)
        return 2;
    const double *o = vx(s, p->origin);
    Xp v;
    /* X = o W + D (homogeneous, the sign of W apart) */
    for (int k = 0; k < 3; k++) {
        x_of(&v, o[k]);
        if (x_mul(e->c + k, &e->W, &v, 1.0, 0) < 0 || x_add(e->c + k, e->D + k, 1.0) < 0)
            return 2;
    }
    if (l->kind == LN_U) {
        /* n . (X - a W) */
        const double *a = corner(s, l->a, 0);
        if (x_normal(s, l->a, e, e->n2) < 0)
            return 2;
        e->N.n = 0;
        for (int k = 0; k < 3; k++) {
            x_copy(&e->t2, e->c + k);
            x_of(&v, a[k]);
            if (x_mul(&e->t2, &e->W, &v, -1.0, 1) < 0 || x_mul(&e->N, e->n2 + k, &e->t2, 1.0, 1) < 0)
                return 2;
        }
    } else {
        /* (S - R)_i (X_j - R_j W) - (S - R)_j (X_i - R_i W) */
        const double *r = vx(s, l->a), *q = vx(s, l->b);
        int i = c->i, j = c->j;
        Xp *xi = e->n3, *xj = e->n3 + 1, *di = e->n3 + 2;
        x_copy(xi, e->c + i);
        x_of(&v, r[i]);
        if (x_mul(xi, &e->W, &v, -1.0, 1) < 0)
            return 2;
        x_copy(xj, e->c + j);
        x_of(&v, r[j]);
        if (x_mul(xj, &e->W, &v, -1.0, 1) < 0)
            return 2;
        x_diff(di, q[i], r[i]);
        x_diff(&e->t2, q[j], r[j]);
        if (x_det2(&e->N, di, xj, &e->t2, xi) < 0)
            return 2;
    }
    double top = x_top(&e->N);
    return ((top > 0) - (top < 0)) * w;
}

/* ---- output of one block of faces --------------------------------------------------------------- */

typedef Arranged Out;

static void buf_free(Buf *b)
{
    free(b->data);
    b->data = NULL;
    b->size = b->capacity = 0;
}

static int out_push(Buf *g, const void *item, size_t bytes)
{
    if (g->size + bytes > g->capacity) {
        size_t cap = g->capacity ? g->capacity : 256;
        while (cap < g->size + bytes)
            cap *= 2;
        char *data = realloc(g->data, cap);
        if (!data)
            return -1;
        g->data = data;
        g->capacity = cap;
    }
    memcpy(g->data + g->size, item, bytes);
    g->size += bytes;
    return 0;
}

#define N_INNER 6

/* The corner's index among the returned points (input vertices: their own index). */
static int64_t corner_out(Face *c, Out *o, int k)
{
    Pt *p = c->pts + k;
    if (p->kind == PT_V)
        return p->a;
    if (p->out >= 0)
        return c->s->n + p->out;
    double q[3], err[3];
    double low = (p->W.v - p->W.e) * (1.0 - 4 * EPS);
    if (!(low > 0.0))
        return -1;
    const double *origin = vx(c->s, p->origin);
    for (int d = 0; d < 3; d++) {
        /* x = origin + D / W.  d = Dv / Wv (rounded): |D/W - Dv/Wv| <= (eD + |Dv/Wv| eW) / (Wv - eW), and
         * |Dv/Wv - d| <= u |d|; then q = origin + d rounded, whose error two_sum finds exactly. */
        double step = p->D[d].v / p->W.v, rest;
        double a = fabs(step) * (1.0 + 4 * EPS);
        double bound = ((p->D[d].e + a * p->W.e) / low + a * EPS) * (1.0 + 0x1p-40) + FX_TINY;
        two_sum(origin[d], step, &q[d], &rest);
        err[d] = (bound + fabs(rest)) * (1.0 + 4 * EPS);
        if (!isfinite(q[d]) || !isfinite(err[d]))
            return -1;
    }
    /* how the point is defined, for an exact rounding later (refine_points) of the points kept */
    int64_t def[7] = {p->kind, p->a, p->b, p->c, p->d, c->i, c->j};
    if (out_push(&o->points, q, sizeof q) < 0 || out_push(&o->errors, err, sizeof err) < 0
        || out_push(&o->defs, def, sizeof def) < 0)
        return -1;
    p->out = o->n_points++;
    return c->s->n + p->out;
}

static const double TRIES[N_INNER][3] = {{1, 1, 1}, {1, 2, 3}, {3, 1, 2}, {2, 3, 1}, {1, 3, 7}, {5, 1, 2}};

/* Approximate projected coordinates of a point of the face. */
static void approx(const Face *c, const Pt *p, double *x, double *y)
{
    if (p->kind == PT_V) {
        const double *q = vx(c->s, p->a);
        *x = q[c->i], *y = q[c->j];
    } else {
        *x = p->X[c->i].v / p->W.v;
        *y = p->X[c->j].v / p->W.v;
    }
}

/* Points strictly inside the cell (NaN where one could not be certified); 0 when the first could not. */
static int inner_points(Face *c, CellRef cell, double *inner)
{
    double ax[3], ay[3], cx = 0.0, cy = 0.0;
    for (int k = 0; k < cell.n; k++) {
        double x, y;
        approx(c, c->pts + c->c_pt[cell.start + k], &x, &y);
        if (k < 3)
            ax[k] = x, ay[k] = y;
        cx += x, cy += y;
    }
    for (int t = 0; t < N_INNER; t++) {
        double x, y;
        if (t == 0)
            x = cx / cell.n, y = cy / cell.n;
        else {
            const double *w = TRIES[t];
            double total = w[0] + w[1] + w[2];
            x = (w[0] * ax[0] + w[1] * ax[1] + w[2] * ax[2]) / total;
            y = (w[0] * ay[0] + w[1] * ay[1] + w[2] * ay[2]) / total;
        }
        Pt q;
        int inside = isfinite(x) && isfinite(y) && make_proj(c->s, &q, c->t, c->drop, c->i, c->j, x, y);
        for (int k = 0; k < cell.n && inside; k++) {
            int s = side(c, &q, c->c_ln[cell.start + k]);
            inside = !c->fail && s * c->c_in[cell.start + k] > 0;
            c->fail = 0;
        }
        inner[2 * t] = inside ? x : NAN;
        inner[2 * t + 1] = inside ? y : NAN;
        if (t == 0 && !inside)
            return 0;
    }
    return 1;
}

/* ---- one face ----------------------------------------------------------------------------------- */

/* The segment of pair `pair` as seen from face t, appended to segs; -1 on failure. */
static int add_pair_segments(Face *c, int64_t pair, Segment **segs, int *n_segs, int *cap_segs)
{
    const Shared *s = c->s;
    int64_t t = c->t, u = s->pairs[2 * pair] == t ? s->pairs[2 * pair + 1] : s->pairs[2 * pair];
    if (s->kind[pair] == PAIR_COPLANAR) {
        for (int k = 0; k < 3; k++) {
            int64_t R = s->F[3 * u + k], S = s->F[3 * u + (k + 1) % 3];
            int line = line_of(c, LN_E, R, S);
            int e1 = new_pt(c);
            if (e1 >= 0)
                make_vertex(c->pts + e1, R, -1, -1);
            int e2 = new_pt(c);
            if (e2 >= 0)
                make_vertex(c->pts + e2, S, -1, -1);
            if (line < 0 || e1 < 0 || e2 < 0)
                return -1;
            if (face_reserve((void **)segs, cap_segs, *n_segs + 1, sizeof(Segment)) < 0) {
                c->fail = 2;
                return -1;
            }
            Segment g = {line, e1, e2};
            (*segs)[(*n_segs)++] = g;
        }
        return 0;
    }
    if (s->kind[pair] != PAIR_SEGMENT)
        return 0;                          /* the faces only touch: nothing cuts */
    int line = line_of(c, LN_U, u, 0);
    if (line < 0)
        return -1;
    int ends[2];
    for (int k = 0; k < 2; k++) {
        const End *e = s->ends + 2 * pair + k;
        int p = new_pt(c);
        if (p < 0)
            return -1;
        if (e->kind == 0)
            make_vertex(c->pts + p, e->a, -1, -1);
        else if (e->g == t) {
            if (!make_lpi(s, c->pts + p, e->a, e->b, t, line, -1)) {
                c->fail = 1;
                return -1;
            }
        } else {
            int edge = line_of(c, LN_E, e->a, e->b);
            if (edge < 0)
                return -1;
            if (!make_lpi(s, c->pts + p, e->a, e->b, u, edge, line)) {
                c->fail = 1;
                return -1;
            }
        }
        ends[k] = p;
    }
    if (face_reserve((void **)segs, cap_segs, *n_segs + 1, sizeof(Segment)) < 0) {
        c->fail = 2;
        return -1;
    }
    Segment g = {line, ends[0], ends[1]};
    (*segs)[(*n_segs)++] = g;
    return 0;
}

/* Cut face t; its cells are appended to o (1), or o is left as it was (0: hand it back; -1: memory). */
static int cut_face(Face *c, Out *o, int64_t t, Segment **segs_p, int *cap_segs, CellRef **cells_p,
                    CellRef **next_p, int *cap_cells)
{
    const Shared *s = c->s;
    c->t = t;
    c->fail = 0;
    c->n_pts = c->n_lns = c->n_c = 0;
    int drop = triangle_axis(corner(s, t, 0), corner(s, t, 1), corner(s, t, 2));
    if (drop < 0)
        return 0;
    c->drop = drop;
    c->i = (drop + 1) % 3, c->j = (drop + 2) % 3;
    const int64_t *f = s->F + 3 * t;
    for (int k = 0; k < 3; k++)
        line_of(c, LN_E, f[k], f[(k + 1) % 3]);
    if (c->fail || c->n_lns != 3)
        return c->fail == 2 ? -1 : 0;
    for (int k = 0; k < 3; k++) {
        int p = new_pt(c);
        if (p < 0)
            return -1;
        make_vertex(c->pts + p, f[k], (k + 2) % 3, k);
    }
    const double *a = corner(s, t, 0), *b = corner(s, t, 1), *cc = corner(s, t, 2);
    int8_t sense = (int8_t)orient2d(a[c->i], a[c->j], b[c->i], b[c->j], cc[c->i], cc[c->j]);
    int n_segs = 0;
    for (int64_t k = s->begin[t]; k < s->begin[t + 1]; k++) {
        if (add_pair_segments(c, s->list[k], segs_p, &n_segs, cap_segs) < 0 || c->fail)
            return c->fail == 2 ? -1 : 0;
    }
    Segment *segs = *segs_p;
    for (int k = 0; k < 3; k++)
        if (push_corner(c, k, k, sense) < 0)
            return -1;
    CellRef *cells = *cells_p, *next = *next_p;
    int n_cells = 1;
    cells[0].start = 0, cells[0].n = 3;
    for (int g = 0; g < n_segs; g++) {
        if (2 * n_cells + 2 > *cap_cells) {
            int cap = 2 * (2 * n_cells + 2);
            CellRef *x = realloc(cells, sizeof(CellRef) * cap), *y = x ? realloc(next, sizeof(CellRef) * cap) : NULL;
            if (x)
                cells = *cells_p = x;
            if (!y)
                return -1;
            next = *next_p = y;
            *cap_cells = cap;
        }
        int n_next = 0;
        for (int k = 0; k < n_cells; k++) {
            int cut = split(c, cells[k], segs + g, next + n_next);
            if (cut < 0)
                return c->fail == 2 ? -1 : 0;
            if (cut)
                n_next += 2;
            else
                next[n_next++] = cells[k];
        }
        CellRef *swap = cells;
        cells = *cells_p = next;
        next = *next_p = swap;
        n_cells = n_next;
    }
    /* the cells, all or nothing */
    Out saved = *o;
    for (int k = 0; k < n_cells; k++) {
        double inner[2 * N_INNER];
        if (!inner_points(c, cells[k], inner))
            goto back;
        int64_t count = cells[k].n;
        if (out_push(&o->face, &t, 8) < 0 || out_push(&o->count, &count, 8) < 0
            || out_push(&o->inner, inner, sizeof inner) < 0)
            return -1;
        for (int q = 0; q < cells[k].n; q++) {
            int64_t id = corner_out(c, o, c->c_pt[cells[k].start + q]);
            if (id < 0)
                goto back;
            if (out_push(&o->corners, &id, 8) < 0)
                return -1;
        }
        o->n_cells++;
    }
    return 1;
back:
    /* undo: sizes back (the buffers may have grown, which is harmless) */
    o->face.size = saved.face.size, o->count.size = saved.count.size, o->corners.size = saved.corners.size;
    o->inner.size = saved.inner.size, o->points.size = saved.points.size, o->errors.size = saved.errors.size;
    o->defs.size = saved.defs.size;
    o->n_cells = saved.n_cells, o->n_points = saved.n_points;
    return 0;
}

/* ---- the segment of one pair (as _crossing) ------------------------------------------------------ */

/* Whether two points of the line where the planes of t and u meet are one point, exactly: ends of
 * the segment (vertices of t or u, edges of one crossing the other's plane). */
static int same_end(const Shared *s, const End *x, const End *y)
{
    if (x->kind == 0 && y->kind == 0) {
        const double *p = vx(s, x->a), *q = vx(s, y->a);
        return p[0] == q[0] && p[1] == q[1] && p[2] == q[2];
    }
    if (x->kind == 1 && y->kind == 1)
        /* lines PQ and RS, each crossing the plane the other lies in, meet at a point of both planes */
        return x->g != y->g && orient3d(vx(s, x->a), vx(s, x->b), vx(s, y->a), vx(s, y->b)) == 0;
    const End *v = x->kind == 0 ? x : y, *e = x->kind == 0 ? y : x;
    const double *p = vx(s, e->a), *q = vx(s, e->b), *r = vx(s, v->a);
    /* the vertex on the line PQ: collinear in every projection */
    for (int k = 0; k < 3; k++)
        if (porient(k, p, q, r) != 0)
            return 0;
    return 1;
}

/* Order of two points of one line along `axis`: -1, 0, 1, or 2 when unsure. */
static int along(const Shared *s, const Pt *p, const Pt *q, const End *ep, const End *eq, int axis)
{
    if (p->kind == PT_V && q->kind == PT_V) {
        double x = vx(s, p->a)[axis], y = vx(s, q->a)[axis];
        return (x > y) - (x < y);
    }
    fx xp = p->kind == PT_V ? fx_c(vx(s, p->a)[axis]) : p->X[axis], wp = p->kind == PT_V ? fx_c(1.0) : p->W;
    fx xq = q->kind == PT_V ? fx_c(vx(s, q->a)[axis]) : q->X[axis], wq = q->kind == PT_V ? fx_c(1.0) : q->W;
    int sign = fx_sign(fx_sub(fx_mul(xp, wq), fx_mul(xq, wp)));
    return sign ? sign : (same_end(s, ep, eq) ? 0 : 2);
}

/* The lowest and highest of pts[0..n) along `axis` (the first of equals), as _span; -1 when a
 * comparison is unsure. */
static int extremes(const Shared *s, const Pt *pts, const End *ends, int n, int axis, int *low, int *high)
{
    *low = *high = 0;
    for (int k = 1; k < n; k++) {
        int lo = along(s, pts + k, pts + *low, ends + k, ends + *low, axis);
        int hi = along(s, pts + k, pts + *high, ends + k, ends + *high, axis);
        if (lo == 2 || hi == 2)
            return -1;
        if (lo < 0)
            *low = k;
        if (hi > 0)
            *high = k;
    }
    return 0;
}

/* The points of face f's triangle on the plane of face g: its vertices there, its edges crossing it. */
static int on_plane(const Shared *s, int64_t f, int64_t g, const int *level, End *ends, Pt *pts)
{
    int count = 0;
    for (int k = 0; k < 3; k++)
        if (level[k] == 0) {
            End e = {0, s->F[3 * f + k], 0, 0};
            ends[count] = e;
            make_vertex(pts + count++, e.a, -1, -1);
        }
    for (int k = 0; k < 3; k++) {
        int l = (k + 1) % 3;
        if (level[k] * level[l] < 0) {
            End e = {1, s->F[3 * f + k], s->F[3 * f + l], g};
            ends[count] = e;
            if (!make_lpi(s, pts + count++, e.a, e.b, g, -1, -1))
                return -1;
        }
    }
    return count;
}

static void pair_segment(Shared *s, int64_t q)
{
    int64_t t = s->pairs[2 * q], u = s->pairs[2 * q + 1];
    int lt[3], lu[3];                    /* t's corners against u's plane, u's against t's */
    int zero = 0;
    for (int k = 0; k < 3; k++) {
        lu[k] = plane_side(s, t, corner(s, u, k));
        lt[k] = plane_side(s, u, corner(s, t, k));
        zero += lu[k] == 0;
    }
    s->kind[q] = PAIR_NONE;
    if (zero == 3) {
        s->kind[q] = PAIR_COPLANAR;
        return;
    }
    End ends_t[3], ends_u[3];
    Pt pts_t[3], pts_u[3];
    int n_t = on_plane(s, u, t, lu, ends_t, pts_t), n_u = on_plane(s, t, u, lt, ends_u, pts_u);
    if (n_t < 0 || n_u < 0) {
        s->kind[q] = PAIR_UNSURE;
        return;
    }
    if (n_t == 0 || n_u == 0)
        return;                          /* one triangle strictly on one side of the other's plane */
    fx d[3];
    fx_cross(s->normal + 3 * t, s->normal + 3 * u, d);
    int axis = 0;
    for (int k = 1; k < 3; k++)
        if (fabs(d[k].v) > fabs(d[axis].v))
            axis = k;
    int low_t, high_t, low_u, high_u;
    if (extremes(s, pts_t, ends_t, n_t, axis, &low_t, &high_t) < 0
        || extremes(s, pts_u, ends_u, n_u, axis, &low_u, &high_u) < 0)
        goto unsure;
    int lows = along(s, pts_t + low_t, pts_u + low_u, ends_t + low_t, ends_u + low_u, axis);
    int highs = along(s, pts_t + high_t, pts_u + high_u, ends_t + high_t, ends_u + high_u, axis);
    if (lows == 2 || highs == 2)
        goto unsure;
    const Pt *low = lows >= 0 ? pts_t + low_t : pts_u + low_u, *high = highs <= 0 ? pts_t + high_t : pts_u + high_u;
    const End *end_low = lows >= 0 ? ends_t + low_t : ends_u + low_u;
    const End *end_high = highs <= 0 ? ends_t + high_t : ends_u + high_u;
    int order = along(s, low, high, end_low, end_high, axis);
    if (order == 2)
        goto unsure;
    if (order >= 0)
        return;                          /* a point or nothing: no face is cut */
    s->kind[q] = PAIR_SEGMENT;
    s->ends[2 * q] = *end_low;
    s->ends[2 * q + 1] = *end_high;
    return;
unsure:
    s->kind[q] = PAIR_UNSURE;
}

/* ---- the whole stage ------------------------------------------------------------------------------ */

#define FACES_PER_BLOCK 32

typedef struct {
    Shared *s;
    const int64_t *faces;     /* faces with segments, ascending */
    int64_t n_faces;
    Out *outs;                /* per block */
    Face *scratch;            /* per worker */
    Segment **segs;
    int *cap_segs;
    CellRef **cells, **next;
    int *cap_cells;
    int memory;
} Job;

static void pair_block(void *ctx, int64_t block)
{
    Job *job = ctx;
    int64_t end = (block + 1) * 1024 < job->s->p ? (block + 1) * 1024 : job->s->p;
    for (int64_t q = block * 1024; q < end; q++)
        pair_segment(job->s, q);
}

static void face_block(void *ctx, int worker, int64_t block)
{
    Job *job = ctx;
    Face *c = job->scratch + worker;
    Out *o = job->outs + block;
    int64_t end = (block + 1) * FACES_PER_BLOCK < job->n_faces ? (block + 1) * FACES_PER_BLOCK : job->n_faces;
    for (int64_t k = block * FACES_PER_BLOCK; k < end; k++) {
        int64_t t = job->faces[k];
        if (job->s->status[t] == 2)
            continue;
        int done = cut_face(c, o, t, job->segs + worker, job->cap_segs + worker, job->cells + worker,
                            job->next + worker, job->cap_cells + worker);
        if (done < 0) {
            job->memory = 1;
            return;
        }
        job->s->status[t] = done ? 1 : 2;
        job->s->drop[t] = (int8_t)c->drop;
    }
}

void arranged_free(Arranged *a)
{
    buf_free(&a->face), buf_free(&a->count), buf_free(&a->corners);
    buf_free(&a->inner), buf_free(&a->points), buf_free(&a->errors), buf_free(&a->defs);
}

int arrange_cut(const double *V, const int64_t *F, int64_t n, int64_t m, const int64_t *pairs, int64_t p, int threads,
                int8_t *kind, int8_t *status, int8_t *drop, Arranged *result)
{
    Shared s = {V, F, n, m, p, pairs, NULL, kind, NULL, NULL, NULL, status, drop};
    Job job;
    memset(&job, 0, sizeof(job));
    memset(result, 0, sizeof(*result));
    int ok = -1;
    int64_t n_faces = 0, blocks = 0, points = 0;
    threads = threads < 1 ? 1 : (threads > 64 ? 64 : threads);
    int64_t *faces = malloc(sizeof(int64_t) * (m ? m : 1));
    s.normal = malloc(sizeof(fx) * 3 * (m ? m : 1));
    s.ends = malloc(sizeof(End) * 2 * (p ? p : 1));
    s.begin = calloc(m + 1, sizeof(int64_t));
    s.list = malloc(sizeof(int64_t) * 2 * (p ? p : 1));
    int64_t *fill = malloc(sizeof(int64_t) * (m ? m : 1));
    if (!s.normal || !s.ends || !s.begin || !s.list || !faces || !fill)
        goto done;
    memset(status, 0, m);
    memset(drop, 0, m);
    for (int64_t q = 0; q < 2 * p; q++)
        s.begin[pairs[q] + 1]++;
    for (int64_t t = 0; t < m; t++) {
        if (s.begin[t + 1])
            face_normal(&s, t);
        s.begin[t + 1] += s.begin[t];
    }
    memcpy(fill, s.begin, sizeof(int64_t) * m);
    for (int64_t q = 0; q < p; q++) {
        s.list[fill[pairs[2 * q]]++] = q;
        s.list[fill[pairs[2 * q + 1]]++] = q;
    }
    job.s = &s;
    parallel_blocks(threads, (p + 1023) / 1024, pair_block, &job);
    for (int64_t t = 0; t < m; t++) {
        int cut = 0, unsure = 0;
        for (int64_t k = s.begin[t]; k < s.begin[t + 1]; k++) {
            int8_t x = kind[s.list[k]];
            cut |= x == PAIR_SEGMENT || x == PAIR_COPLANAR;
            unsure |= x == PAIR_UNSURE;
        }
        if (unsure)
            status[t] = 2;
        if (cut || unsure)
            faces[n_faces++] = t;
    }
    blocks = (n_faces + FACES_PER_BLOCK - 1) / FACES_PER_BLOCK;
    if (threads > blocks)
        threads = blocks > 1 ? (int)blocks : 1;          /* no scratch for workers that would have no block */
    job.faces = faces;
    job.n_faces = n_faces;
    job.outs = calloc(blocks ? blocks : 1, sizeof(Out));
    job.scratch = calloc(threads, sizeof(Face));
    job.segs = calloc(threads, sizeof(Segment *));
    job.cap_segs = calloc(threads, sizeof(int));
    job.cells = calloc(threads, sizeof(CellRef *));
    job.next = calloc(threads, sizeof(CellRef *));
    job.cap_cells = calloc(threads, sizeof(int));
    if (!job.outs || !job.scratch || !job.segs || !job.cap_segs || !job.cells || !job.next || !job.cap_cells)
        goto done;
    for (int w = 0; w < threads; w++) {
        job.scratch[w].s = &s;
        job.scratch[w].exact = malloc(sizeof(Exact));      /* NULL: open signs hand the face back */
        job.cells[w] = malloc(sizeof(CellRef) * 64);
        job.next[w] = malloc(sizeof(CellRef) * 64);
        job.cap_cells[w] = 64;
        if (!job.cells[w] || !job.next[w])
            goto done;
    }
    parallel_workers(threads, blocks, face_block, &job);
    if (job.memory)
        goto done;
    /* one output, blocks in order; new points renumbered after the earlier blocks' */
    for (int64_t b = 0; b < blocks; b++) {
        Out *o = job.outs + b;
        int64_t *ids = (int64_t *)o->corners.data;
        for (size_t k = 0; k < o->corners.size / 8; k++)
            if (ids[k] >= n)
                ids[k] += points;
        points += o->n_points;
        if ((o->face.size && out_push(&result->face, o->face.data, o->face.size) < 0)
            || (o->count.size && out_push(&result->count, o->count.data, o->count.size) < 0)
            || (o->corners.size && out_push(&result->corners, o->corners.data, o->corners.size) < 0)
            || (o->inner.size && out_push(&result->inner, o->inner.data, o->inner.size) < 0)
            || (o->points.size && out_push(&result->points, o->points.data, o->points.size) < 0)
            || (o->errors.size && out_push(&result->errors, o->errors.data, o->errors.size) < 0)
            || (o->defs.size && out_push(&result->defs, o->defs.data, o->defs.size) < 0))
            goto done;
        result->n_cells += o->n_cells;
    }
    result->n_points = points;
    ok = 0;
done:
    if (job.outs)
        for (int64_t b = 0; b < blocks; b++)
            arranged_free(job.outs + b);
    if (job.scratch)
        for (int w = 0; w < threads; w++) {
            Face *c = job.scratch + w;
            free(c->pts), free(c->lns), free(c->c_pt), free(c->c_ln), free(c->c_in), free(c->exact);
            if (job.segs)
                free(job.segs[w]);
            if (job.cells)
                free(job.cells[w]);
            if (job.next)
                free(job.next[w]);
        }
    free(job.outs), free(job.scratch), free(job.segs), free(job.cap_segs), free(job.cells), free(job.next);
    free(job.cap_cells);
    free(faces), free(fill), free(s.normal), free(s.ends), free(s.begin), free(s.list);
    if (ok < 0)
        arranged_free(result);
    return ok;
}

/* ---- labels: winding numbers at points inside the pieces (as _Soup.windings) ----------------------- */

/* A query: the winding number at q + sigma (eps e1 + eps^2 e2) (eps > 0 infinitesimal; e1, e2 the axes
 * after `axis`), q a point of face t's plane strictly inside the piece; counted along the ray +axis
 * (Simulation of Simplicity, as the exact path).  Faces in t's plane are crossed or not by the
 * perturbation alone.  A query whose every test the filter settles is answered; any other is handed
 * back (the exact path answers it, or finds q on another face and asks at another point). */

typedef struct {
    double origin[2], inverse[2];
    int side;
    int64_t *begin;           /* side * side + 1 */
    int32_t *face;
    uint8_t *needed;          /* per column: listed (a query may lie there); others are left empty */
} Columns;

typedef struct {
    const double *V;
    const int64_t *F, *weight;
    int64_t m;
    double *lo, *hi;          /* 3 per face */
    double low[3], high[3];   /* every face's box */
    Columns columns[3];
    const int64_t *qface;
    const double *qxy;
    int64_t k;
    double *approx;           /* 3 per query: about where its point is */
    uint8_t *axes;            /* per query: the axes its ray may take (bits) */
    int axis;                 /* the rays' common axis */
    const int64_t *pbegin, *plist;      /* per query: the faces in its face's plane that meet it (CSR) */
    int64_t *front, *net;
    int8_t *status, *owned;
    int memory;
} Labels;

static inline int column_of(const Columns *c, int d, double x)
{
    double v = (x - c->origin[d]) * c->inverse[d];
    if (!(v > 0.0))
        return 0;
    return v >= c->side - 1 ? c->side - 1 : (int)v;
}

/* A face listed in a column: (column, face), sorted into the columns after one pass over the faces. */
typedef struct {
    int64_t cell;
    int32_t face;
} Listed;

static int columns_build(Labels *L, int axis)
{
    Columns *c = L->columns + axis;
    int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    double lo[2] = {L->low[a1], L->low[a2]}, hi[2] = {L->high[a1], L->high[a2]};
    int side = (int)sqrt((double)L->m / 2.0);
    side = side < 1 ? 1 : (side > 1024 ? 1024 : side);
    Listed *listed = NULL;
    int64_t n_listed = 0, cap = 0;
    for (;;) {
        for (int d = 0; d < 2; d++) {
            c->origin[d] = L->m ? lo[d] : 0.0;
            double extent = L->m ? hi[d] - lo[d] : 1.0;
            c->inverse[d] = extent > 0.0 ? side / extent : 1.0;
        }
        c->side = side;
        free(c->needed);
        c->needed = calloc((size_t)side * side, 1);
        if (!c->needed) {
            free(listed);
            return -1;
        }
        /* only the columns about the queries' points are listed (a query reaching another is handed back);
         * `reach`: the range of columns those lie in */
        int reach[4] = {side, -1, side, -1};
        for (int64_t q = 0; q < L->k; q++) {
            if (!(L->axes[q] >> axis & 1))
                continue;
            const double *p = L->approx + 3 * q;
            double dx = 1e-6 * (hi[0] - lo[0]) + 1e-9 * fabs(p[a1]), dy = 1e-6 * (hi[1] - lo[1]) + 1e-9 * fabs(p[a2]);
            int x0 = column_of(c, 0, p[a1] - dx), x1 = column_of(c, 0, p[a1] + dx);
            int y0 = column_of(c, 1, p[a2] - dy), y1 = column_of(c, 1, p[a2] + dy);
            reach[0] = x0 < reach[0] ? x0 : reach[0], reach[1] = x1 > reach[1] ? x1 : reach[1];
            reach[2] = y0 < reach[2] ? y0 : reach[2], reach[3] = y1 > reach[3] ? y1 : reach[3];
            for (int x = x0; x <= x1; x++)
                for (int y = y0; y <= y1; y++)
                    c->needed[(int64_t)x * side + y] = 1;
        }
        /* A bound on the entries of every face's columns (a face spans at most its extent's columns plus two
         * along each axis): when it stays within 16 per face, no face needs its columns counted, and a face
         * whose box lies half a column or more outside the columns listed is passed over on its box alone. */
        double bound = 0.0, edge[4] = {-INFINITY, INFINITY, -INFINITY, INFINITY};
        for (int64_t t = 0; t < L->m; t++) {
            double cx = (L->hi[3 * t + a1] - L->lo[3 * t + a1]) * c->inverse[0] * (1 + 1e-12) + 2.000001;
            double cy = (L->hi[3 * t + a2] - L->lo[3 * t + a2]) * c->inverse[1] * (1 + 1e-12) + 2.000001;
            bound += (cx < side ? cx : side) * (cy < side ? cy : side);
        }
        int counted = !(side > 1 && L->m && bound <= 16.0 * (double)L->m * (1 - 1e-9)) || reach[1] < reach[0];
        if (!counted) {
            edge[0] = c->origin[0] + (reach[0] - 0.5) / c->inverse[0];
            edge[1] = c->origin[0] + (reach[1] + 1.5) / c->inverse[0];
            edge[2] = c->origin[1] + (reach[2] - 0.5) / c->inverse[1];
            edge[3] = c->origin[1] + (reach[3] + 1.5) / c->inverse[1];
        }
        /* one pass: each face's columns, counted, and those listed kept */
        int64_t entries = 0;
        n_listed = 0;
        for (int64_t t = 0; t < L->m; t++) {
            if (!counted && (L->hi[3 * t + a1] < edge[0] || L->lo[3 * t + a1] > edge[1]
                             || L->hi[3 * t + a2] < edge[2] || L->lo[3 * t + a2] > edge[3]))
                continue;                /* surely in no listed column */
            int x0 = column_of(c, 0, L->lo[3 * t + a1]), x1 = column_of(c, 0, L->hi[3 * t + a1]);
            int y0 = column_of(c, 1, L->lo[3 * t + a2]), y1 = column_of(c, 1, L->hi[3 * t + a2]);
            if (counted) {
                entries += (int64_t)(x1 - x0 + 1) * (y1 - y0 + 1);
                if (side > 1 && entries > 16 * L->m)
                    break;               /* large faces: fewer columns (below), before listing them all */
            }
            if (x1 < reach[0] || x0 > reach[1] || y1 < reach[2] || y0 > reach[3])
                continue;                /* in no listed column */
            x0 = x0 > reach[0] ? x0 : reach[0], x1 = x1 < reach[1] ? x1 : reach[1];
            y0 = y0 > reach[2] ? y0 : reach[2], y1 = y1 < reach[3] ? y1 : reach[3];
            for (int x = x0; x <= x1; x++)
                for (int y = y0; y <= y1; y++) {
                    int64_t cell = (int64_t)x * side + y;
                    if (!c->needed[cell])
                        continue;
                    if (n_listed == cap) {
                        int64_t grown = cap ? 2 * cap : 1024;
                        Listed *more = realloc(listed, sizeof(Listed) * grown);
                        if (!more) {
                            free(listed);
                            return -1;
                        }
                        listed = more, cap = grown;
                    }
                    listed[n_listed++] = (Listed){cell, (int32_t)t};
                }
        }
        if (side > 1 && entries > 16 * L->m) {
            side = side / 2 > 1 ? side / 2 : 1;       /* large faces: fewer, larger columns */
            continue;
        }
        break;
    }
    /* the listed faces sorted into their columns, each column's faces ascending */
    c->begin = calloc((size_t)side * side + 1, sizeof(int64_t));
    c->face = malloc(sizeof(int32_t) * (n_listed ? n_listed : 1));
    if (!c->begin || !c->face) {
        free(listed);
        return -1;
    }
    for (int64_t e = 0; e < n_listed; e++)
        c->begin[listed[e].cell + 1]++;
    for (int64_t q = 0; q < (int64_t)side * side; q++)
        c->begin[q + 1] += c->begin[q];
    for (int64_t e = 0; e < n_listed; e++)
        c->face[c->begin[listed[e].cell]++] = listed[e].face;
    for (int64_t q = (int64_t)side * side; q > 0; q--)
        c->begin[q] = c->begin[q - 1];
    c->begin[0] = 0;
    free(listed);
    return 0;
}

static inline const double *lcorner(const Labels *L, int64_t f, int k) { return L->V + 3 * L->F[3 * f + k]; }

/* Exact sign of the component `axis` of face f's normal (b - a) x (c - a). */
static inline int normal_sign(const Labels *L, int64_t f, int axis)
{
    int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    const double *a = lcorner(L, f, 0), *b = lcorner(L, f, 1), *c = lcorner(L, f, 2);
    return orient2d(a[a1], a[a2], b[a1], b[a2], c[a1], c[a2]);
}

/* The query point (face t's plane over (x, y) on axes i, j) as exact expansions X[3], W, in e. */
typedef struct {
    int64_t t;
    int drop, i, j;
    double x, y;
    Exact *e;                 /* scratch; NULL: no exact evaluation */
    Xp X[3], W;
    int ready;                /* X, W computed (1), failed (-1), not yet (0) */
} Query;

static int query_exact(const Labels *L, Query *q)
{
    if (q->ready)
        return q->ready;
    q->ready = -1;
    if (!q->e)
        return -1;
    Shared s;
    memset(&s, 0, sizeof(s));
    s.V = L->V, s.F = L->F;
    Exact *e = q->e;
    if (x_normal(&s, q->t, e, e->n1) < 0)
        return -1;
    const double *a = lcorner(L, q->t, 0);
    Xp v;
    x_copy(&q->W, e->n1 + q->drop);
    x_of(&v, q->x);
    if (x_mul(q->X + q->i, e->n1 + q->drop, &v, 1.0, 0) < 0)
        return -1;
    x_of(&v, q->y);
    if (x_mul(q->X + q->j, e->n1 + q->drop, &v, 1.0, 0) < 0)
        return -1;
    /* X_d = n_d a_d - n_i (x - a_i) - n_j (y - a_j) */
    Xp *out = q->X + q->drop;
    x_of(&v, a[q->drop]);
    if (x_mul(out, e->n1 + q->drop, &v, 1.0, 0) < 0)
        return -1;
    x_diff(&v, q->x, a[q->i]);
    if (x_mul(out, e->n1 + q->i, &v, -1.0, 1) < 0)
        return -1;
    x_diff(&v, q->y, a[q->j]);
    if (x_mul(out, e->n1 + q->j, &v, -1.0, 1) < 0)
        return -1;
    q->ready = 1;
    return 1;
}

/* Exact sign of orient2d(U, V, q) on axes a1, a2 (times W^2 > 0); 2 when it could not be found. */
static int exact_turn(const Labels *L, Query *q, const double *U, const double *V, int a1, int a2)
{
    if (query_exact(L, q) < 0)
        return 2;
    Exact *e = q->e;
    Xp v, *A = e->u, *B = e->u + 1, *C = e->w, *D = e->w + 1;
    const double *pt[2] = {U, V};
    Xp *slot[2][2] = {{A, C}, {D, B}};      /* U: (a1, a2) -> A, C; V: (a1, a2) -> D, B */
    int axes[2] = {a1, a2};
    for (int w = 0; w < 2; w++)
        for (int d = 0; d < 2; d++) {
            Xp *out = slot[w][d];
            out->n = 0;
            if (x_add(out, q->X + axes[d], -1.0) < 0)
                return 2;
            x_of(&v, pt[w][axes[d]]);
            if (x_mul(out, &q->W, &v, 1.0, 1) < 0)
                return 2;
        }
    /* (U_a1 W - X_a1)(V_a2 W - X_a2) - (U_a2 W - X_a2)(V_a1 W - X_a1) */
    if (x_det2(&e->N, A, B, C, D) < 0)
        return 2;
    double top = x_top(&e->N);
    return (top > 0) - (top < 0);
}

/* The weight face u adds to the query's count; 2 when a sign is unsure. */
static int64_t ahead(const Labels *L, int64_t t, int64_t u, const Pt *p, Query *query, int axis, int sigma,
                     int *unsure)
{
    int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    const double *a = lcorner(L, u, 0), *b = lcorner(L, u, 1), *c = lcorner(L, u, 2);
    /* level: n_u . (q - a) times W */
    fx du[3], dv[3], n[3];
    for (int k = 0; k < 3; k++) {
        du[k] = fx_diff(b[k], a[k]);
        dv[k] = fx_diff(c[k], a[k]);
    }
    fx_cross(du, dv, n);
    fx level = fx_c(0.0);
    for (int k = 0; k < 3; k++)
        level = fx_add(level, fx_mul(n[k], fx_sub(p->X[k], fx_mul(fx_c(a[k]), p->W))));
    int side = fx_sign(level);
    if (side == 0) {
        /* on u's plane: allowed only when u lies in t's plane (then the perturbation decides) */
        const double *o = lcorner(L, t, 0), *q = lcorner(L, t, 1), *r = lcorner(L, t, 2);
        if (u != t && (orient3d(o, q, r, a) != 0 || orient3d(o, q, r, b) != 0 || orient3d(o, q, r, c) != 0)) {
            *unsure = 1;
            return 0;
        }
    }
    int facing = normal_sign(L, u, axis);
    if (facing == 0)
        return 0;
    const double *corners[3] = {a, b, c};
    int undecided = 0;
    for (int k = 0; k < 3; k++) {
        const double *x = corners[k], *y = corners[(k + 1) % 3];
        fx xa = fx_sub(fx_mul(fx_c(x[a1]), p->W), p->X[a1]), xb = fx_sub(fx_mul(fx_c(x[a2]), p->W), p->X[a2]);
        fx ya = fx_sub(fx_mul(fx_c(y[a1]), p->W), p->X[a1]), yb = fx_sub(fx_mul(fx_c(y[a2]), p->W), p->X[a2]);
        int o = fx_sign(fx_sub(fx_mul(xa, yb), fx_mul(xb, ya)));
        if (o == 0) {
            o = exact_turn(L, query, x, y, a1, a2);
            if (o == 0)                  /* on the edge's line: the perturbation decides, as the exact path */
                o = sigma * ((x[a2] > y[a2]) - (x[a2] < y[a2]));
            if (o == 0)
                o = sigma * ((y[a1] > x[a1]) - (y[a1] < x[a1]));
        }
        if (o == 2 || o == 0)
            undecided = 1;
        else if (o != facing)
            return 0;                    /* the ray certainly misses u */
    }
    if (undecided) {
        *unsure = 1;
        return 0;
    }
    if (side == 0)
        side = sigma * (normal_sign(L, u, a1) ? normal_sign(L, u, a1) : normal_sign(L, u, a2));
    return -side * facing > 0 ? L->weight[u] * facing : 0;
}

/* The ray's axis for a query on face t: the common one (L->axis) unless t's normal lies along it, then
 * the next axis on which it leans (exact signs). */
static int ray_axis(const Labels *L, int64_t t)
{
    for (int k = 0; k < 3; k++) {
        int axis = (L->axis + k) % 3;
        if (normal_sign(L, t, (axis + 1) % 3) != 0 || normal_sign(L, t, (axis + 2) % 3) != 0)
            return axis;
    }
    return L->axis;               /* never: the face has non-zero area */
}

static void label_block(void *ctx, int64_t block)
{
    Labels *L = ctx;
    Query query;
    query.e = malloc(sizeof(Exact));         /* NULL: edges the filter cannot settle are handed back */
    int64_t end = (block + 1) * 256 < L->k ? (block + 1) * 256 : L->k;
    fx normal[3];
    for (int64_t q = block * 256; q < end; q++) {
        int64_t t = L->qface[q];
        L->status[q] = 1;
        const double *a = lcorner(L, t, 0), *b = lcorner(L, t, 1), *c = lcorner(L, t, 2);
        int drop = triangle_axis(a, b, c);
        if (drop < 0)
            continue;
        int i = (drop + 1) % 3, j = (drop + 2) % 3;
        double x = L->qxy[2 * q], y = L->qxy[2 * q + 1];
        Pt p;
        /* the normal of t, for make_proj (which reads s.normal + 3 t) */
        fx du[3], dv[3];
        for (int k = 0; k < 3; k++)
            du[k] = fx_diff(b[k], a[k]), dv[k] = fx_diff(c[k], a[k]);
        fx_cross(du, dv, normal);
        if (x != x || y != y) {
            /* a face's own query: its centroid, certified inside below */
            x = (a[i] + b[i] + c[i]) / 3.0, y = (a[j] + b[j] + c[j]) / 3.0;
            if (!make_proj_n(&p, normal, a, drop, i, j, x, y))
                continue;
            int sense = orient2d(a[i], a[j], b[i], b[j], c[i], c[j]), inside = 1;
            const double *cs[3] = {a, b, c};
            for (int k = 0; k < 3 && inside; k++) {
                const double *u = cs[k], *v = cs[(k + 1) % 3];
                fx ui = fx_sub(fx_mul(fx_c(u[i]), p.W), p.X[i]), uj = fx_sub(fx_mul(fx_c(u[j]), p.W), p.X[j]);
                fx vi = fx_sub(fx_mul(fx_c(v[i]), p.W), p.X[i]), vj = fx_sub(fx_mul(fx_c(v[j]), p.W), p.X[j]);
                inside = fx_sign(fx_sub(fx_mul(ui, vj), fx_mul(uj, vi))) * sense > 0;
            }
            if (!inside) {
                L->status[q] = 2;
                continue;
            }
        } else if (!make_proj_n(&p, normal, a, drop, i, j, x, y))
            continue;
        /* the ray: along one axis for every query where it can be (fewer columns to list).  Any axis
         * gives the same winding number; the perturbation needs t's normal to lean on an axis after it. */
        int axis = ray_axis(L, t);
        int a1 = (axis + 1) % 3;
        int sigma = normal_sign(L, t, a1) ? normal_sign(L, t, a1) : normal_sign(L, t, (axis + 2) % 3);
        const Columns *col = L->columns + axis;
        if (!col->begin)
            continue;
        int b1 = (axis + 1) % 3, b2 = (axis + 2) % 3;
        /* the columns the point may be in (its coordinates within their certified bounds) */
        double wl = p.W.v - p.W.e;
        if (!(wl > 0.0))
            continue;
        double cx = p.X[b1].v / p.W.v, cy = p.X[b2].v / p.W.v;
        double rx = (p.X[b1].e + fabs(cx) * p.W.e) / wl * 2.0 + fabs(cx) * 4 * EPS + FX_TINY;
        double ry = (p.X[b2].e + fabs(cy) * p.W.e) / wl * 2.0 + fabs(cy) * 4 * EPS + FX_TINY;
        double cz = p.X[axis].v / p.W.v;
        double rz = (p.X[axis].e + fabs(cz) * p.W.e) / wl * 2.0 + fabs(cz) * 4 * EPS + FX_TINY;
        int x0 = column_of(col, 0, cx - rx), x1 = column_of(col, 0, cx + rx);
        int y0 = column_of(col, 1, cy - ry), y1 = column_of(col, 1, cy + ry);
        int unsure = 0;
        int64_t total = 0;
        query.t = t, query.drop = drop, query.i = i, query.j = j, query.x = x, query.y = y, query.ready = 0;
        for (int gx = x0; gx <= x1 && !unsure; gx++)
            for (int gy = y0; gy <= y1 && !unsure; gy++) {
                int64_t cell = (int64_t)gx * col->side + gy;
                if (!col->needed[cell]) {
                    unsure = 1;          /* a column not listed: the exact path counts this one */
                    break;
                }
                for (int64_t e = col->begin[cell]; e < col->begin[cell + 1] && !unsure; e++) {
                    int64_t u = col->face[e];
                    const double *lo = L->lo + 3 * u, *hi = L->hi + 3 * u;
                    if (lo[b1] > cx + rx || hi[b1] < cx - rx || lo[b2] > cy + ry || hi[b2] < cy - ry
                        || hi[axis] < cz - rz)
                        continue;        /* the box misses every point the query may be, or lies behind */
                    /* each face once: in the first column both the query's and the face's ranges hold */
                    int fx0 = column_of(col, 0, lo[b1]), fy0 = column_of(col, 1, lo[b2]);
                    if (gx != (fx0 > x0 ? fx0 : x0) || gy != (fy0 > y0 ? fy0 : y0))
                        continue;
                    total += ahead(L, t, u, &p, &query, axis, sigma, &unsure);
                }
            }
        if (unsure)
            continue;
        /* the net weight on the piece: its face's, and that of every face in its plane that holds the
         * point strictly inside (as the exact path's _contains); the piece is owned when those are all
         * numbered after its face */
        int64_t net = L->weight[t];
        int owned = 1;
        int sign_t = normal_sign(L, t, drop);
        for (int64_t e = L->pbegin[q]; e < L->pbegin[q + 1] && !unsure; e++) {
            int64_t u = L->plist[e];
            const double *cu[3] = {lcorner(L, u, 0), lcorner(L, u, 1), lcorner(L, u, 2)};
            int sense = orient2d(cu[0][i], cu[0][j], cu[1][i], cu[1][j], cu[2][i], cu[2][j]);
            int inside = sense != 0;
            for (int k = 0; k < 3 && inside && !unsure; k++) {
                const double *x1 = cu[k], *y1 = cu[(k + 1) % 3];
                fx xa = fx_sub(fx_mul(fx_c(x1[i]), p.W), p.X[i]), xb = fx_sub(fx_mul(fx_c(x1[j]), p.W), p.X[j]);
                fx ya = fx_sub(fx_mul(fx_c(y1[i]), p.W), p.X[i]), yb = fx_sub(fx_mul(fx_c(y1[j]), p.W), p.X[j]);
                int o = fx_sign(fx_sub(fx_mul(xa, yb), fx_mul(xb, ya)));
                if (o == 0)
                    o = exact_turn(L, &query, x1, y1, i, j);
                if (o == 2)
                    unsure = 1;
                inside = o * sense > 0;
            }
            if (inside && !unsure) {
                net += L->weight[u] * normal_sign(L, u, drop) * sign_t;
                owned = owned && u > t;
            }
        }
        if (unsure)
            continue;
        L->front[q] = total;
        L->net[q] = net;
        L->owned[q] = (int8_t)owned;
        L->status[q] = 0;
    }
    free(query.e);
}

int label_queries(const double *V, const int64_t *F, const int64_t *weight, int64_t m, const int64_t *qface,
                  const double *qxy, const int64_t *pbegin, const int64_t *plist, int64_t k, int threads,
                  int64_t *front, int64_t *net, int8_t *owned, int8_t *status)
{
    Labels L;
    memset(&L, 0, sizeof(L));
    L.V = V, L.F = F, L.weight = weight, L.m = m, L.qface = qface, L.qxy = qxy, L.k = k;
    L.pbegin = pbegin, L.plist = plist;
    L.front = front, L.net = net, L.owned = owned, L.status = status;
    int ok = -1;
    L.lo = malloc(sizeof(double) * 3 * (m ? m : 1));
    L.hi = malloc(sizeof(double) * 3 * (m ? m : 1));
    if (!L.lo || !L.hi)
        goto done;
    for (int d = 0; d < 3; d++)
        L.low[d] = INFINITY, L.high[d] = -INFINITY;
    for (int64_t t = 0; t < m; t++) {
        const double *a = lcorner(&L, t, 0), *b = lcorner(&L, t, 1), *c = lcorner(&L, t, 2);
        for (int d = 0; d < 3; d++) {
            L.lo[3 * t + d] = dmin(a[d], dmin(b[d], c[d]));
            L.hi[3 * t + d] = dmax(a[d], dmax(b[d], c[d]));
            L.low[d] = dmin(L.low[d], L.lo[3 * t + d]), L.high[d] = dmax(L.high[d], L.hi[3 * t + d]);
        }
    }
    /* columns only along the axes the queries' rays take, listed only about the queries' points; the
     * common axis is the one the faces' box is thinnest along (rays cross fewer faces, as a rule) */
    int used[3] = {0, 0, 0};
    L.axis = 0;
    for (int d = 1; d < 3; d++)
        if (L.high[d] - L.low[d] < L.high[L.axis] - L.low[L.axis])
            L.axis = d;
    L.approx = malloc(sizeof(double) * 3 * (k ? k : 1));
    L.axes = malloc(k ? k : 1);
    if (!L.approx || !L.axes)
        goto done;
    for (int64_t q = 0; q < k; q++) {
        const double *a = lcorner(&L, qface[q], 0), *b = lcorner(&L, qface[q], 1), *c = lcorner(&L, qface[q], 2);
        double n[3];
        for (int d = 0; d < 3; d++) {
            int d1 = (d + 1) % 3, d2 = (d + 2) % 3;
            n[d] = (b[d1] - a[d1]) * (c[d2] - a[d2]) - (b[d2] - a[d2]) * (c[d1] - a[d1]);
        }
        L.axes[q] = (uint8_t)(1 << ray_axis(&L, qface[q]));
        used[ray_axis(&L, qface[q])] = 1;
        int drop = 0;
        for (int d = 1; d < 3; d++)
            if (fabs(n[d]) > fabs(n[drop]))
                drop = d;
        int i = (drop + 1) % 3, j = (drop + 2) % 3;
        double *p = L.approx + 3 * q, x = qxy[2 * q], y = qxy[2 * q + 1];
        if (x != x || y != y)
            x = (a[i] + b[i] + c[i]) / 3.0, y = (a[j] + b[j] + c[j]) / 3.0;
        p[i] = x, p[j] = y;
        p[drop] = n[drop] != 0.0 ? a[drop] - (n[i] * (x - a[i]) + n[j] * (y - a[j])) / n[drop] : a[drop];
    }
    for (int axis = 0; axis < 3; axis++)
        if (used[axis] && columns_build(&L, axis) < 0)
            goto done;
    parallel_blocks(threads, (k + 255) / 256, label_block, &L);
    ok = 0;
done:
    for (int axis = 0; axis < 3; axis++)
        free(L.columns[axis].begin), free(L.columns[axis].face), free(L.columns[axis].needed);
    free(L.lo), free(L.hi), free(L.approx), free(L.axes);
    return ok;
}

/* ---- patches: uncut faces joined across edges that exactly two faces use, once each way ------------- */

static int64_t root_of(int64_t *parent, int64_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

/* A corner of a face at a vertex: the face, and the vertices its edges there lead to and come from. */
typedef struct {
    int32_t next, prev;
    uint32_t face;
} Corner;

int patch_labels(const int64_t *F, int64_t m, int64_t n, const uint8_t *cut, int64_t *label)
{
    if (m >= ((int64_t)1 << 32))
        return -1;
    int64_t *begin = calloc(n + 1, sizeof(int64_t));
    Corner *around = malloc(sizeof(Corner) * (3 * m + 1));       /* the corners at each vertex (vertices < 2**31) */
    if (!begin || !around) {
        free(begin), free(around);
        return -1;
    }
    for (int64_t i = 0; i < 3 * m; i++)
        begin[F[i] + 1]++;
    for (int64_t v = 0; v < n; v++)
        begin[v + 1] += begin[v];
    for (int64_t t = 0; t < m; t++)
        for (int k = 0; k < 3; k++)
            around[begin[F[3 * t + k]]++] = (Corner){(int32_t)F[3 * t + (k + 1) % 3], (int32_t)F[3 * t + (k + 2) % 3],
                                                     (uint32_t)t};
    for (int64_t v = n; v > 0; v--)
        begin[v] = begin[v - 1];
    begin[0] = 0;
    for (int64_t t = 0; t < m; t++)
        label[t] = t;
    /* vertex by vertex (its corners are together in memory), each edge a -> b of an uncut face leaving a with
     * a < b: the face across, if it pairs with this one, runs b -> a, seen from there.  Each patch's label
     * is its lowest face whatever the order of the unions. */
    for (int64_t a = 0; a < n; a++) {
        const Corner *first = around + begin[a], *end = around + begin[a + 1];
        for (const Corner *x = first; x < end; x++) {
            int64_t b = x->next, t = x->face;
            if (a > b || cut[t])
                continue;
            /* the edges a -> b and b -> a of every face: each leaves one of a's corners or enters one */
            int count = 0;
            int64_t other = -1;
            int reverse = 0;
            for (const Corner *c = first; c < end; c++) {
                if (c->next == b) {
                    count++;
                    if (c->face != t)
                        other = c->face, reverse = 0;
                }
                if (c->prev == b) {
                    count++;
                    if (c->face != t)
                        other = c->face, reverse = 1;
                }
            }
            if (count == 2 && other >= 0 && reverse && !cut[other]) {
                int64_t r = root_of(label, t), y = root_of(label, other);
                if (r != y)
                    label[r > y ? r : y] = r < y ? r : y;
            }
        }
    }
    for (int64_t t = 0; t < m; t++)
        label[t] = root_of(label, t);
    free(begin), free(around);
    return 0;
}

/* ---- exact rounding of the points kept ------------------------------------------------------------ */

typedef struct {
    Shared s;
    const int64_t *defs;
    double *q, *err;
    int64_t k;
} Refine;

static void refine_block(void *ctx, int64_t block)
{
    Refine *r = ctx;
    Exact *e = malloc(sizeof(Exact));
    if (!e)
        return;                              /* the filter's bounds stay */
    int64_t end = (block + 1) * 64 < r->k ? (block + 1) * 64 : r->k;
    Face c;
    memset(&c, 0, sizeof(c));
    c.s = &r->s;
    for (int64_t x = block * 64; x < end; x++) {
        const int64_t *d = r->defs + 7 * x;
        Pt p;
        memset(&p, 0, sizeof(p));
        p.kind = (int8_t)d[0], p.a = d[1], p.b = d[2], p.c = d[3], p.d = d[4];
        p.origin = p.kind == PT_TPI ? r->s.F[3 * p.a] : p.a;
        c.i = (int)d[5], c.j = (int)d[6];
        double q[3] = {r->q[3 * x], r->q[3 * x + 1], r->q[3 * x + 2]}, err[3];
        if (exact_round(&c, &p, e, q, err) == 0)
            for (int k = 0; k < 3; k++)
                if (isfinite(q[k]) && isfinite(err[k]) && err[k] <= r->err[3 * x + k])
                    r->q[3 * x + k] = q[k], r->err[3 * x + k] = err[k];
    }
    free(e);
}

void refine_points(const double *V, const int64_t *F, const int64_t *defs, int64_t k, double *q, double *err,
                   int threads)
{
    Refine r;
    memset(&r, 0, sizeof(r));
    r.s.V = V, r.s.F = F;
    r.defs = defs, r.q = q, r.err = err, r.k = k;
    parallel_blocks(threads, (k + 63) / 64, refine_block, &r);
}
