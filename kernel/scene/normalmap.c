/* Tangent-space normal maps (glTF normalTexture, MTL norm / map_bump).
 * The tangent frame is derived per triangle from its positions and
 * texture coordinates (the direction of increasing u and v on the
 * surface), then made orthonormal around the interpolated shading normal
 * (Gram-Schmidt), so that smooth normals stay smooth; the texel's
 * (r, g, b) in [0, 1] is the direction 2 (r, g, b) - 1 in that frame
 * (x along +u; y towards the top of the image, -v of the texture service,
 * whose v runs down the image: the OpenGL convention glTF and OBJ normal
 * maps use; z along the normal).
 *
 * A grey image given as a normal map is a height (bump) map, which MTL's
 * map_bump usually names: it is reported once and ignored, not bent into
 * a wrong normal. */
#include "scene.h"

#include <math.h>

/* 1 when every texel is grey (r = g = b): a height map. */
static int is_height_map(const rtk_texture *t)
{
    size_t n = (size_t)t->width * (size_t)t->height;
    for (size_t i = 0; i < n; i++) {
        const float *p = t->rgba + 4 * i;
        if (p[0] != p[1] || p[1] != p[2])
            return 0;
    }
    return 1;
}

int rtk_normal_map_usable(rtk_texture *t)
{
    if (!t->decoded || t->missing || !t->rgba)
        return 0;
    if (t->normal_map_checked)
        return t->normal_map_checked > 0;
    t->normal_map_checked = is_height_map(t) ? -1 : 1;
    if (t->normal_map_checked < 0)
        rtk_log(RTK_LOG_WARN, "texture '%s' is grey: a height (bump) map, not a tangent-space normal map; "
                "shading ignores it", t->name ? t->name : "(unnamed)");
    return t->normal_map_checked > 0;
}

static rtk_vec3 corner(const rtk_scene *s, uint32_t prim, int k)
{
    const float *p = s->positions + 3 * (size_t)s->indices[3 * (size_t)prim + (size_t)k];
    return rtk_vec3_make(p[0], p[1], p[2]);
}

int rtk_apply_normal_map(const rtk_scene *s, const rtk_material *m, uint32_t prim, float u, float v, rtk_vec3 *ns)
{
    if (m->normal_tex < 0 || (uint32_t)m->normal_tex >= s->texture_count || !s->uvs)
        return 0;
    const rtk_texture *tex = &s->textures[m->normal_tex];
    if (!tex->decoded || tex->missing || tex->normal_map_checked <= 0)
        return 0;
    /* dp = T du + B dv over the triangle's two edges, in the normal map's
     * own (set and transformed) texture coordinates. */
    float t[6];
    for (int k = 0; k < 3; k++) {
        rtk_vec2 c = rtk_tex_map_uv(s, &m->normal_uv, prim, k == 1 ? 1.0f : 0.0f, k == 2 ? 1.0f : 0.0f);
        t[2 * k] = c.x, t[2 * k + 1] = c.y;
    }
    rtk_vec2 uv = rtk_tex_map_uv(s, &m->normal_uv, prim, u, v);
    float texel[4];
    rtk_texture_lookup(tex, uv.x, uv.y, texel);
    return rtk_bend_normal(corner(s, prim, 0), corner(s, prim, 1), corner(s, prim, 2), t, texel, ns);
}
