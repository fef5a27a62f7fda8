/* The kernel's core: allocation and paths, logging, worker threads,
 * parameters, the plugin loader, reading files and writing them through
 * temporaries (output.h). Below every other kernel module; nothing here
 * knows a scene. Kernel headers are not the SDK: plugins see only
 * include/rtk/, and the tools the few RTK_KERNEL_API services. */
#ifndef RTK_KERNEL_CORE_H
#define RTK_KERNEL_CORE_H

#include <rtk/host.h>
#include <rtk/rtk.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

/* A kernel service the tools under tools/ (rtk conform, bench, diff,
 * sweep) call across librtk.so: exported, but declared only in kernel
 * headers, so not part of the SDK and free to change with the kernel. */
#define RTK_KERNEL_API RTK_EXPORT

#include "output.h"

RTK_EXTERN_C_BEGIN

/* ---- small utilities (util.c) ---- */

/* malloc/calloc/realloc that record RTK_ERR_NOMEM on failure. */
RTK_KERNEL_API void *rtk_alloc(size_t size);
RTK_KERNEL_API void *rtk_calloc(size_t count, size_t size);
RTK_KERNEL_API void *rtk_realloc_array(void *ptr, size_t count, size_t size);
/* Makes room for item count of *array (capacity *cap, items of size
 * bytes), growing by half; 1 on success, 0 (error set) when out of memory
 * or past 2^31 items, *array left alone. */
int rtk_grow_array(void **array, uint32_t *cap, uint32_t count, size_t size);
/* rtk_alloc for large arrays, on a 64-byte boundary; from 8 MiB on,
 * rounded up to whole 2 MiB pages on a 2 MiB boundary, advised as
 * transparent huge pages, which cuts the cost of first touching it and
 * keeps traversal out of TLB misses. Freed with free(). */
RTK_KERNEL_API void *rtk_alloc_large(size_t size);
/* glibc's largest threshold for giving an allocation a mapping of its
 * own (DEFAULT_MMAP_THRESHOLD_MAX on 64 bits): arrays above it are fresh
 * memory, first touched page by page, every time they are allocated. */
#define RTK_FRESH_ALLOC_BYTES ((size_t)32 << 20)
/* Gives the whole pages of block[used, size) back to the system (they
 * read as zeros if touched again); the block stays allocated. */
void rtk_release_tail(void *block, size_t used, size_t size);
/* Calls fn(ctx, begin, end) over [0, n) cut into at most threads
 * contiguous ranges, the first on the calling thread, the others on
 * threads of their own (run on the caller when a thread cannot start);
 * returns when all are done. Ranges below min_chunk items are not cut. */
typedef void (*rtk_range_fn)(void *ctx, uint32_t begin, uint32_t end);
void rtk_parallel_ranges(uint32_t n, uint32_t threads, uint32_t min_chunk, rtk_range_fn fn, void *ctx);
/* The next run [*first, *first + run) of count items that workers take
 * from the shared counter *next (atomic): half of what is left over the
 * workers, at least 1 (guided), so that neighbouring items, which
 * mostly write neighbouring memory, go to one worker. Returns run, 0
 * when none is left. */
uint32_t rtk_take_run(uint32_t *next, uint32_t count, uint32_t workers, uint32_t *first);
/* rtk_calloc for arrays read before they are written (sums and marks
 * added to), zeroed by writes on up to threads threads; freed with free().
 * calloc's untouched pages would be read first, which maps the shared
 * zero page, and the write after it copies the page and flushes the TLB
 * of every core running the process: an interrupt per page for each. */
RTK_KERNEL_API void *rtk_alloc_zeroed(size_t count, size_t size, uint32_t threads);
/* A file written through a temporary sibling (name.tmp<pid>-<n>.ext, see
 * output.h) and renamed over path only when complete, so that a failed or
 * interrupted write never leaves a half-written file under path. */
typedef struct rtk_out_file {
    FILE *f;          /* write here between open and close */
    char *tmp;
    const char *path; /* borrowed: must outlive the file */
    int slot;         /* interrupt registry slot of tmp */
} rtk_out_file;
/* Opens the temporary file (error set, naming it, on failure). */
RTK_KERNEL_API rtk_status rtk_out_open(rtk_out_file *out, const char *path);
/* Closes; when ok and every write succeeded renames it over path, else
 * removes it. RTK_ERR_IO (naming path) when ok but writing failed. */
RTK_KERNEL_API rtk_status rtk_out_close(rtk_out_file *out, int ok);
/* strdup that returns NULL on NULL. [caller frees] */
RTK_KERNEL_API char *rtk_strdup(const char *s);
/* Joins dir and a relative path; absolute paths are returned as they are. [caller frees] */
char *rtk_path_join(const char *dir, const char *path);
/* Directory part of path ("." when none). [caller frees] */
char *rtk_path_dirname(const char *path);
/* Monotonic seconds. */
RTK_KERNEL_API double rtk_now(void);
/* Peak resident set size of this process in bytes (0 if unknown). */
size_t rtk_peak_rss(void);
/* Cores this process may use (>= 1): the online ones, within its CPU
 * affinity and its cgroup's CPU quota rounded up (kernel/core/cpus.c). */
RTK_KERNEL_API uint32_t rtk_core_count(void);
/* The CPU quota of this process's cgroup (v2 cpu.max, v1
 * cpu.cfs_quota_us, the least along its cgroup's ancestors) in whole
 * CPUs rounded up, 0 when none is set; root prefixes every path read
 * ("" on a live system). */
RTK_KERNEL_API uint32_t rtk_cgroup_cpu_limit(const char *root);
/* Edit distance between a and b, for "did you mean" suggestions. */
int rtk_edit_distance(const char *a, const char *b);

/* ---- logging (log.c) ---- */

/* Warns once per key for the life of the process (keys compared by text). */
void rtk_warn_once(const char *key, const char *fmt, ...) RTK_PRINTF(2, 3);
/* Whether lines of this level are printed: to skip work done only for them. */
RTK_KERNEL_API int rtk_log_enabled(rtk_log_level level);
/* While held (calls nest), lines wait in memory and are written, in
 * order, when the last hold is released: a timed span's own debug lines
 * (a write to a pipe wakes its reader) stay out of its time. */
RTK_KERNEL_API void rtk_log_hold(void);
RTK_KERNEL_API void rtk_log_release(void);

/* ---- params (params.c) ---- */

/* One value, after validation. */
typedef struct rtk_param_value {
    const rtk_param_desc *desc;
    int64_t i;
    double f;
    char *s;
    int set_by_user;
} rtk_param_value;

/* Validated values for one plugin instance; one entry per schema entry. */
struct rtk_params {
    const rtk_plugin *plugin;
    rtk_param_value *values;
    uint32_t count;
};

/* Params holding every default of plugin's schema. [caller frees] */
RTK_KERNEL_API rtk_params *rtk_params_defaults(const rtk_plugin *plugin);
/* Sets a declared parameter from its text form ("16", "0.5", "true",
 * "name"), checking type, range and choices; errors name the key. */
RTK_KERNEL_API rtk_status rtk_params_set_text(rtk_params *params, const char *name, const char *text);
RTK_KERNEL_API void rtk_params_destroy(rtk_params *params);
/* Checks a schema for sanity (names unique and non-empty, valid types,
 * defaults inside ranges and choices). Errors name the plugin. */
RTK_KERNEL_API rtk_status rtk_params_check_schema(const rtk_plugin *plugin);
/* Closest declared name to name, or NULL when none is close. */
const char *rtk_params_suggest(const rtk_param_desc *schema, uint32_t count, const char *name);

/* ---- plugins (plugins.c) ---- */

/* Checks a descriptor as the loader does; path is used in messages. */
rtk_status rtk_plugin_check(const rtk_plugin *plugin, const char *path, rtk_plugin_kind expected);

/* Whether this librtk (or the static copy in a test) runs from the build
 * tree (plugins.c): plugins and the image module are then taken from
 * there rather than from the install directories. */
int rtk_running_from_build_tree(void);
/* subpath joined to the directory librtk's own file lies in (plugins.c):
 * how an installed librtk finds its plugins and image module from any
 * prefix; NULL when that file is unknown. [caller frees] */
char *rtk_installed_path(const char *subpath);

/* ---- files (files.c) ---- */

/* Largest files read whole: an MTL, a glTF's JSON, a buffer or .glb, an
 * encoded image. */
#define RTK_MAX_TEXT_FILE ((uint64_t)256 << 20)
#define RTK_MAX_BUFFER_FILE ((uint64_t)16 << 30)
#define RTK_MAX_IMAGE_FILE ((uint64_t)1 << 30)
/* Opens a regular file for reading (never blocks on a FIFO; a directory,
 * FIFO or device is an error naming it); *size its size. [caller closes] */
rtk_status rtk_file_open(const char *path, const char *what, int *fd, uint64_t *size);
/* Reads all of the regular file path, refusing one above limit bytes;
 * (*bytes)[*count] is a 0 byte, so text can be read as a string.
 * [caller frees *bytes] */
rtk_status rtk_file_read(const char *path, const char *what, uint64_t limit, unsigned char **bytes, size_t *count);
/* Absolute path with symbolic links, "." and ".." resolved; the part that
 * does not exist is taken lexically. NULL when it cannot be. [caller frees] */
char *rtk_path_canonical(const char *path);

RTK_EXTERN_C_END

#endif
