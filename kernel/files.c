/* Files a scene names: which ones it may read, and reading them safely.
 *
 * The boundary: a scene reads files (OBJ mtllib and maps, glTF buffers and
 * images, the files of those) only under its own folder or the config's,
 * each widened to the folder above it for the common `../textures/`
 * layout, unless that folder is / or a folder right below it (/tmp, /home)
 * or holds the user's home directory. Paths are compared after symbolic
 * links are resolved. --allow-outside-files (rtk_config_options) lifts it.
 * A refusal names the file as the scene wrote it and the folders allowed,
 * never anything found outside them: the check runs before the file is
 * opened, so a missing and an existing file outside read the same.
 *
 * Reading: only regular files. A FIFO, device or directory is refused
 * before a byte is read; the file is opened without blocking (a FIFO
 * with no writer would otherwise block the open forever) and checked with
 * fstat, so a name swapped between the check and the open is caught. */
#include "internal.h"

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

/* 1 when path (canonical) is root or lies under it. */
static int path_under(const char *path, const char *root)
{
    size_t n = strlen(root);
    if (n == 1 && root[0] == '/')
        return 1;
    return strncmp(path, root, n) == 0 && (path[n] == '\0' || path[n] == '/');
}

/* Number of components of a canonical path: "/" 0, "/tmp" 1. */
static int path_depth(const char *path)
{
    int depth = 0;
    for (const char *p = path; *p; p++)
        depth += *p == '/' && p[1];
    return depth;
}

/* Adds the canonical folder dir to roots and, when allowed, the folder
 * above it (see the top of the file). */
static void add_roots(const char *dir, char **roots, int *count)
{
    char *canon = rtk_path_canonical(dir);
    if (!canon)
        return;
    char *parent = rtk_path_dirname(canon);
    const char *home = getenv("HOME");
    char *home_canon = home && home[0] ? rtk_path_canonical(home) : NULL;
    int holds_home = home_canon && parent && path_under(home_canon, parent);
    free(home_canon);
    char *found[2] = {canon, parent && path_depth(parent) >= 2 && !holds_home ? parent : NULL};
    for (int f = 0; f < 2; f++) {
        int seen = !found[f];
        for (int i = 0; i < *count && !seen; i++)
            seen = strcmp(roots[i], found[f]) == 0;
        if (!seen)
            roots[(*count)++] = found[f];
        else
            free(found[f]);
    }
    if (!found[1])
        free(parent);
}

rtk_status rtk_scene_file_allowed(const rtk_scene *scene, const char *path, const char *what)
{
    /* A scene built in memory by a program reads what the program names. */
    const rtk_scene_files *files = scene->files;
    if (!files || files->allow_outside)
        return RTK_OK;
    char *roots[4] = {NULL, NULL, NULL, NULL};
    int count = 0;
    char *scene_dir = rtk_path_dirname(scene->path);
    if (scene_dir)
        add_roots(scene_dir, roots, &count);
    free(scene_dir);
    if (files->config_dir)
        add_roots(files->config_dir, roots, &count);
    char *target = rtk_path_canonical(path);
    int inside = 0;
    for (int i = 0; i < count && target && !inside; i++)
        inside = path_under(target, roots[i]);
    free(target);
    rtk_status st = RTK_OK;
    if (!inside) {
        char list[2048] = "";
        size_t used = 0;
        for (int i = 0; i < count; i++) {
            int n = snprintf(list + used, sizeof list - used, "%s%s", i ? ", " : "", roots[i]);
            if (n < 0 || (size_t)n >= sizeof list - used)
                break;
            used += (size_t)n;
        }
        st = rtk_error(RTK_ERR_IO, "%s '%s' lies outside the folders this scene may read (%s): move it there, "
                       "or pass --allow-outside-files if you trust the scene", what, path,
                       count ? list : "none could be resolved");
    }
    for (int i = 0; i < count; i++)
        free(roots[i]);
    return st;
}

rtk_status rtk_scene_file_read(const rtk_scene *scene, const char *path, const char *what, uint64_t limit,
                               unsigned char **bytes, size_t *count)
{
    *bytes = NULL;
    *count = 0;
    rtk_status st = rtk_scene_file_allowed(scene, path, what);
    if (st != RTK_OK)
        return st;
    return rtk_file_read(path, what, limit, bytes, count);
}

rtk_scene_files *rtk_scene_files_new(const char *config_dir, int allow_outside, uint64_t texture_budget)
{
    rtk_scene_files *f = rtk_calloc(1, sizeof *f);
    if (!f)
        return NULL;
    if (config_dir && !(f->config_dir = rtk_strdup(config_dir))) {
        free(f);
        return NULL;
    }
    f->allow_outside = allow_outside != 0;
    f->texture_budget = texture_budget ? texture_budget : RTK_TEXTURE_BUDGET_DEFAULT;
    f->refs = 1;
    return f;
}

rtk_scene_files *rtk_scene_files_ref(rtk_scene_files *files)
{
    if (files)
        files->refs++;
    return files;
}

void rtk_scene_files_unref(rtk_scene_files *files)
{
    if (!files || --files->refs > 0)
        return;
    free(files->config_dir);
    free(files);
}

rtk_status rtk_config_load_scene(const rtk_config *cfg, uint32_t needs, rtk_scene **out)
{
    *out = NULL;
    char *dir = rtk_path_dirname(cfg->path);
    rtk_scene_files *files = dir ? rtk_scene_files_new(dir, cfg->allow_outside_files, cfg->texture_budget) : NULL;
    free(dir);
    if (!files)
        return RTK_ERR_NOMEM;
    files->trilinear = cfg->texture_filter == RTK_TEX_TRILINEAR;
    rtk_status st = rtk_scene_load_with(cfg->scene_path, needs, files, out);
    rtk_scene_files_unref(files);
    return st;
}
