/* Alpha cutouts: triangles whose material cuts out (glTF MASK, or BLEND
 * with a texture; OBJ map_d) are transparent where their coverage is below
 * the cutoff. Traversal asks here for every hit on such a triangle, so
 * shadow, AO and camera rays all pass through the cut-out parts; scenes
 * without cutout materials never call in (rtk_scene.has_cutouts).
 * glTF BLEND is stochastic coverage: a ray stops with the chance alpha,
 * decided by a hash of the ray and triangle, so that samples average to
 * the blend. Camera rays pass through the back of single-sided glTF
 * materials (doubleSided false); other rays see both sides. */
#include "scene.h"

#include <string.h>

/* Whether this thread traces a camera ray now (rtk_trace sets it). */
static _Thread_local int camera_ray;

void rtk_alpha_camera_ray(int on)
{
    camera_ray = on;
}

int rtk_material_cutout(const rtk_material *m, float *cutoff)
{
    if (m->alpha_mode == RTK_ALPHA_MASK) {
        *cutoff = m->alpha_cutoff;
        return 1;
    }
    if (m->alpha_mode == RTK_ALPHA_BLEND && m->coverage) {
        *cutoff = -1.0f;
        return m->alpha < 1.0f || m->alpha_tex >= 0;
    }
    /* BLEND needs blending a ray tracer of this kind does not do; with a
     * texture (foliage atlases) it is a cutout at 0.5, a constant alpha
     * alone (glass, d < 1 in MTL) is left to the integrators. */
    if (m->alpha_mode == RTK_ALPHA_BLEND && m->alpha_tex >= 0) {
        *cutoff = 0.5f;
        return 1;
    }
    return 0;
}

float rtk_texture_coverage(const rtk_texture *tex, const float texel[4])
{
    return tex->has_alpha ? texel[3] : texel[0];
}

float rtk_material_alpha(const rtk_scene *s, const rtk_material *m, float u, float v)
{
    float alpha = m->alpha;
    if (m->alpha_tex < 0 || (uint32_t)m->alpha_tex >= s->texture_count)
        return alpha;
    const rtk_texture *tex = &s->textures[m->alpha_tex];
    if (!tex->decoded || tex->missing)
        return alpha;
    float texel[4];
    rtk_texture_sample(tex, m->alpha_wrap, u, v, 0.0f, texel);
    return alpha * (m->alpha_tex == m->base_tex ? texel[3] : rtk_texture_coverage(tex, texel));
}

/* A number in [0, 1) from the ray's origin and direction and prim. */
static float ray_hash(const rtk_ray *ray, uint32_t prim)
{
    uint32_t w[6];
    memcpy(w, &ray->org, 3 * sizeof(float));
    memcpy(w + 3, &ray->dir, 3 * sizeof(float));
    uint64_t h = 0x9e3779b97f4a7c15ull ^ prim;
    for (int k = 0; k < 6; k++) {
        h = (h ^ w[k]) * 0xff51afd7ed558ccdull;
        h ^= h >> 33;
    }
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    return (float)(h >> 40) * 0x1p-24f;
}

/* Whether ray meets triangle prim from the side its winding does not face. */
static int back_side(const rtk_scene *s, const rtk_ray *ray, uint32_t prim)
{
    float c[9];
    rtk_triangle_corners(s, prim, c);
    double e1[3] = {(double)c[3] - c[0], (double)c[4] - c[1], (double)c[5] - c[2]};
    double e2[3] = {(double)c[6] - c[0], (double)c[7] - c[1], (double)c[8] - c[2]};
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    return n[0] * ray->dir.x + n[1] * ray->dir.y + n[2] * ray->dir.z > 0.0;
}

int rtk_alpha_opaque(const rtk_scene *s, const rtk_ray *ray, uint32_t prim, float u, float v)
{
    uint32_t id = s->tri_material ? s->tri_material[prim] : RTK_INVALID_ID;
    if (id >= s->material_count)
        return 1;
    const rtk_material *m = &s->materials[id];
    if (m->single_sided && camera_ray && back_side(s, ray, prim))
        return 0;
    float cutoff;
    if (!rtk_material_cutout(m, &cutoff))
        return 1;
    rtk_vec2 uv = rtk_tex_map_uv(s, &m->alpha_uv, prim, u, v);
    float vc[4];
    rtk_vertex_color(s, prim, u, v, vc);
    float alpha = rtk_material_alpha(s, m, uv.x, uv.y) * vc[3];
    return cutoff < 0.0f ? alpha > ray_hash(ray, prim) : alpha >= cutoff;
}
