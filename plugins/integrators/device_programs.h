/* Device programs: integrators' estimators that a device accelerator runs
 * whole for each camera sample (rtk_accelerator_fns.shade), in plain C
 * that nvcc compiles too (RTK_HD), over the kernel's flat trees
 * (kernel/accel/device_tree.h) with its sampler (kernel/render/sample.h)
 * and surface geometry (kernel/scene/surface_geom.h). Device accelerators
 * (plugins/accelerators/cuda, tests/plugins/device) and `rtk conform`
 * run them.
 *
 * Programs (rtk_device_program.name, then its params):
 *   "ao"         ao (plugins/integrators/ao_estimator.h): params[0] rays
 *                (1 to 4096), params[1] distance (> 0), params[2] albedo
 *                (0 or 1).
 *   "headlight"  headlight (plugins/integrators/headlight_estimator.h):
 *                params[0] ambient (0 to 1).
 *   "path"       path (plugins/integrators/path_estimator.h): params[0]
 *                max_depth (0 to 1024), params[1] rr_depth (1 to 1024),
 *                params[2] clamp (>= 0), all lights (emitters, punctual,
 *                environment) as rtk_sample_incident_light samples them.
 * Surfaces: position, normals, the material's factors (base colour times
 * vertex colour, emission, the BSDF of kernel/scene/material_bsdf.h) and
 * its textures (base colour, alpha, emission, normal map and the BSDF's
 * factor maps, through kernel/scene/texture_sample.h): at a camera ray's
 * hit, base colour, alpha and emission read trilinearly filtered textures
 * at the level of detail of the pixel's footprint (the camera
 * differentials of rtk_shade_batch.diffs), as rtk_surface_at_footprint
 * does; every other read is at level 0, as on the CPU.
 * Scenes: a device accelerator's (no cut-outs, no single-sided
 * materials), instances included.
 *
 * Run on a CPU, a program gives what the integrator's li gives, bit for
 * bit (tests/plugins/device checks it); on a GPU, hits are still the
 * CPU's (tests/cuda), while cosf and sinf may round differently. */
#ifndef RTK_DEVICE_PROGRAMS_H
#define RTK_DEVICE_PROGRAMS_H

#include "ao_estimator.h"
#include "headlight_estimator.h"
#define RTK_PATH_BSDF_INLINE
#include "path_estimator.h"

/* The kernel's shared code: its folder must be on the include path. */
#include "accel/accel.h"
#include "accel/device_tree.h"
#include "render/sample.h"
#include "scene/light_sample.h"
#include "scene/material_bsdf.h"
#include "scene/surface_geom.h"
#include "scene/texture_sample.h"

#include <rtk/integrator.h>

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef enum rtk_program_kind {
    RTK_PROGRAM_NONE = 0,
    RTK_PROGRAM_AO = 1,
    RTK_PROGRAM_HEADLIGHT = 2,
    RTK_PROGRAM_PATH = 3
} rtk_program_kind;

/* A program checked and unpacked from its description. */
typedef struct rtk_program {
    rtk_program_kind kind;
    int rays;       /* ao */
    float distance; /* ao */
    int albedo;     /* ao */
    float ambient;  /* headlight */
    rtk_path_params path;
} rtk_program;

/* What a program reads of one tree's triangles (the scene's own or a
 * placed mesh's): their corners (the flat tree's, in leaf order), each
 * triangle's leaf slot, the corners' normals, the materials, vertex
 * colours, which emitter each triangle is, texture coordinates and
 * textures (rtk_device_tree's). */
typedef struct rtk_program_mesh {
    const float *corners;          /* 9 floats a leaf slot */
    const uint32_t *slot_of;       /* triangle id -> leaf slot */
    const float *normals;          /* 9 floats a triangle id; NULL: none */
    const uint32_t *tri_materials; /* NULL: materials not read */
    const rtk_material *materials;
    uint32_t material_count;
    const float *colors;           /* 12 floats a triangle id; NULL: none */
    const uint32_t *light_of;      /* triangle id -> its emitter (NULL: none emit) */
    const float *uvs, *uvs1;       /* 6 floats a triangle id; uvs NULL: no textures read */
    const rtk_device_texture *textures;
    uint32_t texture_count;
    const rtk_texture_level *const *levels; /* each texture's MIP levels (NULL: level 0 alone) */
} rtk_program_mesh;

/* What a program reads: the scene's trees, its own triangles' and each
 * placed mesh's, the instances' frames, the lights and the default
 * material's colour. Pointers are the device's or the host's alike. */
typedef struct rtk_program_scene {
    rtk_flat_scene flat;
    rtk_program_mesh own;
    const rtk_program_mesh *meshes;  /* one a placed mesh */
    const rtk_device_frame *frames;  /* one an instance */
    const rtk_lights *lights;        /* NULL: none sampled */
    const rtk_punctual_light *punctual;
    uint32_t punctual_count;
    rtk_rgb albedo;
} rtk_program_scene;

/* The program d describes, or kind RTK_PROGRAM_NONE when it is not one
 * of the list above (or its parameters are out of range). */
static inline rtk_program rtk_program_of(const rtk_device_program *d)
{
    rtk_program p;
    memset(&p, 0, sizeof p);
    const float *v = d->params;
    if (strncmp(d->name, "ao", sizeof d->name) == 0 && v[0] >= 1.0f && v[0] <= 4096.0f && v[1] > 0.0f &&
        (v[2] == 0.0f || v[2] == 1.0f)) {
        p.kind = RTK_PROGRAM_AO;
        p.rays = (int)v[0];
        p.distance = v[1];
        p.albedo = v[2] == 1.0f;
    } else if (strncmp(d->name, "headlight", sizeof d->name) == 0 && v[0] >= 0.0f && v[0] <= 1.0f) {
        p.kind = RTK_PROGRAM_HEADLIGHT;
        p.ambient = v[0];
    } else if (strncmp(d->name, "path", sizeof d->name) == 0 && v[0] >= 0.0f && v[0] <= 1024.0f &&
               v[0] == floorf(v[0]) && v[1] >= 1.0f && v[1] <= 1024.0f && v[1] == floorf(v[1]) && v[2] >= 0.0f) {
        p.kind = RTK_PROGRAM_PATH;
        p.path.max_depth = (int)v[0];
        p.path.rr_depth = (int)v[1];
        p.path.clamp = v[2];
    }
    return p;
}

/* The leaf slot of every triangle of tree (slot_of has tree->slot_count
 * entries), for rtk_program_mesh.slot_of. */
static inline void rtk_program_slots(const rtk_device_tree *tree, uint32_t *slot_of)
{
    for (uint32_t slot = 0; slot < tree->slot_count; slot++)
        slot_of[tree->prim_ids[slot]] = slot;
}

/* The emitter of each triangle of tree (tree->slot_count of them), NULL
 * when none of them emits. */
static inline const uint32_t *rtk_program_light_of(const rtk_device_tree *tree)
{
    return tree->lights && tree->lights->count && tree->slot_count ? tree->lights->light_of : NULL;
}

/* What programs read of one tree, its corners and slot_of given (pointers
 * of the same side as the tree's arrays). */
static inline rtk_program_mesh rtk_program_mesh_of(const rtk_device_tree *tree, const float *corners,
                                                   const uint32_t *slot_of)
{
    rtk_program_mesh m;
    memset(&m, 0, sizeof m);
    m.corners = corners;
    m.slot_of = slot_of;
    m.normals = tree->normals;
    m.tri_materials = tree->tri_materials;
    m.materials = tree->materials;
    m.material_count = tree->material_count;
    m.colors = tree->colors;
    m.light_of = rtk_program_light_of(tree);
    if (tree->textures && tree->uvs) {
        m.uvs = tree->uvs, m.uvs1 = tree->uvs1;
        m.textures = tree->textures;
        m.texture_count = tree->texture_count;
        m.levels = tree->texture_levels;
    }
    return m;
}

/* What programs read of tree, flat its traversal's view (host pointers):
 * the placed meshes' table and every tree's slots in *block, made here
 * [caller frees]; albedo left for each batch. 0, or -1 out of memory. */
static inline int rtk_program_scene_of(const rtk_device_tree *tree, const rtk_flat_scene *flat, void **block,
                                       rtk_program_scene *out)
{
    size_t slots = tree->slot_count;
    for (uint32_t i = 0; i < tree->mesh_count; i++)
        slots += tree->meshes[i].slot_count;
    const size_t table = sizeof(rtk_program_mesh) * tree->mesh_count;
    if (!(*block = malloc(table + sizeof(uint32_t) * slots + 1)))
        return -1;
    rtk_program_mesh *meshes = (rtk_program_mesh *)*block;
    uint32_t *slot_of = (uint32_t *)(void *)((char *)*block + table);
    memset(out, 0, sizeof *out);
    out->flat = *flat;
    rtk_program_slots(tree, slot_of);
    out->own = rtk_program_mesh_of(tree, flat->own.corners, slot_of);
    slot_of += tree->slot_count;
    for (uint32_t i = 0; i < tree->mesh_count; i++) {
        rtk_program_slots(&tree->meshes[i], slot_of);
        meshes[i] = rtk_program_mesh_of(&tree->meshes[i], flat->meshes[i].corners, slot_of);
        slot_of += tree->meshes[i].slot_count;
    }
    out->meshes = meshes;
    out->frames = tree->frames;
    out->lights = tree->lights;
    out->punctual = tree->punctual;
    out->punctual_count = tree->punctual_count;
    return 0;
}

/* Rays a sample traced and how many of them were invalid (what rtk_trace
 * and rtk_occluded count). */
typedef struct rtk_program_count {
    uint32_t traced, invalid;
} rtk_program_count;

/* rtk_trace: 1 with the closest hit of ray, 0 when it misses (or is
 * invalid, counted). */
RTK_HD static inline int rtk_program_trace(const rtk_program_scene *s, const rtk_ray *ray, rtk_program_count *count,
                                           rtk_hit *hit)
{
    count->traced++;
    if (!rtk_ray_usable(ray)) {
        count->invalid++;
        return 0;
    }
    rtk_flat_scene_closest(&s->flat, ray, hit);
    return hit->prim != RTK_INVALID_ID;
}

/* rtk_occluded: an invalid ray (counted) is not blocked. */
RTK_HD static inline int rtk_program_occluded(const rtk_program_scene *s, const rtk_ray *ray, rtk_program_count *count)
{
    count->traced++;
    if (!rtk_ray_usable(ray)) {
        count->invalid++;
        return 0;
    }
    return rtk_flat_scene_any(&s->flat, ray);
}

/* The triangles instance inst places (RTK_INVALID_ID: the scene's own). */
RTK_HD static inline const rtk_program_mesh *rtk_program_mesh_at(const rtk_program_scene *s, uint32_t inst)
{
    return inst == RTK_INVALID_ID ? &s->own : &s->meshes[s->flat.top.instances[inst].mesh];
}

/* Triangle prim's corners in its tree's space. */
RTK_HD static inline void rtk_program_corners(const rtk_program_mesh *m, uint32_t prim, rtk_vec3 *a, rtk_vec3 *b,
                                              rtk_vec3 *c)
{
    const float *v = m->corners + 9 * (size_t)m->slot_of[prim];
    *a = rtk_vec3_make(v[0], v[1], v[2]);
    *b = rtk_vec3_make(v[3], v[4], v[5]);
    *c = rtk_vec3_make(v[6], v[7], v[8]);
}

/* p placed by frame f, rounded to float (rtk_instance_triangle's way). */
RTK_HD static inline rtk_vec3 rtk_program_place(const rtk_device_frame *f, rtk_vec3 p)
{
    double w[3];
    rtk_affine_point(f->to_world, p.x, p.y, p.z, w);
    return rtk_vec3_make((float)w[0], (float)w[1], (float)w[2]);
}

/* Triangle prim of instance inst (RTK_INVALID_ID: the scene's own) in
 * world space, as rtk_scene_triangle and rtk_instance_triangle give it. */
RTK_HD static inline void rtk_program_world_corners(const rtk_program_scene *s, uint32_t inst, uint32_t prim,
                                                    rtk_vec3 *a, rtk_vec3 *b, rtk_vec3 *c)
{
    rtk_program_corners(rtk_program_mesh_at(s, inst), prim, a, b, c);
    if (inst != RTK_INVALID_ID) {
        const rtk_device_frame *f = &s->frames[inst];
        *a = rtk_program_place(f, *a), *b = rtk_program_place(f, *b), *c = rtk_program_place(f, *c);
    }
}

/* Triangle prim's material, NULL for the default one. */
RTK_HD static inline const rtk_material *rtk_program_material(const rtk_program_mesh *m, uint32_t prim)
{
    if (!m->tri_materials || !m->materials)
        return NULL;
    const uint32_t id = m->tri_materials[prim];
    return id < m->material_count ? &m->materials[id] : NULL;
}

/* A hit's surface as rtk_surface_at gives it (with textures read at
 * level 0), and where its factor maps are read. */
typedef struct rtk_program_surface {
    rtk_vec3 p, ng, ns;
    int front;
    rtk_rgb base, emission;
    float alpha, ior;
    const rtk_material *m;        /* NULL: the default material */
    const rtk_program_mesh *mesh; /* the hit triangle's tree */
    uint32_t prim;
    float u, v;
} rtk_program_surface;

/* Texture tex of mesh m as a material's slot reads it (scene.c's usable):
 * NULL when m reads no textures, or tex is none or was never decoded. */
RTK_HD static inline const rtk_device_texture *rtk_program_texture(const rtk_program_mesh *m, int tex)
{
    return m->uvs && tex >= 0 && (uint32_t)tex < m->texture_count && m->textures[tex].decoded ? &m->textures[tex]
                                                                                             : NULL;
}

/* rtk_tex_map_uv: map's texture coordinates on triangle prim of m at (u, v). */
RTK_HD static inline rtk_vec2 rtk_program_uv(const rtk_program_mesh *m, const rtk_tex_map *map, uint32_t prim, float u,
                                             float v)
{
    const float *uvs = map->set == 1 && m->uvs1 ? m->uvs1 : m->uvs;
    return rtk_corner_uv(uvs + 6 * (size_t)prim, map->transformed, map->m, u, v);
}

/* Texture t (one of m's) through wrap and map at (u, v) of triangle
 * prim of m; when t is trilinear and fp (each uv set's footprint, NULL
 * where not measured) has map's, at its level of detail through map,
 * else at level 0 (scene.c's lookup). */
RTK_HD static inline void rtk_program_lookup(const rtk_program_mesh *m, const rtk_device_texture *t, rtk_tex_wrap wrap,
                                             const rtk_tex_map *map, uint32_t prim, float u, float v,
                                             const rtk_uv_footprint *const *fp, float texel[4])
{
    rtk_vec2 uv = rtk_program_uv(m, map, prim, u, v);
    const rtk_uv_footprint *set = fp ? fp[map->set == 1 && m->uvs1 ? 1 : 0] : NULL;
    float lod = 0.0f;
    if (set && t->filter == RTK_TEX_TRILINEAR) {
        const rtk_uv_footprint mapped = rtk_uv_footprint_mapped(set, map->transformed, map->m);
        lod = rtk_texture_lod_at(t->width, t->height, &mapped);
    }
    rtk_device_texture_sample(t, m->levels ? m->levels[t - m->textures] : NULL, wrap, uv.x, uv.y, lod, texel);
}

/* Whether two slots read the same texels: the same wrap and uv map. */
RTK_HD static inline int rtk_program_same_use(rtk_tex_wrap a, rtk_tex_wrap b, const rtk_tex_map *ma,
                                              const rtk_tex_map *mb)
{
    int same = a.s == b.s && a.t == b.t && ma->set == mb->set && ma->transformed == mb->transformed;
    for (int k = 0; k < 6; k++)
        same = same && ma->m[k] == mb->m[k];
    return same;
}

/* rtk_apply_normal_map on triangle prim of m (material mat) at (u, v):
 * bends *ns (on the authored side) by the normal map; 1 when it did. */
RTK_HD static inline int rtk_program_normal_map(const rtk_program_mesh *m, const rtk_material *mat, uint32_t prim,
                                                float u, float v, rtk_vec3 *ns)
{
    if (!m->uvs || mat->normal_tex < 0 || (uint32_t)mat->normal_tex >= m->texture_count)
        return 0;
    const rtk_device_texture *tex = &m->textures[mat->normal_tex];
    if (!tex->normal_map)
        return 0;
    float t[6];
    for (int k = 0; k < 3; k++) {
        rtk_vec2 c = rtk_program_uv(m, &mat->normal_uv, prim, k == 1 ? 1.0f : 0.0f, k == 2 ? 1.0f : 0.0f);
        t[2 * k] = c.x, t[2 * k + 1] = c.y;
    }
    const rtk_tex_wrap repeat = {RTK_WRAP_REPEAT, RTK_WRAP_REPEAT};
    float texel[4];
    rtk_program_lookup(m, tex, repeat, &mat->normal_uv, prim, u, v, NULL, texel);
    rtk_vec3 p0, p1, p2;
    rtk_program_corners(m, prim, &p0, &p1, &p2);
    return rtk_bend_normal(p0, p1, p2, t, texel, ns);
}

/* The textures of material mat on out (scene.c's surface): base colour,
 * alpha, emission (at footprints fp, rtk_program_lookup's), then the
 * normal map. */
RTK_HD static inline void rtk_program_textures(const rtk_program_mesh *m, const rtk_material *mat, uint32_t prim,
                                               float u, float v, const rtk_uv_footprint *const *fp,
                                               rtk_program_surface *out)
{
    float texel[4];
    int alpha_done = 0;
    const rtk_device_texture *t = rtk_program_texture(m, mat->base_tex);
    if (t) {
        rtk_program_lookup(m, t, mat->base_wrap, &mat->base_uv, prim, u, v, fp, texel);
        out->base = rtk_rgb_mul(out->base, rtk_rgb_make(texel[0], texel[1], texel[2]));
        if (mat->alpha_tex == mat->base_tex &&
            rtk_program_same_use(mat->alpha_wrap, mat->base_wrap, &mat->alpha_uv, &mat->base_uv)) {
            out->alpha *= texel[3];
            alpha_done = 1;
        }
    }
    if (!alpha_done && (t = rtk_program_texture(m, mat->alpha_tex))) {
        rtk_program_lookup(m, t, mat->alpha_wrap, &mat->alpha_uv, prim, u, v, fp, texel);
        out->alpha *= mat->alpha_tex == mat->base_tex || t->has_alpha ? texel[3] : texel[0];
    }
    if ((t = rtk_program_texture(m, mat->emission_tex))) {
        rtk_program_lookup(m, t, mat->emission_wrap, &mat->emission_uv, prim, u, v, fp, texel);
        out->emission = rtk_rgb_mul(out->emission, rtk_rgb_make(texel[0], texel[1], texel[2]));
    }
    rtk_vec3 n = out->front ? out->ns : rtk_vec3_neg(out->ns);
    if (rtk_program_normal_map(m, mat, prim, u, v, &n)) {
        if (!out->front)
            n = rtk_vec3_neg(n);
        if (rtk_vec3_dot(n, out->ng) > 0.0f)
            out->ns = n;
    }
}

/* material_bsdf.h's map reader over a program surface (material.c's
 * read_map): factor map k of m at the surface's hit, at level 0. */
RTK_HD static inline int rtk_program_read_map(const void *ctx, const rtk_material *m, rtk_material_map k,
                                              float texel[4])
{
    const rtk_program_surface *sf = (const rtk_program_surface *)ctx;
    const rtk_tex_slot *slot = &m->maps[k];
    const rtk_device_texture *t = rtk_program_texture(sf->mesh, slot->tex);
    if (!t)
        return 0;
    rtk_program_lookup(sf->mesh, t, slot->wrap, &slot->uv, sf->prim, sf->u, sf->v, NULL, texel);
    return 1;
}

/* Whether material mat's base colour, alpha or emission reads a
 * trilinear texture of m (scene.c's surface then measures footprints). */
RTK_HD static inline int rtk_program_reads_mip(const rtk_program_mesh *m, const rtk_material *mat)
{
    const int slots[3] = {mat->base_tex, mat->alpha_tex, mat->emission_tex};
    int mip = 0;
    for (int k = 0; k < 3; k++) {
        const rtk_device_texture *t = rtk_program_texture(m, slots[k]);
        mip |= t && t->filter == RTK_TEX_TRILINEAR;
    }
    return mip;
}

/* The surface of triangle prim of mesh m at barycentrics (u, v), seen
 * along dir, in m's space; diff (NULL: none) the ray's differentials
 * there, for the textures' footprints. */
RTK_HD static inline void rtk_program_mesh_surface(const rtk_program_scene *s, const rtk_program_mesh *m, uint32_t prim,
                                                   float u, float v, rtk_vec3 dir, const rtk_ray_differential *diff,
                                                   rtk_program_surface *out)
{
    rtk_vec3 p0, p1, p2;
    rtk_program_corners(m, prim, &p0, &p1, &p2);
    rtk_surface_geometry(p0, p1, p2, m->normals ? m->normals + 9 * (size_t)prim : NULL, u, v, dir, &out->p, &out->ng,
                         &out->ns, &out->front);
    out->m = rtk_program_material(m, prim);
    out->mesh = m;
    out->prim = prim;
    out->u = u, out->v = v;
    out->base = s->albedo;
    out->emission = rtk_rgb_make(0.0f, 0.0f, 0.0f);
    out->alpha = 1.0f;
    out->ior = 1.5f;
    if (out->m) {
        out->base = out->m->base_color;
        out->emission = out->m->emission;
        out->alpha = out->m->alpha;
        out->ior = out->m->ior;
    }
    if (m->tri_materials && m->colors) {
        const float *colors = m->colors + 12 * (size_t)prim;
        float vc[4];
        rtk_corner_colors(colors, u, v, vc);
        out->base = rtk_surface_base_color(out->base, colors, u, v);
        out->alpha *= vc[3];
    }
    if (out->m && m->uvs) {
        rtk_uv_footprint footprint[2];
        const rtk_uv_footprint *fp[2] = {NULL, NULL};
        if (diff && rtk_program_reads_mip(m, out->m)) {
            const size_t at = 6 * (size_t)prim;
            if (rtk_uv_footprint_at(m->uvs + at, p0, p1, p2, out->p, out->ng, diff, &footprint[0]))
                fp[0] = &footprint[0];
            if (m->uvs1 && rtk_uv_footprint_at(m->uvs1 + at, p0, p1, p2, out->p, out->ng, diff, &footprint[1]))
                fp[1] = &footprint[1];
        }
        rtk_program_textures(m, out->m, prim, u, v, fp, out);
    }
}

/* A normal through frame f: the inverse transpose (to_object's rows as
 * columns), normalised; rtk_instance_surface's way. */
RTK_HD static inline rtk_vec3 rtk_program_world_normal(const double *to_object, rtk_vec3 n)
{
    double w[3];
    for (int k = 0; k < 3; k++)
        w[k] = to_object[k] * n.x + to_object[4 + k] * n.y + to_object[8 + k] * n.z;
    return rtk_vec3_normalize(rtk_vec3_make((float)w[0], (float)w[1], (float)w[2]));
}

/* A hit's surface as rtk_surface_at_footprint gives it for differentials
 * diff (NULL: rtk_surface_at's): an instance's in its mesh's space (the
 * ray's direction and the differential rays taken there), then placed in
 * the world. */
RTK_HD static inline void rtk_program_surface_at(const rtk_program_scene *s, const rtk_ray *ray,
                                                 const rtk_ray_differential *diff, const rtk_hit *hit,
                                                 rtk_program_surface *out)
{
    if (hit->inst == RTK_INVALID_ID) {
        rtk_program_mesh_surface(s, &s->own, hit->prim, hit->u, hit->v, ray->dir, diff, out);
        return;
    }
    const rtk_device_instance *in = &s->flat.top.instances[hit->inst];
    double d[3];
    rtk_affine_vector(in->to_object, ray->dir.x, ray->dir.y, ray->dir.z, d);
    rtk_ray_differential local;
    int local_diff = 0;
    if (diff) {
        rtk_ray rx, ry, lx, ly;
        rx.org = diff->rx_org, rx.dir = diff->rx_dir, ry.org = diff->ry_org, ry.dir = diff->ry_dir;
        rx.tmin = ry.tmin = 0.0f;
        rx.tmax = ry.tmax = INFINITY;
        local_diff = rtk_local_ray(in->to_object, &rx, &lx) && rtk_local_ray(in->to_object, &ry, &ly);
        if (local_diff)
            local.rx_org = lx.org, local.rx_dir = lx.dir, local.ry_org = ly.org, local.ry_dir = ly.dir;
    }
    rtk_program_mesh_surface(s, &s->meshes[in->mesh], hit->prim, hit->u, hit->v,
                             rtk_vec3_make((float)d[0], (float)d[1], (float)d[2]), local_diff ? &local : NULL, out);
    out->p = rtk_program_place(&s->frames[hit->inst], out->p);
    out->ng = rtk_program_world_normal(in->to_object, out->ng);
    out->ns = rtk_program_world_normal(in->to_object, out->ns);
}

/* A camera ray's first hit as rtk_trace and rtk_surface_at_footprint
 * give it (diff its differentials, NULL: none): 0 when it misses (or is
 * invalid, counted); else its surface, with out's AOVs set. */
RTK_HD static inline int rtk_program_camera_hit(const rtk_program_scene *s, const rtk_ray *ray,
                                                const rtk_ray_differential *diff, rtk_li_result *out,
                                                rtk_program_count *count, rtk_program_surface *h)
{
    rtk_hit hit;
    if (!rtk_program_trace(s, ray, count, &hit))
        return 0;
    rtk_program_surface_at(s, ray, diff, &hit, h);
    out->albedo = h->base;
    out->normal = h->ns;
    out->depth = hit.t * rtk_vec3_length(ray->dir);
    return 1;
}

/* ao's li (plugins/integrators/ao.c) for camera ray ray (differentials
 * diff, read for albedo only), drawing from pos. */
RTK_HD static inline void rtk_program_ao(const rtk_program *p, const rtk_program_scene *s, const rtk_sample_gen *g,
                                         rtk_sample_pos pos, const rtk_ray *ray, const rtk_ray_differential *diff,
                                         rtk_li_result *out, rtk_program_count *count)
{
    rtk_program_surface h;
    if (!rtk_program_camera_hit(s, ray, p->albedo ? diff : NULL, out, count, &h))
        return;
    rtk_vec3 b1, b2;
    rtk_ao_basis(h.ns, &b1, &b2);
    const rtk_vec3 org = rtk_offset_point(h.p, h.ng);
    int open = 0;
    for (int i = 0; i < p->rays; i++) {
        rtk_ray r;
        if (!rtk_ao_ray(rtk_sample_next_2d(g, &pos), org, h.ng, h.ns, b1, b2, p->distance, &r))
            continue;
        open += !rtk_program_occluded(s, &r, count);
    }
    out->radiance = rtk_ao_value(open, p->rays, p->albedo, h.base);
}

/* headlight's li (plugins/integrators/headlight.c) for camera ray ray
 * (differentials diff). */
RTK_HD static inline void rtk_program_headlight(const rtk_program *p, const rtk_program_scene *s, const rtk_ray *ray,
                                                const rtk_ray_differential *diff, rtk_li_result *out,
                                                rtk_program_count *count)
{
    rtk_program_surface h;
    if (rtk_program_camera_hit(s, ray, diff, out, count, &h))
        out->radiance = rtk_headlight_value(h.base, h.ns, ray->dir, p->ambient);
}

/* rtk_emitter_fns over a program scene: an emitter's corners and its
 * material's emission times its emission texture (lights.c's). */
RTK_HD static inline void rtk_program_emitter_corners(const void *ctx, uint32_t light, rtk_vec3 *a, rtk_vec3 *b,
                                                      rtk_vec3 *c, int *mirrored)
{
    const rtk_program_scene *s = (const rtk_program_scene *)ctx;
    const uint32_t inst = s->lights->insts[light];
    rtk_program_world_corners(s, inst, s->lights->prims[light], a, b, c);
    *mirrored = inst != RTK_INVALID_ID && s->frames[inst].mirrored;
}

RTK_HD static inline rtk_rgb rtk_program_emitter_emission(const void *ctx, uint32_t light, float b1, float b2)
{
    const rtk_program_scene *s = (const rtk_program_scene *)ctx;
    const rtk_program_mesh *mesh = rtk_program_mesh_at(s, s->lights->insts[light]);
    const uint32_t prim = s->lights->prims[light];
    const rtk_material *m = rtk_program_material(mesh, prim);
    if (!m)
        return rtk_rgb_make(0.0f, 0.0f, 0.0f);
    const rtk_device_texture *t = rtk_program_texture(mesh, m->emission_tex);
    if (!t)
        return m->emission;
    const rtk_tex_wrap repeat = {RTK_WRAP_REPEAT, RTK_WRAP_REPEAT};
    float texel[4];
    rtk_program_lookup(mesh, t, repeat, &m->emission_uv, prim, b1, b2, NULL, texel);
    return rtk_rgb_mul(m->emission, rtk_rgb_make(texel[0], texel[1], texel[2]));
}

/* rtk_sample_incident_light. */
RTK_HD static inline int rtk_program_sample_light(const rtk_program_scene *s, rtk_vec3 p, rtk_vec3 ng, float u_pick,
                                                  rtk_vec2 u, rtk_light_incident *out)
{
    const rtk_lights *l = s->lights;
    if (!l || l->slot_count == 0)
        return 0;
    const rtk_emitter_fns fns = {rtk_program_emitter_corners, rtk_program_emitter_emission};
    return rtk_lights_incident(l, s->punctual, s->punctual_count, &fns, s, p, ng, u_pick, u, out);
}

/* rtk_incident_light_pdf of ray, which hit an emitter (hit) or left the
 * scene (hit NULL). */
RTK_HD static inline float rtk_program_light_pdf(const rtk_program_scene *s, const rtk_ray *ray, const rtk_hit *hit)
{
    const rtk_lights *l = s->lights;
    if (!l || l->slot_count == 0)
        return 0.0f;
    if (!hit) {
        float pick = l->slot_pick[l->slot_count - 1];
        return pick > 0.0f && l->environment ? rtk_env_pdf(l->environment, ray->dir) * pick : 0.0f;
    }
    const rtk_program_mesh *m = rtk_program_mesh_at(s, hit->inst);
    if (l->count == 0 || !m->light_of)
        return 0.0f;
    uint32_t light = m->light_of[hit->prim];
    if (light == RTK_INVALID_ID)
        return 0.0f;
    if (hit->inst != RTK_INVALID_ID)
        light += l->inst_first[hit->inst];
    const float pdf_area = l->pick[light] / l->area[light];
    if (!(pdf_area > 0.0f))
        return 0.0f;
    rtk_vec3 a, b, c;
    rtk_program_world_corners(s, hit->inst, hit->prim, &a, &b, &c);
    rtk_vec3 n = rtk_vec3_normalize(rtk_vec3_cross(rtk_vec3_sub(b, a), rtk_vec3_sub(c, a)));
    if (hit->inst != RTK_INVALID_ID && s->frames[hit->inst].mirrored)
        n = rtk_vec3_neg(n);
    return rtk_emitter_solid_pdf(n, ray, hit->t, pdf_area, l->slot_pick[0]);
}

/* rtk_scene_environment. */
RTK_HD static inline rtk_rgb rtk_program_environment(const rtk_program_scene *s, rtk_vec3 dir)
{
    const rtk_lights *l = s->lights;
    return l && l->environment ? rtk_env_radiance(l->environment, dir) : rtk_rgb_make(0.0f, 0.0f, 0.0f);
}

/* One camera sample's path between the steps of path's bounce: the ray
 * it extends next, and the shadow ray its last vertex left pending. */
typedef struct rtk_path_walk {
    rtk_path_state ps;
    rtk_rgb L;
    rtk_ray ray;        /* extended next, while more */
    rtk_sample_pos pos; /* the sample's stream */
    rtk_ray shadow;     /* tested next, when shadowed */
    rtk_rgb nee;        /* what the shadow ray adds when nothing blocks it */
    int shadowed, more;
} rtk_path_walk;

/* The walk of camera ray camera, drawing from pos. */
RTK_HD static inline void rtk_path_walk_start(rtk_path_walk *w, const rtk_ray *camera, rtk_sample_pos pos)
{
    w->ps = rtk_path_start(camera->org);
    w->L = rtk_rgb_make(0.0f, 0.0f, 0.0f);
    w->ray = *camera;
    w->pos = pos;
    w->nee = w->L;
    w->shadowed = 0;
    w->more = 1;
}

/* One vertex of path's li: w's ray found hit (NULL: it left the scene).
 * Adds what it found, leaves the vertex's shadow ray pending (shadowed)
 * and the next ray (more; the depth counted on). diff: the camera ray's
 * differentials (NULL: none), read at the first vertex. */
RTK_HD static inline void rtk_path_walk_shade(const rtk_program *p, const rtk_program_scene *s,
                                              const rtk_sample_gen *g, rtk_path_walk *w, const rtk_hit *hit,
                                              const rtk_ray_differential *diff, rtk_li_result *out)
{
    const rtk_path_params *pt = &p->path;
    rtk_path_state *ps = &w->ps;
    w->shadowed = w->more = 0;
    rtk_sample_seek_pos(g, &w->pos, (uint32_t)ps->depth * RTK_PATH_DIMS_PER_BOUNCE);
    if (!hit) {
        rtk_rgb env = rtk_program_environment(s, w->ray.dir);
        if (!rtk_path_is_black(env)) {
            float wt = ps->delta ? 1.0f : rtk_path_found_weight(ps, rtk_program_light_pdf(s, &w->ray, NULL));
            w->L = rtk_rgb_add(w->L, rtk_path_weighted(pt, ps->beta, rtk_rgb_scale(env, wt)));
        }
        return;
    }
    rtk_program_surface sf;
    rtk_program_surface_at(s, &w->ray, ps->depth == 0 ? diff : NULL, hit, &sf);
    if (ps->depth == 0) {
        out->albedo = sf.base;
        out->normal = sf.ns;
        out->depth = hit->t * rtk_vec3_length(w->ray.dir);
    }
    if (sf.front && !rtk_path_is_black(sf.emission)) {
        float wt = ps->delta ? 1.0f : rtk_path_found_weight(ps, rtk_program_light_pdf(s, &w->ray, hit));
        w->L = rtk_rgb_add(w->L, rtk_path_weighted(pt, ps->beta, rtk_rgb_scale(sf.emission, wt)));
    }
    if (ps->depth >= pt->max_depth)
        return;
    rtk_bsdf bsdf;
    rtk_material_bsdf(sf.m, sf.base, sf.alpha, sf.ior, rtk_program_read_map, &sf, &bsdf);
    if (bsdf.count == 0)
        return;
    rtk_path_vertex v = rtk_path_vertex_at(sf.ng, sf.ns, sf.front, &bsdf, w->ray.dir);
    if (rtk_lobes_flags(&bsdf) & (RTK_BSDF_DIFFUSE | RTK_BSDF_GLOSSY)) {
        float u_pick = rtk_sample_next_1d(g, &w->pos);
        rtk_vec2 u = rtk_sample_next_2d(g, &w->pos);
        rtk_light_incident li;
        rtk_rgb c;
        if (rtk_program_sample_light(s, sf.p, sf.ng, u_pick, u, &li) && rtk_path_light(&v, &bsdf, &li, &c)) {
            w->nee = rtk_path_weighted(pt, ps->beta, c);
            w->shadow = li.shadow;
            w->shadowed = 1;
        }
    }
    float u_lobe = rtk_sample_next_1d(g, &w->pos);
    rtk_vec2 u = rtk_sample_next_2d(g, &w->pos);
    rtk_bsdf_sample_out bs;
    rtk_vec3 side;
    float m;
    w->more = rtk_lobes_sample(&bsdf, v.wo, u_lobe, u, &bs) && bs.pdf > 0.0f &&
              rtk_path_scatter(ps, &v, sf.p, sf.ng, &bs, &w->ray, &side) &&
              !(rtk_path_roulette_due(pt, ps, &m) && !rtk_path_survives(ps, m, rtk_sample_next_1d(g, &w->pos)));
    if (w->more) {
        w->ray.org = rtk_offset_point(sf.p, side);
        ps->depth++;
    }
}

/* The pending shadow ray of w was blocked (occluded 1) or not. */
RTK_HD static inline void rtk_path_walk_shadow(rtk_path_walk *w, int occluded)
{
    if (!occluded)
        w->L = rtk_rgb_add(w->L, w->nee);
    w->shadowed = 0;
}

/* path's li (plugins/integrators/path.c) for camera ray camera
 * (differentials diff), drawing from pos, as one loop (a megakernel's):
 * each vertex's hit, its shading, then its shadow ray. A wavefront runs
 * the same three steps on many walks at once. */
RTK_HD static inline void rtk_program_path(const rtk_program *p, const rtk_program_scene *s, const rtk_sample_gen *g,
                                           rtk_sample_pos pos, const rtk_ray *camera, const rtk_ray_differential *diff,
                                           rtk_li_result *out, rtk_program_count *count)
{
    rtk_path_walk w;
    rtk_path_walk_start(&w, camera, pos);
    while (w.more) {
        rtk_hit hit;
        const int found = rtk_program_trace(s, &w.ray, count, &hit);
        rtk_path_walk_shade(p, s, g, &w, found ? &hit : NULL, diff, out);
        if (w.shadowed)
            rtk_path_walk_shadow(&w, rtk_program_occluded(s, &w.shadow, count));
    }
    out->radiance = w.L;
}

/* out as the kernel pre-fills li's (all 0, depth infinite), no rays counted. */
RTK_HD static inline void rtk_program_prefill(rtk_li_result *out, rtk_program_count *count)
{
    out->radiance = out->albedo = rtk_rgb_make(0.0f, 0.0f, 0.0f);
    out->normal = rtk_vec3_make(0.0f, 0.0f, 0.0f);
    out->depth = INFINITY;
    count->traced = count->invalid = 0;
}

/* Program p on one sample (camera ray ray, its differentials diff or
 * NULL): out pre-filled, then as the program sets it. */
RTK_HD static inline void rtk_program_run(const rtk_program *p, const rtk_program_scene *s, const rtk_sample_gen *g,
                                          const rtk_sample_pos *pos, const rtk_ray *ray,
                                          const rtk_ray_differential *diff, rtk_li_result *out,
                                          rtk_program_count *count)
{
    rtk_program_prefill(out, count);
    if (p->kind == RTK_PROGRAM_AO)
        rtk_program_ao(p, s, g, *pos, ray, diff, out, count);
    else if (p->kind == RTK_PROGRAM_HEADLIGHT)
        rtk_program_headlight(p, s, ray, diff, out, count);
    else if (p->kind == RTK_PROGRAM_PATH)
        rtk_program_path(p, s, g, *pos, ray, diff, out, count);
}

/* path (p) on n samples as a wavefront, on the host: every live walk's
 * hit and shading, then every pending shadow ray, until no walk goes on:
 * the steps a GPU's wavefront runs as kernels, in their order for each
 * walk, so the results equal rtk_program_run's. diffs: the rays'
 * differentials, or NULL. walks and live have room for n. */
static inline void rtk_program_path_wavefront(const rtk_program *p, const rtk_program_scene *s,
                                              const rtk_sample_gen *g, uint32_t n, const rtk_ray *rays,
                                              const rtk_ray_differential *diffs, const rtk_sample_pos *pos,
                                              rtk_li_result *out, rtk_program_count *counts, rtk_path_walk *walks,
                                              uint32_t *live)
{
    uint32_t alive = 0;
    for (uint32_t i = 0; i < n; i++) {
        rtk_program_prefill(&out[i], &counts[i]);
        rtk_path_walk_start(&walks[i], &rays[i], pos[i]);
        live[alive++] = i;
    }
    while (alive) {
        for (uint32_t k = 0; k < alive; k++) {
            const uint32_t i = live[k];
            rtk_hit hit;
            const int found = rtk_program_trace(s, &walks[i].ray, &counts[i], &hit);
            rtk_path_walk_shade(p, s, g, &walks[i], found ? &hit : NULL, diffs ? &diffs[i] : NULL, &out[i]);
        }
        uint32_t next = 0;
        for (uint32_t k = 0; k < alive; k++) {
            const uint32_t i = live[k];
            if (walks[i].shadowed)
                rtk_path_walk_shadow(&walks[i], rtk_program_occluded(s, &walks[i].shadow, &counts[i]));
            if (walks[i].more)
                live[next++] = i;
        }
        alive = next;
    }
    for (uint32_t i = 0; i < n; i++)
        out[i].radiance = walks[i].L;
}

#endif
