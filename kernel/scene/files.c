/* Files a scene names: which ones it may read, and its texture budget.
 *
 * The boundary: a scene reads files (OBJ mtllib and maps, glTF buffers and
 * images, the files of those) only under its own folder or the config's,
 * each widened to the folder above it for the common `../textures/`
 * layout, unless that folder is / or a folder right below it (/tmp, /home)
 * or holds the user's home directory. Paths are compared after symbolic
 * links are resolved. --allow-outside-files (rtk_config_options) lifts it.
 * A refusal names the file as the scene wrote it and the folders allowed,
 * never anything found outside them: the check runs before the file is
 * opened, so a missing and an existing file outside read the same. */
#include "scene.h"

#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

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
