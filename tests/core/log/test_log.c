/* The log held during a timed span (rtk_log_hold / rtk_log_release):
 * nothing reaches stderr while held, every line does when the last hold
 * is released, in the order logged, from any thread; lines above the
 * level are dropped as ever; unheld lines are written at once. */
#include "core/core.h"
#include "check.h"
#include "scratch.h"
#include "capture.h"

#include <pthread.h>

/* What stderr's file holds now, while capturing. */
static void peek(char *out, size_t cap)
{
    fflush(stderr);
    FILE *f = fopen(in_tmp("stderr.txt"), "rb");
    size_t n = f ? fread(out, 1, cap - 1, f) : 0;
    out[n] = '\0';
    if (f)
        fclose(f);
}

static void *log_from_thread(void *arg)
{
    (void)arg;
    rtk_log(RTK_LOG_INFO, "line from a thread");
    return NULL;
}

int main(void)
{
    scratch_begin("rtk-log");
    rtk_log_set_level(RTK_LOG_INFO);
    char now[4096];
    int saved;

    capture_begin(&saved);
    rtk_log(RTK_LOG_INFO, "unheld");
    peek(now, sizeof now);
    const int unheld_at_once = strcmp(now, "rtk: unheld\n") == 0;
    rtk_log_hold();
    rtk_log(RTK_LOG_INFO, "first");
    rtk_log_hold();
    rtk_log(RTK_LOG_WARN, "second");
    rtk_log(RTK_LOG_DEBUG, "dropped");
    pthread_t id;
    const int threaded = pthread_create(&id, NULL, log_from_thread, NULL) == 0;
    if (threaded)
        pthread_join(id, NULL);
    rtk_log_release();
    peek(now, sizeof now);
    const int inner_kept = strcmp(now, "rtk: unheld\n") == 0;
    /* Enough lines to grow the buffer several times. */
    for (int i = 0; i < 2000; i++)
        rtk_log(RTK_LOG_INFO, "bulk %d", i);
    peek(now, sizeof now);
    const int bulk_kept = strcmp(now, "rtk: unheld\n") == 0;
    rtk_log_release();
    rtk_log(RTK_LOG_INFO, "after");
    rtk_log_release(); /* one too many: nothing to release */
    capture_end(saved);

    check(unheld_at_once, "an unheld line is written at once");
    check(inner_kept, "lines wait while an outer hold remains");
    check(bulk_kept, "2,000 held lines wait too");
    char expect[65536];
    size_t o = (size_t)snprintf(expect, sizeof expect, "rtk: unheld\nrtk: first\nrtk: warning: second\n%s",
                                threaded ? "rtk: line from a thread\n" : "");
    for (int i = 0; i < 2000; i++)
        o += (size_t)snprintf(expect + o, sizeof expect - o, "rtk: bulk %d\n", i);
    snprintf(expect + o, sizeof expect - o, "rtk: after\n");
    check(threaded, "a thread logs while held");
    check(strcmp(captured, expect) == 0, "released, every line in the order logged, the debug line dropped "
          "(%zu bytes, expected %zu)", strlen(captured), strlen(expect));
    scratch_end();
    printf("%d passed, %d failed\n", passed, failed);
    return failed != 0;
}
