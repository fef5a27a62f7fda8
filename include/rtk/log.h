/* Logging and error reporting, shared by the kernel, plugins and hosts.
 * Messages go to stderr through the kernel; errors are kept per thread. */
#ifndef RTK_LOG_H
#define RTK_LOG_H

#include <rtk/common.h>

RTK_EXTERN_C_BEGIN

/* Severity of a log line; lines above the current level are dropped. */
typedef enum rtk_log_level {
    RTK_LOG_ERROR = 0,
    RTK_LOG_WARN = 1,
    RTK_LOG_INFO = 2,
    RTK_LOG_DEBUG = 3
} rtk_log_level;

/* Prints one line (no trailing newline needed). [any thread] */
RTK_API void rtk_log(rtk_log_level level, const char *fmt, ...) RTK_PRINTF(2, 3);

/* Records the calling thread's error message and returns code, so that
 * `return rtk_error(RTK_ERR_INVALID, "...");` reads naturally. [any thread] */
RTK_API rtk_status rtk_error(rtk_status code, const char *fmt, ...) RTK_PRINTF(2, 3);

/* The calling thread's last error message ("" if none). [any thread] */
RTK_API const char *rtk_error_message(void);

RTK_EXTERN_C_END

#endif
