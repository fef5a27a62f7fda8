/* Reading files safely: only regular files. A FIFO, device or directory is
 * refused before a byte is read; the file is opened without blocking (a
 * FIFO with no writer would otherwise block the open forever) and checked
 * with fstat, so a name swapped between the check and the open is caught.
 * Canonical paths for the scene boundary (scene/files.c). */
#include "core.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* What a file that is not regular is, for messages. */
static const char *kind_of(mode_t mode)
{
    if (S_ISDIR(mode))
        return "a directory";
    if (S_ISFIFO(mode))
        return "a FIFO (named pipe)";
    if (S_ISCHR(mode) || S_ISBLK(mode))
        return "a device";
    if (S_ISSOCK(mode))
        return "a socket";
    return "not a regular file";
}

rtk_status rtk_file_open(const char *path, const char *what, int *fd_out, uint64_t *size)
{
    *fd_out = -1;
    struct stat st;
    /* stat first: a device is never opened (opening some has effects). */
    if (stat(path, &st) != 0)
        return rtk_error(RTK_ERR_IO, "cannot open %s '%s': %s", what, path, strerror(errno));
    if (!S_ISREG(st.st_mode))
        return rtk_error(RTK_ERR_IO, "cannot read %s '%s': it is %s; rtk reads only regular files", what, path,
                         kind_of(st.st_mode));
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0)
        return rtk_error(RTK_ERR_IO, "cannot open %s '%s': %s", what, path, strerror(errno));
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        const char *kind = kind_of(st.st_mode);
        close(fd);
        return rtk_error(RTK_ERR_IO, "cannot read %s '%s': it is %s; rtk reads only regular files", what, path,
                         kind);
    }
    int flags = fcntl(fd, F_GETFL);
    if (flags >= 0)
        fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
    *fd_out = fd;
    if (size)
        *size = (uint64_t)st.st_size;
    return RTK_OK;
}

rtk_status rtk_file_read(const char *path, const char *what, uint64_t limit, unsigned char **bytes, size_t *count)
{
    *bytes = NULL;
    *count = 0;
    int fd;
    uint64_t size;
    rtk_status st = rtk_file_open(path, what, &fd, &size);
    if (st != RTK_OK)
        return st;
    if (size > limit || size > SIZE_MAX - 1) {
        close(fd);
        return rtk_error(RTK_ERR_UNSUPPORTED, "cannot read %s '%s': it is %llu bytes, over rtk's limit of %llu "
                         "for a %s", what, path, (unsigned long long)size, (unsigned long long)limit, what);
    }
    /* One byte more than fstat said, so that a file that grew is noticed. */
    unsigned char *data = rtk_alloc((size_t)size + 1);
    if (!data) {
        close(fd);
        return rtk_error(RTK_ERR_NOMEM, "cannot read %s '%s': no memory for its %llu bytes", what, path,
                         (unsigned long long)size);
    }
    size_t got = 0;
    while (got < (size_t)size + 1) {
        ssize_t n = read(fd, data + got, (size_t)size + 1 - got);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0) {
            int e = errno;
            close(fd);
            free(data);
            return rtk_error(RTK_ERR_IO, "cannot read %s '%s': %s", what, path, strerror(e));
        }
        if (n == 0)
            break;
        got += (size_t)n;
    }
    close(fd);
    if (got != (size_t)size) {
        free(data);
        return rtk_error(RTK_ERR_IO, "cannot read %s '%s': it changed size while being read", what, path);
    }
    data[got] = 0;
    *bytes = data;
    *count = got;
    return RTK_OK;
}

/* Appends the components of rel (relative) to the absolute, canonical
 * path in buf, taking "." and ".." lexically. 0 when it does not fit. */
static int append_lexical(char *buf, size_t cap, const char *rel)
{
    size_t len = strlen(buf);
    while (*rel) {
        while (*rel == '/')
            rel++;
        const char *end = strchr(rel, '/');
        size_t n = end ? (size_t)(end - rel) : strlen(rel);
        if (n == 0)
            break;
        if (n == 1 && rel[0] == '.') {
            /* nothing */
        } else if (n == 2 && rel[0] == '.' && rel[1] == '.') {
            while (len > 1 && buf[len - 1] != '/')
                len--;
            if (len > 1)
                len--;
            buf[len] = '\0';
        } else {
            if (len + 1 + n + 1 > cap)
                return 0;
            if (len > 1)
                buf[len++] = '/';
            memcpy(buf + len, rel, n);
            len += n;
            buf[len] = '\0';
        }
        rel += n;
    }
    return 1;
}

char *rtk_path_canonical(const char *path)
{
    if (!path || !path[0])
        return NULL;
    char abs[PATH_MAX];
    if (path[0] == '/') {
        if (strlen(path) >= sizeof abs)
            return NULL;
        strcpy(abs, path);
    } else {
        if (!getcwd(abs, sizeof abs))
            return NULL;
        size_t n = strlen(abs);
        if (n + 1 + strlen(path) >= sizeof abs)
            return NULL;
        abs[n] = '/';
        strcpy(abs + n + 1, path);
    }
    char real[PATH_MAX];
    if (realpath(abs, real))
        return rtk_strdup(real);
    /* Part of it does not exist: resolve the longest prefix that does and
     * take the rest lexically, as the missing file would be found. */
    size_t cut = strlen(abs);
    while (cut > 0) {
        while (cut > 0 && abs[cut - 1] != '/')
            cut--;
        if (cut == 0)
            break;
        size_t at = cut - 1; /* the slash */
        char head[PATH_MAX];
        memcpy(head, abs, at);
        head[at] = '\0';
        if (realpath(at ? head : "/", real)) {
            if (!append_lexical(real, sizeof real, abs + cut))
                return NULL;
            return rtk_strdup(real);
        }
        cut = at;
    }
    return NULL;
}
