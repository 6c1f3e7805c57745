/* Exact triangle intersection and point-in-solid tests for massprops.
 *
 * Every decision comes from the signs of two exact predicates, orient3d and
 * orient2d (predicates.h).  The caller passes coordinates scaled to about
 * unit size whose non-zero magnitudes are at least 2**-200, so no product
 * under- or overflows and the predicates are exact.
 *
 * Entry points (the GIL is released while they run):
 *   degenerate(V, F, out)            which triangles have zero area (exactly)
 *   pairs(V, F, shell, active, ...)  triangle pairs that intersect, through a
 *                                    hierarchical hash grid, in threads
 *   winding(V, F, points)            winding numbers of points off the surface
 *   orient3d_signs(P)                a batch of the predicate
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "predicates.h"

/* ---- buffers ------------------------------------------------------------------------------- */

static int get_buffer(PyObject *obj, Py_buffer *view, Py_ssize_t itemsize, int writable, const char *name)
{
    if (PyObject_GetBuffer(obj, view, PyBUF_C_CONTIGUOUS | (writable ? PyBUF_WRITABLE : 0)) < 0)
        return -1;
    if (view->len % itemsize != 0) {
        PyErr_Format(PyExc_ValueError, "%s: expected items of %zd bytes", name, itemsize);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

/* The buffers of vertices (float64), faces (int64) and a third array; all or none are held. */
static int get_three(PyObject *vo, PyObject *fo, PyObject *xo, Py_buffer *vb, Py_buffer *fb, Py_buffer *xb,
                     Py_ssize_t x_itemsize, int x_writable, const char *x_name)
{
    if (get_buffer(vo, vb, 8, 0, "vertices") < 0)
        return -1;
    if (get_buffer(fo, fb, 8, 0, "faces") < 0) {
        PyBuffer_Release(vb);
        return -1;
    }
    if (get_buffer(xo, xb, x_itemsize, x_writable, x_name) < 0) {
        PyBuffer_Release(vb);
        PyBuffer_Release(fb);
        return -1;
    }
    return 0;
}

static PyObject *py_degenerate(PyObject *self, PyObject *args)
{
    PyObject *vo, *fo, *oo;
    Py_buffer vb, fb, ob;
    if (!PyArg_ParseTuple(args, "OOO", &vo, &fo, &oo) || get_three(vo, fo, oo, &vb, &fb, &ob, 1, 1, "out") < 0)
        return NULL;
    const double *V = vb.buf;
    const int64_t *F = fb.buf;
    uint8_t *out = ob.buf;
    Py_ssize_t m = fb.len / 24;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t t = 0; t < m; t++)
        out[t] = triangle_axis(V + 3 * F[3 * t], V + 3 * F[3 * t + 1], V + 3 * F[3 * t + 2]) < 0;
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&vb);
    PyBuffer_Release(&fb);
    PyBuffer_Release(&ob);
    Py_RETURN_NONE;
}

/* ---- sorting and Morton codes -------------------------------------------------------------- */

/* Sort (key, value) pairs by key: LSD radix sort on 8-bit digits, histograms in one pass, digits
 * that every key shares skipped.  tk, tv: scratch of n entries.  The sorted pairs end in key, value. */
static int radix_sort(uint64_t *key, uint32_t *value, uint64_t *tk, uint32_t *tv, Py_ssize_t n)
{
    size_t (*count)[256] = calloc(8, sizeof(*count));
    if (!count)
        return -1;
    for (Py_ssize_t i = 0; i < n; i++) {
        uint64_t k = key[i];
        for (int d = 0; d < 8; d++)
            count[d][(k >> (8 * d)) & 0xFF]++;
    }
    uint64_t *src_k = key, *dst_k = tk;
    uint32_t *src_v = value, *dst_v = tv;
    for (int d = 0; d < 8; d++) {
        int shift = 8 * d;
        if (n == 0 || count[d][(key[0] >> shift) & 0xFF] == (size_t)n)
            continue;
        size_t sum = 0;
        for (int b = 0; b < 256; b++) {
            size_t c = count[d][b];
            count[d][b] = sum;
            sum += c;
        }
        for (Py_ssize_t i = 0; i < n; i++) {
            size_t slot = count[d][(src_k[i] >> shift) & 0xFF]++;
            dst_k[slot] = src_k[i];
            dst_v[slot] = src_v[i];
        }
        uint64_t *xk = src_k;
        src_k = dst_k;
        dst_k = xk;
        uint32_t *xv = src_v;
        src_v = dst_v;
        dst_v = xv;
    }
    if (src_k != key) {
        memcpy(key, src_k, sizeof(uint64_t) * n);
        memcpy(value, src_v, sizeof(uint32_t) * n);
    }
    free(count);
    return 0;
}

static inline uint64_t spread21(uint64_t x)
{
    x &= 0x1FFFFF;
    x = (x | x << 32) & 0x1F00000000FFFFULL;
    x = (x | x << 16) & 0x1F0000FF0000FFULL;
    x = (x | x << 8) & 0x100F00F00F00F00FULL;
    x = (x | x << 4) & 0x10C30C30C30C30C3ULL;
    x = (x | x << 2) & 0x1249249249249249ULL;
    return x;
}

static inline uint64_t compact21(uint64_t x)
{
    x &= 0x1249249249249249ULL;
    x = (x | x >> 2) & 0x10C30C30C30C30C3ULL;
    x = (x | x >> 4) & 0x100F00F00F00F00FULL;
    x = (x | x >> 8) & 0x1F0000FF0000FFULL;
    x = (x | x >> 16) & 0x1F00000000FFFFULL;
    x = (x | x >> 32) & 0x1FFFFF;
    return x;
}

static inline uint64_t morton(uint64_t i, uint64_t j, uint64_t k)
{
    return spread21(i) | spread21(j) << 1 | spread21(k) << 2;
}

/* ---- faces in space order, and the hierarchical grid ------------------------------------- */

#define MAX_LEVEL 40
#define INDEX_BITS 19
#define LEVEL_SHIFT (3 * INDEX_BITS)

typedef struct {
    const double *V;
    Py_ssize_t n;          /* faces taken: active, of non-zero area; in Morton order of their box centres */
    int64_t *id;           /* original face index */
    int64_t *corner;       /* 3 per face */
    int64_t *shell;
    double *lo, *hi;       /* 3 per face */
    int8_t *axis, *level;
    /* grid */
    double origin[3], size[MAX_LEVEL + 1], inverse[MAX_LEVEL + 1];
    int used[MAX_LEVEL + 1], n_used;
    Py_ssize_t level_begin[MAX_LEVEL + 2];   /* entries of each level: [begin[l], begin[l + 1]) */
    Py_ssize_t n_entries;
    uint64_t *key;         /* per entry, sorted */
    uint32_t *face;        /* per entry: index into the sorted faces */
} Grid;

static void free_grid(Grid *g)
{
    free(g->id);
    free(g->corner);
    free(g->shell);
    free(g->lo);
    free(g->hi);
    free(g->axis);
    free(g->level);
    free(g->key);
    free(g->face);
}

/* x is never below the origin, so truncation is the floor. */
static inline int64_t cell_of(const Grid *g, int level, int axis, double x)
{
    return (int64_t)((x - g->origin[axis]) * g->inverse[level]);
}

static inline uint64_t cell_key(int level, int64_t i, int64_t j, int64_t k)
{
    return ((uint64_t)level << LEVEL_SHIFT) | morton((uint64_t)i, (uint64_t)j, (uint64_t)k);
}

static void cell_range(const Grid *g, Py_ssize_t t, int level, int64_t *c0, int64_t *c1)
{
    for (int axis = 0; axis < 3; axis++) {
        c0[axis] = cell_of(g, level, axis, g->lo[3 * t + axis]);
        c1[axis] = cell_of(g, level, axis, g->hi[3 * t + axis]);
    }
}

static int compare_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static inline double face_extent(const double *lo, const double *hi)
{
    return dmax(hi[0] - lo[0], dmax(hi[1] - lo[1], hi[2] - lo[2]));
}

/* Build the sorted faces and the grid; 0 on success, -1 out of memory. */
static int build_grid(Grid *g, const double *V, const int64_t *F, const int64_t *shell, const uint8_t *active,
                      Py_ssize_t m)
{
    memset(g, 0, sizeof(*g));
    g->V = V;
    int8_t *axis = malloc(m ? m : 1);
    double *box = malloc(sizeof(double) * 6 * (m ? m : 1));     /* lo, hi of each face, input order */
    if (!axis || !box) {
        free(axis), free(box);
        return -1;
    }
    double glo[3] = {INFINITY, INFINITY, INFINITY}, ghi[3] = {-INFINITY, -INFINITY, -INFINITY};
    Py_ssize_t n = 0;
    for (Py_ssize_t t = 0; t < m; t++) {
        axis[t] = -1;
        if (!active[t])
            continue;
        P a = V + 3 * F[3 * t], b = V + 3 * F[3 * t + 1], c = V + 3 * F[3 * t + 2];
        axis[t] = (int8_t)triangle_axis(a, b, c);
        if (axis[t] < 0)
            continue;
        for (int k = 0; k < 3; k++) {
            double lo = dmin(a[k], dmin(b[k], c[k])), hi = dmax(a[k], dmax(b[k], c[k]));
            box[6 * t + k] = lo;
            box[6 * t + 3 + k] = hi;
            glo[k] = dmin(glo[k], lo);
            ghi[k] = dmax(ghi[k], hi);
        }
        n++;
    }
    if (n == 0 || n >= ((Py_ssize_t)1 << 32)) {
        free(axis), free(box);
        return n == 0 ? 0 : -1;
    }
    double whole = dmax(ghi[0] - glo[0], dmax(ghi[1] - glo[1], ghi[2] - glo[2]));
    if (!(whole > 0.0))
        whole = 1.0;
    /* The faces taken, in input order: exporters write neighbouring faces near each other, so the
     * cells' runs of faces stay near each other in memory too. */
    uint64_t *tk = malloc(sizeof(uint64_t) * n);
    uint32_t *tv = malloc(sizeof(uint32_t) * n);
    g->n = n;
    g->id = malloc(sizeof(int64_t) * n);
    g->corner = malloc(sizeof(int64_t) * 3 * n);
    g->shell = malloc(sizeof(int64_t) * n);
    g->lo = malloc(sizeof(double) * 3 * n);
    g->hi = malloc(sizeof(double) * 3 * n);
    g->axis = malloc(n);
    g->level = malloc(n);
    if (!tk || !tv || !g->id || !g->corner || !g->shell || !g->lo || !g->hi || !g->axis || !g->level) {
        free(axis), free(box), free(tk), free(tv);
        return -1;
    }
    Py_ssize_t s = 0;
    for (Py_ssize_t t = 0; t < m; t++) {
        if (axis[t] < 0)
            continue;
        g->id[s] = t;
        g->shell[s] = shell[t];
        g->axis[s] = axis[t];
        for (int k = 0; k < 3; k++) {
            g->corner[3 * s + k] = F[3 * t + k];
            g->lo[3 * s + k] = box[6 * t + k];
            g->hi[3 * s + k] = box[6 * t + 3 + k];
        }
        s++;
    }
    free(axis), free(box);
    /* The finest cell: twice the largest sampled face extent when that extent is at most twice
     * the 90th percentile (one level: no lookups across levels; cells twice the faces' size keep
     * the entries near 2.5 a face, measured best on the 1.31M icosphere), else that percentile
     * (larger faces go up a level per doubling); never below 2**-17 of the whole. */
    int samples = n < 4096 ? (int)n : 4096;
    double *extent = malloc(sizeof(double) * samples);
    if (!extent) {
        free(tk), free(tv);
        return -1;
    }
    for (int s = 0; s < samples; s++) {
        Py_ssize_t t = (Py_ssize_t)((double)s * n / samples);
        extent[s] = face_extent(g->lo + 3 * t, g->hi + 3 * t);
    }
    qsort(extent, samples, sizeof(double), compare_double);
    double base = extent[(samples * 9) / 10];
    if (extent[samples - 1] <= 2.0 * base)
        base = 2.0 * extent[samples - 1];
    free(extent);
    double floor_size = ldexp(whole, -(INDEX_BITS - 2));
    if (!(base > floor_size))
        base = floor_size;
    for (int k = 0; k < 3; k++)
        g->origin[k] = glo[k];
    for (int level = 0; level <= MAX_LEVEL; level++) {
        g->size[level] = ldexp(base, level);
        g->inverse[level] = 1.0 / g->size[level];
    }
    Py_ssize_t n_entries = 0;
    for (Py_ssize_t t = 0; t < n; t++) {
        double e = face_extent(g->lo + 3 * t, g->hi + 3 * t);
        int level = 0;
        while (level < MAX_LEVEL && e > g->size[level])
            level++;
        g->level[t] = (int8_t)level;
        g->used[level] = 1;
        int64_t c0[3], c1[3];
        cell_range(g, t, level, c0, c1);
        n_entries += (c1[0] - c0[0] + 1) * (c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1);
    }
    g->n_used = 0;
    int used_levels[MAX_LEVEL + 1];
    for (int level = 0; level <= MAX_LEVEL; level++)
        if (g->used[level])
            used_levels[g->n_used++] = level;
    memcpy(g->used, used_levels, sizeof(int) * g->n_used);
    g->n_entries = n_entries;
    g->key = malloc(sizeof(uint64_t) * n_entries);
    g->face = malloc(sizeof(uint32_t) * n_entries);
    uint64_t *tk2 = realloc(tk, sizeof(uint64_t) * (n_entries > n ? n_entries : n));
    uint32_t *tv2 = realloc(tv, sizeof(uint32_t) * (n_entries > n ? n_entries : n));
    if (!g->key || !g->face || !tk2 || !tv2) {
        free(tk2 ? tk2 : tk), free(tv2 ? tv2 : tv);
        return -1;
    }
    Py_ssize_t e = 0;
    for (Py_ssize_t t = 0; t < n; t++) {
        int64_t c0[3], c1[3];
        cell_range(g, t, g->level[t], c0, c1);
        for (int64_t a = c0[0]; a <= c1[0]; a++)
            for (int64_t b = c0[1]; b <= c1[1]; b++)
                for (int64_t c = c0[2]; c <= c1[2]; c++) {
                    g->key[e] = cell_key(g->level[t], a, b, c);
                    g->face[e] = (uint32_t)t;
                    e++;
                }
    }
    int sorted = radix_sort(g->key, g->face, tk2, tv2, n_entries);
    free(tk2), free(tv2);
    if (sorted < 0)
        return -1;
    for (int level = 0, e2 = 0; level <= MAX_LEVEL + 1; level++) {
        while (e2 < n_entries && (int)(g->key[e2] >> LEVEL_SHIFT) < level)
            e2++;
        g->level_begin[level] = e2;
    }
    return 0;
}

/* First entry with this key (within its level's range), or -1. */
static Py_ssize_t find_key(const Grid *g, int level, uint64_t key)
{
    Py_ssize_t lo = g->level_begin[level], hi = g->level_begin[level + 1];
    while (lo < hi) {
        Py_ssize_t mid = lo + (hi - lo) / 2;
        if (g->key[mid] < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < g->level_begin[level + 1] && g->key[lo] == key ? lo : -1;
}

static inline P corner(const Grid *g, Py_ssize_t t, int k)
{
    return g->V + 3 * g->corner[3 * t + k];
}

/* Whether sorted faces t and u of one shell meet other than along what they share. */
static int self_hit(const Grid *g, Py_ssize_t t, Py_ssize_t u)
{
    const int64_t *a = g->corner + 3 * t, *b = g->corner + 3 * u;
    int shared = 0, ia[3], ib[3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            if (a[i] == b[j]) {
                ia[shared] = i;
                ib[shared] = j;
                shared++;
            }
    P ta[3] = {corner(g, t, 0), corner(g, t, 1), corner(g, t, 2)};
    P tb[3] = {corner(g, u, 0), corner(g, u, 1), corner(g, u, 2)};
    if (shared == 0)
        return triangles_meet(ta, g->axis[t], tb, g->axis[u]);
    if (shared >= 3)
        return 1;
    if (shared == 2) {
        int ra = 3 - ia[0] - ia[1], rb = 3 - ib[0] - ib[1];
        return fold_over_edge(ta[ia[0]], ta[ia[1]], ta[ra], tb[rb], g->axis[t]);
    }
    return meet_beyond_vertex(ta[ia[0]], ta[(ia[0] + 1) % 3], ta[(ia[0] + 2) % 3], g->axis[t],
                              tb[(ib[0] + 1) % 3], tb[(ib[0] + 2) % 3], g->axis[u]);
}

static int other_hit(const Grid *g, Py_ssize_t t, Py_ssize_t u)
{
    P ta[3] = {corner(g, t, 0), corner(g, t, 1), corner(g, t, 2)};
    P tb[3] = {corner(g, u, 0), corner(g, u, 1), corner(g, u, 2)};
    return triangles_meet(ta, g->axis[t], tb, g->axis[u]);
}

/* ---- pair search, per thread -------------------------------------------------------------- */

typedef struct {
    const Grid *g;
    int within, between;
    Py_ssize_t n_shells, max_examples;
    Py_ssize_t entry_begin, entry_end, face_begin, face_end;
    uint8_t *self_found;      /* per shell */
    int64_t *examples;        /* 2 per example: original face indices */
    Py_ssize_t n_examples;
    int64_t *found;           /* 4 per intersecting shell pair: shells, original faces */
    Py_ssize_t n_found, cap_found;
    uint64_t *seen;           /* open-addressing set of shell pairs (key + 1; 0 empty) */
    uint64_t seen_mask;
    Py_ssize_t n_seen;
    int64_t candidates, tests;
    int failed;
} Work;

static inline uint64_t mix64(uint64_t h)
{
    h ^= h >> 30;
    h *= 0xBF58476D1CE4E5B9ULL;
    h ^= h >> 27;
    h *= 0x94D049BB133111EBULL;
    h ^= h >> 31;
    return h;
}

static int seen_has(const Work *w, uint64_t key)
{
    for (uint64_t i = mix64(key) & w->seen_mask;; i = (i + 1) & w->seen_mask) {
        if (w->seen[i] == 0)
            return 0;
        if (w->seen[i] == key + 1)
            return 1;
    }
}

static int seen_add(Work *w, uint64_t key)
{
    if (2 * (uint64_t)(w->n_seen + 1) > w->seen_mask + 1) {
        uint64_t size = 2 * (w->seen_mask + 1);
        uint64_t *table = calloc(size, sizeof(uint64_t));
        if (!table)
            return -1;
        for (uint64_t i = 0; i <= w->seen_mask; i++)
            if (w->seen[i]) {
                uint64_t j = mix64(w->seen[i] - 1) & (size - 1);
                while (table[j])
                    j = (j + 1) & (size - 1);
                table[j] = w->seen[i];
            }
        free(w->seen);
        w->seen = table;
        w->seen_mask = size - 1;
    }
    uint64_t i = mix64(key) & w->seen_mask;
    while (w->seen[i])
        i = (i + 1) & w->seen_mask;
    w->seen[i] = key + 1;
    w->n_seen++;
    return 0;
}

static void consider(Work *w, Py_ssize_t t, Py_ssize_t u)
{
    const Grid *g = w->g;
    int64_t st = g->shell[t], su = g->shell[u];
    if (st == su) {
        if (!w->within || (w->self_found[st] && w->n_examples >= w->max_examples))
            return;
        w->tests++;
        if (self_hit(g, t, u)) {
            w->self_found[st] = 1;
            if (w->n_examples < w->max_examples) {
                int64_t a = g->id[t], b = g->id[u];
                w->examples[2 * w->n_examples] = a < b ? a : b;
                w->examples[2 * w->n_examples + 1] = a < b ? b : a;
                w->n_examples++;
            }
        }
        return;
    }
    if (!w->between)
        return;
    if (st > su) {
        int64_t x = st;
        st = su;
        su = x;
        Py_ssize_t y = t;
        t = u;
        u = y;
    }
    uint64_t key = ((uint64_t)st << 32) | (uint64_t)su;
    if (seen_has(w, key))
        return;
    w->tests++;
    if (!other_hit(g, t, u))
        return;
    if (seen_add(w, key) < 0) {
        w->failed = 1;
        return;
    }
    if (w->n_found == w->cap_found) {
        Py_ssize_t cap = w->cap_found ? 2 * w->cap_found : 64;
        int64_t *grown = realloc(w->found, sizeof(int64_t) * 4 * cap);
        if (!grown) {
            w->failed = 1;
            return;
        }
        w->found = grown;
        w->cap_found = cap;
    }
    int64_t *row = w->found + 4 * w->n_found++;
    row[0] = st;
    row[1] = su;
    row[2] = g->id[t];
    row[3] = g->id[u];
}

static inline int boxes_meet(const Grid *g, Py_ssize_t t, Py_ssize_t u)
{
    const double *lt = g->lo + 3 * t, *ht = g->hi + 3 * t, *lu = g->lo + 3 * u, *hu = g->hi + 3 * u;
    return !(lt[0] > hu[0] || lu[0] > ht[0] || lt[1] > hu[1] || lu[1] > ht[1] || lt[2] > hu[2] || lu[2] > ht[2]);
}

/* A pair is met in the cell (at `level`, coordinates `cell`) holding the larger of its two lower
 * corners: exactly once. */
static inline int canonical_cell(const Grid *g, Py_ssize_t t, Py_ssize_t u, int level, const int64_t *cell)
{
    for (int k = 0; k < 3; k++)
        if (cell_of(g, level, k, dmax(g->lo[3 * t + k], g->lo[3 * u + k])) != cell[k])
            return 0;
    return 1;
}

static inline void key_cell(uint64_t key, int64_t *cell)
{
    cell[0] = (int64_t)compact21(key);
    cell[1] = (int64_t)compact21(key >> 1);
    cell[2] = (int64_t)compact21(key >> 2);
}

static void *search(void *arg)
{
    Work *w = arg;
    const Grid *g = w->g;
    /* Pairs within a level: runs of equal keys. */
    Py_ssize_t e = w->entry_begin;
    while (e < w->entry_end && !w->failed) {
        Py_ssize_t end = e + 1;
        while (end < g->n_entries && g->key[end] == g->key[e])
            end++;
        int level = (int)(g->key[e] >> LEVEL_SHIFT);
        int64_t cell[3];
        key_cell(g->key[e] & ((1ULL << LEVEL_SHIFT) - 1), cell);
        for (Py_ssize_t i = e; i < end; i++)
            for (Py_ssize_t j = i + 1; j < end; j++) {
                Py_ssize_t t = g->face[i], u = g->face[j];
                w->candidates++;
                if (boxes_meet(g, t, u) && canonical_cell(g, t, u, level, cell))
                    consider(w, t, u);
            }
        e = end;
    }
    /* Pairs across levels: each face looks up the cells of coarser levels its box covers. */
    if (g->n_used > 1)
        for (Py_ssize_t t = w->face_begin; t < w->face_end && !w->failed; t++) {
            int level = g->level[t];
            for (int l = 0; l < g->n_used; l++) {
                int coarse = g->used[l];
                if (coarse <= level)
                    continue;
                int64_t c0[3], c1[3];
                cell_range(g, t, coarse, c0, c1);
                for (int64_t a = c0[0]; a <= c1[0]; a++)
                    for (int64_t b = c0[1]; b <= c1[1]; b++)
                        for (int64_t c = c0[2]; c <= c1[2]; c++) {
                            uint64_t key = cell_key(coarse, a, b, c);
                            int64_t cell[3] = {a, b, c};
                            for (Py_ssize_t x = find_key(g, coarse, key); x >= 0 && x < g->n_entries
                                                                          && g->key[x] == key; x++) {
                                Py_ssize_t u = g->face[x];
                                w->candidates++;
                                if (boxes_meet(g, t, u) && canonical_cell(g, t, u, coarse, cell))
                                    consider(w, t, u);
                            }
                        }
            }
        }
    return NULL;
}

#define MAX_THREADS 16

static PyObject *py_pairs(PyObject *self, PyObject *args)
{
    PyObject *vo, *fo, *so, *ao;
    Py_ssize_t n_shells, max_examples;
    int within, between, threads;
    if (!PyArg_ParseTuple(args, "OOOOnppni", &vo, &fo, &so, &ao, &n_shells, &within, &between, &max_examples,
                          &threads))
        return NULL;
    if (n_shells < 1 || n_shells >= ((Py_ssize_t)1 << 31)) {
        PyErr_SetString(PyExc_ValueError, "shell count out of range");
        return NULL;
    }
    threads = threads < 1 ? 1 : (threads > MAX_THREADS ? MAX_THREADS : threads);
    Py_buffer vb, fb, sb, ab;
    if (get_buffer(vo, &vb, 8, 0, "vertices") < 0)
        return NULL;
    if (get_buffer(fo, &fb, 8, 0, "faces") < 0)
        goto fail_v;
    if (get_buffer(so, &sb, 8, 0, "shell") < 0)
        goto fail_f;
    if (get_buffer(ao, &ab, 1, 0, "active") < 0)
        goto fail_s;
    Py_ssize_t m = fb.len / 24;
    if (sb.len / 8 != m || ab.len != m) {
        PyErr_SetString(PyExc_ValueError, "shell and active need one entry per face");
        goto fail_a;
    }
    Grid g;
    Work work[MAX_THREADS];
    memset(work, 0, sizeof(work));
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = build_grid(&g, vb.buf, fb.buf, sb.buf, ab.buf, m) < 0;
    Py_END_ALLOW_THREADS
    for (int i = 0; i < threads && !failed; i++) {
        Work *w = &work[i];
        w->g = &g;
        w->within = within;
        w->between = between;
        w->n_shells = n_shells;
        w->max_examples = max_examples;
        /* Contiguous shares, cut at key boundaries, so each thread reads its own stretch of memory. */
        Py_ssize_t b = g.n_entries * i / threads, e = g.n_entries * (i + 1) / threads;
        while (b > 0 && b < g.n_entries && g.key[b] == g.key[b - 1])
            b++;
        while (e > 0 && e < g.n_entries && g.key[e] == g.key[e - 1])
            e++;
        w->entry_begin = b;
        w->entry_end = e;
        w->face_begin = g.n * i / threads;
        w->face_end = g.n * (i + 1) / threads;
        w->self_found = calloc(n_shells, 1);
        w->examples = malloc(sizeof(int64_t) * 2 * (max_examples ? max_examples : 1));
        w->seen = calloc(64, sizeof(uint64_t));
        w->seen_mask = 63;
        failed |= !w->self_found || !w->examples || !w->seen;
    }
    if (!failed && g.n > 0) {
        Py_BEGIN_ALLOW_THREADS
        pthread_t ids[MAX_THREADS];
        int started[MAX_THREADS] = {0};
        for (int i = 1; i < threads; i++)
            started[i] = pthread_create(&ids[i], NULL, search, &work[i]) == 0;
        search(&work[0]);
        for (int i = 1; i < threads; i++) {
            if (started[i])
                pthread_join(ids[i], NULL);
            else
                search(&work[i]);
        }
        Py_END_ALLOW_THREADS
        for (int i = 0; i < threads; i++)
            failed |= work[i].failed;
    }
    PyObject *result = NULL;
    if (failed) {
        PyErr_NoMemory();
    } else {
        /* Merge: shells found by any thread; examples up to the cap; shell pairs as found. */
        Py_ssize_t n_examples = 0, n_found = 0;
        for (int i = 0; i < threads; i++) {
            n_examples += work[i].n_examples;
            n_found += work[i].n_found;
        }
        n_examples = n_examples > max_examples ? max_examples : n_examples;
        PyObject *flags = PyBytes_FromStringAndSize(NULL, n_shells);
        PyObject *examples = PyBytes_FromStringAndSize(NULL, 16 * n_examples);
        PyObject *found = PyBytes_FromStringAndSize(NULL, 32 * n_found);
        if (flags && examples && found) {
            uint8_t *fl = (uint8_t *)PyBytes_AS_STRING(flags);
            int64_t *ex = (int64_t *)PyBytes_AS_STRING(examples), *fd = (int64_t *)PyBytes_AS_STRING(found);
            memset(fl, 0, n_shells);
            Py_ssize_t e = 0, k = 0;
            long long candidates = 0, tests = 0;
            for (int i = 0; i < threads; i++) {
                for (Py_ssize_t s = 0; s < n_shells; s++)
                    fl[s] |= work[i].self_found[s];
                for (Py_ssize_t j = 0; j < work[i].n_examples && e < n_examples; j++, e++) {
                    ex[2 * e] = work[i].examples[2 * j];
                    ex[2 * e + 1] = work[i].examples[2 * j + 1];
                }
                if (work[i].n_found)
                    memcpy(fd + 4 * k, work[i].found, 32 * work[i].n_found);
                k += work[i].n_found;
                candidates += work[i].candidates;
                tests += work[i].tests;
            }
            result = Py_BuildValue("NNNLL", flags, examples, found, candidates, tests);
        } else {
            Py_XDECREF(flags);
            Py_XDECREF(examples);
            Py_XDECREF(found);
        }
    }
    for (int i = 0; i < threads; i++) {
        free(work[i].self_found);
        free(work[i].examples);
        free(work[i].found);
        free(work[i].seen);
    }
    free_grid(&g);
    PyBuffer_Release(&ab);
    PyBuffer_Release(&sb);
    PyBuffer_Release(&fb);
    PyBuffer_Release(&vb);
    return result;
fail_a:
    PyBuffer_Release(&ab);
fail_s:
    PyBuffer_Release(&sb);
fail_f:
    PyBuffer_Release(&fb);
fail_v:
    PyBuffer_Release(&vb);
    return NULL;
}

/* ---- winding numbers by exact ray parity --------------------------------------------------- */

enum { RAY_OK = 0, RAY_DEGENERATE = 1, RAY_ON_SURFACE = 2 };

/* Signed crossings of the segment p -> q with the faces, or a degeneracy. */
static int crossings(const double *V, const int64_t *F, Py_ssize_t m, const double *lo, const double *hi,
                     const int8_t *axis, P p, P q, int64_t *count)
{
    double slo[3], shi[3];
    for (int k = 0; k < 3; k++) {
        slo[k] = dmin(p[k], q[k]);
        shi[k] = dmax(p[k], q[k]);
    }
    int64_t total = 0;
    for (Py_ssize_t t = 0; t < m; t++) {
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

static PyObject *py_winding(PyObject *self, PyObject *args)
{
    PyObject *vo, *fo, *po;
    Py_buffer vb, fb, pb;
    if (!PyArg_ParseTuple(args, "OOO", &vo, &fo, &po) || get_three(vo, fo, po, &vb, &fb, &pb, 8, 0, "points") < 0)
        return NULL;
    const double *V = vb.buf, *points = pb.buf;
    const int64_t *F = fb.buf;
    Py_ssize_t m = fb.len / 24, k = pb.len / 24;
    double *lo = malloc(sizeof(double) * 3 * (m ? m : 1)), *hi = malloc(sizeof(double) * 3 * (m ? m : 1));
    int8_t *axis = malloc(m ? m : 1);
    PyObject *out = PyBytes_FromStringAndSize(NULL, 8 * k);
    int status = RAY_OK;
    Py_ssize_t bad = -1;
    if (lo && hi && axis && out) {
        int64_t *w = (int64_t *)PyBytes_AS_STRING(out);
        Py_BEGIN_ALLOW_THREADS
        double glo[3] = {INFINITY, INFINITY, INFINITY}, ghi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (Py_ssize_t t = 0; t < m; t++) {
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
        for (Py_ssize_t i = 0; i < k && status == RAY_OK; i++) {
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
                w[i] = count;
            }
            if (status != RAY_OK)
                bad = i;
        }
        Py_END_ALLOW_THREADS
    }
    free(lo);
    free(hi);
    free(axis);
    PyBuffer_Release(&vb);
    PyBuffer_Release(&fb);
    PyBuffer_Release(&pb);
    if (!out)
        return NULL;
    if (!lo || !hi || !axis) {
        Py_DECREF(out);
        return PyErr_NoMemory();
    }
    if (status == RAY_ON_SURFACE) {
        Py_DECREF(out);
        PyErr_Format(PyExc_ValueError, "point %zd lies on the surface", bad);
        return NULL;
    }
    if (status != RAY_OK) {
        Py_DECREF(out);
        PyErr_Format(PyExc_RuntimeError, "no generic ray found for point %zd", bad);
        return NULL;
    }
    return out;
}

/* ---- batches of the predicates -------------------------------------------------------------- */

static PyObject *py_orient3d_signs(PyObject *self, PyObject *args)
{
    PyObject *po;
    if (!PyArg_ParseTuple(args, "O", &po))
        return NULL;
    Py_buffer pb;
    if (get_buffer(po, &pb, 8, 0, "points") < 0)
        return NULL;
    Py_ssize_t k = pb.len / 96;
    PyObject *out = PyBytes_FromStringAndSize(NULL, k);
    if (out) {
        const double *x = pb.buf;
        int8_t *s = (int8_t *)PyBytes_AS_STRING(out);
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t i = 0; i < k; i++)
            s[i] = (int8_t)orient3d(x + 12 * i, x + 12 * i + 3, x + 12 * i + 6, x + 12 * i + 9);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&pb);
    return out;
}

static PyMethodDef methods[] = {
    {"degenerate", py_degenerate, METH_VARARGS,
     "degenerate(vertices, faces, out): out[t] = 1 where face t has zero area, exactly."},
    {"pairs", py_pairs, METH_VARARGS,
     "pairs(vertices, faces, shell, active, n_shells, within, between, max_examples, threads)\n"
     "-> (self_found bytes, examples int64 pairs, found int64 quads, candidates, tests)"},
    {"winding", py_winding, METH_VARARGS, "winding(vertices, faces, points) -> int64 winding numbers (bytes)"},
    {"orient3d_signs", py_orient3d_signs, METH_VARARGS, "orient3d_signs(points (k, 4, 3)) -> int8 signs (bytes)"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_intersect", NULL, -1, methods};

PyMODINIT_FUNC PyInit__intersect(void)
{
    return PyModule_Create(&module);
}
