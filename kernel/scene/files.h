/* The files a scene names: which it may read (the boundary) and the
 * texture budget (files.c). */
#ifndef RTK_KERNEL_SCENE_FILES_H
#define RTK_KERNEL_SCENE_FILES_H

#include "../core/core.h"

RTK_EXTERN_C_BEGIN

/* Decoded texture memory a scene may use when the config says nothing
 * (textures.memory): 2048 MiB. */
#define RTK_TEXTURE_BUDGET_DEFAULT ((uint64_t)2048 << 20)

/* Where a scene may read and how much its textures may decode to. */
typedef struct rtk_scene_files {
    char *config_dir;        /* the config's folder, readable too; NULL when none */
    int allow_outside;       /* --allow-outside-files: no boundary */
    uint64_t texture_budget; /* bytes decoded textures may take, all together */
    uint64_t texture_bytes;  /* bytes decoded so far */
    int trilinear;           /* MIP levels will be built: each texture counts a third more */
    unsigned refs;
} rtk_scene_files;

/* New settings (texture_budget 0: the default). [caller unrefs] */
rtk_scene_files *rtk_scene_files_new(const char *config_dir, int allow_outside, uint64_t texture_budget);
rtk_scene_files *rtk_scene_files_ref(rtk_scene_files *files);
void rtk_scene_files_unref(rtk_scene_files *files);
/* RTK_OK when scene may read path (see files.c for the boundary; a scene
 * without files, built in memory, may read any), else an error naming
 * what ("texture", "file") and path, the folders allowed and
 * --allow-outside-files; nothing about the file itself. */
rtk_status rtk_scene_file_allowed(const rtk_scene *scene, const char *path, const char *what);
/* rtk_scene_file_allowed, then rtk_file_read. */
rtk_status rtk_scene_file_read(const rtk_scene *scene, const char *path, const char *what, uint64_t limit,
                               unsigned char **bytes, size_t *count);

RTK_EXTERN_C_END

#endif
