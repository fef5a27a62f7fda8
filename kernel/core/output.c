/* Safe outputs: temporary siblings renamed into place, the registry of live
 * temporaries that a SIGINT/SIGTERM handler removes, the phase an
 * interrupt reports, and the removal of temporaries a killed run left.
 * The registry and the phase are read by a signal handler: fixed arrays of
 * lock-free atomics and plain bytes, nothing allocated. */
#include "core.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* More temporaries than are ever open at once (a render holds one). */
#define TEMP_SLOTS 32

enum { SLOT_FREE = 0, SLOT_FILLING = 1, SLOT_LIVE = 2 };

static struct {
    atomic_int state;
    char path[PATH_MAX];
} temps[TEMP_SLOTS];

static _Atomic(const char *) current_phase;
static atomic_int output_set;
static char current_output[PATH_MAX];

int rtk_temp_register(const char *tmp)
{
    size_t n = strlen(tmp);
    if (n >= PATH_MAX)
        return -1;
    for (int i = 0; i < TEMP_SLOTS; i++) {
        int expected = SLOT_FREE;
        if (atomic_compare_exchange_strong(&temps[i].state, &expected, SLOT_FILLING)) {
            memcpy(temps[i].path, tmp, n + 1);
            atomic_store(&temps[i].state, SLOT_LIVE);
            return i;
        }
    }
    return -1;
}

void rtk_temp_unregister(int slot)
{
    if (slot >= 0 && slot < TEMP_SLOTS)
        atomic_store(&temps[slot].state, SLOT_FREE);
}

void rtk_temp_unregister_path(const char *tmp)
{
    for (int i = 0; tmp && i < TEMP_SLOTS; i++)
        if (atomic_load(&temps[i].state) == SLOT_LIVE && strcmp(temps[i].path, tmp) == 0) {
            atomic_store(&temps[i].state, SLOT_FREE);
            return;
        }
}

void rtk_interrupt_stop_point(const char *word)
{
    const char *at = getenv("RTK_TEST_STOP_AT");
    if (at && word && strcmp(at, word) == 0)
        raise(SIGSTOP);
}

void rtk_interrupt_phase(const char *phase, const char *output)
{
    if (output) {
        atomic_store(&output_set, 0);
        snprintf(current_output, sizeof current_output, "%s", output);
        atomic_store(&output_set, 1);
    } else {
        atomic_store(&output_set, 0);
    }
    atomic_store(&current_phase, phase);
    if (phase) {
        char word[32];
        size_t n = strcspn(phase, " ");
        snprintf(word, sizeof word, "%.*s", (int)(n < sizeof word ? n : sizeof word - 1), phase);
        rtk_interrupt_stop_point(word);
    }
}

/* Appends s to buf[*len, cap), async-signal-safe. */
static void put(char *buf, size_t *len, size_t cap, const char *s)
{
    while (*s && *len + 1 < cap)
        buf[(*len)++] = *s++;
}

RTK_API void rtk_interrupt_cleanup(int sig)
{
    for (int i = 0; i < TEMP_SLOTS; i++)
        if (atomic_load(&temps[i].state) == SLOT_LIVE)
            unlink(temps[i].path);
    char line[PATH_MAX + 256];
    size_t len = 0;
    put(line, &len, sizeof line, "rtk: interrupted by ");
    put(line, &len, sizeof line, sig == SIGINT ? "SIGINT" : "SIGTERM");
    const char *phase = atomic_load(&current_phase);
    if (phase) {
        put(line, &len, sizeof line, " while ");
        put(line, &len, sizeof line, phase);
    }
    if (atomic_load(&output_set)) {
        put(line, &len, sizeof line, "; '");
        put(line, &len, sizeof line, current_output);
        put(line, &len, sizeof line, "' was not written");
        if (access(current_output, F_OK) == 0)
            put(line, &len, sizeof line, " (the previous file is unchanged)");
    }
    line[len++] = '\n';
    ssize_t unused = write(STDERR_FILENO, line, len);
    (void)unused;
}

/* SIGXFSZ is ignored while any temporary is open, so that a file size
 * limit makes write() fail with EFBIG instead of killing the process. */
static pthread_mutex_t xfsz_lock = PTHREAD_MUTEX_INITIALIZER;
static int xfsz_holds;
static struct sigaction xfsz_saved;

void rtk_xfsz_hold(void)
{
    pthread_mutex_lock(&xfsz_lock);
    if (xfsz_holds++ == 0) {
        struct sigaction sa;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = SIG_IGN;
        sigemptyset(&sa.sa_mask);
        sigaction(SIGXFSZ, &sa, &xfsz_saved);
    }
    pthread_mutex_unlock(&xfsz_lock);
}

void rtk_xfsz_release(void)
{
    pthread_mutex_lock(&xfsz_lock);
    if (--xfsz_holds == 0)
        sigaction(SIGXFSZ, &xfsz_saved, NULL);
    pthread_mutex_unlock(&xfsz_lock);
}

/* Parses 1 to 10 decimal digits at *s; 0 when there are none or more. */
static int parse_digits(const char **s, unsigned long *value)
{
    const char *p = *s;
    unsigned long v = 0;
    while (*p >= '0' && *p <= '9' && p - *s < 10)
        v = v * 10 + (unsigned long)(*p++ - '0');
    if (p == *s || (*p >= '0' && *p <= '9'))
        return 0;
    *s = p;
    *value = v;
    return 1;
}

/* Pid of the process that made name, when name is exactly
 * "<stem>.tmp<pid>-<n><ext>"; 0 otherwise. */
static long temp_owner(const char *name, const char *stem, size_t stem_n, const char *ext)
{
    if (strncmp(name, stem, stem_n) != 0 || strncmp(name + stem_n, ".tmp", 4) != 0)
        return 0;
    const char *p = name + stem_n + 4;
    unsigned long pid, n;
    if (!parse_digits(&p, &pid) || *p++ != '-' || !parse_digits(&p, &n) || strcmp(p, ext) != 0)
        return 0;
    return pid > 0 && pid <= INT_MAX ? (long)pid : 0;
}

uint32_t rtk_temp_remove_stale(const char *path, size_t stem_len)
{
    const char *slash = strrchr(path, '/');
    size_t base = slash ? (size_t)(slash - path) + 1 : 0;
    if (stem_len < base)
        return 0;
    char *dir = rtk_path_dirname(path);
    if (!dir)
        return 0;
    DIR *d = opendir(dir);
    uint32_t removed = 0;
    const char *stem = path + base, *ext = path + stem_len;
    size_t stem_n = stem_len - base;
    long self = (long)getpid();
    for (struct dirent *e; d && (e = readdir(d)) != NULL;) {
        long pid = temp_owner(e->d_name, stem, stem_n, ext);
        if (pid == 0 || pid == self || kill((pid_t)pid, 0) == 0 || errno != ESRCH)
            continue;
        struct stat st;
        if (fstatat(dirfd(d), e->d_name, &st, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(st.st_mode))
            continue;
        if (unlinkat(dirfd(d), e->d_name, 0) == 0) {
            removed++;
            rtk_log(RTK_LOG_INFO, "removed '%s/%s', a temporary file left by process %ld, which no longer runs",
                    dir, e->d_name, pid);
        }
    }
    if (d)
        closedir(d);
    free(dir);
    return removed;
}

rtk_status rtk_output_check(const char *path)
{
    char *dir = rtk_path_dirname(path);
    if (!dir)
        return RTK_ERR_NOMEM;
    struct stat st;
    rtk_status status = RTK_OK;
    if (stat(dir, &st) != 0)
        status = rtk_error(RTK_ERR_IO, "cannot write '%s': directory '%s' %s; create it or write elsewhere", path,
                           dir, errno == ENOENT ? "does not exist" : strerror(errno));
    else if (!S_ISDIR(st.st_mode))
        status = rtk_error(RTK_ERR_IO, "cannot write '%s': '%s' is not a directory; write elsewhere", path, dir);
    else if (access(dir, W_OK | X_OK) != 0)
        status = rtk_error(RTK_ERR_IO, "cannot write '%s': directory '%s' is not writable (%s); write elsewhere", path,
                           dir, strerror(errno));
    else if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        status = rtk_error(RTK_ERR_IO, "cannot write '%s': it is a directory; name a file", path);
    free(dir);
    return status;
}

rtk_status rtk_temp_open(rtk_temp_file *t, const char *path, size_t stem_len)
{
    static atomic_uint counter;
    t->fd = -1;
    t->err = 0;
    t->slot = -1;
    t->path = path;
    t->tmp = NULL;
    rtk_temp_remove_stale(path, stem_len);
    size_t size = strlen(path) + 48;
    if (!(t->tmp = rtk_alloc(size)))
        return RTK_ERR_NOMEM;
    snprintf(t->tmp, size, "%.*s.tmp%ld-%u%s", (int)stem_len, path, (long)getpid(), atomic_fetch_add(&counter, 1),
             path + stem_len);
    t->slot = rtk_temp_register(t->tmp);
    rtk_xfsz_hold();
    t->fd = open(t->tmp, O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (t->fd < 0) {
        rtk_status st = rtk_error(RTK_ERR_IO, "cannot write '%s': cannot create its temporary file '%s': %s", path,
                                  t->tmp, strerror(errno));
        rtk_temp_unregister(t->slot);
        rtk_xfsz_release();
        free(t->tmp);
        t->tmp = NULL;
        t->slot = -1;
        return st;
    }
    rtk_interrupt_stop_point("write");
    return RTK_OK;
}

int rtk_temp_write_at(rtk_temp_file *t, const void *data, size_t size, uint64_t offset)
{
    const unsigned char *p = data;
    while (size > 0 && t->err == 0) {
        ssize_t n = pwrite(t->fd, p, size, (off_t)offset);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            t->err = n < 0 ? errno : EIO;
            break;
        }
        p += n;
        size -= (size_t)n;
        offset += (uint64_t)n;
    }
    return t->err == 0;
}

rtk_status rtk_temp_commit(rtk_temp_file *t, int ok)
{
    if (!t->tmp)
        return RTK_OK;
    int err = t->err;
    const char *step = "writing";
    if (t->fd >= 0) {
        if (ok && !err && fsync(t->fd) != 0)
            err = errno, step = "syncing";
        if (close(t->fd) != 0 && ok && !err)
            err = errno, step = "closing";
        t->fd = -1;
    }
    int existed = access(t->path, F_OK) == 0;
    if (ok && !err && rename(t->tmp, t->path) != 0)
        err = errno, step = "renaming";
    if (!ok || err)
        unlink(t->tmp);
    rtk_temp_unregister(t->slot);
    t->slot = -1;
    rtk_xfsz_release();
    rtk_status st = RTK_OK;
    if (ok && err)
        st = rtk_error(RTK_ERR_IO, "cannot write '%s': %s while %s its temporary file '%s', which was removed; %s",
                       t->path, strerror(err), step, t->tmp,
                       existed ? "the previous file is unchanged" : "no file was written");
    free(t->tmp);
    t->tmp = NULL;
    return st;
}
