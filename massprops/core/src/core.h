/* Shared declarations of the compiled core (massprops.core._core).
 *
 * Every heavy function runs without the GIL on plain C arrays; Python objects
 * are touched only in module.c, which unpacks arguments (buffer protocol) and
 * wraps results in Buffer objects (PEP 3118, so numpy views them without a
 * copy).  Floating point follows IEEE 754 double rounding to nearest with no
 * contraction (built with -ffp-contract=off, never -ffast-math): the error
 * bounds and the error-free transformations in expansion.h depend on it.
 */
#ifndef MASSPROPS_CORE_H
#define MASSPROPS_CORE_H

#include <stddef.h>
#include <stdint.h>

typedef int64_t index_t;

/* An error raised from GIL-free code: a message and a fix, both static or in the buffers. */
typedef struct {
    int kind;                 /* ERR_NONE, ERR_PARSE, ERR_OS, ERR_MEMORY, ERR_INDEX, ERR_VALUE */
    int os_errno;
    char message[400];
    char fix[160];
} Failure;

enum { ERR_NONE = 0, ERR_PARSE, ERR_OS, ERR_MEMORY, ERR_INDEX, ERR_VALUE };

void fail(Failure *failure, int kind, const char *fix, const char *format, ...)
    __attribute__((format(printf, 4, 5)));

/* Growable arrays (realloc doubling; large blocks grow by mremap in glibc, without copying). */
typedef struct {
    char *data;
    size_t size;       /* bytes used */
    size_t capacity;   /* bytes allocated */
} Growable;

void advise_huge(void *data, size_t bytes);      /* huge pages for a large array, where offered */
void populate_pages(void *data, size_t bytes);    /* its pages faulted in now (for a helper thread) */
int grow_reserve(Growable *g, size_t bytes);   /* 0, or -1 when memory ran out */
void release_free_memory(int64_t bytes_worked); /* after a job on this many bytes: free memory back to the system */
/* grow_reserve with its common case (room enough) inline */
static inline int reserve(Growable *g, size_t bytes) { return g->size + bytes <= g->capacity ? 0 : grow_reserve(g, bytes); }
void grow_free(Growable *g);

#define MAX_THREADS 64
/* A thread count asked for, within 1 .. MAX_THREADS (what the loops below run at most). */
static inline int thread_limit(int threads) { return threads < 1 ? 1 : threads > MAX_THREADS ? MAX_THREADS : threads; }

/* Parallel loop over numbered blocks: fn(ctx, block) for block in [0, blocks), on up to
 * `threads` threads (the caller's thread is one of them).  Blocks are handed out in order
 * from a shared counter; results must be stored per block so they do not depend on which
 * thread ran which block. */
typedef void (*block_fn)(void *ctx, int64_t block);
void parallel_blocks(int threads, int64_t blocks, block_fn fn, void *ctx);
/* The same loop, fn told which worker (0 .. threads - 1) runs the block: for per-worker scratch. */
typedef void (*worker_fn)(void *ctx, int worker, int64_t block);
void parallel_workers(int threads, int64_t blocks, worker_fn fn, void *ctx);

/* ---- welding (weld.c) ---------------------------------------------------------------- */

/* A table of distinct points by exact coordinates: float32 points are kept as their
 * exactly widened float64 values; -0.0 is stored as +0.0 (they are equal), NaNs by bits. */
#define RECENT 16384

typedef struct {
    uint64_t *slots;          /* (tag << 32) | (vertex + 1); 0 = empty */
    uint64_t mask;
    int bits;
    Growable vertices;        /* double[3] per distinct point, in order of first appearance */
    int64_t count;
    /* A small direct-mapped cache of recently welded points: meshes reuse a vertex a few faces
     * after its first use, so most lookups end here, in cache, not in the large table. */
    struct { uint64_t key[3]; int64_t vertex; } *recent;
    uint64_t recent_mask;
} Welder;

int welder_init(Welder *w, int64_t expected);
void welder_free(Welder *w);
/* The vertex number of a point (a new one if not seen before), or -1 when memory ran out. */
int64_t weld_point64(Welder *w, const double point[3]);
int64_t weld_point32(Welder *w, const float point[3]);

typedef struct MeshArrays MeshArrays;

/* Welding on several threads (weld.c): a PointSource fills `points` (count x 3 doubles) with
 * points [first, first + count) of the input; 0, or -1 with a failure.  weld_source welds
 * `count` points (whole triangles) into out->faces, out->m and out->vertices, out->n: the same
 * numbering whatever the thread count. */
#define MAX_RANGES 8
typedef int (*PointSource)(void *context, int64_t first, int64_t count, double *points, Failure *failure);
int weld_source(PointSource source, void *context, int64_t count, int threads, MeshArrays *out, Failure *failure);
/* Weld m triangles given by their corners (3m points, float32 if `single`, else float64). */
int weld_corners(const void *corners, int single, int64_t m, int threads, MeshArrays *out, Failure *failure);
/* Weld the vertices that faces use (int32 or int64 indices, checked), numbered by first use. */
int weld_indexed(const double *vertices, int64_t n, const void *faces, int faces32, int64_t m, int threads,
                 MeshArrays *out, Failure *failure);

/* ---- parsing (numbers.c, stl.c, obj.c) ------------------------------------------------- */

void numbers_init(void);
/* Parse one token [start, end) exactly as Python's float() would accept it (no underscores);
 * returns 0 and the correctly rounded value, or -1 if it is not a number. */
int parse_double(const char *start, const char *end, double *value);
/* The decimal number (sign, digits with an optional point, an optional exponent) that starts at
 * `start`: 0, its value as parse_double gives it, and where it stops in *stop (the caller checks
 * what follows); -1 when no such number starts there (inf and nan are parse_double's). */
int parse_decimal(const char *start, const char *end, const char **stop, double *value);

/* The value of eight decimal digits held one a byte (0..9, the first digit in the lowest byte), as
 * the digit loop forms it (Lemire's fast_float: three multiplications instead of eight). */
static inline uint64_t eight_digits_value(uint64_t digits)
{
    digits = digits * 10 + (digits >> 8);
    return ((digits & 0x000000FF000000FFULL) * (100 + (1000000ULL << 32))
            + ((digits >> 16) & 0x000000FF000000FFULL) * (1 + (10000ULL << 32))) >> 32;
}

struct MeshArrays {
    double *vertices;         /* n x 3, owned by the caller after success */
    int64_t n;
    index_t *faces;           /* m x 3 */
    int64_t m;
    int binary;               /* STL: 1 binary (float32 coordinates), 0 ASCII */
    int64_t ignored;          /* weld_indexed: vertices no face uses whose coordinates are not finite */
};

int read_stl(const char *path, int threads, MeshArrays *out, Failure *failure);
int read_obj(const char *path, int threads, MeshArrays *out, Failure *failure);

/* Open a regular file for reading without blocking on FIFOs; -1 and a failure otherwise. */
int open_regular(const char *path, int64_t *size, Failure *failure);
/* Read exactly `bytes` at `offset`; -1 and a failure if the file ends first (it shrank). */
int read_exactly(int fd, char *buffer, size_t bytes, int64_t offset, Failure *failure);

/* Cyclic Jacobi on a symmetric 3x3 (row-major): ascending moments, vectors (column k the axis of moments[k])
 * and the backward error bound, the same bits as the Python formulation (post.c). */
void jacobi3(const double a[9], double moments[3], double vectors[9], double *bound);
/* max over the vertices of |x - centre|^2, rounded as (dx*dx + dz*dz) + dy*dy (post.c). */
double largest_squared_distance(const double *vertices, int64_t n, const double centre[3]);
int all_finite(const double *values, int64_t count);   /* no NaN and no infinity among count doubles */
/* frame.py's frame_of: the box, the exact reference, the scale and the scaled radius; 0, or 1 when the box spans
 * more than the largest double (nothing else set), 2 when the box's scaled volume is near 2**-900 (frame.py checks) */
int frame_choice(const double *vertices, int64_t n, double low[3], double high[3], double reference[3],
                 int *scale_exp, double *radius);

#endif
