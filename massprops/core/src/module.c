/* massprops.core._core: the CPython face of the compiled core.
 *
 * Arguments arrive through the buffer protocol (C-contiguous float64,
 * float32, int32 or int64 arrays), results leave as Buffer objects that own
 * their memory and export it (PEP 3118) with a format and a shape, so
 * numpy.asarray views them without a copy.  The GIL is released around every
 * call into the C functions; failures raised there become ParseError
 * (ValueError: a malformed file, with a message and a fix), OSError,
 * IndexError, ValueError or MemoryError here.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "core.h"
#include "kernel.h"
#include "topology.h"

#include <stdlib.h>
#include <string.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

static PyObject *ParseError;

/* ---- Buffer ------------------------------------------------------------------------------ */

typedef struct {
    PyObject_HEAD
    void *data;
    Py_ssize_t shape[2], strides[2];
    int ndim;
    char format[2];
    Py_ssize_t itemsize;
} BufferObject;

static void buffer_dealloc(BufferObject *self)
{
    free(self->data);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int buffer_get(BufferObject *self, Py_buffer *view, int flags)
{
    view->obj = (PyObject *)self;
    Py_INCREF(self);
    view->buf = self->data;
    view->len = self->itemsize * self->shape[0] * (self->ndim == 2 ? self->shape[1] : 1);
    view->readonly = 0;
    view->itemsize = self->itemsize;
    view->format = (flags & PyBUF_FORMAT) ? self->format : NULL;
    view->ndim = self->ndim;
    view->shape = (flags & PyBUF_ND) ? self->shape : NULL;
    view->strides = (flags & PyBUF_STRIDES) ? self->strides : NULL;
    view->suboffsets = NULL;
    view->internal = NULL;
    return 0;
}

static PyBufferProcs buffer_procs = {(getbufferproc)buffer_get, NULL};

static PyTypeObject BufferType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "massprops.core._core.Buffer",
    .tp_basicsize = sizeof(BufferObject),
    .tp_dealloc = (destructor)buffer_dealloc,
    .tp_as_buffer = &buffer_procs,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Memory owned by the compiled core, exported through the buffer protocol.",
};

/* Wrap malloc'd memory (taking ownership; freed here on failure). */
static PyObject *buffer_wrap(void *data, char format, Py_ssize_t itemsize, Py_ssize_t rows, Py_ssize_t columns)
{
    BufferObject *b = PyObject_New(BufferObject, &BufferType);
    if (!b) {
        free(data);
        return NULL;
    }
    b->data = data;
    b->format[0] = format;
    b->format[1] = '\0';
    b->itemsize = itemsize;
    b->ndim = columns > 0 ? 2 : 1;
    b->shape[0] = rows;
    b->shape[1] = columns > 0 ? columns : 1;
    b->strides[0] = itemsize * (columns > 0 ? columns : 1);
    b->strides[1] = itemsize;
    return (PyObject *)b;
}

/* Two arrays of n doubles as a tuple of Buffers (taking ownership of both). */
static PyObject *double_pair(double *first, double *second, Py_ssize_t n)
{
    PyObject *a = buffer_wrap(first, 'd', 8, n, 0), *b = a ? buffer_wrap(second, 'd', 8, n, 0) : NULL;
    if (!a || !b) {
        if (!a)
            free(second);
        Py_XDECREF(a);
        return NULL;
    }
    return Py_BuildValue("(NN)", a, b);
}

/* ---- arguments ------------------------------------------------------------------------------ */

enum { ARRAY_F64 = 1, ARRAY_F32 = 2, ARRAY_I32 = 4, ARRAY_I64 = 8 };

/* A C-contiguous buffer of one of the accepted kinds; returns its kind, or 0 with an exception. */
static int get_array(PyObject *object, Py_buffer *view, int accepted, const char *name)
{
    const char *f;
    int kind = 0;
    if (PyObject_GetBuffer(object, view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) != 0)
        return 0;
    f = view->format ? view->format : "B";
    while (*f == '@' || *f == '=' || *f == '<')
        f++;
    if (f[1] == '\0') {
        if (*f == 'd' && view->itemsize == 8)
            kind = ARRAY_F64;
        else if (*f == 'f' && view->itemsize == 4)
            kind = ARRAY_F32;
        else if ((*f == 'i' || *f == 'l' || *f == 'q') && view->itemsize == 4)
            kind = ARRAY_I32;
        else if ((*f == 'l' || *f == 'q') && view->itemsize == 8)
            kind = ARRAY_I64;
    }
    if (!(kind & accepted)) {
        PyErr_Format(PyExc_TypeError, "%s: expected a C-contiguous array of %s, got format '%s'", name,
                     accepted & ARRAY_I64 ? "int32 or int64" : accepted & ARRAY_F32 ? "float32 or float64" : "float64",
                     view->format ? view->format : "B");
        PyBuffer_Release(view);
        return 0;
    }
    return kind;
}

static PyObject *raise_failure(const Failure *failure, PyObject *path)
{
    switch (failure->kind) {
    case ERR_PARSE: {
        /* a line quoted from the file may hold any bytes: shown as Python shows undecodable bytes */
        PyObject *args = Py_BuildValue("(NN)",
                                       PyUnicode_DecodeUTF8(failure->message, (Py_ssize_t)strlen(failure->message),
                                                            "backslashreplace"),
                                       PyUnicode_DecodeUTF8(failure->fix, (Py_ssize_t)strlen(failure->fix),
                                                            "backslashreplace"));
        if (args) {
            PyErr_SetObject(ParseError, args);
            Py_DECREF(args);
        }
        break;
    }
    case ERR_OS:
        errno = failure->os_errno;
        PyErr_SetFromErrnoWithFilenameObject(PyExc_OSError, path);
        break;
    case ERR_INDEX:
        PyErr_SetString(PyExc_IndexError, failure->message);
        break;
    case ERR_MEMORY:
        PyErr_SetString(PyExc_MemoryError, failure->message);
        break;
    default:
        PyErr_SetString(PyExc_ValueError, failure->message);
    }
    return NULL;
}

static PyObject *mesh_result(MeshArrays *mesh, int with_binary)
{
    PyObject *vertices = buffer_wrap(mesh->vertices, 'd', 8, (Py_ssize_t)mesh->n, 3), *faces;
    mesh->vertices = NULL;
    faces = buffer_wrap(mesh->faces, 'q', 8, (Py_ssize_t)mesh->m, 3);
    mesh->faces = NULL;
    if (!vertices || !faces) {
        Py_XDECREF(vertices);
        Py_XDECREF(faces);
        return NULL;
    }
    if (with_binary)
        return Py_BuildValue("(NNO)", vertices, faces, mesh->binary ? Py_True : Py_False);
    return Py_BuildValue("(NNL)", vertices, faces, (long long)mesh->ignored);
}

/* ---- readers and welding ------------------------------------------------------------------ */

static PyObject *read_file(PyObject *args, int stl)
{
    PyObject *path;
    MeshArrays mesh = {0};
    Failure failure = {0};
    int status, threads = 1;
    if (!PyArg_ParseTuple(args, stl ? "O&i" : "O&|i", PyUnicode_FSConverter, &path, &threads))
        return NULL;
    Py_BEGIN_ALLOW_THREADS
    status = stl ? read_stl(PyBytes_AS_STRING(path), threads, &mesh, &failure)
                 : read_obj(PyBytes_AS_STRING(path), threads, &mesh, &failure);
    Py_END_ALLOW_THREADS
    if (status != 0) {
        PyObject *name = PyUnicode_DecodeFSDefault(PyBytes_AS_STRING(path));
        raise_failure(&failure, name);
        Py_XDECREF(name);
        Py_DECREF(path);
        return NULL;
    }
    Py_DECREF(path);
    return mesh_result(&mesh, stl);
}

static PyObject *core_read_stl(PyObject *self, PyObject *args) { return read_file(args, 1); }
static PyObject *core_read_obj(PyObject *self, PyObject *args) { return read_file(args, 0); }

static PyObject *core_weld_corners(PyObject *self, PyObject *args)
{
    PyObject *object;
    Py_buffer view;
    MeshArrays mesh = {0};
    Failure failure = {0};
    int kind, status, threads;
    Py_ssize_t count;
    if (!PyArg_ParseTuple(args, "Oi", &object, &threads)
            || !(kind = get_array(object, &view, ARRAY_F64 | ARRAY_F32, "corners")))
        return NULL;
    count = view.len / view.itemsize;
    if (count % 9) {
        PyBuffer_Release(&view);
        PyErr_SetString(PyExc_ValueError, "corners: expected 3 points of 3 coordinates per triangle");
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS
    status = weld_corners(view.buf, kind == ARRAY_F32, count / 9, threads, &mesh, &failure);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&view);
    return status ? raise_failure(&failure, NULL) : mesh_result(&mesh, 0);
}

static PyObject *core_weld_indexed(PyObject *self, PyObject *args)
{
    PyObject *vertex_object, *face_object;
    Py_buffer vertices, faces;
    MeshArrays mesh = {0};
    Failure failure = {0};
    int kind, status, threads = 1;
    if (!PyArg_ParseTuple(args, "OO|i", &vertex_object, &face_object, &threads)
            || !get_array(vertex_object, &vertices, ARRAY_F64, "vertices"))
        return NULL;
    if (!(kind = get_array(face_object, &faces, ARRAY_I32 | ARRAY_I64, "faces"))) {
        PyBuffer_Release(&vertices);
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS
    status = weld_indexed(vertices.buf, vertices.len / 24, faces.buf, kind == ARRAY_I32,
                          faces.len / faces.itemsize / 3, threads, &mesh, &failure);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&vertices);
    PyBuffer_Release(&faces);
    return status ? raise_failure(&failure, NULL) : mesh_result(&mesh, 0);
}

/* ---- topology ------------------------------------------------------------------------------ */

/* An EdgeSummary as the dict topology.py makes an EdgeSummary of. */
static PyObject *summary_dict(const EdgeSummary *s)
{
    return Py_BuildValue("{sLsLsLsLsLsLsLsLs(LL)s(LL)}", "edges", (long long)s->edges, "boundary",
                         (long long)s->boundary, "odd", (long long)s->odd, "unbalanced", (long long)s->unbalanced,
                         "nonmanifold", (long long)s->nonmanifold, "max_uses", (long long)s->max_uses, "collapsed",
                         (long long)s->collapsed, "degenerate_faces", (long long)s->degenerate_faces,
                         "first_boundary", (long long)s->first_boundary[0], (long long)s->first_boundary[1],
                         "first_unbalanced", (long long)s->first_unbalanced[0], (long long)s->first_unbalanced[1]);
}

static PyObject *core_edge_summary(PyObject *self, PyObject *args)
{
    PyObject *face_object, *result;
    Py_buffer faces;
    Py_ssize_t n;
    int threads, with_arrays, kind, status;
    EdgeSummary s;
    EdgeArrays arrays = {0};
    Failure failure = {0};
    if (!PyArg_ParseTuple(args, "Onip", &face_object, &n, &threads, &with_arrays)
            || !(kind = get_array(face_object, &faces, ARRAY_I32 | ARRAY_I64, "faces")))
        return NULL;
    Py_BEGIN_ALLOW_THREADS
    status = edge_summary(faces.buf, kind == ARRAY_I32, faces.len / faces.itemsize / 3, n, threads, &s,
                          with_arrays ? &arrays : NULL, &failure);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&faces);
    if (status) {
        free(arrays.edges);
        free(arrays.uses);
        free(arrays.balance);
        return raise_failure(&failure, NULL);
    }
    result = summary_dict(&s);
    if (result && with_arrays) {
        PyObject *edges = buffer_wrap(arrays.edges, 'q', 8, (Py_ssize_t)arrays.count, 2);
        PyObject *uses = buffer_wrap(arrays.uses, 'i', 4, (Py_ssize_t)arrays.count, 0);
        PyObject *balance = buffer_wrap(arrays.balance, 'i', 4, (Py_ssize_t)arrays.count, 0);
        if (!edges || !uses || !balance || PyDict_SetItemString(result, "edge_vertices", edges)
                || PyDict_SetItemString(result, "uses", uses) || PyDict_SetItemString(result, "balance", balance))
            Py_CLEAR(result);
        Py_XDECREF(edges);
        Py_XDECREF(uses);
        Py_XDECREF(balance);
    }
    return result;
}

static PyObject *core_edge_shells(PyObject *self, PyObject *args)
{
    PyObject *face_object, *summary;
    Py_buffer faces;
    Py_ssize_t n, m;
    int threads, kind, status;
    EdgeSummary s;
    ShellResult shells = {0, NULL};
    Failure failure = {0};
    if (!PyArg_ParseTuple(args, "Oni", &face_object, &n, &threads)
            || !(kind = get_array(face_object, &faces, ARRAY_I32 | ARRAY_I64, "faces")))
        return NULL;
    m = faces.len / faces.itemsize / 3;
    Py_BEGIN_ALLOW_THREADS
    status = edge_shells(faces.buf, kind == ARRAY_I32, m, n, threads, &s, &shells, &failure);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&faces);
    if (status) {
        free(shells.labels);
        return raise_failure(&failure, NULL);
    }
    if (!(summary = summary_dict(&s))) {
        free(shells.labels);
        return NULL;
    }
    if (!shells.labels)
        return Py_BuildValue("(NOL)", summary, Py_None, (long long)shells.count);
    return Py_BuildValue("(NNL)", summary, buffer_wrap(shells.labels, 'q', 8, m, 0), (long long)shells.count);
}

static PyObject *core_shells(PyObject *self, PyObject *args)
{
    PyObject *face_object;
    Py_buffer faces;
    Py_ssize_t n, m;
    int with_labels, kind, status;
    int64_t count = 0, *labels = NULL;
    Failure failure = {0};
    if (!PyArg_ParseTuple(args, "Onp", &face_object, &n, &with_labels)
            || !(kind = get_array(face_object, &faces, ARRAY_I32 | ARRAY_I64, "faces")))
        return NULL;
    m = faces.len / faces.itemsize / 3;
    if (with_labels && !(labels = malloc((size_t)(m > 0 ? m : 1) * sizeof *labels))) {
        PyBuffer_Release(&faces);
        return PyErr_NoMemory();
    }
    Py_BEGIN_ALLOW_THREADS
    status = face_shells(faces.buf, kind == ARRAY_I32, m, n, labels, &count, &failure);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&faces);
    if (status) {
        free(labels);
        return raise_failure(&failure, NULL);
    }
    if (!with_labels)
        return Py_BuildValue("(OL)", Py_None, (long long)count);
    return Py_BuildValue("(NL)", buffer_wrap(labels, 'q', 8, m, 0), (long long)count);
}

static PyObject *core_unused_vertices(PyObject *self, PyObject *args)
{
    PyObject *face_object;
    Py_buffer faces;
    Py_ssize_t n;
    int kind, outside, status;
    int64_t unused;
    if (!PyArg_ParseTuple(args, "On", &face_object, &n)
            || !(kind = get_array(face_object, &faces, ARRAY_I32 | ARRAY_I64, "faces")))
        return NULL;
    Py_BEGIN_ALLOW_THREADS
    status = unused_vertices(faces.buf, kind == ARRAY_I32, faces.len / faces.itemsize / 3, n, &unused, &outside);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&faces);
    if (status)
        return PyErr_NoMemory();
    return Py_BuildValue("(LO)", (long long)unused, outside ? Py_True : Py_False);
}

static PyObject *core_row_groups(PyObject *self, PyObject *args)
{
    PyObject *row_object, *labels_buffer, *first_buffer;
    Py_buffer rows;
    Py_ssize_t m;
    int kind, status, columns;
    int64_t *labels, *first, groups = 0, same = 0, opposite = 0;
    Failure failure = {0};
    if (!PyArg_ParseTuple(args, "Oi", &row_object, &columns)
            || !(kind = get_array(row_object, &rows, ARRAY_I32 | ARRAY_I64, "rows")))
        return NULL;
    m = columns > 0 ? rows.len / rows.itemsize / columns : 0;
    labels = malloc((size_t)(m > 0 ? m : 1) * sizeof *labels);
    first = malloc((size_t)(m > 0 ? m : 1) * sizeof *first);
    if (!labels || !first) {
        free(labels);
        free(first);
        PyBuffer_Release(&rows);
        return PyErr_NoMemory();
    }
    Py_BEGIN_ALLOW_THREADS
    status = row_groups(rows.buf, kind == ARRAY_I32, columns, m, labels, first, &groups, &same, &opposite, &failure);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&rows);
    if (status) {
        free(labels);
        free(first);
        return raise_failure(&failure, NULL);
    }
    labels_buffer = buffer_wrap(labels, 'q', 8, m, 0);
    first_buffer = labels_buffer ? buffer_wrap(first, 'q', 8, (Py_ssize_t)groups, 0) : NULL;
    if (!labels_buffer || !first_buffer) {
        if (!labels_buffer)
            free(first);
        Py_XDECREF(labels_buffer);
        return NULL;
    }
    return Py_BuildValue("(NNLL)", labels_buffer, first_buffer, (long long)same, (long long)opposite);
}

/* ---- the kernel ---------------------------------------------------------------------------- */

/* Fill a KernelInput from (vertices, faces, (rx, ry, rz), scale_exp, radius); buffers to release. */
static int kernel_input(PyObject *vertex_object, PyObject *face_object, PyObject *reference, int scale_exp,
                        double radius, KernelInput *in, Py_buffer *vertices, Py_buffer *faces, int columns)
{
    int kind;
    memset(in, 0, sizeof *in);
    if (!PyArg_ParseTuple(reference, "ddd", &in->reference[0], &in->reference[1], &in->reference[2]))
        return -1;
    if (!get_array(vertex_object, vertices, ARRAY_F64, "vertices"))
        return -1;
    if (!(kind = get_array(face_object, faces, ARRAY_I32 | ARRAY_I64, "faces"))) {
        PyBuffer_Release(vertices);
        return -1;
    }
    in->vertices = vertices->buf;
    in->n = vertices->len / 24;
    in->faces = faces->buf;
    in->faces32 = kind == ARRAY_I32;
    in->m = faces->len / faces->itemsize / columns;
    in->scale_exp = scale_exp;
    in->radius = radius;
    return 0;
}

static PyObject *core_integrate(PyObject *self, PyObject *args, PyObject *kwargs)
{
    static char *names[] = {"vertices", "faces", "reference", "scale_exp", "radius", "order", "area", "weights",
                            "threads", "double_double", "scaled", NULL};
    PyObject *vertex_object, *face_object, *reference, *weight_object = Py_None, *scaled_object = Py_None;
    Py_buffer vertices, faces, weights = {0}, scaled = {0};
    KernelInput in;
    KernelResult out;
    Failure failure = {0};
    int scale_exp, order, area, threads, dd, status = 0, ran = 0;
    double radius;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OOO!idipOip|O", names, &vertex_object, &face_object,
                                     &PyTuple_Type, &reference, &scale_exp, &radius, &order, &area, &weight_object,
                                     &threads, &dd, &scaled_object))
        return NULL;
    if (kernel_input(vertex_object, face_object, reference, scale_exp, radius, &in, &vertices, &faces, 3) != 0)
        return NULL;
    in.order = order;
    in.area_measure = area;
    in.threads = threads;
    /* weights (one per face) and the vertices already in the frame (n x 3, used as they are: the
     * caller vouches they are scaled()) are optional; every buffer is released in one place */
    if (weight_object != Py_None) {
        if (!get_array(weight_object, &weights, ARRAY_F64, "weights"))
            goto release;
        if (weights.len / 8 != in.m) {
            PyErr_SetString(PyExc_ValueError, "weights: expected one per face");
            goto release;
        }
        in.weights = weights.buf;
    }
    if (scaled_object != Py_None) {
        if (!get_array(scaled_object, &scaled, ARRAY_F64, "scaled"))
            goto release;
        if (scaled.len != vertices.len) {
            PyErr_SetString(PyExc_ValueError, "scaled: expected one row per vertex");
            goto release;
        }
        in.scaled = scaled.buf;
    }
    Py_BEGIN_ALLOW_THREADS
    status = dd ? integrate_faces_dd(&in, &out, &failure) : integrate_faces(&in, &out, &failure);
    Py_END_ALLOW_THREADS
    ran = 1;
release:
    PyBuffer_Release(&weights);                 /* a buffer never taken (obj NULL) is left as it is */
    PyBuffer_Release(&scaled);
    PyBuffer_Release(&vertices);
    PyBuffer_Release(&faces);
    if (!ran)
        return NULL;
    if (status)
        return raise_failure(&failure, NULL);
    return Py_BuildValue("{sdsds(ddd)sds(dddddd)sdsdsdsLsL}", "det_sum", out.det_sum, "det_error", out.det_error,
                         "first", out.first[0], out.first[1], out.first[2], "first_error", out.first_error,
                         "second", out.second[0], out.second[1], out.second[2], out.second[3], out.second[4],
                         out.second[5], "second_error", out.second_error, "area2", out.area2, "abs_sum",
                         out.abs_sum, "refined", (long long)out.refined, "exact", (long long)out.exact);
}

static PyObject *core_tetra_determinants(PyObject *self, PyObject *args)
{
    PyObject *vertex_object, *tet_object, *reference;
    Py_buffer vertices, tets;
    KernelInput in;
    Failure failure = {0};
    int scale_exp, status;
    int64_t bad = -1;
    double *det, *bound;
    if (!PyArg_ParseTuple(args, "OOO!i", &vertex_object, &tet_object, &PyTuple_Type, &reference, &scale_exp))
        return NULL;
    if (kernel_input(vertex_object, tet_object, reference, scale_exp, 0.0, &in, &vertices, &tets, 4) != 0)
        return NULL;
    det = malloc((size_t)(in.m > 0 ? in.m : 1) * sizeof *det);
    bound = malloc((size_t)(in.m > 0 ? in.m : 1) * sizeof *bound);
    if (!det || !bound) {
        free(det);
        free(bound);
        PyBuffer_Release(&vertices);
        PyBuffer_Release(&tets);
        return PyErr_NoMemory();
    }
    Py_BEGIN_ALLOW_THREADS
    status = tetra_determinants(&in, det, bound, &bad, &failure);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&vertices);
    PyBuffer_Release(&tets);
    if (status) {
        free(det);
        free(bound);
        return PyErr_Format(PyExc_IndexError, "tetrahedron %lld refers to a node that does not exist", (long long)bad);
    }
    return double_pair(det, bound, (Py_ssize_t)in.m);
}

static PyObject *core_shell_determinants(PyObject *self, PyObject *args)
{
    PyObject *vertex_object, *face_object, *label_object, *reference;
    Py_buffer vertices, faces, labels;
    KernelInput in;
    Failure failure = {0};
    Py_ssize_t shells;
    int scale_exp, status;
    double *sums, *errors;
    if (!PyArg_ParseTuple(args, "OOOnO!i", &vertex_object, &face_object, &label_object, &shells, &PyTuple_Type,
                          &reference, &scale_exp))
        return NULL;
    if (kernel_input(vertex_object, face_object, reference, scale_exp, 0.0, &in, &vertices, &faces, 3) != 0)
        return NULL;
    if (!get_array(label_object, &labels, ARRAY_I64, "labels")) {
        PyBuffer_Release(&vertices);
        PyBuffer_Release(&faces);
        return NULL;
    }
    sums = malloc((size_t)(shells > 0 ? shells : 1) * sizeof *sums);
    errors = malloc((size_t)(shells > 0 ? shells : 1) * sizeof *errors);
    status = !sums || !errors || labels.len / 8 != in.m;
    if (!status) {
        Py_BEGIN_ALLOW_THREADS
        status = shell_determinants(&in, labels.buf, shells, sums, errors, &failure);
        Py_END_ALLOW_THREADS
    } else {
        fail(&failure, ERR_VALUE, NULL, "labels: expected one per face");
    }
    PyBuffer_Release(&vertices);
    PyBuffer_Release(&faces);
    PyBuffer_Release(&labels);
    if (status) {
        free(sums);
        free(errors);
        return raise_failure(&failure, NULL);
    }
    return double_pair(sums, errors, shells);
}

static PyObject *core_bounding_box(PyObject *self, PyObject *args)
{
    PyObject *object;
    Py_buffer view;
    double low[3], high[3];
    if (!PyArg_ParseTuple(args, "O", &object) || !get_array(object, &view, ARRAY_F64, "vertices"))
        return NULL;
    Py_BEGIN_ALLOW_THREADS
    bounding_box(view.buf, view.len / 24, low, high);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&view);
    return Py_BuildValue("((ddd)(ddd))", low[0], low[1], low[2], high[0], high[1], high[2]);
}

static PyObject *core_scale_snapped(PyObject *self, PyObject *args)
{
    PyObject *object, *scaled, *moved;
    Py_buffer view;
    double reference[3], smallest, *out;
    int64_t n, count, *rows;
    int scale_exp;
    if (!PyArg_ParseTuple(args, "O(ddd)id", &object, &reference[0], &reference[1], &reference[2], &scale_exp,
                          &smallest)
            || !get_array(object, &view, ARRAY_F64, "vertices"))
        return NULL;
    n = view.len / 24;
    out = malloc((size_t)(n > 0 ? n : 1) * 3 * sizeof(double));
    rows = malloc((size_t)(n > 0 ? n : 1) * sizeof(int64_t));
    advise_huge(out, (size_t)n * 3 * sizeof(double));
    if (!out || !rows) {
        free(out);
        free(rows);
        PyBuffer_Release(&view);
        return PyErr_NoMemory();
    }
    Py_BEGIN_ALLOW_THREADS
    count = scale_snapped(view.buf, n, reference, scale_exp, smallest, out, rows);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&view);
    if (!(scaled = buffer_wrap(out, 'd', 8, (Py_ssize_t)n, 3))) {
        free(rows);
        return NULL;
    }
    if (!(moved = buffer_wrap(rows, 'q', 8, (Py_ssize_t)count, 0))) {
        Py_DECREF(scaled);
        return NULL;
    }
    return Py_BuildValue("(NN)", scaled, moved);
}

static PyObject *core_largest_squared_distance(PyObject *self, PyObject *args)
{
    PyObject *object;
    Py_buffer view;
    double centre[3], largest;
    if (!PyArg_ParseTuple(args, "O(ddd)", &object, &centre[0], &centre[1], &centre[2])
            || !get_array(object, &view, ARRAY_F64, "vertices"))
        return NULL;
    Py_BEGIN_ALLOW_THREADS
    largest = largest_squared_distance(view.buf, view.len / 24, centre);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&view);
    return PyFloat_FromDouble(largest);
}

static PyObject *core_all_finite(PyObject *self, PyObject *args)
{
    PyObject *object;
    Py_buffer view;
    int finite;
    if (!PyArg_ParseTuple(args, "O", &object) || !get_array(object, &view, ARRAY_F64, "vertices"))
        return NULL;
    finite = all_finite(view.buf, view.len / 8);
    PyBuffer_Release(&view);
    return PyBool_FromLong(finite);
}

static PyObject *core_frame(PyObject *self, PyObject *args)
{
    PyObject *object;
    Py_buffer view;
    double low[3], high[3], reference[3] = {0.0, 0.0, 0.0}, radius = 0.0;
    int scale_exp = 0, status;
    if (!PyArg_ParseTuple(args, "O", &object) || !get_array(object, &view, ARRAY_F64, "vertices"))
        return NULL;
    Py_BEGIN_ALLOW_THREADS
    status = frame_choice(view.buf, view.len / 24, low, high, reference, &scale_exp, &radius);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&view);
    return Py_BuildValue("((ddd)(ddd)(ddd)idi)", low[0], low[1], low[2], high[0], high[1], high[2], reference[0],
                         reference[1], reference[2], scale_exp, radius, status);
}

static PyObject *core_jacobi(PyObject *self, PyObject *args)
{
    double a[9], moments[3], vectors[9], bound;
    if (!PyArg_ParseTuple(args, "(ddd)(ddd)(ddd)", &a[0], &a[1], &a[2], &a[3], &a[4], &a[5], &a[6], &a[7], &a[8]))
        return NULL;
    jacobi3(a, moments, vectors, &bound);
    return Py_BuildValue("[ddd][[ddd][ddd][ddd]]d", moments[0], moments[1], moments[2], vectors[0], vectors[1],
                         vectors[2], vectors[3], vectors[4], vectors[5], vectors[6], vectors[7], vectors[8], bound);
}

static PyMethodDef methods[] = {
    {"read_stl", core_read_stl, METH_VARARGS, "read_stl(path, threads) -> (vertices, faces, binary)"},
    {"read_obj", core_read_obj, METH_VARARGS, "read_obj(path, threads=1) -> (vertices, faces, ignored non-finite unused vertices)"},
    {"weld_corners", core_weld_corners, METH_VARARGS, "weld_corners(corners, threads) -> (vertices, faces, 0)"},
    {"weld_indexed", core_weld_indexed, METH_VARARGS, "weld_indexed(vertices, faces, threads=1) -> (vertices, faces, ignored non-finite unused vertices)"},
    {"edge_summary", core_edge_summary, METH_VARARGS, "edge_summary(faces, n, threads, arrays) -> dict"},
    {"shells", core_shells, METH_VARARGS, "shells(faces, n, labels) -> (labels or None, count)"},
    {"edge_shells", core_edge_shells, METH_VARARGS,
     "edge_shells(faces, n, threads) -> (edge_summary's dict, shell labels or None when one shell, shell count)"},
    {"unused_vertices", core_unused_vertices, METH_VARARGS,
     "unused_vertices(faces, n) -> (vertices no face uses, whether an index is outside [0, n))"},
    {"row_groups", core_row_groups, METH_VARARGS, "row_groups(rows, columns) -> (labels, first, same, opposite)"},
    {"integrate", (PyCFunction)(void (*)(void))core_integrate, METH_VARARGS | METH_KEYWORDS,
     "integrate(vertices, faces, reference, scale_exp, radius, order, area, weights, threads, double_double) -> dict"},
    {"tetra_determinants", core_tetra_determinants, METH_VARARGS,
     "tetra_determinants(points, tets, reference, scale_exp) -> (det, bound)"},
    {"shell_determinants", core_shell_determinants, METH_VARARGS,
     "shell_determinants(vertices, faces, labels, shells, reference, scale_exp) -> (det_sum, det_error)"},
    {"bounding_box", core_bounding_box, METH_VARARGS, "bounding_box(vertices) -> (low, high)"},
    {"scale_snapped", core_scale_snapped, METH_VARARGS,
     "scale_snapped(vertices, reference, scale_exp, smallest) -> (scaled, rows with a value below smallest taken as 0)"},
    {"largest_squared_distance", core_largest_squared_distance, METH_VARARGS,
     "largest_squared_distance(vertices, centre) -> max of (dx*dx + dz*dz) + dy*dy over the vertices"},
    {"all_finite", core_all_finite, METH_VARARGS, "all_finite(vertices) -> whether no coordinate is NaN or infinite"},
    {"frame", core_frame, METH_VARARGS,
     "frame(vertices) -> (low, high, reference, scale_exp, radius, status): frame.py's frame_of (n >= 1)"},
    {"jacobi", core_jacobi, METH_VARARGS,
     "jacobi(rows) -> (moments ascending, vectors as rows of columns, backward error) of a symmetric 3x3"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_core", "The compiled core of massprops.", -1, methods};

/* glibc's allocator in the state it reaches by itself once a large block has been freed, from the start:
 * blocks below 32 MiB come from the heap, and up to 64 MiB free at its top is kept for the next call instead
 * of being returned to the kernel.  Otherwise a process that has not yet freed a large block (whether it has
 * is an accident of what ran before: a file opened with a large buffer, a big array) returns the heap's top
 * after every part and faults its pages in again at the next one, zeroed: a fifth of the whole path of a
 * 10k-face part, and about 30 page faults per part of a batch.  Larger blocks are mapped and unmapped as
 * before (glibc's dynamic threshold stops at 32 MiB too).  MALLOC_MMAP_THRESHOLD_, MALLOC_TRIM_THRESHOLD_ or
 * MALLOC_TOP_PAD_ in the environment leave the allocator as the user set it. */
static void steady_allocator(void)
{
#if defined(__GLIBC__) && defined(M_MMAP_THRESHOLD) && defined(M_TRIM_THRESHOLD)
    if (!getenv("MALLOC_MMAP_THRESHOLD_") && !getenv("MALLOC_TRIM_THRESHOLD_") && !getenv("MALLOC_TOP_PAD_")) {
        mallopt(M_MMAP_THRESHOLD, 32 << 20);
        mallopt(M_TRIM_THRESHOLD, 64 << 20);
    }
#endif
}

PyMODINIT_FUNC PyInit__core(void)
{
    PyObject *m;
    if (PyType_Ready(&BufferType) < 0)
        return NULL;
    m = PyModule_Create(&module);
    if (!m)
        return NULL;
    numbers_init();
    steady_allocator();
    ParseError = PyErr_NewExceptionWithDoc("massprops.core._core.ParseError",
                                           "A malformed mesh file: args are (message, fix).", PyExc_ValueError, NULL);
    if (!ParseError || PyModule_AddObject(m, "ParseError", ParseError) != 0) {
        Py_XDECREF(ParseError);
        Py_DECREF(m);
        return NULL;
    }
    Py_INCREF(ParseError);
    Py_INCREF(&BufferType);
    if (PyModule_AddObject(m, "Buffer", (PyObject *)&BufferType) != 0) {
        Py_DECREF(&BufferType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
