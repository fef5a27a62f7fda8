/* What every fuzz target shares: a private directory the input is written
 * into (the loaders read files, not memory), and quiet logs (a warning per
 * input would be most of the time spent). Include once, in the target's
 * one source file. */
#ifndef RTK_FUZZ_COMMON_H
#define RTK_FUZZ_COMMON_H

#include "config/config.h"
#include "render/render.h"
#include "image/image.h"

#include <rtk/host.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char fuzz_dir[256];

/* Creates the private directory once; aborts when it cannot (no input
 * could be tried). */
static const char *fuzz_workdir(void)
{
    if (fuzz_dir[0])
        return fuzz_dir;
    const char *tmp = getenv("TMPDIR");
    snprintf(fuzz_dir, sizeof fuzz_dir, "%s/rtk-fuzz-XXXXXX", tmp && tmp[0] ? tmp : "/tmp");
    if (!mkdtemp(fuzz_dir)) {
        perror("rtk fuzz: cannot create its working directory");
        abort();
    }
    return fuzz_dir;
}

/* Writes data to <workdir>/name and returns the path (static buffer). */
static const char *fuzz_write(const char *name, const uint8_t *data, size_t size)
{
    static char path[512];
    snprintf(path, sizeof path, "%s/%s", fuzz_workdir(), name);
    FILE *f = fopen(path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0) {
        perror("rtk fuzz: cannot write the input file");
        abort();
    }
    return path;
}

/* Errors only: the loaders' warnings are expected on most inputs. */
static void fuzz_quiet(void)
{
    if (!getenv("RTK_FUZZ_VERBOSE"))
        rtk_log_set_level(RTK_LOG_ERROR);
}

#endif
