/* Light services: the scene's emitters, punctual lights and environment,
 * and importance sampling of them. Emitters are the triangles whose
 * material emits (MTL Ke, glTF emissiveFactor); they and the environment
 * exist only when the integrator asked for RTK_NEED_LIGHTS. Emission is
 * one-sided: towards the side the triangle's geometric normal (from its
 * winding) faces. */
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

/* Spot falloff at cos_axis, the cosine between the spot's axis
 * (light->direction) and the direction from the light to the lit point:
 * 1 inside the inner cone, 0 outside the outer one, and between them
 * smoothstep t^2 (3 - 2t) of t = (cos_axis - cos_outer) / (cos_inner -
 * cos_outer). Every user of spot lights reads it here. [any thread] (ABI 3.3) */
RTK_API float rtk_spot_falloff(const rtk_punctual_light *light, float cos_axis);

/* ---- All lights as one service (ABI 3.3) ----
 *
 * The lights are the emitting triangles (one-sided, as above), the
 * punctual lights and the environment (config `environment`, seen by rays
 * that leave the scene). rtk_sample_incident_light chooses one in
 * proportion to its power, luminance (0.2126 R + 0.7152 G + 0.0722 B) of:
 *   area triangle   pi A Le (an emission texture counts as its factor x
 *                   the texture's mean texel)
 *   point           4 pi I
 *   spot            2 pi I (1 - (cos_inner + cos_outer) / 2)
 *   directional     pi R^2 E
 *   environment     pi R^2 x 4 pi x its mean radiance over the sphere
 * (pbrt-v4's estimates; R is the radius of the sphere around the scene's
 * bounds), then a point or direction on it: a uniform point on an area
 * triangle, the environment's importance sampling (below).
 *
 * The environment: a constant colour x strength, sampled uniformly over
 * the sphere (pdf 1 / (4 pi)); or an equirectangular image x strength.
 * Its mapping, y up: a direction d is first turned by -rotation about +y,
 * d' = (cos r d.x - sin r d.z, d.y, sin r d.x + cos r d.z), then
 *   u = 1/2 + atan2(d'.x, -d'.z) / (2 pi)   (0 at the left edge)
 *   v = acos(d'.y) / pi                      (0 at the top row, +y)
 * so that, unrotated, the image's centre is at -z, +x lies right of it and
 * rotation = 90 degrees moves the centre to -x (right-handed about +y).
 * Radiance is the pixel (u, v) falls in (nearest, no filtering); sampling
 * picks pixels with probability proportional to luminance x sin(theta)
 * (theta = pi v at the pixel row's centre; marginal over rows, conditional
 * within the row), uniformly within the pixel, with solid-angle density
 * pdf_uv / (2 pi^2 sin theta). */

/* One sampled light as seen from a point p. */
typedef struct rtk_light_incident {
    rtk_vec3 wi;    /* unit world direction from p to the light */
    float dist;     /* distance to the light point; INFINITY for directional and environment */
    rtk_rgb li;     /* incident radiance along wi (area, environment); for delta lights the
                       irradiance at normal incidence: I / dist^2 x spot falloff, or E (directional) */
    float pdf;      /* solid-angle density of wi including the choice of the light; for delta
                       lights the probability of choosing it */
    int delta;      /* 1 for point, spot, directional (no MIS) */
    rtk_ray shadow; /* test with rtk_occluded: rtk_shadow_ray to area/point/spot points,
                       offset origin to tmax INFINITY for directional and environment */
} rtk_light_incident;

/* Chooses one light of all with u_pick (in proportion to power, above),
 * then a point or direction on it with u, as seen from p on a surface of
 * geometric normal ng (the shadow ray starts off it; the zero vector for a
 * point on no surface). Returns 0 when nothing was sampled: no lights, a
 * zero pdf, p on the light, the back of an emitting triangle, outside a
 * spot's cone. The sample contributes f(wo, wi) |cos| li / pdf when
 * out->shadow is not occluded. [any thread] (ABI 3.3) */
RTK_API int rtk_sample_incident_light(const rtk_scene *scene, rtk_vec3 p, rtk_vec3 ng, float u_pick, rtk_vec2 u,
                                      rtk_light_incident *out);

/* Solid-angle density with which rtk_sample_incident_light from p returns
 * ray->dir, ray leaving p (any length of dir) and hit what rtk_trace
 * returned for it: on the front of an emitting triangle, pick probability
 * x area pdf x dist^2 / |cos at the light|; for a miss (hit NULL, or a hit
 * with prim RTK_INVALID_ID) the environment's; 0 otherwise (delta lights
 * are never hit). For multiple importance sampling. [any thread] (ABI 3.3) */
RTK_API float rtk_incident_light_pdf(const rtk_scene *scene, rtk_vec3 p, const rtk_ray *ray, const rtk_hit *hit);

/* Radiance arriving from direction dir (any length) at infinity, what a
 * ray that misses the scene sees: black without an environment.
 * [any thread] (ABI 3.3) */
RTK_API rtk_rgb rtk_scene_environment(const rtk_scene *scene, rtk_vec3 dir);

RTK_EXTERN_C_END

#endif
