/* The arrangement's kept pieces put together (massprops/mesh/arrangement.py, arrange): the cells fanned into
 * triangles, the uncut faces taken by their patch's side, and the new corners the kept triangles use
 * numbered once per distinct rounded point.  Integers and comparisons only: the same triangles, in the same
 * order, as the numpy it replaces.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "isect.h"

int64_t fan_count(const int64_t *starts, const int64_t *cells, int64_t k)
{
    int64_t total = 0;
    for (int64_t i = 0; i < k; i++)
        total += starts[cells[i] + 1] - starts[cells[i]] - 2;
    return total;
}

void fan_cells(const int64_t *starts, const int64_t *corners, const int64_t *cells, const uint8_t *outward,
               int64_t k, int64_t *out)
{
    for (int64_t i = 0; i < k; i++) {
        int64_t start = starts[cells[i]], count = starts[cells[i] + 1] - start;
        int64_t last = start + count - 1;
        for (int64_t step = 1; step <= count - 2; step++, out += 3) {
            if (outward[i])
                out[0] = corners[start], out[1] = corners[start + step], out[2] = corners[start + step + 1];
            else             /* a cell turned inward is fanned from its last corner */
                out[0] = corners[last], out[1] = corners[last - step], out[2] = corners[last - step - 1];
        }
    }
}

int64_t patch_faces(const int64_t *F, int64_t m, const int64_t *patch, const int8_t *side, int64_t *out)
{
    int64_t o = 0;
    for (int64_t t = 0; t < m; t++)
        if (side[patch[t]] > 0)
            memcpy(out + 3 * o++, F + 3 * t, 3 * sizeof(int64_t));
    for (int64_t t = 0; t < m; t++)
        if (side[patch[t]] < 0) {
            out[3 * o] = F[3 * t + 2], out[3 * o + 1] = F[3 * t + 1], out[3 * o + 2] = F[3 * t];
            o++;
        }
    return o;
}

int64_t used_corners(const int64_t *T, int64_t k, int64_t n, int64_t q, int64_t *used)
{
    uint8_t *seen = calloc(q > 0 ? q : 1, 1);
    if (!seen)
        return -1;
    for (int64_t i = 0; i < 3 * k; i++)
        if (T[i] >= n && T[i] - n < q)
            seen[T[i] - n] = 1;
    int64_t u = 0;
    for (int64_t j = 0; j < q; j++)
        if (seen[j])
            used[u++] = j;
    free(seen);
    return u;
}

/* numpy's order for doubles: NaN last */
static inline int lt(double a, double b) { return a < b || (b != b && a == a); }

typedef struct {
    const double *row;
    int64_t index;
} Row;

static int row_order(const void *x, const void *y)
{
    const Row *p = x, *q = y;
    for (int c = 0; c < 6; c++) {
        if (lt(p->row[c], q->row[c]))
            return -1;
        if (lt(q->row[c], p->row[c]))
            return 1;
    }
    return (p->index > q->index) - (p->index < q->index);        /* stable, as np.lexsort */
}

int64_t distinct_corners(const double *table, int64_t u, const int64_t *used, int64_t q, int64_t n, int64_t *T,
                         int64_t k, double *rows)
{
    Row *order = malloc(sizeof(Row) * (u > 0 ? u : 1));
    int64_t *renumber = malloc(sizeof(int64_t) * (q > 0 ? q : 1));
    if (!order || !renumber) {
        free(order), free(renumber);
        return -1;
    }
    for (int64_t i = 0; i < u; i++)
        order[i] = (Row){table + 6 * i, i};
    qsort(order, u, sizeof(Row), row_order);
    int64_t r = -1;
    for (int64_t i = 0; i < u; i++) {
        const double *row = order[i].row;
        int differs = i == 0;
        for (int c = 0; c < 6 && !differs; c++)
            differs = row[c] != rows[6 * r + c];
        if (differs)
            memcpy(rows + 6 * ++r, row, 6 * sizeof(double));
        renumber[used[order[i].index]] = r + n;
    }
    for (int64_t i = 0; i < 3 * k; i++)
        if (T[i] >= n)
            T[i] = renumber[T[i] - n];
    free(order), free(renumber);
    return r + 1;
}

/* numpy's spacing of a magnitude: the gap to the next double up */
static inline double spacing(double a) { return nextafter(a, INFINITY) - a; }

int64_t kept_corners(const double *V, const int64_t *F, int64_t n, int64_t *T, int64_t k, const double *P,
                     const double *R, const int64_t *defs, int64_t qc, const double *EP, const double *ER, int64_t qe,
                     int threads, double *rows)
{
    int64_t q = qc + qe;
    int64_t *used = malloc(sizeof(int64_t) * (q > 0 ? q : 1));
    double *table = malloc(sizeof(double) * 6 * (q > 0 ? q : 1));
    int64_t *loose = malloc(sizeof(int64_t) * (qc > 0 ? qc : 1));
    int64_t *ldefs = malloc(sizeof(int64_t) * 7 * (qc > 0 ? qc : 1));
    double *lq = malloc(sizeof(double) * 3 * (qc > 0 ? qc : 1)), *le = malloc(sizeof(double) * 3 * (qc > 0 ? qc : 1));
    int64_t u = -1, r = -1;
    if (used && table && loose && ldefs && lq && le)
        u = used_corners(T, k, n, q, used);
    if (u >= 0) {
        int64_t nl = 0, i = 0;
        for (; i < u && used[i] < qc; i++) {
            const double *p = P + 3 * used[i], *e = R + 3 * used[i];
            memcpy(table + 6 * i, p, 3 * sizeof(double));
            memcpy(table + 6 * i + 3, e, 3 * sizeof(double));
            /* rounded again from the exact value where the filter's bound exceeds a unit in the last place */
            if (e[0] > spacing(fabs(p[0])) || e[1] > spacing(fabs(p[1])) || e[2] > spacing(fabs(p[2]))) {
                memcpy(ldefs + 7 * nl, defs + 7 * used[i], 7 * sizeof(int64_t));
                memcpy(lq + 3 * nl, p, 3 * sizeof(double));
                memcpy(le + 3 * nl, e, 3 * sizeof(double));
                loose[nl++] = i;
            }
        }
        if (nl)
            refine_points(V, F, ldefs, nl, lq, le, threads);
        for (int64_t j = 0; j < nl; j++) {
            memcpy(table + 6 * loose[j], lq + 3 * j, 3 * sizeof(double));
            memcpy(table + 6 * loose[j] + 3, le + 3 * j, 3 * sizeof(double));
        }
        for (; i < u; i++) {
            memcpy(table + 6 * i, EP + 3 * (used[i] - qc), 3 * sizeof(double));
            memcpy(table + 6 * i + 3, ER + 3 * (used[i] - qc), 3 * sizeof(double));
        }
        r = distinct_corners(table, u, used, q, n, T, k, rows);
    }
    free(used), free(table), free(loose), free(ldefs), free(lq), free(le);
    return r;
}
