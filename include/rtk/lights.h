/* Light services: the scene's emitters and importance sampling of them.
 * Emitters are the triangles whose material emits (MTL Ke, glTF
 * emissiveFactor); they exist only when the integrator asked for
 * RTK_NEED_LIGHTS. Emission is one-sided: towards the side the triangle's
 * geometric normal (from its winding) faces. */
#ifndef RTK_LIGHTS_H
#define RTK_LIGHTS_H

#include <rtk/scene.h>

RTK_EXTERN_C_BEGIN

/* A point chosen on an emitter. */
typedef struct rtk_light_sample {
    rtk_vec3 p;     /* the point */
    rtk_vec3 n;     /* unit normal of the emitting side */
    rtk_rgb le;     /* emitted radiance at p (towards the n side) */
    float pdf_area; /* density of choosing p, per unit area over all emitters */
    uint32_t prim;  /* the emitting triangle, as in rtk_hit */
    uint32_t inst;  /* its instance, as in rtk_hit (RTK_INVALID_ID: the scene's own) */
} rtk_light_sample;

/* Number of emitting triangles (an instanced emitter counts once per
 * instance). [any thread] */
RTK_API uint32_t rtk_scene_light_count(const rtk_scene *scene);

/* Chooses an emitting triangle in proportion to its emitted power
 * (radiance x area; one alias table over the scene) with u_pick, then a
 * uniform point on it with u. Returns 0 when the scene has no emitters.
 * [any thread] */
RTK_API int rtk_scene_sample_light(const rtk_scene *scene, float u_pick, rtk_vec2 u, rtk_light_sample *out);

/* The shadow ray from p, on a surface with geometric normal np, to q, on
 * a light with geometric normal nq (rtk_light_sample's n; the zero vector
 * when q lies on no surface, as a point light's position): each end moves
 * off its own surface along its own normal turned towards the other end
 * (rtk_offset_ray_origin), so neither end can hit the surface it lies on
 * at any angle; an offset along the ray instead rounds to nothing when the
 * light is seen edge-on. dir = q' - p', tmin 0, tmax 1: rtk_occluded on it
 * says whether q is hidden from p. [any thread] (ABI 3.3) */
RTK_API rtk_ray rtk_shadow_ray(rtk_vec3 p, rtk_vec3 np, rtk_vec3 q, rtk_vec3 nq);

/* Area density with which rtk_scene_sample_light picks points of the
 * triangle a hit landed on (0 when it does not emit or hit is a miss), for
 * multiple importance sampling. [any thread] */
RTK_API float rtk_scene_light_pdf(const rtk_scene *scene, const rtk_hit *hit);

/* Kinds of punctual light (from the config or glTF KHR_lights_punctual). */
typedef enum rtk_punctual_type {
    RTK_LIGHT_POINT = 1,       /* intensity in W/sr, falls off with 1/r^2 */
    RTK_LIGHT_DIRECTIONAL = 2, /* intensity is irradiance, W/m^2, on a surface facing it */
    RTK_LIGHT_SPOT = 3         /* a point light limited to a cone */
} rtk_punctual_type;

/* A light with no area: hard shadows, reached only by shadow rays. */
typedef struct rtk_punctual_light {
    rtk_punctual_type type;
    rtk_vec3 position;  /* point and spot */
    rtk_vec3 direction; /* unit direction the light travels (directional, spot axis) */
    rtk_rgb intensity;
    float cos_inner;    /* spot: full intensity inside this cone (cosine of the angle) */
    float cos_outer;    /* spot: zero outside this cone */
} rtk_punctual_light;

/* Number of punctual lights. [any thread] */
RTK_API uint32_t rtk_scene_punctual_count(const rtk_scene *scene);

/* The i-th punctual light (i < count). [any thread] */
RTK_API const rtk_punctual_light *rtk_scene_punctual(const rtk_scene *scene, uint32_t i);

RTK_EXTERN_C_END

#endif
