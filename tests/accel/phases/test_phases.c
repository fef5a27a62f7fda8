/* Build phases (kernel/accel/build_phase.c): a build with scene->build_log
 * set records the kernel's phases and the builder's marks (sah, lbvh,
 * median at 1 and 2 threads): names, times finite and >= 0, their sum
 * within the build, one thread's phases all serial, an instanced scene's
 * meshes and top level in one log; and rtk_build_phase does nothing
 * without a log or with build arguments too small to hold one. Structure
 * only: no figure here depends on the machine's speed. */
#include "render/render.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"

/* count random small triangles in [-1, 1]^3. */
static void add_soup(rtk_scene *s, uint32_t count, uint64_t seed)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, seed, 1u);
    for (uint32_t i = 0; i < count; i++) {
        float c[3];
        for (int k = 0; k < 3; k++)
            c[k] = 2.0f * rtk_pcg32_float(&rng) - 1.0f;
        uint32_t v[3];
        for (int j = 0; j < 3; j++)
            rtk_scene_add_vertex(s, c[0] + 0.02f * rtk_pcg32_float(&rng), c[1] + 0.02f * rtk_pcg32_float(&rng),
                                 c[2] + 0.02f * rtk_pcg32_float(&rng), &v[j]);
        rtk_scene_add_triangle(s, v[0], v[1], v[2], NULL, NULL, RTK_INVALID_ID);
    }
}

static const rtk_build_phase_time *find_phase(const rtk_build_log *log, const char *name)
{
    for (uint32_t k = 0; k < log->count; k++)
        if (strcmp(log->phases[k].name, name) == 0)
            return &log->phases[k];
    return NULL;
}

/* The checks every recorded build passes; wall is the caller's time of it. */
static void check_log(const rtk_build_log *log, const char *what, double wall, uint32_t threads)
{
    int named = 1, timed = 1, serial = 1;
    double sum = 0.0;
    for (uint32_t k = 0; k < log->count; k++) {
        const rtk_build_phase_time *p = &log->phases[k];
        named &= p->name != NULL && p->name[0] != '\0';
        timed &= isfinite(p->seconds) && p->seconds >= 0.0;
        serial &= p->parallel == 0;
        sum += p->seconds;
    }
    check(log->depth == 0 && log->dropped == 0 && log->count >= 4, "%s: the log is closed with %u phases", what,
          log->count);
    check(named, "%s: every phase is named", what);
    check(timed, "%s: every phase's time is finite and >= 0", what);
    check(isfinite(log->seconds) && sum <= log->seconds + 1e-9 && log->seconds <= wall + 1e-9,
          "%s: the phases' sum %.9f s <= the recorded build %.9f s <= the call's %.9f s", what, sum, log->seconds,
          wall);
    if (threads == 1)
        check(serial, "%s: on one thread every phase is serial", what);
}

static void test_builder(const rtk_plugin *p, const char *key, const char *value, const char *mark, uint32_t threads)
{
    char what[128];
    snprintf(what, sizeof what, "%s%s%s%s, %u thread%s", p->name, key ? " " : "", key ? key : "",
             key ? value : "", threads, threads == 1 ? "" : "s");
    rtk_scene *s = rtk_scene_new("phases", 0);
    add_soup(s, 20000, 7);
    rtk_params *params = rtk_params_defaults(p);
    if (key)
        rtk_params_set_text(params, key, value);
    rtk_build_log log;
    memset(&log, 0, sizeof log);
    s->build_log = &log;
    double t0 = rtk_now();
    rtk_status st = rtk_bvh_build(s, p, params, threads);
    double wall = rtk_now() - t0;
    s->build_log = NULL;
    check(st == RTK_OK, "%s: build", what);
    check_log(&log, what, wall, threads);
    static const char *kernel[] = {"kernel: allocate", "builder: create", "builder: unmarked",
                                   "wide: collapse and leaves"};
    for (size_t k = 0; k < sizeof kernel / sizeof *kernel; k++) {
        const rtk_build_phase_time *ph = find_phase(&log, kernel[k]);
        check(ph && !ph->builder, "%s: the kernel's phase '%s'", what, kernel[k]);
    }
    const rtk_build_phase_time *ph = find_phase(&log, mark);
    check(ph && ph->builder, "%s: the builder's mark '%s'", what, mark);
    uint32_t builder = 0, parallel = 0;
    for (uint32_t k = 0; k < log.count; k++) {
        builder += log.phases[k].builder;
        parallel += log.phases[k].parallel > 0;
    }
    check(builder >= 1, "%s: %u phases marked by the builder", what, builder);
    if (threads > 1 && strcmp(p->name, "median") != 0)
        check(parallel >= 1, "%s: %u phases on several threads", what, parallel);

    /* Built again without a log: the last one is left as it was. */
    rtk_build_log copy = log;
    check(rtk_bvh_build(s, p, params, threads) == RTK_OK && memcmp(&copy, &log, sizeof log) == 0,
          "%s: a build without a log records nothing", what);
    rtk_params_destroy(params);
    rtk_scene_free(s);
}

static void test_instanced(const rtk_plugin *p)
{
    rtk_scene *s = rtk_scene_new("phases", 0);
    add_soup(s, 3000, 11);
    uint32_t mi;
    rtk_scene_add_mesh(s, "soup", &mi);
    add_soup(s->meshes[mi], 5000, 13);
    for (int i = 0; i < 4; i++) {
        const double xf[12] = {1, 0, 0, 3.0 * i, 0, 1, 0, 0, 0, 0, 1, 0};
        rtk_scene_add_instance(s, mi, xf, "phases");
    }
    rtk_status st = rtk_scene_finish(s);
    rtk_params *params = rtk_params_defaults(p);
    rtk_build_log log;
    memset(&log, 0, sizeof log);
    s->build_log = &log;
    double t0 = rtk_now();
    if (st == RTK_OK)
        st = rtk_instances_build(s, p, params, 2, NULL, NULL);
    double wall = rtk_now() - t0;
    s->build_log = NULL;
    char what[64];
    snprintf(what, sizeof what, "%s, instanced, 2 threads", p->name);
    check(st == RTK_OK, "%s: build", what);
    check_log(&log, what, wall, 2);
    const rtk_build_phase_time *top = find_phase(&log, "instances: top level");
    check(top && log.count >= 2 && top == &log.phases[log.count - 1], "%s: the top level is the last phase", what);
    const rtk_build_phase_time *alloc = find_phase(&log, "kernel: allocate");
    check(alloc && alloc->marks == 2 && top->marks == 1,
          "%s: the scene's and the mesh's builds add up in one log (%u marks of 'kernel: allocate')", what,
          alloc ? alloc->marks : 0);
    check(s->meshes[mi]->build_log == NULL, "%s: the mesh's log pointer is left NULL", what);
    rtk_params_destroy(params);
    rtk_scene_free(s);
}

/* rtk_build_phase as a builder calls it, on a log open for a build. */
static void test_no_op(void)
{
    rtk_build_log log;
    memset(&log, 0, sizeof log);
    rtk_build_args a;
    memset(&a, 0, sizeof a);
    a.size = sizeof a;
    a.phase_log = &log;
    rtk_build_phase(&a, "closed", 1);
    check(log.count == 0, "a closed log takes no mark");
    rtk_build_log_begin(&log);
    rtk_build_phase(&a, "first", 1);
    rtk_build_phase(&a, NULL, 0);
    check(log.count == 2 && strcmp(log.phases[0].name, "first") == 0 && log.phases[0].parallel == 1 &&
              log.phases[0].builder == 1 && log.phases[1].name && log.phases[1].name[0] && log.phases[1].parallel == 0,
          "an open log takes the builder's marks (a NULL name gets one)");
    a.phase_log = NULL;
    rtk_build_phase(&a, "nobody records", 1);
    check(log.count == 2, "args->phase_log NULL: no mark");
    a.phase_log = &log;
    a.size = (uint32_t)offsetof(rtk_build_args, phase_log);
    rtk_build_phase(&a, "older kernel", 1);
    check(log.count == 2, "args->size short of phase_log (an older kernel's args): no mark");
    rtk_build_phase(NULL, "no args", 1);
    check(log.count == 2, "args NULL: no mark");
    a.size = sizeof a;
    rtk_build_phase(&a, "first", 1);
    rtk_build_phase(&a, "first", 0);
    check(log.count == 3 && log.phases[0].marks == 2 && log.phases[2].marks == 1 && log.phases[2].parallel == 0,
          "a phase marked again adds to its entry, unless its flags differ");
    static char names[RTK_BUILD_LOG_MAX + 5][16];
    for (int i = 0; i < RTK_BUILD_LOG_MAX + 5; i++) {
        snprintf(names[i], sizeof names[i], "phase %d", i);
        rtk_build_phase(&a, names[i], 1);
    }
    check(log.count == RTK_BUILD_LOG_MAX && log.dropped == 8,
          "past %u phases marks are counted, not kept (%u kept, %u dropped)", RTK_BUILD_LOG_MAX, log.count,
          log.dropped);
    rtk_build_log_end(&log);
    double sum = 0.0;
    for (uint32_t k = 0; k < log.count; k++)
        sum += log.phases[k].seconds;
    check(log.depth == 0 && sum <= log.seconds + 1e-9, "end closes the log; the phases' sum is within its time");
    rtk_build_log_mark(NULL, "nothing", 0, 0);
    rtk_build_log_begin(NULL);
    rtk_build_log_end(NULL);
    check(1, "a NULL log is ignored");
}

int main(void)
{
    rtk_log_set_level(RTK_LOG_WARN);
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK) {
        printf("FAIL  registry: %s\n", rtk_error_message());
        return 1;
    }
    test_no_op();
    static const struct {
        const char *name, *key, *value, *mark;
    } builders[] = {
        {"sah", NULL, NULL, "sah: refs"},
        {"sah", "mode", "sweep", "sah: sort centroids"},
        {"lbvh", NULL, NULL, "lbvh: sort"},
        {"median", NULL, NULL, "median: subtrees"},
    };
    for (size_t i = 0; i < sizeof builders / sizeof *builders; i++) {
        const rtk_plugin *p = NULL;
        if (rtk_registry_find(reg, RTK_KIND_ACCELERATOR, builders[i].name, &p) != RTK_OK) {
            check(0, "accelerator %s is found", builders[i].name);
            continue;
        }
        for (uint32_t threads = 1; threads <= 2; threads++)
            test_builder(p, builders[i].key, builders[i].value, builders[i].mark, threads);
        if (i == 0)
            test_instanced(p);
    }
    rtk_registry_destroy(reg);
    printf("%d passed, %d failed\n", passed, failed);
    return failed != 0;
}
