/* kernel/core/output.c and the write side of kernel/image/image.c through their C
 * interface: a JPEG too wide for libjpeg is refused before libjpeg can
 * exit; rtk_out_open/rtk_out_close (bench --csv, sweep) under a file size
 * limit fail with EFBIG, keep the old file and leave no temporary, and
 * SIGXFSZ's action is back to what it was afterwards; the registry hands
 * out each slot once. */
#include "check.h"
#include "config/config.h"
#include "render/render.h"
#include "image/image.h"
#include "core/core.h"

#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

static char dir[64];

static char *in_dir(const char *name)
{
    static char path[400];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    return path;
}

/* Entries of dir whose name contains ".tmp". */
static int temporaries(void)
{
    int n = 0;
    DIR *d = opendir(dir);
    for (struct dirent *e; d && (e = readdir(d)) != NULL;)
        n += strstr(e->d_name, ".tmp") != NULL;
    if (d)
        closedir(d);
    return n;
}

static void test_jpeg_limit(void)
{
    enum { w = 70000 };
    float *pixels = calloc((size_t)w * 3, sizeof *pixels);
    rtk_status st = rtk_image_write(in_dir("wide.jpg"), w, 1, 3, NULL, pixels, 0);
    check(st == RTK_ERR_UNSUPPORTED && strstr(rtk_error_message(), "larger than JPEG allows"),
          "a 70000x1 JPEG is refused before libjpeg sees it: %d '%s'", (int)st, rtk_error_message());
    check(access(in_dir("wide.jpg"), F_OK) != 0 && temporaries() == 0, "  and nothing was written");
    st = rtk_image_write(in_dir("wide.png"), w, 1, 3, NULL, pixels, 0);
    check(st == RTK_OK, "the same image as PNG is written: '%s'", st ? rtk_error_message() : "");
    free(pixels);
}

static void test_out_file_limit(void)
{
    const char *path = in_dir("table.csv");
    FILE *f = fopen(path, "w");
    fputs("old\n", f);
    fclose(f);
    struct sigaction before;
    sigaction(SIGXFSZ, NULL, &before);
    struct rlimit saved, small = {.rlim_cur = 4096, .rlim_max = RLIM_INFINITY};
    getrlimit(RLIMIT_FSIZE, &saved);
    small.rlim_max = saved.rlim_max;
    setrlimit(RLIMIT_FSIZE, &small);
    rtk_out_file out;
    rtk_status st = rtk_out_open(&out, path);
    check(st == RTK_OK, "rtk_out_open under a 4 KiB file size limit");
    if (st == RTK_OK) {
        for (int i = 0; i < 2000; i++)
            fprintf(out.f, "row %d of a table larger than the limit\n", i);
        st = rtk_out_close(&out, 1);
    }
    setrlimit(RLIMIT_FSIZE, &saved);
    check(st == RTK_ERR_IO && strstr(rtk_error_message(), "File too large") &&
              strstr(rtk_error_message(), "the previous file is unchanged"),
          "a CSV past the limit fails with EFBIG, not SIGXFSZ: '%s'", rtk_error_message());
    char text[16] = "";
    f = fopen(path, "r");
    size_t n = f ? fread(text, 1, sizeof text - 1, f) : 0;
    text[n] = '\0';
    if (f)
        fclose(f);
    check(strcmp(text, "old\n") == 0 && temporaries() == 0, "  the old CSV is kept and no temporary is left");
    struct sigaction after;
    sigaction(SIGXFSZ, NULL, &after);
    check(after.sa_handler == before.sa_handler, "  SIGXFSZ's action is restored");
}

static void test_registry(void)
{
    int slots[40], got = 0;
    for (int i = 0; i < 40; i++) {
        char name[32];
        snprintf(name, sizeof name, "/nonexistent/t%d", i);
        slots[i] = rtk_temp_register(name);
        got += slots[i] >= 0;
    }
    int distinct = 1;
    for (int i = 0; i < 40; i++)
        for (int j = i + 1; j < 40; j++)
            distinct &= slots[i] < 0 || slots[i] != slots[j];
    check(got == 32 && distinct && slots[39] == -1, "32 distinct registry slots, then -1 (%d)", got);
    for (int i = 0; i < 40; i++)
        rtk_temp_unregister(slots[i]);
    int again = rtk_temp_register("/nonexistent/again");
    check(again >= 0, "slots are free again after unregistering");
    rtk_temp_unregister(again);
}

int main(void)
{
    snprintf(dir, sizeof dir, "/tmp/rtk-test-output-XXXXXX");
    if (!mkdtemp(dir))
        return 1;
    test_jpeg_limit();
    test_out_file_limit();
    test_registry();
    DIR *d = opendir(dir);
    for (struct dirent *e; d && (e = readdir(d)) != NULL;)
        if (e->d_name[0] != '.')
            unlink(in_dir(e->d_name));
    if (d)
        closedir(d);
    rmdir(dir);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
