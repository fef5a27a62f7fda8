/* Alpha cutouts: triangles whose material cuts out (glTF MASK, or BLEND
 * with a texture; OBJ map_d) are transparent where their coverage is below
 * the cutoff. Traversal asks here for every hit on such a triangle, so
 * shadow, AO and camera rays all pass through the cut-out parts; scenes
 * without cutout materials never call in (rtk_scene.has_cutouts). */
#include "internal.h"

int rtk_material_cutout(const rtk_material *m, float *cutoff)
{
    if (m->alpha_mode == RTK_ALPHA_MASK) {
        *cutoff = m->alpha_cutoff;
        return 1;
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

int rtk_alpha_opaque(const rtk_scene *s, uint32_t prim, float u, float v)
{
    uint32_t id = s->tri_material ? s->tri_material[prim] : RTK_INVALID_ID;
    if (id >= s->material_count)
        return 1;
    const rtk_material *m = &s->materials[id];
    float cutoff;
    if (!rtk_material_cutout(m, &cutoff))
        return 1;
    rtk_vec2 uv = rtk_tex_map_uv(s, &m->alpha_uv, prim, u, v);
    float vc[4];
    rtk_vertex_color(s, prim, u, v, vc);
    return rtk_material_alpha(s, m, uv.x, uv.y) * vc[3] >= cutoff;
}
