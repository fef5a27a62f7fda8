/* Emitters: the triangles whose material emits, chosen in proportion to
 * power with one alias table (Vose 1991) over the whole scene, then a
 * uniform point on the chosen triangle. */
#include "scene.h"
#include "../accel/accel.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static float luminance(rtk_rgb c)
{
    return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b;
}

static const rtk_material *material_of(const rtk_scene *s, uint32_t prim)
{
    if (!s->tri_material)
        return NULL;
    uint32_t id = s->tri_material[prim];
    return id < s->material_count ? &s->materials[id] : NULL;
}

void rtk_lights_free(rtk_lights *l)
{
    if (!l)
        return;
    free(l->prims);
    free(l->insts);
    free(l->inst_first);
    free(l->area);
    free(l->pick);
    free(l->alias_prob);
    free(l->alias);
    free(l->light_of);
    free(l);
}

/* Emitters of the mesh that instance inst places (its own table). */
static uint32_t instance_lights(const rtk_scene *s, uint32_t inst)
{
    const rtk_scene *mesh = s->meshes[s->instances[inst].mesh];
    return mesh->lights ? mesh->lights->count : 0;
}

static double triangle_area(rtk_vec3 a, rtk_vec3 b, rtk_vec3 c)
{
    double ex = (double)b.x - a.x, ey = (double)b.y - a.y, ez = (double)b.z - a.z;
    double fx = (double)c.x - a.x, fy = (double)c.y - a.y, fz = (double)c.z - a.z;
    double cx = ey * fz - ez * fy, cy = ez * fx - ex * fz, cz = ex * fy - ey * fx;
    return 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
}

rtk_status rtk_lights_build(rtk_scene *s)
{
    rtk_lights_free(s->lights);
    s->lights = NULL;
    rtk_lights *l = rtk_calloc(1, sizeof *l);
    if (!l)
        return RTK_ERR_NOMEM;
    s->lights = l;
    uint64_t total_count = 0;
    for (uint32_t t = 0; t < s->triangle_count; t++) {
        const rtk_material *m = material_of(s, t);
        if (m && luminance(m->emission) > 0.0f)
            total_count++;
    }
    if (s->instance_count) {
        l->inst_first = rtk_alloc(sizeof *l->inst_first * s->instance_count);
        if (!l->inst_first)
            return RTK_ERR_NOMEM;
        for (uint32_t i = 0; i < s->instance_count; i++) {
            l->inst_first[i] = (uint32_t)total_count;
            total_count += instance_lights(s, i);
        }
    }
    if (total_count >= RTK_INVALID_ID)
        return rtk_error(RTK_ERR_NOMEM, "%s: %llu emitting triangles (instances counted) are more than rtk indexes",
                         s->path, (unsigned long long)total_count);
    uint32_t n = (uint32_t)total_count;
    l->count = n;
    if (n == 0)
        return RTK_OK;
    l->prims = rtk_alloc(sizeof *l->prims * n);
    l->insts = rtk_alloc(sizeof *l->insts * n);
    l->area = rtk_alloc(sizeof *l->area * n);
    l->pick = rtk_alloc(sizeof *l->pick * n);
    l->alias_prob = rtk_alloc(sizeof *l->alias_prob * n);
    l->alias = rtk_alloc(sizeof *l->alias * n);
    l->light_of = rtk_alloc(sizeof *l->light_of * (s->triangle_count ? s->triangle_count : 1));
    double *scaled = rtk_alloc(sizeof *scaled * n);
    uint32_t *small = rtk_alloc(sizeof *small * n), *large = rtk_alloc(sizeof *large * n);
    if (!l->prims || !l->insts || !l->area || !l->pick || !l->alias_prob || !l->alias || !l->light_of || !scaled ||
        !small || !large) {
        free(scaled);
        free(small);
        free(large);
        return RTK_ERR_NOMEM;
    }
    double total = 0.0;
    uint32_t k = 0;
    for (uint32_t t = 0; t < s->triangle_count; t++) {
        const rtk_material *m = material_of(s, t);
        l->light_of[t] = RTK_INVALID_ID;
        if (!m || !(luminance(m->emission) > 0.0f))
            continue;
        rtk_vec3 a, b, c;
        rtk_scene_triangle(s, t, &a, &b, &c);
        double area = triangle_area(a, b, c);
        l->prims[k] = t;
        l->insts[k] = RTK_INVALID_ID;
        l->area[k] = (float)area;
        l->light_of[t] = k;
        scaled[k] = area * luminance(m->emission);
        total += scaled[k];
        k++;
    }
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const rtk_scene *mesh = s->meshes[s->instances[i].mesh];
        for (uint32_t j = 0; j < instance_lights(s, i); j++) {
            uint32_t t = mesh->lights->prims[j];
            rtk_vec3 a, b, c;
            rtk_instance_triangle(s, i, t, &a, &b, &c);
            double area = triangle_area(a, b, c);
            l->prims[k] = t;
            l->insts[k] = i;
            l->area[k] = (float)area;
            scaled[k] = area * luminance(material_of(mesh, t)->emission);
            total += scaled[k];
            k++;
        }
    }
    /* Vose's alias method: columns of height 1, each split between its
     * own light and one alias. */
    uint32_t ns = 0, nl = 0;
    for (uint32_t i = 0; i < n; i++) {
        l->pick[i] = (float)(scaled[i] / total);
        scaled[i] = scaled[i] / total * n;
        if (scaled[i] < 1.0)
            small[ns++] = i;
        else
            large[nl++] = i;
    }
    while (ns > 0 && nl > 0) {
        uint32_t lo = small[--ns], hi = large[--nl];
        l->alias_prob[lo] = (float)scaled[lo];
        l->alias[lo] = hi;
        scaled[hi] = (scaled[hi] + scaled[lo]) - 1.0;
        if (scaled[hi] < 1.0)
            small[ns++] = hi;
        else
            large[nl++] = hi;
    }
    while (nl > 0) {
        uint32_t i = large[--nl];
        l->alias_prob[i] = 1.0f, l->alias[i] = i;
    }
    while (ns > 0) {
        uint32_t i = small[--ns];
        l->alias_prob[i] = 1.0f, l->alias[i] = i;
    }
    free(scaled);
    free(small);
    free(large);
    return RTK_OK;
}

RTK_API uint32_t rtk_scene_light_count(const rtk_scene *s)
{
    return s->lights ? s->lights->count : 0;
}

RTK_API int rtk_scene_sample_light(const rtk_scene *s, float u_pick, rtk_vec2 u, rtk_light_sample *out)
{
    const rtk_lights *l = s->lights;
    if (!l || l->count == 0)
        return 0;
    float x = u_pick * (float)l->count;
    uint32_t col = (uint32_t)x;
    if (col >= l->count)
        col = l->count - 1;
    float frac = x - (float)col;
    uint32_t light = frac < l->alias_prob[col] ? col : l->alias[col];
    uint32_t prim = l->prims[light], inst = l->insts[light];
    const rtk_scene *mesh = s; /* the scene whose materials and uvs the triangle has */
    rtk_vec3 a, b, c;
    if (inst == RTK_INVALID_ID) {
        rtk_scene_triangle(s, prim, &a, &b, &c);
    } else {
        mesh = s->meshes[s->instances[inst].mesh];
        rtk_instance_triangle(s, inst, prim, &a, &b, &c);
    }
    /* Uniform on the triangle: the square-root warp. */
    float r = sqrtf(u.x);
    float b0 = 1.0f - r, b1 = u.y * r, b2 = 1.0f - b0 - b1;
    out->p = rtk_vec3_make(b0 * a.x + b1 * b.x + b2 * c.x, b0 * a.y + b1 * b.y + b2 * c.y,
                           b0 * a.z + b1 * b.z + b2 * c.z);
    out->n = rtk_vec3_normalize(rtk_vec3_cross(rtk_vec3_sub(b, a), rtk_vec3_sub(c, a)));
    /* A mirrored instance's corners wind the other way round; the emitting
     * side stays the authored one (see rtk_instance_surface). */
    if (inst != RTK_INVALID_ID && s->instances[inst].mirrored)
        out->n = rtk_vec3_neg(out->n);
    const rtk_material *m = material_of(mesh, prim);
    out->le = m->emission;
    if (m->emission_tex >= 0 && (uint32_t)m->emission_tex < mesh->texture_count && mesh->uvs &&
        mesh->textures[m->emission_tex].decoded) {
        rtk_vec2 uv = rtk_tex_map_uv(mesh, &m->emission_uv, prim, b1, b2);
        float texel[4];
        rtk_texture_lookup(&mesh->textures[m->emission_tex], uv.x, uv.y, texel);
        out->le = rtk_rgb_mul(out->le, rtk_rgb_make(texel[0], texel[1], texel[2]));
    }
    out->pdf_area = l->pick[light] / l->area[light];
    out->prim = prim;
    out->inst = inst;
    return 1;
}

/* n, or -n when it faces away from d. */
static rtk_vec3 facing(rtk_vec3 n, rtk_vec3 d)
{
    return rtk_vec3_dot(n, d) < 0.0f ? rtk_vec3_neg(n) : n;
}

RTK_API rtk_ray rtk_shadow_ray(rtk_vec3 p, rtk_vec3 np, rtk_vec3 q, rtk_vec3 nq)
{
    rtk_vec3 d = rtk_vec3_sub(q, p);
    rtk_vec3 from = rtk_offset_ray_origin(p, facing(np, d)), to = rtk_offset_ray_origin(q, facing(nq, rtk_vec3_neg(d)));
    rtk_ray r = {from, 0.0f, rtk_vec3_sub(to, from), 1.0f};
    return r;
}

RTK_API float rtk_scene_light_pdf(const rtk_scene *s, const rtk_hit *hit)
{
    const rtk_lights *l = s->lights;
    if (!l || l->count == 0 || hit->prim == RTK_INVALID_ID)
        return 0.0f;
    uint32_t light;
    if (hit->inst == RTK_INVALID_ID) {
        if (hit->prim >= s->triangle_count)
            return 0.0f;
        light = l->light_of[hit->prim];
    } else {
        if (hit->inst >= s->instance_count)
            return 0.0f;
        const rtk_scene *mesh = s->meshes[s->instances[hit->inst].mesh];
        if (!mesh->lights || !mesh->lights->count || hit->prim >= mesh->triangle_count)
            return 0.0f;
        light = mesh->lights->light_of[hit->prim];
        if (light != RTK_INVALID_ID)
            light += l->inst_first[hit->inst];
    }
    return light == RTK_INVALID_ID ? 0.0f : l->pick[light] / l->area[light];
}

rtk_status rtk_scene_add_punctual(rtk_scene *s, const rtk_punctual_light *light)
{
    rtk_punctual_light *grown = rtk_realloc_array(s->punctual, (size_t)s->punctual_count + 1, sizeof *grown);
    if (!grown)
        return RTK_ERR_NOMEM;
    s->punctual = grown;
    s->punctual[s->punctual_count++] = *light;
    return RTK_OK;
}

RTK_API uint32_t rtk_scene_punctual_count(const rtk_scene *s)
{
    return s->punctual_count;
}

RTK_API const rtk_punctual_light *rtk_scene_punctual(const rtk_scene *s, uint32_t i)
{
    return i < s->punctual_count ? &s->punctual[i] : NULL;
}
