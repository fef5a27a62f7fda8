/* A test's scratch folder: the files a test writes as its inputs. Include
 * once, in the test's one source file (inline: a test uses what it needs). */
#ifndef RTK_TESTS_SCRATCH_H
#define RTK_TESTS_SCRATCH_H

#include <ftw.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char tmpdir[256];

/* Makes the scratch folder $TMPDIR/<prefix>-XXXXXX; exits failing without it. */
static inline void scratch_begin(const char *prefix)
{
    const char *base = getenv("TMPDIR") && getenv("TMPDIR")[0] ? getenv("TMPDIR") : "/tmp";
    snprintf(tmpdir, sizeof tmpdir, "%s/%s-XXXXXX", base, prefix);
    if (!mkdtemp(tmpdir)) {
        printf("FAIL  cannot make a temporary folder in %s\n", base);
        exit(1);
    }
}

/* Path of name in the scratch folder; eight calls' results stay valid. */
static inline const char *in_tmp(const char *name)
{
    static char buffers[8][600];
    static int next;
    char *p = buffers[next++ % 8];
    snprintf(p, 600, "%s/%s", tmpdir, name);
    return p;
}

/* Writes size bytes to name in the scratch folder; exits failing when it cannot. */
static inline const char *write_file(const char *name, const void *data, size_t size)
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

static inline const char *write_text(const char *name, const char *text)
{
    return write_file(name, text, strlen(text));
}

/* Removes one entry; goes on past one that cannot be removed. */
static inline int scratch_remove_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb, (void)flag, (void)ftw;
    remove(path);
    return 0;
}

/* Removes the scratch folder and everything in it. */
static inline void scratch_end(void) { nftw(tmpdir, scratch_remove_entry, 16, FTW_DEPTH | FTW_PHYS); }

#endif
