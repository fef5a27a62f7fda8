/* Small helpers: checked allocation, paths, clocks, memory figures. */
#include "core.h"

#include <errno.h>
#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

void *rtk_alloc(size_t size)
{
    void *p = malloc(size ? size : 1);
    if (!p)
        rtk_error(RTK_ERR_NOMEM, "out of memory allocating %zu bytes", size);
    return p;
}

void *rtk_alloc_large(size_t size)
{
    const size_t huge = (size_t)2 << 20;
    if (size > SIZE_MAX - huge) {
        rtk_error(RTK_ERR_NOMEM, "out of memory allocating %zu bytes", size);
        return NULL;
    }
    /* From 8 MiB on, whole huge pages (at most 2 MiB more, under 25%);
     * below, whole cache lines: an array that small fits the reach of the
     * TLB in 4 KiB pages, and a huge page fault may stall on compaction
     * (THP defrag "madvise", Debian's default), which would cost small
     * arrays more than the TLB saves. aligned_alloc wants the size a multiple of the alignment. */
    size_t align = 64, bytes = (size + 63) / 64 * 64;
    if (size >= 4 * huge)
        align = huge, bytes = (size + huge - 1) / huge * huge;
    void *p = aligned_alloc(align, bytes ? bytes : 64);
    if (!p) {
        rtk_error(RTK_ERR_NOMEM, "out of memory allocating %zu bytes", size);
        return NULL;
    }
#ifdef MADV_HUGEPAGE
    if (align == huge)
        madvise(p, bytes, MADV_HUGEPAGE); /* advice: where refused, nothing changes */
#endif
    return p;
}

void rtk_release_tail(void *block, size_t used, size_t size)
{
    const uintptr_t page = (uintptr_t)sysconf(_SC_PAGESIZE);
    uintptr_t from = ((uintptr_t)block + used + page - 1) / page * page;
    uintptr_t to = ((uintptr_t)block + size) / page * page;
    if (page > 0 && to > from)
        madvise((void *)from, to - from, MADV_DONTNEED); /* advice: a refusal changes nothing */
}

void *rtk_calloc(size_t count, size_t size)
{
    void *p = calloc(count ? count : 1, size ? size : 1);
    if (!p)
        rtk_error(RTK_ERR_NOMEM, "out of memory allocating %zu x %zu bytes", count, size);
    return p;
}

void *rtk_realloc_array(void *ptr, size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size) {
        rtk_error(RTK_ERR_NOMEM, "array of %zu x %zu bytes is too large", count, size);
        return NULL;
    }
    size_t bytes = count * size;
    void *p = realloc(ptr, bytes ? bytes : 1);
    if (!p)
        rtk_error(RTK_ERR_NOMEM, "out of memory allocating %zu x %zu bytes", count, size);
    return p;
}

int rtk_grow_array(void **array, uint32_t *cap, uint32_t count, size_t size)
{
    if (count < *cap)
        return 1;
    uint32_t want = *cap ? *cap + *cap / 2 + 1 : 8;
    if (want <= count || want > UINT32_MAX / 2) {
        rtk_error(RTK_ERR_NOMEM, "array of more than %u items", count);
        return 0;
    }
    void *grown = rtk_realloc_array(*array, want, size);
    if (!grown)
        return 0;
    *array = grown;
    *cap = want;
    return 1;
}

rtk_status rtk_out_open(rtk_out_file *out, const char *path)
{
    out->path = path;
    out->f = NULL;
    out->tmp = NULL;
    out->slot = -1;
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(slash ? slash + 1 : path, '.');
    rtk_temp_file t;
    rtk_status st = rtk_temp_open(&t, path, dot ? (size_t)(dot - path) : strlen(path));
    if (st != RTK_OK)
        return st;
    if (!(out->f = fdopen(t.fd, "w"))) {
        st = rtk_error(RTK_ERR_IO, "cannot write %s: cannot open its temporary file %s: %s", path, t.tmp,
                       strerror(errno));
        rtk_temp_commit(&t, 0);
        return st;
    }
    out->tmp = t.tmp;
    out->slot = t.slot;
    return RTK_OK;
}

rtk_status rtk_out_close(rtk_out_file *out, int ok)
{
    if (!out->f)
        return RTK_OK;
    rtk_temp_file t = {.fd = -1, .tmp = out->tmp, .path = out->path, .slot = out->slot};
    if (fflush(out->f) != 0)
        t.err = errno;
    else if (ferror(out->f))
        t.err = EIO;
    else if (ok && fsync(fileno(out->f)) != 0)
        t.err = errno;
    if (fclose(out->f) != 0 && !t.err)
        t.err = errno;
    out->f = NULL;
    out->tmp = NULL;
    out->slot = -1;
    return rtk_temp_commit(&t, ok);
}

char *rtk_strdup(const char *s)
{
    if (!s)
        return NULL;
    size_t n = strlen(s) + 1;
    char *d = rtk_alloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

char *rtk_path_join(const char *dir, const char *path)
{
    if (!path)
        return NULL;
    if (path[0] == '/' || !dir || !dir[0] || strcmp(dir, ".") == 0)
        return rtk_strdup(path);
    size_t a = strlen(dir), b = strlen(path);
    char *out = rtk_alloc(a + b + 2);
    if (!out)
        return NULL;
    memcpy(out, dir, a);
    size_t k = a;
    if (dir[a - 1] != '/')
        out[k++] = '/';
    memcpy(out + k, path, b + 1);
    return out;
}

char *rtk_path_dirname(const char *path)
{
    const char *slash = path ? strrchr(path, '/') : NULL;
    if (!slash)
        return rtk_strdup(".");
    if (slash == path)
        return rtk_strdup("/");
    size_t n = (size_t)(slash - path);
    char *out = rtk_alloc(n + 1);
    if (out) {
        memcpy(out, path, n);
        out[n] = '\0';
    }
    return out;
}

double rtk_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

size_t rtk_peak_rss(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0)
        return 0;
    return (size_t)ru.ru_maxrss * 1024u; /* Linux reports kilobytes */
}

int rtk_edit_distance(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b);
    if (la > 64 || lb > 64)
        return INT_MAX;
    int row[65];
    for (size_t j = 0; j <= lb; j++)
        row[j] = (int)j;
    for (size_t i = 1; i <= la; i++) {
        int diag = row[0];
        row[0] = (int)i;
        for (size_t j = 1; j <= lb; j++) {
            int up = row[j];
            int cost = a[i - 1] == b[j - 1] ? 0 : 1;
            int best = diag + cost;
            if (row[j] + 1 < best)
                best = row[j] + 1;
            if (row[j - 1] + 1 < best)
                best = row[j - 1] + 1;
            row[j] = best;
            diag = up;
        }
    }
    return row[lb];
}

