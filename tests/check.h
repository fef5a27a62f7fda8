/* The line every C test prints per check ("ok  " or "FAIL", then what was
 * checked) and the counts main reports at the end; and the create/destroy
 * pair of the stateless plugins tests define in place. Include once, in
 * the test's one source file. */
#ifndef RTK_TESTS_CHECK_H
#define RTK_TESTS_CHECK_H

#include <rtk/rtk.h>

#include <stdarg.h>
#include <stdio.h>

static int passed, failed;
/* Set to 1 by tests that run many checks per printed group: only
 * failures get a line of their own. */
static int check_failures_only;

static void check(int ok, const char *fmt, ...) RTK_PRINTF(2, 3);
static void check(int ok, const char *fmt, ...)
{
    char what[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    if (!ok || !check_failures_only)
        printf("%s  %s\n", ok ? "ok  " : "FAIL", what);
    ok ? passed++ : failed++;
}

static inline rtk_status stateless_create(const rtk_params *params, void **state)
{
    (void)params;
    *state = NULL;
    return RTK_OK;
}

static inline void stateless_destroy(void *state)
{
    (void)state;
}

#endif
