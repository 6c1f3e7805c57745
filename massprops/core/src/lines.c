/* Line reader: see lines.h. */
#include "lines.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int lines_open(LineReader *r, int fd, int64_t size, Failure *failure)
{
    return lines_open_range(r, fd, 0, size, failure);
}

int lines_open_range(LineReader *r, int fd, int64_t start, int64_t stop, Failure *failure)
{
    memset(r, 0, sizeof *r);
    r->fd = fd;
    r->offset = start;
    r->size = stop;
    r->failure = failure;
    r->capacity = stop - start + 16 < (int64_t)LINE_CHUNK ? (size_t)(stop - start) + 16 : LINE_CHUNK;     /* small files: small buffers */
    r->buffer = malloc(r->capacity);
    if (!r->buffer) {
        fail(failure, ERR_MEMORY, NULL, "out of memory");
        return -1;
    }
    return 0;
}

void lines_close(LineReader *r)
{
    free(r->buffer);
    r->buffer = NULL;
    if (r->fd >= 0)
        close(r->fd);
    r->fd = -1;
}

/* Read more of the file after the unread rest of the buffer; 0 if nothing is left to read. */
static int refill(LineReader *r)
{
    size_t rest = r->end - r->start, want;
    if (r->offset >= r->size)
        return 0;
    r->cr_known = 0;
    if (r->start > 0) {
        memmove(r->buffer, r->buffer + r->start, rest);
        r->start = 0;
        r->end = rest;
    }
    if (r->capacity - r->end < LINE_CHUNK / 2 && (int64_t)(r->capacity - r->end) < r->size - r->offset) {
        char *bigger;
        if (r->capacity >= MAX_LINE + LINE_CHUNK) {
            fail(r->failure, ERR_PARSE, "check that this is a text mesh file",
                 "line %lld is longer than %d MiB (this is not a text file)", (long long)(r->line + 1),
                 (int)(MAX_LINE >> 20));
            return -1;
        }
        bigger = realloc(r->buffer, r->capacity * 2);
        if (!bigger) {
            fail(r->failure, ERR_MEMORY, NULL, "out of memory");
            return -1;
        }
        r->buffer = bigger;
        r->capacity *= 2;
    }
    want = r->capacity - r->end;
    if ((int64_t)want > r->size - r->offset)
        want = (size_t)(r->size - r->offset);
    if (read_exactly(r->fd, r->buffer + r->end, want, r->offset, r->failure) != 0)
        return -1;
    r->offset += (int64_t)want;
    r->end += want;
    return 1;
}

int lines_next(LineReader *r, const char **text, size_t *length)
{
    size_t scanned = r->start;
    for (;;) {
        /* the first '\n' or '\r' at or after `scanned` (memchr: vectorised by the C library) */
        char *newline = memchr(r->buffer + scanned, '\n', r->end - scanned), *found;
        size_t k;
        /* and the first '\r': looked for once up to the buffer's end, again only once passed (a file
         * with '\n' line ends is searched for '\r' once, not once a line) */
        if (!r->cr_known || r->cr < scanned) {
            char *cr = memchr(r->buffer + scanned, '\r', r->end - scanned);
            r->cr = cr ? (size_t)(cr - r->buffer) : r->end;
            r->cr_known = 1;
        }
        found = r->cr < (newline ? (size_t)(newline - r->buffer) : r->end) ? r->buffer + r->cr : newline;
        k = found ? (size_t)(found - r->buffer) : r->end;
        /* A '\r' at the end of the buffer may be the first half of "\r\n": read on first. */
        if (found && !(*found == '\r' && k + 1 == r->end && r->offset < r->size)) {
            *text = r->buffer + r->start;
            *length = k - r->start;
            r->start = k + 1 + (*found == '\r' && k + 1 < r->end && r->buffer[k + 1] == '\n');
            r->line++;
            return 1;
        }
        scanned = (found ? k : r->end) - r->start;
        switch (refill(r)) {
        case -1:
            return -1;
        case 0:
            if (r->start == r->end)
                return 0;
            *text = r->buffer + r->start;           /* the last line has no line end */
            *length = r->end - r->start;
            r->start = r->end;
            r->line++;
            return 1;
        }
        scanned += r->start;
    }
}
