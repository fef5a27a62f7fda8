/* The scene's emitters and their alias table (lights.c). */
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
} rtk_lights;

/* Appends a punctual light to the scene (copied). */
RTK_KERNEL_API rtk_status rtk_scene_add_punctual(rtk_scene *scene, const rtk_punctual_light *light);

/* Finds the emitters of a finished scene and builds the table; a scene
 * without emitters gets an empty table. */
rtk_status rtk_lights_build(rtk_scene *scene);
void rtk_lights_free(rtk_lights *lights);

RTK_EXTERN_C_END

#endif
