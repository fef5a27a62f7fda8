/* Kernel services over a loaded scene: tracing with counters, surface
 * interaction (normals, uvs, materials, textures), scene queries. */
#include "bvh_wide.h"

#include <math.h>

RTK_API int rtk_trace(rtk_ctx *ctx, const rtk_ray *ray, rtk_hit *hit)
{
    ctx->rays++;
    if (!rtk_ray_valid(ray)) {
        ctx->invalid_rays++;
        hit->prim = hit->inst = RTK_INVALID_ID;
        hit->t = INFINITY;
        hit->u = hit->v = 0.0f;
        return 0;
    }
    return rtk_bvh_closest(ctx->scene, ray, hit);
}

RTK_API int rtk_occluded(rtk_ctx *ctx, const rtk_ray *ray)
{
    ctx->rays++;
    if (!rtk_ray_valid(ray)) {
        ctx->invalid_rays++;
        return 0;
    }
    return rtk_bvh_any(ctx->scene, ray);
}

RTK_API int rtk_trace_measure(rtk_ctx *ctx, const rtk_ray *ray, rtk_hit *hit, rtk_trace_work *work)
{
    ctx->rays++;
    if (!rtk_ray_valid(ray)) {
        ctx->invalid_rays++;
        hit->prim = hit->inst = RTK_INVALID_ID;
        hit->t = INFINITY;
        hit->u = hit->v = 0.0f;
        work->nodes = work->triangles = 0;
        return 0;
    }
    return rtk_bvh_closest_measure(ctx->scene, ray, hit, work);
}

RTK_API const rtk_scene *rtk_ctx_scene(const rtk_ctx *ctx)
{
    return ctx->scene;
}

RTK_API rtk_bounds rtk_scene_bounds(const rtk_scene *scene)
{
    return scene->bounds;
}

RTK_API uint32_t rtk_scene_triangle_count(const rtk_scene *scene)
{
    return scene->triangle_count;
}

RTK_API void rtk_scene_triangle(const rtk_scene *s, uint32_t prim, rtk_vec3 *a, rtk_vec3 *b, rtk_vec3 *c)
{
    const uint32_t *idx = s->indices + 3 * (size_t)prim;
    const float *p0 = s->positions + 3 * (size_t)idx[0];
    const float *p1 = s->positions + 3 * (size_t)idx[1];
    const float *p2 = s->positions + 3 * (size_t)idx[2];
    *a = rtk_vec3_make(p0[0], p0[1], p0[2]);
    *b = rtk_vec3_make(p1[0], p1[1], p1[2]);
    *c = rtk_vec3_make(p2[0], p2[1], p2[2]);
}

static rtk_vec3 lerp3(const float *corner, float u, float v)
{
    float w = 1.0f - u - v;
    return rtk_vec3_make(w * corner[0] + u * corner[3] + v * corner[6], w * corner[1] + u * corner[4] + v * corner[7],
                         w * corner[2] + u * corner[5] + v * corner[8]);
}

RTK_API void rtk_surface_at(const rtk_scene *s, const rtk_ray *ray, const rtk_hit *hit, rtk_surface *out)
{
    if (hit->inst != RTK_INVALID_ID && hit->inst < s->instance_count) {
        rtk_instance_surface(s, ray, hit, out);
        return;
    }
    rtk_vec3 a, b, c;
    rtk_scene_triangle(s, hit->prim, &a, &b, &c);
    float u = hit->u, v = hit->v, w = 1.0f - u - v;
    out->p = rtk_vec3_make(w * a.x + u * b.x + v * c.x, w * a.y + u * b.y + v * c.y, w * a.z + u * b.z + v * c.z);
    rtk_vec3 ng = rtk_vec3_normalize(rtk_vec3_cross(rtk_vec3_sub(b, a), rtk_vec3_sub(c, a)));
    out->front_face = rtk_vec3_dot(ng, ray->dir) < 0.0f;
    if (!out->front_face)
        ng = rtk_vec3_neg(ng);
    out->ng = ng;
    out->ns = ng;
    if (s->normals) {
        rtk_vec3 ns = rtk_vec3_normalize(lerp3(s->normals + 9 * (size_t)hit->prim, u, v));
        if (rtk_vec3_dot(ns, ns) > 0.0f && isfinite(ns.x) && isfinite(ns.y) && isfinite(ns.z))
            out->ns = rtk_vec3_dot(ns, ng) < 0.0f ? rtk_vec3_neg(ns) : ns;
    }
    /* Cutouts make a scene keep uvs and materials the integrator did not
     * ask for; it still gets the neutral values it was promised. */
    const int uvs = s->uvs && (s->needs & RTK_NEED_UVS);
    const int materials = s->tri_material && (s->needs & (RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS));
    out->uv.x = out->uv.y = 0.0f;
    if (uvs) {
        const float *t = s->uvs + 6 * (size_t)hit->prim;
        out->uv.x = w * t[0] + u * t[2] + v * t[4];
        out->uv.y = w * t[1] + u * t[3] + v * t[5];
    }
    rtk_material m = rtk_material_default();
    out->material = RTK_INVALID_ID;
    if (materials) {
        uint32_t id = s->tri_material[hit->prim];
        if (id < s->material_count) {
            m = s->materials[id];
            out->material = id;
        }
    }
    out->base_color = m.base_color;
    out->alpha = m.alpha;
    out->emission = m.emission;
    out->specular = m.specular;
    out->shininess = m.shininess;
    out->ior = m.ior;
    out->metallic = m.metallic;
    out->roughness = m.roughness;
    out->transmission = m.transmission;
    out->illum = m.illum;
    if (s->textures && uvs && (s->needs & RTK_NEED_TEXTURES)) {
        float texel[4];
        if (m.base_tex >= 0 && (uint32_t)m.base_tex < s->texture_count && s->textures[m.base_tex].decoded) {
            rtk_texture_lookup(&s->textures[m.base_tex], out->uv.x, out->uv.y, texel);
            out->base_color = rtk_rgb_mul(out->base_color, rtk_rgb_make(texel[0], texel[1], texel[2]));
            if (m.alpha_tex == m.base_tex)
                out->alpha *= texel[3];
        }
        if (m.alpha_tex >= 0 && m.alpha_tex != m.base_tex && (uint32_t)m.alpha_tex < s->texture_count &&
            s->textures[m.alpha_tex].decoded) {
            rtk_texture_lookup(&s->textures[m.alpha_tex], out->uv.x, out->uv.y, texel);
            out->alpha *= rtk_texture_coverage(&s->textures[m.alpha_tex], texel);
        }
        if (m.emission_tex >= 0 && (uint32_t)m.emission_tex < s->texture_count && s->textures[m.emission_tex].decoded) {
            rtk_texture_lookup(&s->textures[m.emission_tex], out->uv.x, out->uv.y, texel);
            out->emission = rtk_rgb_mul(out->emission, rtk_rgb_make(texel[0], texel[1], texel[2]));
        }
    }
}
