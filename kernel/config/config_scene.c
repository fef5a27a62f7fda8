/* What a config adds to its scene: the scene file loaded within the
 * config's file boundary and texture budget, its environment, and the
 * instances it places. */
#include "config.h"
#include "../accel/accel.h"

#include <stdlib.h>
#include <string.h>

/* The config's environment, given to scene; errors name the setting. */
static rtk_status load_environment(const rtk_config_environment *ce, rtk_scene *scene)
{
    rtk_environment *env = NULL;
    rtk_status st = ce->file ? rtk_environment_load(ce->file, ce->strength, ce->rotation, &env)
                             : rtk_environment_constant(ce->color, ce->strength, &env);
    if (st != RTK_OK)
        return st == RTK_ERR_NOMEM ? st : rtk_error(st, "%s: file: %s", ce->where, rtk_error_message());
    return rtk_scene_set_environment(scene, env);
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
    if (st == RTK_OK && (needs & RTK_NEED_LIGHTS) && cfg->environment.given) {
        st = load_environment(&cfg->environment, *out);
        if (st != RTK_OK) {
            rtk_scene_free(*out);
            *out = NULL;
        }
    }
    return st;
}

rtk_status rtk_config_place_instances(const rtk_config *cfg, rtk_scene *scene)
{
    rtk_status st = RTK_OK;
    for (uint32_t e = 0; e < cfg->instance_count && st == RTK_OK; e++) {
        const rtk_config_instance *in = &cfg->instances[e];
        for (uint32_t k = 0; k < in->grid[2] && st == RTK_OK; k++)
            for (uint32_t j = 0; j < in->grid[1] && st == RTK_OK; j++)
                for (uint32_t i = 0; i < in->grid[0] && st == RTK_OK; i++) {
                    double m[12];
                    memcpy(m, in->to_world, sizeof m);
                    m[3] += i * in->spacing[0];
                    m[7] += j * in->spacing[1];
                    m[11] += k * in->spacing[2];
                    st = rtk_scene_instance_file(scene, in->file, m, in->where);
                }
    }
    if (st == RTK_OK)
        st = rtk_instances_finish(scene);
    if (st == RTK_OK && (scene->needs & RTK_NEED_LIGHTS))
        st = rtk_lights_build(scene);
    return st;
}
