/* Welding by exact coordinates: one open-addressing table of distinct points.
 *
 * A point's key is the bit pattern of its three float64 coordinates (float32
 * values are widened first, exactly), with -0.0 stored as +0.0 so equal
 * values weld; NaNs weld only with the same bits.  Vertices are numbered in
 * order of first appearance, so the result does not depend on the table.
 */
#include "core.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

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
    advise_huge(slots, size * sizeof *slots);
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

/* The table sized for `expected` points; with `cached`, the cache of recent points too (for points that
 * repeat: without it, welding goes through the table alone, see weld_direct). */
static int welder_start(Welder *w, int64_t expected, int cached)
{
    int bits = 10;
    uint64_t k, recent = 64;
    memset(w, 0, sizeof *w);
    while (cached && recent < RECENT && (int64_t)recent < expected)
        recent *= 2;
    if (cached) {
        w->recent = malloc(recent * sizeof *w->recent);
        if (!w->recent)
            return -1;
        w->recent_mask = recent - 1;
        for (k = 0; k < recent; k++)
            w->recent[k].vertex = -1;
    }
    while (bits < 40 && ((int64_t)1 << bits) < 2 * expected)
        bits++;
    if (reserve(&w->vertices, (size_t)(expected > 0 ? expected : 16) * 3 * sizeof(double)) != 0)
        return -1;
    return resize(w, bits);
}

int welder_init(Welder *w, int64_t expected)
{
    return welder_start(w, expected, 1);
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
    if (w->count >= 0xFFFFFFFELL || reserve(&w->vertices, 3 * sizeof(double)) != 0)
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

/* ---- welding a block of points, with the slots fetched ahead ------------------------------- */

/* In the cache of recent points, a point still waiting in the pipeline below is marked with
 * PENDING(k), k its index in the block.  A later copy of it is written to out as LINK(k), and
 * replaced by out[k]'s number once the block is done. */
#define PENDING(k) (-2 - (k))
#define LINK(k) (-1 - (k))

/* Weld the point waiting at the pipeline's tail; 0, or -1 when memory ran out. */
static inline int weld_tail(Welder *w, index_t *out, uint64_t key[3], uint64_t h, int64_t k)
{
    int64_t vertex = insert(w, key, h), *cached;
    if (vertex < 0)
        return -1;
    out[k] = vertex;
    cached = &w->recent[h & w->recent_mask].vertex;
    if (*cached == PENDING(k))
        *cached = vertex;
    return 0;
}

/* Weld `count` points (count x 3 doubles) into out: each point's vertex, numbered in order of
 * first appearance in `w`.  0, or -1 when memory ran out. */
static int weld_block(Welder *w, const double *points, int64_t count, index_t *out)
{
    uint64_t keys[AHEAD][3], hashes[AHEAD];
    int64_t index[AHEAD], k, head = 0, tail = 0;
    for (k = 0; k < count; k++) {
        uint64_t key[3] = {point_bits(points[3 * k]), point_bits(points[3 * k + 1]), point_bits(points[3 * k + 2])};
        uint64_t h = point_hash(key);
        int64_t known = recent_lookup(w, key, h);
        if (known >= 0) {                        /* welded before: its number is final */
            out[k] = known;
            continue;
        }
        if (known != -1) {                       /* waiting in the pipeline: a link to it */
            out[k] = LINK(-2 - known);
            continue;
        }
        __builtin_prefetch(&w->slots[h >> (64 - w->bits)]);
        memcpy(w->recent[h & w->recent_mask].key, key, sizeof key);
        w->recent[h & w->recent_mask].vertex = PENDING(k);
        if (head - tail == AHEAD) {
            if (weld_tail(w, out, keys[tail % AHEAD], hashes[tail % AHEAD], index[tail % AHEAD]) != 0)
                return -1;
            tail++;
        }
        memcpy(keys[head % AHEAD], key, sizeof key);
        hashes[head % AHEAD] = h;
        index[head % AHEAD] = k;
        head++;
    }
    for (; tail < head; tail++)
        if (weld_tail(w, out, keys[tail % AHEAD], hashes[tail % AHEAD], index[tail % AHEAD]) != 0)
            return -1;
    for (k = 0; k < count; k++)                  /* links point back, to numbers already final */
        if (out[k] < 0)
            out[k] = out[-1 - out[k]];
    return 0;
}

/* ---- welding on several threads -------------------------------------------------------------- */

/* Each thread welds a contiguous range of the points into its own table, numbering its vertices
 * in order of first appearance within the range; then, range after range, each range's vertices
 * are looked up in (or added to) the first range's table.  A vertex first seen in range t comes
 * after every vertex of the earlier ranges, so the numbers are those of one thread welding all
 * points in order, whatever the number of threads. */
#define WELD_BLOCK 4608                 /* points widened and welded at a time, a multiple of 3 (108 kB: from the
                                           allocator's heap, not new pages of mmap at every call; in cache) */

typedef struct {
    PointSource source;
    void *context;
    int64_t count;                      /* points */
    int64_t expected;                   /* distinct points expected (the tables' first size) */
    int ranges;
    Welder welders[MAX_RANGES];
    index_t *out;
    int failed[MAX_RANGES];
    Failure failures[MAX_RANGES];
    int prefault;                       /* the first range's table is ready, and a helper faults in its pages */
    int welded;                         /* set once the ranges are welded: the helper stops */
    char *blocks[3];                    /* what the helper faults in: the table, the faces, the vertices */
    size_t bytes[3];
} RangeWork;

static int64_t range_start(const RangeWork *work, int64_t t)
{
    return (work->count / 3 * t / work->ranges) * 3;          /* whole triangles */
}

static void weld_range(void *arg, int64_t t)
{
    RangeWork *work = arg;
    int64_t first = range_start(work, t), last = range_start(work, t + 1), k;
    double *block = malloc((size_t)(last - first < WELD_BLOCK ? last - first + 1 : WELD_BLOCK) * 3 * sizeof(double));
    /* the first range's table ends up holding every vertex: sized for all of them at once */
    if (!block || (!(t == 0 && work->prefault)
                   && welder_init(&work->welders[t], (t == 0 ? work->expected : work->expected / work->ranges) + 16) != 0)) {
        free(block);
        work->failed[t] = 1;
        fail(&work->failures[t], ERR_MEMORY, NULL, "out of memory");
        return;
    }
    for (k = first; k < last; k += WELD_BLOCK) {
        int64_t n = last - k < WELD_BLOCK ? last - k : WELD_BLOCK;
        if (work->source(work->context, k, n, block, &work->failures[t]) != 0) {
            work->failed[t] = 1;
            break;
        }
        if (weld_block(&work->welders[t], block, n, work->out + k) != 0) {
            work->failed[t] = 1;
            fail(&work->failures[t], ERR_MEMORY, NULL, "out of memory");
            break;
        }
    }
    free(block);
}

/* ---- new pages faulted in on the other core ------------------------------------------------- */

/* From this many bytes of faces, the weld's large arrays are new pages at every call (glibc maps
 * blocks above 32 MiB afresh and unmaps them when freed), and the kernel zeroing them took as
 * long as the weld itself on the 10M-face torus (issue 24): with a second thread, the helper
 * below faults them in while the weld runs. */
#define PREFAULT_FROM ((size_t)1 << 25)
#define PREFAULT_CHUNK ((size_t)1 << 23)   /* 8 MiB at a time, then a look at whether the weld is done */

static void populate_part(const RangeWork *work, int block, size_t from, size_t to)
{
    if (to > work->bytes[block])
        to = work->bytes[block];
    if (from < to)
        populate_pages(work->blocks[block] + from, to - from);
}

/* The table first (the weld touches it all over from the start), then the faces and the vertices
 * in step, as the weld writes them; no data is written, so the weld may be writing them meanwhile. */
static void prefault(RangeWork *work)
{
    size_t k;
    double share = (double)work->bytes[2] / (double)work->bytes[1];    /* vertices' bytes per face byte */
    for (k = 0; k < work->bytes[0] && !__atomic_load_n(&work->welded, __ATOMIC_ACQUIRE); k += PREFAULT_CHUNK)
        populate_part(work, 0, k, k + PREFAULT_CHUNK);
    for (k = 0; k < work->bytes[1] && !__atomic_load_n(&work->welded, __ATOMIC_ACQUIRE); k += PREFAULT_CHUNK) {
        populate_part(work, 1, k, k + PREFAULT_CHUNK);
        populate_part(work, 2, (size_t)(share * (double)k), (size_t)(share * (double)(k + PREFAULT_CHUNK)));
    }
}

/* Blocks 0 .. ranges - 1 weld their ranges; block `ranges`, when there is one, is the helper. */
static void weld_or_prefault(void *arg, int64_t t)
{
    RangeWork *work = arg;
    if (t == work->ranges) {
        prefault(work);
        return;
    }
    weld_range(work, t);
    __atomic_store_n(&work->welded, 1, __ATOMIC_RELEASE);     /* one range when there is a helper */
}

/* weld_source, the tables first sized for `expected` distinct points. */
static int weld_stream(PointSource source, void *context, int64_t count, int64_t expected, int threads,
                       MeshArrays *out, Failure *failure)
{
    RangeWork work;
    int t;
    int64_t k;
    out->m = count / 3;
    out->faces = malloc((size_t)(count > 0 ? count : 3) * sizeof(index_t));
    if (!out->faces) {
        fail(failure, ERR_MEMORY, NULL, "out of memory for %lld triangles", (long long)(count / 3));
        return -1;
    }
    advise_huge(out->faces, (size_t)count * sizeof(index_t));
    memset(&work, 0, sizeof work);
    work.source = source;
    work.context = context;
    work.count = count;
    work.expected = expected;
    /* Not on two threads: on this 2-core machine, two ranges and their merge took 25-35% longer than
     * one thread (the merge, the second table's fresh pages, the caches shared with the other core's
     * jobs), and a reader thread feeding one welder took 20-25% longer as well (issue 24). */
    work.ranges = count < 300000 || threads < 3 ? 1 : threads > MAX_RANGES ? MAX_RANGES : threads;
    work.out = out->faces;
    if (work.ranges == 1 && threads >= 2 && (size_t)count * sizeof(index_t) >= PREFAULT_FROM) {
        Welder *w = &work.welders[0];
        if (welder_init(w, expected + 16) != 0) {
            free(out->faces);
            out->faces = NULL;
            fail(failure, ERR_MEMORY, NULL, "out of memory");
            return -1;
        }
        work.prefault = 1;
        work.blocks[0] = (char *)w->slots;
        work.bytes[0] = (size_t)(w->mask + 1) * sizeof *w->slots;
        work.blocks[1] = (char *)out->faces;
        work.bytes[1] = (size_t)count * sizeof(index_t);
        /* a closed mesh has about a vertex in 6 corners: no more is faulted in than that */
        work.blocks[2] = w->vertices.data;
        work.bytes[2] = (size_t)(count / 6 + 16) * 3 * sizeof(double);
        if (work.bytes[2] > w->vertices.capacity)
            work.bytes[2] = w->vertices.capacity;
    }
    parallel_blocks(work.ranges + work.prefault, work.ranges + work.prefault, weld_or_prefault, &work);
    for (t = 0; t < work.ranges; t++)
        if (work.failed[t] && failure->kind == ERR_NONE)
            *failure = work.failures[t];
    for (t = 1; t < work.ranges; t++) {          /* only the later ranges' vertices are merged: their tables go first */
        free(work.welders[t].slots);
        work.welders[t].slots = NULL;
    }
    for (t = 1; t < work.ranges && failure->kind == ERR_NONE; t++) {
        Welder *w = &work.welders[t];
        index_t *number = malloc((size_t)(w->count > 0 ? w->count : 1) * sizeof *number);
        if (!number || weld_block(&work.welders[0], (const double *)w->vertices.data, w->count, number) != 0) {
            free(number);
            fail(failure, ERR_MEMORY, NULL, "out of memory");
            break;
        }
        for (k = range_start(&work, t); k < range_start(&work, t + 1); k++)
            work.out[k] = number[work.out[k]];
        free(number);
        welder_free(w);
    }
    for (t = 1; t < work.ranges; t++)
        welder_free(&work.welders[t]);
    if (failure->kind != ERR_NONE) {
        if (work.welders[0].slots)
            welder_free(&work.welders[0]);
        free(out->faces);
        out->faces = NULL;
        return -1;
    }
    out->n = work.welders[0].count;
    out->vertices = (double *)work.welders[0].vertices.data;
    work.welders[0].vertices.data = NULL;
    welder_free(&work.welders[0]);
    if (!out->vertices && !(out->vertices = malloc(3 * sizeof(double)))) {
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    return 0;
}

int weld_source(PointSource source, void *context, int64_t count, int threads, MeshArrays *out, Failure *failure)
{
    return weld_stream(source, context, count, count / 5, threads, out, failure);     /* a vertex in ~6 corners */
}

/* ---- whole arrays -------------------------------------------------------------------- */

typedef struct {
    const void *corners;
    int single;
} CornerArray;

/* Points [first, first + count) of an array of float32 or float64 corners, as doubles (exact). */
static int corner_source(void *context, int64_t first, int64_t count, double *points, Failure *failure)
{
    const CornerArray *array = context;
    int64_t j;
    (void)failure;
    if (array->single)
        for (j = 0; j < 3 * count; j++)
            points[j] = ((const float *)array->corners)[3 * first + j];
    else
        memcpy(points, (const double *)array->corners + 3 * first, (size_t)count * 3 * sizeof(double));
    return 0;
}

int weld_corners(const void *corners, int single, int64_t m, int threads, MeshArrays *out, Failure *failure)
{
    CornerArray array = {corners, single};
    return weld_source(corner_source, &array, 3 * m, threads, out, failure);
}

typedef struct {
    const double *vertices;
    const int64_t *order;               /* input vertex of each point, in order of first use */
    int64_t count;                      /* points in order (the source pads to whole triangles) */
} FirstUses;

/* Points [first, first + count) of the vertices in order of first use; past the end, the last. */
static int first_use_source(void *context, int64_t first, int64_t count, double *points, Failure *failure)
{
    const FirstUses *uses = context;
    int64_t j;
    (void)failure;
    for (j = 0; j < count; j++) {
        int64_t k = first + j < uses->count ? first + j : uses->count - 1;
        memcpy(points + 3 * j, uses->vertices + 3 * uses->order[k], 3 * sizeof(double));
    }
    return 0;
}

/* Corner k's vertex index, or -1 (and the failure) when it names no vertex. */
static int64_t corner_index(const void *faces, int faces32, int64_t k, int64_t n, Failure *failure)
{
    int64_t given = faces32 ? ((const int32_t *)faces)[k] : ((const int64_t *)faces)[k];
    if (given >= 0 && given < n)
        return given;
    fail(failure, ERR_INDEX, "re-export the mesh", "face %lld refers to vertex %lld, but there are %lld vertices",
         (long long)(k / 3), (long long)given, (long long)n);
    return -1;
}

/* Vertices no face uses (used[k] < 0) that are not finite: they are left out, and counted. */
static int64_t unused_nonfinite(const double *vertices, const int64_t *used, int64_t n)
{
    int64_t k, count = 0;
    for (k = 0; k < n; k++)
        count += used[k] < 0 && !(isfinite(vertices[3 * k]) && isfinite(vertices[3 * k + 1])
                                  && isfinite(vertices[3 * k + 2]));
    return count;
}

/* A point welded through the table alone (a welder started without the cache of recent points). */
static int64_t weld_point_uncached(Welder *w, const double point[3])
{
    uint64_t key[3] = {point_bits(point[0]), point_bits(point[1]), point_bits(point[2])};
    return insert(w, key, point_hash(key));
}

/* Every corner welded in order, one point at a time (a vertex used again takes its number): for
 * small meshes, whose table stays in cache.  Each vertex is welded once (then `renumber` holds its
 * number), so the cache of recent points would hold only misses: it is left out. */
static int weld_direct(const double *vertices, int64_t n, const void *faces, int faces32, int64_t m,
                       MeshArrays *out, Failure *failure)
{
    Welder w;
    int64_t k, *renumber = malloc((size_t)(n > 0 ? n : 1) * sizeof(int64_t));
    out->m = m;
    out->faces = malloc((size_t)(m > 0 ? m : 1) * 3 * sizeof(index_t));
    if (!renumber || !out->faces || welder_start(&w, n, 0) != 0) {
        free(renumber);
        free(out->faces);
        out->faces = NULL;
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    for (k = 0; k < n; k++)
        renumber[k] = -1;
    for (k = 0; k < 3 * m; k++) {
        int64_t given = corner_index(faces, faces32, k, n, failure);
        if (given < 0)
            break;
        if (renumber[given] < 0 && (renumber[given] = weld_point_uncached(&w, vertices + 3 * given)) < 0) {
            fail(failure, ERR_MEMORY, NULL, "out of memory");
            break;
        }
        out->faces[k] = renumber[given];
    }
    out->ignored = failure->kind == ERR_NONE ? unused_nonfinite(vertices, renumber, n) : 0;
    free(renumber);
    if (failure->kind != ERR_NONE) {
        welder_free(&w);
        free(out->faces);
        out->faces = NULL;
        return -1;
    }
    out->n = w.count;
    out->vertices = (double *)w.vertices.data;
    w.vertices.data = NULL;
    welder_free(&w);
    if (!out->vertices && !(out->vertices = malloc(3 * sizeof(double)))) {
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    return 0;
}

#define STREAM_MIN 65536                /* vertices from which weld_indexed welds them as a stream */

/* From STREAM_MIN vertices, the vertices the faces use, in order of first use, are welded as a
 * stream of points (the pipelined, multi-threaded weld of weld_source); a vertex used again takes
 * the number its first use got.  Either way the numbers are those of welding every corner in
 * order, one at a time. */
int weld_indexed(const double *vertices, int64_t n, const void *faces, int faces32, int64_t m, int threads,
                 MeshArrays *out, Failure *failure)
{
    MeshArrays welded = {0};
    FirstUses uses;
    int64_t k, count = 0, *rank, *order;
    if (n < STREAM_MIN)
        return weld_direct(vertices, n, faces, faces32, m, out, failure);
    rank = malloc((size_t)n * sizeof(int64_t));
    order = malloc((size_t)n * sizeof(int64_t));
    out->m = m;
    out->faces = malloc((size_t)(m > 0 ? m : 1) * 3 * sizeof(index_t));
    if (!rank || !order || !out->faces) {
        free(rank);
        free(order);
        free(out->faces);
        out->faces = NULL;
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    advise_huge(out->faces, (size_t)m * 3 * sizeof(index_t));
    for (k = 0; k < n; k++)
        rank[k] = -1;
    for (k = 0; k < 3 * m; k++) {
        int64_t given = corner_index(faces, faces32, k, n, failure);
        if (given < 0)
            break;
        if (rank[given] < 0) {
            rank[given] = count;
            order[count++] = given;
        }
        out->faces[k] = rank[given];
    }
    out->ignored = failure->kind == ERR_NONE ? unused_nonfinite(vertices, rank, n) : 0;
    free(rank);
    if (failure->kind == ERR_NONE) {
        uses.vertices = vertices;
        uses.order = order;
        uses.count = count;
        weld_stream(first_use_source, &uses, (count + 2) / 3 * 3, count, threads, &welded, failure);
    }
    free(order);
    if (failure->kind != ERR_NONE) {
        free(out->faces);
        out->faces = NULL;
        return -1;
    }
    for (k = 0; k < 3 * m; k++)                  /* rank of first use -> welded vertex */
        out->faces[k] = welded.faces[out->faces[k]];
    free(welded.faces);
    out->vertices = welded.vertices;
    out->n = welded.n;
    return 0;
}
