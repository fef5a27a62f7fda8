/* The scene's lights: the emitting triangles, chosen in proportion to
 * power with one alias table (Vose 1991) over the whole scene, then a
 * uniform point on the chosen triangle; the punctual lights; and the
 * choice between all of them and the environment (environment.c) by
 * power, for rtk_sample_incident_light. */
#include "light_sample.h"

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
    free(l->slot_pick);
    free(l->slot_cdf);
    rtk_environment_free(l->environment);
    free(l);
}

/* Emitters of the mesh that instance inst places (its own table). */
static uint32_t instance_lights(const rtk_scene *s, uint32_t inst)
{
    const rtk_scene *mesh = s->meshes[s->instances[inst].mesh];
    return mesh->lights ? mesh->lights->count : 0;
}

/* Luminance of m's emission as the power table counts it: the factor x
 * the mean texel of its emission texture, when one is decoded. */
static double emitted_luminance(const rtk_scene *s, const rtk_material *m)
{
    double le = luminance(m->emission);
    if (m->emission_tex < 0 || (uint32_t)m->emission_tex >= s->texture_count)
        return le;
    const rtk_texture *t = &s->textures[m->emission_tex];
    if (!t->decoded || t->missing || !t->rgba || t->width <= 0 || t->height <= 0)
        return le;
    size_t n = (size_t)t->width * (size_t)t->height;
    double sum = 0.0;
    for (size_t i = 0; i < n; i++)
        sum += luminance(rtk_rgb_make(t->rgba[4 * i], t->rgba[4 * i + 1], t->rgba[4 * i + 2]));
    return le * sum / (double)n;
}

static double triangle_area(rtk_vec3 a, rtk_vec3 b, rtk_vec3 c)
{
    double ex = (double)b.x - a.x, ey = (double)b.y - a.y, ez = (double)b.z - a.z;
    double fx = (double)c.x - a.x, fy = (double)c.y - a.y, fz = (double)c.z - a.z;
    double cx = ey * fz - ez * fy, cy = ez * fx - ex * fz, cz = ex * fy - ey * fx;
    return 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
}

static rtk_status update_choice(rtk_scene *s);

/* The emitter table and light choice of s: emptied, keeping the environment. */
static rtk_status lights_reset(rtk_scene *s)
{
    rtk_environment *env = s->lights ? s->lights->environment : NULL;
    if (s->lights)
        s->lights->environment = NULL;
    rtk_lights_free(s->lights);
    s->lights = rtk_calloc(1, sizeof *s->lights);
    if (!s->lights) {
        rtk_environment_free(env);
        return RTK_ERR_NOMEM;
    }
    s->lights->environment = env;
    return RTK_OK;
}

static rtk_status build_emitters(rtk_scene *s);

rtk_status rtk_lights_build(rtk_scene *s)
{
    rtk_status st = lights_reset(s);
    if (st == RTK_OK)
        st = build_emitters(s);
    if (st == RTK_OK)
        st = update_choice(s);
    return st;
}

/* The alias table over the emitting triangles of s (its lights just reset). */
static rtk_status build_emitters(rtk_scene *s)
{
    rtk_lights *l = s->lights;
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
        scaled[k] = area * emitted_luminance(s, m);
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
            scaled[k] = area * emitted_luminance(mesh, material_of(mesh, t));
            total += scaled[k];
            k++;
        }
    }
    if (!(total > 0.0)) { /* every emission texture is black */
        l->count = 0;
        free(scaled);
        free(small);
        free(large);
        return RTK_OK;
    }
    l->area_power = RTK_PI * total;
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

/* Emitter light's corners in world space, and whether its instance mirrors them. */
static void emitter_corners(const void *ctx, uint32_t light, rtk_vec3 *a, rtk_vec3 *b, rtk_vec3 *c, int *mirrored)
{
    const rtk_scene *s = ctx;
    uint32_t prim = s->lights->prims[light], inst = s->lights->insts[light];
    if (inst == RTK_INVALID_ID) {
        rtk_scene_triangle(s, prim, a, b, c);
        *mirrored = 0;
    } else {
        rtk_instance_triangle(s, inst, prim, a, b, c);
        *mirrored = s->instances[inst].mirrored;
    }
}

/* Emitter light's radiance at barycentrics (b1, b2): its material's
 * emission, times its emission texture where decoded. */
static rtk_rgb emitter_emission(const void *ctx, uint32_t light, float b1, float b2)
{
    const rtk_scene *s = ctx;
    uint32_t prim = s->lights->prims[light], inst = s->lights->insts[light];
    const rtk_scene *mesh = inst == RTK_INVALID_ID ? s : s->meshes[s->instances[inst].mesh];
    const rtk_material *m = material_of(mesh, prim);
    rtk_rgb le = m->emission;
    if (m->emission_tex >= 0 && (uint32_t)m->emission_tex < mesh->texture_count && mesh->uvs &&
        mesh->textures[m->emission_tex].decoded) {
        rtk_vec2 uv = rtk_tex_map_uv(mesh, &m->emission_uv, prim, b1, b2);
        float texel[4];
        rtk_texture_lookup(&mesh->textures[m->emission_tex], uv.x, uv.y, texel);
        le = rtk_rgb_mul(le, rtk_rgb_make(texel[0], texel[1], texel[2]));
    }
    return le;
}

static const rtk_emitter_fns scene_emitters = {emitter_corners, emitter_emission};

RTK_API int rtk_scene_sample_light(const rtk_scene *s, float u_pick, rtk_vec2 u, rtk_light_sample *out)
{
    const rtk_lights *l = s->lights;
    if (!l || l->count == 0)
        return 0;
    rtk_emitter_sample(l, &scene_emitters, s, u_pick, u, out);
    return 1;
}

RTK_API rtk_ray rtk_shadow_ray(rtk_vec3 p, rtk_vec3 np, rtk_vec3 q, rtk_vec3 nq)
{
    return rtk_shadow_between(p, np, q, nq);
}

/* rtk_scene_light_pdf on s's table l (or NULL). */
static inline float area_pdf(const rtk_scene *s, const rtk_lights *l, const rtk_hit *hit)
{
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

RTK_API float rtk_scene_light_pdf(const rtk_scene *s, const rtk_hit *hit)
{
    return area_pdf(s, s->lights, hit);
}

rtk_status rtk_scene_add_punctual(rtk_scene *s, const rtk_punctual_light *light)
{
    rtk_punctual_light *grown = rtk_realloc_array(s->punctual, (size_t)s->punctual_count + 1, sizeof *grown);
    if (!grown)
        return RTK_ERR_NOMEM;
    s->punctual = grown;
    s->punctual[s->punctual_count++] = *light;
    return update_choice(s);
}

rtk_status rtk_scene_set_environment(rtk_scene *s, rtk_environment *env)
{
    if (!s->lights && !(s->lights = rtk_calloc(1, sizeof *s->lights))) {
        rtk_environment_free(env);
        return RTK_ERR_NOMEM;
    }
    rtk_environment_free(s->lights->environment);
    s->lights->environment = env;
    return update_choice(s);
}

/* Radius of the sphere around the scene's bounds (1 for empty bounds). */
static double scene_radius(const rtk_scene *s)
{
    rtk_bounds b = s->bounds;
    if (!(b.upper.x >= b.lower.x && b.upper.y >= b.lower.y && b.upper.z >= b.lower.z))
        return 1.0;
    double dx = (double)b.upper.x - b.lower.x, dy = (double)b.upper.y - b.lower.y, dz = (double)b.upper.z - b.lower.z;
    double r = 0.5 * sqrt(dx * dx + dy * dy + dz * dz);
    return r > 0.0 && isfinite(r) ? r : 1.0;
}

/* Power of a punctual light (rtk/lights.h's table). */
static double punctual_power(const rtk_punctual_light *p, double radius)
{
    double i = luminance(p->intensity);
    switch (p->type) {
    case RTK_LIGHT_POINT:
        return 4.0 * RTK_PI * i;
    case RTK_LIGHT_SPOT:
        return 2.0 * RTK_PI * i * (1.0 - 0.5 * ((double)p->cos_inner + p->cos_outer));
    case RTK_LIGHT_DIRECTIONAL:
        return RTK_PI * radius * radius * i;
    }
    return 0.0;
}

/* The choice between all lights by power: slot 0 the emitters, then the
 * punctual lights, then the environment. */
static rtk_status update_choice(rtk_scene *s)
{
    if (!s->lights && !(s->lights = rtk_calloc(1, sizeof *s->lights)))
        return RTK_ERR_NOMEM;
    static uint64_t stamps;
    rtk_lights *l = s->lights;
    l->stamp = __atomic_add_fetch(&stamps, 1, __ATOMIC_RELAXED);
    l->slot_count = 0; /* no choice until the table is whole */
    uint32_t n = s->punctual_count + 2;
    float *pick = rtk_realloc_array(l->slot_pick, n, sizeof *pick);
    if (pick)
        l->slot_pick = pick;
    float *cdf = rtk_realloc_array(l->slot_cdf, (size_t)n + 1, sizeof *cdf);
    if (cdf)
        l->slot_cdf = cdf;
    if (!pick || !cdf)
        return RTK_ERR_NOMEM;
    double radius = scene_radius(s), total = 0.0;
    double *power = rtk_alloc(sizeof *power * n);
    if (!power)
        return RTK_ERR_NOMEM;
    power[0] = l->count ? l->area_power : 0.0;
    for (uint32_t i = 0; i < s->punctual_count; i++)
        power[1 + i] = punctual_power(&s->punctual[i], radius);
    const rtk_environment *env = l->environment;
    power[n - 1] = env ? RTK_PI * radius * radius * 4.0 * RTK_PI * env->mean_radiance : 0.0;
    for (uint32_t i = 0; i < n; i++) {
        if (!(power[i] > 0.0) || !isfinite(power[i]))
            power[i] = 0.0;
        total += power[i];
    }
    double run = 0.0;
    for (uint32_t i = 0; i < n; i++) {
        pick[i] = total > 0.0 ? (float)(power[i] / total) : 0.0f;
        cdf[i] = (float)(total > 0.0 ? run / total : 0.0);
        run += power[i];
    }
    cdf[n] = 1.0f;
    /* Slots after the last one with power end at 1, so that no u_pick < 1
     * reaches them. */
    for (uint32_t i = n; i-- > 0 && !(power[i] > 0.0);)
        cdf[i] = 1.0f;
    l->slot_count = total > 0.0 ? n : 0;
    free(power);
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

RTK_API float rtk_spot_falloff(const rtk_punctual_light *light, float cos_axis)
{
    return rtk_spot_factor(light, cos_axis);
}

RTK_API int rtk_sample_incident_light(const rtk_scene *s, rtk_vec3 p, rtk_vec3 ng, float u_pick, rtk_vec2 u,
                                      rtk_light_incident *out)
{
    const rtk_lights *l = s->lights;
    if (!l || l->slot_count == 0)
        return 0;
    return rtk_lights_incident(l, s->punctual, s->punctual_count, &scene_emitters, s, p, ng, u_pick, u, out);
}

/* The geometric normal of emitter light (its emitting side). */
static rtk_vec3 emitter_normal(const rtk_scene *s, uint32_t prim, uint32_t inst)
{
    rtk_vec3 a, b, c;
    if (inst == RTK_INVALID_ID)
        rtk_scene_triangle(s, prim, &a, &b, &c);
    else
        rtk_instance_triangle(s, inst, prim, &a, &b, &c);
    rtk_vec3 n = rtk_vec3_normalize(rtk_vec3_cross(rtk_vec3_sub(b, a), rtk_vec3_sub(c, a)));
    return inst != RTK_INVALID_ID && s->instances[inst].mirrored ? rtk_vec3_neg(n) : n;
}

RTK_API float rtk_incident_light_pdf(const rtk_scene *s, rtk_vec3 p, const rtk_ray *ray, const rtk_hit *hit)
{
    (void)p; /* the ray leaves p: its length to the hit is hit->t x |dir| */
    const rtk_lights *l = s->lights;
    if (!l || l->slot_count == 0)
        return 0.0f;
    if (!hit || hit->prim == RTK_INVALID_ID) {
        float pick = l->slot_pick[l->slot_count - 1];
        return pick > 0.0f ? rtk_env_pdf(l->environment, ray->dir) * pick : 0.0f;
    }
    float pdf_area = area_pdf(s, l, hit);
    return pdf_area > 0.0f ? rtk_emitter_solid_pdf(emitter_normal(s, hit->prim, hit->inst), ray, hit->t, pdf_area,
                                                   l->slot_pick[0])
                           : 0.0f;
}

RTK_API rtk_rgb rtk_scene_environment(const rtk_scene *s, rtk_vec3 dir)
{
    const rtk_lights *l = s->lights;
    if (!l || !l->environment)
        return rtk_rgb_make(0.0f, 0.0f, 0.0f);
    return rtk_env_radiance(l->environment, dir);
}
