/* The broad phase: a hierarchical grid of the faces' boxes.
 *
 * Cells of level l are cubes of side base * 2**l from a common origin; a face
 * goes to the finest level whose cells are at least its box's extent, and is
 * entered in every cell of that level its box covers.  A cell's coordinates
 * are the level-0 cell of a point shifted right by l (floor division by 2**l
 * of a floor is the floor of the quotient), so the cells of every level are
 * computed from one rounding of each coordinate, and the cell of a point is
 * monotone in it: two faces whose closed boxes meet share the cell of
 * max(their lower corners) at the coarser of their levels (search.c).
 *
 * Faces whose stars share a hub (a certified vertex of large degree: the
 * centre of a fan of needles) are consecutive in the sorted order, so a cell
 * lists them together and the search skips their pairs as a block instead of
 * one by one: any two faces of a certified star meet only along what they
 * share (stars.c).
 */
#include "isect.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#if defined(__linux__)
#include <sys/mman.h>
#endif

void *isect_alloc(size_t bytes, int zeroed)
{
    void *data = zeroed ? calloc(bytes ? bytes : 1, 1) : malloc(bytes ? bytes : 1);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    const uintptr_t huge = (uintptr_t)1 << 21;
    uintptr_t start = ((uintptr_t)data + huge - 1) & ~(huge - 1), end = ((uintptr_t)data + bytes) & ~(huge - 1);
    /* from 4 MiB (the 1.2M torus's filed faces, per-face cells and incidence offsets): a fresh
     * process's first search took 4,100-4,600 page faults at 8 MiB, 2,200-2,900 at 4 */
    if (data && bytes >= 2 * huge && end > start)
        madvise((void *)start, end - start, MADV_HUGEPAGE);
#endif
    return data;
}

/* A certified vertex with at least this many faces groups them (below, pairs are skipped one
 * by one, which costs less than the grouping). */
#define HUB_DEGREE 16

/* LSD radix sort on 11-bit digits (six cover the key), histograms in one pass, digits every key
 * shares skipped (cell keys of one level differ in few bits: two or three passes). */
#define DIGIT_BITS 11
#define DIGITS 6
/* At most this many keys are sorted by insertion. */
#define SMALL_SORT 256
int radix_sort(uint64_t *key, uint32_t *value, uint64_t *tk, uint32_t *tv, int64_t n)
{
    const uint64_t mask = (1u << DIGIT_BITS) - 1;
    if (n <= SMALL_SORT) {
        /* a few keys (the faces no patch covers on a small mesh): an insertion sort, stable as
         * the radix sort, without its 96 KiB of zeroed counts */
        for (int64_t i = 1; i < n; i++) {
            uint64_t k = key[i];
            uint32_t v = value[i];
            int64_t j = i;
            for (; j > 0 && key[j - 1] > k; j--) {
                key[j] = key[j - 1];
                value[j] = value[j - 1];
            }
            key[j] = k;
            value[j] = v;
        }
        return 0;
    }
    size_t (*count)[1 << DIGIT_BITS] = calloc(DIGITS, sizeof(*count));
    if (!count)
        return -1;
    for (int64_t i = 0; i < n; i++) {
        uint64_t k = key[i];
        for (int d = 0; d < DIGITS; d++)
            count[d][(k >> (DIGIT_BITS * d)) & mask]++;
    }
    uint64_t *src_k = key, *dst_k = tk;
    uint32_t *src_v = value, *dst_v = tv;
    for (int d = 0; d < DIGITS; d++) {
        int shift = DIGIT_BITS * d;
        if (n == 0 || count[d][(key[0] >> shift) & mask] == (size_t)n)
            continue;
        size_t sum = 0;
        for (int b = 0; b <= (int)mask; b++) {
            size_t c = count[d][b];
            count[d][b] = sum;
            sum += c;
        }
        for (int64_t i = 0; i < n; i++) {
            size_t slot = count[d][(src_k[i] >> shift) & mask]++;
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

uint64_t grid_key(int level, int64_t i, int64_t j, int64_t k)
{
    return ((uint64_t)level << LEVEL_SHIFT) | spread21((uint64_t)i) | spread21((uint64_t)j) << 1
           | spread21((uint64_t)k) << 2;
}

void grid_key_cell(uint64_t key, int64_t *cell)
{
    cell[0] = (int64_t)compact21(key);
    cell[1] = (int64_t)compact21(key >> 1);
    cell[2] = (int64_t)compact21(key >> 2);
}

int64_t grid_find(const Grid *g, int level, uint64_t key)
{
    int64_t lo = g->level_begin[level], hi = g->level_begin[level + 1];
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (g->key[mid] < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < g->level_begin[level + 1] && g->key[lo] == key ? lo : -1;
}

void grid_free(Grid *g)
{
    free(g->id), free(g->own_corner), free(g->own_shell), free(g->lo), free(g->hi), free(g->low_cell), free(g->high_cell),
        free(g->own_axis), free(g->level), free(g->certified), free(g->group_begin), free(g->group_end), free(g->key),
        free(g->face);
    memset(g, 0, sizeof(*g));
}

/* The k-th smallest of x[0..n) (0-based), partly reordering x: the value a sort would put at k,
 * without sorting (a sort of 4,096 samples was 5% of a 10k-face part's whole path). */
static double kth_smallest(double *x, int n, int k)
{
    int low = 0, high = n - 1;
    while (low < high) {
        int i = low, j = high, mid = low + (high - low) / 2;
        double a = x[low], b = x[mid], c = x[high];
        double pivot = a < b ? (b < c ? b : (a < c ? c : a)) : (a < c ? a : (b < c ? c : b));
        while (i <= j) {
            while (x[i] < pivot)
                i++;
            while (pivot < x[j])
                j--;
            if (i <= j) {
                double t = x[i];
                x[i] = x[j];
                x[j] = t;
                i++;
                j--;
            }
        }
        if (k <= j)
            high = j;
        else if (k >= i)
            low = i;
        else
            return x[k];
    }
    return x[k];
}

static inline double face_extent(const double *lo, const double *hi)
{
    return dmax(hi[0] - lo[0], dmax(hi[1] - lo[1], hi[2] - lo[2]));
}

/* Face t's box: stored, or (a coarse grid, which keeps none) from its corners. */
static inline void face_box(const Grid *g, int64_t t, double *lo, double *hi)
{
    if (g->lo) {
        for (int k = 0; k < 3; k++)
            lo[k] = g->lo[3 * t + k], hi[k] = g->hi[3 * t + k];
        return;
    }
    P a = g->V + 3 * g->corner[3 * t], b = g->V + 3 * g->corner[3 * t + 1], c = g->V + 3 * g->corner[3 * t + 2];
    for (int k = 0; k < 3; k++) {
        lo[k] = dmin(a[k], dmin(b[k], c[k]));
        hi[k] = dmax(a[k], dmax(b[k], c[k]));
    }
}

/* The hub of face t: its certified corner of largest degree (at least HUB_DEGREE), else -1. */
static int64_t hub_of(const Stars *stars, const int64_t *F, int64_t t)
{
    int64_t hub = -1, best = HUB_DEGREE - 1;
    for (int k = 0; k < 3; k++) {
        int64_t v = F[3 * t + k];
        if ((stars->flag[v] & STAR_EMBEDDED) && star_degree(stars, v) > best) {
            best = star_degree(stars, v);
            hub = v;
        }
    }
    return hub;
}

/* The order of the faces taken: faces without a hub in input order (exporters write
 * neighbouring faces near each other), then those with one, by hub. */
static int64_t *face_order(const int64_t *F, const int8_t *axis, int64_t m, int64_t n, const Stars *stars,
                           int64_t **hub_out)
{
    int64_t *order = malloc(sizeof(int64_t) * (n ? n : 1));
    int64_t *hub = malloc(sizeof(int64_t) * (n ? n : 1));
    if (!order || !hub) {
        free(order), free(hub);
        return NULL;
    }
    int64_t s = 0, grouped = 0;
    for (int64_t t = 0; t < m; t++)
        if (axis[t] >= 0) {
            int64_t h = stars ? hub_of(stars, F, t) : -1;
            if (h < 0) {
                hub[s] = -1;
                order[s++] = t;
            } else
                grouped++;
        }
    if (grouped) {
        uint64_t *key = malloc(sizeof(uint64_t) * grouped), *tk = malloc(sizeof(uint64_t) * grouped);
        uint32_t *value = malloc(sizeof(uint32_t) * grouped), *tv = malloc(sizeof(uint32_t) * grouped);
        int sorted = -1;
        if (key && tk && value && tv) {
            int64_t g = 0;
            for (int64_t t = 0; t < m; t++)
                if (axis[t] >= 0) {
                    int64_t h = hub_of(stars, F, t);
                    if (h >= 0) {
                        key[g] = (uint64_t)h;
                        value[g++] = (uint32_t)t;
                    }
                }
            sorted = radix_sort(key, value, tk, tv, grouped);
            for (int64_t i = 0; sorted == 0 && i < grouped; i++) {
                hub[s] = (int64_t)key[i];
                order[s++] = value[i];
            }
        }
        free(key), free(tk), free(value), free(tv);
        if (sorted < 0) {
            free(order), free(hub);
            return NULL;
        }
    }
    *hub_out = hub;
    return order;
}

/* The finest cell from the extents of up to 4,096 faces sampled evenly in the faces' order
 * (extent[] is reordered): twice the largest when it is at most twice the 90th percentile (one
 * level: no lookups across levels; cells twice the faces' size keep the entries near 2.5 a face),
 * else that percentile (larger faces go up a level per doubling); never below 2**-17 of the
 * whole, so cell indices fit INDEX_BITS.  A grid with every face at one level (`one_level`: the
 * patch grid, patches.c) takes twice that percentile instead: its cells then hold as many faces
 * as on a mesh of faces of one size, as patches.c sizes them (at the percentile, a few long faces
 * made its cells a quarter of that: four times the cells to certify, and the search on a
 * 5,120-face dented icosphere took 1.6 ms instead of 0.95). */
double grid_base(double *extent, int samples, double whole, int one_level)
{
    double largest = 0.0;                       /* extents are >= 0 */
    for (int s = 0; s < samples; s++)
        largest = extent[s] > largest ? extent[s] : largest;
    double b = samples > 0 ? kth_smallest(extent, samples, (samples * 9) / 10) : 0.0;
    if (largest <= 2.0 * b)
        b = 2.0 * largest;
    else if (one_level)
        b = 2.0 * b;
    double floor_size = ldexp(whole, -(INDEX_BITS - 2));
    return b > floor_size ? b : floor_size;
}

static int choose_base(Grid *g, double whole, double *base, int one_level)
{
    int64_t n = g->n;
    int samples = n < GRID_SAMPLES ? (int)n : GRID_SAMPLES;
    double *extent = malloc(sizeof(double) * (samples ? samples : 1));
    if (!extent)
        return -1;
    for (int s = 0; s < samples; s++) {
        double lo[3], hi[3];
        face_box(g, grid_sample(s, n, samples), lo, hi);
        extent[s] = face_extent(lo, hi);
    }
    *base = grid_base(extent, samples, whole, one_level);
    free(extent);
    return 0;
}

/* Faces per block of the parallel loops below. */
#define BUILD_BLOCK 65536

typedef struct {
    Grid *g;
    const double *V;
    const int64_t *F, *shell, *order, *hub;
    const uint8_t *take;
    const Stars *stars;
    int8_t *axis;
    int64_t m;
    double base;
    double (*box)[6];         /* per block of input faces: low corner, high corner */
    int64_t *count;           /* per block: faces taken, then entries */
    int64_t *hubs;            /* per block of input faces: faces taken with a hub */
    double *lo, *hi;          /* per input face taken: its box (3 each) */
    uint8_t *certified;       /* per input face taken: its certified corners */
    int force_level;          /* every face at this level (-1: each at its own) */
} Build;

/* Input faces of one block: each taken face's projection axis (-1: not taken or zero area), box
 * and certified corners. */
static void axis_block(void *ctx, int64_t block)
{
    Build *w = ctx;
    int64_t t0 = block * BUILD_BLOCK, t1 = t0 + BUILD_BLOCK < w->m ? t0 + BUILD_BLOCK : w->m, n = 0, hubs = 0;
    /* the box in locals, stored once: the blocks' boxes share cache lines */
    double box[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (int64_t t = t0; t < t1; t++) {
        w->axis[t] = -1;
        if (w->take && !w->take[t])
            continue;
        P a = w->V + 3 * w->F[3 * t], b = w->V + 3 * w->F[3 * t + 1], c = w->V + 3 * w->F[3 * t + 2];
        w->axis[t] = (int8_t)triangle_axis(a, b, c);
        if (w->axis[t] < 0)
            continue;
        uint8_t certified = 0;
        for (int k = 0; k < 3; k++) {
            double lo = dmin(a[k], dmin(b[k], c[k])), hi = dmax(a[k], dmax(b[k], c[k]));
            if (w->lo) {
                w->lo[3 * t + k] = lo;
                w->hi[3 * t + k] = hi;
            }
            box[k] = dmin(box[k], lo);
            box[3 + k] = dmax(box[3 + k], hi);
            if (w->stars && (w->stars->flag[w->F[3 * t + k]] & STAR_EMBEDDED))
                certified |= (uint8_t)(1 << k);
        }
        w->certified[t] = certified;
        n++;
        hubs += w->stars && hub_of(w->stars, w->F, t) >= 0;
    }
    memcpy(w->box[block], box, sizeof(box));
    w->count[block] = n;
    w->hubs[block] = hubs;
}

/* Sorted faces of one block, when they are not the input's in order: their original index,
 * shell, axis, corners, box and certified corners. */
static void fill_block(void *ctx, int64_t block)
{
    Build *w = ctx;
    Grid *g = w->g;
    int64_t s0 = block * BUILD_BLOCK, s1 = s0 + BUILD_BLOCK < g->n ? s0 + BUILD_BLOCK : g->n;
    for (int64_t s = s0; s < s1; s++) {
        int64_t t = w->order[s];
        g->id[s] = (uint32_t)t;
        if (g->own_shell)
            g->own_shell[s] = w->shell[t];
        g->own_axis[s] = w->axis[t];
        g->certified[s] = w->certified[t];
        for (int k = 0; k < 3; k++) {
            g->own_corner[3 * s + k] = w->F[3 * t + k];
            if (g->lo) {
                g->lo[3 * s + k] = w->lo[3 * t + k];
                g->hi[3 * s + k] = w->hi[3 * t + k];
            }
        }
    }
}

/* Without an order (every face taken, none with a hub: the sorted order is the input's), the
 * grid keeps pointers to the input's corners and shells, and the boxes found with the axes,
 * instead of copies. */
static int fill_faces(Grid *g, Build *w, int threads)
{
    int64_t n = g->n;
    int grouped = 0;
    for (int64_t s = 0; w->hub && s < n && !grouped; s++)
        grouped = w->hub[s] >= 0;
    if (!w->order) {
        g->corner = w->F;
        g->shell = w->shell;
        g->axis = g->own_axis = w->axis;
        g->lo = w->lo;
        g->hi = w->hi;
        g->certified = w->certified;
        w->axis = NULL;
        w->lo = w->hi = NULL;
        w->certified = NULL;
    } else {
        g->id = malloc(sizeof(uint32_t) * n);
        g->corner = g->own_corner = isect_alloc(sizeof(int64_t) * 3 * n, 0);
        g->shell = g->own_shell = w->shell ? isect_alloc(sizeof(int64_t) * n, 0) : NULL;
        g->axis = g->own_axis = malloc(n);
        if (w->lo) {
            g->lo = isect_alloc(sizeof(double) * 3 * n, 0);
            g->hi = isect_alloc(sizeof(double) * 3 * n, 0);
        }
        g->certified = malloc(n);
        if (!g->id || !g->own_corner || (w->shell && !g->own_shell) || !g->own_axis || (w->lo && (!g->lo || !g->hi))
            || !g->certified)
            return -1;
        parallel_blocks(threads, (n + BUILD_BLOCK - 1) / BUILD_BLOCK, fill_block, w);
    }
    g->low_cell = isect_alloc(sizeof(int32_t) * 3 * n, 0);
    g->level = malloc(n);
    if (!g->low_cell || !g->level)
        return -1;
    if (!g->lo && !(g->high_cell = isect_alloc(sizeof(int32_t) * 3 * n, 0)))
        return -1;
    if (!grouped)
        return 0;
    g->group_begin = malloc(sizeof(uint32_t) * n);
    g->group_end = malloc(sizeof(uint32_t) * n);
    if (!g->group_begin || !g->group_end)
        return -1;
    const int64_t *hub = w->hub;
    for (int64_t s = 0; s < n;) {
        int64_t e = s + 1;
        while (hub[s] >= 0 && e < n && hub[e] == hub[s])
            e++;
        for (int64_t i = s; i < e; i++) {
            g->group_begin[i] = (uint32_t)s;
            g->group_end[i] = (uint32_t)e;
        }
        s = e;
    }
    return 0;
}

/* Sorted faces of one block: level (the first whose side reaches the face's extent; level l has
 * cells of side base * 2**l), level-0 cell of the low corner, and the block's entries. */
static void level_block(void *ctx, int64_t block)
{
    Build *w = ctx;
    Grid *g = w->g;
    double base = w->base;
    int64_t s0 = block * BUILD_BLOCK, s1 = s0 + BUILD_BLOCK < g->n ? s0 + BUILD_BLOCK : g->n, entries = 0;
    for (int64_t t = s0; t < s1; t++) {
        double lo[3], hi[3];
        face_box(g, t, lo, hi);
        int level = w->force_level >= 0 ? w->force_level : 0;
        if (w->force_level < 0) {
            double e = face_extent(lo, hi), size = base;
            while (level < MAX_LEVEL && e > size) {
                level++;
                size = ldexp(base, level);
            }
        }
        g->level[t] = (int8_t)level;
        int64_t count = 1;
        for (int k = 0; k < 3; k++) {
            int64_t c0 = grid_cell0(g, k, lo[k]), c1 = grid_cell0(g, k, hi[k]);
            g->low_cell[3 * t + k] = (int32_t)c0;
            if (g->high_cell)
                g->high_cell[3 * t + k] = (int32_t)c1;
            count *= (c1 >> level) - (c0 >> level) + 1;
        }
        entries += count;
    }
    w->count[block] = entries;
}

/* The entries of one block of sorted faces, from the block's first entry on. */
static void key_block(void *ctx, int64_t block)
{
    Build *w = ctx;
    Grid *g = w->g;
    int64_t s0 = block * BUILD_BLOCK, s1 = s0 + BUILD_BLOCK < g->n ? s0 + BUILD_BLOCK : g->n, e = w->count[block];
    for (int64_t t = s0; t < s1; t++) {
        int level = g->level[t];
        int64_t c0[3], c1[3];
        grid_face_cells(g, t, level, c0, c1);
        for (int64_t a = c0[0]; a <= c1[0]; a++)
            for (int64_t b = c0[1]; b <= c1[1]; b++)
                for (int64_t c = c0[2]; c <= c1[2]; c++) {
                    g->key[e] = grid_key(level, a, b, c);
                    g->face[e] = (uint32_t)t;
                    e++;
                }
    }
}

int grid_build(Grid *g, const double *V, const int64_t *F, const int64_t *shell, const uint8_t *take, int64_t m,
               const Stars *stars, int threads)
{
    return grid_build_at(g, V, F, shell, take, m, stars, threads, -1, 0);
}

int grid_build_at(Grid *g, const double *V, const int64_t *F, const int64_t *shell, const uint8_t *take, int64_t m,
                  const Stars *stars, int threads, int force_level, int64_t max_entries_per_face)
{
    memset(g, 0, sizeof(*g));
    g->V = V;
    int64_t n_blocks = (m + BUILD_BLOCK - 1) / BUILD_BLOCK;
    Build w = {g, V, F, shell, NULL, NULL, take, stars, malloc(m ? m : 1), m, 0.0,
               malloc(sizeof(double[6]) * (n_blocks + 1)), malloc(sizeof(int64_t) * (n_blocks + 1)),
               malloc(sizeof(int64_t) * (n_blocks + 1)),
               force_level < 0 ? isect_alloc(sizeof(double) * 3 * m, 0) : NULL,
               force_level < 0 ? isect_alloc(sizeof(double) * 3 * m, 0) : NULL, malloc(m ? m : 1),
               force_level};
    int status = -1;
    if (!w.axis || !w.box || !w.count || !w.hubs || (force_level < 0 && (!w.lo || !w.hi)) || !w.certified)
        goto done;
    parallel_blocks(threads, n_blocks, axis_block, &w);
    double glo[3] = {INFINITY, INFINITY, INFINITY}, ghi[3] = {-INFINITY, -INFINITY, -INFINITY};
    int64_t n = 0, hubs = 0;
    for (int64_t k = 0; k < n_blocks; k++) {
        n += w.count[k];
        hubs += w.hubs[k];
        for (int a = 0; a < 3; a++) {
            glo[a] = dmin(glo[a], w.box[k][a]);
            ghi[a] = dmax(ghi[a], w.box[k][3 + a]);
        }
    }
    if (n == 0 || n >= ((int64_t)1 << 32)) {
        status = n == 0 ? 0 : -1;
        goto done;
    }
    g->n = n;
    int64_t *hub = NULL, *order = NULL;
    if (n < m || hubs) {
        order = face_order(F, w.axis, m, n, stars, &hub);
        if (!order)
            goto done;
    }
    w.order = order;
    w.hub = hub;
    status = fill_faces(g, &w, threads);
    free(order), free(hub);
    if (status < 0)
        goto done;
    status = -1;
    double whole = dmax(ghi[0] - glo[0], dmax(ghi[1] - glo[1], ghi[2] - glo[2])), base;
    if (!(whole > 0.0))
        whole = 1.0;
    if (choose_base(g, whole, &base, force_level >= 0) < 0)
        goto done;
    for (int k = 0; k < 3; k++)
        g->origin[k] = glo[k];
    g->inverse = 1.0 / base;
    /* the blocks now run over sorted faces */
    int64_t n_face_blocks = (n + BUILD_BLOCK - 1) / BUILD_BLOCK;
    free(w.count);
    w.count = malloc(sizeof(int64_t) * (n_face_blocks + 1));
    if (!w.count)
        goto done;
    w.base = base;
    parallel_blocks(threads, n_face_blocks, level_block, &w);
    int64_t n_entries = 0;
    for (int64_t k = 0; k < n_face_blocks; k++) {
        int64_t c = w.count[k];
        w.count[k] = n_entries;
        n_entries += c;
    }
    if (max_entries_per_face > 0 && n_entries > max_entries_per_face * n) {
        status = 1;
        goto done;
    }
    for (int64_t t = 0; t < n; t++)
        g->used[g->level[t]] = 1;
    int used_levels[MAX_LEVEL + 1];
    g->n_used = 0;
    for (int level = 0; level <= MAX_LEVEL; level++)
        if (g->used[level])
            used_levels[g->n_used++] = level;
    memcpy(g->used, used_levels, sizeof(int) * g->n_used);
    g->n_entries = n_entries;
    g->key = isect_alloc(sizeof(uint64_t) * n_entries, 0);
    g->face = isect_alloc(sizeof(uint32_t) * n_entries, 0);
    uint64_t *tk = isect_alloc(sizeof(uint64_t) * n_entries, 0);
    uint32_t *tv = isect_alloc(sizeof(uint32_t) * n_entries, 0);
    if (!g->key || !g->face || !tk || !tv) {
        free(tk), free(tv);
        goto done;
    }
    parallel_blocks(threads, n_face_blocks, key_block, &w);
    int sorted = radix_sort(g->key, g->face, tk, tv, n_entries);
    free(tk), free(tv);
    if (sorted < 0)
        goto done;
    int64_t x = 0;
    for (int level = 0; level <= MAX_LEVEL + 1; level++) {
        while (x < n_entries && (int)(g->key[x] >> LEVEL_SHIFT) < level)
            x++;
        g->level_begin[level] = x;
    }
    status = 0;
done:
    free(w.axis), free(w.box), free(w.count), free(w.hubs), free(w.lo), free(w.hi), free(w.certified);
    return status;
}
