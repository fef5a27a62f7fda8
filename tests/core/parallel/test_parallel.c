/* Teams of threads (include/rtk/parallel.h) and the kernel's parallel
 * ranges: every member runs once, on a thread of its own, at the same
 * time as the others; the barrier orders what members write; a member's
 * own team has one member; two threads running teams at once both get
 * whole teams (one on the pool, one on threads of its own); members that
 * sleep at the barrier are woken. */
#include "config/config.h"
#include "render/render.h"
#include "image/image.h"
#include "check.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define MAX_MEMBERS 256

/* What the members of one team saw. */
typedef struct record {
    atomic_uint calls[MAX_MEMBERS];
    pthread_t self[MAX_MEMBERS];
    atomic_uint wrong_size;
    uint32_t size_seen;
} record;

static void note_member(void *ctx, rtk_team *team, uint32_t index, uint32_t size)
{
    (void)team;
    record *r = ctx;
    if (index >= MAX_MEMBERS || size != r->size_seen) {
        atomic_fetch_add(&r->wrong_size, 1);
        return;
    }
    atomic_fetch_add(&r->calls[index], 1);
    r->self[index] = pthread_self();
    /* Every member is here before any leaves: they run at once. */
    rtk_team_sync(team);
}

/* Runs a team of wanted and checks each member ran once on its own thread. */
static void check_team(uint32_t wanted, uint32_t expect)
{
    record *r = calloc(1, sizeof *r);
    r->size_seen = expect;
    uint32_t size = rtk_team_run(wanted, note_member, r);
    check(size == expect, "a team of %u wanted has %u members (got %u)", wanted, expect, size);
    int once = 1, distinct = 1;
    for (uint32_t i = 0; i < size && i < MAX_MEMBERS; i++) {
        once &= atomic_load(&r->calls[i]) == 1;
        for (uint32_t j = 0; j < i; j++)
            distinct &= !pthread_equal(r->self[i], r->self[j]);
    }
    check(once && atomic_load(&r->wrong_size) == 0, "  every member of %u ran once, told the team's size", size);
    check(distinct && pthread_equal(r->self[0], pthread_self()),
          "  each on a thread of its own, member 0 on the caller's");
    free(r);
}

/* Rounds of writes between barriers: in round k member i writes slot i,
 * then after the barrier reads every slot, which must hold round k. */
typedef struct rounds {
    uint32_t rounds;
    uint32_t slots[MAX_MEMBERS];
    atomic_uint stale;
    uint32_t sleeper; /* member that sleeps before some barriers */
} rounds;

static void sleep_us(long us)
{
    struct timespec ts = {0, us * 1000};
    nanosleep(&ts, NULL);
}

static void round_member(void *ctx, rtk_team *team, uint32_t index, uint32_t size)
{
    rounds *r = ctx;
    for (uint32_t k = 1; k <= r->rounds; k++) {
        r->slots[index] = k;
        /* Long enough for the others to stop spinning and sleep. */
        if (index == r->sleeper && k % 50 == 0)
            sleep_us(2000);
        rtk_team_sync(team);
        for (uint32_t i = 0; i < size; i++)
            if (r->slots[i] != k)
                atomic_fetch_add(&r->stale, 1);
        rtk_team_sync(team);
    }
}

static void check_rounds(uint32_t wanted, uint32_t count, uint32_t sleeper)
{
    rounds *r = calloc(1, sizeof *r);
    r->rounds = count;
    r->sleeper = sleeper;
    uint32_t size = rtk_team_run(wanted, round_member, r);
    check(size == wanted && atomic_load(&r->stale) == 0,
          "%u rounds on %u members (member %u sleeping 2 ms every 50th): every write seen after the barrier "
          "(%u stale reads)",
          count, size, sleeper, atomic_load(&r->stale));
    free(r);
}

/* A member that runs a team of its own. */
typedef struct nested {
    atomic_uint inner_size_sum, inner_calls, inner_elsewhere;
} nested;

typedef struct inner_ctx {
    nested *n;
    pthread_t outer;
} inner_ctx;

static void inner_member(void *ctx, rtk_team *team, uint32_t index, uint32_t size)
{
    inner_ctx *c = ctx;
    rtk_team_sync(team); /* a team of one: returns at once */
    atomic_fetch_add(&c->n->inner_calls, 1);
    if (index != 0 || size != 1 || !pthread_equal(pthread_self(), c->outer))
        atomic_fetch_add(&c->n->inner_elsewhere, 1);
}

static void outer_member(void *ctx, rtk_team *team, uint32_t index, uint32_t size)
{
    (void)team, (void)index, (void)size;
    nested *n = ctx;
    inner_ctx c = {n, pthread_self()};
    atomic_fetch_add(&n->inner_size_sum, rtk_team_run(4, inner_member, &c));
}

/* Ranges: every item covered once. */
typedef struct cover {
    uint32_t n;
    atomic_uchar *hits;
} cover;

static void cover_range(void *ctx, uint32_t begin, uint32_t end)
{
    cover *c = ctx;
    for (uint32_t i = begin; i < end; i++)
        atomic_fetch_add(&c->hits[i], 1);
}

static int covered_once(uint32_t n, uint32_t threads, uint32_t min_chunk)
{
    cover c = {n, calloc(n ? n : 1, 1)};
    rtk_parallel_ranges(n, threads, min_chunk, cover_range, &c);
    int ok = 1;
    for (uint32_t i = 0; i < n; i++)
        ok &= atomic_load(&c.hits[i]) == 1;
    free((void *)c.hits);
    return ok;
}

/* Runs that workers take from one counter (rtk_take_run): every item
 * once; with count the runs taken. */
typedef struct take {
    cover c;
    uint32_t next, workers;
    atomic_uint runs;
} take;

static void take_runs(void *ctx, uint32_t begin, uint32_t end)
{
    (void)begin, (void)end;
    take *t = ctx;
    for (uint32_t first, run; (run = rtk_take_run(&t->next, t->c.n, t->workers, &first)) > 0;) {
        cover_range(&t->c, first, first + run);
        atomic_fetch_add(&t->runs, 1);
    }
}

static int taken_once(uint32_t n, uint32_t workers, uint32_t *runs)
{
    take t = {{n, calloc(n ? n : 1, 1)}, 0, workers, 0};
    rtk_parallel_ranges(workers, workers, 1, take_runs, &t);
    int ok = 1;
    for (uint32_t i = 0; i < n; i++)
        ok &= atomic_load(&t.c.hits[i]) == 1;
    free((void *)t.c.hits);
    *runs = atomic_load(&t.runs);
    return ok;
}

/* Two outside threads running teams at the same time. */
typedef struct racer {
    uint32_t teams, wanted;
    int ok;
} racer;

static void *race(void *arg)
{
    racer *r = arg;
    r->ok = 1;
    for (uint32_t i = 0; i < r->teams; i++) {
        rounds *w = calloc(1, sizeof *w);
        w->rounds = 3;
        w->sleeper = MAX_MEMBERS;
        uint32_t size = rtk_team_run(r->wanted, round_member, w);
        r->ok &= size == r->wanted && atomic_load(&w->stale) == 0;
        free(w);
    }
    return NULL;
}

int main(void)
{
    check_team(0, 1);
    check_team(1, 1);
    check_team(2, 2);
    check_team(3, 3);
    check_team(8, 8);
    check_team(300, MAX_MEMBERS);
    check_team(2, 2);

    check_rounds(2, 2000, MAX_MEMBERS);
    check_rounds(3, 500, 1);
    check_rounds(2, 500, 0);
    check_rounds(8, 200, 5);

    nested n = {0};
    uint32_t outer = rtk_team_run(3, outer_member, &n);
    check(outer == 3 && atomic_load(&n.inner_size_sum) == 3 && atomic_load(&n.inner_calls) == 3 &&
              atomic_load(&n.inner_elsewhere) == 0,
          "a member's own team has one member, run on the member's thread (3 members: sizes sum %u, %u calls)",
          atomic_load(&n.inner_size_sum), atomic_load(&n.inner_calls));

    racer a = {2000, 2, 0}, b = {2000, 3, 0};
    pthread_t ta, tb;
    pthread_create(&ta, NULL, race, &a);
    pthread_create(&tb, NULL, race, &b);
    pthread_join(ta, NULL);
    pthread_join(tb, NULL);
    check(a.ok && b.ok, "two threads running 2,000 teams each at once (2 and 3 members): every team whole");

    int ranges_ok = 1;
    const uint32_t sizes[] = {0, 1, 2, 3, 63, 64, 65, 1000, 100003};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
        for (uint32_t threads = 0; threads <= 70; threads += threads < 4 ? 1 : 33)
            for (uint32_t chunk = 0; chunk <= 1000; chunk += 500)
                ranges_ok &= covered_once(sizes[i], threads, chunk);
    check(ranges_ok, "rtk_parallel_ranges covers every item once (0-100,003 items, 0-70 threads, chunks 0-1000)");

    int taken_ok = 1;
    uint32_t runs = 0;
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
        for (uint32_t workers = 1; workers <= 33; workers += 8)
            taken_ok &= taken_once(sizes[i], workers, &runs);
    check(taken_ok, "rtk_take_run hands out every item once (0-100,003 items, 1-33 workers)");
    /* Guided: about 2 workers ln(n / (2 workers)) runs, then one item each. */
    const int four = taken_once(100003, 4, &runs);
    check(four && runs < 200, "100,003 items to 4 workers in few runs (%u)", runs);

    /* Zeroed arrays: heap blocks of these sizes filled with 0xa5 and
     * freed first, so that a block handed back unzeroed shows. */
    int zero_ok = 1;
    const size_t zero_sizes[] = {0, 1, 4095, 65536 * 4 + 3, (size_t)5 << 20};
    for (size_t i = 0; i < sizeof zero_sizes / sizeof zero_sizes[0]; i++) {
        for (uint32_t threads = 0; threads <= 5; threads += 1 + 2 * (threads > 0)) {
            unsigned char *dirty = malloc(zero_sizes[i] + 1);
            if (dirty)
                memset(dirty, 0xa5, zero_sizes[i] + 1);
            free(dirty);
            unsigned char *z = rtk_alloc_zeroed(zero_sizes[i], 1, threads);
            zero_ok &= z != NULL;
            for (size_t k = 0; z && k < zero_sizes[i]; k++)
                zero_ok &= z[k] == 0;
            free(z);
        }
    }
    check(zero_ok, "rtk_alloc_zeroed gives zeros (0 B to 5 MiB, 0-4 threads)");
    check(rtk_alloc_zeroed(SIZE_MAX / 2, 3, 2) == NULL && strstr(rtk_error_message(), "too large") != NULL,
          "rtk_alloc_zeroed refuses a size that overflows: %s", rtk_error_message());

    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
