/* The scene's lights (lights.c): the emitters' alias table, the choice
 * between all lights by power, and the environment (environment.c). */
#ifndef RTK_KERNEL_LIGHTS_H
#define RTK_KERNEL_LIGHTS_H

#include "scene.h"

RTK_EXTERN_C_BEGIN

/* Emitting triangles and a Vose alias table over their power. */
typedef struct rtk_lights {
    uint32_t count;
    uint32_t *prims;      /* light -> triangle (of its instance's mesh when insts says so) */
    uint32_t *insts;      /* light -> instance, RTK_INVALID_ID for the scene's own */
    uint32_t *inst_first; /* instance -> its first light (the mesh's light j is inst_first + j) */
    float *area;          /* light -> triangle area */
    float *pick;          /* light -> probability of being chosen */
    float *alias_prob;    /* alias table: keep probability per column */
    uint32_t *alias;      /* alias table: other light per column */
    uint32_t *light_of;   /* own triangle -> light, RTK_INVALID_ID when it does not emit */
    double area_power;    /* sum of pi A Le over the emitters */
    /* The choice between all lights: slot 0 the emitters together, slots
     * 1..punctual_count the punctual lights, the last the environment. */
    uint32_t slot_count;
    float *slot_pick;     /* slot -> probability of being chosen */
    float *slot_cdf;      /* slot_count + 1 running sums, the last 1 */
    struct rtk_environment *environment; /* owned, or NULL */
    uint64_t stamp;       /* new at every change of the lights, unique in the process */
} rtk_lights;

/* An environment light: a constant colour, or an equirectangular image
 * with its sampling distribution (the mapping is in rtk/lights.h). */
typedef struct rtk_environment {
    int width, height;    /* 0 x 0 for a constant colour */
    float *rgb;           /* 3 floats per pixel, row 0 at +y, strength applied */
    rtk_rgb color;        /* the constant colour x strength */
    float cos_rot, sin_rot; /* rotation about +y */
    float *func;          /* pixel -> luminance x sin(theta at its row's centre) */
    float *row_cdf;       /* height + 1 running sums of the rows' mean func, the last 1 */
    float *col_cdf;       /* per row width + 1 running sums, the last 1 */
    double func_mean;     /* mean of func over the pixels: pdf_uv = func / func_mean */
    double mean_radiance; /* luminance averaged over the sphere (solid angle) */
} rtk_environment;

/* An environment of constant radiance color x strength. [caller frees] */
RTK_KERNEL_API rtk_status rtk_environment_constant(rtk_rgb color, float strength, rtk_environment **out);
/* An environment from width x height pixels of nchannels floats (3 or 4,
 * alpha ignored), rows from the top, x strength, turned by rotation
 * degrees about +y; name for messages. Refuses NaN, infinite and negative
 * pixels, naming the first. [caller frees] */
RTK_KERNEL_API rtk_status rtk_environment_from_pixels(const char *name, int width, int height, int nchannels,
                                                      const float *pixels, float strength, float rotation,
                                                      rtk_environment **out);
/* rtk_environment_from_pixels on an image file OpenImageIO reads (EXR,
 * HDR, ...): a file with other than 3 or 4 channels is refused. */
RTK_KERNEL_API rtk_status rtk_environment_load(const char *path, float strength, float rotation,
                                               rtk_environment **out);
RTK_KERNEL_API void rtk_environment_free(rtk_environment *env);
/* Radiance from direction dir (any length). [any thread] */
RTK_KERNEL_API rtk_rgb rtk_environment_radiance(const rtk_environment *env, rtk_vec3 dir);
/* Samples a direction with u: its unit wi, solid-angle pdf (0: none) and
 * radiance. [any thread] */
RTK_KERNEL_API float rtk_environment_sample(const rtk_environment *env, rtk_vec2 u, rtk_vec3 *wi,
                                            rtk_rgb *radiance);
/* Solid-angle density of rtk_environment_sample returning dir. [any thread] */
RTK_KERNEL_API float rtk_environment_pdf(const rtk_environment *env, rtk_vec3 dir);

/* Gives scene the environment (owned by it from now, replacing one it
 * had; NULL removes it) and updates the choice between lights. */
RTK_KERNEL_API rtk_status rtk_scene_set_environment(rtk_scene *scene, rtk_environment *env);

/* Appends a punctual light to the scene (copied) and updates the choice
 * between lights. */
RTK_KERNEL_API rtk_status rtk_scene_add_punctual(rtk_scene *scene, const rtk_punctual_light *light);

/* Finds the emitters of a finished scene and builds the table and the
 * choice between all lights (keeping the environment); a scene without
 * emitters gets an empty table. */
rtk_status rtk_lights_build(rtk_scene *scene);
void rtk_lights_free(rtk_lights *lights);

RTK_EXTERN_C_END

#endif
