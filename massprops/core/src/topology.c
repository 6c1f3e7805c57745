/* Edges, shells and duplicate faces of a triangle mesh (indices only, no coordinates).
 *
 * Edges: every directed edge tail -> head is filed under its lower vertex
 * (a counting sort by vertex, in face order), so each undirected edge is
 * found by looking only at the few edges of one vertex.  For each undirected
 * edge we count its uses and its balance (uses from the lower vertex to the
 * higher minus uses back): a closed, consistently wound surface has balance
 * 0 on every edge.  Vertex ranges are grouped in parallel; every count is a
 * sum and every example the first in vertex order, so nothing depends on the
 * thread count.
 *
 * Shells: connected components of faces sharing a vertex, by union-find
 * (roots are the smallest vertex of their set), numbered by first face.
 *
 * Duplicate faces: faces with the same three vertices, found by hashing the
 * sorted triple; each is compared with the first face of its group, and
 * counted as the same orientation or the opposite one.
 */
#include "core.h"
#include "topology.h"

#include <stdlib.h>
#include <string.h>

static inline int64_t face_index(const void *faces, int faces32, int64_t k)
{
    return faces32 ? ((const int32_t *)faces)[k] : ((const int64_t *)faces)[k];
}

int check_indices(const void *faces, int faces32, int64_t m, int64_t n, Failure *failure)
{
    int64_t k;
    if (n >= ((int64_t)1 << 31)) {
        fail(failure, ERR_VALUE, "split the mesh into parts", "more than 2**31 vertices: too many for the checks");
        return -1;
    }
    for (k = 0; k < 3 * m; k++) {
        int64_t v = face_index(faces, faces32, k);
        if (v < 0 || v >= n) {
            fail(failure, ERR_INDEX, "re-export the mesh",
                 "face %lld refers to vertex %lld, but there are %lld vertices", (long long)(k / 3), (long long)v,
                 (long long)n);
            return -1;
        }
    }
    return 0;
}

static inline int32_t find_root(int32_t *parent, int32_t v)
{
    while (parent[v] != v) {
        parent[v] = parent[parent[v]];                 /* path halving */
        v = parent[v];
    }
    return v;
}

static inline void join(int32_t *parent, int32_t a, int32_t b)
{
    int32_t ra = find_root(parent, a), rb = find_root(parent, b);
    if (ra < rb)
        parent[rb] = ra;
    else if (rb < ra)
        parent[ra] = rb;
}

/* ---- edges ------------------------------------------------------------------------------ */

#define VERTEX_BLOCK 4096

typedef struct {
    const void *faces;
    int faces32;
    int64_t m, n;
    uint32_t *offsets;          /* n + 1: edges filed under vertex v are entries[offsets[v] .. offsets[v+1]) */
    uint32_t *entries;          /* (head << 1) | 1 if the edge runs from the higher vertex to the lower */
    EdgeSummary *blocks;        /* one summary per block of VERTEX_BLOCK vertices */
    int64_t parts;              /* counting and filing: the vertex range split in this many parts */
    int64_t *collapsed, *degenerate;   /* per part: directed edges a -> a, faces with a repeated vertex */
    int32_t *parent;            /* edge_shells: the shells' union-find over vertices (NULL: no shells) */
    int checked;                /* edge_shells: the passes check the indices (not checked before) */
    int outside[2];             /* edge_shells: a face refers to no vertex (found by the counting, the joining) */
    int64_t *roots;             /* edge_shells: per block of VERTEX_BLOCK vertices, roots with an edge filed */
} EdgeWork;

/* The three corners of face f. */
#define CORNERS(w, f, a, b, c)                                                                   \
    do {                                                                                         \
        if ((w)->faces32) {                                                                      \
            const int32_t *p_ = (const int32_t *)(w)->faces + 3 * (f);                          \
            a = p_[0], b = p_[1], c = p_[2];                                                     \
        } else {                                                                                 \
            const int64_t *p_ = (const int64_t *)(w)->faces + 3 * (f);                          \
            a = p_[0], b = p_[1], c = p_[2];                                                     \
        }                                                                                        \
    } while (0)

/* The directed edge tail -> head, filed under its lower vertex if that is in [low, high). */
#define COUNT(w, tail, head, low, high)                                                          \
    do {                                                                                         \
        int64_t lower_ = (tail) < (head) ? (tail) : (head);                                      \
        if ((tail) != (head) && lower_ >= (low) && lower_ < (high))                              \
            (w)->offsets[lower_ + 1]++;                                                          \
    } while (0)

#define FILE_EDGE(w, tail, head, low, high)                                                      \
    do {                                                                                         \
        int64_t lower_ = (tail) < (head) ? (tail) : (head), higher_ = (tail) < (head) ? (head) : (tail); \
        if ((tail) != (head) && lower_ >= (low) && lower_ < (high))                              \
            (w)->entries[(w)->offsets[lower_]++] = (uint32_t)(higher_ << 1) | (uint32_t)((tail) > (head)); \
    } while (0)

/* Whether a face's corner is outside [0, n), in the passes that check the indices themselves. */
#define OUTSIDE(w, a, b, c)                                                                      \
    ((w)->checked && ((uint64_t)(a) >= (uint64_t)(w)->n || (uint64_t)(b) >= (uint64_t)(w)->n     \
                      || (uint64_t)(c) >= (uint64_t)(w)->n))

/* One part (one thread, or a small mesh): every vertex is in range, so the edges are counted and filed with no
 * range test (the indices were checked before, or are checked here face by face). */
#define COUNT_ALL(w, tail, head)                                                                 \
    do {                                                                                         \
        if ((tail) != (head))                                                                    \
            (w)->offsets[((tail) < (head) ? (tail) : (head)) + 1]++;                             \
    } while (0)

#define FILE_ALL(w, tail, head)                                                                  \
    do {                                                                                         \
        if ((tail) != (head)) {                                                                  \
            int64_t lower_ = (tail) < (head) ? (tail) : (head), higher_ = (tail) < (head) ? (head) : (tail); \
            (w)->entries[(w)->offsets[lower_]++] = (uint32_t)(higher_ << 1) | (uint32_t)((tail) > (head)); \
        }                                                                                        \
    } while (0)

/* Every face's three edges counted; with `join`, its corners joined into one shell as well (one
 * thread: the joining and the counting in one pass over the faces). */
static inline void count_faces(EdgeWork *w, int join_shells)
{
    int64_t f, a, b, c, collapsed = 0, degenerate = 0;
    for (f = 0; join_shells && f < w->n; f++)
        w->parent[f] = (int32_t)f;
    for (f = 0; f < w->m; f++) {
        CORNERS(w, f, a, b, c);
        if (__builtin_expect(OUTSIDE(w, a, b, c), 0)) {
            w->outside[0] = 1;
            if (join_shells)
                w->outside[1] = 1;
            break;
        }
        if (join_shells) {
            join(w->parent, (int32_t)a, (int32_t)b);
            join(w->parent, (int32_t)a, (int32_t)c);
        }
        COUNT_ALL(w, a, b);
        COUNT_ALL(w, b, c);
        COUNT_ALL(w, c, a);
        collapsed += (a == b) + (b == c) + (c == a);
        degenerate += a == b || b == c || c == a;
    }
    w->collapsed[0] = collapsed;
    w->degenerate[0] = degenerate;
}

static void file_all(EdgeWork *w)
{
    int64_t f, a, b, c;
    for (f = 0; f < w->m; f++) {
        CORNERS(w, f, a, b, c);
        FILE_ALL(w, a, b);
        FILE_ALL(w, b, c);
        FILE_ALL(w, c, a);
    }
}

static void count_part(void *arg, int64_t part)
{
    EdgeWork *w = arg;
    int64_t low = w->n * part / w->parts, high = w->n * (part + 1) / w->parts, f, a, b, c, collapsed = 0,
            degenerate = 0;
    if (w->parts == 1) {
        count_faces(w, 0);
        return;
    }
    for (f = 0; f < w->m; f++) {
        CORNERS(w, f, a, b, c);
        if (__builtin_expect(OUTSIDE(w, a, b, c), 0)) {
            w->outside[0] = 1;
            break;
        }
        COUNT(w, a, b, low, high);
        COUNT(w, b, c, low, high);
        COUNT(w, c, a, low, high);
        if (part == 0) {
            collapsed += (a == b) + (b == c) + (c == a);
            degenerate += a == b || b == c || c == a;
        }
    }
    w->collapsed[part] = collapsed;
    w->degenerate[part] = degenerate;
}

static void file_part(void *arg, int64_t part)
{
    EdgeWork *w = arg;
    int64_t low = w->n * part / w->parts, high = w->n * (part + 1) / w->parts, f, a, b, c;
    if (w->parts == 1) {
        file_all(w);
        return;
    }
    for (f = 0; f < w->m; f++) {
        CORNERS(w, f, a, b, c);
        FILE_EDGE(w, a, b, low, high);
        FILE_EDGE(w, b, c, low, high);
        FILE_EDGE(w, c, a, low, high);
    }
}

static void insertion_sort(uint32_t *list, int64_t k)
{
    int64_t i, j;
    for (i = 1; i < k; i++) {
        uint32_t value = list[i];
        for (j = i; j > 0 && list[j - 1] > value; j--)
            list[j] = list[j - 1];
        list[j] = value;
    }
}

static void sift_down(uint32_t *list, int64_t root, int64_t k)
{
    uint32_t value = list[root];
    int64_t child;
    while ((child = 2 * root + 1) < k) {
        if (child + 1 < k && list[child + 1] > list[child])
            child++;
        if (list[child] <= value)
            break;
        list[root] = list[child];
        root = child;
    }
    list[root] = value;
}

static void heap_sort(uint32_t *list, int64_t k)
{
    int64_t i;
    for (i = k / 2 - 1; i >= 0; i--)
        sift_down(list, i, k);
    for (i = k - 1; i > 0; i--) {
        uint32_t top = list[0];
        list[0] = list[i];
        list[i] = top;
        sift_down(list, 0, i);
    }
}

/* Ascending, in place: a quicksort (median of three, the smaller side first) that turns to heap
 * sort when it goes too deep, and to insertion sort on short runs.  Equal entries are equal
 * values, so any sort gives the same list.  (qsort's calls through a comparison function cost
 * more than the sorting on a fan's centre.) */
static void sort_entries(uint32_t *list, int64_t k)
{
    int depth = 0;
    int64_t n;
    for (n = k; n > 1; n >>= 1)
        depth += 2;
    while (k > 32) {
        uint32_t a, b, c, pivot, t;
        int64_t i, j;
        if (depth-- == 0) {
            heap_sort(list, k);
            return;
        }
        a = list[0], b = list[k / 2], c = list[k - 1];
        pivot = a < b ? (b < c ? b : a < c ? c : a) : (a < c ? a : b < c ? c : b);
        i = -1, j = k;
        for (;;) {                                       /* Hoare's partition */
            do
                i++;
            while (list[i] < pivot);
            do
                j--;
            while (list[j] > pivot);
            if (i >= j)
                break;
            t = list[i], list[i] = list[j], list[j] = t;
        }
        /* [0, j] <= pivot <= [j + 1, k): sort the smaller side, loop on the larger */
        if (j + 1 < k - j - 1) {
            sort_entries(list, j + 1);
            list += j + 1;
            k -= j + 1;
        } else {
            sort_entries(list + j + 1, k - j - 1);
            k = j + 1;
        }
    }
    insertion_sort(list, k);
}

/* Keep the smallest (a, b) seen: the first such edge in vertex order. */
static void note_example(int64_t example[2], int64_t a, int64_t b)
{
    if (example[0] < 0 || a < example[0] || (a == example[0] && b < example[1])) {
        example[0] = a;
        example[1] = b;
    }
}

static inline void count_edge(EdgeSummary *s, int64_t v, int64_t head, int64_t uses, int64_t balance)
{
    s->edges++;
    s->boundary += uses == 1;
    s->odd += uses & 1;
    s->unbalanced += balance != 0;
    s->nonmanifold += uses > 2;
    s->max_uses = uses > s->max_uses ? uses : s->max_uses;
    if (__builtin_expect(uses == 1 || balance != 0, 0)) {
        if (uses == 1)
            note_example(s->first_boundary, v, head);
        if (balance)
            note_example(s->first_unbalanced, v, head);
    }
}

/* Group the edges of vertex v, adding to `s`, and calling `each` per edge (then in order of the
 * higher vertex).  A vertex has few edges: without `each` they are grouped by scanning, with no
 * sort; many (a fan's centre), or with `each`, are sorted first. */
typedef void (*edge_fn)(void *ctx, int64_t low, int64_t high, int64_t uses, int64_t balance);

#define GROUPED 0xFFFFFFFFu        /* never an entry: heads are below 2**31 - 1 */

/* The edges of a vertex with many (a fan's centre), grouped in a table keyed by the higher vertex instead
 * of sorted: the same edges, uses and balances (counted in another order, which no count depends on).
 * 0, or -1 when the vertex has too many entries for the table's 16-bit counts or there is no memory
 * for it (then the caller sorts). */
static int group_hashed(const uint32_t *list, int64_t k, int64_t v, EdgeSummary *s)
{
    typedef struct {
        uint32_t key;                      /* the higher vertex + 1; 0: an empty slot */
        uint16_t uses, backward;           /* at most k < 65536 each */
    } Slot;
    int bits = 6;
    uint32_t mask;
    int64_t i;
    Slot *table;
    if (k >= 65536)
        return -1;
    while (((int64_t)1 << bits) <= k)      /* more slots than entries: a free slot ends every search */
        bits++;
    mask = ((uint32_t)1 << bits) - 1;
    if (!(table = calloc((size_t)1 << bits, sizeof *table)))
        return -1;
    for (i = 0; i < k; i++) {
        uint32_t key = (list[i] >> 1) + 1, slot = (key * 0x9E3779B1u) >> (32 - bits);
        while (table[slot].key && table[slot].key != key)
            slot = (slot + 1) & mask;
        table[slot].key = key;
        table[slot].uses++;
        table[slot].backward += list[i] & 1;
    }
    for (i = 0; i <= (int64_t)mask; i++)
        if (table[i].key)
            count_edge(s, v, (int64_t)table[i].key - 1, table[i].uses,
                       (int64_t)table[i].uses - 2 * (int64_t)table[i].backward);
    free(table);
    return 0;
}

static void group_vertex(const EdgeWork *w, int64_t v, EdgeSummary *s, edge_fn each, void *ctx)
{
    uint32_t *list = w->entries + w->offsets[v];
    int64_t k = w->offsets[v + 1] - w->offsets[v], i = 0, j;
    if (!each && k <= 32) {
        for (i = 0; i < k; i++) {
            uint32_t head = list[i] >> 1;
            int64_t uses = 1, backward = list[i] & 1;
            if (list[i] == GROUPED)
                continue;
            for (j = i + 1; j < k; j++)
                if (list[j] >> 1 == head && list[j] != GROUPED) {
                    uses++;
                    backward += list[j] & 1;
                    list[j] = GROUPED;
                }
            count_edge(s, v, head, uses, uses - 2 * backward);
        }
        return;
    }
    if (!each && group_hashed(list, k, v, s) == 0)
        return;
    sort_entries(list, k);
    while (i < k) {
        uint32_t head = list[i] >> 1;
        int64_t uses = 0, backward = 0;
        for (; i < k && list[i] >> 1 == head; i++, uses++)
            backward += list[i] & 1;
        count_edge(s, v, head, uses, uses - 2 * backward);
        if (each)
            each(ctx, v, head, uses, uses - 2 * backward);
    }
}

static void summary_init(EdgeSummary *s)
{
    memset(s, 0, sizeof *s);
    s->first_boundary[0] = s->first_boundary[1] = -1;
    s->first_unbalanced[0] = s->first_unbalanced[1] = -1;
}

static void group_block(void *arg, int64_t block)
{
    EdgeWork *w = arg;
    int64_t v, last = (block + 1) * VERTEX_BLOCK < w->n ? (block + 1) * VERTEX_BLOCK : w->n, roots = 0;
    summary_init(&w->blocks[block]);
    for (v = block * VERTEX_BLOCK; v < last; v++)
        group_vertex(w, v, &w->blocks[block], NULL, NULL);
    if (w->parent) {
        /* A shell's root is its smallest vertex, so its edges are filed under it: unless the shell is
         * one vertex of collapsed faces (a, a, a), which edge_shells counts from the faces instead. */
        for (v = block * VERTEX_BLOCK; v < last; v++)
            roots += w->parent[v] == v && w->offsets[v + 1] > w->offsets[v];
        w->roots[block] = roots;
    }
}

static void merge_summary(EdgeSummary *into, const EdgeSummary *s)
{
    into->edges += s->edges;
    into->boundary += s->boundary;
    into->odd += s->odd;
    into->unbalanced += s->unbalanced;
    into->nonmanifold += s->nonmanifold;
    if (s->max_uses > into->max_uses)
        into->max_uses = s->max_uses;
    if (s->first_boundary[0] >= 0)
        note_example(into->first_boundary, s->first_boundary[0], s->first_boundary[1]);
    if (s->first_unbalanced[0] >= 0)
        note_example(into->first_unbalanced, s->first_unbalanced[0], s->first_unbalanced[1]);
}

static void append_edge(void *ctx, int64_t low, int64_t high, int64_t uses, int64_t balance)
{
    EdgeArrays *a = ctx;
    a->edges[2 * a->count] = low;
    a->edges[2 * a->count + 1] = high;
    a->uses[a->count] = (int32_t)uses;
    a->balance[a->count] = (int32_t)balance;
    a->count++;
}

/* edge_shells: the union-find of the shells (block 0) beside the edges' counting (block 1); then the
 * filing in parts, so on two threads the shells cost little time of their own. */
static void join_faces(EdgeWork *w)
{
    int64_t f, a, b, c;
    for (f = 0; f < w->n; f++)
        w->parent[f] = (int32_t)f;
    for (f = 0; f < w->m; f++) {
        CORNERS(w, f, a, b, c);
        if (__builtin_expect(OUTSIDE(w, a, b, c), 0)) {
            w->outside[1] = 1;
            return;
        }
        join(w->parent, (int32_t)a, (int32_t)b);
        join(w->parent, (int32_t)a, (int32_t)c);
    }
}

static void shells_or_edges(void *arg, int64_t block)
{
    if (block == 0)
        join_faces(arg);
    else
        count_part(arg, 0);
}

/* Number the shells of w->parent's union-find by first face: their count, and each face's shell in
 * labels (when not NULL).  -1 when memory ran out. */
static int64_t number_shells(const EdgeWork *w, int64_t *labels)
{
    int32_t *number = malloc((size_t)(w->n > 0 ? w->n : 1) * sizeof *number);
    int64_t f, a, b, c, shells = 0;
    if (!number)
        return -1;
    memset(number, 0xFF, (size_t)w->n * sizeof *number);
    for (f = 0; f < w->m; f++) {
        int32_t root;
        CORNERS(w, f, a, b, c);
        (void)b;
        (void)c;
        root = find_root(w->parent, (int32_t)a);
        if (number[root] < 0)
            number[root] = (int32_t)shells++;
        if (labels)
            labels[f] = number[root];
    }
    free(number);
    return shells;
}

static int edge_work(const void *faces, int faces32, int64_t m, int64_t n, int threads, EdgeSummary *out,
                     EdgeArrays *arrays, ShellResult *shells, Failure *failure);

int edge_summary(const void *faces, int faces32, int64_t m, int64_t n, int threads, EdgeSummary *out,
                 EdgeArrays *arrays, Failure *failure)
{
    return edge_work(faces, faces32, m, n, threads, out, arrays, NULL, failure);
}

int edge_shells(const void *faces, int faces32, int64_t m, int64_t n, int threads, EdgeSummary *out,
                ShellResult *shells, Failure *failure)
{
    return edge_work(faces, faces32, m, n, threads, out, NULL, shells, failure);
}

static int edge_work(const void *faces, int faces32, int64_t m, int64_t n, int threads, EdgeSummary *out,
                     EdgeArrays *arrays, ShellResult *shells, Failure *failure)
{
    EdgeWork w = {faces, faces32, m, n, NULL, NULL, NULL, 1, NULL, NULL, NULL, 0, {0, 0}, NULL};
    int64_t blocks = (n + VERTEX_BLOCK - 1) / VERTEX_BLOCK, v, k, collapsed = 0, degenerate = 0;
    summary_init(out);
    if (shells) {
        shells->count = 0;
        shells->labels = NULL;
    }
    /* edge_shells checks the indices in its passes (the first face outside is then found from the start) */
    if (check_indices(faces, faces32, shells ? 0 : m, n, failure) != 0)
        return -1;
    if (3 * m >= ((int64_t)1 << 32)) {
        fail(failure, ERR_VALUE, "split the mesh into parts", "more than 1.4 billion triangles: too many for the checks");
        return -1;
    }
    w.parts = threads > 1 && m > 20000 ? threads : 1;
    w.offsets = calloc((size_t)n + 1, sizeof *w.offsets);
    w.entries = malloc((size_t)(3 * m > 0 ? 3 * m : 1) * sizeof *w.entries);
    w.blocks = malloc((size_t)(blocks > 0 ? blocks : 1) * sizeof *w.blocks);
    w.collapsed = calloc((size_t)w.parts, sizeof(int64_t));
    w.degenerate = calloc((size_t)w.parts, sizeof(int64_t));
    advise_huge(w.offsets, ((size_t)n + 1) * sizeof *w.offsets);
    advise_huge(w.entries, (size_t)(3 * m) * sizeof *w.entries);
    if (!w.offsets || !w.entries || !w.blocks || !w.collapsed || !w.degenerate) {
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        goto done;
    }
    if (shells) {
        int64_t parts = w.parts;
        w.parts = 1;                               /* counted on one part, beside the joining */
        w.parent = malloc((size_t)(n > 0 ? n : 1) * sizeof *w.parent);
        w.roots = calloc((size_t)(blocks > 0 ? blocks : 1), sizeof *w.roots);
        if (!w.parent || !w.roots) {
            fail(failure, ERR_MEMORY, NULL, "out of memory");
            goto done;
        }
        w.checked = 1;
        if (threads > 1)
            parallel_blocks(threads, 2, shells_or_edges, &w);
        else
            count_faces(&w, 1);         /* one thread: the joining and the counting in one pass */
        if ((w.outside[0] || w.outside[1]) && check_indices(faces, faces32, m, n, failure) != 0)
            goto done;
        w.checked = 0;
        w.parts = parts;
        for (v = 0; v < n; v++)
            w.offsets[v + 1] += w.offsets[v];
        parallel_blocks(threads, w.parts, file_part, &w);
    } else {
        parallel_blocks(threads, w.parts, count_part, &w);
        for (v = 0; v < n; v++)
            w.offsets[v + 1] += w.offsets[v];
        parallel_blocks(threads, w.parts, file_part, &w);
    }
    collapsed = w.collapsed[0];
    degenerate = w.degenerate[0];
    for (v = n; v > 0; v--)                            /* filing advanced each start to the next one's */
        w.offsets[v] = w.offsets[v - 1];
    w.offsets[0] = 0;
    if (arrays) {
        /* In vertex order on one thread, appending each edge as it is grouped. */
        EdgeSummary whole;
        int64_t edges = w.offsets[n];
        summary_init(&whole);
        arrays->count = 0;
        arrays->edges = malloc((size_t)(edges + 1) * 2 * sizeof(int64_t));
        arrays->uses = malloc((size_t)(edges + 1) * sizeof(int32_t));
        arrays->balance = malloc((size_t)(edges + 1) * sizeof(int32_t));
        if (!arrays->edges || !arrays->uses || !arrays->balance) {
            fail(failure, ERR_MEMORY, NULL, "out of memory");
            goto done;
        }
        for (v = 0; v < n; v++)
            group_vertex(&w, v, &whole, append_edge, arrays);
        *out = whole;
    } else {
        parallel_blocks(threads, blocks, group_block, &w);
        for (k = 0; k < blocks; k++)
            merge_summary(out, &w.blocks[k]);
    }
    out->collapsed = collapsed;
    out->degenerate_faces = degenerate;
    if (shells) {
        shells->count = 0;
        for (k = 0; k < blocks; k++)
            shells->count += w.roots[k];
        /* labels when there is more than one shell; faces (a, a, a) may hold shells without edges */
        if (degenerate || shells->count != 1) {
            free(w.offsets);                       /* not needed any more: less memory alive at once */
            free(w.entries);
            w.offsets = NULL;
            w.entries = NULL;
            shells->labels = malloc((size_t)(m > 0 ? m : 1) * sizeof *shells->labels);
            shells->count = shells->labels ? number_shells(&w, shells->labels) : -1;
            if (shells->count < 0) {
                fail(failure, ERR_MEMORY, NULL, "out of memory");
            }
            if (shells->count <= 1) {
                free(shells->labels);
                shells->labels = NULL;
            }
        }
    }
done:
    free(w.parent);
    free(w.roots);
    free(w.offsets);
    free(w.entries);
    free(w.blocks);
    free(w.collapsed);
    free(w.degenerate);
    release_free_memory(3 * m * (int64_t)sizeof(int64_t));
    return failure->kind == ERR_NONE ? 0 : -1;
}

/* ---- shells -------------------------------------------------------------------------------- */

int face_shells(const void *faces, int faces32, int64_t m, int64_t n, int64_t *labels, int64_t *count,
                Failure *failure)
{
    int32_t *parent, *number;
    int64_t f, shells = 0;
    if (check_indices(faces, faces32, m, n, failure) != 0)
        return -1;
    parent = malloc((size_t)(n > 0 ? n : 1) * sizeof *parent);
    number = malloc((size_t)(n > 0 ? n : 1) * sizeof *number);
    if (!parent || !number) {
        free(parent);
        free(number);
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    for (f = 0; f < n; f++) {
        parent[f] = (int32_t)f;
        number[f] = -1;
    }
    for (f = 0; f < m; f++) {
        int32_t a = (int32_t)face_index(faces, faces32, 3 * f);
        join(parent, a, (int32_t)face_index(faces, faces32, 3 * f + 1));
        join(parent, a, (int32_t)face_index(faces, faces32, 3 * f + 2));
    }
    for (f = 0; f < m; f++) {
        int32_t root = find_root(parent, (int32_t)face_index(faces, faces32, 3 * f));
        if (number[root] < 0)
            number[root] = (int32_t)shells++;
        if (labels)
            labels[f] = number[root];
    }
    free(parent);
    free(number);
    *count = shells;
    return 0;
}

/* ---- duplicate faces, and rows of indices in general ------------------------------------------ */

#define MAX_ROW 8

/* Row r of `columns` indices, sorted; *odd is the parity of the sort's swaps. */
static inline void sorted_row(const void *rows, int rows32, int columns, int64_t r, int64_t t[MAX_ROW], int *odd)
{
    int i, j, swaps = 0;
    for (i = 0; i < columns; i++)
        t[i] = face_index(rows, rows32, (int64_t)columns * r + i);
    for (i = 1; i < columns; i++) {
        int64_t value = t[i];
        for (j = i; j > 0 && t[j - 1] > value; j--, swaps++)
            t[j] = t[j - 1];
        t[j] = value;
    }
    *odd = swaps & 1;
}

static inline uint64_t row_hash(const int64_t t[MAX_ROW], int columns)
{
    uint64_t h = 0x9E3779B97F4A7C15ULL;
    int i;
    for (i = 0; i < columns; i++)
        h = (h ^ (uint64_t)t[i]) * 0xBF58476D1CE4E5B9ULL;
    return h ^ (h >> 29);
}

int row_groups(const void *rows, int rows32, int columns, int64_t m, int64_t *labels, int64_t *first, int64_t *groups,
               int64_t *same, int64_t *opposite, Failure *failure)
{
    int bits = 4;
    uint64_t size, mask;
    int64_t *slots, f, k = 0;
    if (columns < 1 || columns > MAX_ROW) {
        fail(failure, ERR_VALUE, NULL, "rows of %d indices: between 1 and %d expected", columns, MAX_ROW);
        return -1;
    }
    while (((int64_t)1 << bits) < 2 * m)
        bits++;
    size = (uint64_t)1 << bits;
    mask = size - 1;
    slots = malloc(size * sizeof *slots);
    if (!slots) {
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    memset(slots, 0xFF, size * sizeof *slots);        /* -1: empty */
    *same = *opposite = 0;
    for (f = 0; f < m; f++) {
        int64_t t[MAX_ROW], u[MAX_ROW];
        int odd, other_odd, i, equal, repeated = 0;
        uint64_t slot;
        sorted_row(rows, rows32, columns, f, t, &odd);
        for (slot = row_hash(t, columns) >> (64 - bits);; slot = (slot + 1) & mask) {
            int64_t g = slots[slot];
            if (g < 0) {                                  /* a new group, numbered by its first row */
                slots[slot] = k;
                first[k] = f;
                labels[f] = k++;
                break;
            }
            sorted_row(rows, rows32, columns, first[g], u, &other_odd);
            for (i = 0, equal = 1; i < columns; i++)
                equal &= u[i] == t[i];
            if (equal) {
                labels[f] = g;
                for (i = 1; i < columns; i++)
                    repeated |= t[i] == t[i - 1];
                /* Only a triangle has an orientation (and a degenerate one none): others count as the same. */
                if (columns == 3 && odd != other_odd && !repeated)
                    ++*opposite;
                else
                    ++*same;
                break;
            }
        }
    }
    free(slots);
    *groups = k;
    return 0;
}

/* How many of the n vertices no face uses (*unused), or *outside = 1 when an index is not in [0, n) (then
 * *unused is not counted).  -1 when memory ran out. */
int unused_vertices(const void *faces, int faces32, int64_t m, int64_t n, int64_t *unused, int *outside)
{
    unsigned char *used = calloc((size_t)(n > 0 ? n : 1), 1);
    int64_t k, count = 0;
    *unused = 0;
    *outside = 0;
    if (!used)
        return -1;
    for (k = 0; k < 3 * m; k++) {
        int64_t v = face_index(faces, faces32, k);
        if (v < 0 || v >= n) {
            *outside = 1;
            free(used);
            return 0;
        }
        used[v] = 1;
    }
    for (k = 0; k < n; k++)
        count += used[k];
    free(used);
    *unused = n - count;
    return 0;
}
