/* A test's scratch folder (files the test writes as inputs) and the
 * capture of what the kernel prints on stderr. Include once, in the
 * test's one source file, after check.h. */
#ifndef RTK_TESTS_SCRATCH_H
#define RTK_TESTS_SCRATCH_H

#include <fcntl.h>
#include <ftw.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char tmpdir[256];

/* Makes the scratch folder $TMPDIR/<prefix>-XXXXXX; exits failing without it. */
static void scratch_begin(const char *prefix)
{
    const char *base = getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp";
    snprintf(tmpdir, sizeof tmpdir, "%s/%s-XXXXXX", base, prefix);
    if (!mkdtemp(tmpdir)) {
        printf("FAIL  cannot make a temporary folder in %s\n", base);
        exit(1);
    }
}

/* Path of name in the scratch folder; eight calls' results stay valid. */
static const char *in_tmp(const char *name)
{
    static char buffers[8][600];
    static int next;
    char *p = buffers[next++ % 8];
    snprintf(p, 600, "%s/%s", tmpdir, name);
    return p;
}

/* Writes size bytes to name in the scratch folder; exits failing when it cannot. */
static const char *write_file(const char *name, const void *data, size_t size)
{
    const char *path = in_tmp(name);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, size, f) != size) {
        printf("FAIL  cannot write %s\n", path);
        exit(1);
    }
    fclose(f);
    return path;
}

static const char *write_text(const char *name, const char *text) { return write_file(name, text, strlen(text)); }

/* Removes one entry; goes on past one that cannot be removed. */
static int scratch_remove_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb, (void)flag, (void)ftw;
    remove(path);
    return 0;
}

/* Removes the scratch folder and everything in it. */
static void scratch_end(void) { nftw(tmpdir, scratch_remove_entry, 16, FTW_DEPTH | FTW_PHYS); }

/* What the kernel prints on stderr between capture_begin and capture_end. */
static char captured[65536];

static void capture_begin(int *saved)
{
    fflush(stderr);
    *saved = dup(2);
    int fd = open(in_tmp("stderr.txt"), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    dup2(fd, 2);
    close(fd);
}

static void capture_end(int saved)
{
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    FILE *f = fopen(in_tmp("stderr.txt"), "rb");
    size_t n = f ? fread(captured, 1, sizeof captured - 1, f) : 0;
    captured[n] = '\0';
    if (f)
        fclose(f);
}

#endif
