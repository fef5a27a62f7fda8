/* Files rtk writes (images, CSV and text files, BVH cache files) go to a
 * temporary sibling "STEM.tmp<pid>-<n>EXT" that is renamed over the target
 * only once every byte is written and synced, so the target is either the
 * old file or the complete new one. Rules for callers:
 * - every temporary is registered (rtk_temp_register) from before it is
 *   created until after it is renamed or removed, so that the SIGINT and
 *   SIGTERM handler (through rtk_interrupt_cleanup) can remove it;
 * - while a temporary is open SIGXFSZ is ignored, so that a file size limit
 *   is a write error (EFBIG) like a full disk (ENOSPC), not a kill;
 * - rtk_temp_open removes temporaries of the same target left by processes
 *   that no longer run (SIGKILL, power loss), matched by exact name;
 * - rtk_interrupt_phase says what the process is doing, for the one line
 *   an interrupt prints. */
#ifndef RTK_KERNEL_OUTPUT_H
#define RTK_KERNEL_OUTPUT_H

#include <rtk/rtk.h>

#include <stdint.h>

RTK_EXTERN_C_BEGIN

/* A file being written through its temporary sibling. */
typedef struct rtk_temp_file {
    int fd;           /* write here between open and commit; -1 when closed */
    char *tmp;        /* the temporary's name */
    const char *path; /* the target, borrowed: must outlive the file */
    int err;          /* errno of the first failed write, 0 when none */
    int slot;         /* interrupt registry slot, -1 when none */
} rtk_temp_file;

/* Checks that path can be written: its directory exists and is writable,
 * and path is not a directory. The error names path and the fix. */
rtk_status rtk_output_check(const char *path);

/* Creates path's temporary sibling (mode 0666 less umask) after removing
 * stale ones, registers it and ignores SIGXFSZ until rtk_temp_commit.
 * stem_len: where ".tmp<pid>-<n>" goes into path (before the extension for
 * images, so the name keeps it; strlen(path) to append it). */
rtk_status rtk_temp_open(rtk_temp_file *t, const char *path, size_t stem_len);

/* Writes size bytes at offset, retrying short writes and EINTR; on failure
 * records errno in t->err (the first one) and returns 0. */
int rtk_temp_write_at(rtk_temp_file *t, const void *data, size_t size, uint64_t offset);

/* Finishes: when ok and no write failed, syncs, closes and renames the
 * temporary over path; otherwise (or when any of those fails) removes it.
 * The error says what failed and that path is unchanged. A caller that
 * wrote through its own descriptor syncs and closes it and sets fd = -1. */
rtk_status rtk_temp_commit(rtk_temp_file *t, int ok);

/* Removes temporaries "STEM.tmp<pid>-<n>EXT" of path (split at stem_len)
 * whose pid is not a running process; returns how many. */
uint32_t rtk_temp_remove_stale(const char *path, size_t stem_len);

/* Ignores SIGXFSZ until the matching release (counted, [any thread]):
 * for writers that do not go through rtk_temp_open. */
void rtk_xfsz_hold(void);
void rtk_xfsz_release(void);

/* Registers a temporary file name for removal on SIGINT/SIGTERM; returns
 * its slot, or -1 when the registry is full (the name is then left to
 * rtk_temp_remove_stale). [any thread] */
RTK_KERNEL_API int rtk_temp_register(const char *tmp);
/* Forgets a slot; -1 is ignored. [any thread] */
RTK_KERNEL_API void rtk_temp_unregister(int slot);
/* Forgets the slot registered for tmp, if any. [one thread per name] */
RTK_KERNEL_API void rtk_temp_unregister_path(const char *tmp);

/* What the process does now, for the interrupt message: phase is a static
 * string ("loading the scene", "rendering", ...) or NULL; output the file
 * it will write (copied) or NULL. Test hook: when RTK_TEST_STOP_AT names
 * the phase's first word, the process stops itself (SIGSTOP) there. */
void rtk_interrupt_phase(const char *phase, const char *output);

/* Test hook of the write phase: stops the process (SIGSTOP) when
 * RTK_TEST_STOP_AT is "write"; called with the temporary created. */
void rtk_interrupt_stop_point(const char *word);

RTK_EXTERN_C_END

#endif
