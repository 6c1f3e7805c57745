/* The pair search: which faces meet, within a shell and between shells.
 *
 * When looking within shells, faces that lie only in cells of a coarse grid
 * certified as embedded patches (patches.c) are left out first; the vertex
 * stars of the faces left are certified then (stars.c).  Candidates come from
 * the grid (grid.c) of the faces left: pairs of faces in one cell (within
 * a level, the pairs a sweep along one axis finds overlapping there; a cell
 * holding a hub group lists every pair but the group's).  Each pair is
 * decided once, in the cell of max(their boxes' lower corners) at the coarser
 * of their levels; before any predicate:
 *   - faces of one shell that the certificates cover (a shell certified
 *     embedded, a certified vertex in common, a common hub) are skipped: they
 *     meet only along what they share (stars.c);
 *   - boxes that do not meet, and faces that a plane certifiably separates
 *     (`separated` below), do not meet;
 *   - the rest go to the exact closed-set tests of predicates.h.
 *
 * Work is split into blocks (runs of cells, then runs of faces for the
 * lookups across levels) handed to the threads in order; each block keeps its
 * own findings, and they are merged in block order, so what is reported does
 * not depend on the thread count.
 */
#include "isect.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Entries per block of the search within levels, faces per block across levels. */
#define ENTRY_BLOCK 16384
#define FACE_BLOCK 4096

typedef struct {
    int64_t *examples;        /* 2 per example, up to max_examples (when it is negative: every meeting pair, between shells too) */
    int64_t n_examples, cap_examples;
    int64_t *self_shells;     /* shells found crossing themselves in this block, each once */
    int64_t n_self, cap_self;
    int64_t *found;           /* 4 per meeting shell pair, each pair once in this block */
    int64_t n_found, cap_found;
    int64_t candidates, tests;
    int failed;
} Block;

typedef struct {
    uint64_t *slots;          /* shell pairs of the current block (key + 1; 0 empty) */
    uint64_t mask;
    int64_t count;
} Seen;

/* A face of the current cell, copied out for the sweep. */
typedef struct {
    double lo[3], hi[3];
    int64_t corner[3], shell;
    uint32_t face;
    uint8_t certified, home;
} Item;

/* A face of the sweep, in sorted order: its interval along the sweep axis, its box on the other
 * two (low, high, low, high), its home bits, and its Item. */
typedef struct {
    double lo, hi, box[4];
    uint8_t home;
    uint32_t item;
} Slab;

typedef struct {
    double x;
    uint32_t i;
} SortKey;

typedef struct {
    Item *items;              /* cap each */
    Slab *slabs;
    uint32_t *hits;
    SortKey *keys;            /* 2 cap */
    int64_t cap;
} Scratch;

typedef struct {
    const Grid *g;
    int within, between;
    int64_t n_shells, max_examples;
    const uint8_t *embedded;  /* per shell, or NULL */
    int64_t n_entry_blocks, n_face_blocks;
    int64_t *entry_cut;       /* n_entry_blocks + 1 cuts, at key boundaries */
    Block *blocks;
    Seen *seen;               /* per worker */
    Scratch *scratch;         /* per worker */
} Search;

/* ---- the float separation filter -------------------------------------------------------- */

/* Whether the plane of normal n (any vector; see separated) certifiably has one triangle's
 * corners x strictly below every corner p of the other.  For e(p) = fl(n . p) (three products,
 * two sums), |e(p) - n.p| <= g3 S(p), S(p) = sum |n_k p_k|, g3 = 3u / (1 - 3u) (Higham, 3.1).
 * M = the largest rounded S over the six corners has S(p) <= M / (1 - g3).  If
 * D = fl(min e(p) - max e(x)) > T = fl(8 u M), then min e(p) - max e(x) >= D / (1 + u) >
 * 8 u M (1 - u) / (1 + u), which exceeds 2 g3 M / (1 - g3) ~ 6 u M, so n.p > n.x for every
 * pair: the plane n.y = max n.x has one triangle on its closed lower side and the other
 * strictly above it.  (Scaled coordinates are 0 or at least 2**-200 in magnitude: no product
 * underflows.) */
static int slab_separates(const double *n, P const *a, P const *b)
{
    double ea[3], eb[3], largest = 0.0;
    for (int i = 0; i < 3; i++) {
        ea[i] = n[0] * a[i][0] + n[1] * a[i][1] + n[2] * a[i][2];
        eb[i] = n[0] * b[i][0] + n[1] * b[i][1] + n[2] * b[i][2];
        largest = dmax(largest, fabs(n[0]) * fabs(a[i][0]) + fabs(n[1]) * fabs(a[i][1]) + fabs(n[2]) * fabs(a[i][2]));
        largest = dmax(largest, fabs(n[0]) * fabs(b[i][0]) + fabs(n[1]) * fabs(b[i][1]) + fabs(n[2]) * fabs(b[i][2]));
    }
    double threshold = 8.0 * EPS * largest;
    double a_lo = dmin(ea[0], dmin(ea[1], ea[2])), a_hi = dmax(ea[0], dmax(ea[1], ea[2]));
    double b_lo = dmin(eb[0], dmin(eb[1], eb[2])), b_hi = dmax(eb[0], dmax(eb[1], eb[2]));
    return b_lo - a_hi > threshold || a_lo - b_hi > threshold;
}

static inline void rounded_normal(P const *t, double *n)
{
    double u[3] = {t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]};
    double v[3] = {t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]};
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
}

/* Triangles a and b certifiably lie on two sides of a plane: one of them's, or one parallel to an
 * edge of each (the candidate axes of the separating-axis theorem; they separate the pairs near
 * a saddle that straddle each other's planes).  Each normal is a rounded cross product of corner
 * differences, as the faces' normals are, so no product in slab_separates underflows. */
static int separated(P const *a, P const *b)
{
    double n[3];
    rounded_normal(a, n);
    if (slab_separates(n, a, b))
        return 1;
    rounded_normal(b, n);
    if (slab_separates(n, a, b))
        return 1;
    for (int i = 0; i < 3; i++) {
        P a0 = a[i], a1 = a[(i + 1) % 3];
        double u[3] = {a1[0] - a0[0], a1[1] - a0[1], a1[2] - a0[2]};
        for (int j = 0; j < 3; j++) {
            P b0 = b[j], b1 = b[(j + 1) % 3];
            double v[3] = {b1[0] - b0[0], b1[1] - b0[1], b1[2] - b0[2]};
            n[0] = u[1] * v[2] - u[2] * v[1];
            n[1] = u[2] * v[0] - u[0] * v[2];
            n[2] = u[0] * v[1] - u[1] * v[0];
            if (slab_separates(n, a, b))
                return 1;
        }
    }
    return 0;
}

/* ---- pair tests ----------------------------------------------------------------------------- */

static inline P corner(const Grid *g, int64_t t, int k)
{
    return g->V + 3 * g->corner[3 * t + k];
}

/* Whether sorted faces t and u of one shell meet other than along what they share. */
static int self_hit(const Grid *g, int64_t t, int64_t u)
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
        return !separated(ta, tb) && triangles_meet(ta, g->axis[t], tb, g->axis[u]);
    if (shared >= 3)
        return 1;
    if (shared == 2) {
        int ra = 3 - ia[0] - ia[1], rb = 3 - ib[0] - ib[1];
        return fold_over_edge(ta[ia[0]], ta[ia[1]], ta[ra], tb[rb], g->axis[t]);
    }
    return meet_beyond_vertex(ta[ia[0]], ta[(ia[0] + 1) % 3], ta[(ia[0] + 2) % 3], g->axis[t],
                              tb[(ib[0] + 1) % 3], tb[(ib[0] + 2) % 3], g->axis[u]);
}

static int other_hit(const Grid *g, int64_t t, int64_t u)
{
    P ta[3] = {corner(g, t, 0), corner(g, t, 1), corner(g, t, 2)};
    P tb[3] = {corner(g, u, 0), corner(g, u, 1), corner(g, u, 2)};
    return !separated(ta, tb) && triangles_meet(ta, g->axis[t], tb, g->axis[u]);
}

/* ---- findings of a block -------------------------------------------------------------------- */

static inline uint64_t mix64(uint64_t h)
{
    h ^= h >> 30;
    h *= 0xBF58476D1CE4E5B9ULL;
    h ^= h >> 27;
    h *= 0x94D049BB133111EBULL;
    h ^= h >> 31;
    return h;
}

static int seen_has(const Seen *s, uint64_t key)
{
    for (uint64_t i = mix64(key) & s->mask;; i = (i + 1) & s->mask) {
        if (s->slots[i] == 0)
            return 0;
        if (s->slots[i] == key + 1)
            return 1;
    }
}

static int seen_add(Seen *s, uint64_t key)
{
    if (2 * (uint64_t)(s->count + 1) > s->mask + 1) {
        uint64_t size = 2 * (s->mask + 1);
        uint64_t *table = calloc(size, sizeof(uint64_t));
        if (!table)
            return -1;
        for (uint64_t i = 0; i <= s->mask; i++)
            if (s->slots[i]) {
                uint64_t j = mix64(s->slots[i] - 1) & (size - 1);
                while (table[j])
                    j = (j + 1) & (size - 1);
                table[j] = s->slots[i];
            }
        free(s->slots);
        s->slots = table;
        s->mask = size - 1;
    }
    uint64_t i = mix64(key) & s->mask;
    while (s->slots[i])
        i = (i + 1) & s->mask;
    s->slots[i] = key + 1;
    s->count++;
    return 0;
}

/* Empty the set of the pairs a block added (every key in it is one of them). */
static void seen_clear(Seen *s, const Block *b)
{
    for (int64_t k = 0; k < b->n_found && s->count; k++) {
        uint64_t key = ((uint64_t)b->found[4 * k] << 32) | (uint64_t)b->found[4 * k + 1];
        for (uint64_t i = mix64(key) & s->mask; s->slots[i]; i = (i + 1) & s->mask)
            s->slots[i] = 0;
    }
    s->count = 0;
}

static int append(int64_t **items, int64_t *count, int64_t *cap, int width, const int64_t *row)
{
    if (*count == *cap) {
        int64_t grown = *cap ? 2 * *cap : 8;
        int64_t *more = realloc(*items, sizeof(int64_t) * width * grown);
        if (!more)
            return -1;
        *items = more;
        *cap = grown;
    }
    memcpy(*items + width * (*count)++, row, sizeof(int64_t) * width);
    return 0;
}

static int block_has_self(const Block *b, int64_t shell)
{
    for (int64_t i = 0; i < b->n_self; i++)
        if (b->self_shells[i] == shell)
            return 1;
    return 0;
}

static void consider(const Search *s, Block *b, Seen *seen, int64_t t, int64_t u)
{
    const Grid *g = s->g;
    int64_t st = shell_at(g->shell, t), su = shell_at(g->shell, u);
    if (st == su) {
        if (s->max_examples >= 0 && b->n_examples >= s->max_examples && block_has_self(b, st))
            return;
        b->tests++;
        if (!self_hit(g, t, u))
            return;
        if (!block_has_self(b, st) && append(&b->self_shells, &b->n_self, &b->cap_self, 1, &st) < 0) {
            b->failed = 1;
            return;
        }
        if (s->max_examples < 0) {
            int64_t x = grid_id(g, t), y = grid_id(g, u);
            int64_t row[2] = {x < y ? x : y, x < y ? y : x};
            if (append(&b->examples, &b->n_examples, &b->cap_examples, 2, row) < 0)
                b->failed = 1;
        } else if (b->n_examples < s->max_examples) {
            int64_t x = grid_id(g, t), y = grid_id(g, u);
            b->examples[2 * b->n_examples] = x < y ? x : y;
            b->examples[2 * b->n_examples + 1] = x < y ? y : x;
            b->n_examples++;
        }
        return;
    }
    if (st > su) {
        int64_t x = st;
        st = su;
        su = x;
        x = t;
        t = u;
        u = x;
    }
    uint64_t key = ((uint64_t)st << 32) | (uint64_t)su;
    int every = s->max_examples < 0;    /* every meeting pair is listed, between shells too */
    if (!every && seen_has(seen, key))
        return;
    b->tests++;
    if (!other_hit(g, t, u))
        return;
    if (every) {
        int64_t x = grid_id(g, t), y = grid_id(g, u);
        int64_t pair[2] = {x < y ? x : y, x < y ? y : x};
        if (append(&b->examples, &b->n_examples, &b->cap_examples, 2, pair) < 0) {
            b->failed = 1;
            return;
        }
        if (seen_has(seen, key))
            return;
    }
    int64_t row[4] = {st, su, grid_id(g, t), grid_id(g, u)};
    if (seen_add(seen, key) < 0 || append(&b->found, &b->n_found, &b->cap_found, 4, row) < 0)
        b->failed = 1;
}

/* ---- candidates ----------------------------------------------------------------------------- */

static inline int boxes_meet(const Grid *g, int64_t t, int64_t u)
{
    const double *lt = g->lo + 3 * t, *ht = g->hi + 3 * t, *lu = g->lo + 3 * u, *hu = g->hi + 3 * u;
    return !(lt[0] > hu[0] || lu[0] > ht[0] || lt[1] > hu[1] || lu[1] > ht[1] || lt[2] > hu[2] || lu[2] > ht[2]);
}

/* Faces of one shell with a vertex in common whose star is certified embedded (its bit is set in
 * both faces, so t's bits suffice). */
static inline int share_certified(const Grid *g, int64_t t, int64_t u)
{
    uint8_t c = g->certified[t];
    if (!c)
        return 0;
    const int64_t *a = g->corner + 3 * t, *b = g->corner + 3 * u;
    for (int k = 0; k < 3; k++)
        if ((c >> k & 1) && (a[k] == b[0] || a[k] == b[1] || a[k] == b[2]))
            return 1;
    return 0;
}

/* A pair is decided in the cell (at `level`, coordinates `cell`) holding max(lower corners). */
static inline int canonical_cell(const Grid *g, int64_t t, int64_t u, int level, const int64_t *cell)
{
    const int32_t *a = g->low_cell + 3 * t, *b = g->low_cell + 3 * u;
    for (int k = 0; k < 3; k++)
        if ((int64_t)(a[k] > b[k] ? a[k] : b[k]) >> level != cell[k])
            return 0;
    return 1;
}

static inline void candidate(const Search *s, Block *b, Seen *seen, int64_t t, int64_t u, int level,
                             const int64_t *cell)
{
    const Grid *g = s->g;
    b->candidates++;
    if (!boxes_meet(g, t, u))
        return;
    int64_t st = shell_at(g->shell, t), su = shell_at(g->shell, u);
    if (st == su) {
        if (!s->within || (s->embedded && s->embedded[st]) || share_certified(g, t, u))
            return;
    } else if (!s->between) {
        return;
    }
    if (canonical_cell(g, t, u, level, cell))
        consider(s, b, seen, t, u);
}

/* The pairs of the faces of run [e, run) one by one; faces of one hub group are consecutive in a
 * run: their pairs are skipped as a block. */
static void all_pairs(const Search *s, Block *b, Seen *seen, int64_t e, int64_t run, int level, const int64_t *cell)
{
    const Grid *g = s->g;
    for (int64_t i = e; i < run;) {
        uint32_t group_end = grid_group_end(g, g->face[i]);
        int64_t after = i + 1;
        while (after < run && g->face[after] < group_end)
            after++;
        for (int64_t x = i; x < after; x++)
            for (int64_t y = after; y < run; y++)
                candidate(s, b, seen, g->face[x], g->face[y], level, cell);
        i = after;
    }
}

/* share_certified on copied faces: a corner of x whose star is certified is a corner of y. */
static inline int items_share_certified(const Item *x, const Item *y)
{
    uint8_t c = x->certified;
    for (int k = 0; k < 3; k++)
        if ((c >> k & 1)
            && (x->corner[k] == y->corner[0] || x->corner[k] == y->corner[1] || x->corner[k] == y->corner[2]))
            return 1;
    return 0;
}

static int scratch_reserve(Scratch *sc, int64_t k)
{
    if (k <= sc->cap)
        return 0;
    int64_t cap = sc->cap ? sc->cap : 64;
    while (cap < k)
        cap *= 2;
    Item *items = malloc(sizeof(Item) * cap);
    Slab *slabs = malloc(sizeof(Slab) * cap);
    uint32_t *hits = malloc(sizeof(uint32_t) * cap);
    SortKey *keys = malloc(sizeof(SortKey) * 2 * cap);
    if (!items || !slabs || !hits || !keys) {
        free(items), free(slabs), free(hits), free(keys);
        return -1;
    }
    free(sc->items), free(sc->slabs), free(sc->hits), free(sc->keys);
    sc->items = items;
    sc->slabs = slabs;
    sc->hits = hits;
    sc->keys = keys;
    sc->cap = cap;
    return 0;
}

/* Keys sorted by x, stably (in the array given or tmp). */
RUN_MERGE_SORT(sort_keys, SortKey, x)

/* The pairs of run [e, run) whose boxes meet, by a sweep: the faces sorted by their boxes' low
 * end along one axis, each face meets on that axis exactly the faces after it whose low end is at
 * most its high end (both boxes are closed intervals, the later starts no earlier), so stopping
 * at the first that starts above it misses no pair.  The axis is the one along which the faces
 * are shortest against the run's extent.  A pair is decided in the cell of max(lower corners):
 * every face of the cell has its low cell at most the cell's on each axis, so that is the cell
 * exactly when, on every axis, one of the two has its low cell there (`home` bits).  0, or -1
 * out of memory (nothing done). */
static int sweep_pairs(const Search *s, Block *b, Seen *seen, Scratch *sc, int64_t e, int64_t run, int level,
                       const int64_t *cell)
{
    const Grid *g = s->g;
    int64_t k = run - e;
    if (scratch_reserve(sc, k) < 0)
        return -1;
    double length[3] = {0.0, 0.0, 0.0}, low[3] = {INFINITY, INFINITY, INFINITY};
    double high[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int64_t i = 0; i < k; i++) {
        uint32_t t = g->face[e + i];
        Item *it = &sc->items[i];
        it->face = t;
        it->shell = shell_at(g->shell, t);
        it->certified = g->certified[t];
        uint8_t home = 0;
        for (int a = 0; a < 3; a++) {
            it->lo[a] = g->lo[3 * t + a];
            it->hi[a] = g->hi[3 * t + a];
            it->corner[a] = g->corner[3 * t + a];
            home |= (uint8_t)(((int64_t)g->low_cell[3 * t + a] >> level == cell[a]) << a);
            length[a] += it->hi[a] - it->lo[a];
            low[a] = dmin(low[a], it->lo[a]);
            high[a] = dmax(high[a], it->hi[a]);
        }
        it->home = home;
    }
    int axis = 0;
    double best = INFINITY;
    for (int a = 0; a < 3; a++) {
        double span = high[a] - low[a], ratio = span > 0.0 ? length[a] / span : INFINITY;
        if (ratio < best) {
            best = ratio;
            axis = a;
        }
    }
    int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    for (int64_t i = 0; i < k; i++) {
        sc->keys[i].x = sc->items[i].lo[axis];
        sc->keys[i].i = (uint32_t)i;
    }
    SortKey *order = sort_keys(sc->keys, sc->keys + k, k);
    Slab *S = sc->slabs;
    for (int64_t i = 0; i < k; i++) {
        const Item *it = &sc->items[order[i].i];
        S[i] = (Slab){it->lo[axis], it->hi[axis], {it->lo[a1], it->hi[a1], it->lo[a2], it->hi[a2]}, it->home,
                      order[i].i};
    }
    uint32_t *hits = sc->hits;
    int64_t candidates = 0;
    for (int64_t i = 0; i < k && !b->failed; i++) {
        const Slab x = S[i];
        int64_t n_hits = 0, j = i + 1;
        for (; j < k && S[j].lo <= x.hi; j++) {
            const Slab *y = &S[j];
            hits[n_hits] = (uint32_t)j;
            n_hits += (x.box[0] <= y->box[1]) & (y->box[0] <= x.box[1]) & (x.box[2] <= y->box[3])
                      & (y->box[2] <= x.box[3]) & ((x.home | y->home) == 7);
        }
        candidates += j - i - 1;
        const Item *p = &sc->items[x.item];
        for (int64_t h = 0; h < n_hits; h++) {
            const Item *q = &sc->items[S[hits[h]].item];
            if (p->shell == q->shell) {
                if (!s->within || (s->embedded && s->embedded[p->shell]) || items_share_certified(p, q))
                    continue;
            } else if (!s->between) {
                continue;
            }
            int64_t t = p->face < q->face ? p->face : q->face, u = p->face < q->face ? q->face : p->face;
            consider(s, b, seen, t, u);
        }
    }
    b->candidates += candidates;
    return 0;
}

/* Pairs within a level: the entries [begin, end) of the block, runs of one key. */
static void search_cells(const Search *s, Block *b, Seen *seen, Scratch *sc, int64_t begin, int64_t end)
{
    const Grid *g = s->g;
    int64_t e = begin;
    while (e < end && !b->failed) {
        int64_t run = e + 1;
        int grouped = 0;
        while (run < g->n_entries && g->key[run] == g->key[e])
            run++;
        for (int64_t i = e; g->group_begin && i < run && !grouped; i++)
            grouped = g->group_end[g->face[i]] - g->group_begin[g->face[i]] > 1;
        int level = (int)(g->key[e] >> LEVEL_SHIFT);
        int64_t cell[3];
        grid_key_cell(g->key[e] & ((1ULL << LEVEL_SHIFT) - 1), cell);
        /* a sweep finds the pairs whose boxes meet without looking at the others; a hub group's
         * faces all meet at the hub, so there its pairs are skipped as a block instead */
        if (run - e > 1 && (grouped || sweep_pairs(s, b, seen, sc, e, run, level, cell) < 0))
            all_pairs(s, b, seen, e, run, level, cell);
        e = run;
    }
}

/* First entry in [lo, hi) whose face is at least `face` (entries of a key ascend by face). */
static int64_t first_face_at_least(const Grid *g, int64_t lo, int64_t hi, uint32_t face)
{
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (g->face[mid] < face)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* Pairs across levels: each face of [begin, end) looks up the coarser cells its box covers. */
static void search_levels(const Search *s, Block *b, Seen *seen, int64_t begin, int64_t end)
{
    const Grid *g = s->g;
    for (int64_t t = begin; t < end && !b->failed; t++) {
        int level = g->level[t];
        uint32_t group_begin = grid_group_begin(g, t), group_end = grid_group_end(g, t);
        for (int l = 0; l < g->n_used; l++) {
            int coarse = g->used[l];
            if (coarse <= level)
                continue;
            int64_t c0[3], c1[3];
            grid_face_cells(g, t, coarse, c0, c1);
            for (int64_t x = c0[0]; x <= c1[0]; x++)
                for (int64_t y = c0[1]; y <= c1[1]; y++)
                    for (int64_t z = c0[2]; z <= c1[2]; z++) {
                        uint64_t key = grid_key(coarse, x, y, z);
                        int64_t cell[3] = {x, y, z};
                        int64_t first = grid_find(g, coarse, key);
                        if (first < 0)
                            continue;
                        int64_t last = first;
                        while (last < g->n_entries && g->key[last] == key)
                            last++;
                        /* the faces of t's hub group, consecutive here too, are skipped */
                        int64_t skip0 = last, skip1 = last;
                        if (group_end - group_begin > 1) {
                            skip0 = first_face_at_least(g, first, last, group_begin);
                            skip1 = first_face_at_least(g, skip0, last, group_end);
                        }
                        for (int64_t i = first; i < last; i++) {
                            if (i == skip0)
                                i = skip1;
                            if (i < last)
                                candidate(s, b, seen, t, g->face[i], coarse, cell);
                        }
                    }
        }
    }
}

static void search_block(void *ctx, int worker, int64_t block)
{
    const Search *s = ctx;
    Block *b = &s->blocks[block];
    Seen *seen = &s->seen[worker];
    if (s->max_examples >= 0) {
        b->examples = malloc(sizeof(int64_t) * 2 * (s->max_examples ? s->max_examples : 1));
        if (!b->examples) {
            b->failed = 1;
            return;
        }
    }
    if (block < s->n_entry_blocks)
        search_cells(s, b, seen, &s->scratch[worker], s->entry_cut[block], s->entry_cut[block + 1]);
    else {
        int64_t k = block - s->n_entry_blocks;
        int64_t end = (k + 1) * FACE_BLOCK < s->g->n ? (k + 1) * FACE_BLOCK : s->g->n;
        search_levels(s, b, seen, k * FACE_BLOCK, end);
    }
    seen_clear(seen, b);
}

/* ---- the search ---------------------------------------------------------------------------- */

void found_free(Found *f)
{
    free(f->self_found), free(f->examples), free(f->found);
    memset(f, 0, sizeof(*f));
}

static int merge(const Search *s, int64_t n_blocks, Found *out)
{
    int64_t n_examples = 0, n_found = 0;
    for (int64_t k = 0; k < n_blocks; k++) {
        n_examples += s->blocks[k].n_examples;
        n_found += s->blocks[k].n_found;
    }
    if (s->max_examples >= 0)
        n_examples = n_examples < s->max_examples ? n_examples : s->max_examples;
    out->self_found = calloc(s->n_shells, 1);
    out->examples = malloc(sizeof(int64_t) * 2 * (n_examples ? n_examples : 1));
    out->found = malloc(sizeof(int64_t) * 4 * (n_found ? n_found : 1));
    if (!out->self_found || !out->examples || !out->found)
        return -1;
    for (int64_t k = 0; k < n_blocks; k++) {
        const Block *b = &s->blocks[k];
        for (int64_t i = 0; i < b->n_self; i++)
            out->self_found[b->self_shells[i]] = 1;
        for (int64_t i = 0; i < b->n_examples && out->n_examples < n_examples; i++, out->n_examples++)
            memcpy(out->examples + 2 * out->n_examples, b->examples + 2 * i, 2 * sizeof(int64_t));
        if (b->n_found)
            memcpy(out->found + 4 * out->n_found, b->found, 4 * sizeof(int64_t) * b->n_found);
        out->n_found += b->n_found;
        out->candidates += b->candidates;
        out->tests += b->tests;
    }
    return 0;
}

static int run_search(Search *s, int threads, Found *out)
{
    const Grid *g = s->g;
    int64_t want = g->n_entries / ENTRY_BLOCK + 1;
    s->entry_cut = malloc(sizeof(int64_t) * (want + 1));
    if (!s->entry_cut)
        return -1;
    /* blocks of about ENTRY_BLOCK entries, cut where the key changes */
    int64_t n_cuts = 0, at = 0;
    s->entry_cut[n_cuts++] = 0;
    while (at < g->n_entries && n_cuts <= want) {
        int64_t next = at + ENTRY_BLOCK < g->n_entries ? at + ENTRY_BLOCK : g->n_entries;
        while (next < g->n_entries && g->key[next] == g->key[next - 1])
            next++;
        s->entry_cut[n_cuts++] = next;
        at = next;
    }
    s->n_entry_blocks = n_cuts - 1;
    s->n_face_blocks = g->n_used > 1 ? (g->n + FACE_BLOCK - 1) / FACE_BLOCK : 0;
    int64_t n_blocks = s->n_entry_blocks + s->n_face_blocks;
    int workers = threads < 1 ? 1 : threads;
    s->blocks = calloc(n_blocks ? n_blocks : 1, sizeof(Block));
    s->seen = calloc(workers, sizeof(Seen));
    s->scratch = calloc(workers, sizeof(Scratch));
    int status = -1;
    if (!s->blocks || !s->seen || !s->scratch)
        goto done;
    for (int k = 0; k < workers; k++) {
        s->seen[k].slots = calloc(64, sizeof(uint64_t));
        s->seen[k].mask = 63;
        if (!s->seen[k].slots)
            goto done;
    }
    parallel_workers(workers, n_blocks, search_block, s);
    for (int64_t k = 0; k < n_blocks; k++)
        if (s->blocks[k].failed)
            goto done;
    status = merge(s, n_blocks, out);
done:
    for (int64_t k = 0; s->blocks && k < n_blocks; k++) {
        free(s->blocks[k].examples);
        free(s->blocks[k].self_shells);
        free(s->blocks[k].found);
    }
    for (int k = 0; s->seen && k < workers; k++)
        free(s->seen[k].slots);
    for (int k = 0; s->scratch && k < workers; k++)
        free(s->scratch[k].items), free(s->scratch[k].slabs), free(s->scratch[k].hits), free(s->scratch[k].keys);
    free(s->blocks), free(s->seen), free(s->scratch), free(s->entry_cut);
    return status;
}

/* An empty result; 0, or -1 when memory ran out (then freed). */
static int found_nothing(Found *out, int64_t n_shells)
{
    out->self_found = calloc(n_shells, 1);
    out->examples = malloc(16);
    out->found = malloc(32);
    if (out->self_found && out->examples && out->found)
        return 0;
    found_free(out);
    return -1;
}

int search_pairs(const double *V, const int64_t *F, const int64_t *shell, const uint8_t *active, int64_t n,
                 int64_t m, int64_t n_shells, int within, int between, int64_t max_examples, int closed, int threads,
                 Found *out, Stars *stars)
{
    memset(out, 0, sizeof(*out));
    memset(stars, 0, sizeof(*stars));
    int have_stars = 0;
    if (within && m < ((int64_t)1 << 30)) {
        uint8_t *wanted = calloc(n_shells, 1);
        if (!wanted)
            return -1;
        /* one shell (labels are checked by the caller): no label read */
        for (int64_t t = 0; n_shells == 1 && t < m && !wanted[0]; t++)
            wanted[0] = !active || active[t] != 0;
        for (int64_t t = 0; n_shells > 1 && t < m; t++)
            wanted[shell[t]] |= active ? active[t] : 1;
        /* out of memory for the certificates: every pair is tested */
        /* certified by its degree (closed, one shell, no pairs between shells): no stars are built,
         * and none is needed after */
        have_stars = stars_build_lazy(stars, V, F, n, m, shell, n_shells, wanted, threads, 1,
                                      closed && n_shells == 1 && !between) == 0;
        free(wanted);
    }
    /* Faces whose every pair is certified take no part unless other shells may meet them.  take
     * NULL: every face (one shell, no active flags: no byte a face written). */
    int64_t taken = 0;
    if (have_stars && n_shells == 1 && !between && stars->shell_embedded[0])
        return found_nothing(out, n_shells);     /* one shell certified as a whole: no face is searched */
    int keep_all = n_shells == 1 && (between || !have_stars || !stars->shell_embedded[0]);
    uint8_t *take = keep_all && !active ? NULL : malloc(m ? m : 1);
    if (!take && !(keep_all && !active))
        return -1;                    /* the caller frees the stars */
    if (!take)
        taken = m;
    for (int64_t t = 0; take && keep_all && t < m; t++) {
        take[t] = active[t] != 0;
        taken += take[t];
    }
    if (take && keep_all && taken == m) {
        free(take);                   /* every face active: as without flags */
        take = NULL;
    }
    for (int64_t t = 0; take && !keep_all && t < m; t++) {
        take[t] = (!active || active[t]) && (between || !have_stars || !stars->shell_embedded[shell_at(shell, t)]);
        taken += take[t];
    }
    /* Faces in cells of a coarse grid certified embedded as a patch need no search of their own
     * (patches.c): the pairs they form there are certified, and any other pair is in a cell that
     * failed, whose faces are all searched. */
    if (within && have_stars && taken > 1) {
        uint8_t *bad = isect_alloc(m, 1);
        if (bad && patches_mark(V, F, shell, take, m, stars, threads, bad) == 0) {
            taken = 0;
            if (!take) {
                take = bad;       /* every face was taken: those of the cells that failed (read, not written) */
                bad = NULL;
            }
            for (int64_t t = 0; bad && t < m; t++)
                take[t] = take[t] && bad[t];
            for (int64_t t = 0; t < m; t++)
                taken += take[t];
        }
        free(bad);
    }
    /* the stars of the faces left to search, which the search skips pairs by */
    if (have_stars && taken)
        stars_certify_corners(stars, shell, take, threads);
    Grid g;
    memset(&g, 0, sizeof(g));
    int status = taken ? grid_build(&g, V, F, shell, take, m, have_stars ? stars : NULL, threads) : 0;
    free(take);
    if (status == 0 && g.n > 0) {
        Search s;
        memset(&s, 0, sizeof(s));
        s.g = &g;
        s.within = within;
        s.between = between;
        s.n_shells = n_shells;
        s.max_examples = max_examples;
        s.embedded = have_stars ? stars->shell_embedded : NULL;
        status = run_search(&s, threads, out);
    } else if (status == 0) {
        status = found_nothing(out, n_shells);
    }
    grid_free(&g);
    if (status < 0)
        found_free(out);
    return status;
}
