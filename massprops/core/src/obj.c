/* Wavefront OBJ: one reader with one behaviour, straight into welded arrays.
 *
 * Read: "v x y z [w] [r g b]" (the first three numbers are the point; any
 * further words must be numbers too) and "f" with corners "i", "i/t",
 * "i//n" or "i/t/n"; indices count from 1, negative ones back from the last
 * vertex defined; a polygon is fanned from its first corner.  Lines may be
 * indented, end in LF, CRLF or CR, continue after a trailing backslash, and
 * carry a '#' comment.  Every other statement (vt, vn, o, g, s, usemtl, l,
 * ...) is skipped.  Coordinates are read as Python's float() reads them.
 * Faces may only use vertices defined before them.  The vertices the faces
 * use are then welded by exact coordinates (unused ones take no part).
 */
#include "core.h"
#include "lines.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct {
    Growable vertices;        /* double[3] per "v" line */
    Growable faces;           /* index_t[3] per triangle (0-based, into vertices) */
    Growable corners;         /* int64 per corner of the face being read */
    int64_t line;
    Failure *failure;
    /* A chunk of the file read on its own (read_chunk): corners are stored before the vertices
     * defined ahead of the chunk are known, a negative one as RELATIVE + (its index counted from
     * the chunk's first vertex); `need` is how many vertices must come before the chunk for
     * every corner read so far to exist. */
    int chunk;
    int64_t need;
} ObjState;

#define RELATIVE ((int64_t)1 << 61)      /* corners have at most 18 digits: below 2**60 in magnitude */

static int64_t vertex_count(const ObjState *s) { return (int64_t)(s->vertices.size / (3 * sizeof(double))); }

static void cannot_read(ObjState *s, const char *text, const char *end)
{
    while (text < end && is_space(*text))
        text++;
    fail(s->failure, ERR_PARSE, "re-export the mesh", "line %lld: cannot read '%.*s'", (long long)s->line,
         (int)(end - text < 60 ? end - text : 60), text);
}

static int vertex_line(ObjState *s, const char *p, const char *end, const char *text)
{
    const char *word = NULL, *word_end = NULL;
    double value, point[3];
    int count = 0;
    for (;;) {
        const char *stop;
        while (p < end && is_space(*p))
            p++;
        if (p >= end || *p == '#')
            break;
        /* A decimal number read where it starts, the line scanned once; anything else as a word. */
        if (parse_decimal(p, end, &stop, &value) == 0 && (stop == end || is_space(*stop))) {
            p = stop;
        } else {
            next_word(&p, end, &word, &word_end);
            if (parse_double(word, word_end, &value) != 0) {
                cannot_read(s, text, end);
                return -1;
            }
        }
        if (count < 3)
            point[count] = value;
        count++;
    }
    if (count < 3) {
        cannot_read(s, text, end);
        return -1;
    }
    if (reserve(&s->vertices, sizeof point) != 0) {
        fail(s->failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    memcpy(s->vertices.data + s->vertices.size, point, sizeof point);
    s->vertices.size += sizeof point;
    return 0;
}

/* Digits with an optional sign: 1 and the value, 0 if empty, -1 if malformed or too long. */
static int signed_integer(const char **p, const char *end, int64_t *value)
{
    const char *q = *p;
    int negative = 0, digits = 0;
    int64_t result = 0;
    if (q < end && (*q == '-' || *q == '+'))
        negative = *q++ == '-';
    for (; q < end && *q >= '0' && *q <= '9'; q++, digits++) {
        if (digits >= 18)
            return -1;
        result = 10 * result + (*q - '0');
    }
    if (digits == 0)
        return q == *p ? 0 : -1;
    *p = q;
    *value = negative ? -result : result;
    return 1;
}

/* The corner "i", "i/t", "i//n" or "i/t/n" that starts at *p: 1 and its vertex number as given,
 * with *p after it; 0 if what starts there is not a corner (up to `end`). */
static int corner_number(const char **p, const char *end, int64_t *given)
{
    const char *q = *p;
    int64_t ignored;
    int part;
    if (signed_integer(&q, end, given) != 1)
        return 0;
    for (part = 0; part < 2 && q < end && *q == '/'; part++) {
        q++;
        if (signed_integer(&q, end, &ignored) < 0)
            return 0;
    }
    *p = q;
    return 1;
}

/* The digits at *p when fewer than eight of them come before something else (eight bytes readable):
 * 1 and their value, *p after them; 0 otherwise. */
static inline int short_number(const char **p, int64_t *value)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    uint64_t v, x, other;
    int n;
    memcpy(&v, *p, sizeof v);
    x = v ^ 0x3030303030303030ULL;               /* a digit's byte becomes 0..9 */
    /* a byte's top bit set where it is not a digit (a carry only spills into the bytes after the first) */
    other = (x | (x + 0x7676767676767676ULL)) & 0x8080808080808080ULL;
    if (other == 0)
        return 0;
    n = __builtin_ctzll(other) >> 3;             /* digits before it: 1..7 (the first is a digit) */
    x <<= 8 * (8 - n);                           /* the digits, as the last n of eight */
    *value = (int64_t)eight_digits_value(x);
    *p += n;
    return 1;
#else
    (void)p;
    (void)value;
    return 0;
#endif
}

/* The 0-based vertex of a corner given as `given`, `defined` vertices having been read; -1 after a failure. */
static inline int64_t corner_index(ObjState *s, int64_t given, int64_t defined)
{
    if (given > 0 && given <= defined && !s->chunk)
        return given - 1;
    if (s->chunk && given != 0) {
        int64_t need = (given > 0 ? given : -given) - defined;
        if (need > s->need)
            s->need = need;
        return given > 0 ? given - 1 : RELATIVE + defined + given;
    }
    if (given == 0) {
        fail(s->failure, ERR_PARSE, "re-export the mesh",
             "line %lld: face corner 0 (OBJ numbers vertices from 1)", (long long)s->line);
        return -1;
    }
    if ((given > 0 && given > defined) || (given < 0 && -given > defined)) {
        fail(s->failure, ERR_PARSE, "re-export the mesh",
             "line %lld: face corner %lld refers to a vertex that does not exist (%lld vertices defined before it)",
             (long long)s->line, (long long)given, (long long)defined);
        return -1;
    }
    return given > 0 ? given - 1 : defined + given;
}

/* The 0-based vertex of a corner word; -1 after a failure. */
static int64_t corner_vertex(ObjState *s, const char *word, const char *word_end, const char *text,
                             const char *end, int64_t defined)
{
    const char *p = word;
    int64_t given;
    if (!corner_number(&p, word_end, &given) || p != word_end) {
        cannot_read(s, text, end);
        return -1;
    }
    return corner_index(s, given, defined);
}

static int face_line(ObjState *s, const char *p, const char *end, const char *text)
{
    const char *word = NULL, *word_end = NULL;
    int64_t count = 0, k, *corners, defined = vertex_count(s);
    /* room for every corner the line can hold (each is a character and a blank), reserved once */
    if (reserve(&s->corners, ((size_t)(end - p) / 2 + 1) * sizeof(int64_t)) != 0) {
        fail(s->failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    corners = (int64_t *)s->corners.data;
    for (;;) {
        const char *q;
        int64_t vertex, given;
        while (p < end && is_space(*p))
            p++;
        if (p >= end || *p == '#')
            break;
        q = p;
        /* A corner read where it starts, the line scanned once (plain digits first: "f 1 2 3"), anything
         * else as a word. */
        if (*q >= '0' && *q <= '9') {
            if (end - q < 8 || !short_number(&q, &given)) {
                int digits = 0;
                for (given = 0; q < end && *q >= '0' && *q <= '9' && digits < 18; q++, digits++)
                    given = 10 * given + (*q - '0');
            }
            if (q == end || is_space(*q)) {
                p = q;
                vertex = corner_index(s, given, defined);
                if (vertex < 0)
                    return -1;
                corners[count++] = vertex;
                continue;
            }
            q = p;
        }
        if (corner_number(&q, end, &given) && (q == end || is_space(*q))) {
            p = q;
            vertex = corner_index(s, given, defined);
        } else {
            next_word(&p, end, &word, &word_end);
            vertex = corner_vertex(s, word, word_end, text, end, defined);
        }
        if (vertex < 0)
            return -1;
        corners[count++] = vertex;
    }
    if (count < 3) {
        fail(s->failure, ERR_PARSE, "re-export the mesh",
             "line %lld: a face needs at least 3 vertices, this one has %lld", (long long)s->line, (long long)count);
        return -1;
    }
    if (reserve(&s->faces, (size_t)(count - 2) * 3 * sizeof(index_t)) != 0) {
        fail(s->failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    for (k = 1; k + 1 < count; k++) {                    /* a fan from the first corner */
        index_t *triangle = (index_t *)(s->faces.data + s->faces.size);
        triangle[0] = corners[0];
        triangle[1] = corners[k];
        triangle[2] = corners[k + 1];
        s->faces.size += 3 * sizeof(index_t);
    }
    return 0;
}

static int statement(ObjState *s, const char *text, size_t length)
{
    const char *p = text, *end = text + length, *word, *word_end;
    if (!next_word(&p, end, &word, &word_end) || word_end - word != 1)
        return 0;
    if (*word == 'v')
        return vertex_line(s, p, end, text);
    if (*word == 'f')
        return face_line(s, p, end, text);
    return 0;
}

/* Whether a line continues on the next one: its last non-blank character is a backslash. */
static const char *continuation(const char *text, size_t length)
{
    const char *q = text + length;
    while (q > text && is_space(q[-1]))
        q--;
    return q > text && q[-1] == '\\' ? q - 1 : NULL;
}

static int read_statements(ObjState *s, LineReader *r)
{
    Growable joined = {0};
    const char *text, *backslash;
    size_t length;
    int status;
    while ((status = lines_next(r, &text, &length)) == 1) {
        s->line = r->line;
        if ((backslash = continuation(text, length)) != NULL) {
            joined.size = 0;
            do {                                         /* copy: the reader reuses its buffer */
                size_t part = (size_t)(backslash - text);
                if (reserve(&joined, part + 1) != 0) {
                    fail(s->failure, ERR_MEMORY, NULL, "out of memory");
                    status = -1;
                    break;
                }
                memcpy(joined.data + joined.size, text, part);
                joined.data[joined.size + part] = ' ';
                joined.size += part + 1;
                status = lines_next(r, &text, &length);
            } while (status == 1 && (backslash = continuation(text, length)) != NULL);
            if (status == 1 && reserve(&joined, length) == 0) {
                memcpy(joined.data + joined.size, text, length);
                joined.size += length;
            }
            if (status == -1)
                break;
            text = joined.data;
            length = joined.size;
        }
        if (statement(s, text, length) != 0) {
            status = -1;
            break;
        }
    }
    grow_free(&joined);
    return status;
}

static int read_sequential(int fd, int64_t size, MeshArrays *out, Failure *failure);

/* ---- reading in chunks, on several threads ---------------------------------------------------
 *
 * The file is cut at statement starts into chunks; each is read on its own into its own vertices
 * and faces, and the chunks are then joined in order, so the arrays are those of reading the file
 * from start to end whatever the thread count.  A chunk's corners are resolved when the vertices
 * before it are counted.  Any failure (a malformed line, a corner that does not exist, ...) is
 * left to the reading from the start, which reports the first one with its line number. */

#define CHUNK_MIN ((int64_t)1 << 20)      /* bytes: smaller files, or parts, are read on one thread */
#define MAX_CHUNKS 64
#define WINDOW 65536                      /* bytes looked at for a statement start */
#define BEHIND 256                        /* of which before the nominal cut: the blanks ending a line */

typedef struct {
    int fd;
    int64_t bounds[MAX_CHUNKS + 1];
    int chunks;
    ObjState states[MAX_CHUNKS];
    Failure failures[MAX_CHUNKS];
    int64_t first_vertex[MAX_CHUNKS + 1], first_face[MAX_CHUNKS + 1];
    double *vertices;
    index_t *faces;
} Chunks;

/* The first statement start at or after `from` (the byte after a '\n' ending a line that does
 * not continue on the next), or -1 when none is found within the window (or it cannot tell). */
static int64_t statement_start(int fd, int64_t size, int64_t from)
{
    char window[WINDOW];
    int64_t base = from > BEHIND ? from - BEHIND : 0, k;
    size_t want = size - base < (int64_t)sizeof window ? (size_t)(size - base) : sizeof window;
    Failure ignored = {0};
    if (read_exactly(fd, window, want, base, &ignored) != 0)
        return -1;
    for (k = from - base; k < (int64_t)want; k++) {
        int64_t j = k;
        if (window[k] != '\n')
            continue;
        if (j > 0 && window[j - 1] == '\r')
            j--;
        while (j > 0 && is_space(window[j - 1]))
            j--;
        if (j == 0)
            return -1;                    /* the line may start before the window */
        if (window[j - 1] != '\\')
            return base + k + 1;
    }
    return -1;
}

static void read_chunk(void *arg, int64_t c)
{
    Chunks *work = arg;
    ObjState *s = &work->states[c];
    LineReader r;
    s->failure = &work->failures[c];
    s->chunk = 1;
    if (lines_open_range(&r, work->fd, work->bounds[c], work->bounds[c + 1], s->failure) != 0)
        return;
    if (read_statements(s, &r) != 0 && s->failure->kind == ERR_NONE)
        fail(s->failure, ERR_PARSE, NULL, "unreadable");
    r.fd = -1;                                   /* shared: closed by the caller */
    lines_close(&r);
}

/* Copy chunk c's vertices to their place and its corners, resolved, to theirs. */
static void join_chunk(void *arg, int64_t c)
{
    Chunks *work = arg;
    const ObjState *s = &work->states[c];
    int64_t k, count = (int64_t)(s->faces.size / sizeof(index_t)), before = work->first_vertex[c];
    const index_t *corners = (const index_t *)s->faces.data;
    index_t *faces = work->faces + 3 * work->first_face[c];
    memcpy(work->vertices + 3 * before, s->vertices.data, s->vertices.size);
    for (k = 0; k < count; k++)
        faces[k] = corners[k] >= RELATIVE / 2 ? corners[k] - RELATIVE + before : corners[k];
}

static void free_chunks(Chunks *work)
{
    int c;
    for (c = 0; c < work->chunks; c++) {
        grow_free(&work->states[c].vertices);
        grow_free(&work->states[c].faces);
        grow_free(&work->states[c].corners);
    }
}

/* 1 and the welded mesh, or -1 and a failure, when read in chunks; 0 when the file is better
 * read from its start (small, no statement start found to cut at, or something to report). */
static int read_chunked(int fd, int64_t size, int threads, MeshArrays *out, Failure *failure)
{
    Chunks *work;
    int c, wanted = threads * 8, status;
    if (threads < 2 || size < 2 * CHUNK_MIN)
        return 0;
    if (wanted > size / CHUNK_MIN)
        wanted = (int)(size / CHUNK_MIN);
    if (wanted > MAX_CHUNKS)
        wanted = MAX_CHUNKS;
    if (!(work = calloc(1, sizeof *work)))
        return 0;
    work->fd = fd;
    work->bounds[0] = 0;
    for (c = 1; c < wanted; c++) {
        int64_t start = statement_start(fd, size, size / wanted * c);
        if (start < 0) {
            free(work);
            return 0;
        }
        if (start > work->bounds[work->chunks] && start < size)
            work->bounds[++work->chunks] = start;
    }
    work->bounds[++work->chunks] = size;
    parallel_blocks(threads, work->chunks, read_chunk, work);
    work->first_vertex[0] = work->first_face[0] = 0;
    for (c = 0; c < work->chunks; c++) {
        const ObjState *s = &work->states[c];
        if (work->failures[c].kind != ERR_NONE || s->need > work->first_vertex[c]) {
            free_chunks(work);
            free(work);
            return 0;                            /* reported, with its line, by reading from the start */
        }
        work->first_vertex[c + 1] = work->first_vertex[c] + vertex_count(s);
        work->first_face[c + 1] = work->first_face[c] + (int64_t)(s->faces.size / (3 * sizeof(index_t)));
    }
    if (work->first_face[work->chunks] == 0) {
        free_chunks(work);
        free(work);
        return 0;
    }
    work->vertices = malloc((size_t)(work->first_vertex[work->chunks] > 0 ? work->first_vertex[work->chunks] : 1)
                            * 3 * sizeof(double));
    work->faces = malloc((size_t)work->first_face[work->chunks] * 3 * sizeof(index_t));
    if (!work->vertices || !work->faces) {
        free(work->vertices);
        free(work->faces);
        free_chunks(work);
        free(work);
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    parallel_blocks(threads, work->chunks, join_chunk, work);
    free_chunks(work);
    status = weld_indexed(work->vertices, work->first_vertex[work->chunks], work->faces, 0,
                          work->first_face[work->chunks], threads, out, failure);
    free(work->vertices);
    free(work->faces);
    free(work);
    return status == 0 ? 1 : -1;
}

int read_obj(const char *path, int threads, MeshArrays *out, Failure *failure)
{
    int64_t size;
    int fd = open_regular(path, &size, failure), status;
    memset(out, 0, sizeof *out);
    if (fd < 0)
        return -1;
    status = read_chunked(fd, size, threads, out, failure);
    if (status == 0)
        status = read_sequential(fd, size, out, failure);
    else
        status = status == 1 ? 0 : -1;
    close(fd);
    return status;
}

/* ---- reading from the start, on one thread ---------------------------------------------------- */

static int read_sequential(int fd, int64_t size, MeshArrays *out, Failure *failure)
{
    LineReader r;
    ObjState s;
    int status;
    memset(&s, 0, sizeof s);
    s.failure = failure;
    if (lines_open(&r, fd, size, failure) != 0)
        return -1;
    status = read_statements(&s, &r);
    r.fd = -1;                                   /* closed by the caller */
    lines_close(&r);
    grow_free(&s.corners);
    if (status == 0 && s.faces.size == 0)
        fail(failure, ERR_PARSE, "export the part as a closed surface", "the OBJ file holds no faces");
    if (status == 0 && failure->kind == ERR_NONE)
        status = weld_indexed((const double *)s.vertices.data, vertex_count(&s), s.faces.data, 0,
                              (int64_t)(s.faces.size / (3 * sizeof(index_t))), 1, out, failure);
    else
        status = -1;
    grow_free(&s.vertices);
    grow_free(&s.faces);
    return status;
}
