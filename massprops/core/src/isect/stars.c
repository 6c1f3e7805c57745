/* Certificates that faces meet only along what they share: a vertex's star, or a whole shell.
 *
 * A vertex v is *manifold* here when its faces, each rotated to (v, x, y) in
 * its own orientation, chain into one cycle: every x is some face's y,
 * exactly once.  Then face i of the cycle is (v, a_i, a_{i+1}) (indices mod
 * k, k >= 3), the link a_0 .. a_{k-1} has no repeated vertex, and the faces
 * sharing the edge v a_i are exactly faces i - 1 and i, wound oppositely.
 *
 * STAR CERTIFICATE.  Let d be a vector, y a linear function with y(d) = 0,
 * and suppose
 *   (1) det[d, a_i - v, a_{i+1} - v] has one strict sign for every i, and
 *   (2) exactly one i has y(a_i - v) <= 0 < y(a_{i+1} - v).
 * Then any two faces of the star meet only along what they share.
 * Proof.  Project along d onto the plane d-perp (P(w) = w - (w.d/d.d) d).
 * det[d, x, z] = d . (P(x) x P(z)), so by (1) every P(a_i - v) is non-zero
 * and the angle from P(a_i - v) to P(a_{i+1} - v) about 0, measured in the
 * orientation d gives d-perp, lies strictly in (0, pi) with one sign for all
 * i: the projected link turns monotonically about 0, and its turns add up to
 * 2 pi w, w its winding number about 0.  y restricted to d-perp is a linear
 * coordinate there (y(d) = 0, so y(w) = y(P(w))); if it vanished there, (2)
 * could not hold.  Count crossings of the line y = 0 with the half-open rule
 * of (2): because 0 lies strictly on the same side of every projected link
 * edge, each upward crossing lies on the same half of that line (Sunday's
 * winding-number rule counts exactly these), so |w| = number of upward
 * crossings = 1.  The closed wedges W_i = {v + s(a_i - v) + t(a_{i+1} - v) :
 * s, t >= 0} then project onto sectors of angle in (0, pi) that tile the
 * plane once, adjacent ones sharing only the ray of P(a_{i+1} - v).  P is
 * injective on each W_i (its two generators have independent projections).
 * So if x lies in faces i and j (face i is in W_i): for non-adjacent i, j,
 * P(x - v) lies in two sectors that share only 0, so x = v; for j = i + 1,
 * P(x - v) is on the shared ray, and the only points of W_i over that ray are
 * those of the ray v + s(a_{i+1} - v), so x is on the shared edge (face i
 * meets that ray only there).  (k = 3: sectors i and i + 1 cannot also meet
 * at their far ends, whose angles add up to less than 2 pi.)  []
 * The sign of d's coordinate system never matters: (2) counts upward
 * crossings, which for any closed polygon equal the downward ones.
 * Two choices of d are tried, both exact:
 *   - an axis e_k (the largest component of the star's normal): (1) is
 *     orient2d in the projection dropping k, and y is another coordinate, so
 *     (2) compares coordinates;
 *   - d = q - v for a point q = v + (sum of the faces' unit normals) rounded:
 *     (1) is orient3d(q, a_i, a_{i+1}, v), and y(w) = orient2d of (v + w, q, v)
 *     in the projection dropping the axis of q - v's smallest component.
 * A planar star (every a_i in one plane with v) is the case of any d off
 * that plane; a saddle is fine too, as long as it is a graph over some plane.
 *
 * SHELL CERTIFICATE.  For a shell S (its faces, by label) and a point c:
 *   (a) every face (a, b, e) of S has orient3d(a, b, e, c) of one strict sign;
 *   (b) every vertex of S is manifold, its faces all in S, and satisfies (2)
 *       with d = v - c (y(w) = orient2d(v + w, c, v) dropping the axis of
 *       c - v's smallest component);
 *   (c) V - F/2 = 2, V the vertices of S and F its faces.
 * Then S is embedded: no two of its faces meet other than along what they share.
 * Proof.  For a face i = (v, a_i, a_{i+1}) of v's star, det[v - c, a_i - v,
 * a_{i+1} - v] = det[v - c, a_i - c, a_{i+1} - c] = orient3d(v, a_i, a_{i+1},
 * c), the face's sign in (a): so (1) holds at every vertex with d = v - c,
 * and with (b) every star is embedded as above.  By (b) the faces of S glued
 * along shared vertex numbers form a closed oriented surface |S| (every edge
 * in exactly two faces, wound oppositely; every vertex a disk).  Let r(x) =
 * (x - c) / |x - c| (c is on no face's plane by (a)).  r is injective on each
 * face (a triangle off c), maps the two faces at an edge pq to opposite sides
 * of the plane through c, p, q (orient3d(p, q, e, c) and orient3d(q, p, f, c)
 * have one sign, so e and f lie on opposite sides), and near a vertex v maps
 * the faces to sectors at r(v) whose angles are the azimuths about the line
 * c v, which by the star certificate tile once.  So r is a local
 * homeomorphism from the compact surface |S| to the sphere: a covering map,
 * and each connected component of |S|, covering the simply connected sphere,
 * is mapped homeomorphically onto it, so it is a sphere (Euler characteristic
 * 2).  With E = 3F/2 edges, V - E + F = V - F/2 = 2 * (number of components),
 * so (c) says |S| is connected and r is injective on all of it: two faces
 * with a common point x have r(x) in common, hence x is a common point of
 * |S|, which lies in the part they share.  []
 * c is the shell's volume centroid (its vertex mean when the volume is tiny),
 * rounded: any point works where it works; star-shaped shells (convex parts,
 * convex decompositions, spheres, bumped spheres) pass, and then no pair of
 * the shell is tested at all.
 *
 * DEGREE CERTIFICATE.  When the caller guarantees that every edge of the faces
 * is used as often in each direction (a closed surface: massprops checks this
 * before the search), a one-shell S is certified by its faces alone, without
 * any vertex's star:
 *   (a) as above, every face of S has orient3d(a, b, e, c) of one strict sign s;
 *   (d) some ray R = {c + t u : t > 0} (u != 0) meets no edge of S, and
 *       exactly one face of S.
 * Then S is embedded, every vertex's faces form one cycle (no pinch) and (b)
 * and (c) hold, so the shell certificate gives the same answer.
 * Proof.  Pair the faces at each edge pq, each face using p -> q with one using
 * q -> p (they are equally many), and glue paired faces along pq; at each
 * vertex the glued faces form one or more cycles (face (v, x, y) is followed by
 * the face paired with it along v y); give each cycle its own copy of v.  This
 * is a closed surface S' (its components closed orientable surfaces) that
 * maps onto the faces of S, with E' = 3F/2 edges and V' >= V vertices.  Let
 * r(x) = (x - c) / |x - c| on S' (c is on no face's plane by (a)).  As in the
 * shell certificate's proof, by (a) r is injective on each face with one
 * orientation for all faces, and maps the two faces at each glued edge to the
 * two sides of the plane through it and c; at a vertex copy v, the faces of
 * its cycle (v, a_i, a_{i+1}) map to sectors at r(v) of angle in (0, pi),
 * det[v - c, a_i - v, a_{i+1} - v] = orient3d(v, a_i, a_{i+1}, c) of sign s
 * for all of them, so they turn one way, w_v >= 1 times in all.  So r is a
 * branched covering of the sphere, locally z -> z^{w_v} at v and a local
 * homeomorphism elsewhere, preserving (or, for the other s, reversing)
 * orientation everywhere.  Over the points that are not the image of a vertex
 * copy the number of preimages is then constant, d (their complement in the
 * sphere is connected), each component of S' covers the sphere (an open and
 * closed map), and near v there are w_v preimages of the points near r(v), so
 * 1 <= w_v <= d.  u is not the image of any vertex or edge (R meets none), so
 * its preimages are the points where R crosses a face's interior: d = 1 by (d).
 * Hence S' is connected and r: S' -> sphere is a bijective local
 * homeomorphism, a homeomorphism.  Injectivity has consequences: two copies of
 * one vertex, or two faces paired at one edge with two others (an edge used
 * more than twice), would be distinct points of S' with one image, so every
 * vertex has one cycle, every edge two faces: S' is S as indexed, a sphere
 * (V - F/2 = 2, (c)), every vertex manifold with its link turning once about
 * the line c v (w_v = 1, so (2) holds: a monotone turn of angle 2 pi, in steps
 * below pi, enters the open half-plane y > 0 exactly once), which is (b).  Two
 * faces with a common point x have r(x) in common, so x is one point of S',
 * in what they share.  []
 * (d) is counted in the same pass as (a), for the three axes at once: with
 * N = (b - a) x (e - a), the line c + t e_k meets face (a, b, e)'s plane at
 * t = orient3d(a, b, e, c) / N_k, and crosses the face where c's projection
 * dropping axis k lies strictly inside the face's; a face it meets on an edge
 * or corner has c's projection on the projected boundary (and N_k != 0: a
 * plane parallel to the line does not hold c, so it does not meet it).  The
 * six rays are tried in a fixed order; a ray that some face ahead of c touches
 * on its boundary is skipped.  When all six are (a part symmetric about its
 * centre: a box's rays hit its faces' diagonals), one more pass counts the two
 * rays of an oblique line c + t d the same way (line_block), and when both of
 * those are touched too, nothing is certified here.
 *
 * A certificate that fails proves nothing and costs nothing but its time:
 * the pairs it would have covered are tested exactly.
 */
#include "isect.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Faces per block of the parallel face passes, vertices per block of the vertex passes. */
#define FACE_BLOCK 8192
#define VERTEX_BLOCK 4096
/* Incidences up to which the faces' other corners are kept with them (at most 512 KiB: a part of
 * up to about 20k faces). */
#define XY_MOST ((int64_t)1 << 16)
/* Up to this degree a vertex's cycle is matched pairwise; above, through a sorted copy. */
#define SMALL_DEGREE 16

enum { SIGN_NONE = 0, SIGN_MIXED = 2 };

/* ---- incidences -------------------------------------------------------------------------- */

/* The incidences of the vertices of one range (of `ranges` equal ones), in face order: counted
 * (fill 0) into begin[v + 1], or filed (fill 1), begin[v + 1] running from v's start to its end.
 * Each range reads every face and writes only its own vertices', so the ring does not depend
 * on the number of ranges. */
typedef struct {
    Stars *s;
    int64_t ranges;
    int fill;
} Filing;

static void file_range(void *ctx, int64_t range)
{
    const Filing *w = ctx;
    Stars *s = w->s;
    const int64_t *F = s->F;
    int64_t lo = s->n * range / w->ranges, hi = s->n * (range + 1) / w->ranges, m = s->m;
    uint32_t *next = s->begin + 1;
    if (!w->fill) {
        for (int64_t i = 0; i < 3 * m; i++)
            if (F[i] >= lo && F[i] < hi)
                next[F[i]]++;
        return;
    }
    /* with each incidence, the face's other corners (x, y) while the face is at hand: the cycles
     * are matched from these instead of from the faces, which around a vertex lie anywhere in
     * memory */
    for (int64_t t = 0; t < m; t++)
        for (int c = 0; c < 3; c++) {
            int64_t v = F[3 * t + c];
            if (v < lo || v >= hi)
                continue;
            int64_t at = next[v]++;
            s->ring[at] = (uint32_t)(t << 2 | c);
            if (s->xy)
                s->xy[at] = (uint64_t)next_corner(F, t, c) | (uint64_t)previous_corner(F, t, c) << 32;
        }
}

static int build_incidences(Stars *s, int threads)
{
    int64_t n = s->n, m = s->m;
    s->begin = isect_alloc(sizeof(uint32_t) * (n + 2), 1);
    s->ring = isect_alloc(sizeof(uint32_t) * 3 * m, 0);
    s->flag = calloc(n ? n : 1, 1);
    if (!s->begin || !s->ring || !s->flag)
        return -1;
    /* The corners kept with the incidences spare reads of the faces (a few percent of the search on
     * a small part), but are 24 bytes a face more: on a large mesh, new memory that a fresh process
     * pays for in page faults (on the 1.2M torus, 20-100 ms of the kernel clearing pages against a
     * few ms of reads).  Kept on small meshes only (a batch's worker reuses that memory file after file). */
    s->xy = 3 * m <= XY_MOST && n < ((int64_t)1 << 32) ? malloc(sizeof(uint64_t) * 3 * m) : NULL;
    Filing w = {s, threads < 1 ? 1 : threads, 0};
    parallel_blocks(threads, w.ranges, file_range, &w);
    for (int64_t v = 0, total = 0; v <= n; v++) {
        int64_t c = s->begin[v];
        s->begin[v] = (uint32_t)total;
        total += c;
    }
    w.fill = 1;
    parallel_blocks(threads, w.ranges, file_range, &w);
    return 0;
}

/* ---- per-worker scratch -------------------------------------------------------------------- */

typedef struct {
    int64_t x;
    int64_t index;
} Keyed;

typedef struct {
    int64_t *x, *y, *link;
    int64_t *next;
    uint8_t *above;
    uint32_t *ordered;
    Keyed *sorted, *spare;    /* above SMALL_DEGREE: the link's far corners sorted, and the sort's scratch */
} Scratch;

static void scratch_free(Scratch *sc)
{
    free(sc->x), free(sc->y), free(sc->link), free(sc->next), free(sc->above), free(sc->ordered),
        free(sc->sorted), free(sc->spare);
}

static int scratch_init(Scratch *sc, int64_t degree)
{
    size_t k = (size_t)(degree > 3 ? degree : 3);
    memset(sc, 0, sizeof(*sc));
    sc->x = malloc(sizeof(int64_t) * k);
    sc->y = malloc(sizeof(int64_t) * k);
    sc->link = malloc(sizeof(int64_t) * k);
    sc->next = malloc(sizeof(int64_t) * k);
    sc->above = malloc(k);
    sc->ordered = malloc(sizeof(uint32_t) * k);
    sc->sorted = degree > SMALL_DEGREE ? malloc(sizeof(Keyed) * k) : NULL;
    sc->spare = degree > SMALL_DEGREE ? malloc(sizeof(Keyed) * k) : NULL;
    if (!sc->x || !sc->y || !sc->link || !sc->next || !sc->above || !sc->ordered
        || (degree > SMALL_DEGREE && (!sc->sorted || !sc->spare))) {
        scratch_free(sc);
        return -1;
    }
    return 0;
}

/* Keyed items sorted by x (a run merge sort, isect.h: qsort's call per comparison was a tenth of
 * the search on a part of a few thousand faces with fans of high degree). */
RUN_MERGE_SORT(sort_keyed, Keyed, x)

/* ---- cycles -------------------------------------------------------------------------------- */

/* Put v's incidences in cyclic order and its link in sc->link; 1 when v is manifold (above). */
static int order_cycle(Stars *s, int64_t v, Scratch *sc, int prefetch)
{
    int64_t b = s->begin[v], k = s->begin[v + 1] - b;
    if (k < 3)
        return 0;
    const int64_t *F = s->F;
    for (int64_t i = 0; s->xy && i < k; i++) {
        sc->x[i] = (int64_t)(s->xy[b + i] & 0xFFFFFFFF);
        sc->y[i] = (int64_t)(s->xy[b + i] >> 32);
    }
    for (int64_t i = 0; !s->xy && i < k; i++) {
        uint32_t r = s->ring[b + i];
        int64_t f = r >> 2;
        int c = r & 3;
        sc->x[i] = next_corner(F, f, c);
        sc->y[i] = previous_corner(F, f, c);
    }
    /* the link's coordinates, when a certificate reads them once the cycle is found (around a
     * vertex of a subdivided mesh they lie anywhere in memory) */
    for (int64_t i = 0; prefetch && i < k; i++)
        __builtin_prefetch(s->V + 3 * sc->x[i]);
    if (k <= SMALL_DEGREE) {
        for (int64_t i = 0; i < k; i++) {
            int64_t match = -1;
            for (int64_t j = 0; j < k; j++)
                if (sc->x[j] == sc->y[i]) {
                    if (match >= 0)
                        return 0;
                    match = j;
                }
            if (match < 0)
                return 0;
            sc->next[i] = match;
        }
    } else {
        for (int64_t i = 0; i < k; i++) {
            sc->sorted[i].x = sc->x[i];
            sc->sorted[i].index = i;
        }
        const Keyed *sorted = sort_keyed(sc->sorted, sc->spare, k);
        for (int64_t i = 1; i < k; i++)
            if (sorted[i].x == sorted[i - 1].x)
                return 0;
        for (int64_t i = 0; i < k; i++) {
            int64_t lo = 0, hi = k;
            while (lo < hi) {
                int64_t mid = lo + (hi - lo) / 2;
                if (sorted[mid].x < sc->y[i])
                    lo = mid + 1;
                else
                    hi = mid;
            }
            if (lo == k || sorted[lo].x != sc->y[i])
                return 0;
            sc->next[i] = sorted[lo].index;
        }
    }
    /* back at the first face after k steps and not before: one cycle through all of them (the k
     * faces on the way are distinct: a repeat among them would make the walk periodic from there,
     * and it would pass the first face again before step k, or never reach it) */
    int64_t i = 0;
    for (int64_t step = 0; step < k; step++) {
        if (step > 0 && i == 0)
            return 0;
        sc->ordered[step] = s->ring[b + i];
        sc->link[step] = sc->x[i];
        i = sc->next[i];
    }
    if (i != 0)
        return 0;
    memcpy(s->ring + b, sc->ordered, sizeof(uint32_t) * k);
    return 1;
}

/* Condition (2): exactly one i with above[i] == 0 and above[i + 1] == 1. */
static int one_upward_crossing(const uint8_t *above, int64_t k)
{
    int64_t count = 0;
    for (int64_t i = 0; i < k; i++)
        count += !above[i] && above[i + 1 == k ? 0 : i + 1];
    return count == 1;
}

/* ---- the star certificate ------------------------------------------------------------------ */

/* d = e_axis: (1) by orient2d dropping the axis, y = the coordinate after it. */
static int star_along_axis(const double *V, P v, const int64_t *link, int64_t k, int axis, uint8_t *above)
{
    int w = axis == 0 ? 1 : 0, sign = 0;
    for (int64_t i = 0; i < k; i++) {
        P a = V + 3 * link[i], b = V + 3 * link[i + 1 == k ? 0 : i + 1];
        int s = porient(axis, v, a, b);
        if (s == 0 || (sign != 0 && s != sign))
            return 0;
        sign = s;
        above[i] = a[w] > v[w];
    }
    return one_upward_crossing(above, k);
}

/* d = q - v: (1) by orient3d(q, a_i, a_{i+1}, v), y(w) = orient2d(v + w, q, v) dropping `drop`. */
static int star_along_direction(const double *V, P v, const int64_t *link, int64_t k, P q, uint8_t *above)
{
    double d[3] = {fabs(q[0] - v[0]), fabs(q[1] - v[1]), fabs(q[2] - v[2])};
    int drop = d[0] <= d[1] ? (d[0] <= d[2] ? 0 : 2) : (d[1] <= d[2] ? 1 : 2);
    int sign = 0;
    for (int64_t i = 0; i < k; i++) {
        P a = V + 3 * link[i], b = V + 3 * link[i + 1 == k ? 0 : i + 1];
        int s = orient3d(q, a, b, v);
        if (s == 0 || (sign != 0 && s != sign))
            return 0;
        sign = s;
        above[i] = porient(drop, a, q, v) > 0;
    }
    return one_upward_crossing(above, k);
}

/* The star certificate for v (manifold, link in sc->link), first along an axis, then along
 * the sum of its faces' unit normals. */

static int star_embedded(const double *V, P v, const int64_t *link, int64_t k, uint8_t *above)
{
    double area[3] = {0.0, 0.0, 0.0}, unit[3] = {0.0, 0.0, 0.0}, reach = 0.0;
    for (int64_t i = 0; i < k; i++) {
        P a = V + 3 * link[i], b = V + 3 * link[i + 1 == k ? 0 : i + 1];
        double u[3] = {a[0] - v[0], a[1] - v[1], a[2] - v[2]}, w[3] = {b[0] - v[0], b[1] - v[1], b[2] - v[2]};
        double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
        double length = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int j = 0; j < 3; j++) {
            area[j] += n[j];
            unit[j] += length > 0.0 ? n[j] / length : 0.0;
            reach = dmax(reach, fabs(u[j]));
        }
    }
    double fa[3] = {fabs(area[0]), fabs(area[1]), fabs(area[2])};
    int axis = fa[0] >= fa[1] ? (fa[0] >= fa[2] ? 0 : 2) : (fa[1] >= fa[2] ? 1 : 2);
    if (star_along_axis(V, v, link, k, axis, above))
        return 1;
    double largest = dmax(fabs(unit[0]), dmax(fabs(unit[1]), fabs(unit[2])));
    if (!(largest > 0.0) || !(reach > 0.0))
        return 0;
    double q[3];
    for (int j = 0; j < 3; j++)
        q[j] = v[j] + unit[j] * (reach / largest);
    return star_along_direction(V, v, link, k, q, above);
}

/* star_embedded for vertex v of one cycle, its link taken from its ring in order. */
static int vertex_star_embedded(const Stars *s, int64_t v, Scratch *sc)
{
    int64_t k = star_degree(s, v);
    for (int64_t i = 0; i < k; i++) {
        uint32_t r = s->ring[s->begin[v] + i];
        sc->link[i] = next_corner(s->F, r >> 2, r & 3);
    }
    return star_embedded(s->V, s->V + 3 * v, sc->link, k, sc->above);
}

/* ---- shells -------------------------------------------------------------------------------- */

typedef struct {
    Stars *s;
    const int64_t *shell;
    const uint8_t *wanted;
    int64_t n_shells;
    int64_t *origin;          /* per shell: a vertex of it, the centre's sums are taken about */
    double *sums;             /* per block (few blocks and shells) or else per worker, per shell: volume,
                               * volume-weighted and plain corner sums */
    int sums_per_block;
    double *centre;           /* per shell */
    int8_t *sign;             /* per shell: SIGN_NONE, 1, -1, SIGN_MIXED */
    uint8_t *failed;          /* per shell: a vertex fails (b) */
    int64_t *faces, *vertices;
    Scratch *scratch;         /* per worker */
    int certify_failed;       /* the second vertex pass: local certificates for shells that failed (b) */
    int lazy;                 /* no star certificates here: stars_certify_corners gives them on demand */
    int64_t certified;        /* vertices certified by their stars */
    /* the degree certificate (one shell, closed): per axis k and sign of the face normal's k-th
     * component (0: positive, 1: negative), the faces whose projection dropping k holds the centre
     * strictly inside (crossed), and whether any holds it on its boundary (touched) */
    int by_degree;
    int64_t crossed[3][2];
    uint8_t touched[3][2];
    /* the same for the line through the centre and `towards` (an oblique line, when a face touches
     * each of the six axis rays), by the sign of d . N, d = towards - centre */
    double towards[3];
    int64_t line_crossed[2];
    uint8_t line_touched[2];
} ShellWork;

#define SUMS 7

static inline void add_count(int64_t *counts, int64_t shell, int64_t count)
{
    if (shell >= 0 && count)
        __atomic_fetch_add(&counts[shell], count, __ATOMIC_RELAXED);
}

/* The corners of the face this many ahead are fetched early: on a subdivided mesh a face's corners
 * lie anywhere in memory. */
#define AHEAD 8
static inline void prefetch_corners(const double *V, const int64_t *F, int64_t t)
{
    __builtin_prefetch(V + 3 * F[3 * t]);
    __builtin_prefetch(V + 3 * F[3 * t + 1]);
    __builtin_prefetch(V + 3 * F[3 * t + 2]);
}

/* Add a shell's sums (local, then zeroed) to its row of the worker's sums. */
static inline void add_sums(double *sums, int64_t shell, double *local)
{
    if (shell < 0)
        return;
    for (int j = 0; j < SUMS; j++) {
        sums[shell * SUMS + j] += local[j];
        local[j] = 0.0;
    }
}

/* Sums for each shell's centre, and its face count. */
static void centre_block(void *ctx, int worker, int64_t block)
{
    ShellWork *w = ctx;
    const double *V = w->s->V;
    const int64_t *F = w->s->F;
    double *sums = w->sums + (size_t)(w->sums_per_block ? block : worker) * w->n_shells * SUMS;
    int64_t end = (block + 1) * FACE_BLOCK < w->s->m ? (block + 1) * FACE_BLOCK : w->s->m;
    int64_t current = -1, count = 0;
    /* the current shell's sums, added to the worker's row when the shell changes (the rows of two
     * workers may share a cache line: summing into them face by face made both cores wait on it) */
    double local[SUMS] = {0};
    for (int64_t t = block * FACE_BLOCK; t < end; t++) {
        int64_t s = shell_at(w->shell, t);
        if (!w->wanted[s])
            continue;
        if (s != current) {
            add_count(w->faces, current, count);
            add_sums(sums, current, local);
            current = s;
            count = 0;
        }
        count++;
        P o = V + 3 * w->origin[s];
        if (t + AHEAD < end)
            prefetch_corners(V, F, t + AHEAD);
        P a = V + 3 * F[3 * t], b = V + 3 * F[3 * t + 1], c = V + 3 * F[3 * t + 2];
        double x[3], y[3], z[3];
        for (int k = 0; k < 3; k++) {
            x[k] = a[k] - o[k];
            y[k] = b[k] - o[k];
            z[k] = c[k] - o[k];
        }
        double det = x[0] * (y[1] * z[2] - y[2] * z[1]) + x[1] * (y[2] * z[0] - y[0] * z[2])
                     + x[2] * (y[0] * z[1] - y[1] * z[0]);
        local[0] += det;
        for (int k = 0; k < 3; k++) {
            double corner = x[k] + y[k] + z[k];
            local[1 + k] += det * corner;
            local[4 + k] += corner;
        }
    }
    add_count(w->faces, current, count);
    add_sums(sums, current, local);
}

static void merge_sign(int8_t *sign, int64_t shell, int8_t seen)
{
    if (shell < 0 || seen == SIGN_NONE)
        return;
    int8_t old = __atomic_load_n(&sign[shell], __ATOMIC_RELAXED);
    for (;;) {
        int8_t now = old == SIGN_NONE ? seen : (old == seen ? old : SIGN_MIXED);
        if (now == old || __atomic_compare_exchange_n(&sign[shell], &old, now, 0, __ATOMIC_RELAXED,
                                                      __ATOMIC_RELAXED))
            return;
    }
}

/* How a line meets a face, from the orientations of the line with the face's three edges: 2 all of one
 * strict sign (it crosses the face's interior), 1 some zero and none of the other sign (it meets the
 * face's boundary), 0 otherwise (it misses the face; all zero: parallel to its plane, which does not
 * hold the line's point).  *positive: the sign, when it meets the face. */
static inline int line_meets(int s1, int s2, int s3, int *positive)
{
    int above = (s1 > 0) + (s2 > 0) + (s3 > 0), below = (s1 < 0) + (s2 < 0) + (s3 < 0);
    *positive = above > 0;
    if ((above && below) || (!above && !below))
        return 0;
    return above + below == 3 ? 2 : 1;
}

/* For the degree certificate: where the line through c along each axis k meets face (a, b, e),
 * added to crossed / touched (see ShellWork).  The line meets the face's plane at c + t e_k with
 * t = orient3d(a, b, e, c) / N_k, N = (b - a) x (e - a), whose k-th component is porient(k, a, b, e)
 * (negated for k = 1, whose projection keeps (x, z)).  The sub-triangles' orientations
 * porient(k, a, b, c), (b, e, c), (e, a, c) add up to porient(k, a, b, e): all of one strict sign,
 * c's projection is strictly inside; some zero and none of the other sign, on the boundary; all
 * zero, N_k = 0 and the line, parallel to a plane that does not hold c, misses the face. */
static inline void ray_face(P a, P b, P e, P c, int64_t crossed[3][2], uint8_t touched[3][2])
{
    /* within the face's box on axis j (bit j): the line along k can meet the face only with the
     * two other bits set, and most faces have at most one */
    int within = 0;
    for (int j = 0; j < 3; j++)
        within |= (c[j] >= dmin(a[j], dmin(b[j], e[j])) && c[j] <= dmax(a[j], dmax(b[j], e[j]))) << j;
    if (within == 0 || within == 1 || within == 2 || within == 4)
        return;
    for (int k = 0; k < 3; k++) {
        int u = k == 0 ? 1 : 0, v = k == 2 ? 1 : 2;
        if (!(within >> u & 1) || !(within >> v & 1))
            continue;
        int positive, meets = line_meets(porient(k, a, b, c), porient(k, b, e, c), porient(k, e, a, c), &positive);
        int normal = (positive ? 1 : -1) * (k == 1 ? -1 : 1);     /* the sign of N_k */
        if (meets == 2)
            crossed[k][normal > 0 ? 0 : 1]++;
        else if (meets == 1)
            touched[k][normal > 0 ? 0 : 1] = 1;
    }
}

/* Condition (a): one strict sign of orient3d(face, centre) per shell; with by_degree, the rays'
 * counts too. */
static void sign_block(void *ctx, int worker, int64_t block)
{
    ShellWork *w = ctx;
    const double *V = w->s->V;
    const int64_t *F = w->s->F;
    int64_t end = (block + 1) * FACE_BLOCK < w->s->m ? (block + 1) * FACE_BLOCK : w->s->m;
    int64_t current = -1;
    int8_t seen = SIGN_NONE;
    int64_t crossed[3][2] = {{0}};
    uint8_t touched[3][2] = {{0}};
    for (int64_t t = block * FACE_BLOCK; t < end; t++) {
        int64_t s = shell_at(w->shell, t);
        if (!w->wanted[s])
            continue;
        if (s != current) {
            merge_sign(w->sign, current, seen);
            current = s;
            seen = __atomic_load_n(&w->sign[s], __ATOMIC_RELAXED) == SIGN_MIXED ? SIGN_MIXED : SIGN_NONE;
        }
        if (seen == SIGN_MIXED)
            continue;
        if (t + AHEAD < end)
            prefetch_corners(V, F, t + AHEAD);
        P a = V + 3 * F[3 * t], b = V + 3 * F[3 * t + 1], e = V + 3 * F[3 * t + 2], c = w->centre + 3 * s;
        int o = orient3d(a, b, e, c);
        if (o == 0 || (seen != SIGN_NONE && o != seen))
            seen = SIGN_MIXED;
        else
            seen = (int8_t)o;
        if (w->by_degree && seen != SIGN_MIXED)
            ray_face(a, b, e, c, crossed, touched);
    }
    merge_sign(w->sign, current, seen);
    for (int k = 0; w->by_degree && k < 3; k++)
        for (int j = 0; j < 2; j++) {
            if (crossed[k][j])
                __atomic_fetch_add(&w->crossed[k][j], crossed[k][j], __ATOMIC_RELAXED);
            if (touched[k][j])
                __atomic_store_n(&w->touched[k][j], 1, __ATOMIC_RELAXED);
        }
}

/* The two rays of one line from c (along +d, then -d), counted by the sign of the normal's component
 * along d (0: positive, 1: negative): the first that no face meets on its boundary crosses exactly one
 * face (1) or not (0); -1 when a face meets both on their boundary.  Ahead of c along direction * d,
 * a face's normal component has the sign of orient3d * direction. */
static int rays_decide(const int64_t crossed[2], const uint8_t touched[2], int sign)
{
    for (int direction = 1; direction >= -1; direction -= 2) {
        int j = sign * direction > 0 ? 0 : 1;
        if (!touched[j])
            return crossed[j] == 1;
    }
    return -1;
}

/* The degree certificate's decision for the one shell, of sign `sign` (see the file's comment): the
 * first of the six rays (+x, -x, +y, -y, +z, -z from c) that no face meets on its boundary crosses
 * exactly one face; -1 when a face meets each of them on its boundary. */
static int degree_certified(const ShellWork *w, int sign)
{
    for (int k = 0; k < 3; k++) {
        int certified = rays_decide(w->crossed[k], w->touched[k], sign);
        if (certified >= 0)
            return certified;
    }
    return -1;
}

/* The oblique line c + t d, d = towards - c, on the faces of a block (shell 0; its sign is uniform).
 * orient3d(towards, a, b, c) = det[d, a - c, b - c]: the three of the face's edges add up to d . N, and
 * all of one strict sign say the line crosses the face's interior, some zero and none of the other
 * sign that it meets its boundary (all zero: d . N = 0, parallel to a plane without c: it misses).
 * The line meets the face's plane at t = orient3d(a, b, e, c) / (d . N).  A float test first: with
 * d_x > 1/2, the line's y and z over the face's x range, computed with relative errors below 16 u,
 * widened by 2^-26 of the magnitudes involved, miss the face's box: then so does the line. */
static void line_block(void *ctx, int worker, int64_t block)
{
    ShellWork *w = ctx;
    const double *V = w->s->V;
    const int64_t *F = w->s->F;
    const double *c = w->centre, *q = w->towards;
    double d[3] = {q[0] - c[0], q[1] - c[1], q[2] - c[2]}, slope[3] = {0.0, d[1] / d[0], d[2] / d[0]};
    int64_t end = (block + 1) * FACE_BLOCK < w->s->m ? (block + 1) * FACE_BLOCK : w->s->m, crossed[2] = {0, 0};
    uint8_t touched[2] = {0, 0};
    for (int64_t t = block * FACE_BLOCK; t < end; t++) {
        if (t + AHEAD < end)
            prefetch_corners(V, F, t + AHEAD);
        P a = V + 3 * F[3 * t], b = V + 3 * F[3 * t + 1], e = V + 3 * F[3 * t + 2];
        double lo[3], hi[3];
        for (int j = 0; j < 3; j++) {
            lo[j] = dmin(a[j], dmin(b[j], e[j]));
            hi[j] = dmax(a[j], dmax(b[j], e[j]));
        }
        double x0 = lo[0] - c[0], x1 = hi[0] - c[0];
        int apart = 0;
        for (int j = 1; j < 3 && !apart; j++) {
            double y0 = c[j] + slope[j] * x0, y1 = c[j] + slope[j] * x1;
            double margin = 0x1p-26 * (fabs(c[j]) + fabs(x0) + fabs(x1) + fabs(lo[j]) + fabs(hi[j]));
            apart = hi[j] < dmin(y0, y1) - margin || lo[j] > dmax(y0, y1) + margin;
        }
        if (apart)
            continue;
        int positive, meets = line_meets(orient3d(q, a, b, c), orient3d(q, b, e, c), orient3d(q, e, a, c), &positive);
        if (meets == 2)
            crossed[positive ? 0 : 1]++;
        else if (meets == 1)
            touched[positive ? 0 : 1] = 1;
    }
    for (int j = 0; j < 2; j++) {
        if (crossed[j])
            __atomic_fetch_add(&w->line_crossed[j], crossed[j], __ATOMIC_RELAXED);
        if (touched[j])
            __atomic_store_n(&w->line_touched[j], 1, __ATOMIC_RELAXED);
    }
    (void)worker;
}

/* degree_certified, then, when each axis ray is touched, the two rays of an oblique line. */
static int degree_certified_any(ShellWork *w, int sign, int workers)
{
    int certified = degree_certified(w, sign);
    if (certified >= 0)
        return certified;
    /* d = (1, 1/pi, Euler's gamma), rounded: no symmetry of a part about its centre contains it */
    const double *c = w->centre;
    w->towards[0] = c[0] + 1.0;
    w->towards[1] = c[1] + 0.3183098861837907;
    w->towards[2] = c[2] + 0.5772156649015329;
    if (!(w->towards[0] - c[0] > 0.5))
        return 0;
    parallel_workers(workers, (w->s->m + FACE_BLOCK - 1) / FACE_BLOCK, line_block, w);
    return rays_decide(w->line_crossed, w->line_touched, sign) == 1;
}

/* The shell of v's star, or -1 when its faces lie in several shells. */
static int64_t star_shell(const Stars *s, const int64_t *shell, int64_t v)
{
    if (s->one_shell)
        return 0;
    int64_t b = s->begin[v], e = s->begin[v + 1];
    int64_t first = shell[s->ring[b] >> 2];
    for (int64_t i = b + 1; i < e; i++)
        if (shell[s->ring[i] >> 2] != first)
            return -1;
    return first;
}

static void fail_shells(ShellWork *w, int64_t v)
{
    for (int64_t i = w->s->begin[v]; i < w->s->begin[v + 1]; i++)
        __atomic_store_n(&w->failed[shell_at(w->shell, w->s->ring[i] >> 2)], 1, __ATOMIC_RELAXED);
}

/* Condition (b) for the vertices of star-shaped shells; the star certificate for the others. */
static void vertex_block(void *ctx, int worker, int64_t block)
{
    ShellWork *w = ctx;
    Stars *s = w->s;
    Scratch *sc = &w->scratch[worker];
    int64_t end = (block + 1) * VERTEX_BLOCK < s->n ? (block + 1) * VERTEX_BLOCK : s->n;
    int64_t current = -1, count = 0, certified = 0;
    for (int64_t v = block * VERTEX_BLOCK; v < end; v++) {
        if (s->begin[v + 1] == s->begin[v])
            continue;
        int64_t k = s->begin[v + 1] - s->begin[v];
        P pv = s->V + 3 * v;
        if (w->certify_failed) {
            /* second pass: stars of shells that failed (b) or (c) after passing (a) */
            if (!(s->flag[v] & STAR_CYCLE))
                continue;
            int64_t sh = star_shell(s, w->shell, v);
            if (sh < 0 || !w->wanted[sh] || s->shell_embedded[sh] || w->sign[sh] == SIGN_MIXED)
                continue;
            if (vertex_star_embedded(s, v, sc)) {
                s->flag[v] |= STAR_EMBEDDED;
                certified++;
            }
            continue;
        }
        int64_t sh = star_shell(s, w->shell, v);
        if (sh >= 0 && !w->wanted[sh])
            continue;
        int uniform = sh >= 0 && (w->sign[sh] == 1 || w->sign[sh] == -1);
        int manifold = order_cycle(s, v, sc, uniform || !w->lazy);
        if (manifold)
            s->flag[v] |= STAR_CYCLE;
        if (sh < 0 || !manifold) {
            fail_shells(w, v);
            continue;
        }
        if (sh != current) {
            add_count(w->vertices, current, count);
            current = sh;
            count = 0;
        }
        count++;
        int8_t sign = w->sign[sh];
        if (sign == 1 || sign == -1) {
            if (__atomic_load_n(&w->failed[sh], __ATOMIC_RELAXED))
                continue;
            P c = w->centre + 3 * sh;
            double d[3] = {fabs(c[0] - pv[0]), fabs(c[1] - pv[1]), fabs(c[2] - pv[2])};
            int drop = d[0] <= d[1] ? (d[0] <= d[2] ? 0 : 2) : (d[1] <= d[2] ? 1 : 2);
            for (int64_t i = 0; i < k; i++)
                sc->above[i] = porient(drop, s->V + 3 * sc->link[i], c, pv) > 0;
            if (!one_upward_crossing(sc->above, k))
                __atomic_store_n(&w->failed[sh], 1, __ATOMIC_RELAXED);
        } else if (!w->lazy && star_embedded(s->V, pv, sc->link, k, sc->above)) {
            s->flag[v] |= STAR_EMBEDDED;
            certified++;
        }
    }
    add_count(w->vertices, current, count);
    __atomic_fetch_add(&w->certified, certified, __ATOMIC_RELAXED);
}

static int certify(Stars *s, const int64_t *shell, int64_t n_shells, const uint8_t *wanted, int threads, int lazy,
                   int closed)
{
    ShellWork w;
    memset(&w, 0, sizeof(w));
    w.lazy = lazy;
    w.s = s;
    w.shell = shell;
    w.wanted = wanted;
    w.n_shells = n_shells;
    w.by_degree = closed && lazy && n_shells == 1 && wanted[0];
    int workers = threads < 1 ? 1 : threads;
    w.origin = malloc(sizeof(int64_t) * n_shells);
    /* the sums of each block apart, added in block order, when that is little memory (always for one
     * shell): the centre then does not depend on which thread summed which block */
    int64_t face_blocks = (s->m + FACE_BLOCK - 1) / FACE_BLOCK, vertex_blocks = (s->n + VERTEX_BLOCK - 1) / VERTEX_BLOCK;
    w.sums_per_block = face_blocks * n_shells <= ((int64_t)1 << 16);
    int64_t rows = w.sums_per_block ? face_blocks : workers;
    w.sums = calloc((size_t)(rows ? rows : 1) * n_shells * SUMS, sizeof(double));
    w.centre = malloc(sizeof(double) * 3 * n_shells);
    w.sign = calloc(n_shells, 1);
    w.failed = calloc(n_shells, 1);
    w.faces = calloc(n_shells, sizeof(int64_t));
    w.vertices = calloc(n_shells, sizeof(int64_t));
    w.scratch = calloc(workers, sizeof(Scratch));
    int status = -1, ready = 0;
    if (!w.origin || !w.sums || !w.centre || !w.sign || !w.failed || !w.faces || !w.vertices || !w.scratch)
        goto done;
    for (int64_t sh = 0; sh < n_shells; sh++)
        w.origin[sh] = -1;
    for (int64_t t = 0, found = 0; t < s->m && found < n_shells; t++)
        if (w.origin[shell_at(shell, t)] < 0) {
            w.origin[shell_at(shell, t)] = s->F[3 * t];
            found++;
        }
    parallel_workers(workers, face_blocks, centre_block, &w);
    for (int64_t sh = 0; sh < n_shells; sh++) {
        double row[SUMS] = {0};
        for (int64_t k = 0; k < rows; k++)
            for (int j = 0; j < SUMS; j++)
                row[j] += w.sums[((size_t)k * n_shells + sh) * SUMS + j];
        P o = w.origin[sh] >= 0 ? s->V + 3 * w.origin[sh] : NULL;
        if (!o || !wanted[sh]) {
            w.sign[sh] = SIGN_MIXED;
            continue;
        }
        /* the volume centroid (a tetrahedron's is its corners' mean); the corners' mean when the
         * volume vanishes */
        for (int j = 0; j < 3; j++) {
            double centroid = o[j] + row[1 + j] / (4.0 * row[0]);
            w.centre[3 * sh + j] = isfinite(centroid) ? centroid : o[j] + row[4 + j] / (3.0 * (double)w.faces[sh]);
        }
        for (int j = 0; j < 3; j++)
            if (!isfinite(w.centre[3 * sh + j]))
                w.sign[sh] = SIGN_MIXED;
    }
    parallel_workers(workers, face_blocks, sign_block, &w);
    if (w.by_degree && (w.sign[0] == 1 || w.sign[0] == -1) && degree_certified_any(&w, w.sign[0], workers) == 1) {
        /* the whole search's answer for the shell: embedded, every vertex one cycle; no vertex table */
        s->shell_embedded[0] = 1;
        s->certified_shells = 1;
        s->by_degree = 1;
        status = 0;
        goto done;
    }
    if (build_incidences(s, threads) < 0)
        goto done;
    int64_t max_degree = 3;
    for (int64_t v = 0; v < s->n; v++)
        max_degree = star_degree(s, v) > max_degree ? star_degree(s, v) : max_degree;
    s->max_degree = max_degree;
    while (ready < workers && scratch_init(&w.scratch[ready], max_degree) == 0)
        ready++;
    if (ready == 0)
        goto done;
    workers = ready;                   /* fewer workers: the same certificates */
    parallel_workers(workers, vertex_blocks, vertex_block, &w);
    int again = 0;
    for (int64_t sh = 0; sh < n_shells; sh++) {
        int uniform = w.sign[sh] == 1 || w.sign[sh] == -1;
        s->shell_embedded[sh] = wanted[sh] && uniform && !w.failed[sh] && 2 * w.vertices[sh] - w.faces[sh] == 4;
        s->certified_shells += s->shell_embedded[sh];
        again |= wanted[sh] && uniform && !s->shell_embedded[sh];
    }
    if (again && !w.lazy) {
        w.certify_failed = 1;
        parallel_workers(workers, vertex_blocks, vertex_block, &w);
    }
    s->certified_vertices = w.certified;
    status = 0;
done:
    for (int k = 0; w.scratch && k < ready; k++)
        scratch_free(&w.scratch[k]);
    free(w.origin), free(w.sums), free(w.centre), free(w.sign), free(w.failed), free(w.faces), free(w.vertices),
        free(w.scratch);
    return status;
}

int stars_build(Stars *s, const double *V, const int64_t *F, int64_t n, int64_t m, const int64_t *shell,
                int64_t n_shells, const uint8_t *wanted, int threads)
{
    return stars_build_lazy(s, V, F, n, m, shell, n_shells, wanted, threads, 0, 0);
}

int stars_build_lazy(Stars *s, const double *V, const int64_t *F, int64_t n, int64_t m, const int64_t *shell,
                     int64_t n_shells, const uint8_t *wanted, int threads, int lazy, int closed)
{
    memset(s, 0, sizeof(*s));
    s->V = V;
    s->F = F;
    s->n = n;
    s->m = m;
    s->one_shell = n_shells == 1;
    s->shell_embedded = calloc(n_shells ? n_shells : 1, 1);
    if (!s->shell_embedded || m >= ((int64_t)1 << 30) || certify(s, shell, n_shells, wanted, threads, lazy, closed) < 0) {
        stars_free(s);
        return -1;
    }
    free(s->xy);
    s->xy = NULL;
    return 0;
}

/* ---- star certificates on demand ---------------------------------------------------------- */

typedef struct {
    Stars *s;
    const int64_t *shell;
    const uint8_t *take;
    Scratch *scratch;         /* per worker */
    int64_t certified;
} Corners;

/* The star certificate of each corner of the block's faces taken, each vertex once (the first
 * thread to mark it tried computes it; the result does not depend on which). */
static void corners_block(void *ctx, int worker, int64_t block)
{
    Corners *w = ctx;
    Stars *s = w->s;
    Scratch *sc = &w->scratch[worker];
    int64_t end = (block + 1) * FACE_BLOCK < s->m ? (block + 1) * FACE_BLOCK : s->m, certified = 0;
    for (int64_t t = block * FACE_BLOCK; t < end; t++) {
        if (w->take && !w->take[t])
            continue;
        for (int c = 0; c < 3; c++) {
            int64_t v = s->F[3 * t + c];
            uint8_t flag = __atomic_load_n(&s->flag[v], __ATOMIC_RELAXED);
            if ((flag & STAR_TRIED) || !(flag & STAR_CYCLE))
                continue;
            if (__atomic_fetch_or(&s->flag[v], STAR_TRIED, __ATOMIC_RELAXED) & STAR_TRIED)
                continue;
            int64_t sh = star_shell(s, w->shell, v);
            if (sh < 0 || s->shell_embedded[sh])
                continue;
            if (vertex_star_embedded(s, v, sc)) {
                __atomic_fetch_or(&s->flag[v], STAR_EMBEDDED, __ATOMIC_RELAXED);
                certified++;
            }
        }
    }
    __atomic_fetch_add(&w->certified, certified, __ATOMIC_RELAXED);
}

int stars_certify_corners(Stars *s, const int64_t *shell, const uint8_t *take, int threads)
{
    int workers = threads < 1 ? 1 : threads;
    Corners w = {s, shell, take, calloc(workers, sizeof(Scratch)), 0};
    if (!w.scratch)
        return -1;
    int ready = 0;
    while (ready < workers && scratch_init(&w.scratch[ready], s->max_degree) == 0)
        ready++;
    if (ready > 0)
        parallel_workers(ready, (s->m + FACE_BLOCK - 1) / FACE_BLOCK, corners_block, &w);
    for (int k = 0; k < ready; k++)
        scratch_free(&w.scratch[k]);
    free(w.scratch);
    s->certified_vertices += w.certified;
    return ready > 0 ? 0 : -1;
}

void stars_free(Stars *s)
{
    free(s->begin);
    free(s->ring);
    free(s->flag);
    free(s->xy);
    free(s->shell_embedded);
    memset(s, 0, sizeof(*s));
}
