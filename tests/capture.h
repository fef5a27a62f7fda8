/* What the kernel prints on stderr between capture_begin and capture_end,
 * through a file in the scratch folder. Include after scratch.h. */
#ifndef RTK_TESTS_CAPTURE_H
#define RTK_TESTS_CAPTURE_H

#include "scratch.h"

#include <fcntl.h>

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
