/* Logging to stderr and the per-thread error buffer. */
#include "core.h"

#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static rtk_log_level log_level = RTK_LOG_INFO;
static pthread_mutex_t log_lock = PTHREAD_MUTEX_INITIALIZER;
static _Thread_local char error_text[4096];

static const char *const level_names[] = {"error", "warning", "info", "debug"};

/* Formats into out (cap bytes) with control characters shown as \xNN:
 * names from files (objects, materials, paths) reach every message, and
 * an escape sequence in one would drive the terminal. Newlines and tabs
 * stay; C1 controls (U+0080..U+009F, C2 80..C2 9F in UTF-8) are shown too. */
static void format_safe(char *out, size_t cap, const char *fmt, va_list ap)
{
    char raw[4096];
    vsnprintf(raw, sizeof raw, fmt, ap);
    size_t o = 0;
    for (const unsigned char *p = (const unsigned char *)raw; *p && o + 1 < cap; p++) {
        unsigned c = *p;
        if (c == 0xC2 && p[1] >= 0x80 && p[1] <= 0x9F)
            c = *++p;
        else if (!((c < 0x20 && c != '\n' && c != '\t') || c == 0x7F)) {
            out[o++] = (char)c;
            continue;
        }
        if (o + 5 > cap)
            break;
        o += (size_t)snprintf(out + o, cap - o, "\\x%02x", c);
    }
    out[o] = '\0';
}

/* Lines waiting while the log is held; under log_lock. */
static struct {
    unsigned depth;
    char *text;
    size_t len, cap;
} held;

/* Writes the held lines; log_lock is held. */
static void flush_held(void)
{
    if (held.len)
        fwrite(held.text, 1, held.len, stderr);
    free(held.text);
    held.text = NULL;
    held.len = held.cap = 0;
}

static void log_va(rtk_log_level level, const char *fmt, va_list ap)
{
    if (level > log_level)
        return;
    char line[4096], out[4200];
    format_safe(line, sizeof line, fmt, ap);
    int n = level == RTK_LOG_INFO ? snprintf(out, sizeof out, "rtk: %s\n", line)
                                  : snprintf(out, sizeof out, "rtk: %s: %s\n", level_names[level], line);
    const size_t len = n < 0 ? 0 : (size_t)n < sizeof out ? (size_t)n : sizeof out - 1;
    pthread_mutex_lock(&log_lock);
    if (held.depth && held.len + len > held.cap) {
        const size_t cap = 2 * (held.len + len) + 4096;
        char *more = realloc(held.text, cap);
        if (more)
            held.text = more, held.cap = cap;
        else
            flush_held(); /* out of memory: written now, in order */
    }
    if (held.depth && held.text && held.len + len <= held.cap) {
        memcpy(held.text + held.len, out, len);
        held.len += len;
    } else {
        fwrite(out, 1, len, stderr);
    }
    pthread_mutex_unlock(&log_lock);
}

void rtk_log_hold(void)
{
    pthread_mutex_lock(&log_lock);
    held.depth++;
    pthread_mutex_unlock(&log_lock);
}

void rtk_log_release(void)
{
    pthread_mutex_lock(&log_lock);
    if (held.depth && --held.depth == 0)
        flush_held();
    pthread_mutex_unlock(&log_lock);
}

RTK_API void rtk_log(rtk_log_level level, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    log_va(level, fmt, ap);
    va_end(ap);
}

RTK_API void rtk_log_set_level(rtk_log_level level)
{
    log_level = level;
}

int rtk_log_enabled(rtk_log_level level)
{
    return level <= log_level;
}

RTK_API rtk_status rtk_error(rtk_status code, const char *fmt, ...)
{
    char text[sizeof error_text];
    va_list ap;
    va_start(ap, fmt);
    format_safe(text, sizeof text, fmt, ap);
    va_end(ap);
    memcpy(error_text, text, sizeof text);
    return code;
}

RTK_API const char *rtk_error_message(void)
{
    return error_text;
}

/* Keys already warned about; small, so a linear list is enough. */
static char **warned_keys;
static size_t warned_count;

void rtk_warn_once(const char *key, const char *fmt, ...)
{
    pthread_mutex_lock(&log_lock);
    for (size_t i = 0; i < warned_count; i++) {
        if (strcmp(warned_keys[i], key) == 0) {
            pthread_mutex_unlock(&log_lock);
            return;
        }
    }
    char **grown = realloc(warned_keys, (warned_count + 1) * sizeof *grown);
    char *copy = strdup(key);
    if (grown && copy) {
        warned_keys = grown;
        warned_keys[warned_count++] = copy;
    } else {
        if (grown)
            warned_keys = grown;
        free(copy);
    }
    pthread_mutex_unlock(&log_lock);
    va_list ap;
    va_start(ap, fmt);
    log_va(RTK_LOG_WARN, fmt, ap);
    va_end(ap);
}
