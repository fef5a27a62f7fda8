/* Kernel services over a loaded scene: tracing with counters, surface
 * interaction (normals, uvs, materials, textures), ray differentials and
 * texture footprints, scene queries.
 *
 * Footprints (Igehy 1999, pbrt-v3 section 10.1): a hit's differential
 * rays meet the triangle's plane at p + dp/dx and p + dp/dy; those offsets
 * in barycentrics give du/dx, dv/dx, du/dy, dv/dy, and a texture's level
 * of detail is log2 of the longer footprint side in its texels
 * (rtk_texture_lod). Barycentric changes are affine invariants, so a hit
 * on an instance is measured in the mesh's object space. */
#include "scene.h"
#include "../render/render.h"

#include <math.h>

/* Whether ray is the current sample's camera ray, in a scene where that
 * matters: camera rays pass through the back of single-sided materials. */
static int camera_ray(const rtk_ctx *ctx, const rtk_ray *ray)
{
    return ctx->scene->single_sided && ctx->camera && memcmp(ray, &ctx->camera_ray, sizeof *ray) == 0;
}

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
    if (!camera_ray(ctx, ray))
        return rtk_bvh_closest(ctx->scene, ray, hit);
    rtk_alpha_camera_ray(1);
    int got = rtk_bvh_closest(ctx->scene, ray, hit);
    rtk_alpha_camera_ray(0);
    return got;
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

/* Whether rays[i] of a batch counts as a camera ray: inside li_batch when
 * it is the ray li_batch received as rays[i], outside as for rtk_trace. */
static int batch_camera_ray(const rtk_ctx *ctx, const rtk_ray *rays, uint32_t i)
{
    if (!ctx->batch_count)
        return camera_ray(ctx, &rays[i]);
    return ctx->scene->single_sided && ctx->camera && i < ctx->batch_count &&
           memcmp(&rays[i], &ctx->batch_rays[i], sizeof rays[i]) == 0;
}

/* Rays [i, end) from i that share rays[i]'s validity and, in a
 * single-sided scene, whether they are camera rays: the runs one batch
 * traversal takes. */
static uint32_t batch_run(const rtk_ctx *ctx, const rtk_ray *rays, uint32_t i, uint32_t count, int *valid,
                          int *camera)
{
    *valid = rtk_ray_valid(&rays[i]);
    *camera = *valid && batch_camera_ray(ctx, rays, i);
    if (!*valid)
        return i + 1;
    uint32_t end = i + 1;
    while (end < count && rtk_ray_valid(&rays[end]) && batch_camera_ray(ctx, rays, end) == *camera)
        end++;
    return end;
}

RTK_API uint32_t rtk_trace_batch(rtk_ctx *ctx, const rtk_ray *rays, uint32_t count, rtk_hit *hits)
{
    ctx->rays += count;
    uint32_t got = 0;
    for (uint32_t i = 0; i < count;) {
        int valid, camera;
        uint32_t end = batch_run(ctx, rays, i, count, &valid, &camera);
        if (!valid) {
            ctx->invalid_rays++;
            hits[i].prim = hits[i].inst = RTK_INVALID_ID;
            hits[i].t = INFINITY;
            hits[i].u = hits[i].v = 0.0f;
        } else {
            if (camera)
                rtk_alpha_camera_ray(1);
            rtk_bvh_closest_batch(ctx->scene, rays + i, end - i, hits + i);
            if (camera)
                rtk_alpha_camera_ray(0);
            for (uint32_t k = i; k < end; k++)
                got += hits[k].prim != RTK_INVALID_ID;
        }
        i = end;
    }
    return got;
}

RTK_API uint32_t rtk_occluded_batch(rtk_ctx *ctx, const rtk_ray *rays, uint32_t count, uint8_t *occluded)
{
    ctx->rays += count;
    uint32_t got = 0;
    for (uint32_t i = 0; i < count;) {
        uint32_t end = i;
        while (end < count && rtk_ray_valid(&rays[end]))
            end++;
        if (end > i) {
            rtk_bvh_any_batch(ctx->scene, rays + i, end - i, occluded + i);
            for (uint32_t k = i; k < end; k++)
                got += occluded[k];
            i = end;
        } else {
            ctx->invalid_rays++;
            occluded[i++] = 0;
        }
    }
    return got;
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
    const int camera = camera_ray(ctx, ray);
    rtk_alpha_camera_ray(camera);
    int got = rtk_bvh_closest_measure(ctx->scene, ray, hit, work);
    rtk_alpha_camera_ray(0);
    return got;
}

RTK_API const rtk_scene *rtk_ctx_scene(const rtk_ctx *ctx)
{
    return ctx->scene;
}

RTK_API int rtk_ctx_camera_differential(const rtk_ctx *ctx, rtk_ray_differential *out)
{
    if (!ctx->camera)
        return 0;
    rtk_camera_differential(ctx->camera, ctx->film_x, ctx->film_y, out);
    return 1;
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

static int finite3d(const double v[3])
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

static void to3d(rtk_vec3 v, double out[3])
{
    out[0] = v.x, out[1] = v.y, out[2] = v.z;
}

/* The uv set map reads: uvs1 for set 1 when the scene has it, else uvs. */
static const float *map_set(const rtk_scene *s, const rtk_tex_map *map)
{
    return map->set == 1 && s->uvs1 ? s->uvs1 : s->uvs;
}

rtk_vec2 rtk_tex_map_uv(const rtk_scene *s, const rtk_tex_map *map, uint32_t prim, float u, float v)
{
    const float *uvs = map_set(s, map);
    if (!uvs)
        return (rtk_vec2){0.0f, 0.0f};
    return rtk_corner_uv(uvs + 6 * (size_t)prim, map->transformed, map->m, u, v);
}

void rtk_vertex_color(const rtk_scene *s, uint32_t prim, float u, float v, float rgba[4])
{
    if (!s->colors) {
        rgba[0] = rgba[1] = rgba[2] = rgba[3] = 1.0f;
        return;
    }
    rtk_corner_colors(s->colors + 12 * (size_t)prim, u, v, rgba);
}

/* Whether texture slot tex of the scene is decoded, so lookups read it. */
static int usable(const rtk_scene *s, int tex)
{
    return tex >= 0 && (uint32_t)tex < s->texture_count && s->textures[tex].decoded;
}

/* A hit's texture reads: the triangle, barycentrics, and the footprint
 * of each uv set (NULL where it was not measured). */
typedef struct tex_query {
    uint32_t prim;
    float u, v;
    const rtk_uv_footprint *fp[2];
} tex_query;

/* Texture tex through map and wrap at the query's point; at the
 * footprint's level of detail (through map's transform) when the texture
 * is filtered trilinearly and the footprint was measured. */
static void lookup(const rtk_scene *s, int tex, rtk_tex_wrap wrap, const rtk_tex_map *map, const tex_query *q,
                   float texel[4])
{
    const rtk_texture *t = &s->textures[tex];
    rtk_vec2 uv = rtk_tex_map_uv(s, map, q->prim, q->u, q->v);
    const rtk_uv_footprint *fp = q->fp[map_set(s, map) == s->uvs1 && s->uvs1 ? 1 : 0];
    float lod = 0.0f;
    if (fp && t->filter == RTK_TEX_TRILINEAR) {
        const rtk_uv_footprint mapped = rtk_uv_footprint_mapped(fp, map->transformed, map->m);
        lod = rtk_texture_lod(t, &mapped);
    }
    rtk_texture_sample(t, wrap, uv.x, uv.y, lod, texel);
}

/* Whether two slots read the same texels: the same wrap and uv map. */
static int same_use(rtk_tex_wrap a, rtk_tex_wrap b, const rtk_tex_map *ma, const rtk_tex_map *mb)
{
    return a.s == b.s && a.t == b.t && memcmp(ma, mb, sizeof *ma) == 0;
}

static void surface(const rtk_scene *s, const rtk_ray *ray, const rtk_ray_differential *diff, const rtk_hit *hit,
                    rtk_surface *out)
{
    if (hit->inst != RTK_INVALID_ID && hit->inst < s->instance_count) {
        rtk_instance_surface(s, ray, diff, hit, out);
        return;
    }
    rtk_vec3 a, b, c;
    rtk_scene_triangle(s, hit->prim, &a, &b, &c);
    float u = hit->u, v = hit->v, w = 1.0f - u - v;
    rtk_surface_geometry(a, b, c, s->normals ? s->normals + 9 * (size_t)hit->prim : NULL, u, v, ray->dir, &out->p,
                         &out->ng, &out->ns, &out->front_face);
    rtk_vec3 ng = out->ng;
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
    /* Read in place: a material is large, and this runs at every hit. */
    const rtk_material *m = NULL;
    rtk_material fallback;
    out->material = RTK_INVALID_ID;
    if (materials) {
        uint32_t id = s->tri_material[hit->prim];
        if (id < s->material_count) {
            m = &s->materials[id];
            out->material = id;
        }
    }
    if (!m) {
        fallback = rtk_material_default();
        m = &fallback;
    }
    out->base_color = m->base_color;
    out->alpha = m->alpha;
    out->emission = m->emission;
    out->specular = m->specular;
    out->shininess = m->shininess;
    out->ior = m->ior;
    out->metallic = m->metallic;
    out->roughness = m->roughness;
    out->transmission = m->transmission;
    out->illum = m->illum;
    if (materials && s->colors) {
        const float *c = s->colors + 12 * (size_t)hit->prim;
        float vc[4];
        rtk_corner_colors(c, u, v, vc);
        out->base_color = rtk_surface_base_color(out->base_color, c, u, v);
        out->alpha *= vc[3];
    }
    if (s->textures && uvs && (s->needs & RTK_NEED_TEXTURES)) {
        float texel[4];
        rtk_uv_footprint footprint[2];
        tex_query q = {hit->prim, u, v, {NULL, NULL}};
        const int slots[3] = {m->base_tex, m->alpha_tex, m->emission_tex};
        int mip = 0;
        for (int k = 0; k < 3; k++)
            mip |= usable(s, slots[k]) && s->textures[slots[k]].filter == RTK_TEX_TRILINEAR;
        const size_t at = 6 * (size_t)hit->prim;
        if (diff && mip && rtk_uv_footprint_at(s->uvs + at, a, b, c, out->p, ng, diff, &footprint[0]))
            q.fp[0] = &footprint[0];
        if (diff && mip && s->uvs1 && rtk_uv_footprint_at(s->uvs1 + at, a, b, c, out->p, ng, diff, &footprint[1]))
            q.fp[1] = &footprint[1];
        int alpha_done = 0;
        if (usable(s, m->base_tex)) {
            lookup(s, m->base_tex, m->base_wrap, &m->base_uv, &q, texel);
            out->base_color = rtk_rgb_mul(out->base_color, rtk_rgb_make(texel[0], texel[1], texel[2]));
            if (m->alpha_tex == m->base_tex && same_use(m->alpha_wrap, m->base_wrap, &m->alpha_uv, &m->base_uv)) {
                out->alpha *= texel[3];
                alpha_done = 1;
            }
        }
        if (!alpha_done && usable(s, m->alpha_tex)) {
            lookup(s, m->alpha_tex, m->alpha_wrap, &m->alpha_uv, &q, texel);
            out->alpha *=
                m->alpha_tex == m->base_tex ? texel[3] : rtk_texture_coverage(&s->textures[m->alpha_tex], texel);
        }
        if (usable(s, m->emission_tex)) {
            lookup(s, m->emission_tex, m->emission_wrap, &m->emission_uv, &q, texel);
            out->emission = rtk_rgb_mul(out->emission, rtk_rgb_make(texel[0], texel[1], texel[2]));
        }
        /* The normal map bends the normal on the authored side (so a
         * two-sided leaf seen from behind shows the mirror of its front),
         * which then turns to the ray's side; a bent normal that would
         * face away from the ray is not used. */
        rtk_vec3 n = out->front_face ? out->ns : rtk_vec3_neg(out->ns);
        if (rtk_apply_normal_map(s, m, hit->prim, u, v, &n)) {
            if (!out->front_face)
                n = rtk_vec3_neg(n);
            if (rtk_vec3_dot(n, out->ng) > 0.0f)
                out->ns = n;
        }
    }
}

RTK_API void rtk_surface_at(const rtk_scene *s, const rtk_ray *ray, const rtk_hit *hit, rtk_surface *out)
{
    surface(s, ray, NULL, hit, out);
}

RTK_API void rtk_surface_at_footprint(const rtk_scene *s, const rtk_ray *ray, const rtk_ray_differential *diff,
                                      const rtk_hit *hit, rtk_surface *out)
{
    surface(s, ray, diff, hit, out);
}

/* dn/dx and dn/dy (world space) of the shading normal of sf, the surface
 * at hit, for a point moving by dpdx and dpdy: the corner normals'
 * barycentric blend changes with the point (pbrt-v3 ignores the change of
 * the normalisation too). Zero without per-vertex normals. */
static void normal_change(const rtk_scene *scene, const rtk_hit *hit, const rtk_surface *sf, const double dpdx[3],
                          const double dpdy[3], double dndx[3], double dndy[3])
{
    for (int k = 0; k < 3; k++)
        dndx[k] = dndy[k] = 0.0;
    const rtk_scene *s = scene;
    const rtk_instance *in = NULL;
    if (hit->inst != RTK_INVALID_ID && hit->inst < scene->instance_count) {
        in = &scene->instances[hit->inst];
        s = scene->meshes[in->mesh];
    }
    if (!s->normals || hit->prim >= s->triangle_count)
        return;
    double dx[3], dy[3];
    for (int r = 0; r < 3; r++) {
        /* Object space: the linear part of to_object. */
        dx[r] = in ? in->to_object[4 * r] * dpdx[0] + in->to_object[4 * r + 1] * dpdx[1] +
                         in->to_object[4 * r + 2] * dpdx[2]
                   : dpdx[r];
        dy[r] = in ? in->to_object[4 * r] * dpdy[0] + in->to_object[4 * r + 1] * dpdy[1] +
                         in->to_object[4 * r + 2] * dpdy[2]
                   : dpdy[r];
    }
    rtk_vec3 a, b, c;
    rtk_scene_triangle(s, hit->prim, &a, &b, &c);
    double bx[2], by[2];
    if (!rtk_bary_change(a, b, c, dx, bx) || !rtk_bary_change(a, b, c, dy, by))
        return;
    const float *n = s->normals + 9 * (size_t)hit->prim;
    double w = 1.0 - (double)hit->u - (double)hit->v;
    double nx[3], ny[3], n0[3];
    for (int k = 0; k < 3; k++) {
        double e1 = (double)n[3 + k] - n[k], e2 = (double)n[6 + k] - n[k];
        nx[k] = bx[0] * e1 + bx[1] * e2;
        ny[k] = by[0] * e1 + by[1] * e2;
        n0[k] = w * n[k] + hit->u * (double)n[3 + k] + hit->v * (double)n[6 + k];
    }
    /* To world space as rtk_instance_surface maps normals: the inverse
     * transpose, then divided by the length it gives the normal. */
    double wn[3], wx[3], wy[3];
    for (int k = 0; k < 3; k++) {
        const double *m = in ? in->to_object : NULL;
        wn[k] = m ? m[k] * n0[0] + m[4 + k] * n0[1] + m[8 + k] * n0[2] : n0[k];
        wx[k] = m ? m[k] * nx[0] + m[4 + k] * nx[1] + m[8 + k] * nx[2] : nx[k];
        wy[k] = m ? m[k] * ny[0] + m[4 + k] * ny[1] + m[8 + k] * ny[2] : ny[k];
    }
    double len = sqrt(rtk_dot3d(wn, wn));
    if (!(len > 0.0))
        return;
    double ns[3];
    to3d(sf->ns, ns);
    double scale = (rtk_dot3d(wn, ns) < 0.0 ? -1.0 : 1.0) / len;
    for (int k = 0; k < 3; k++) {
        dndx[k] = wx[k] * scale;
        dndy[k] = wy[k] * scale;
    }
    if (!finite3d(dndx) || !finite3d(dndy))
        for (int k = 0; k < 3; k++)
            dndx[k] = dndy[k] = 0.0;
}

/* What both specular propagations share: the hit, where the differential
 * rays meet its tangent plane, wo, the incoming directions' change dwo/dx,
 * dwo/dy, and the normal's change. */
typedef struct specular_diff {
    rtk_vec3 p, ng;
    double dpdx[3], dpdy[3];
    double wo[3], dwodx[3], dwody[3];
    double dndx[3], dndy[3];
} specular_diff;

static void unit3d(rtk_vec3 v, double out[3])
{
    to3d(v, out);
    double len = sqrt(rtk_dot3d(out, out));
    for (int k = 0; k < 3; k++)
        out[k] = len > 0.0 ? out[k] / len : 0.0;
}

static int specular_setup(const rtk_scene *scene, const rtk_ray *ray, const rtk_ray_differential *diff,
                          const rtk_hit *hit, const rtk_surface *sf, specular_diff *sd)
{
    if (!rtk_plane_offset(sf->p, sf->ng, diff->rx_org, diff->rx_dir, sd->dpdx) ||
        !rtk_plane_offset(sf->p, sf->ng, diff->ry_org, diff->ry_dir, sd->dpdy))
        return 0;
    sd->p = sf->p;
    sd->ng = sf->ng;
    double d[3], dx[3], dy[3];
    unit3d(ray->dir, d);
    unit3d(diff->rx_dir, dx);
    unit3d(diff->ry_dir, dy);
    for (int k = 0; k < 3; k++) {
        sd->wo[k] = -d[k];
        sd->dwodx[k] = -dx[k] - sd->wo[k];
        sd->dwody[k] = -dy[k] - sd->wo[k];
    }
    normal_change(scene, hit, sf, sd->dpdx, sd->dpdy, sd->dndx, sd->dndy);
    return 1;
}

/* The new differentials: origins the tangent-plane offsets from the origin
 * the new ray gets (rtk_offset_ray_origin on wi's side, as integrators
 * spawn it), so that the offset, up to 2^-16 near the origin, does not
 * count as footprint. */
static int specular_finish(const specular_diff *sd, const double wi[3], const double dirx[3], const double diry[3],
                           rtk_ray_differential *out)
{
    double n[3], o[3], ox[3], oy[3];
    to3d(sd->ng, n);
    to3d(rtk_offset_ray_origin(sd->p, rtk_dot3d(wi, n) >= 0.0 ? sd->ng : rtk_vec3_neg(sd->ng)), o);
    for (int k = 0; k < 3; k++) {
        ox[k] = o[k] + sd->dpdx[k];
        oy[k] = o[k] + sd->dpdy[k];
    }
    if (!finite3d(ox) || !finite3d(oy) || !finite3d(dirx) || !finite3d(diry))
        return 0;
    out->rx_org = rtk_vec3_make((float)ox[0], (float)ox[1], (float)ox[2]);
    out->ry_org = rtk_vec3_make((float)oy[0], (float)oy[1], (float)oy[2]);
    out->rx_dir = rtk_vec3_make((float)dirx[0], (float)dirx[1], (float)dirx[2]);
    out->ry_dir = rtk_vec3_make((float)diry[0], (float)diry[1], (float)diry[2]);
    return 1;
}

RTK_API int rtk_differential_reflect(const rtk_scene *scene, const rtk_ray *ray, const rtk_ray_differential *diff,
                                     const rtk_hit *hit, const rtk_surface *s, rtk_vec3 wi,
                                     rtk_ray_differential *out)
{
    specular_diff sd;
    if (!diff || !specular_setup(scene, ray, diff, hit, s, &sd))
        return 0;
    double ns[3], w[3], dirx[3], diry[3];
    to3d(s->ns, ns);
    unit3d(wi, w);
    double dn = rtk_dot3d(sd.wo, ns);
    double ddnx = rtk_dot3d(sd.dwodx, ns) + rtk_dot3d(sd.wo, sd.dndx);
    double ddny = rtk_dot3d(sd.dwody, ns) + rtk_dot3d(sd.wo, sd.dndy);
    for (int k = 0; k < 3; k++) {
        dirx[k] = w[k] - sd.dwodx[k] + 2.0 * (dn * sd.dndx[k] + ddnx * ns[k]);
        diry[k] = w[k] - sd.dwody[k] + 2.0 * (dn * sd.dndy[k] + ddny * ns[k]);
    }
    return specular_finish(&sd, w, dirx, diry, out);
}

RTK_API int rtk_differential_refract(const rtk_scene *scene, const rtk_ray *ray, const rtk_ray_differential *diff,
                                     const rtk_hit *hit, const rtk_surface *s, rtk_vec3 wi, float eta,
                                     rtk_ray_differential *out)
{
    specular_diff sd;
    if (!diff || !(eta > 0.0f) || !specular_setup(scene, ray, diff, hit, s, &sd))
        return 0;
    double ns[3], w[3], dirx[3], diry[3];
    to3d(s->ns, ns);
    unit3d(wi, w);
    /* The normal on wo's side, as the refraction formula has it. */
    if (rtk_dot3d(sd.wo, ns) < 0.0)
        for (int k = 0; k < 3; k++)
            ns[k] = -ns[k], sd.dndx[k] = -sd.dndx[k], sd.dndy[k] = -sd.dndy[k];
    double e = eta, dn = rtk_dot3d(sd.wo, ns), cos_t = fabs(rtk_dot3d(w, ns));
    if (!(cos_t > 0.0))
        return 0;
    /* wi = -eta wo + mu n with mu = eta (wo.n) - cos_t, differentiated. */
    double mu = e * dn - cos_t;
    double ddnx = rtk_dot3d(sd.dwodx, ns) + rtk_dot3d(sd.wo, sd.dndx);
    double ddny = rtk_dot3d(sd.dwody, ns) + rtk_dot3d(sd.wo, sd.dndy);
    double k_mu = e - e * e * dn / cos_t;
    for (int k = 0; k < 3; k++) {
        dirx[k] = w[k] - e * sd.dwodx[k] + mu * sd.dndx[k] + k_mu * ddnx * ns[k];
        diry[k] = w[k] - e * sd.dwody[k] + mu * sd.dndy[k] + k_mu * ddny * ns[k];
    }
    return specular_finish(&sd, w, dirx, diry, out);
}
