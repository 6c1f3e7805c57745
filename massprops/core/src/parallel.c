/* The parallel loops of both extensions (_core and _intersect): numbered blocks handed out in
 * order from a shared counter, on up to `threads` threads, the caller's thread one of them. */
#include "core.h"

#include <pthread.h>

typedef struct {
    worker_fn fn;
    block_fn plain;           /* parallel_blocks: fn ignores the worker */
    void *ctx;
    int64_t blocks;
    int64_t next;             /* shared counter, taken with __atomic_fetch_add */
} Loop;

typedef struct {
    Loop *loop;
    int worker;
} Worker;

static void *run_blocks(void *arg)
{
    Worker *w = arg;
    Loop *loop = w->loop;
    for (;;) {
        int64_t block = __atomic_fetch_add(&loop->next, 1, __ATOMIC_RELAXED);
        if (block >= loop->blocks)
            return NULL;
        if (loop->plain)
            loop->plain(loop->ctx, block);
        else
            loop->fn(loop->ctx, w->worker, block);
    }
}

static void run_loop(int threads, Loop *loop)
{
    pthread_t ids[MAX_THREADS];
    Worker workers[MAX_THREADS];
    int started = 0, k;
    if (threads > MAX_THREADS)
        threads = MAX_THREADS;
    if (threads > loop->blocks)
        threads = (int)loop->blocks;
    for (k = 0; k < MAX_THREADS; k++) {
        workers[k].loop = loop;
        workers[k].worker = k;
    }
    for (k = 1; k < threads; k++) {
        if (pthread_create(&ids[started], NULL, run_blocks, &workers[started + 1]) != 0)
            break;                               /* fewer threads: the same blocks, the same results */
        started++;
    }
    run_blocks(&workers[0]);
    for (k = 0; k < started; k++)
        pthread_join(ids[k], NULL);
}

void parallel_blocks(int threads, int64_t blocks, block_fn fn, void *ctx)
{
    Loop loop = {NULL, fn, ctx, blocks, 0};
    run_loop(threads, &loop);
}

void parallel_workers(int threads, int64_t blocks, worker_fn fn, void *ctx)
{
    Loop loop = {fn, NULL, ctx, blocks, 0};
    run_loop(threads, &loop);
}
