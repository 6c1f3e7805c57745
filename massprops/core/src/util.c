/* Failures, growable arrays and safe file reading. */
#define _GNU_SOURCE
#include "core.h"

#include <stdint.h>
#if defined(__linux__)
#include <sys/mman.h>
#endif

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

void fail(Failure *failure, int kind, const char *fix, const char *format, ...)
{
    va_list args;
    if (failure->kind != ERR_NONE)
        return;                                    /* the first failure is the one reported */
    failure->kind = kind;
    va_start(args, format);
    vsnprintf(failure->message, sizeof failure->message, format, args);
    va_end(args);
    snprintf(failure->fix, sizeof failure->fix, "%s", fix ? fix : "");
}

/* Large arrays in huge pages where the kernel offers them on request (Linux, transparent huge pages in
 * "madvise" mode): one fault per 2 MiB instead of 512, and fewer TLB misses in the weld's hash table.
 * Only the whole 2 MiB pages inside the block are advised; the contents are unchanged. */
void advise_huge(void *data, size_t bytes)
{
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    const uintptr_t huge = (uintptr_t)1 << 21;
    uintptr_t start = ((uintptr_t)data + huge - 1) & ~(huge - 1), end = ((uintptr_t)data + bytes) & ~(huge - 1);
    if (data && bytes >= 4 * huge && end > start)
        madvise((void *)start, end - start, MADV_HUGEPAGE);
#else
    (void)data;
    (void)bytes;
#endif
}

/* Pages of [data, data + bytes) made present and writable (zeroed by the kernel) without writing
 * them: another thread may be writing the same block meanwhile (Linux 5.14 and later; elsewhere,
 * and on older kernels, nothing is done and the writer takes the page faults itself). */
void populate_pages(void *data, size_t bytes)
{
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
    const uintptr_t page = 4096;
    uintptr_t start = ((uintptr_t)data + page - 1) & ~(page - 1), end = ((uintptr_t)data + bytes) & ~(page - 1);
    if (data && end > start)
        madvise((void *)start, end - start, MADV_POPULATE_WRITE);
#else
    (void)data;
    (void)bytes;
#endif
}

/* After a large job: the free memory glibc's allocator keeps (in the heaps of the threads that worked,
 * and below its raised trimming threshold, up to 64 MiB of it) is given back to the system, so that it
 * does not stay resident beside what the next stage allocates (issue 24: 39 MiB of the 10M-face peak).
 * Small jobs keep it (reusing it saves their page faults). */
#define RELEASE_FROM ((int64_t)1 << 26)

void release_free_memory(int64_t bytes_worked)
{
#if defined(__GLIBC__)
    if (bytes_worked >= RELEASE_FROM)
        malloc_trim(0);
#else
    (void)bytes_worked;
#endif
}

int grow_reserve(Growable *g, size_t bytes)
{
    size_t wanted = g->size + bytes, capacity;
    char *data;
    if (wanted <= g->capacity)
        return 0;
    capacity = g->capacity ? g->capacity : 4096;
    while (capacity < wanted)
        capacity += capacity / 2 + 4096;
    data = realloc(g->data, capacity);
    if (!data)
        return -1;
    g->data = data;
    g->capacity = capacity;
    advise_huge(data, capacity);
    return 0;
}

void grow_free(Growable *g)
{
    free(g->data);
    g->data = NULL;
    g->size = g->capacity = 0;
}

/* ---- files ------------------------------------------------------------------------------ */

int open_regular(const char *path, int64_t *size, Failure *failure)
{
    struct stat info;
    /* O_NONBLOCK: opening a FIFO must not wait for a writer; it is refused below. */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        failure->os_errno = errno;
        fail(failure, ERR_OS, NULL, "%s", strerror(errno));
        return -1;
    }
    if (fstat(fd, &info) != 0) {
        failure->os_errno = errno;
        fail(failure, ERR_OS, NULL, "%s", strerror(errno));
        close(fd);
        return -1;
    }
    if (!S_ISREG(info.st_mode)) {
        close(fd);
        fail(failure, ERR_PARSE, "name a regular mesh file",
             "not a regular file (a FIFO, device or socket cannot be read as a mesh)");
        return -1;
    }
    fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK);
    *size = (int64_t)info.st_size;
    return fd;
}

int read_exactly(int fd, char *buffer, size_t bytes, int64_t offset, Failure *failure)
{
    size_t done = 0;
    while (done < bytes) {
        ssize_t got = pread(fd, buffer + done, bytes - done, (off_t)(offset + (int64_t)done));
        if (got < 0) {
            if (errno == EINTR)
                continue;
            failure->os_errno = errno;
            fail(failure, ERR_OS, NULL, "%s", strerror(errno));
            return -1;
        }
        if (got == 0) {
            fail(failure, ERR_PARSE, "re-export the mesh, and do not change the file while it is read",
                 "the file ended early (it is truncated, or shrank while being read)");
            return -1;
        }
        done += (size_t)got;
    }
    return 0;
}
