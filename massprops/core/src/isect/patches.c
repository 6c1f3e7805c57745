/* Patch certificates: whole cells of a coarse grid whose faces are proved to meet only along
 * what they share, so that the pair search skips them.
 *
 * On a shell that is not star-shaped (a torus, most machined parts) the
 * search would otherwise enumerate every pair of neighbouring faces whose
 * boxes meet.  Here a coarse grid (cells 8 times the search's, finer on fewer
 * faces or a thin box; grid.c, every face at one level, filed by counting
 * into an array of cells; below) is built first, and each cell's faces are
 * certified as
 * one embedded patch when they can be; failing that, each of the cell's
 * children, then each of theirs.  Only faces in some cell that is not
 * certified go on to the pair search.
 *
 * WHY THAT MISSES NO PAIR.  Two faces whose closed boxes meet are both in
 * the cell (at any level of this grid) that holds the maximum of their
 * boxes' lower corners (grid.c): that point lies in both boxes.  That cell
 * is one of the tree of cells tried here, so either some tried cell holding
 * both faces was certified, and then they meet only along what they share,
 * or the last one tried was not, and both faces are searched.
 *
 * PATCH CERTIFICATE.  Let D be a set of faces of one shell (each face a
 * triangle of positive area, its corners vertex indices), k an axis, and
 * pi the projection dropping k.  Suppose
 *   (a) every face of D has orient2d of its projection of one strict sign;
 *   (b) every vertex of D is manifold (stars.c: its faces chain into one
 *       cycle), and either all its faces are in D ("interior": then it
 *       satisfies the star condition (2) of stars.c with d = e_k, y the
 *       coordinate after k) or those in D are one run of its cycle
 *       ("boundary");
 *   (c) 2V - F - B = 2, V the vertices of D, F its faces, B its boundary
 *       vertices, and the boundary edges (edges of one face of D whose other
 *       face is not in D) form one loop through all B of them;
 *   (d) the projection of that loop is a simple polygon: no two of its edges
 *       meet but consecutive ones, at their common corner only.
 * Then no two faces of D meet other than along what they share.
 * Proof.  Glue the faces of D along shared vertex indices: by (b) each
 * vertex is an interior point (a full cycle) or a boundary point (one run)
 * of a compact surface |D| with boundary, oriented by the faces' winding
 * (edges shared by two faces of D are wound oppositely: stars.c).  Every
 * boundary vertex has one outgoing and one incoming boundary edge, so the
 * boundary edges form loops; (c) says there is one, and with E = (3F + B) / 2
 * edges, V - E + F = 1.  Every component of |D| has boundary: a closed
 * component's projected areas, all of one strict sign by (a), would add up to
 * zero.  So |D| is connected, and a connected orientable surface with one
 * boundary loop and Euler characteristic 1 is a disk.  pi is a local
 * homeomorphism on the interior of |D| that keeps orientation: on faces by
 * (a); across an interior edge because the two faces, wound oppositely along
 * it and both of one projected sign, lie on the two sides of its projection;
 * at an interior vertex by the star certificate of stars.c (its condition (1)
 * is (a), its condition (2) is checked).  For a point p off the projected
 * loop, the number of its preimages (all interior, each counted +1) is the
 * loop's winding number about p, which by (d) (a Jordan curve) is 0 or 1.
 * Two points x != x' with pi(x) = pi(x') = p are then impossible: if both lie
 * on the boundary, (d); otherwise one of them, say x, is interior, pi maps a
 * neighbourhood of x onto a neighbourhood U of p, and the interior points
 * near x' map into U onto an open set, whose points off the loop (the loop
 * has no interior) have a preimage near x and another near x'.  So pi is
 * injective on |D|, and a point common to two faces of D in space is one
 * point of |D|: one of the vertices or edges they share.  []
 * Everything is decided exactly: (a) and (d) with orient2d, (b)'s condition
 * (2) and (d)'s collinear cases with coordinate comparisons.  A patch that
 * fails proves nothing and costs nothing but its time: its faces are searched.
 */
#include "isect.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The coarsest cells' level (the search's cells are level 0 at its base size), the finest level
 * tried, and the most entries a face may have in the coarse grid (beyond: no patches). */
#define PATCH_LEVEL 3
#define PATCH_FINEST 0
#define PATCH_ENTRY_LIMIT 3
/* The widest top cell, as a fraction of the smallest extent of the faces' box (below). */
#define PATCH_THICKNESS 0.6
/* A vertex of more faces fails its cells (each cell holding it would walk all its faces: a fan's hub
 * is left to the search, which skips a hub's pairs as a block). */
#define PATCH_MAX_DEGREE 64
/* Entries per block of the parallel loop. */
#define PATCH_BLOCK 16384

typedef struct {
    double lo, hi;            /* along the projection's first axis */
    double low, high;         /* along its second */
    int64_t i;
} Segment;

typedef struct {
    int64_t vertex;           /* index + 1, 0 empty */
    int64_t next;
} Slot;

typedef struct {
    uint64_t *face_bits;      /* per original face: in the patch being tried (m bits) */
    uint8_t *vertex_count;    /* per vertex: its corners among the faces of the patch being tried (0: not seen) */
    Slot *vertex;             /* boundary vertices from the BOUNDARY_DIRECT-th on and their boundary edges' far
                               * ends (a hash table) */
    int64_t vertex_mask;      /* of the table's part in use for the patch being tried (2 (k + 2) slots or more) */
    int64_t *boundary;        /* the boundary vertices, as they are met */
    int64_t *far;             /* the far end of each one's boundary edge */
    int64_t *loop;            /* the boundary loop's vertices */
    int64_t *seen;            /* the vertices of the patch being tried, as they are first met */
    Segment *segments, *sorted;
    uint32_t *list[PATCH_LEVEL];   /* faces of a child cell, per depth */
    uint8_t *octants[PATCH_LEVEL]; /* per face of a cell: the children it is in, per depth */
    int64_t cap;              /* faces the arrays hold */
    int failed;
} Scratch;

typedef struct {
    const Grid *g;
    const Stars *stars;
    const uint8_t *embedded;  /* per shell, or NULL */
    uint8_t *bad;             /* per original face: in some cell not certified */
    int64_t n_blocks;
    int64_t *cut;             /* n_blocks + 1 cuts: entries at key boundaries (sorted grid), or cells */
    Scratch *scratch;         /* per worker */
    const uint32_t *cell_end; /* counted grid: per cell, the end of its faces in g->face (NULL: sorted grid) */
    int64_t dims[3];          /* counted grid: cells along each axis, at level `top` */
    int top;
} Patches;

static inline uint64_t mix(uint64_t h)
{
    h ^= h >> 33;
    h *= 0xFF51AFD7ED558CCDULL;
    h ^= h >> 33;
    return h;
}

static void scratch_release(Scratch *sc)
{
    free(sc->vertex), free(sc->boundary), free(sc->far), free(sc->loop), free(sc->seen), free(sc->segments), free(sc->sorted);
    for (int d = 0; d < PATCH_LEVEL; d++)
        free(sc->list[d]), free(sc->octants[d]);
}

static int patch_reserve(Scratch *sc, int64_t k)
{
    if (k <= sc->cap)
        return 0;
    int64_t cap = sc->cap ? sc->cap : 64;
    while (cap < k)
        cap *= 2;
    int64_t vertices = 1;
    while (vertices < 2 * (cap + 2))
        vertices *= 2;
    scratch_release(sc);
    sc->cap = 0;
    sc->vertex = calloc(vertices, sizeof(Slot));
    sc->boundary = malloc(sizeof(int64_t) * 3 * cap);
    sc->far = malloc(sizeof(int64_t) * 3 * cap);
    sc->loop = malloc(sizeof(int64_t) * 3 * cap);
    sc->seen = malloc(sizeof(int64_t) * 3 * cap);
    sc->segments = malloc(sizeof(Segment) * 3 * cap);
    sc->sorted = malloc(sizeof(Segment) * 3 * cap);
    int ok = sc->vertex && sc->boundary && sc->far && sc->loop && sc->seen && sc->segments && sc->sorted;
    for (int d = 0; d < PATCH_LEVEL; d++) {
        ok = (sc->list[d] = malloc(sizeof(uint32_t) * cap)) && ok;
        ok = (sc->octants[d] = malloc(cap)) && ok;
    }
    if (!ok) {
        scratch_release(sc);
        memset(sc->list, 0, sizeof(sc->list));
        memset(sc->octants, 0, sizeof(sc->octants));
        sc->vertex = NULL;
        sc->boundary = sc->far = sc->loop = sc->seen = NULL;
        sc->segments = sc->sorted = NULL;
        sc->failed = 1;
        return -1;
    }
    sc->cap = cap;
    return 0;
}

static inline int bit(const uint64_t *bits, int64_t i) { return (int)(bits[i >> 6] >> (i & 63) & 1); }
static inline void set_bit(uint64_t *bits, int64_t i) { bits[i >> 6] |= 1ULL << (i & 63); }
static inline void clear_bit(uint64_t *bits, int64_t i) { bits[i >> 6] &= ~(1ULL << (i & 63)); }

/* Once a vertex of the patch is known to be on its boundary, its corner count (at most
 * PATCH_MAX_DEGREE + 1, below BOUNDARY_MARK) is replaced by BOUNDARY_MARK | its rank among the
 * boundary vertices, for the first BOUNDARY_DIRECT of them; the others are marked BOUNDARY_HASHED
 * and found in the hash table. */
#define BOUNDARY_MARK 0x80
#define BOUNDARY_DIRECT 127
#define BOUNDARY_HASHED 0xFF
_Static_assert(PATCH_MAX_DEGREE + 1 < BOUNDARY_MARK, "a corner count is below the boundary mark");

/* Add boundary vertex v, the count-th, its boundary edge going to `to` (v is not there yet). */
static inline void boundary_add(Scratch *sc, int64_t v, int64_t to, int64_t count)
{
    sc->boundary[count] = v;
    sc->far[count] = to;
    if (count < BOUNDARY_DIRECT) {
        sc->vertex_count[v] = (uint8_t)(BOUNDARY_MARK | count);
        return;
    }
    sc->vertex_count[v] = BOUNDARY_HASHED;
    uint64_t i = mix((uint64_t)v) & sc->vertex_mask;
    while (sc->vertex[i].vertex)
        i = (i + 1) & sc->vertex_mask;
    sc->vertex[i] = (Slot){v + 1, to};
}

/* The far end of boundary vertex v's boundary edge, or -1 when v is not a boundary vertex. */
static inline int64_t boundary_next(const Scratch *sc, int64_t v)
{
    uint8_t mark = sc->vertex_count[v];
    if (mark < BOUNDARY_MARK)
        return -1;
    if (mark != BOUNDARY_HASHED)
        return sc->far[mark & ~BOUNDARY_MARK];
    for (uint64_t i = mix((uint64_t)v) & sc->vertex_mask;; i = (i + 1) & sc->vertex_mask) {
        if (sc->vertex[i].vertex == v + 1)
            return sc->vertex[i].next;
        if (!sc->vertex[i].vertex)
            return -1;
    }
}

/* Empty what the patch list[0..k), with `vertices` vertices seen and `boundary` boundary vertices,
 * filled. */
static void clear(Scratch *sc, const Grid *g, const uint32_t *list, int64_t k, int64_t vertices, int64_t boundary)
{
    /* every bit set is this patch's: whole words are cleared (no read of each) */
    for (int64_t i = 0; i < k; i++)
        sc->face_bits[grid_id(g, list[i]) >> 6] = 0;
    for (int64_t i = 0; i < vertices; i++)
        sc->vertex_count[sc->seen[i]] = 0;
    for (int64_t i = BOUNDARY_DIRECT; i < boundary; i++) {
        int64_t v = sc->boundary[i];
        for (uint64_t s = mix((uint64_t)v) & sc->vertex_mask; sc->vertex[s].vertex; s = (s + 1) & sc->vertex_mask)
            sc->vertex[s].vertex = 0;
    }
}

static inline int sign_of(double x) { return (x > 0.0) - (x < 0.0); }

/* Consecutive projected loop edges p q and q r meet only at q (p, q, r already known collinear
 * or not): (d) for neighbours.  u, w: the projection's coordinates. */
static int turn_ok(int axis, P p, P q, P r, int u, int w)
{
    if (porient(axis, p, q, r) != 0)
        return 1;
    /* collinear: they overlap beyond q exactly when p and r lie on one side of q */
    return sign_of(p[u] - q[u]) * sign_of(r[u] - q[u]) <= 0 && sign_of(p[w] - q[w]) * sign_of(r[w] - q[w]) <= 0;
}

/* Projected closed segments p q and r s certainly do not meet: one lies strictly on one side of
 * the other's line. */
static int apart(int axis, P p, P q, P r, P s)
{
    int a = porient(axis, p, q, r), b = porient(axis, p, q, s);
    if (a != 0 && a == b)
        return 1;
    int c = porient(axis, r, s, p), d = porient(axis, r, s, q);
    return c != 0 && c == d;
}

/* The segments x[0..b) of a loop, in its order, sorted by lo (in x or tmp; the one returned).  A
 * loop's lo rises and falls in few runs (two on a convex one): the falling runs are turned, then
 * neighbouring runs merged until one is left. */
static Segment *sort_segments(Segment *x, Segment *tmp, int64_t b)
{
    for (int64_t i = 0; i + 1 < b;) {
        if (!(x[i + 1].lo < x[i].lo)) {
            i++;
            continue;
        }
        int64_t j = i + 1;
        while (j + 1 < b && x[j + 1].lo < x[j].lo)
            j++;
        for (int64_t lo = i, hi = j; lo < hi; lo++, hi--) {
            Segment swap = x[lo];
            x[lo] = x[hi];
            x[hi] = swap;
        }
        i = j + 1;
    }
    Segment *src = x, *dst = tmp;
    for (;;) {
        int64_t o = 0, runs = 0;
        for (int64_t start = 0; start < b; runs++) {
            int64_t mid = start + 1;
            while (mid < b && !(src[mid].lo < src[mid - 1].lo))
                mid++;
            int64_t stop = mid < b ? mid + 1 : b;
            while (stop < b && !(src[stop].lo < src[stop - 1].lo))
                stop++;
            int64_t i = start, j = mid;
            while (i < mid && j < stop) {
                int later = src[j].lo < src[i].lo;     /* (a pointer chosen, not a branch) */
                const Segment *pick = later ? &src[j] : &src[i];
                dst[o++] = *pick;
                j += later;
                i += !later;
            }
            while (i < mid)
                dst[o++] = src[i++];
            while (j < stop)
                dst[o++] = src[j++];
            start = stop;
        }
        Segment *swap = src;
        src = dst;
        dst = swap;
        if (runs <= 1)
            return src;
    }
}

/* (d) shown the cheap way, or not: the projected loop loop[0..b) turns one way about a point c, once.
 * Every edge p q has orient2d(c, p, q) of one strict sign, and one edge only crosses the line
 * through c parallel to u in the direction that sign gives (w of p below c's, q's at or above it,
 * for a positive sign; the other way for a negative one).  Then the loop is a simple polygon.
 * Proof.  Let the sign be positive (else reverse the loop).  Seen from c, the angle of a point
 * moving along an edge grows strictly (c is on no edge: each orient2d is not zero) and by less
 * than pi.  An edge crossing that line upwards crosses it right of c: for x where it does,
 * orient2d(c, p, q) = (x - c) x (q - p) = (x_u - c_u)(q_w - p_w), positive.  With the half-open
 * rule (below, then at or above) a loop meets that ray once per turn about c, so the loop turns
 * once: its vertices' angles t_0 < t_1 < ... < t_(b-1) < t_0 + 2 pi.  Each closed edge lies in
 * the closed sector of its ends' angles; the sectors of two edges that are not consecutive are
 * disjoint and c is on neither, so those edges do not meet; two consecutive ones share the ray
 * through their common corner, which each meets there only (neither lies along it).  []  c is any
 * point (here the mean of the corners, rounded): the predicates are exact for it. */
static int loop_turns_once(const double *V, const int64_t *loop, int64_t b, int u, int w)
{
    double cu = 0.0, cw = 0.0;
    for (int64_t i = 0; i < b; i++) {
        cu += V[3 * loop[i] + u];
        cw += V[3 * loop[i] + w];
    }
    cu /= (double)b;
    cw /= (double)b;
    int sign = 0;
    int64_t up = 0, down = 0;
    P p = V + 3 * loop[b - 1];
    for (int64_t i = 0; i < b; i++) {
        P q = V + 3 * loop[i];
        int o = orient2d(cu, cw, p[u], p[w], q[u], q[w]);
        if (o == 0 || (sign != 0 && o != sign))
            return 0;
        sign = o;
        up += (p[w] < cw) & (cw <= q[w]);
        down += (q[w] < cw) & (cw <= p[w]);
        p = q;
    }
    return (sign > 0 ? up : down) == 1;
}

/* (d): the projected loop loop[0..b) is a simple polygon. */
static int loop_simple(const double *V, const int64_t *loop, int64_t b, int axis, Scratch *sc)
{
    int u = axis == 0 ? 1 : 0, w = axis == 2 ? 1 : 2;
    if (b >= 3 && loop_turns_once(V, loop, b, u, w))
        return 1;
    for (int64_t i = 0; i < b; i++) {
        int64_t i1 = i + 1 == b ? 0 : i + 1, i2 = i1 + 1 == b ? 0 : i1 + 1;
        P p = V + 3 * loop[i], q = V + 3 * loop[i1], r = V + 3 * loop[i2];
        if (p[u] == q[u] && p[w] == q[w])
            return 0;
        if (!turn_ok(axis, p, q, r, u, w))
            return 0;
        sc->segments[i] = (Segment){dmin(p[u], q[u]), dmax(p[u], q[u]), dmin(p[w], q[w]), dmax(p[w], q[w]), i};
    }
    if (b <= 3)
        return 1;
    const Segment *sorted = sort_segments(sc->segments, sc->sorted, b);
    for (int64_t x = 0; x < b; x++) {
        const Segment *s = &sorted[x];
        int64_t i = s->i, after = i + 1 == b ? 0 : i + 1, before = i == 0 ? b - 1 : i - 1;
        for (int64_t y = x + 1; y < b && sorted[y].lo <= s->hi; y++) {
            const Segment *o = &sorted[y];
            int64_t j = o->i;
            if (j == after || j == before || o->high < s->low || o->low > s->high)
                continue;
            P p = V + 3 * loop[i], q = V + 3 * loop[after];
            P r = V + 3 * loop[j], t = V + 3 * loop[j + 1 == b ? 0 : j + 1];
            if (!apart(axis, p, q, r, t))
                return 0;
        }
    }
    return 1;
}

static inline void face_normal(const Grid *g, uint32_t t, double *n)
{
    const int64_t *c = g->corner + 3 * (int64_t)t;
    P a = g->V + 3 * c[0], b = g->V + 3 * c[1], e = g->V + 3 * c[2];
    double x[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, y[3] = {e[0] - a[0], e[1] - a[1], e[2] - a[2]};
    n[0] = x[1] * y[2] - x[2] * y[1];
    n[1] = x[2] * y[0] - x[0] * y[2];
    n[2] = x[0] * y[1] - x[1] * y[0];
}

static inline int largest(const double *n)
{
    double f[3] = {fabs(n[0]), fabs(n[1]), fabs(n[2])};
    return f[0] >= f[1] ? (f[0] >= f[2] ? 0 : 2) : (f[1] >= f[2] ? 1 : 2);
}

/* (a) along `axis` for faces of one shell: the common strict sign of their projections' orient2d,
 * or 0. */
static int one_sign(const Grid *g, const uint32_t *list, int64_t k, int axis, int64_t shell)
{
    int sign = 0;
    /* every 16th face first: a cell holding two sheets usually fails there, without the full pass */
    for (int64_t i = 0; i < k; i += 16) {
        const int64_t *c = g->corner + 3 * (int64_t)list[i];
        int o = porient(axis, g->V + 3 * c[0], g->V + 3 * c[1], g->V + 3 * c[2]);
        if (o == 0 || (sign != 0 && o != sign))
            return 0;
        sign = o;
    }
    for (int64_t i = 0; i < k; i++) {
        const int64_t *c = g->corner + 3 * (int64_t)list[i];
        int o = porient(axis, g->V + 3 * c[0], g->V + 3 * c[1], g->V + 3 * c[2]);
        if (o == 0 || (sign != 0 && o != sign) || shell_at(g->shell, list[i]) != shell)
            return 0;
        sign = o;
    }
    return sign;
}

/* Whether the faces list[0..k) (indices into the grid's faces) are a certified patch. */
static int patch(const Patches *pa, Scratch *sc, const uint32_t *list, int64_t k)
{
    const Grid *g = pa->g;
    const Stars *st = pa->stars;
    const double *V = g->V;
    if (k <= 1)
        return 1;
    int64_t shell = shell_at(g->shell, list[0]);
    if (pa->embedded && pa->embedded[shell]) {
        for (int64_t i = 1; i < k; i++)
            if (shell_at(g->shell, list[i]) != shell)
                return 0;
        return 1;
    }
    /* (a): along the largest component of the first face's normal, else of the summed normals */
    double n[3];
    face_normal(g, list[0], n);
    int axis = largest(n), sign = one_sign(g, list, k, axis, shell);
    if (sign == 0) {
        double sum[3] = {0.0, 0.0, 0.0};
        for (int64_t i = 0; i < k; i++) {
            face_normal(g, list[i], n);
            for (int a = 0; a < 3; a++)
                sum[a] += n[a];
        }
        int other = largest(sum);
        sign = other == axis ? 0 : one_sign(g, list, k, other, shell);
        axis = other;
    }
    if (sign == 0)
        return 0;
    /* (b), counting V and B (with (c), B <= V = (k + B + 2) / 2: B <= k + 2).  Each vertex's corners
     * among the faces are counted first: a vertex with as many as it has faces is interior (all its
     * faces are in the patch; each is there once), and only the others' cycles are walked for
     * their runs. */
    int ok = 1, y = axis == 0 ? 1 : 0;
    int64_t n_vertices = 0, n_boundary = 0, start = -1;
    sc->vertex_mask = 1;
    while (sc->vertex_mask < 2 * (k + 2))
        sc->vertex_mask *= 2;
    sc->vertex_mask--;
    const int64_t *F = st->F;
    uint8_t *count = sc->vertex_count;
    for (int64_t i = 0; i < k; i++) {
        set_bit(sc->face_bits, grid_id(g, list[i]));
        const int64_t *c = g->corner + 3 * (int64_t)list[i];
        for (int j = 0; j < 3; j++) {
            int64_t v = c[j];
            sc->seen[n_vertices] = v;
            n_vertices += !count[v];
            /* at most PATCH_MAX_DEGREE + 1 is kept (a vertex of more faces fails below) */
            count[v] += count[v] <= PATCH_MAX_DEGREE;
        }
    }
    for (int64_t i = 0; i < n_vertices && ok; i++) {
        int64_t v = sc->seen[i];
        int64_t b = st->begin[v], degree = st->begin[v + 1] - b;
        if (!(st->flag[v] & STAR_CYCLE) || degree > PATCH_MAX_DEGREE) {
            ok = 0;
            break;
        }
        if (count[v] == degree) {
            /* an interior vertex: the star condition (2) along the axis (its link's coordinates) */
            P pv = V + 3 * v;
            int64_t upward = 0;
            int first_above = 0, last_above = 0;
            for (int64_t j = 0; j < degree; j++) {
                uint32_t r = st->ring[b + j];
                int64_t x = next_corner(F, r >> 2, r & 3);
                int above = V[3 * x + y] > pv[y];
                if (j == 0)
                    first_above = above;
                else
                    upward += !last_above && above;
                last_above = above;
            }
            upward += !last_above && first_above;
            ok = upward == 1;
            continue;
        }
        /* which of its faces are in the patch: one run of them (a boundary vertex; the edge that
         * leaves the patch goes to the far end of the run's first face) */
        int64_t runs = 0;
        uint32_t first = 0;   /* (without branches: which faces are in is not predictable) */
        int last_in = bit(sc->face_bits, st->ring[b + degree - 1] >> 2);
        for (int64_t j = 0; j < degree; j++) {
            uint32_t r = st->ring[b + j];
            int in = bit(sc->face_bits, r >> 2), starts = in & !last_in;
            runs += starts;
            first = starts ? r : first;
            last_in = in;
        }
        if (runs == 1 && n_boundary < k + 2) {
            int64_t edge = next_corner(F, first >> 2, first & 3);
            boundary_add(sc, v, edge, n_boundary++);
            start = v;
        } else
            ok = 0;
    }
    /* (c) */
    if (ok)
        ok = n_boundary >= 3 && 2 * n_vertices - k - n_boundary == 2;
    int64_t at = start;
    for (int64_t i = 0; ok && i < n_boundary; i++) {
        sc->loop[i] = at;
        at = boundary_next(sc, at);
        ok = at >= 0 && (at != start || i == n_boundary - 1);
    }
    ok = ok && at == start;
    /* (d) */
    if (ok)
        ok = loop_simple(V, sc->loop, n_boundary, axis, sc);
    clear(sc, g, list, k, n_vertices, n_boundary);
    return ok;
}

/* The cells of `level` that face t's box covers (the counted grid keeps no cells: from its corners). */
static inline void face_cells(const Grid *g, int64_t t, int level, int64_t *c0, int64_t *c1)
{
    if (g->low_cell) {
        grid_face_cells(g, t, level, c0, c1);
        return;
    }
    const int64_t *c = g->corner + 3 * t;
    P a = g->V + 3 * c[0], b = g->V + 3 * c[1], e = g->V + 3 * c[2];
    for (int k = 0; k < 3; k++) {
        c0[k] = grid_cell0(g, k, dmin(a[k], dmin(b[k], e[k]))) >> level;
        c1[k] = grid_cell0(g, k, dmax(a[k], dmax(b[k], e[k]))) >> level;
    }
}

static void mark_bad(const Patches *pa, const uint32_t *list, int64_t k)
{
    for (int64_t i = 0; i < k; i++)
        __atomic_store_n(&pa->bad[grid_id(pa->g, list[i])], 1, __ATOMIC_RELAXED);
}

/* Certify the cell `cell` at `level` holding list[0..k); failing that, its children, down to
 * PATCH_FINEST; faces of the cells that fail are marked. */
static void certify_cell(const Patches *pa, Scratch *sc, const uint32_t *list, int64_t k, int level,
                            const int64_t *cell)
{
    if (patch_reserve(sc, k) < 0) {
        mark_bad(pa, list, k);
        return;
    }
    if (patch(pa, sc, list, k))
        return;
    if (level <= PATCH_FINEST || sc->failed) {
        mark_bad(pa, list, k);
        return;
    }
    const Grid *g = pa->g;
    int child = level - 1;
    uint32_t *sub = sc->list[child];
    uint8_t *octants = sc->octants[child];
    /* octant o is child (o & 1, o >> 1 & 1, o >> 2 & 1) along x, y, z; per axis, the octants on its
     * lower and upper side */
    static const uint8_t side[3][2] = {{0x55, 0xAA}, {0x33, 0xCC}, {0x0F, 0xF0}};
    unsigned occupied = 0;
    for (int64_t i = 0; i < k; i++) {
        int64_t c0[3], c1[3];
        face_cells(g, list[i], child, c0, c1);
        uint8_t in = 0xFF;
        for (int a = 0; a < 3; a++)
            in &= (uint8_t)((c0[a] <= 2 * cell[a] && 2 * cell[a] <= c1[a] ? side[a][0] : 0)
                            | (c0[a] <= 2 * cell[a] + 1 && 2 * cell[a] + 1 <= c1[a] ? side[a][1] : 0));
        octants[i] = in;
        occupied |= in;
    }
    for (int octant = 0; octant < 8; octant++) {
        if (!(occupied >> octant & 1))
            continue;
        int64_t at[3] = {2 * cell[0] + (octant & 1), 2 * cell[1] + (octant >> 1 & 1), 2 * cell[2] + (octant >> 2 & 1)};
        int64_t n = 0;
        for (int64_t i = 0; i < k; i++)
            if (octants[i] >> octant & 1)
                sub[n++] = list[i];
        if (n)
            certify_cell(pa, sc, sub, n, child, at);
    }
}

static void patch_block(void *ctx, int worker, int64_t block)
{
    const Patches *pa = ctx;
    const Grid *g = pa->g;
    Scratch *sc = &pa->scratch[worker];
    int64_t e = pa->cut[block], end = pa->cut[block + 1];
    if (pa->cell_end) {
        for (int64_t c = e; c < end; c++) {
            int64_t first = c ? pa->cell_end[c - 1] : 0;
            int64_t cell[3] = {c % pa->dims[0], c / pa->dims[0] % pa->dims[1], c / pa->dims[0] / pa->dims[1]};
            if (pa->cell_end[c] > first)
                certify_cell(pa, sc, g->face + first, pa->cell_end[c] - first, pa->top, cell);
        }
        return;
    }
    while (e < end) {
        int64_t run = e + 1;
        while (run < end && g->key[run] == g->key[e])
            run++;
        int64_t cell[3];
        grid_key_cell(g->key[e] & ((1ULL << LEVEL_SHIFT) - 1), cell);
        certify_cell(pa, sc, g->face + e, run - e, (int)(g->key[e] >> LEVEL_SHIFT), cell);
        e = run;
    }
}

/* ---- the coarse grid, by counting ------------------------------------------------------------ */

/* Every face is at one level, so the cells can be an array (when there are not many more cells
 * than faces) and the faces filed into them by counting: per block of faces, per cell, instead
 * of keys sorted.  Faces keep their input index, ascending within a cell as in the sorted grid
 * (grid.c), the fallback.  About 4 bytes a face (a 32-bit index per entry) instead of the sorted
 * grid's 40 (keys, copies, cells and the sort's scratch).  The grid's origin is the low corner of
 * a box holding every face taken: with every face taken, the box of the vertices some face uses
 * (the stars' incidences say which: a pass over the vertices, not over the faces' scattered
 * corners), or else a pass of its own. */

/* A face's home: the cell of its box's low corner << 3, and per bit of home & 7 the next cell
 * along x (1), y (2), z (4) it reaches too (enter); or one of these two. */
enum { HOME_NONE = 0xFFFFFFFF, HOME_SPLIT = 0xFFFFFFFE };
/* Homes are kept while counting as runs of consecutive faces with the same home, so that filing
 * need not find each face's cells again from its corners (on the 10M torus, whose 10M faces are
 * 172k runs, that was 3 ns/triangle of the search).  Per block, room for its faces' runs up to
 * RUNS_WHOLE faces, and for a sixteenth of them beyond: a block whose faces are in no order
 * (runs of one face) finds the cells of the faces after its runs again, as without them. */
#define RUNS_WHOLE 65536
#define RUNS_SHARE 16
/* Homes need 8 * cell + 7 < HOME_SPLIT: no runs with more cells. */
#define RUNS_MOST_CELLS ((int64_t)1 << 28)

typedef struct {
    uint32_t home, length;
} Run;

typedef struct {
    const double *V;
    const int64_t *F;
    const uint8_t *take;
    const uint32_t *begin;    /* the stars' incidence offsets: vertex v is used when begin[v + 1] > begin[v] */
    int64_t n;                /* vertices */
    const Grid *g;
    int64_t m, per_block, n_blocks;
    Run *runs;                /* per block, room for run_room: its first faces' homes, in order */
    int64_t run_room;
    int64_t *n_runs;          /* per block: runs kept; they cover its first faces, the rest are found again */
    double (*box)[6];         /* per block: low corner, high corner of its valid faces */
    int64_t *count;           /* per block: valid faces (valid_block), then entries */
    int64_t *valid;           /* per block: valid faces (counted with the entries) */
    int top;
    int64_t dims[3], n_cells;
    uint32_t *slot;           /* per block, per cell: entries, then where the next one goes */
    uint32_t *face;           /* per entry: input face index */
} Coarse;

/* Faces of zero area are filed too: (a) fails the cells that hold one (and its neighbours are
 * searched; the search leaves it out).  Testing every face's area here cost more than those
 * cells, which are rare. */
static inline int taken_face(const Coarse *co, int64_t t)
{
    return !co->take || co->take[t];
}

static void valid_block(void *ctx, int64_t block)
{
    Coarse *co = ctx;
    int64_t t0 = block * co->per_block, t1 = t0 + co->per_block < co->m ? t0 + co->per_block : co->m, n = 0;
    /* the box in locals, stored once: the blocks' boxes share cache lines */
    double box[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (int64_t t = t0; t < t1; t++) {
        if (!taken_face(co, t))
            continue;
        const int64_t *c = co->F + 3 * t;
        P a = co->V + 3 * c[0], b = co->V + 3 * c[1], e = co->V + 3 * c[2];
        for (int k = 0; k < 3; k++) {
            box[k] = dmin(box[k], dmin(a[k], dmin(b[k], e[k])));
            box[3 + k] = dmax(box[3 + k], dmax(a[k], dmax(b[k], e[k])));
        }
        n++;
    }
    memcpy(co->box[block], box, sizeof(box));
    co->count[block] = n;
}

/* The box of the used vertices of the block's share of them. */
static void used_block(void *ctx, int64_t block)
{
    Coarse *co = ctx;
    int64_t per = (co->n + co->n_blocks - 1) / co->n_blocks;
    int64_t v0 = block * per, v1 = v0 + per < co->n ? v0 + per : co->n;
    double box[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (int64_t v = v0; v < v1; v++) {
        if (co->begin[v + 1] == co->begin[v])
            continue;
        P p = co->V + 3 * v;
        for (int k = 0; k < 3; k++) {
            box[k] = dmin(box[k], p[k]);
            box[3 + k] = dmax(box[3 + k], p[k]);
        }
    }
    memcpy(co->box[block], box, sizeof(box));
}

/* Face t entered in the cells of `home` (not HOME_NONE or HOME_SPLIT): counted (fill 0) or filed
 * (fill 1); how many cells. */
static inline int64_t enter(Coarse *co, uint32_t *slot, uint32_t home, int fill, uint32_t t)
{
    int64_t at[8], n = 0, cell = home >> 3, row = co->dims[0], plane = co->dims[0] * co->dims[1];
    at[n++] = cell;
    if (home & 1)
        at[n++] = cell + 1;
    if (home & 2) {
        at[n++] = cell + row;
        if (home & 1)
            at[n++] = cell + row + 1;
    }
    if (home & 4) {
        int64_t up = n;
        for (int64_t i = 0; i < up; i++)
            at[n++] = at[i] + plane;
    }
    for (int64_t i = 0; i < n; i++) {
        if (fill)
            co->face[slot[at[i]]++] = t;
        else
            slot[at[i]]++;
    }
    return n;
}

/* Face t's cells found from its corners, counted (fill 0) or filed (fill 1) and added to *entries:
 * its home (HOME_NONE when it is not taken, HOME_SPLIT when it reaches further than the next cell
 * along an axis: a coarse cell is at least twice most faces' extent). */
static uint32_t cells_of_face(Coarse *co, uint32_t *slot, int fill, int64_t t, int64_t *entries)
{
    if (!taken_face(co, t))
        return HOME_NONE;
    const Grid *g = co->g;
    const int64_t *c = co->F + 3 * t;
    P a = co->V + 3 * c[0], b = co->V + 3 * c[1], e = co->V + 3 * c[2];
    int64_t c0[3], c1[3];
    for (int k = 0; k < 3; k++) {
        c0[k] = grid_cell0(g, k, dmin(a[k], dmin(b[k], e[k]))) >> co->top;
        c1[k] = grid_cell0(g, k, dmax(a[k], dmax(b[k], e[k]))) >> co->top;
    }
    int64_t low = (c0[2] * co->dims[1] + c0[1]) * co->dims[0] + c0[0];
    if (c1[0] - c0[0] <= 1 && c1[1] - c0[1] <= 1 && c1[2] - c0[2] <= 1 && co->n_cells < RUNS_MOST_CELLS) {
        uint32_t home = (uint32_t)(low << 3 | (c1[0] - c0[0]) | (c1[1] - c0[1]) << 1 | (c1[2] - c0[2]) << 2);
        *entries += enter(co, slot, home, fill, (uint32_t)t);
        return home;
    }
    for (int64_t z = c0[2]; z <= c1[2]; z++)
        for (int64_t y = c0[1]; y <= c1[1]; y++)
            for (int64_t x = c0[0]; x <= c1[0]; x++) {
                int64_t cell = (z * co->dims[1] + y) * co->dims[0] + x;
                if (fill)
                    co->face[slot[cell]++] = (uint32_t)t;
                else
                    slot[cell]++;
                (*entries)++;
            }
    return HOME_SPLIT;
}

/* The block's entries: counted per cell, its faces' homes kept as runs (fill 0); or filed, from
 * the runs and then from the corners of the faces after them (fill 1). */
static void cells_block(Coarse *co, int64_t block, int fill)
{
    int64_t t = block * co->per_block, t1 = t + co->per_block < co->m ? t + co->per_block : co->m;
    int64_t entries = 0, valid = 0, n_runs = 0;
    uint32_t *slot = co->slot + block * co->n_cells;
    Run *run = co->runs + block * co->run_room;
    if (fill) {
        for (int64_t r = 0; r < co->n_runs[block]; r++)
            for (uint32_t i = 0; i < run[r].length; i++, t++) {
                uint32_t home = run[r].home;
                if (home == HOME_SPLIT)
                    cells_of_face(co, slot, 1, t, &entries);
                else if (!(home & 7))
                    co->face[slot[home >> 3]++] = (uint32_t)t;
                else if (home != HOME_NONE)
                    enter(co, slot, home, 1, (uint32_t)t);
            }
        for (; t < t1; t++)
            cells_of_face(co, slot, 1, t, &entries);
        return;
    }
    for (int keeping = co->run_room > 0; t < t1; t++) {
        uint32_t home = cells_of_face(co, slot, 0, t, &entries);
        valid += home != HOME_NONE;
        if (keeping && n_runs && run[n_runs - 1].home == home && run[n_runs - 1].length < UINT32_MAX)
            run[n_runs - 1].length++;
        else if (keeping && n_runs < co->run_room)
            run[n_runs++] = (Run){home, 1};
        else
            keeping = 0;
    }
    co->count[block] = entries;
    co->valid[block] = valid;
    co->n_runs[block] = n_runs;
}

static void count_block(void *ctx, int64_t block) { cells_block(ctx, block, 0); }
static void fill_block(void *ctx, int64_t block) { cells_block(ctx, block, 1); }

/* The coarse grid at level co->top (`top` or finer: see PATCH_THICKNESS) of the faces taken,
 * counted into g (its faces are the input's: g->corner = F) and co->slot; with `stars` (NULL when
 * take is not) the box is that of their used vertices.  0, 1 when nothing is to be done (no face, or more than PATCH_ENTRY_LIMIT entries a
 * face, as grid_build_at), 2 when the cells are too many for an array (then nothing is built), -1
 * out of memory. */
static int coarse_build(Coarse *co, Grid *g, const double *V, const int64_t *F, const int64_t *shell,
                        const uint8_t *take, int64_t m, int top, const Stars *stars, int threads)
{
    memset(g, 0, sizeof(*g));
    memset(co, 0, sizeof(*co));
    g->V = co->V = V;
    g->corner = co->F = F;
    g->shell = shell;
    co->take = take;
    co->g = g;
    co->m = m;
    co->top = top;
    int64_t most = (m + 8191) / 8192, n_blocks = 4 * (int64_t)(threads < 1 ? 1 : threads);
    co->n_blocks = n_blocks = n_blocks < most ? n_blocks : (most ? most : 1);
    co->per_block = (m + n_blocks - 1) / n_blocks;
    co->run_room = co->per_block < RUNS_WHOLE ? co->per_block : RUNS_WHOLE + co->per_block / RUNS_SHARE;
    co->runs = malloc(sizeof(Run) * n_blocks * co->run_room);
    co->n_runs = malloc(sizeof(int64_t) * n_blocks);
    co->box = malloc(sizeof(double[6]) * n_blocks);
    co->count = malloc(sizeof(int64_t) * n_blocks);
    co->valid = malloc(sizeof(int64_t) * n_blocks);
    double *extent = malloc(sizeof(double) * GRID_SAMPLES);
    int status = -1;
    if (!co->runs || !co->n_runs || !co->box || !co->count || !co->valid || !extent)
        goto done;
    double glo[3], ghi[3];
    int64_t n = m;            /* faces taken: at most m until counted */
    if (stars) {
        co->begin = stars->begin;
        co->n = stars->n;
        parallel_blocks(threads, n_blocks, used_block, co);
    } else {
        parallel_blocks(threads, n_blocks, valid_block, co);
        n = 0;
        for (int64_t k = 0; k < n_blocks; k++)
            n += co->count[k];
    }
    for (int a = 0; a < 3; a++)
        glo[a] = INFINITY, ghi[a] = -INFINITY;
    for (int64_t k = 0; k < n_blocks; k++)
        for (int a = 0; a < 3; a++) {
            glo[a] = dmin(glo[a], co->box[k][a]);
            ghi[a] = dmax(ghi[a], co->box[k][3 + a]);
        }
    status = 1;
    if (n == 0 || !(glo[0] <= ghi[0]))
        goto done;
    /* the cells' side from the extents of faces taken spread over the input (of zero area too:
     * the side is a choice of speed, not of what is certified) */
    int64_t pool = 0;
    for (int64_t t = 0; take && t < m; t++)
        pool += take[t] != 0;
    pool = take ? pool : m;
    int samples = pool < GRID_SAMPLES ? (int)pool : GRID_SAMPLES;
    for (int64_t x = 0, t = -1, rank = -1; x < samples; x++) {
        int64_t want = grid_sample((int)x, pool, samples);
        if (!take)
            t = want;
        while (take && rank < want)
            rank += take[++t] != 0;
        const int64_t *c = F + 3 * t;
        P a = V + 3 * c[0], b = V + 3 * c[1], e = V + 3 * c[2];
        extent[x] = 0.0;
        for (int k = 0; k < 3; k++)
            extent[x] = dmax(extent[x], dmax(a[k], dmax(b[k], e[k])) - dmin(a[k], dmin(b[k], e[k])));
    }
    double whole = dmax(ghi[0] - glo[0], dmax(ghi[1] - glo[1], ghi[2] - glo[2]));
    if (!(whole > 0.0))
        whole = 1.0;
    double base = grid_base(extent, samples, whole, 1);
    /* no top cell wider than PATCH_THICKNESS of the box's smallest extent: a wider cell of a thin
     * or tube-like shell (a torus: its tube) holds both of its sides and fails, and its faces are
     * tried again in its children */
    double thin = dmin(ghi[0] - glo[0], dmin(ghi[1] - glo[1], ghi[2] - glo[2]));
    while (co->top > PATCH_FINEST && ldexp(base, co->top) > PATCH_THICKNESS * thin)
        co->top--;
    top = co->top;
    for (int k = 0; k < 3; k++)
        g->origin[k] = glo[k];
    g->inverse = 1.0 / base;
    co->n_cells = 1;
    for (int k = 0; k < 3; k++) {
        co->dims[k] = (grid_cell0(g, k, ghi[k]) >> top) + 1;
        co->n_cells *= co->dims[k];
    }
    status = 2;
    if (co->n_cells > (n + 65536) / n_blocks)
        goto done;
    status = -1;
    co->slot = calloc((size_t)(n_blocks * co->n_cells), sizeof(uint32_t));
    if (!co->slot)
        goto done;
    parallel_blocks(threads, n_blocks, count_block, co);
    int64_t entries = 0;
    n = 0;
    for (int64_t k = 0; k < n_blocks; k++) {
        entries += co->count[k];
        n += co->valid[k];
    }
    status = 1;
    if (n == 0 || entries > PATCH_ENTRY_LIMIT * n)
        goto done;
    status = -1;
    for (int64_t c = 0, at = 0; c < co->n_cells; c++)
        for (int64_t k = 0; k < n_blocks; k++) {
            uint32_t x = co->slot[k * co->n_cells + c];
            co->slot[k * co->n_cells + c] = (uint32_t)at;
            at += x;
        }
    g->face = co->face = isect_alloc(sizeof(uint32_t) * (entries ? entries : 1), 0);
    if (!g->face)
        goto done;
    parallel_blocks(threads, n_blocks, fill_block, co);
    g->n = n;
    g->n_entries = entries;
    status = 0;
done:
    free(co->runs), free(co->n_runs), free(co->box), free(co->count), free(co->valid), free(extent);
    co->runs = NULL;
    co->n_runs = NULL;
    if (status != 0) {
        free(co->slot);
        co->slot = NULL;
        grid_free(g);
    }
    return status;
}

int patches_mark(const double *V, const int64_t *F, const int64_t *shell, const uint8_t *take, int64_t m,
                 const Stars *stars, int threads, uint8_t *bad)
{
    /* Cells of about 1/128 of the faces or fewer (a cell at level l holds about 8 * 4**l faces of a
     * smooth surface): finer than a curved part's radius, coarse enough to cover most of it; and
     * no wider than PATCH_THICKNESS of the box's smallest extent (coarse_build). */
    int64_t taken = take ? 0 : m;
    for (int64_t t = 0; take && t < m; t++)
        taken += take[t] != 0;
    int top = 1;
    while (top < PATCH_LEVEL && ((int64_t)1024 << (2 * (top + 1))) <= taken)
        top++;
    Grid g;
    Coarse co;
    int status = coarse_build(&co, &g, V, F, shell, take, m, top, take ? NULL : stars, threads);
    top = co.top;
    if (status == 2)
        status = grid_build_at(&g, V, F, shell, take, m, NULL, threads, top, PATCH_ENTRY_LIMIT);
    if (status != 0 || g.n == 0) {
        grid_free(&g);
        return status < 0 ? -1 : 1;
    }
    Patches pa;
    memset(&pa, 0, sizeof(pa));
    pa.g = &g;
    pa.stars = stars;
    pa.embedded = stars->shell_embedded;
    pa.bad = bad;
    if (co.slot) {
        pa.cell_end = co.slot + (co.n_blocks - 1) * co.n_cells;
        memcpy(pa.dims, co.dims, sizeof(pa.dims));
        pa.top = top;
    }
    int64_t want = g.n_entries / PATCH_BLOCK + 1;
    int workers = threads < 1 ? 1 : threads;
    pa.cut = malloc(sizeof(int64_t) * (want + 2));
    pa.scratch = calloc(workers, sizeof(Scratch));
    status = -1;
    int ready = pa.scratch != NULL;
    for (int k = 0; ready && k < workers; k++) {
        pa.scratch[k].face_bits = calloc((stars->m >> 6) + 1, sizeof(uint64_t));
        pa.scratch[k].vertex_count = calloc(stars->n + 1, 1);
        ready = pa.scratch[k].face_bits && pa.scratch[k].vertex_count;
    }
    if (pa.cut && ready) {
        int64_t n_cuts = 0, at = 0;
        pa.cut[n_cuts++] = 0;
        /* the counted grid: runs of cells of about PATCH_BLOCK entries */
        for (int64_t c = 0, next = PATCH_BLOCK; pa.cell_end && c < co.n_cells; c++)
            if (pa.cell_end[c] >= next || c == co.n_cells - 1) {
                pa.cut[n_cuts++] = c + 1;
                next = pa.cell_end[c] + PATCH_BLOCK;
            }
        while (!pa.cell_end && at < g.n_entries && n_cuts <= want) {
            int64_t next = at + PATCH_BLOCK < g.n_entries ? at + PATCH_BLOCK : g.n_entries;
            while (next < g.n_entries && g.key[next] == g.key[next - 1])
                next++;
            pa.cut[n_cuts++] = next;
            at = next;
        }
        pa.n_blocks = n_cuts - 1;
        parallel_workers(workers, pa.n_blocks, patch_block, &pa);
        status = 0;
        for (int k = 0; k < workers; k++)
            status = pa.scratch[k].failed ? -1 : status;
    }
    for (int k = 0; pa.scratch && k < workers; k++) {
        scratch_release(&pa.scratch[k]);
        free(pa.scratch[k].face_bits), free(pa.scratch[k].vertex_count);
    }
    free(pa.cut), free(pa.scratch), free(co.slot);
    grid_free(&g);
    return status;
}
