/* Welding by exact coordinates: one open-addressing table of distinct points.
 *
 * A point's key is the bit pattern of its three float64 coordinates (float32
 * values are widened first, exactly), with -0.0 stored as +0.0 so equal
 * values weld; NaNs weld only with the same bits.  Vertices are numbered in
 * order of first appearance, so the result does not depend on the table.
 */
#include "core.h"

#include <stdlib.h>
#include <string.h>

static inline uint64_t mix64(uint64_t h)
{
    h ^= h >> 30;
    h *= 0xBF58476D1CE4E5B9ULL;
    h ^= h >> 27;
    h *= 0x94D049BB133111EBULL;
    h ^= h >> 31;
    return h;
}

static inline uint64_t point_bits(double x)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    return (bits << 1) == 0 ? 0 : bits;          /* -0.0 and +0.0: one key */
}

/* Odd multipliers carry every bit of a coordinate into the product's top bits (the slot); the
 * fold brings the top into the low bits (the tag, and the recent cache's index). */
static inline uint64_t point_hash(const uint64_t key[3])
{
    uint64_t h = key[0] * 0x9E3779B97F4A7C15ULL ^ key[1] * 0xBF58476D1CE4E5B9ULL ^ key[2] * 0x94D049BB133111EBULL;
    return h ^ (h >> 29) ^ (h >> 47);
}

static int resize(Welder *w, int bits)
{
    uint64_t size = (uint64_t)1 << bits, k;
    uint64_t *slots = calloc(size, sizeof *slots);
    const double *stored = (const double *)w->vertices.data;
    if (!slots)
        return -1;
    free(w->slots);
    w->slots = slots;
    w->bits = bits;
    w->mask = size - 1;
    for (k = 0; k < (uint64_t)w->count; k++) {
        uint64_t key[3] = {point_bits(stored[3 * k]), point_bits(stored[3 * k + 1]), point_bits(stored[3 * k + 2])};
        uint64_t h = point_hash(key), slot = h >> (64 - bits);
        while (slots[slot])
            slot = (slot + 1) & w->mask;
        slots[slot] = (h << 32) | (k + 1);
    }
    return 0;
}

int welder_init(Welder *w, int64_t expected)
{
    int bits = 10;
    uint64_t k, recent = 64;
    memset(w, 0, sizeof *w);
    while (recent < RECENT && (int64_t)recent < expected)
        recent *= 2;
    w->recent = malloc(recent * sizeof *w->recent);
    if (!w->recent)
        return -1;
    w->recent_mask = recent - 1;
    for (k = 0; k < recent; k++)
        w->recent[k].vertex = -1;
    while (bits < 40 && ((int64_t)1 << bits) < 2 * expected)
        bits++;
    if (grow_reserve(&w->vertices, (size_t)(expected > 0 ? expected : 16) * 3 * sizeof(double)) != 0)
        return -1;
    return resize(w, bits);
}

void welder_free(Welder *w)
{
    free(w->slots);
    free(w->recent);
    w->slots = NULL;
    w->recent = NULL;
    grow_free(&w->vertices);
}

/* Insert a point with its key bits and hash: its vertex number, or -1 when memory ran out. */
static inline int64_t insert(Welder *w, const uint64_t key[3], uint64_t h)
{
    uint64_t slot = h >> (64 - w->bits), tag = h << 32;
    const double *stored;
    double *added;
    for (;;) {
        uint64_t entry = w->slots[slot];
        if (!entry)
            break;
        if ((entry & 0xFFFFFFFF00000000ULL) == tag) {
            uint64_t vertex = (entry & 0xFFFFFFFFULL) - 1;
            stored = (const double *)w->vertices.data + 3 * vertex;
            if (point_bits(stored[0]) == key[0] && point_bits(stored[1]) == key[1] && point_bits(stored[2]) == key[2])
                return (int64_t)vertex;
        }
        slot = (slot + 1) & w->mask;
    }
    if (w->count >= 0xFFFFFFFELL || grow_reserve(&w->vertices, 3 * sizeof(double)) != 0)
        return -1;
    added = (double *)(w->vertices.data + w->vertices.size);
    memcpy(added, key, 3 * sizeof(double));       /* the canonical bits: -0.0 stored as +0.0 */
    w->vertices.size += 3 * sizeof(double);
    w->slots[slot] = tag | (uint64_t)(w->count + 1);
    w->count++;
    if ((uint64_t)w->count * 2 > w->mask + 1 && resize(w, w->bits + 1) != 0)
        return -1;
    return w->count - 1;
}

/* What the cache of recent points holds for this point: its vertex (>= 0), a pending marker
 * (<= -2, see weld_part), or -1 when it holds another point or none. */
static inline int64_t recent_lookup(const Welder *w, const uint64_t key[3], uint64_t h)
{
    const uint64_t *known = w->recent[h & w->recent_mask].key;
    int64_t vertex = w->recent[h & w->recent_mask].vertex;
    return vertex != -1 && known[0] == key[0] && known[1] == key[1] && known[2] == key[2] ? vertex : -1;
}

/* insert(), looking in the cache of recent points first. */
static inline int64_t weld_key(Welder *w, const uint64_t key[3], uint64_t h)
{
    int64_t vertex = recent_lookup(w, key, h);
    if (vertex >= 0)
        return vertex;
    vertex = insert(w, key, h);
    memcpy(w->recent[h & w->recent_mask].key, key, 3 * sizeof *key);
    w->recent[h & w->recent_mask].vertex = vertex;
    return vertex;
}

int64_t weld_point64(Welder *w, const double point[3])
{
    uint64_t key[3] = {point_bits(point[0]), point_bits(point[1]), point_bits(point[2])};
    return weld_key(w, key, point_hash(key));
}

int64_t weld_point32(Welder *w, const float point[3])
{
    double wide[3] = {point[0], point[1], point[2]};      /* exact */
    return weld_point64(w, wide);
}

/* The table is much larger than the caches: the slots of the next points are fetched while the
 * current ones are inserted (in order, so numbering is unchanged). */
#define AHEAD 16

/* ---- welding on several threads ----------------------------------------------------------- */

static inline int part_of(uint64_t h, int parts)
{
    return (int)((((h >> 20) & 0xFFFF) * (uint64_t)parts) >> 16);     /* bits apart from slot and cache */
}

int split_init(SplitWelder *s, int threads, int64_t expected_points)
{
    int p;
    memset(s, 0, sizeof *s);
    s->parts = threads < 1 ? 1 : threads > MAX_PARTS ? MAX_PARTS : threads;
    if (expected_points < 200000)
        s->parts = 1;                                     /* a thread costs more than it saves */
    for (p = 0; p < s->parts; p++)
        if (welder_init(&s->part[p], expected_points / 5 / s->parts + 16) != 0) {
            split_free(s);
            return -1;
        }
    return 0;
}

void split_free(SplitWelder *s)
{
    int p;
    for (p = 0; p < MAX_PARTS; p++) {
        if (s->part[p].slots)
            welder_free(&s->part[p]);
        grow_free(&s->global[p]);
    }
}

typedef struct {
    SplitWelder *s;
    const double *points;
    int64_t count;
    index_t *out;
    int failed[MAX_PARTS];
} SplitWork;

/* Phase one, for part p: weld its points into its own table, and write each point's code
 * (vertex of the part * parts + p) into out.  Slots are fetched AHEAD points early. */
/* In the cache of recent points, a point still waiting in the pipeline below is marked with
 * PENDING(k), k its index in this call: later copies of it take its number once it has one. */
#define PENDING(k) (-2 - (k))

static void weld_part(void *arg, int64_t p)
{
    SplitWork *work = arg;
    SplitWelder *s = work->s;
    Welder *w = &s->part[p];
    uint64_t keys[AHEAD][3], hashes[AHEAD];
    int64_t index[AHEAD], copy_of[AHEAD], k, head = 0, tail = 0;
    for (k = 0; k <= work->count; k++) {
        if (k < work->count) {
            uint64_t key[3] = {point_bits(work->points[3 * k]), point_bits(work->points[3 * k + 1]),
                               point_bits(work->points[3 * k + 2])}, h = point_hash(key);
            int64_t known;
            if (s->parts > 1 && part_of(h, s->parts) != p)
                continue;
            known = recent_lookup(w, key, h);
            if (known >= 0) {
                /* a vertex welded before: its number is final, whatever is still pending */
                work->out[k] = known * s->parts + p;
                continue;
            }
            if (known == -1) {
                __builtin_prefetch(&w->slots[h >> (64 - w->bits)]);
                memcpy(w->recent[h & w->recent_mask].key, key, sizeof key);
                w->recent[h & w->recent_mask].vertex = PENDING(k);
            }
            memcpy(keys[head % AHEAD], key, sizeof key);
            hashes[head % AHEAD] = h;
            index[head % AHEAD] = k;
            copy_of[head % AHEAD] = known == -1 ? -1 : -2 - known;
            head++;
            if (head - tail < AHEAD)
                continue;
        }
        for (; tail < head && (k < work->count ? head - tail >= AHEAD : 1); tail++) {
            int64_t slot = tail % AHEAD, vertex, *cached;
            if (copy_of[slot] >= 0) {              /* the same point as one earlier in the pipeline */
                work->out[index[slot]] = work->out[copy_of[slot]];
                continue;
            }
            vertex = insert(w, keys[slot], hashes[slot]);
            if (vertex < 0) {
                work->failed[p] = 1;
                return;
            }
            work->out[index[slot]] = vertex * s->parts + p;
            cached = &w->recent[hashes[slot] & w->recent_mask].vertex;
            if (*cached == PENDING(index[slot]))
                *cached = vertex;
        }
    }
}

int split_points(SplitWelder *s, const double *points, int64_t count, index_t *out)
{
    SplitWork work = {s, points, count, out, {0}};
    int p;
    int64_t k;
    parallel_blocks(s->parts, s->parts, weld_part, &work);
    for (p = 0; p < s->parts; p++) {
        Growable *g = &s->global[p];
        size_t have = g->size / sizeof(int64_t), need = (size_t)s->part[p].count;
        if (work.failed[p] || grow_reserve(g, (need - have) * sizeof(int64_t)) != 0)
            return -1;
        for (; have < need; have++)
            ((int64_t *)g->data)[have] = -1;
        g->size = need * sizeof(int64_t);
    }
    /* Phase two, in order: number each vertex when first seen. */
    for (k = 0; k < count; k++) {
        int64_t code = out[k], *number = (int64_t *)s->global[code % s->parts].data + code / s->parts;
        if (*number < 0)
            *number = s->count++;
        out[k] = *number;
    }
    return 0;
}

int split_finish(SplitWelder *s, MeshArrays *out, Failure *failure)
{
    int p;
    int64_t j;
    out->n = s->count;
    out->vertices = malloc((size_t)(s->count > 0 ? s->count : 1) * 3 * sizeof(double));
    if (!out->vertices) {
        split_free(s);
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    for (p = 0; p < s->parts; p++) {
        const double *stored = (const double *)s->part[p].vertices.data;
        const int64_t *number = (const int64_t *)s->global[p].data;
        for (j = 0; j < s->part[p].count; j++)
            memcpy(out->vertices + 3 * number[j], stored + 3 * j, 3 * sizeof(double));
    }
    split_free(s);
    return 0;
}

/* ---- whole arrays -------------------------------------------------------------------- */

static int finish(Welder *w, MeshArrays *out, Failure *failure)
{
    out->n = w->count;
    out->vertices = (double *)w->vertices.data;
    w->vertices.data = NULL;
    if (out->n == 0) {
        out->vertices = malloc(3 * sizeof(double));          /* a valid pointer for an empty array */
        if (!out->vertices) {
            fail(failure, ERR_MEMORY, NULL, "out of memory");
            return -1;
        }
    }
    welder_free(w);
    return 0;
}

#define WIDE 196608                                      /* float32 corners widened at a time */

int weld_corners(const void *corners, int single, int64_t m, int threads, MeshArrays *out, Failure *failure)
{
    SplitWelder s;
    int64_t k;
    double *wide = single ? malloc((size_t)(3 * m < WIDE ? 3 * m + 1 : WIDE) * 3 * sizeof(double)) : NULL;
    out->m = m;
    out->faces = malloc((size_t)(m > 0 ? m : 1) * 3 * sizeof(index_t));
    if (!out->faces || (single && !wide) || split_init(&s, threads, 3 * m) != 0) {
        free(out->faces);
        free(wide);
        out->faces = NULL;
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    if (single) {
        for (k = 0; k < 3 * m && failure->kind == ERR_NONE; k += WIDE) {
            int64_t n = 3 * m - k < WIDE ? 3 * m - k : WIDE, j;
            for (j = 0; j < 3 * n; j++)
                wide[j] = ((const float *)corners)[3 * k + j];      /* exact */
            if (split_points(&s, wide, n, out->faces + k) != 0)
                fail(failure, ERR_MEMORY, NULL, "out of memory");
        }
    } else if (split_points(&s, corners, 3 * m, out->faces) != 0) {
        fail(failure, ERR_MEMORY, NULL, "out of memory");
    }
    free(wide);
    if (failure->kind != ERR_NONE) {
        split_free(&s);
        free(out->faces);
        out->faces = NULL;
        return -1;
    }
    return split_finish(&s, out, failure);
}

int weld_indexed(const double *vertices, int64_t n, const void *faces, int faces32, int64_t m,
                 MeshArrays *out, Failure *failure)
{
    Welder w;
    int64_t k, *renumber = malloc((size_t)(n > 0 ? n : 1) * sizeof(int64_t));
    out->m = m;
    out->faces = malloc((size_t)(m > 0 ? m : 1) * 3 * sizeof(index_t));
    if (!renumber || !out->faces || welder_init(&w, n) != 0) {
        free(renumber);
        free(out->faces);
        out->faces = NULL;
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    for (k = 0; k < n; k++)
        renumber[k] = -1;
    for (k = 0; k < 3 * m; k++) {
        int64_t given = faces32 ? ((const int32_t *)faces)[k] : ((const int64_t *)faces)[k];
        if (given < 0 || given >= n) {
            fail(failure, ERR_INDEX, "re-export the mesh",
                 "face %lld refers to vertex %lld, but there are %lld vertices", (long long)(k / 3),
                 (long long)given, (long long)n);
            break;
        }
        if (renumber[given] < 0 && (renumber[given] = weld_point64(&w, vertices + 3 * given)) < 0) {
            fail(failure, ERR_MEMORY, NULL, "out of memory");
            break;
        }
        out->faces[k] = renumber[given];
    }
    free(renumber);
    if (failure->kind != ERR_NONE) {
        welder_free(&w);
        free(out->faces);
        out->faces = NULL;
        return -1;
    }
    return finish(&w, out, failure);
}
