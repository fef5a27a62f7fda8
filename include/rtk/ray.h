/* Rays, hits, and the geometric primitives every kernel service shares. */
#ifndef RTK_RAY_H
#define RTK_RAY_H

#include <rtk/math.h>

RTK_EXTERN_C_BEGIN

/* Marks "no primitive" in rtk_hit.prim and friends. */
#define RTK_INVALID_ID 0xffffffffu

/* A ray segment org + t*dir for t in [tmin, tmax]; dir need not be unit. */
typedef struct rtk_ray {
    rtk_vec3 org;
    float tmin;
    rtk_vec3 dir;
    float tmax;
} rtk_ray;

/* Closest hit: distance, barycentrics of vertices 1 and 2, triangle id,
 * or prim == RTK_INVALID_ID on a miss. inst is RTK_INVALID_ID for the
 * scene's own (world-space) triangles, where prim is the id in the
 * scene's original order; for a hit on an instanced mesh it is the
 * instance and prim the triangle's id within that mesh. Pass the whole
 * hit to the services that take it (rtk_surface_at, rtk_scene_light_pdf). */
typedef struct rtk_hit {
    float t, u, v;
    uint32_t prim;
    uint32_t inst;
} rtk_hit;

/* A ray's differentials (Igehy 1999; pbrt's RayDifferential): the rays
 * through the film positions one pixel to the right (rx) and one pixel
 * down (ry) of the ray's own, carried along specular bounces. They give a
 * hit its footprint, which picks the texture level of detail. */
typedef struct rtk_ray_differential {
    rtk_vec3 rx_org, rx_dir;
    rtk_vec3 ry_org, ry_dir;
} rtk_ray_differential;

/* Watertight ray/triangle test (Woop, Benthin, Wald 2013): no cracks on
 * shared edges, no scale-dependent epsilon. Returns 1 and fills t, u, v
 * when the ray hits triangle (a, b, c) with tmin <= t <= tmax. [any thread] */
RTK_API int rtk_intersect_triangle(const rtk_ray *ray, rtk_vec3 a, rtk_vec3 b, rtk_vec3 c,
                                   float *t, float *u, float *v);

/* Moves p off the surface with geometric normal n, along n, by an amount
 * that scales with |p| (Waechter and Binder 2019). Flip n first to leave
 * on the other side (refraction, shadow rays below the surface). */
RTK_API rtk_vec3 rtk_offset_ray_origin(rtk_vec3 p, rtk_vec3 n);

RTK_EXTERN_C_END

#endif
