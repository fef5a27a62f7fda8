/* The phases of a BVH build (accel.h): the kernel's own marks in
 * rtk_bvh_build and the wide collapse, and the builder's through
 * rtk_build_phase, recorded into the scene's build log for `rtk bench
 * --verbose`. Marks come from the thread that runs the build; a log
 * serves one build at a time. */
#include "accel.h"

#include <stddef.h>
#include <string.h>

void rtk_build_log_begin(rtk_build_log *log)
{
    if (!log)
        return;
    if (log->depth++ > 0)
        return;
    log->count = 0;
    log->open = 0;
    log->dropped = 0;
    log->seconds = 0.0;
    log->begun = log->at = rtk_now();
}

/* Adds the time since the open phase began to it. */
static void close_open(rtk_build_log *log, double now)
{
    if (log->open < log->count)
        log->phases[log->open].seconds += now - log->at;
    log->at = now;
}

void rtk_build_log_mark(rtk_build_log *log, const char *name, int parallel, int builder)
{
    if (!log || log->depth == 0)
        return;
    close_open(log, rtk_now());
    name = name && name[0] ? name : "(unnamed)";
    parallel = parallel > 0 ? 1 : parallel < 0 ? -1 : 0;
    uint32_t k = 0;
    while (k < log->count && (log->phases[k].parallel != parallel || log->phases[k].builder != builder ||
                              strcmp(log->phases[k].name, name) != 0))
        k++;
    if (k == RTK_BUILD_LOG_MAX) {
        log->dropped++;
        log->open = k - 1;
        return;
    }
    if (k == log->count)
        log->phases[log->count++] = (rtk_build_phase_time){.name = name, .parallel = parallel, .builder = builder};
    log->phases[k].marks++;
    log->open = k;
}

void rtk_build_log_end(rtk_build_log *log)
{
    if (!log || log->depth == 0 || --log->depth > 0)
        return;
    const double now = rtk_now();
    close_open(log, now);
    log->open = log->count;
    log->seconds = now - log->begun;
}

int rtk_ranges_parallel(uint32_t n, uint32_t threads, uint32_t min_chunk)
{
    /* rtk_parallel_ranges' count of ranges */
    uint32_t parts = threads > 64 ? 64 : threads;
    if (min_chunk && n / min_chunk < parts)
        parts = n / min_chunk;
    return parts > 1;
}

void rtk_build_phase(rtk_build_args *args, const char *name, int parallel)
{
    if (!args || args->size < offsetof(rtk_build_args, phase_log) + sizeof args->phase_log || !args->phase_log)
        return;
    rtk_build_log_mark(args->phase_log, name, parallel > 0, 1);
}
