/* Reading a text file line by line in bounded memory (OBJ, ASCII STL).
 *
 * Lines end at "\n", "\r\n" or a lone "\r" (as bytes.splitlines splits);
 * the file is read with pread in 1 MiB chunks up to the size it had when
 * opened, so a file that shrinks while it is read is an error, not a crash,
 * and one that grows is read as it was.  A line longer than MAX_LINE is
 * refused (a binary or sparse file is not read into memory whole).
 */
#ifndef MASSPROPS_LINES_H
#define MASSPROPS_LINES_H

#include "core.h"

#define LINE_CHUNK ((size_t)1 << 20)
#define MAX_LINE ((size_t)1 << 26)

typedef struct {
    int fd;
    int64_t size, offset;     /* file size at open; bytes read so far */
    char *buffer;
    size_t capacity, start, end;
    int64_t line;             /* number of the line last returned, from 1 */
    size_t cr;                /* where the buffer's next '\r' is (`end` if none), when cr_known */
    int cr_known;
    Failure *failure;
} LineReader;

int lines_open(LineReader *r, int fd, int64_t size, Failure *failure);
/* The lines of bytes [start, stop) of the file, `start` a line start (a part of a file read on its
 * own: its line numbers count from the part's start). */
int lines_open_range(LineReader *r, int fd, int64_t start, int64_t stop, Failure *failure);
void lines_close(LineReader *r);
/* 1 and the next line [*text, *text + *length), 0 at the end, -1 on failure. */
int lines_next(LineReader *r, const char **text, size_t *length);

static inline int is_space(char c) { return c == ' ' || (c >= '\t' && c <= '\f' && c != '\n' && c != '\r'); }

/* The next whitespace-separated word of [*p, end), or 0 when none is left (a '#' ends the words). */
static inline int next_word(const char **p, const char *end, const char **word, const char **word_end)
{
    const char *q = *p;
    while (q < end && is_space(*q))
        q++;
    if (q >= end || *q == '#')
        return 0;
    *word = q;
    while (q < end && !is_space(*q))
        q++;
    *word_end = q;
    *p = q;
    return 1;
}

#endif
