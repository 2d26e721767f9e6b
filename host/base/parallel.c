/* parallel.c — ts_parallel_for (parallel.h). */
#include "base/parallel.h"

#include <pthread.h>
#include <unistd.h>

enum { PARALLEL_MAX = 64 };

typedef struct chunk {
    void (*fn)(void *ctx, size_t begin, size_t end);
    void *ctx;
    size_t begin, end;
} chunk;

static void *chunk_run(void *arg)
{
    const chunk *c = arg;
    c->fn(c->ctx, c->begin, c->end);
    return NULL;
}

unsigned ts_parallel_threads(unsigned threads)
{
    if (threads == 0) {
        long cpus = sysconf(_SC_NPROCESSORS_ONLN);
        threads = cpus > 0 ? (unsigned)cpus : 1u;
    }
    return threads > PARALLEL_MAX ? PARALLEL_MAX : threads;
}

void ts_parallel_for(size_t n, size_t grain, unsigned threads,
                     void (*fn)(void *ctx, size_t begin, size_t end), void *ctx)
{
    if (n == 0) return;
    threads = ts_parallel_threads(threads);
    size_t k = grain ? n / grain : n;
    if (k > threads) k = threads;
    if (k < 2) {
        fn(ctx, 0, n);
        return;
    }
    chunk c[PARALLEL_MAX];
    pthread_t tid[PARALLEL_MAX];
    int started[PARALLEL_MAX] = {0};
    for (size_t i = 0; i < k; ++i)
        c[i] = (chunk){fn, ctx, n * i / k, n * (i + 1) / k};
    for (size_t i = 1; i < k; ++i)
        started[i] = pthread_create(&tid[i], NULL, chunk_run, &c[i]) == 0;
    chunk_run(&c[0]);
    for (size_t i = 1; i < k; ++i) {
        if (started[i])
            pthread_join(tid[i], NULL);
        else
            chunk_run(&c[i]);
    }
}
