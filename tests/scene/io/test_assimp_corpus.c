/* Robustness of the scene loaders on the Assimp test models (Debian
 * package assimp-testmodels), broken files included: every .obj, .gltf and
 * .glb must either load or be refused with a message; only a crash or a
 * hang (meson's timeout) fails. One line per file on stdout.
 * Usage: test_assimp_corpus [folder]   (default /usr/share/assimp/models) */
#include "config/config.h"
#include "render/render.h"
#include "image/image.h"

#include <ftw.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#define SKIP 77 /* meson's exit code for a skipped test */

static int loaded, refused, silent;

static int has_extension(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    return n >= e && strcasecmp(path + n - e, ext) == 0;
}

static int visit(const char *path, const struct stat *st, int type, struct FTW *ftw)
{
    (void)st;
    (void)ftw;
    if (type != FTW_F || !(has_extension(path, ".obj") || has_extension(path, ".gltf") || has_extension(path, ".glb")))
        return 0;
    const uint32_t all = RTK_NEED_NORMALS | RTK_NEED_UVS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS;
    rtk_scene *scene = NULL;
    rtk_error(RTK_OK, "%s", "");
    rtk_status status = rtk_scene_load(path, all, &scene);
    if (status == RTK_OK) {
        printf("ok: %s (%u triangles)\n", path, scene->triangle_count);
        rtk_scene_free(scene);
        loaded++;
    } else if (rtk_error_message()[0]) {
        /* Messages name the file; add it when one does not. */
        if (strstr(rtk_error_message(), path))
            printf("refused: %s\n", rtk_error_message());
        else
            printf("refused: %s: %s\n", path, rtk_error_message());
        refused++;
    } else {
        printf("FAILED: %s: refused (status %d) without a message\n", path, (int)status);
        silent++;
    }
    fflush(stdout);
    return 0;
}

int main(int argc, char **argv)
{
    const char *root = argc > 1 ? argv[1] : "/usr/share/assimp/models";
    struct stat st;
    if (stat(root, &st) != 0 || !S_ISDIR(st.st_mode)) {
        printf("skipped: %s is absent (install the Debian package assimp-testmodels)\n", root);
        return SKIP;
    }
    if (nftw(root, visit, 16, FTW_PHYS) != 0) {
        printf("FAILED: cannot walk %s\n", root);
        return 1;
    }
    printf("%d loaded, %d refused with a message, %d refused silently\n", loaded, refused, silent);
    printf("%d passed, %d failed\n", loaded + refused, silent);
    return silent ? 1 : 0;
}
