/* A config file, loaded and validated (config.c), and what a config adds
 * to its scene (config_scene.c). */
#ifndef RTK_KERNEL_CONFIG_H
#define RTK_KERNEL_CONFIG_H

#include "../scene/scene.h"

RTK_EXTERN_C_BEGIN

/* ---- config (config.c) ---- */

/* One entry of a config's instances list: a model and where its copies go. */
typedef struct rtk_config_instance {
    char *file;              /* resolved against the config's directory */
    char where[1100];        /* "scene.cfg:12: instances[0]", for messages */
    double to_world[12];     /* the first copy's transform (3x4 row-major) */
    uint32_t grid[3];        /* copies along x, y, z */
    double spacing[3];       /* offset between copies */
} rtk_config_instance;

/* A config's environment group (given 0: none). */
typedef struct rtk_config_environment {
    int given;
    char *file;              /* resolved against the config's directory; NULL for a colour */
    rtk_rgb color;           /* the constant radiance when file is NULL */
    float strength, rotation; /* factor, and degrees about +y */
    char where[1100];        /* "scene.cfg:12: environment", for messages */
} rtk_config_environment;

/* One plugin slot of a config. */
typedef struct rtk_plugin_slot {
    const rtk_plugin *plugin;
    rtk_params *params;
} rtk_plugin_slot;

struct rtk_config {
    char *path;                  /* the config file */
    char *scene_path;            /* resolved against the config's directory */
    int has_camera;              /* camera group given */
    rtk_camera_desc camera;      /* when has_camera */
    uint32_t width, height, spp;
    char *output;                /* resolved path of the image */
    int half;                    /* EXR as half floats */
    int importance;              /* film.reconstruction = "importance" */
    int aov_albedo, aov_normal, aov_depth;
    char *sampler_type;          /* "independent", "stratified" or "sobol" */
    uint64_t seed;
    uint32_t threads;            /* 0 = all cores */
    char *cache_dir;             /* BVH cache directory, NULL = caching off */
    uint64_t cache_limit;        /* bytes the BVH cache may hold, 0 = no limit */
    rtk_punctual_light *lights;  /* the config's punctual lights */
    uint32_t light_count;
    rtk_config_environment environment; /* loaded with the scene when it keeps lights */
    rtk_config_instance *instances; /* models placed beside the scene */
    uint32_t instance_count;
    rtk_texture_filter texture_filter; /* textures.filter */
    uint64_t texture_budget;     /* textures.memory in bytes */
    int allow_outside_files;     /* rtk_config_options.allow_outside_files */
    rtk_plugin_slot integrator, accelerator, filter;
};

/* Files the last rtk_config_load on this thread read to check the config's
 * text: each once, however often it is @included (tests count work). */
unsigned rtk_config_files_read(void);

/* Places a config's instances in scene (each model loaded once), then
 * finishes them: world boxes, and the emitter table again when the scene
 * keeps lights. (render.c) */
RTK_KERNEL_API rtk_status rtk_config_place_instances(const struct rtk_config *cfg, rtk_scene *scene);
/* Loads cfg's scene as rtk_scene_load_with does, with the config's
 * folder, --allow-outside-files and textures group, and its environment
 * when needs has RTK_NEED_LIGHTS. */
RTK_KERNEL_API rtk_status rtk_config_load_scene(const struct rtk_config *cfg, uint32_t needs, rtk_scene **out);

RTK_EXTERN_C_END

#endif
