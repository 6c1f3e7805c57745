/* The arrangement in one compiled call (massprops/mesh/arrangement.py, arrange), when the compiled core settles
 * every face and every piece: the cut (arrange_cut), the patches of uncut faces (patch_labels), the winding
 * numbers of the cells and patches (label_queries), the kept cells fanned and the kept patches' faces
 * (assemble.c), and the kept new corners rounded, made distinct and renumbered (kept_corners).  The same
 * functions, called in the same order with the same arguments as the Python steps they replace, so the
 * answer is the same bit for bit; only the arrays between the steps no longer cross into numpy.  The
 * threads are the steps' own: `threads` for the cut and the exact rounding, `available` for the ray counts
 * when there are more than `parallel_above` / 64 of them.  (Taking threads by the work of a stage instead,
 * whatever the soup's size, made a resolution of 2,560 faces take 2-4 times as long in some runs on a busy
 * machine of two cores: a worker waiting for a core held up the call.)  No answer depends on them.
 *
 * When the cut hands a face back, or a piece's count is not settled, the exact path in Python is needed:
 * then the cut's outputs are returned as arrange() gives them, and Python goes on from there.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "isect.h"

PyObject *py_resolve(PyObject *self, PyObject *args);

static PyObject *bytes_of(const void *data, size_t size)
{
    return PyBytes_FromStringAndSize(size ? (const char *)data : "", (Py_ssize_t)size);
}

/* The cut's outputs as arrange() returns them (kind, status, drop, face, count, corners, inner, points, errors,
 * definitions). */
static PyObject *cut_tuple(const int8_t *kind, int64_t p, const int8_t *status, const int8_t *drop, int64_t m,
                           const Arranged *a)
{
    return Py_BuildValue("NNNNNNNNNN", bytes_of(kind, p), bytes_of(status, m), bytes_of(drop, m),
                         bytes_of(a->face.data, a->face.size), bytes_of(a->count.data, a->count.size),
                         bytes_of(a->corners.data, a->corners.size), bytes_of(a->inner.data, a->inner.size),
                         bytes_of(a->points.data, a->points.size), bytes_of(a->errors.data, a->errors.size),
                         bytes_of(a->defs.data, a->defs.size));
}

typedef struct {
    int64_t *pbegin, *plist, *starts, *label, *qface, *front, *net, *cells, *pieces, *cell_of;
    int64_t *out;             /* the kept uncut faces: the caller's (a bytes object of 3 m int64, made with the GIL) */
    double *qxy, *rows;
    int8_t *owned, *qstatus, *side;
    uint8_t *cut, *outward;
} Work;

static void work_free(Work *w)
{
    free(w->pbegin), free(w->plist), free(w->starts), free(w->label), free(w->qface), free(w->front);
    free(w->net), free(w->cells), free(w->pieces), free(w->cell_of), free(w->qxy), free(w->rows);
    free(w->owned), free(w->qstatus), free(w->side), free(w->cut), free(w->outward);
}

/* The steps after the cut; 1 done, 0 the exact path is needed, -1 memory ran out.  On 1, out/n_out (faces),
 * pieces/n_pieces (triangles), rows/n_rows and *negative hold the arrangement. */
static int assemble_all(const double *V, const int64_t *F, const int64_t *weight, int64_t n, int64_t m,
                        const int64_t *pairs, int64_t p, const int8_t *kind, const int8_t *status,
                        const Arranged *a, int threads, int available, int64_t parallel_above, Work *w,
                        int64_t *n_out, int64_t *n_pieces, int64_t *n_rows, int *negative)
{
    int back = 0;                      /* (one pass without branches) */
    for (int64_t t = 0; t < m; t++)
        back |= status[t] == 2;
    if (back)
        return 0;
    int64_t cells = (int64_t)(a->face.size / sizeof(int64_t));
    const int64_t *face = (const int64_t *)a->face.data, *count = (const int64_t *)a->count.data;
    /* the coplanar partners of each face, in the order of the pairs (as the Python dict of lists); none (NULL)
     * when no pair is coplanar, as a rule */
    int64_t n_partners = 0;
    for (int64_t k = 0; k < p; k++)
        n_partners += 2 * (kind[k] == 2);
    int64_t *per = NULL, *plist_face = NULL;
    if (n_partners) {
        per = calloc(m + 1, sizeof(int64_t));
        plist_face = malloc(n_partners * sizeof(int64_t));
        int64_t *fill = malloc((m ? m : 1) * sizeof(int64_t));
        if (!per || !plist_face || !fill) {
            free(per), free(plist_face), free(fill);
            return -1;
        }
        for (int64_t k = 0; k < p; k++)
            if (kind[k] == 2)
                per[pairs[2 * k] + 1]++, per[pairs[2 * k + 1] + 1]++;
        for (int64_t t = 0; t < m; t++)
            per[t + 1] += per[t];
        memcpy(fill, per, m * sizeof(int64_t));
        for (int64_t k = 0; k < p; k++)
            if (kind[k] == 2) {
                int64_t t = pairs[2 * k], u = pairs[2 * k + 1];
                plist_face[fill[t]++] = u;
                plist_face[fill[u]++] = t;
            }
        free(fill);
    }
    /* the patches of uncut faces, and their roots (the uncut faces labelled by themselves) */
    w->cut = malloc(m ? m : 1);
    w->label = malloc((m ? m : 1) * sizeof(int64_t));
    if (!w->cut || !w->label) {
        free(per), free(plist_face);
        return -1;
    }
    for (int64_t t = 0; t < m; t++)
        w->cut[t] = status[t] == 1;
    if (patch_labels(F, m, n, w->cut, w->label) < 0) {
        free(per), free(plist_face);
        return -1;
    }
    int64_t roots = 0;
    for (int64_t t = 0; t < m; t++)
        roots += !w->cut[t] && w->label[t] == t;
    /* the queries: every cell at its first inner point, then every patch at its root's centroid (NaN) */
    int64_t k = cells + roots;
    w->qface = malloc((k ? k : 1) * sizeof(int64_t));
    w->qxy = malloc((k ? k : 1) * 2 * sizeof(double));
    w->pbegin = malloc((k + 1) * sizeof(int64_t));
    w->front = malloc((k ? k : 1) * sizeof(int64_t));
    w->net = malloc((k ? k : 1) * sizeof(int64_t));
    w->owned = malloc(k ? k : 1);
    w->qstatus = malloc(k ? k : 1);
    int64_t listed = 0;
    for (int64_t c = 0; c < cells && per; c++)
        listed += per[face[c] + 1] - per[face[c]];
    w->plist = malloc((listed ? listed : 1) * sizeof(int64_t));
    if (!w->qface || !w->qxy || !w->pbegin || !w->front || !w->net || !w->owned || !w->qstatus || !w->plist) {
        free(per), free(plist_face);
        return -1;
    }
    const double *inner = (const double *)a->inner.data;
    w->pbegin[0] = 0;
    for (int64_t c = 0; c < cells; c++) {
        int64_t t = face[c], mine = per ? per[t + 1] - per[t] : 0;
        w->qface[c] = t;
        w->qxy[2 * c] = inner[12 * c], w->qxy[2 * c + 1] = inner[12 * c + 1];
        if (mine)
            memcpy(w->plist + w->pbegin[c], plist_face + per[t], mine * sizeof(int64_t));
        w->pbegin[c + 1] = w->pbegin[c] + mine;
    }
    free(per), free(plist_face);
    int64_t q = cells;
    for (int64_t t = 0; t < m; t++)
        if (!w->cut[t] && w->label[t] == t) {
            w->qface[q] = t;
            w->qxy[2 * q] = w->qxy[2 * q + 1] = NAN;
            w->pbegin[q + 1] = w->pbegin[q];
            q++;
        }
    if (k) {
        int label_threads = k * 64 > parallel_above ? available : 1;
        if (label_queries(V, F, weight, m, w->qface, w->qxy, w->pbegin, w->plist, k, label_threads, w->front,
                          w->net, w->owned, w->qstatus) < 0)
            return -1;
        for (int64_t i = 0; i < k; i++)
            if (w->qstatus[i] != 0)
                return 0;
    }
    /* which pieces bound {w > 0}: one side positive, the other not */
    *negative = 0;
    for (int64_t i = 0; i < k; i++)
        if (w->front[i] < 0 || w->front[i] + w->net[i] < 0)
            *negative = 1;
    /* the kept cells fanned (each turned out of the solid) */
    w->cells = malloc((cells ? cells : 1) * sizeof(int64_t));
    w->outward = malloc(cells ? cells : 1);
    w->starts = malloc((cells + 1) * sizeof(int64_t));
    if (!w->cells || !w->outward || !w->starts)
        return -1;
    w->starts[0] = 0;
    for (int64_t c = 0; c < cells; c++)
        w->starts[c + 1] = w->starts[c] + count[c];
    int64_t kept = 0;
    for (int64_t c = 0; c < cells; c++) {
        int64_t front = w->front[c], behind = front + w->net[c];
        if ((front > 0) != (behind > 0) && w->owned[c]) {
            w->cells[kept] = c;
            w->outward[kept++] = behind > 0;
        }
    }
    int64_t triangles = fan_count(w->starts, w->cells, kept);
    w->pieces = malloc((triangles ? triangles : 1) * 3 * sizeof(int64_t));
    if (!w->pieces)
        return -1;
    fan_cells(w->starts, (const int64_t *)a->corners.data, w->cells, w->outward, kept, w->pieces);
    *n_pieces = triangles;
    /* the uncut faces by their patch's side: +1 as they are, -1 turned (after those kept), 0 left out */
    *n_out = 0;
    if (roots) {
        w->side = calloc(m ? m : 1, 1);
        if (!w->side)
            return -1;
        for (int64_t i = cells; i < k; i++) {
            int64_t front = w->front[i], behind = front + w->net[i];
            w->side[w->qface[i]] = (front > 0) != (behind > 0) ? (behind > 0 ? 1 : -1) : 0;
        }
        *n_out = patch_faces(F, m, w->label, w->side, w->out);
    }
    /* the new corners the pieces use, rounded again where their bound exceeds an ulp, distinct, renumbered */
    int64_t qc = (int64_t)(a->points.size / (3 * sizeof(double)));
    w->rows = malloc((qc ? qc : 1) * 6 * sizeof(double));
    if (!w->rows)
        return -1;
    double none = 0.0;
    *n_rows = kept_corners(V, F, n, w->pieces, triangles, (const double *)a->points.data,
                           (const double *)a->errors.data, (const int64_t *)a->defs.data, qc, &none, &none, 0,
                           threads, w->rows);
    return *n_rows < 0 ? -1 : 1;
}

PyObject *py_resolve(PyObject *self, PyObject *args)
{
    PyObject *o[4];
    Py_buffer b[4];
    int threads, available;
    long long parallel_above;
    if (!PyArg_ParseTuple(args, "OOOOiiL", o, o + 1, o + 2, o + 3, &threads, &available, &parallel_above))
        return NULL;
    const Py_ssize_t sizes[4] = {24, 24, 8, 16};
    for (int i = 0; i < 4; i++) {
        int fails = PyObject_GetBuffer(o[i], b + i, PyBUF_C_CONTIGUOUS) < 0;
        if (!fails && b[i].len % sizes[i]) {
            PyErr_SetString(PyExc_ValueError, "resolve: arrays of the wrong shape");
            PyBuffer_Release(b + i);
            fails = 1;
        }
        if (fails) {
            while (i-- > 0)
                PyBuffer_Release(b + i);
            return NULL;
        }
    }
    threads = thread_limit(threads);
    available = thread_limit(available);
    const double *V = b[0].buf;
    const int64_t *F = b[1].buf, *weight = b[2].buf, *pairs = b[3].buf;
    int64_t n = b[0].len / 24, m = b[1].len / 24, p = b[3].len / 16;
    /* (every index in range: as unsigned, a negative one is above the count; one pass without branches) */
    uint64_t out_of_range = 0;
    for (int64_t i = 0; i < 3 * m; i++)
        out_of_range |= (uint64_t)F[i] >= (uint64_t)n;
    uint64_t unpaired = 0;
    for (int64_t k = 0; k < 2 * p; k++)
        unpaired |= (uint64_t)pairs[k] >= (uint64_t)m;
    const char *bad = b[2].len / 8 != m ? "weights need one entry per face"
                      : out_of_range ? "a face names a vertex that does not exist"
                      : unpaired ? "a pair names a face that does not exist" : NULL;
    if (!bad && n > ((int64_t)1 << 31))
        bad = "the vertex count is out of range";
    PyObject *result = NULL;
    if (bad) {
        PyErr_SetString(PyExc_ValueError, bad);
        for (int i = 0; i < 4; i++)
            PyBuffer_Release(b + i);
        return NULL;
    }
    int8_t *kind = malloc(p ? p : 1), *status = malloc(m ? m : 1), *drop = malloc(m ? m : 1);
    /* the kept uncut faces go straight into the bytes returned (at most every face; cut to size after) */
    PyObject *out = PyBytes_FromStringAndSize(NULL, 24 * m);
    Arranged cut;
    memset(&cut, 0, sizeof(cut));
    Work w;
    memset(&w, 0, sizeof(w));
    w.out = out ? (int64_t *)PyBytes_AS_STRING(out) : NULL;
    int code = -1, negative = 0;
    int64_t n_out = 0, n_pieces = 0, n_rows = 0;
    if (kind && status && drop && out) {
        Py_BEGIN_ALLOW_THREADS
        code = arrange_cut(V, F, n, m, pairs, p, threads, kind, status, drop, &cut);
        if (code == 0)
            code = assemble_all(V, F, weight, n, m, pairs, p, kind, status, &cut, threads, available,
                                (int64_t)parallel_above, &w, &n_out, &n_pieces, &n_rows, &negative);
        Py_END_ALLOW_THREADS
    }
    if (code < 0) {
        if (!PyErr_Occurred())
            PyErr_NoMemory();
        Py_XDECREF(out);
    } else if (code == 0) {
        Py_DECREF(out);
        result = cut_tuple(kind, p, status, drop, m, &cut);
    } else if (n_out == m || _PyBytes_Resize(&out, 24 * n_out) == 0) {
        PyObject *pieces = PyByteArray_FromStringAndSize((const char *)w.pieces, 24 * n_pieces);
        result = Py_BuildValue("NNNO", out, pieces, bytes_of(w.rows, 48 * n_rows), negative ? Py_True : Py_False);
    }
    free(kind), free(status), free(drop);
    arranged_free(&cut);
    work_free(&w);
    for (int i = 0; i < 4; i++)
        PyBuffer_Release(b + i);
    return result;
}
