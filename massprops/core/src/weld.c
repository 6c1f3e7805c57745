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

static inline uint64_t point_hash(const uint64_t key[3])
{
    return mix64(key[0] + mix64(key[1] + mix64(key[2] ^ 0x9E3779B97F4A7C15ULL)));
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
    memset(w, 0, sizeof *w);
    while (bits < 40 && ((int64_t)1 << bits) < 2 * expected)
        bits++;
    if (grow_reserve(&w->vertices, (size_t)(expected > 0 ? expected : 16) * 3 * sizeof(double)) != 0)
        return -1;
    return resize(w, bits);
}

void welder_free(Welder *w)
{
    free(w->slots);
    w->slots = NULL;
    grow_free(&w->vertices);
}

int64_t weld_point64(Welder *w, const double point[3])
{
    uint64_t key[3] = {point_bits(point[0]), point_bits(point[1]), point_bits(point[2])};
    uint64_t h = point_hash(key), slot = h >> (64 - w->bits), tag = h << 32;
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

int64_t weld_point32(Welder *w, const float point[3])
{
    double wide[3] = {point[0], point[1], point[2]};      /* exact */
    return weld_point64(w, wide);
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

int weld_corners(const void *corners, int single, int64_t m, MeshArrays *out, Failure *failure)
{
    Welder w;
    int64_t k;
    out->m = m;
    out->faces = malloc((size_t)(m > 0 ? m : 1) * 3 * sizeof(index_t));
    if (!out->faces || welder_init(&w, m / 2 + 16) != 0) {
        free(out->faces);
        out->faces = NULL;
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    for (k = 0; k < 3 * m; k++) {
        int64_t vertex = single ? weld_point32(&w, (const float *)corners + 3 * k)
                                : weld_point64(&w, (const double *)corners + 3 * k);
        if (vertex < 0) {
            welder_free(&w);
            free(out->faces);
            out->faces = NULL;
            fail(failure, ERR_MEMORY, NULL, "out of memory");
            return -1;
        }
        out->faces[k] = vertex;
    }
    return finish(&w, out, failure);
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
