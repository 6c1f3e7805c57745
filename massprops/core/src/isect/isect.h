/* Shared declarations of massprops.core._intersect: exact triangle-intersection search.
 *
 * The caller passes coordinates scaled to about unit size whose non-zero
 * magnitudes are at least 2**-200, so no product of coordinate differences
 * under- or overflows and the predicates (predicates.h) are exact.  Every
 * "these faces do not meet" comes from one of four places, each proved in
 * its file:
 *
 *   stars.c   certificates that a vertex's star, or a whole shell, is
 *             embedded (its faces meet only along what they share);
 *   patches.c certificates that the faces of a cell of a coarse grid are one
 *             disk that projects one-to-one along an axis (then embedded);
 *   search.c  a float plane-separation filter with a certified bound, then
 *             the exact closed-set tests of predicates.h;
 *   grid.c    the broad phase: faces whose boxes are disjoint never meet.
 *
 * Nothing here touches Python objects except module.c; the rest runs
 * without the GIL, on up to `threads` threads (parallel_workers, ../parallel.c).
 */
#ifndef MASSPROPS_ISECT_H
#define MASSPROPS_ISECT_H

#include <stddef.h>
#include <stdint.h>

#include "../core.h"
#include "predicates.h"

/* Face t's shell label; shell is NULL when every face is of shell 0 (no labels were given). */
static inline int64_t shell_at(const int64_t *shell, int64_t t) { return shell ? shell[t] : 0; }

/* malloc (calloc when `zeroed`) of a large array, advised into transparent huge pages where the
 * kernel offers them on request: one page fault per 2 MiB instead of 512 (grid.c). */
void *isect_alloc(size_t bytes, int zeroed);

/* ---- stars.c: which faces are known to meet only along what they share ---------------- */

enum { STAR_CYCLE = 1, STAR_EMBEDDED = 2, STAR_TRIED = 4 };

typedef struct {
    const double *V;
    const int64_t *F;
    int64_t n, m;             /* vertices, faces */
    uint32_t *begin;          /* n + 1: incidences of vertex v are ring[begin[v] .. begin[v + 1]) (3m < 2**32) */
    uint32_t *ring;           /* face << 2 | corner; around a manifold vertex in cyclic order */
    uint64_t *xy;             /* until the cycles are found, on small meshes: per incidence as filed, its
                               * face's next corner | previous corner << 32 (NULL: read from F) */
    uint8_t *flag;            /* per vertex: STAR_CYCLE, STAR_EMBEDDED */
    uint8_t *shell_embedded;  /* per shell: the whole shell is certified embedded */
    int64_t certified_vertices, certified_shells;
    int64_t max_degree;
    int one_shell;            /* every face is of shell 0 (labels are below n_shells, checked by the caller) */
    int by_degree;            /* the one shell certified by its degree (stars.c): no incidences (begin, ring,
                               * flag NULL), and every vertex a face uses has its faces in one cycle */
} Stars;

/* The vertex after (next_corner) and before (previous_corner) corner c of face t, in its winding;
 * for a ring entry r, face r >> 2 and corner r & 3. */
static inline int64_t next_corner(const int64_t *F, int64_t t, int c)
{
    return F[3 * t + (c == 2 ? 0 : c + 1)];
}

static inline int64_t previous_corner(const int64_t *F, int64_t t, int c)
{
    return F[3 * t + (c == 0 ? 2 : c - 1)];
}

/* Certificates for the shells flagged in `wanted` (per shell) and their vertices; 0, or -1 when
 * memory ran out (then nothing is certified: every pair is tested).  Faces need
 * 0 <= F < n and m < 2**30. */
int stars_build(Stars *s, const double *V, const int64_t *F, int64_t n, int64_t m, const int64_t *shell,
                int64_t n_shells, const uint8_t *wanted, int threads);
/* The same; with `lazy`, the shells' certificates and the cycles only: no vertex's star is
 * certified until stars_certify_corners asks for it.  With `closed` (lazy, one shell: the caller
 * guarantees that every edge of the faces is used as often in each direction), the shell may be
 * certified by its degree, and then nothing else is built (by_degree): only for a caller that
 * needs no stars once the shell is certified. */
int stars_build_lazy(Stars *s, const double *V, const int64_t *F, int64_t n, int64_t m, const int64_t *shell,
                     int64_t n_shells, const uint8_t *wanted, int threads, int lazy, int closed);
/* Star certificates (as stars_build gives them) for the corners of the faces with take[t] set;
 * 0, or -1 when memory ran out (then fewer are certified).  Does not depend on the thread count. */
int stars_certify_corners(Stars *s, const int64_t *shell, const uint8_t *take, int threads);
void stars_free(Stars *s);

static inline int64_t star_degree(const Stars *s, int64_t v) { return (int64_t)s->begin[v + 1] - s->begin[v]; }

/* ---- grid.c: faces in space order and a hierarchical grid of their boxes --------------- */

#define MAX_LEVEL 40
#define INDEX_BITS 19
#define LEVEL_SHIFT (3 * INDEX_BITS)

typedef struct {
    const double *V;
    int64_t n;                /* faces taken (active, of non-zero area, and needed) */
    uint32_t *id;             /* original face index (NULL: the same, every face is taken in order) */
    const int64_t *corner;    /* 3 per face (the input's when id is NULL) */
    const int64_t *shell;
    const int8_t *axis;
    int64_t *own_corner, *own_shell;     /* what corner and shell point to when copied */
    int8_t *own_axis;
    double *lo, *hi;          /* 3 per face: the face's box (NULL in a coarse grid: high_cell instead) */
    int32_t *low_cell;        /* 3 per face: level-0 cell of lo */
    int32_t *high_cell;       /* 3 per face: level-0 cell of hi (a coarse grid only, else NULL) */
    int8_t *level;
    uint8_t *certified;       /* bit k: the star of corner k is certified embedded */
    uint32_t *group_begin, *group_end;   /* faces sharing a hub vertex: consecutive, [begin, end)
                                          * (NULL: no hubs, every face its own group) */
    /* grid: cells of level l have side base * 2**l; a cell's coordinates are level-0 cells >> l */
    double origin[3], inverse;            /* 1 / base */
    int used[MAX_LEVEL + 1], n_used;
    int64_t level_begin[MAX_LEVEL + 2];   /* entries of each level: [begin[l], begin[l + 1]) */
    int64_t n_entries;
    uint64_t *key;            /* per entry, sorted: level << LEVEL_SHIFT | Morton code of the cell */
    uint32_t *face;           /* per entry: index into the sorted faces, ascending within a key */
} Grid;

/* The grid of the faces with take[t] set (and non-zero area); 0, or -1 when memory ran out.
 * `stars` (or NULL) gives the certified corners and the hubs that group faces.  The grid does not
 * depend on the thread count. */
int grid_build(Grid *g, const double *V, const int64_t *F, const int64_t *shell, const uint8_t *take, int64_t m,
               const Stars *stars, int threads);
/* The same with every face at `force_level` (>= 0; cells of side base * 2**force_level), or at
 * its own level (-1); 1 (nothing built) when there would be more than max_entries_per_face
 * entries a face (0: no limit). */
int grid_build_at(Grid *g, const double *V, const int64_t *F, const int64_t *shell, const uint8_t *take, int64_t m,
                  const Stars *stars, int threads, int force_level, int64_t max_entries_per_face);
void grid_free(Grid *g);

static inline int64_t grid_id(const Grid *g, int64_t t) { return g->id ? g->id[t] : t; }
static inline uint32_t grid_group_begin(const Grid *g, int64_t t)
{
    return g->group_begin ? g->group_begin[t] : (uint32_t)t;
}
static inline uint32_t grid_group_end(const Grid *g, int64_t t)
{
    return g->group_end ? g->group_end[t] : (uint32_t)t + 1;
}

/* x is never below the origin, so truncation is the floor. */
static inline int64_t grid_cell0(const Grid *g, int axis, double x)
{
    return (int64_t)((x - g->origin[axis]) * g->inverse);
}

/* The cells of `level` that face t's box covers: c0[k] .. c1[k] on each axis. */
static inline void grid_face_cells(const Grid *g, int64_t t, int level, int64_t *c0, int64_t *c1)
{
    for (int k = 0; k < 3; k++) {
        c0[k] = (int64_t)g->low_cell[3 * t + k] >> level;
        c1[k] = (g->high_cell ? (int64_t)g->high_cell[3 * t + k] : grid_cell0(g, k, g->hi[3 * t + k])) >> level;
    }
}

/* The side of the finest cells (grid.c): from the extents of GRID_SAMPLES faces (or all, when
 * fewer), sample s being face grid_sample(s, n, samples) in the order of the n faces. */
#define GRID_SAMPLES 4096
static inline int64_t grid_sample(int s, int64_t n, int samples) { return (int64_t)((double)s * n / samples); }
double grid_base(double *extent, int samples, double whole, int one_level);

uint64_t grid_key(int level, int64_t i, int64_t j, int64_t k);
void grid_key_cell(uint64_t key, int64_t *cell);
/* First entry with this key (within its level's range), or -1. */
int64_t grid_find(const Grid *g, int level, uint64_t key);

/* Sort (key, value) pairs by key, stably; tk, tv: scratch of n entries.  0, or -1 out of memory. */
int radix_sort(uint64_t *key, uint32_t *value, uint64_t *tk, uint32_t *tv, int64_t n);

/* ---- patches.c: cells of a coarse grid certified embedded --------------------------------- */

/* Set bad[t] (original face index) for each face taken that lies in some coarse cell whose
 * faces could not be certified embedded (they must be searched); faces of certified cells are
 * left 0.  0; 1 when nothing was done (too many entries: every face must be searched); -1 out
 * of memory (then too, every face must be searched). */
int patches_mark(const double *V, const int64_t *F, const int64_t *shell, const uint8_t *take, int64_t m,
                 const Stars *stars, int threads, uint8_t *bad);

/* ---- search.c: the pair search ------------------------------------------------------- */

typedef struct {
    uint8_t *self_found;      /* per shell */
    int64_t *examples;        /* 2 per example: original face indices, in search order */
    int64_t n_examples;
    int64_t *found;           /* 4 per meeting shell pair: shells, then original faces */
    int64_t n_found;
    int64_t candidates, tests;
} Found;

/* Pairs of faces that meet: within a shell (other than along what they share) when `within`,
 * between shells when `between`.  `closed`: every edge of the faces is used as often in each
 * direction (the caller checked it; a one-shell search may then certify the shell by its degree).  shell NULL: every face is of shell 0 (n_shells 1); active
 * NULL: every face is active.  0, or -1 when memory ran out.  The result does not depend on the
 * thread count. */
int search_pairs(const double *V, const int64_t *F, const int64_t *shell, const uint8_t *active, int64_t n,
                 int64_t m, int64_t n_shells, int within, int between, int64_t max_examples, int closed, int threads,
                 Found *out, Stars *stars);
void found_free(Found *f);

/* ---- winding.c ---------------------------------------------------------------------- */

enum { RAY_OK = 0, RAY_DEGENERATE = 1, RAY_ON_SURFACE = 2, RAY_MEMORY = 3 };

/* Winding numbers of the closed surface (V, F) about points[0..k); RAY_OK, or the status of
 * point *bad. */
int winding_numbers(const double *V, const int64_t *F, int64_t m, const double *points, int64_t k, int64_t *out,
                    int64_t *bad);

/* ---- arrange.c: the arrangement's cut stage --------------------------------------------- */

/* Cells of the faces cut by their pairs' segments (see arrange.c). */
typedef struct {
    char *data;
    size_t size, capacity;
} Buf;

typedef struct {
    Buf face, count, corners, inner, points, errors, defs;   /* int64, int64, int64, 12 double, 3, 3, 7 int64 */
    int64_t n_cells, n_points;
} Arranged;

/* kind (per pair): 0 the faces do not cut each other, 1 a segment, 2 coplanar, -1 unsure (both faces
 * are handed back); status (per face): 0 not cut, 1 cut here, 2 handed back; drop (per face cut
 * here): the axis its projection drops.  0, or -1 when memory ran out. */
int arrange_cut(const double *V, const int64_t *F, int64_t n, int64_t m, const int64_t *pairs, int64_t p, int threads,
                int8_t *kind, int8_t *status, int8_t *drop, Arranged *result);
void arranged_free(Arranged *a);

/* Each point (defined by defs, 7 int64 as arrange_cut gives them) rounded again from its exact value,
 * where that gives a smaller certified error: q, err (3 each) updated in place. */
void refine_points(const double *V, const int64_t *F, const int64_t *defs, int64_t k, double *q, double *err,
                   int threads);

/* Per face, a label shared by the uncut faces joined across edges that exactly two faces use, once
 * each way (faces are below 2**32; their vertices below n, below 2**31).  0, or -1 when memory ran out. */
int patch_labels(const int64_t *F, int64_t m, int64_t n, const uint8_t *cut, int64_t *label);

/* The kept pieces put together (assemble.c).  fan_cells: cells[i] (its corners corners[starts[c] ..
 * starts[c + 1]]) fanned into fan_count(...) triangles, from its first corner, or from its last one
 * turned where not outward[i].  patch_faces: the faces whose patch has side > 0 in order, then those
 * with side < 0 reversed; their count.  used_corners: the new corners (n + j, j < q) the triangles T use,
 * ascending; their count, or -1.  distinct_corners: the rows table[i] (6 doubles: point, rounding) of
 * corners used[i], distinct in numpy's lexicographic order into rows; T's new corners renumbered to
 * n + their row; the rows' count, or -1. */
int64_t fan_count(const int64_t *starts, const int64_t *cells, int64_t k);
void fan_cells(const int64_t *starts, const int64_t *corners, const int64_t *cells, const uint8_t *outward,
               int64_t k, int64_t *out);
int64_t patch_faces(const int64_t *F, int64_t m, const int64_t *patch, const int8_t *side, int64_t *out);
int64_t used_corners(const int64_t *T, int64_t k, int64_t n, int64_t q, int64_t *used);
int64_t distinct_corners(const double *table, int64_t u, const int64_t *used, int64_t q, int64_t n, int64_t *T,
                         int64_t k, double *rows);
/* kept_corners: the new corners the triangles T use: the compiled cut's (P, R, defined by defs; q < qc),
 * rounded again from their exact values where the filter's bound exceeds a unit in the last place
 * (refine_points), then the exact path's (EP, ER); made distinct into rows and renumbered in T as
 * distinct_corners does.  The rows' count, or -1 when memory ran out. */
int64_t kept_corners(const double *V, const int64_t *F, int64_t n, int64_t *T, int64_t k, const double *P,
                     const double *R, const int64_t *defs, int64_t qc, const double *EP, const double *ER, int64_t qe,
                     int threads, double *rows);

/* The arrangement's new corners Q (q, 3, scaled) in mesh units (reference + Q * power, into points after
 * the n vertices V), each one's move (its rounding R * power plus the addition's exact error), and the
 * terms of the volume those moves may sweep across the pieces F (k, 3): one per face around a moved
 * corner, one per directed edge of those faces that its reverse does not cancel (swept.c).  0, or -1
 * when memory ran out; the terms are malloc'd. */
int swept_pieces(const double *V, int64_t n, const double *Q, const double *R, int64_t q, double power,
                 const double *ref, const int64_t *F, int64_t k, double *points, double *largest,
                 double **face_terms, int64_t *n_faces, double **wall_terms, int64_t *n_walls);

/* Winding numbers (front[q]) at points of faces qface[q] over qxy[q] (the axes after the face's dropped
 * one; NaN: the face's centroid), off the surface by Simulation of Simplicity as the exact path does;
 * the net weight of the faces on the point (its face and those of plist[pbegin[q] .. pbegin[q + 1]),
 * faces in its plane, that hold it strictly inside) and whether all of those come after its face
 * (owned); status[q]: 0 answered, 1 handed back (a sign the filter could not settle), 2 no certified
 * point.  0, or -1 when memory ran out. */
int label_queries(const double *V, const int64_t *F, const int64_t *weight, int64_t m, const int64_t *qface,
                  const double *qxy, const int64_t *pbegin, const int64_t *plist, int64_t k, int threads,
                  int64_t *front, int64_t *net, int8_t *owned, int8_t *status);

/* RUN_MERGE_SORT(NAME, T, KEY) defines `static T *NAME(T *x, T *tmp, int64_t k)`: x[0..k) sorted
 * by the double field KEY, stably: insertion sort on runs of 16, then bottom-up merges between x
 * and tmp (k elements); it returns whichever holds the result.  (glibc's qsort, with a call per
 * comparison, was a tenth of the search on small meshes.) */
#define RUN_MERGE_SORT(NAME, T, KEY)                                                                  \
    static T *NAME(T *x, T *tmp, int64_t k)                                                          \
    {                                                                                                 \
        const int64_t run = 16;                                                                       \
        for (int64_t start = 0; start < k; start += run) {                                            \
            int64_t stop = start + run < k ? start + run : k;                                         \
            for (int64_t i = start + 1; i < stop; i++) {                                              \
                T item = x[i];                                                                        \
                int64_t j = i;                                                                        \
                while (j > start && x[j - 1].KEY > item.KEY) {                                        \
                    x[j] = x[j - 1];                                                                  \
                    j--;                                                                              \
                }                                                                                     \
                x[j] = item;                                                                          \
            }                                                                                         \
        }                                                                                             \
        T *src = x, *dst = tmp;                                                                       \
        for (int64_t width = run; width < k; width *= 2) {                                            \
            for (int64_t start = 0; start < k; start += 2 * width) {                                  \
                int64_t mid = start + width < k ? start + width : k;                                  \
                int64_t stop = start + 2 * width < k ? start + 2 * width : k;                         \
                int64_t i = start, j = mid, o = start;                                                \
                while (i < mid && j < stop)                                                           \
                    dst[o++] = src[j].KEY < src[i].KEY ? src[j++] : src[i++];                         \
                while (i < mid)                                                                       \
                    dst[o++] = src[i++];                                                              \
                while (j < stop)                                                                      \
                    dst[o++] = src[j++];                                                              \
            }                                                                                         \
            T *swap = src;                                                                            \
            src = dst;                                                                                \
            dst = swap;                                                                               \
        }                                                                                             \
        return src;                                                                                   \
    }

#endif
