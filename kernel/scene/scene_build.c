/* Building a scene: growable arrays filled by the format loaders, the
 * finishing pass (validation, degenerate triangles, normals, bounds,
 * texture decoding) and the loader dispatch by file extension.
 * Rules for loaders: call only the rtk_scene_add_* functions; they keep
 * just what scene->needs asks for, so a loader may offer everything. */
#include "scene.h"
#include "../accel/accel.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* The largest count an index array may reach: RTK_INVALID_ID is reserved. */
#define MAX_COUNT (RTK_INVALID_ID - 1u)

static int keeps_normals(const rtk_scene *scene) { return (scene->needs & RTK_NEED_NORMALS) != 0; }
static int keeps_uvs(const rtk_scene *scene) { return (scene->needs & RTK_NEED_UVS) != 0; }
static int keeps_textures(const rtk_scene *scene) { return (scene->needs & RTK_NEED_TEXTURES) != 0; }

static int keeps_materials(const rtk_scene *scene)
{
    return (scene->needs & (RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS)) != 0;
}

rtk_material rtk_material_default(void)
{
    rtk_material m;
    memset(&m, 0, sizeof m);
    m.base_color = rtk_rgb_make(1.0f, 1.0f, 1.0f);
    m.alpha = 1.0f;
    m.ior = 1.5f;
    m.metallic = 0.0f;
    m.roughness = 1.0f;
    m.illum = -1;
    m.alpha_mode = RTK_ALPHA_OPAQUE;
    m.alpha_cutoff = 0.5f;
    m.base_tex = m.alpha_tex = m.normal_tex = m.emission_tex = -1;
    m.specular_color = rtk_rgb_make(1.0f, 1.0f, 1.0f);
    m.specular_weight = 1.0f;
    for (int k = 0; k < RTK_MAP_COUNT; k++)
        m.maps[k].tex = -1;
    return m;
}

rtk_scene *rtk_scene_new(const char *path, uint32_t needs)
{
    rtk_scene *scene = rtk_calloc(1, sizeof *scene);
    if (!scene)
        return NULL;
    scene->path = rtk_strdup(path ? path : "(memory)");
    if (!scene->path) {
        free(scene);
        return NULL;
    }
    if (needs & RTK_NEED_TEXTURES)
        needs |= RTK_NEED_UVS | RTK_NEED_MATERIALS;
    scene->needs = needs;
    scene->bounds.lower = rtk_vec3_make(FLT_MAX, FLT_MAX, FLT_MAX);
    scene->bounds.upper = rtk_vec3_make(-FLT_MAX, -FLT_MAX, -FLT_MAX);
    return scene;
}

void rtk_scene_free(rtk_scene *scene)
{
    if (!scene)
        return;
    /* The accelerator first: one with its own traversal may share the
     * scene's arrays (rtk_build_args.positions). */
    rtk_bvh_release(scene);
    free(scene->path);
    free(scene->positions);
    free(scene->indices);
    free(scene->normals);
    free(scene->uvs);
    free(scene->uvs1);
    free(scene->colors);
    free(scene->tri_material);
    if (!scene->owner) { /* a glTF mesh shares its file's materials */
        for (uint32_t i = 0; i < scene->material_count; i++)
            free(scene->materials[i].name);
        free(scene->materials);
        for (uint32_t i = 0; i < scene->texture_count; i++)
            rtk_texture_free(&scene->textures[i]);
        free(scene->textures);
    }
    rtk_instances_free(scene);
    free(scene->nodes);
    free(scene->prim_ids);
    rtk_lights_free(scene->lights);
    free(scene->punctual);
    rtk_scene_files_unref(scene->files);
    free(scene);
}

/* Next capacity after cap (x1.5), or 0 when count already reached the limit. */
static uint32_t grown_capacity(uint32_t cap, uint32_t initial)
{
    if (cap >= MAX_COUNT)
        return 0;
    uint64_t next = cap < initial ? initial : (uint64_t)cap + cap / 2;
    return next > MAX_COUNT ? MAX_COUNT : (uint32_t)next;
}

/* Reallocates *array to count items of size bytes; leaves it alone on failure. */
static int resize(void *array, size_t count, size_t size)
{
    void **slot = array;
    void *p = rtk_realloc_array(*slot, count, size);
    if (!p)
        return 0;
    *slot = p;
    return 1;
}

rtk_status rtk_scene_add_vertex(rtk_scene *scene, double x, double y, double z, uint32_t *index)
{
    if (scene->vertex_count == scene->vertex_cap) {
        uint32_t cap = grown_capacity(scene->vertex_cap, 1024);
        if (!cap)
            return rtk_error(RTK_ERR_NOMEM, "%s: more than %u vertices", scene->path, MAX_COUNT);
        /* One float more: see shrink_arrays. */
        if (!resize(&scene->positions, (size_t)cap * 3 + 1, sizeof(float)))
            return RTK_ERR_NOMEM;
        scene->vertex_cap = cap;
    }
    float *p = scene->positions + (size_t)scene->vertex_count * 3;
    p[0] = (float)x;
    p[1] = (float)y;
    p[2] = (float)z;
    if (index)
        *index = scene->vertex_count;
    scene->vertex_count++;
    return RTK_OK;
}

/* Grows every per-triangle array the scene keeps; the capacity is raised
 * only once all of them succeeded, so a failure leaves a consistent scene. */
static rtk_status grow_triangles(rtk_scene *scene)
{
    uint32_t cap = grown_capacity(scene->triangle_cap, 1024);
    if (!cap)
        return rtk_error(RTK_ERR_NOMEM, "%s: more than %u triangles", scene->path, MAX_COUNT);
    if (!resize(&scene->indices, (size_t)cap * 3, sizeof(uint32_t)))
        return RTK_ERR_NOMEM;
    if (keeps_normals(scene) && !resize(&scene->normals, (size_t)cap * 9, sizeof(float)))
        return RTK_ERR_NOMEM;
    /* Cutout materials need materials and uvs whatever the integrator
     * reads: traversal tests their alpha. */
    if ((keeps_uvs(scene) || scene->cutout_materials) && !resize(&scene->uvs, (size_t)cap * 6, sizeof(float)))
        return RTK_ERR_NOMEM;
    if ((keeps_materials(scene) || scene->cutout_materials || scene->single_sided) &&
        !resize(&scene->tri_material, cap, sizeof(uint32_t)))
        return RTK_ERR_NOMEM;
    if ((scene->uvs1 && !resize(&scene->uvs1, (size_t)cap * 6, sizeof(float))) ||
        (scene->colors && !resize(&scene->colors, (size_t)cap * 12, sizeof(float))))
        return RTK_ERR_NOMEM;
    scene->triangle_cap = cap;
    return RTK_OK;
}

rtk_status rtk_scene_add_triangle(rtk_scene *scene, uint32_t a, uint32_t b, uint32_t c,
                                  const float *normals, const float *uvs, uint32_t material)
{
    if (scene->triangle_count == scene->triangle_cap) {
        rtk_status status = grow_triangles(scene);
        if (status != RTK_OK)
            return status;
    }
    size_t t = scene->triangle_count;
    scene->indices[t * 3 + 0] = a;
    scene->indices[t * 3 + 1] = b;
    scene->indices[t * 3 + 2] = c;
    /* A missing normal is stored as zero; rtk_scene_finish fills it in. */
    if (scene->normals) {
        if (normals)
            memcpy(scene->normals + t * 9, normals, 9 * sizeof(float));
        else
            memset(scene->normals + t * 9, 0, 9 * sizeof(float));
    }
    if (scene->uvs) {
        if (uvs)
            memcpy(scene->uvs + t * 6, uvs, 6 * sizeof(float));
        else
            memset(scene->uvs + t * 6, 0, 6 * sizeof(float));
    }
    if (scene->tri_material)
        scene->tri_material[t] = material;
    /* Until rtk_scene_set_corners says otherwise: no second set, white. */
    if (scene->uvs1)
        memset(scene->uvs1 + t * 6, 0, 6 * sizeof(float));
    for (size_t k = 0; scene->colors && k < 12; k++)
        scene->colors[t * 12 + k] = 1.0f;
    scene->triangle_count++;
    return RTK_OK;
}

/* *array (per triangle, size floats each, made on first use): the
 * capacity's worth, earlier triangles set to fill. 0 when out of memory. */
static int corner_array(const rtk_scene *scene, float **array, size_t size, float fill)
{
    if (*array)
        return 1;
    size_t cap = scene->triangle_cap, n = (size_t)scene->triangle_count * size;
    if (!(*array = rtk_alloc(cap * size * sizeof(float))))
        return 0;
    for (size_t i = 0; i < n; i++)
        (*array)[i] = fill;
    return 1;
}

rtk_status rtk_scene_set_corners(rtk_scene *scene, const float *uvs1, const float *colors)
{
    if (!scene->triangle_count)
        return RTK_OK;
    size_t t = scene->triangle_count - 1;
    if (uvs1 && (keeps_uvs(scene) || scene->cutout_materials)) {
        if (!corner_array(scene, &scene->uvs1, 6, 0.0f))
            return RTK_ERR_NOMEM;
        memcpy(scene->uvs1 + t * 6, uvs1, 6 * sizeof(float));
    }
    if (colors && (keeps_materials(scene) || scene->cutout_materials)) {
        if (!corner_array(scene, &scene->colors, 12, 1.0f))
            return RTK_ERR_NOMEM;
        memcpy(scene->colors + t * 12, colors, 12 * sizeof(float));
    }
    return RTK_OK;
}

/* The first material that cuts out (uvs: 1) or is single-sided (uvs: 0):
 * from now on the scene keeps material ids, and uvs for a cutout;
 * triangles added before it get none (they cannot use it). */
static rtk_status keep_cutout_data(rtk_scene *scene, int uvs)
{
    size_t cap = scene->triangle_cap, n = scene->triangle_count;
    if (uvs && !scene->uvs && cap) {
        if (!(scene->uvs = rtk_calloc(cap * 6, sizeof(float))))
            return RTK_ERR_NOMEM;
    }
    if (!scene->tri_material && cap) {
        if (!(scene->tri_material = rtk_alloc(cap * sizeof(uint32_t))))
            return RTK_ERR_NOMEM;
        for (size_t t = 0; t < n; t++)
            scene->tri_material[t] = RTK_INVALID_ID;
    }
    return RTK_OK;
}

rtk_status rtk_scene_add_material(rtk_scene *scene, const rtk_material *material, uint32_t *index)
{
    float cutoff;
    if (!scene->cutout_materials && rtk_material_cutout(material, &cutoff)) {
        scene->cutout_materials = 1;
        rtk_status status = keep_cutout_data(scene, 1);
        if (status != RTK_OK)
            return status;
    }
    if (!scene->single_sided && material->single_sided) {
        scene->single_sided = 1;
        rtk_status status = keep_cutout_data(scene, 0);
        if (status != RTK_OK)
            return status;
    }
    if (scene->material_count == scene->material_cap) {
        uint32_t cap = grown_capacity(scene->material_cap, 16);
        if (!cap)
            return rtk_error(RTK_ERR_NOMEM, "%s: more than %u materials", scene->path, MAX_COUNT);
        if (!resize(&scene->materials, cap, sizeof(rtk_material)))
            return RTK_ERR_NOMEM;
        scene->material_cap = cap;
    }
    rtk_material copy = *material;
    copy.name = NULL;
    if (material->name && !(copy.name = rtk_strdup(material->name)))
        return RTK_ERR_NOMEM;
    scene->materials[scene->material_count] = copy;
    if (index)
        *index = scene->material_count;
    scene->material_count++;
    return RTK_OK;
}

rtk_status rtk_scene_add_texture(rtk_scene *scene, const char *name, const char *path,
                                 const void *bytes, size_t byte_count, int srgb, int *index)
{
    srgb = srgb != 0;
    /* One entry per file and colour space: the same image may serve as
     * sRGB colour in one material and as linear data in another. */
    if (path) {
        for (uint32_t i = 0; i < scene->texture_count; i++) {
            const rtk_texture *t = &scene->textures[i];
            if (t->path && t->srgb == srgb && strcmp(t->path, path) == 0) {
                if (index)
                    *index = (int)i;
                return RTK_OK;
            }
        }
    }
    if (scene->texture_count >= (uint32_t)INT32_MAX)
        return rtk_error(RTK_ERR_NOMEM, "%s: too many textures", scene->path);
    if (scene->texture_count == scene->texture_cap) {
        uint32_t cap = grown_capacity(scene->texture_cap, 16);
        if (!resize(&scene->textures, cap, sizeof(rtk_texture)))
            return RTK_ERR_NOMEM;
        scene->texture_cap = cap;
    }
    rtk_texture tex;
    memset(&tex, 0, sizeof tex);
    tex.srgb = srgb;
    tex.name = rtk_strdup(name ? name : path ? path : "embedded image");
    tex.path = rtk_strdup(path);
    /* Refused files stay textures that read white, as missing ones do:
     * the reason is told if a plugin needs the image. */
    if (path && rtk_scene_file_allowed(scene, path, "texture") != RTK_OK &&
        !(tex.problem = rtk_strdup(rtk_error_message()))) {
        free(tex.name);
        free(tex.path);
        return RTK_ERR_NOMEM;
    }
    /* Encoded bytes are kept: a cutout material may need the image even
     * when the integrator reads no texture (rtk_scene_finish frees those
     * that were not decoded). */
    if (bytes && byte_count) {
        tex.bytes = rtk_alloc(byte_count);
        if (tex.bytes) {
            memcpy(tex.bytes, bytes, byte_count);
            tex.byte_count = byte_count;
        }
    }
    if (!tex.name || (path && !tex.path) || (bytes && byte_count && !tex.bytes)) {
        free(tex.name);
        free(tex.path);
        free(tex.problem);
        free(tex.bytes);
        return RTK_ERR_NOMEM;
    }
    scene->textures[scene->texture_count] = tex;
    if (index)
        *index = (int)scene->texture_count;
    scene->texture_count++;
    return RTK_OK;
}

/* The texture slots of a material: base, alpha, normal, emission (in
 * that order), then its factor maps. */
#define MATERIAL_TEXTURES (4 + RTK_MAP_COUNT)
static void material_textures(const rtk_material *m, int tex[MATERIAL_TEXTURES])
{
    tex[0] = m->base_tex, tex[1] = m->alpha_tex, tex[2] = m->normal_tex, tex[3] = m->emission_tex;
    for (int k = 0; k < RTK_MAP_COUNT; k++)
        tex[4 + k] = m->maps[k].tex;
}

static int finite3(const float *v) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

/* Checks what the loaders promised: finite positions, indices in range,
 * material and texture references in range. */
static rtk_status check_scene(const rtk_scene *scene)
{
    for (uint32_t i = 0; i < scene->vertex_count; i++) {
        const float *p = scene->positions + (size_t)i * 3;
        if (!finite3(p))
            return rtk_error(RTK_ERR_INVALID,
                             "%s: vertex %u (counting from 1) has a non-finite position (%g, %g, %g); "
                             "fix or remove that vertex",
                             scene->path, i + 1, (double)p[0], (double)p[1], (double)p[2]);
    }
    for (uint32_t t = 0; t < scene->triangle_count; t++) {
        const uint32_t *v = scene->indices + (size_t)t * 3;
        for (int k = 0; k < 3; k++) {
            if (v[k] >= scene->vertex_count)
                return rtk_error(RTK_ERR_INVALID, "%s: triangle %u uses vertex %u, but there are only %u vertices",
                                 scene->path, t + 1, v[k] + 1, scene->vertex_count);
        }
        if (scene->tri_material && scene->tri_material[t] != RTK_INVALID_ID &&
            scene->tri_material[t] >= scene->material_count)
            return rtk_error(RTK_ERR_INVALID, "%s: triangle %u uses material %u, but there are only %u materials",
                             scene->path, t + 1, scene->tri_material[t] + 1, scene->material_count);
    }
    for (uint32_t m = 0; m < scene->material_count; m++) {
        const rtk_material *mat = &scene->materials[m];
        int tex[MATERIAL_TEXTURES];
        material_textures(mat, tex);
        for (int k = 0; k < MATERIAL_TEXTURES; k++) {
            if (tex[k] < -1 || (tex[k] >= 0 && (uint32_t)tex[k] >= scene->texture_count))
                return rtk_error(RTK_ERR_INVALID, "%s: material '%s' refers to texture %d, but there are only %u",
                                 scene->path, mat->name ? mat->name : "", tex[k], scene->texture_count);
        }
    }
    return RTK_OK;
}

/* Twice the area vector of triangle t, in double so that tiny but real
 * triangles do not underflow to zero. */
static void triangle_cross(const rtk_scene *scene, const uint32_t *v, double n[3])
{
    const float *a = scene->positions + (size_t)v[0] * 3;
    const float *b = scene->positions + (size_t)v[1] * 3;
    const float *c = scene->positions + (size_t)v[2] * 3;
    double e1[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
    double e2[3] = {(double)c[0] - a[0], (double)c[1] - a[1], (double)c[2] - a[2]};
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

/* Unit normals at the three corners; a missing (zero) or broken
 * (non-finite) corner normal becomes the geometric normal. */
static void fix_normals(float *corner, const double cross[3])
{
    double len = sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]);
    float geo[3] = {(float)(cross[0] / len), (float)(cross[1] / len), (float)(cross[2] / len)};
    for (int k = 0; k < 3; k++) {
        float *n = corner + k * 3;
        float l = finite3(n) ? sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) : 0.0f;
        if (l > 0.0f && isfinite(l)) {
            n[0] /= l;
            n[1] /= l;
            n[2] /= l;
        } else {
            memcpy(n, geo, sizeof geo);
        }
    }
}

static void fix_uvs(float *uv)
{
    for (int k = 0; k < 6; k++) {
        if (!isfinite(uv[k]))
            uv[k] = 0.0f;
    }
}

static void grow_bounds(rtk_bounds *b, const float *p)
{
    b->lower.x = fminf(b->lower.x, p[0]);
    b->lower.y = fminf(b->lower.y, p[1]);
    b->lower.z = fminf(b->lower.z, p[2]);
    b->upper.x = fmaxf(b->upper.x, p[0]);
    b->upper.y = fmaxf(b->upper.y, p[1]);
    b->upper.z = fmaxf(b->upper.z, p[2]);
}

/* Shrinks *array to bytes; keeps the larger block if realloc fails. */
static void shrink(void *array, size_t bytes)
{
    void **slot = array;
    if (!*slot)
        return;
    void *p = realloc(*slot, bytes ? bytes : 1);
    if (p)
        *slot = p;
}

/* Gives back the spare capacity of the geometric growth. A capacity only
 * has to be a lower bound of each array's size, so a failed shrink (the
 * block stays larger) leaves the scene consistent. */
static void shrink_arrays(rtk_scene *scene)
{
    size_t v = scene->vertex_count, t = scene->triangle_count;
    /* Positions keep one float past the last vertex, so that a 16-byte
     * load of it stays in bounds (rtk_build_args.positions). */
    shrink(&scene->positions, (v * 3 + 1) * sizeof(float));
    shrink(&scene->indices, t * 3 * sizeof(uint32_t));
    shrink(&scene->normals, t * 9 * sizeof(float));
    shrink(&scene->uvs, t * 6 * sizeof(float));
    shrink(&scene->uvs1, t * 6 * sizeof(float));
    shrink(&scene->colors, t * 12 * sizeof(float));
    shrink(&scene->tri_material, t * sizeof(uint32_t));
    if (scene->positions)
        scene->vertex_cap = (uint32_t)v;
    if (scene->indices)
        scene->triangle_cap = (uint32_t)t;
}

/* Decodes the textures of materials that some triangle uses: every one
 * when the integrator reads textures, else only the alpha textures of
 * cutout materials; notes whether any used material cuts out. */
static rtk_status decode_textures(rtk_scene *scene)
{
    if (!scene->tri_material)
        return RTK_OK;
    unsigned char *used = rtk_calloc(scene->material_count ? scene->material_count : 1, 1);
    if (!used)
        return RTK_ERR_NOMEM;
    for (uint32_t t = 0; t < scene->triangle_count; t++) {
        if (scene->tri_material[t] < scene->material_count)
            used[scene->tri_material[t]] = 1;
    }
    for (uint32_t m = 0; m < scene->material_count; m++) {
        if (!used[m])
            continue;
        const rtk_material *mat = &scene->materials[m];
        float cutoff;
        int cutout = rtk_material_cutout(mat, &cutoff);
        scene->has_cutouts |= cutout || mat->single_sided;
        int tex[MATERIAL_TEXTURES];
        material_textures(mat, tex);
        for (int k = 0; k < MATERIAL_TEXTURES; k++) {
            if (tex[k] >= 0 && (uint32_t)tex[k] < scene->texture_count &&
                (keeps_textures(scene) || (cutout && k == 1))) {
                rtk_texture_decode_within(&scene->textures[tex[k]], scene->files);
                if (k == 2)
                    rtk_normal_map_usable(&scene->textures[tex[k]]);
            }
        }
    }
    free(used);
    return RTK_OK;
}

/* Without texture-reading integrators, images no cutout needed are never
 * decoded: their encoded bytes go. */
static void drop_unused_images(rtk_scene *scene)
{
    if (keeps_textures(scene) || scene->owner)
        return;
    for (uint32_t i = 0; i < scene->texture_count; i++) {
        rtk_texture *t = &scene->textures[i];
        if (!t->decoded && t->bytes) {
            free(t->bytes);
            t->bytes = NULL;
            t->byte_count = 0;
        }
    }
}

rtk_status rtk_scene_finish(rtk_scene *scene)
{
    rtk_status status = check_scene(scene);
    if (status != RTK_OK)
        return status;

    rtk_bounds bounds;
    bounds.lower = rtk_vec3_make(FLT_MAX, FLT_MAX, FLT_MAX);
    bounds.upper = rtk_vec3_make(-FLT_MAX, -FLT_MAX, -FLT_MAX);
    uint32_t kept = 0;
    for (uint32_t t = 0; t < scene->triangle_count; t++) {
        const uint32_t *v = scene->indices + (size_t)t * 3;
        double cross[3];
        triangle_cross(scene, v, cross);
        if (cross[0] == 0.0 && cross[1] == 0.0 && cross[2] == 0.0)
            continue;
        if (kept != t) {
            memmove(scene->indices + (size_t)kept * 3, v, 3 * sizeof(uint32_t));
            if (scene->normals)
                memmove(scene->normals + (size_t)kept * 9, scene->normals + (size_t)t * 9, 9 * sizeof(float));
            if (scene->uvs)
                memmove(scene->uvs + (size_t)kept * 6, scene->uvs + (size_t)t * 6, 6 * sizeof(float));
            if (scene->uvs1)
                memmove(scene->uvs1 + (size_t)kept * 6, scene->uvs1 + (size_t)t * 6, 6 * sizeof(float));
            if (scene->colors)
                memmove(scene->colors + (size_t)kept * 12, scene->colors + (size_t)t * 12, 12 * sizeof(float));
            if (scene->tri_material)
                scene->tri_material[kept] = scene->tri_material[t];
        }
        if (scene->normals)
            fix_normals(scene->normals + (size_t)kept * 9, cross);
        if (scene->uvs)
            fix_uvs(scene->uvs + (size_t)kept * 6);
        if (scene->uvs1)
            fix_uvs(scene->uvs1 + (size_t)kept * 6);
        const uint32_t *kv = scene->indices + (size_t)kept * 3;
        for (int k = 0; k < 3; k++)
            grow_bounds(&bounds, scene->positions + (size_t)kv[k] * 3);
        kept++;
    }
    uint32_t dropped = scene->triangle_count - kept;
    scene->dropped_degenerate += dropped;
    scene->triangle_count = kept;
    scene->bounds = bounds;
    if (dropped)
        rtk_log(RTK_LOG_WARN, "%s: dropped %u degenerate (zero-area) triangle%s", scene->path, dropped,
                dropped == 1 ? "" : "s");
    shrink_arrays(scene);
    scene->finished = 1;
    if ((status = rtk_instances_finish(scene)) != RTK_OK)
        return status;
    if (!kept && !scene->instance_count && !scene->owner)
        rtk_log(RTK_LOG_WARN, "%s: the scene has no triangles", scene->path);

    if ((status = decode_textures(scene)) != RTK_OK)
        return status;
    drop_unused_images(scene);
    if (scene->needs & RTK_NEED_LIGHTS)
        return rtk_lights_build(scene);
    return RTK_OK;
}

/* Extension of path without the dot, or "" when there is none. */
static const char *path_extension(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(slash ? slash + 1 : path, '.');
    return dot && dot[1] ? dot + 1 : "";
}

rtk_status rtk_scene_load(const char *path, uint32_t needs, rtk_scene **out)
{
    return rtk_scene_load_with(path, needs, NULL, out);
}

rtk_status rtk_scene_load_with(const char *path, uint32_t needs, rtk_scene_files *files, rtk_scene **out)
{
    *out = NULL;
    if (!path || !path[0])
        return rtk_error(RTK_ERR_INVALID, "no scene file given");
    const char *ext = path_extension(path);
    rtk_status (*load)(const char *, rtk_scene *);
    if (strcasecmp(ext, "obj") == 0)
        load = rtk_load_obj;
    else if (strcasecmp(ext, "gltf") == 0 || strcasecmp(ext, "glb") == 0)
        load = rtk_load_gltf;
    else if (!ext[0])
        return rtk_error(RTK_ERR_UNSUPPORTED,
                         "%s: the scene file has no extension; supported extensions are .obj, .gltf and .glb", path);
    else
        return rtk_error(RTK_ERR_UNSUPPORTED,
                         "%s: unknown scene format '.%s'; supported extensions are .obj, .gltf and .glb", path, ext);

    int fd;
    rtk_status status = rtk_file_open(path, "scene file", &fd, NULL);
    if (status != RTK_OK)
        return status;
    close(fd);

    rtk_scene *scene = rtk_scene_new(path, needs);
    if (!scene)
        return RTK_ERR_NOMEM;
    scene->files = files ? rtk_scene_files_ref(files) : rtk_scene_files_new(NULL, 0, 0);
    if (!scene->files) {
        rtk_scene_free(scene);
        return RTK_ERR_NOMEM;
    }
    double start = rtk_now();
    status = load(path, scene);
    if (status == RTK_OK)
        status = rtk_scene_finish(scene);
    if (status != RTK_OK) {
        rtk_scene_free(scene);
        return status;
    }
    rtk_log(RTK_LOG_DEBUG, "%s: %u triangles, %u vertices, %u materials, %u textures in %.2f s", path,
            scene->triangle_count, scene->vertex_count, scene->material_count, scene->texture_count,
            rtk_now() - start);
    *out = scene;
    return RTK_OK;
}
