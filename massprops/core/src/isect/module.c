/* massprops.core._intersect: exact triangle intersection and point-in-solid tests (isect.h).
 *
 * Entry points (the GIL is released while they run):
 *   degenerate(V, F, out)            which triangles have zero area (exactly)
 *   pairs(V, F, shell, active, ...)  triangle pairs that intersect (search.c), in threads
 *   certificates(V, F, shell, ...)   which stars and shells are certified embedded (stars.c)
 *   winding(V, F, points)            winding numbers of points off the surface (winding.c)
 *   orient3d_signs(P)                a batch of the predicate
 *   arrange(V, F, pairs, threads)    the arrangement's cut stage (arrange.c)
 *   labels(V, F, weights, ...)       the winding numbers of the arrangement's pieces (arrange.c)
 *   patches(F, cut)                  the arrangement's patches of uncut faces (arrange.c)
 *   swept(V, Q, R, power, ref, F)    the new corners in mesh units and their swept volume's terms (swept.c)
 *   fans, patch_faces, kept_corners: the kept pieces put together (assemble.c)
 *   resolve(V, F, weights, pairs, ...) the arrangement in one call, when the compiled core settles it (resolve.c)
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "isect.h"

/* ---- buffers ------------------------------------------------------------------------------- */

static int get_buffer(PyObject *obj, Py_buffer *view, Py_ssize_t itemsize, int writable, const char *name)
{
    if (PyObject_GetBuffer(obj, view, PyBUF_C_CONTIGUOUS | (writable ? PyBUF_WRITABLE : 0)) < 0)
        return -1;
    if (view->len % itemsize != 0) {
        PyErr_Format(PyExc_ValueError, "%s: expected items of %zd bytes", name, itemsize);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

/* A buffer, or none for None (view->buf NULL; PyBuffer_Release does nothing with it). */
static int get_optional(PyObject *obj, Py_buffer *view, Py_ssize_t itemsize, const char *name)
{
    if (obj != Py_None)
        return get_buffer(obj, view, itemsize, 0, name);
    memset(view, 0, sizeof(*view));
    return 0;
}

/* The buffers of vertices (float64), faces (int64) and a third array; all or none are held. */
static int get_three(PyObject *vo, PyObject *fo, PyObject *xo, Py_buffer *vb, Py_buffer *fb, Py_buffer *xb,
                     Py_ssize_t x_itemsize, int x_writable, const char *x_name)
{
    if (get_buffer(vo, vb, 8, 0, "vertices") < 0)
        return -1;
    if (get_buffer(fo, fb, 8, 0, "faces") < 0) {
        PyBuffer_Release(vb);
        return -1;
    }
    if (get_buffer(xo, xb, x_itemsize, x_writable, x_name) < 0) {
        PyBuffer_Release(vb);
        PyBuffer_Release(fb);
        return -1;
    }
    return 0;
}

/* Faces index vertices [0, n); NULL or a message. */
static const char *bad_faces(const int64_t *F, Py_ssize_t m, Py_ssize_t n)
{
    for (Py_ssize_t i = 0; i < 3 * m; i++)
        if (F[i] < 0 || F[i] >= n)
            return "a face names a vertex that does not exist";
    return NULL;
}

static PyObject *py_degenerate(PyObject *self, PyObject *args)
{
    PyObject *vo, *fo, *oo;
    Py_buffer vb, fb, ob;
    if (!PyArg_ParseTuple(args, "OOO", &vo, &fo, &oo) || get_three(vo, fo, oo, &vb, &fb, &ob, 1, 1, "out") < 0)
        return NULL;
    const double *V = vb.buf;
    const int64_t *F = fb.buf;
    uint8_t *out = ob.buf;
    Py_ssize_t m = fb.len / 24;
    const char *bad = ob.len < m ? "out needs one entry per face" : NULL;
    Py_BEGIN_ALLOW_THREADS
    if (!bad)
        bad = bad_faces(F, m, vb.len / 24);
    for (Py_ssize_t t = 0; t < m && !bad; t++)
        out[t] = !has_area(V + 3 * F[3 * t], V + 3 * F[3 * t + 1], V + 3 * F[3 * t + 2]);   /* filter first */
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&vb);
    PyBuffer_Release(&fb);
    PyBuffer_Release(&ob);
    if (bad) {
        PyErr_SetString(PyExc_ValueError, bad);
        return NULL;
    }
    Py_RETURN_NONE;
}

/* Shell labels in [0, n_shells); NULL or a message. */
static const char *bad_shells(const int64_t *shell, Py_ssize_t m, Py_ssize_t n_shells)
{
    for (Py_ssize_t t = 0; t < m; t++)
        if (shell[t] < 0 || shell[t] >= n_shells)
            return "a shell label is out of range";
    return NULL;
}

static PyObject *py_pairs(PyObject *self, PyObject *args)
{
    PyObject *vo, *fo, *so, *ao;
    Py_ssize_t n_shells, max_examples;
    int within, between, threads, closed = 0;
    if (!PyArg_ParseTuple(args, "OOOOnppni|p", &vo, &fo, &so, &ao, &n_shells, &within, &between, &max_examples,
                          &threads, &closed))
        return NULL;
    if (n_shells < 1 || n_shells >= ((Py_ssize_t)1 << 31) || max_examples < -1) {
        PyErr_SetString(PyExc_ValueError, "shell count or example count out of range");
        return NULL;
    }
    threads = thread_limit(threads);
    /* shell None: every face of shell 0 (n_shells 1); active None: every face */
    Py_buffer vb, fb, sb, ab;
    if (get_buffer(vo, &vb, 8, 0, "vertices") < 0)
        return NULL;
    if (get_buffer(fo, &fb, 8, 0, "faces") < 0) {
        PyBuffer_Release(&vb);
        return NULL;
    }
    if (get_optional(so, &sb, 8, "shell") < 0) {
        PyBuffer_Release(&vb), PyBuffer_Release(&fb);
        return NULL;
    }
    if (get_optional(ao, &ab, 1, "active") < 0) {
        PyBuffer_Release(&vb), PyBuffer_Release(&fb), PyBuffer_Release(&sb);
        return NULL;
    }
    PyObject *result = NULL;
    Py_ssize_t m = fb.len / 24, n = vb.len / 24;
    const char *bad = NULL;
    int status = 0;
    Found found;
    Stars stars;
    memset(&found, 0, sizeof(found));
    memset(&stars, 0, sizeof(stars));
    if ((sb.buf && sb.len / 8 != m) || (ab.buf && ab.len != m))
        bad = "shell and active need one entry per face";
    else if (!sb.buf && n_shells != 1)
        bad = "shell labels are needed for more than one shell";
    if (!bad) {
        Py_BEGIN_ALLOW_THREADS
        bad = bad_faces(fb.buf, m, n);
        if (!bad && sb.buf)
            bad = bad_shells(sb.buf, m, n_shells);
        if (!bad)
            status = search_pairs(vb.buf, fb.buf, sb.buf, ab.buf, n, m, n_shells, within, between, max_examples,
                                  closed, threads, &found, &stars);
        Py_END_ALLOW_THREADS
    }
    if (bad)
        PyErr_SetString(PyExc_ValueError, bad);
    else if (status < 0)
        PyErr_NoMemory();
    else {
        PyObject *flags = PyBytes_FromStringAndSize((const char *)found.self_found, n_shells);
        PyObject *examples = PyBytes_FromStringAndSize((const char *)found.examples, 16 * found.n_examples);
        PyObject *pairs = PyBytes_FromStringAndSize((const char *)found.found, 32 * found.n_found);
        /* Vertices whose faces do not turn once around them (a pinch, an edge of more than two faces):
         * -1 when the stars were not built (then nothing is known). */
        long long pinched = stars.by_degree ? 0 : -1;
        if (stars.flag) {
            pinched = 0;
            for (Py_ssize_t v = 0; v < n; v++)
                pinched += stars.begin[v + 1] > stars.begin[v] && !(stars.flag[v] & STAR_CYCLE);
        }
        if (flags && examples && pairs)
            result = Py_BuildValue("NNNLLLLL", flags, examples, pairs, (long long)found.candidates,
                                   (long long)found.tests, (long long)stars.certified_shells,
                                   (long long)stars.certified_vertices, pinched);
        else {
            Py_XDECREF(flags);
            Py_XDECREF(examples);
            Py_XDECREF(pairs);
        }
    }
    found_free(&found);
    stars_free(&stars);
    PyBuffer_Release(&ab), PyBuffer_Release(&sb), PyBuffer_Release(&fb), PyBuffer_Release(&vb);
    return result;
}

static PyObject *py_certificates(PyObject *self, PyObject *args)
{
    PyObject *vo, *fo, *so;
    Py_ssize_t n_shells;
    int threads;
    if (!PyArg_ParseTuple(args, "OOOni", &vo, &fo, &so, &n_shells, &threads))
        return NULL;
    if (n_shells < 1 || n_shells >= ((Py_ssize_t)1 << 31)) {
        PyErr_SetString(PyExc_ValueError, "shell count out of range");
        return NULL;
    }
    threads = thread_limit(threads);
    Py_buffer vb, fb, sb;
    if (get_three(vo, fo, so, &vb, &fb, &sb, 8, 0, "shell") < 0)
        return NULL;
    Py_ssize_t m = fb.len / 24, n = vb.len / 24;
    const char *bad = sb.len / 8 != m ? "shell needs one entry per face"
                      : m >= ((Py_ssize_t)1 << 30) ? "too many faces" : NULL;
    int status = 0;
    Stars stars;
    memset(&stars, 0, sizeof(stars));
    uint8_t *wanted = calloc(n_shells, 1);
    if (!bad && wanted) {
        memset(wanted, 1, n_shells);
        Py_BEGIN_ALLOW_THREADS
        bad = bad_faces(fb.buf, m, n);
        if (!bad)
            bad = bad_shells(sb.buf, m, n_shells);
        if (!bad)
            status = stars_build(&stars, vb.buf, fb.buf, n, m, sb.buf, n_shells, wanted, threads);
        Py_END_ALLOW_THREADS
    }
    PyObject *result = NULL;
    if (bad)
        PyErr_SetString(PyExc_ValueError, bad);
    else if (!wanted || status < 0)
        PyErr_NoMemory();
    else {
        PyObject *vertices = PyBytes_FromStringAndSize(NULL, n), *shells = PyBytes_FromStringAndSize(NULL, n_shells);
        if (vertices && shells) {
            uint8_t *flag = (uint8_t *)PyBytes_AS_STRING(vertices);
            for (Py_ssize_t v = 0; v < n; v++)
                flag[v] = (stars.flag[v] & STAR_EMBEDDED) != 0;
            memcpy(PyBytes_AS_STRING(shells), stars.shell_embedded, n_shells);
            result = Py_BuildValue("NN", vertices, shells);
        } else {
            Py_XDECREF(vertices);
            Py_XDECREF(shells);
        }
    }
    free(wanted);
    stars_free(&stars);
    PyBuffer_Release(&sb), PyBuffer_Release(&fb), PyBuffer_Release(&vb);
    return result;
}

/* ---- winding numbers by exact ray parity --------------------------------------------------- */

static PyObject *py_winding(PyObject *self, PyObject *args)
{
    PyObject *vo, *fo, *po;
    Py_buffer vb, fb, pb;
    if (!PyArg_ParseTuple(args, "OOO", &vo, &fo, &po) || get_three(vo, fo, po, &vb, &fb, &pb, 8, 0, "points") < 0)
        return NULL;
    Py_ssize_t m = fb.len / 24, k = pb.len / 24;
    PyObject *out = PyBytes_FromStringAndSize(NULL, 8 * k);
    int status = RAY_OK;
    int64_t bad = -1;
    const char *invalid = NULL;
    if (out) {
        Py_BEGIN_ALLOW_THREADS
        invalid = bad_faces(fb.buf, m, vb.len / 24);
        if (!invalid)
            status = winding_numbers(vb.buf, fb.buf, m, pb.buf, k, (int64_t *)PyBytes_AS_STRING(out), &bad);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&vb);
    PyBuffer_Release(&fb);
    PyBuffer_Release(&pb);
    if (!out)
        return NULL;
    if (invalid || status != RAY_OK) {
        Py_DECREF(out);
        if (invalid)
            PyErr_SetString(PyExc_ValueError, invalid);
        else if (status == RAY_MEMORY)
            PyErr_NoMemory();
        else if (status == RAY_ON_SURFACE)
            PyErr_Format(PyExc_ValueError, "point %lld lies on the surface", (long long)bad);
        else
            PyErr_Format(PyExc_RuntimeError, "no generic ray found for point %lld", (long long)bad);
        return NULL;
    }
    return out;
}

/* ---- batches of the predicates -------------------------------------------------------------- */

static PyObject *py_orient3d_signs(PyObject *self, PyObject *args)
{
    PyObject *po;
    if (!PyArg_ParseTuple(args, "O", &po))
        return NULL;
    Py_buffer pb;
    if (get_buffer(po, &pb, 8, 0, "points") < 0)
        return NULL;
    Py_ssize_t k = pb.len / 96;
    PyObject *out = PyBytes_FromStringAndSize(NULL, k);
    if (out) {
        const double *x = pb.buf;
        int8_t *s = (int8_t *)PyBytes_AS_STRING(out);
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t i = 0; i < k; i++)
            s[i] = (int8_t)orient3d(x + 12 * i, x + 12 * i + 3, x + 12 * i + 6, x + 12 * i + 9);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&pb);
    return out;
}

/* ---- the arrangement's cut stage ------------------------------------------------------------- */

static PyObject *buf_bytes(Buf *b) { return PyBytes_FromStringAndSize(b->data ? b->data : "", (Py_ssize_t)b->size); }

static PyObject *py_arrange(PyObject *self, PyObject *args)
{
    PyObject *vo, *fo, *po;
    int threads;
    if (!PyArg_ParseTuple(args, "OOOi", &vo, &fo, &po, &threads))
        return NULL;
    threads = thread_limit(threads);
    Py_buffer vb, fb, pb;
    if (get_three(vo, fo, po, &vb, &fb, &pb, 16, 0, "pairs") < 0)
        return NULL;
    Py_ssize_t m = fb.len / 24, n = vb.len / 24, p = pb.len / 16;
    PyObject *kind = PyBytes_FromStringAndSize(NULL, p), *status = PyBytes_FromStringAndSize(NULL, m);
    PyObject *drop = PyBytes_FromStringAndSize(NULL, m), *result = NULL;
    const char *bad = NULL;
    int code = 0;
    Arranged out;
    memset(&out, 0, sizeof(out));
    if (kind && status && drop) {
        Py_BEGIN_ALLOW_THREADS
        bad = bad_faces(fb.buf, m, n);
        const int64_t *pairs = pb.buf;
        for (Py_ssize_t k = 0; k < 2 * p && !bad; k++)
            if (pairs[k] < 0 || pairs[k] >= m)
                bad = "a pair names a face that does not exist";
        if (!bad)
            code = arrange_cut(vb.buf, fb.buf, n, m, pairs, p, threads, (int8_t *)PyBytes_AS_STRING(kind),
                               (int8_t *)PyBytes_AS_STRING(status), (int8_t *)PyBytes_AS_STRING(drop), &out);
        Py_END_ALLOW_THREADS
        if (bad)
            PyErr_SetString(PyExc_ValueError, bad);
        else if (code < 0)
            PyErr_NoMemory();
        else
        {
            result = Py_BuildValue("NNNNNNNNNN", kind, status, drop, buf_bytes(&out.face), buf_bytes(&out.count),
                                   buf_bytes(&out.corners), buf_bytes(&out.inner), buf_bytes(&out.points),
                                   buf_bytes(&out.errors), buf_bytes(&out.defs));
            kind = status = drop = NULL;          /* taken by Py_BuildValue, also when it fails */
        }
    }
    if (!result) {
        Py_XDECREF(kind);
        Py_XDECREF(status);
        Py_XDECREF(drop);
    }
    arranged_free(&out);
    PyBuffer_Release(&vb), PyBuffer_Release(&fb), PyBuffer_Release(&pb);
    return result;
}

static PyObject *py_labels(PyObject *self, PyObject *args)
{
    PyObject *vo, *fo, *wo, *qo, *xo, *bo, *lo;
    int threads;
    if (!PyArg_ParseTuple(args, "OOOOOOOi", &vo, &fo, &wo, &qo, &xo, &bo, &lo, &threads))
        return NULL;
    threads = thread_limit(threads);
    Py_buffer vb, fb, wb, qb, xb, bb, lb;
    if (get_three(vo, fo, wo, &vb, &fb, &wb, 8, 0, "weights") < 0)
        return NULL;
    if (get_three(qo, xo, bo, &qb, &xb, &bb, 8, 0, "partner starts") < 0) {
        PyBuffer_Release(&vb), PyBuffer_Release(&fb), PyBuffer_Release(&wb);
        return NULL;
    }
    if (get_buffer(lo, &lb, 8, 0, "partners") < 0) {
        PyBuffer_Release(&vb), PyBuffer_Release(&fb), PyBuffer_Release(&wb);
        PyBuffer_Release(&qb), PyBuffer_Release(&xb), PyBuffer_Release(&bb);
        return NULL;
    }
    Py_ssize_t m = fb.len / 24, n = vb.len / 24, k = qb.len / 8, np_ = lb.len / 8;
    PyObject *front = PyBytes_FromStringAndSize(NULL, 8 * k), *net = PyBytes_FromStringAndSize(NULL, 8 * k);
    PyObject *owned = PyBytes_FromStringAndSize(NULL, k), *status = PyBytes_FromStringAndSize(NULL, k);
    PyObject *result = NULL;
    const char *bad = wb.len / 8 != m ? "weights need one entry per face"
                      : xb.len / 16 != k ? "query points need one per query face"
                      : bb.len / 8 != k + 1 ? "partner starts need one per query face and one more" : NULL;
    int code = 0;
    if (front && net && owned && status && !bad) {
        Py_BEGIN_ALLOW_THREADS
        bad = bad_faces(fb.buf, m, n);
        const int64_t *q = qb.buf, *b = bb.buf, *l = lb.buf;
        for (Py_ssize_t i = 0; i < k && !bad; i++)
            if (q[i] < 0 || q[i] >= m || b[i] < 0 || b[i] > b[i + 1] || b[i + 1] > np_)
                bad = "a query names a face or partners that do not exist";
        for (Py_ssize_t i = 0; i < np_ && !bad; i++)
            if (l[i] < 0 || l[i] >= m)
                bad = "a partner names a face that does not exist";
        if (!bad)
            code = label_queries(vb.buf, fb.buf, wb.buf, m, qb.buf, xb.buf, bb.buf, lb.buf, k, threads,
                                 (int64_t *)PyBytes_AS_STRING(front), (int64_t *)PyBytes_AS_STRING(net),
                                 (int8_t *)PyBytes_AS_STRING(owned), (int8_t *)PyBytes_AS_STRING(status));
        Py_END_ALLOW_THREADS
    }
    if (bad)
        PyErr_SetString(PyExc_ValueError, bad);
    else if (front && net && owned && status && code < 0)
        PyErr_NoMemory();
    else if (front && net && owned && status) {
        result = Py_BuildValue("NNNN", front, net, owned, status);
        front = net = owned = status = NULL;
    }
    Py_XDECREF(front);
    Py_XDECREF(net);
    Py_XDECREF(owned);
    Py_XDECREF(status);
    PyBuffer_Release(&vb), PyBuffer_Release(&fb), PyBuffer_Release(&wb), PyBuffer_Release(&qb);
    PyBuffer_Release(&xb), PyBuffer_Release(&bb), PyBuffer_Release(&lb);
    return result;
}

static PyObject *py_patches(PyObject *self, PyObject *args)
{
    PyObject *fo, *co;
    long long n;
    if (!PyArg_ParseTuple(args, "OOL", &fo, &co, &n))
        return NULL;
    if (n < 0 || n > ((int64_t)1 << 31)) {
        PyErr_SetString(PyExc_ValueError, "the vertex count is out of range");
        return NULL;
    }
    Py_buffer fb, cb;
    if (get_buffer(fo, &fb, 24, 0, "faces") < 0)
        return NULL;
    if (get_buffer(co, &cb, 1, 0, "cut") < 0) {
        PyBuffer_Release(&fb);
        return NULL;
    }
    Py_ssize_t m = fb.len / 24;
    PyObject *out = cb.len == m ? PyBytes_FromStringAndSize(NULL, 8 * m) : NULL;
    int code = 0;
    const char *bad = cb.len != m ? "cut needs one entry per face" : NULL;
    if (out) {
        const int64_t *F = fb.buf;
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t i = 0; i < 3 * m && !bad; i++)
            if (F[i] < 0 || F[i] >= n)
                bad = "a face names a vertex out of range";
        if (!bad)
            code = patch_labels(F, m, n, cb.buf, (int64_t *)PyBytes_AS_STRING(out));
        Py_END_ALLOW_THREADS
    }
    /* the patches' roots: the uncut faces labelled by themselves (each patch's lowest face), ascending */
    PyObject *roots = NULL;
    if (out && !bad && code == 0) {
        const int64_t *label = (const int64_t *)PyBytes_AS_STRING(out);
        const uint8_t *cut = cb.buf;
        Py_ssize_t k = 0;
        for (Py_ssize_t t = 0; t < m; t++)
            k += !cut[t] && label[t] == t;
        roots = PyBytes_FromStringAndSize(NULL, 8 * k);
        if (roots) {
            int64_t *root = (int64_t *)PyBytes_AS_STRING(roots);
            for (Py_ssize_t t = 0; t < m; t++)
                if (!cut[t] && label[t] == t)
                    *root++ = t;
        }
    }
    PyBuffer_Release(&fb), PyBuffer_Release(&cb);
    if (bad || code < 0 || !roots) {
        Py_XDECREF(out);
        if (bad)
            PyErr_SetString(PyExc_ValueError, bad);
        else if (code < 0)
            PyErr_NoMemory();
        return NULL;
    }
    return Py_BuildValue("NN", out, roots);
}

static PyObject *py_swept(PyObject *self, PyObject *args)
{
    PyObject *vo, *qo, *ro, *reo, *fo;
    double power;
    if (!PyArg_ParseTuple(args, "OOOdOO", &vo, &qo, &ro, &power, &reo, &fo))
        return NULL;
    Py_buffer vb, qb, rb, eb, fb;
    if (get_three(vo, fo, qo, &vb, &fb, &qb, 24, 0, "points") < 0)
        return NULL;
    if (get_buffer(ro, &rb, 24, 0, "rounding") < 0) {
        PyBuffer_Release(&vb), PyBuffer_Release(&fb), PyBuffer_Release(&qb);
        return NULL;
    }
    if (get_buffer(reo, &eb, 24, 0, "reference") < 0) {
        PyBuffer_Release(&vb), PyBuffer_Release(&fb), PyBuffer_Release(&qb), PyBuffer_Release(&rb);
        return NULL;
    }
    Py_ssize_t n = vb.len / 24, q = qb.len / 24, k = fb.len / 24;
    const char *bad = vb.len % 24 ? "vertices must be (n, 3)"
                      : fb.len % 24 ? "faces must be (k, 3)"
                      : rb.len != qb.len ? "one rounding per point"
                      : eb.len != 24 ? "the reference is one point" : NULL;
    PyObject *points = bad ? NULL : PyBytes_FromStringAndSize(NULL, 24 * (n + q));
    double largest = 0.0, *face_terms = NULL, *wall_terms = NULL;
    int64_t n_faces = 0, n_walls = 0;
    int code = 0;
    if (points) {
        Py_BEGIN_ALLOW_THREADS
        bad = bad_faces(fb.buf, k, n + q);
        if (!bad)
            code = swept_pieces(vb.buf, n, qb.buf, rb.buf, q, power, eb.buf, fb.buf, k,
                                (double *)PyBytes_AS_STRING(points), &largest, &face_terms, &n_faces,
                                &wall_terms, &n_walls);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&vb), PyBuffer_Release(&fb), PyBuffer_Release(&qb), PyBuffer_Release(&rb);
    PyBuffer_Release(&eb);
    PyObject *result = NULL;
    if (points && !bad && code == 0) {
        PyObject *faces = PyBytes_FromStringAndSize((const char *)face_terms, 8 * n_faces);
        PyObject *walls = PyBytes_FromStringAndSize((const char *)wall_terms, 8 * n_walls);
        if (faces && walls)
            result = Py_BuildValue("NNNd", points, faces, walls, largest);
        else
            Py_XDECREF(points), Py_XDECREF(faces), Py_XDECREF(walls);
    } else {
        Py_XDECREF(points);
        if (bad)
            PyErr_SetString(PyExc_ValueError, bad);
        else if (code < 0)
            PyErr_NoMemory();
    }
    free(face_terms), free(wall_terms);
    return result;
}

/* ---- the kept pieces put together (assemble.c) ---------------------------------------------- */

/* Up to four C-contiguous buffers of the item sizes given (0: none); all or none are held. */
static int get_many(PyObject **objs, Py_buffer *views, const Py_ssize_t *itemsizes, const int *writable, int k)
{
    for (int i = 0; i < k; i++)
        if (get_buffer(objs[i], views + i, itemsizes[i], writable[i], "array") < 0) {
            while (i-- > 0)
                PyBuffer_Release(views + i);
            return -1;
        }
    return 0;
}

static void release_many(Py_buffer *views, int k)
{
    for (int i = 0; i < k; i++)
        PyBuffer_Release(views + i);
}

static PyObject *py_fans(PyObject *self, PyObject *args)
{
    PyObject *o[4];
    Py_buffer b[4];
    if (!PyArg_ParseTuple(args, "OOOO", o, o + 1, o + 2, o + 3)
        || get_many(o, b, (Py_ssize_t[]){8, 8, 8, 1}, (int[]){0, 0, 0, 0}, 4) < 0)
        return NULL;
    const int64_t *starts = b[0].buf, *cells = b[2].buf;
    Py_ssize_t n_starts = b[0].len / 8, n_corners = b[1].len / 8, k = b[2].len / 8;
    const char *bad = b[3].len != k ? "one outward flag per cell" : NULL;
    for (Py_ssize_t i = 0; i < k && !bad; i++)
        if (cells[i] < 0 || cells[i] + 1 >= n_starts || starts[cells[i]] < 0
            || starts[cells[i] + 1] - starts[cells[i]] < 2 || starts[cells[i] + 1] > n_corners)
            bad = "a cell does not exist or has fewer than two corners";
    PyObject *out = bad ? NULL : PyBytes_FromStringAndSize(NULL, 24 * fan_count(starts, cells, k));
    if (out)
        fan_cells(starts, b[1].buf, cells, b[3].buf, k, (int64_t *)PyBytes_AS_STRING(out));
    release_many(b, 4);
    if (bad)
        PyErr_SetString(PyExc_ValueError, bad);
    return out;
}

static PyObject *py_patch_faces(PyObject *self, PyObject *args)
{
    PyObject *o[3];
    Py_buffer b[3];
    if (!PyArg_ParseTuple(args, "OOO", o, o + 1, o + 2)
        || get_many(o, b, (Py_ssize_t[]){24, 8, 1}, (int[]){0, 0, 0}, 3) < 0)
        return NULL;
    Py_ssize_t m = b[0].len / 24;
    const int64_t *patch = b[1].buf;
    const char *bad = b[1].len / 8 != m ? "one patch per face" : NULL;
    for (Py_ssize_t t = 0; t < m && !bad; t++)
        if (patch[t] < 0 || patch[t] >= b[2].len)
            bad = "a patch has no side";
    PyObject *out = bad ? NULL : PyBytes_FromStringAndSize(NULL, 24 * m);
    if (out) {
        int64_t k = patch_faces(b[0].buf, m, patch, b[2].buf, (int64_t *)PyBytes_AS_STRING(out));
        if (k < m)
            _PyBytes_Resize(&out, 24 * k);
    }
    release_many(b, 3);
    if (bad)
        PyErr_SetString(PyExc_ValueError, bad);
    return out;
}

/* Point definitions (7 int64 each, as arrange gives them) that name only what exists; NULL or a message. */
static const char *bad_definitions(const int64_t *d, Py_ssize_t k, Py_ssize_t n, Py_ssize_t m)
{
    for (Py_ssize_t i = 0; i < k; i++) {
        int64_t kind = d[7 * i];
        if (kind < 1 || kind > 3 || d[7 * i + 5] < 0 || d[7 * i + 5] > 2 || d[7 * i + 6] < 0 || d[7 * i + 6] > 2)
            return "a point definition is not one the arrangement makes";
        for (int j = 1; j <= (kind == 2 ? 4 : 3); j++) {
            /* LPI: two vertices and a face; EE: four vertices; TPI: three faces */
            int64_t top = kind == 3 || (kind == 1 && j == 3) ? m : n;
            if (d[7 * i + j] < 0 || d[7 * i + j] >= top)
                return "a point definition names something that does not exist";
        }
    }
    return NULL;
}

static PyObject *py_kept_corners(PyObject *self, PyObject *args)
{
    PyObject *o[8];
    Py_buffer b[8];
    int threads;
    if (!PyArg_ParseTuple(args, "OOOOOOOOi", o, o + 1, o + 2, o + 3, o + 4, o + 5, o + 6, o + 7, &threads)
        || get_many(o, b, (Py_ssize_t[]){24, 24, 24, 24, 24, 56, 24, 24}, (int[]){0, 0, 1, 0, 0, 0, 0, 0}, 8) < 0)
        return NULL;
    threads = thread_limit(threads);
    Py_ssize_t n = b[0].len / 24, m = b[1].len / 24, k = b[2].len / 24, qc = b[3].len / 24, qe = b[6].len / 24;
    const int64_t *T = b[2].buf;
    const char *bad = b[4].len != b[3].len || b[5].len / 56 != qc ? "one rounding and one definition per point"
                      : b[7].len != b[6].len ? "one rounding per exact point" : NULL;
    if (!bad)
        bad = bad_faces(b[1].buf, m, n);
    if (!bad)
        bad = bad_definitions(b[5].buf, qc, n, m);
    for (Py_ssize_t i = 0; i < 3 * k && !bad; i++)
        if (T[i] < 0 || T[i] >= n + qc + qe)
            bad = "a triangle names a corner that does not exist";
    PyObject *out = bad ? NULL : PyBytes_FromStringAndSize(NULL, 48 * (qc + qe));
    if (out) {
        int64_t r;
        Py_BEGIN_ALLOW_THREADS
        r = kept_corners(b[0].buf, b[1].buf, n, b[2].buf, k, b[3].buf, b[4].buf, b[5].buf, qc, b[6].buf, b[7].buf,
                         qe, threads, (double *)PyBytes_AS_STRING(out));
        Py_END_ALLOW_THREADS
        if (r < 0) {
            Py_CLEAR(out);
            PyErr_NoMemory();
        } else if (r < qc + qe)
            _PyBytes_Resize(&out, 48 * r);
    }
    release_many(b, 8);
    if (bad)
        PyErr_SetString(PyExc_ValueError, bad);
    return out;
}

PyObject *py_resolve(PyObject *self, PyObject *args);   /* resolve.c */

static PyMethodDef methods[] = {
    {"degenerate", py_degenerate, METH_VARARGS,
     "degenerate(vertices, faces, out): out[t] = 1 where face t has zero area, exactly."},
    {"pairs", py_pairs, METH_VARARGS,
     "pairs(vertices, faces, shell (None: all of shell 0), active (None: all), n_shells, within, between, max_examples (-1: every meeting pair, within and between shells), threads,\n"
     "closed=False (every edge used as often each way: a one-shell search may certify the shell by its degree))\n"
     "-> (self_found bytes, examples int64 pairs, found int64 quads, candidates, tests, certified shells,\n"
     "certified vertices, vertices whose faces do not turn once around them or -1)"},
    {"certificates", py_certificates, METH_VARARGS,
     "certificates(vertices, faces, shell, n_shells, threads) -> (per vertex: star certified embedded,\n"
     "per shell: shell certified embedded), bytes of 0/1"},
    {"winding", py_winding, METH_VARARGS, "winding(vertices, faces, points) -> int64 winding numbers (bytes)"},
    {"orient3d_signs", py_orient3d_signs, METH_VARARGS, "orient3d_signs(points (k, 4, 3)) -> int8 signs (bytes)"},
    {"arrange", py_arrange, METH_VARARGS,
     "arrange(vertices, faces, pairs (p, 2), threads) -> (kind int8 per pair, status int8 per face, drop int8 per\n"
     "face, cell faces int64, corner counts int64, corners int64, inner points (c, 6, 2) float64, new points (q, 3),\n"
     "their errors (q, 3)) (bytes): the arrangement's cut stage (arrange.c)"},
    {"labels", py_labels, METH_VARARGS,
     "labels(vertices, faces, weights, query faces, query points (k, 2) or NaN, partner starts (k + 1),\n"
     "partners, threads) -> (winding numbers int64, net weights int64, owned int8, status int8: 0 answered,\n"
     "1 handed back, 2 no certified point) (bytes) (arrange.c)"},
    {"patches", py_patches, METH_VARARGS,
     "patches(faces, cut uint8, vertex count) -> (int64 labels, int64 roots) (bytes): uncut faces joined across edges two faces\n"
     "use once each way share a label, their lowest face (a root) (arrange.c)"},
    {"swept", py_swept, METH_VARARGS,
     "swept(vertices, new points (q, 3) scaled, their rounding (q, 3), power, reference (3), pieces (k, 3))\n"
     "-> (vertices and new points in mesh units (bytes), terms per face around a moved corner (bytes), terms\n"
     "per uncancelled directed edge (bytes), largest move) (swept.c)"},
    {"fans", py_fans, METH_VARARGS,
     "fans(starts, corners, cells, outward uint8) -> int64 triangles (bytes): the cells fanned (assemble.c)"},
    {"patch_faces", py_patch_faces, METH_VARARGS,
     "patch_faces(faces, patch, side int8 per patch) -> int64 faces (bytes): side > 0 as they are, then side < 0\n"
     "reversed (assemble.c)"},
    {"kept_corners", py_kept_corners, METH_VARARGS,
     "kept_corners(vertices, faces, triangles (writable), points, rounding, definitions (q, 7), exact points,\n"
     "their rounding, threads) -> float64 rows (r, 6) (bytes): the new corners the triangles use, the compiled\n"
     "cut's rounded again from their exact values where their bound exceeds an ulp, distinct in lexicographic\n"
     "order; the triangles' new corners renumbered to n + their row (assemble.c)"},
    {"resolve", py_resolve, METH_VARARGS,
     "resolve(vertices, faces, weights, pairs, threads, available threads, parallel above) -> (faces, pieces\n"
     "(bytearray), corner rows (r, 6), negative) when the compiled core settles every face and piece, else the\n"
     "ten outputs of arrange(): the arrangement's steps in one call (resolve.c)"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_intersect", NULL, -1, methods};

PyMODINIT_FUNC PyInit__intersect(void)
{
    return PyModule_Create(&module);
}
