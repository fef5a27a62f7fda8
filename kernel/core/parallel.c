/* Teams of threads (include/rtk/parallel.h) and the kernel's parallel
 * ranges on top of them.
 *
 * The pool's workers are started when a team first needs them and kept
 * until the process exits, handed members of one team at a time (the
 * run_lock). A thread that finds the pool busy with another thread's team
 * starts threads of its own for its team, as everything did before the
 * pool. Waiting (a worker for its next member, a member at a barrier, the
 * caller for its team) spins for a while, since during a build the next
 * phase comes within microseconds, then sleeps: an idle worker on a
 * condition variable of its own, members and callers on one they share.
 * A team larger than the cores this process may use does not spin: its
 * spinning members would hold the cores the others need to arrive. */
#include "core.h"

#include <rtk/parallel.h>

#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define RTK_CPU_RELAX() _mm_pause()
#else
#define RTK_CPU_RELAX() ((void)0)
#endif

/* Most workers the pool starts; a larger team gets this many plus the caller. */
#define POOL_MAX 255
/* How long a waiter spins before it sleeps, in seconds. */
#define SPIN_SECONDS 50e-6

struct rtk_team {
    rtk_team_fn fn;
    void *ctx;
    uint32_t size;
    double spin; /* seconds its waiters spin before they sleep */
    atomic_uint arrived; /* members at the barrier */
    atomic_uint phase;   /* barriers passed */
    atomic_uint running; /* members other than the caller not yet returned */
};

/* Where waiters sleep once they have spun: who changes a word they wait
 * on wakes them all. */
typedef struct sleep_queue {
    pthread_mutex_t lock;
    pthread_cond_t wake;
    atomic_uint sleepers;
} sleep_queue;

/* A worker of the pool: the ticket moves when it has a member to run,
 * or when the pool stops. */
typedef struct worker {
    atomic_uint ticket;
    rtk_team *team;
    uint32_t index;
    sleep_queue idle; /* this worker alone, between members */
    pthread_t id;
} worker;

static struct {
    pthread_mutex_t run_lock; /* held by the team on the pool */
    uint32_t started;         /* workers running; under run_lock */
    int stop_registered;      /* pool_stop is an atexit handler; under run_lock */
    atomic_int stopping;      /* workers return when woken */
    sleep_queue members;      /* members at a barrier, callers waiting for their team */
    _Atomic double idle_spin; /* seconds idle workers spin: the last team's */
    worker workers[POOL_MAX];
} pool = {.run_lock = PTHREAD_MUTEX_INITIALIZER,
          .members = {PTHREAD_MUTEX_INITIALIZER, PTHREAD_COND_INITIALIZER, 0}};

/* Set on threads running a member: a team started there gets one member. */
static _Thread_local int in_team;

/* Cores this process may use, read once (rtk_core_count reads files). */
static uint32_t cores(void)
{
    static atomic_uint known;
    uint32_t n = atomic_load_explicit(&known, memory_order_relaxed);
    if (n == 0) {
        n = rtk_core_count();
        atomic_store_explicit(&known, n, memory_order_relaxed);
    }
    return n;
}

/* Returns once *word != value, sleeping in q after spinning about spin
 * seconds (a few dozen pauses when spin is 0). */
static void wait_while(sleep_queue *q, atomic_uint *word, uint32_t value, double spin)
{
    double deadline = 0.0;
    for (uint32_t i = 1;; i++) {
        if (atomic_load_explicit(word, memory_order_acquire) != value)
            return;
        RTK_CPU_RELAX();
        if ((i & 63) == 0) {
            if (spin <= 0.0)
                break;
            double now = rtk_now();
            if (deadline == 0.0)
                deadline = now + spin;
            else if (now > deadline)
                break;
        }
    }
    /* The sleeper counts itself before it looks again, and whoever
     * changes a word changes it before looking for sleepers (both
     * sequentially consistent): one of the two sees the other. */
    pthread_mutex_lock(&q->lock);
    atomic_fetch_add(&q->sleepers, 1);
    while (atomic_load(word) == value)
        pthread_cond_wait(&q->wake, &q->lock);
    atomic_fetch_sub(&q->sleepers, 1);
    pthread_mutex_unlock(&q->lock);
}

/* Wakes the sleepers of q after a word they wait on changed. */
static void wake_sleepers(sleep_queue *q)
{
    if (atomic_load(&q->sleepers) == 0)
        return;
    pthread_mutex_lock(&q->lock);
    pthread_cond_broadcast(&q->wake);
    pthread_mutex_unlock(&q->lock);
}

/* Calls member index of t's function, marked as in a team meanwhile. */
static void call_member(rtk_team *t, uint32_t index)
{
    int was = in_team;
    in_team = 1;
    t->fn(t->ctx, t, index, t->size);
    in_team = was;
}

/* Runs member index (> 0) of t and reports its return. */
static void run_member(rtk_team *t, uint32_t index)
{
    call_member(t, index);
    /* t may be gone once running reaches 0: touch only the pool after. */
    if (atomic_fetch_sub(&t->running, 1) == 1)
        wake_sleepers(&pool.members);
}

static void *worker_main(void *arg)
{
    worker *w = arg;
    uint32_t seen = 0;
    for (;;) {
        wait_while(&w->idle, &w->ticket, seen, atomic_load_explicit(&pool.idle_spin, memory_order_relaxed));
        seen = atomic_load_explicit(&w->ticket, memory_order_acquire);
        if (atomic_load(&pool.stopping))
            return NULL;
        run_member(w->team, w->index);
    }
}

/* At exit: the workers return and are joined, so that no thread of the
 * pool is left while the process ends (leak checkers and valgrind find
 * only the threads the program had before). Not while a team runs (exit
 * called from elsewhere meanwhile): then the workers are left as they are. */
static void pool_stop(void)
{
    if (pthread_mutex_trylock(&pool.run_lock) != 0)
        return;
    atomic_store(&pool.stopping, 1);
    for (uint32_t i = 0; i < pool.started; i++) {
        atomic_fetch_add(&pool.workers[i].ticket, 1);
        wake_sleepers(&pool.workers[i].idle);
    }
    for (uint32_t i = 0; i < pool.started; i++) {
        worker *w = &pool.workers[i];
        pthread_join(w->id, NULL);
        pthread_cond_destroy(&w->idle.wake);
        pthread_mutex_destroy(&w->idle.lock);
    }
    pool.started = 0;
    atomic_store(&pool.stopping, 0);
    pthread_mutex_unlock(&pool.run_lock);
}

/* Runs member 0 of t on the calling thread and waits for the others. */
static void lead(rtk_team *t)
{
    call_member(t, 0);
    for (uint32_t left; (left = atomic_load(&t->running)) != 0;)
        wait_while(&pool.members, &t->running, left, t->spin);
}

/* The team on the pool's workers; run_lock is held. */
static uint32_t run_on_pool(rtk_team *t, uint32_t helpers)
{
    atomic_store_explicit(&pool.idle_spin, t->spin, memory_order_relaxed);
    while (pool.started < helpers) {
        worker *w = &pool.workers[pool.started];
        atomic_store(&w->ticket, 0); /* a slot may be reused after pool_stop */
        if (pthread_mutex_init(&w->idle.lock, NULL) != 0)
            break;
        if (pthread_cond_init(&w->idle.wake, NULL) != 0) {
            pthread_mutex_destroy(&w->idle.lock);
            break;
        }
        if (pthread_create(&w->id, NULL, worker_main, w) != 0) {
            pthread_cond_destroy(&w->idle.wake);
            pthread_mutex_destroy(&w->idle.lock);
            break;
        }
        pool.started++;
        if (!pool.stop_registered)
            pool.stop_registered = atexit(pool_stop) == 0;
    }
    if (helpers > pool.started)
        helpers = pool.started;
    t->size = helpers + 1;
    atomic_store(&t->running, helpers);
    for (uint32_t i = 0; i < helpers; i++) {
        pool.workers[i].team = t;
        pool.workers[i].index = i + 1;
        atomic_fetch_add(&pool.workers[i].ticket, 1);
        wake_sleepers(&pool.workers[i].idle);
    }
    lead(t);
    return t->size;
}

/* A member on a thread of its own, when the pool is busy; it waits at
 * the gate until the team's size is known. */
typedef struct own_member {
    rtk_team *team;
    uint32_t index;
    atomic_uint *gate;
} own_member;

static void *own_main(void *arg)
{
    const own_member *m = arg;
    wait_while(&pool.members, m->gate, 0, m->team->spin);
    run_member(m->team, m->index);
    return NULL;
}

/* The team on threads of its own (the pool is busy). */
static uint32_t run_on_own(rtk_team *t, uint32_t helpers)
{
    pthread_t *ids = malloc(sizeof *ids * helpers);
    own_member *members = malloc(sizeof *members * helpers);
    atomic_uint gate = 0;
    uint32_t started = 0;
    if (ids && members) {
        for (; started < helpers; started++) {
            members[started] = (own_member){t, started + 1, &gate};
            if (pthread_create(&ids[started], NULL, own_main, &members[started]) != 0)
                break;
        }
    }
    t->size = started + 1;
    atomic_store(&t->running, started);
    atomic_store(&gate, 1);
    wake_sleepers(&pool.members);
    lead(t);
    for (uint32_t i = 0; i < started; i++)
        pthread_join(ids[i], NULL);
    free(ids);
    free(members);
    return t->size;
}

uint32_t rtk_team_run(uint32_t wanted, rtk_team_fn fn, void *ctx)
{
    rtk_team t = {.fn = fn, .ctx = ctx, .size = 1};
    uint32_t helpers = wanted > 1 ? wanted - 1 : 0;
    if (helpers > POOL_MAX)
        helpers = POOL_MAX;
    t.spin = helpers < cores() ? SPIN_SECONDS : 0.0;
    if (helpers > 0 && !in_team) {
        if (pthread_mutex_trylock(&pool.run_lock) == 0) {
            uint32_t size = run_on_pool(&t, helpers);
            pthread_mutex_unlock(&pool.run_lock);
            return size;
        }
        return run_on_own(&t, helpers);
    }
    atomic_store(&t.running, 0);
    lead(&t);
    return 1;
}

void rtk_team_sync(rtk_team *t)
{
    if (t->size <= 1)
        return;
    uint32_t phase = atomic_load(&t->phase);
    if (atomic_fetch_add(&t->arrived, 1) == t->size - 1) {
        atomic_store(&t->arrived, 0);
        atomic_fetch_add(&t->phase, 1);
        wake_sleepers(&pool.members);
    } else {
        wait_while(&pool.members, &t->phase, phase, t->spin);
    }
}

/* rtk_parallel_ranges' ranges: member i takes ranges i, i + size, ... */
typedef struct ranges_job {
    uint32_t n, parts;
    rtk_range_fn fn;
    void *ctx;
} ranges_job;

static void ranges_member(void *ctx, rtk_team *team, uint32_t index, uint32_t size)
{
    (void)team;
    const ranges_job *j = ctx;
    for (uint32_t i = index; i < j->parts; i += size)
        j->fn(j->ctx, (uint32_t)((uint64_t)j->n * i / j->parts), (uint32_t)((uint64_t)j->n * (i + 1) / j->parts));
}

uint32_t rtk_take_run(uint32_t *next, uint32_t count, uint32_t workers, uint32_t *first)
{
    uint32_t k = __atomic_load_n(next, __ATOMIC_RELAXED);
    for (;;) {
        if (k >= count)
            return 0;
        const uint32_t share = (count - k) / (2 * (workers ? workers : 1)), run = share ? share : 1;
        if (__atomic_compare_exchange_n(next, &k, k + run, 1, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) {
            *first = k;
            return run;
        }
    }
}

void rtk_parallel_ranges(uint32_t n, uint32_t threads, uint32_t min_chunk, rtk_range_fn fn, void *ctx)
{
    enum { max_ranges = 64 };
    uint32_t parts = threads ? threads : 1;
    if (parts > max_ranges)
        parts = max_ranges;
    if (min_chunk && n / min_chunk < parts)
        parts = n / min_chunk ? n / min_chunk : 1;
    if (parts <= 1) {
        if (n)
            fn(ctx, 0, n);
        return;
    }
    ranges_job j = {n, parts, fn, ctx};
    rtk_team_run(parts, ranges_member, &j);
}

/* rtk_alloc_zeroed's pieces: 64 KiB, at least four a thread. */
#define ZERO_CHUNK ((size_t)64 << 10)
typedef struct zero_job {
    unsigned char *block;
    size_t bytes;
} zero_job;

static void zero_range(void *ctx, uint32_t begin, uint32_t end)
{
    const zero_job *z = ctx;
    const size_t from = (size_t)begin * ZERO_CHUNK, to = (size_t)end * ZERO_CHUNK;
    memset(z->block + from, 0, (to < z->bytes ? to : z->bytes) - from);
}

void *rtk_alloc_zeroed(size_t count, size_t size, uint32_t threads)
{
    if (size && count > SIZE_MAX / size) {
        rtk_error(RTK_ERR_NOMEM, "array of %zu x %zu bytes is too large", count, size);
        return NULL;
    }
    const size_t bytes = count && size ? count * size : 1;
    zero_job z = {rtk_alloc(bytes), bytes};
    if (!z.block)
        return NULL;
    /* A block allocated has fewer than 2^32 chunks (256 TiB). */
    rtk_parallel_ranges((uint32_t)((bytes + ZERO_CHUNK - 1) / ZERO_CHUNK), threads ? threads : 1, 4, zero_range, &z);
    return z.block;
}
