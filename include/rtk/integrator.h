/* Integrator plugins: radiance along one camera ray, using kernel services.
 * Call order: create (once) -> needs -> [scene loaded and built] ->
 * prepare (optional) -> li (or li_batch, when set) from many threads at
 * once -> destroy. */
#ifndef RTK_INTEGRATOR_H
#define RTK_INTEGRATOR_H

#include <rtk/plugin.h>
#include <rtk/sampler.h>
#include <rtk/scene.h>

RTK_EXTERN_C_BEGIN

/* Scene data an integrator reads; the kernel loads only what is asked. */
#define RTK_NEED_NORMALS (1u << 0)   /* per-vertex shading normals */
#define RTK_NEED_UVS (1u << 1)       /* texture coordinates */
#define RTK_NEED_MATERIALS (1u << 2) /* material factors (colour, specular, ior ...) */
#define RTK_NEED_TEXTURES (1u << 3)  /* decoded textures (implies UVS and MATERIALS) */
#define RTK_NEED_LIGHTS (1u << 4)    /* emissive triangles and scene lights */

/* What one camera ray returns. The kernel pre-fills radiance 0, albedo 0,
 * normal 0 and depth +inf; set the AOVs you know (used when the film asks). */
typedef struct rtk_li_result {
    rtk_rgb radiance; /* linear radiance towards the camera */
    rtk_rgb albedo;   /* first-hit base colour */
    rtk_vec3 normal;  /* first-hit shading normal, world space */
    float depth;      /* first-hit distance along the (unit) camera ray */
} rtk_li_result;

/* ABI 3.6. An integrator's estimator as plain data, for a device
 * accelerator that runs it on its own processor (see device_program). */
typedef struct rtk_device_program {
    char name[32];    /* the estimator, e.g. "ao" */
    float params[8];  /* its parameters, in the order the estimator documents */
} rtk_device_program;

/* Function table of an integrator. */
typedef struct rtk_integrator_fns {
    uint32_t size; /* sizeof(rtk_integrator_fns) */
    /* Makes an instance from validated params. [main thread] */
    rtk_status (*create)(const rtk_params *params, void **state);
    /* RTK_NEED_* flags this instance reads. [main thread] */
    uint32_t (*needs)(const void *state);
    /* Optional: per-scene set-up (light tables ...), after the build. [main thread] */
    rtk_status (*prepare)(void *state, const rtk_scene *scene);
    /* Radiance for one camera ray. [any thread, concurrently] */
    void (*li)(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out);
    /* Frees the instance. [main thread] */
    void (*destroy)(void *state);
    /* ABI 3.4, optional: radiance for count camera rays at once (up to
     * RTK_BATCH_MAX: the samples of a few pixels of a tile, in film
     * order), out[i] pre-filled as for li, so that an integrator traces
     * in waves through rtk_trace_batch and rtk_occluded_batch. Sample i's
     * numbers are drawn after rtk_ctx_select(ctx, i). out[i] must equal
     * what li gives for rays[i] as sample i, bit for bit: rtk conform
     * checks it, and the renderer calls li_batch when it is set.
     * [any thread, concurrently] */
    void (*li_batch)(const void *state, rtk_ctx *ctx, const rtk_ray *rays, uint32_t count, rtk_li_result *out);
    /* ABI 3.6, optional: 1 when this instance's estimator is one a device
     * accelerator may run whole (plugins/integrators/device_programs.h lists
     * them), described in *program; 0 when it is not (the render then
     * calls li or li_batch). A device program must give what li gives for
     * the same sample: on the CPU bit for bit, on a GPU within its math
     * library's rounding; programs never contract a * b + c into an FMA,
     * so the plugin is compiled with -ffp-contract=off. [main thread] */
    int (*device_program)(const void *state, rtk_device_program *program);
} rtk_integrator_fns;

/* Most camera rays one li_batch call receives. */
#define RTK_BATCH_MAX 256u

/* Inside li_batch: makes sample i of the batch (0 <= i < count) the one
 * whose numbers rtk_sample_1d, rtk_sample_2d and rtk_sample_seek draw,
 * whose camera ray rtk_ctx_camera_differential describes and rtk_trace
 * recognises. Each sample keeps its own position in its stream, so
 * draws of different samples may interleave. Outside li_batch, i = 0
 * selects the one current sample. [ctx's thread] (ABI 3.4) */
RTK_API void rtk_ctx_select(rtk_ctx *ctx, uint32_t i);

RTK_EXTERN_C_END

#endif
