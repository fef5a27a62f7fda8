/* Kernel services over the loaded scene: tracing, surface data, bounds.
 * rtk_ctx is one render thread's context (scene, sample stream, counters):
 * use it only on the thread that received it. The scene is read-only while
 * rendering and may be shared by every thread. */
#ifndef RTK_SCENE_H
#define RTK_SCENE_H

#include <rtk/ray.h>

RTK_EXTERN_C_BEGIN

/* The loaded, built scene (opaque). */
typedef struct rtk_scene rtk_scene;
/* One thread's render context (opaque). */
typedef struct rtk_ctx rtk_ctx;

/* Everything known at a surface point. Fields the integrator did not ask
 * for with RTK_NEED_* hold neutral values (white, no emission, ns = ng). */
typedef struct rtk_surface {
    rtk_vec3 p;          /* hit point */
    rtk_vec3 ng;         /* unit geometric normal, facing against the ray */
    rtk_vec3 ns;         /* unit shading normal, same hemisphere as ng */
    rtk_vec2 uv;         /* texture coordinates (0,0 without UVs) */
    rtk_rgb base_color;  /* diffuse albedo x texture, linear */
    float alpha;         /* coverage from material and texture */
    rtk_rgb emission;    /* emitted radiance */
    rtk_rgb specular;    /* specular colour (MTL Ks) */
    float shininess;     /* Phong exponent (MTL Ns) */
    float ior;           /* index of refraction (MTL Ni, glTF ior) */
    float metallic;      /* glTF metallic factor */
    float roughness;     /* glTF roughness factor */
    uint32_t material;   /* material index, RTK_INVALID_ID for the default */
    int front_face;      /* 1 when the ray hit the side ng was authored on */
    float transmission;  /* glTF KHR_materials_transmission; MTL: 1 - d for illum 4, 6, 7, 9 */
    int illum;           /* MTL illumination model, -1 when the material has none */
} rtk_surface;

/* Closest hit along ray; returns 1 on a hit. Invalid rays (NaN, zero
 * direction, tmin > tmax) miss and are counted. [ctx's thread] */
RTK_API int rtk_trace(rtk_ctx *ctx, const rtk_ray *ray, rtk_hit *hit);

/* 1 if anything lies on the ray within [tmin, tmax]. [ctx's thread] */
RTK_API int rtk_occluded(rtk_ctx *ctx, const rtk_ray *ray);

/* rtk_trace on count rays at once: hits[i] is what rtk_trace(ctx,
 * &rays[i], &hits[i]) fills, bit for bit (ties, cut-outs and instances
 * included; hits[i].prim == RTK_INVALID_ID on a miss), and the counters
 * advance the same. Coherent rays (a tile's camera rays) are traced
 * together, incoherent ones one at a time. Returns the number of hits.
 * Inside li_batch, rays[i] counts as sample i's camera ray when it equals
 * the ray li_batch received as rays[i]. [ctx's thread] (ABI 3.4) */
RTK_API uint32_t rtk_trace_batch(rtk_ctx *ctx, const rtk_ray *rays, uint32_t count, rtk_hit *hits);

/* rtk_occluded on count rays at once: occluded[i] = rtk_occluded(ctx,
 * &rays[i]) (0 or 1). Returns the number occluded. [ctx's thread]
 * (ABI 3.4) */
RTK_API uint32_t rtk_occluded_batch(rtk_ctx *ctx, const rtk_ray *rays, uint32_t count, uint8_t *occluded);

/* The scene this context renders. [ctx's thread] */
RTK_API const rtk_scene *rtk_ctx_scene(const rtk_ctx *ctx);

/* Fills out for a hit returned by rtk_trace on this scene. [any thread] */
RTK_API void rtk_surface_at(const rtk_scene *scene, const rtk_ray *ray, const rtk_hit *hit,
                            rtk_surface *out);

/* rtk_surface_at with the pixel's footprint: diff holds the differentials
 * of ray (rtk_ctx_camera_differential for the camera ray,
 * rtk_differential_reflect or _refract after a specular bounce). With the
 * config's textures.filter = "trilinear", textures are read at the level
 * of detail log2 of the footprint's larger side in texels; otherwise, and
 * with diff NULL, it is rtk_surface_at. [any thread] (ABI 3.1) */
RTK_API void rtk_surface_at_footprint(const rtk_scene *scene, const rtk_ray *ray, const rtk_ray_differential *diff,
                                      const rtk_hit *hit, rtk_surface *out);

/* The differentials of the current sample's camera ray, the ray rtk_render
 * passed to li: the camera's rays through the film positions one pixel
 * right and one pixel down. Returns 0 when the context has no camera
 * (li called by a test or the conformance runner). [ctx's thread] (ABI 3.1) */
RTK_API int rtk_ctx_camera_differential(const rtk_ctx *ctx, rtk_ray_differential *out);

/* Differentials of the ray that leaves surface s (filled by
 * rtk_surface_at_footprint for ray, diff, hit) in the mirror direction wi
 * about s->ns, from rtk_offset_ray_origin(s->p, s->ng): origins that
 * origin moved as far as diff's rays meet the tangent plane from s->p,
 * directions mirrored about the normal as it changes across the footprint
 * (pbrt-v3 section 10.1.3). Returns 0, out untouched, when diff's rays miss
 * the tangent plane. [any thread] (ABI 3.1) */
RTK_API int rtk_differential_reflect(const rtk_scene *scene, const rtk_ray *ray, const rtk_ray_differential *diff,
                                     const rtk_hit *hit, const rtk_surface *s, rtk_vec3 wi,
                                     rtk_ray_differential *out);

/* The same for the ray refracted through s into wi (its origin offset
 * along -s->ng), eta being the index of refraction on the ray's side over
 * the index on wi's side. [any thread] (ABI 3.1) */
RTK_API int rtk_differential_refract(const rtk_scene *scene, const rtk_ray *ray, const rtk_ray_differential *diff,
                                     const rtk_hit *hit, const rtk_surface *s, rtk_vec3 wi, float eta,
                                     rtk_ray_differential *out);

/* Bounds of all geometry (empty bounds for an empty scene). [any thread] */
RTK_API rtk_bounds rtk_scene_bounds(const rtk_scene *scene);

/* Number of the scene's own (world-space, not instanced) triangles after
 * loading; instanced meshes are not counted. [any thread] */
RTK_API uint32_t rtk_scene_triangle_count(const rtk_scene *scene);

/* Vertices of the scene's own triangle prim in world space. [any thread] */
RTK_API void rtk_scene_triangle(const rtk_scene *scene, uint32_t prim, rtk_vec3 *a, rtk_vec3 *b,
                                rtk_vec3 *c);

/* Work one closest-hit traversal did: BVH nodes whose children's boxes
 * were tested, and ray/triangle tests. */
typedef struct rtk_trace_work {
    uint32_t nodes;
    uint32_t triangles;
} rtk_trace_work;

/* rtk_trace that also reports its traversal work (for BVH heat maps): the
 * same hit, counted the same way; work is all zero for an invalid ray or
 * an accelerator with its own traversal. Slower than rtk_trace.
 * [ctx's thread] */
RTK_API int rtk_trace_measure(rtk_ctx *ctx, const rtk_ray *ray, rtk_hit *hit, rtk_trace_work *work);

RTK_EXTERN_C_END

#endif
