/* STL, binary and ASCII, read straight into welded arrays.
 *
 * Binary when the size is exactly 84 + 50 n for the header's n (even if the
 * header starts with "solid", as many exporters write); ASCII when the text
 * starts with "solid" (after an optional UTF-8 byte-order mark and
 * whitespace, any case).  Binary records are read with pread into a bounded
 * buffer (never mapped: a file truncated while it is read is an error, not
 * SIGBUS), and nothing is allocated for a count the file size cannot hold.
 */
#include "core.h"
#include "lines.h"

#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#define HEADER 84
#define RECORD 50

static uint32_t little_endian32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static float little_endian_float(const unsigned char *p)
{
    uint32_t bits = little_endian32(p);
    float value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

/* Whether the text starts with "solid": after a UTF-8 BOM and whitespace, any case. */
static int starts_ascii(const unsigned char *head, size_t length)
{
    size_t k = 0;
    if (length >= 3 && head[0] == 0xEF && head[1] == 0xBB && head[2] == 0xBF)
        k = 3;
    while (k < length && (is_space((char)head[k]) || head[k] == '\n' || head[k] == '\r'))
        k++;
    return length - k >= 5 && strncasecmp((const char *)head + k, "solid", 5) == 0;
}

/* Whether bytes look like text (no NUL, no control characters but whitespace). */
static int looks_like_text(const unsigned char *bytes, size_t length)
{
    size_t k;
    for (k = 0; k < length; k++)
        if (bytes[k] == 0 || (bytes[k] < 32 && !is_space((char)bytes[k]) && bytes[k] != '\n' && bytes[k] != '\r'))
            return 0;
    return 1;
}

typedef struct {
    int fd;
    int64_t records;
} BinaryFile;

/* Records read at a time: a buffer this small stays in the allocator's heap and in cache (a buffer of
 * the whole block came from mmap, new pages faulted in at every call: most of the time of a 10k-face
 * file). */
#define RECORDS_AT_ONCE 1024

/* Corners [first, first + count) of a binary STL (whole records), read with pread (so threads can
 * read their own parts) and widened exactly. */
static int binary_source(void *context, int64_t first, int64_t count, double *points, Failure *failure)
{
    const BinaryFile *file = context;
    int64_t records = count / 3, done, k;
    unsigned char *buffer = malloc((size_t)(records < RECORDS_AT_ONCE ? (records > 0 ? records : 1) : RECORDS_AT_ONCE)
                                   * RECORD);
    if (!buffer) {
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    for (done = 0; done < records; done += RECORDS_AT_ONCE) {
        int64_t n = records - done < RECORDS_AT_ONCE ? records - done : RECORDS_AT_ONCE;
        if (read_exactly(file->fd, (char *)buffer, (size_t)(n * RECORD), HEADER + (first / 3 + done) * RECORD,
                         failure) != 0) {
            free(buffer);
            return -1;
        }
        for (k = 0; k < n; k++) {
            /* the nine corner coordinates of record k, after its 12-byte normal */
            const unsigned char *corners = buffer + k * RECORD + 12;
            double *out = points + 9 * (done + k);
            int c;
            for (c = 0; c < 9; c++)
                out[c] = little_endian_float(corners + 4 * c);
        }
    }
    free(buffer);
    return 0;
}

static int read_binary(int fd, int64_t count, int threads, MeshArrays *out, Failure *failure)
{
    BinaryFile file = {fd, count};
    int status;
    out->binary = 1;
    status = weld_source(binary_source, &file, 3 * count, threads, out, failure);
    release_free_memory(RECORD * count);          /* the weld's tables, freed */
    return status;
}

/* ---- ASCII ----------------------------------------------------------------------------- */

static int keyword(const char *word, const char *word_end, const char *name)
{
    size_t length = strlen(name);
    return (size_t)(word_end - word) == length && strncasecmp(word, name, length) == 0;
}

static int read_ascii(int fd, int64_t size, MeshArrays *out, Failure *failure)
{
    LineReader r;
    Welder w;
    Growable faces = {0};
    const char *text, *word, *word_end;
    size_t length;
    int64_t in_facet = -1, corners = 0;       /* vertices since the last "facet" (-1: none seen) */
    int status;
    out->binary = 0;
    if (lines_open(&r, fd, size, failure) != 0)
        return -1;
    if (welder_init(&w, size / 500 + 16) != 0) {
        lines_close(&r);
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    while ((status = lines_next(&r, &text, &length)) == 1) {
        const char *p = text, *end = text + length;
        if (r.line == 1 && length >= 3 && (unsigned char)p[0] == 0xEF && (unsigned char)p[1] == 0xBB
                && (unsigned char)p[2] == 0xBF)
            p += 3;                                           /* the byte-order mark */
        if (!next_word(&p, end, &word, &word_end))
            continue;
        if (keyword(word, word_end, "vertex")) {
            const char *shown = word;
            double point[3];
            int k;
            int64_t vertex;
            for (k = 0; k < 3; k++) {
                const char *number, *number_end;
                if (!next_word(&p, end, &number, &number_end) || parse_double(number, number_end, &point[k]) != 0)
                    break;
            }
            if (k < 3 || next_word(&p, end, &word, &word_end)) {
                fail(failure, ERR_PARSE, "re-export the mesh", "line %lld: a vertex needs three numbers: '%.*s'",
                     (long long)r.line, (int)(end - shown < 60 ? end - shown : 60), shown);
                break;
            }
            if (reserve(&faces, sizeof(index_t)) != 0 || (vertex = weld_point64(&w, point)) < 0) {
                fail(failure, ERR_MEMORY, NULL, "out of memory");
                break;
            }
            ((index_t *)faces.data)[faces.size / sizeof(index_t)] = vertex;
            faces.size += sizeof(index_t);
            corners++;
            if (in_facet >= 0)
                in_facet++;
        } else if (keyword(word, word_end, "facet")) {
            in_facet = 0;
        } else if (keyword(word, word_end, "endfacet")) {
            if (in_facet >= 0 && in_facet != 3) {
                fail(failure, ERR_PARSE, "re-export the mesh with triangles only",
                     "line %lld: a facet with %lld vertices (an STL facet is a triangle)", (long long)r.line,
                     (long long)in_facet);
                break;
            }
            in_facet = -1;
        }
    }
    lines_close(&r);
    if (status == -1 || failure->kind != ERR_NONE) {
        welder_free(&w);
        grow_free(&faces);
        return -1;
    }
    if (corners == 0 || corners % 3) {
        welder_free(&w);
        grow_free(&faces);
        if (corners == 0)
            fail(failure, ERR_PARSE, "re-export the mesh", "not a valid ASCII STL (no 'vertex' lines)");
        else
            fail(failure, ERR_PARSE, "re-export the mesh",
                 "not a valid ASCII STL (%lld vertices, not a multiple of 3)", (long long)corners);
        return -1;
    }
    out->m = corners / 3;
    out->faces = (index_t *)faces.data;
    out->n = w.count;
    out->vertices = (double *)w.vertices.data;
    w.vertices.data = NULL;
    welder_free(&w);
    return 0;
}

int read_stl(const char *path, int threads, MeshArrays *out, Failure *failure)
{
    unsigned char head[1024];
    int64_t size, count = -1;
    size_t got;
    int fd = open_regular(path, &size, failure), status;
    memset(out, 0, sizeof *out);
    if (fd < 0)
        return -1;
    got = size < (int64_t)sizeof head ? (size_t)size : sizeof head;
    if (size == 0) {
        close(fd);
        fail(failure, ERR_PARSE, "re-export the mesh", "the file is empty");
        return -1;
    }
    if (read_exactly(fd, (char *)head, got, 0, failure) != 0) {
        close(fd);
        return -1;
    }
    if (size >= HEADER) {
        count = little_endian32(head + 80);
        if (size == HEADER + RECORD * count) {
            if (count == 0) {
                close(fd);
                fail(failure, ERR_PARSE, "export the part as a closed surface", "the STL holds no triangles");
                return -1;
            }
            status = read_binary(fd, count, threads, out, failure);
            close(fd);
            return status;
        }
    }
    /* A "solid" header on bytes that are not text is a binary STL of the wrong size. */
    if (starts_ascii(head, got) && (size < HEADER || looks_like_text(head + HEADER, got > HEADER ? got - HEADER : 0)))
        return read_ascii(fd, size, out, failure);                /* closes fd */
    close(fd);
    if (size < HEADER)
        fail(failure, ERR_PARSE, "re-export the mesh",
             "too short for binary STL (%lld bytes, a header needs 84)", (long long)size);
    else
        fail(failure, ERR_PARSE, "the file is truncated, has extra bytes, or is not an STL; re-export it",
             "binary STL header says %lld triangles (%lld bytes) but the file has %lld bytes", (long long)count,
             (long long)(HEADER + RECORD * count), (long long)size);
    return -1;
}
