/* Fuzz target: a scene loader, chosen by FUZZ_EXT (".obj", ".gltf",
 * ".glb"), through rtk_scene_load with every need set, so that materials,
 * textures (data URIs decode through the image module) and lights are
 * read too; with FUZZ_MTL the input is instead the material library of
 * the OBJ seed quad.obj. */
#include "fuzz_common.h"

#include <rtk/integrator.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int ready;
    if (!ready) {
        fuzz_quiet();
        /* The OBJ seed's material library and texture, where mtllib finds them. */
#ifdef FUZZ_MTL
        static const char *const sidecars[] = {"quad.obj", "quad.png"};
#else
        static const char *const sidecars[] = {"quad.mtl", "quad.png"};
#endif
        for (size_t i = 0; i < sizeof sidecars / sizeof sidecars[0]; i++) {
            char from[1024];
            snprintf(from, sizeof from, "%s/%s", FUZZ_SEEDS, sidecars[i]);
            FILE *f = fopen(from, "rb");
            static uint8_t bytes[1 << 16];
            size_t n = f ? fread(bytes, 1, sizeof bytes, f) : 0;
            if (f)
                fclose(f);
            fuzz_write(sidecars[i], bytes, n);
        }
        ready = 1;
    }
#ifdef FUZZ_MTL
    fuzz_write("quad.mtl", data, size);
    char obj[512];
    snprintf(obj, sizeof obj, "%s/quad.obj", fuzz_workdir());
    const char *path = obj;
#else
    const char *path = fuzz_write("fuzz" FUZZ_EXT, data, size);
#endif
    rtk_scene *scene = NULL;
    uint32_t needs = RTK_NEED_NORMALS | RTK_NEED_UVS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS;
    if (rtk_scene_load(path, needs, &scene) == RTK_OK)
        rtk_scene_free(scene);
    return 0;
}
