/* Device accelerators (ABI 3.5): the tree a builder plugin made, through
 * the cache like any other, handed with its triangles in leaf order to an
 * accelerator that traces batches on another processor (the cuda plugin).
 * Single rays stay with the kernel's traversal of the same tree. */
#include "accel.h"

#include <pthread.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

int rtk_accelerator_is_device(const rtk_plugin *accelerator)
{
    const rtk_accelerator_fns *f = accelerator->functions;
    return f->size >= offsetof(rtk_accelerator_fns, report) + sizeof f->report && f->attach != NULL;
}

/* The plugins a device's "builder" may name: rtk's own directories and
 * RTK_PLUGIN_PATH, scanned once per process. */
static pthread_mutex_t registry_lock = PTHREAD_MUTEX_INITIALIZER;
static rtk_registry *builders;

const char *rtk_builder_unfit(const rtk_plugin *accelerator)
{
    return rtk_accelerator_is_device(accelerator)           ? "builds no tree"
           : rtk_accelerator_traverses_itself(accelerator) ? "keeps its tree to itself"
                                                            : NULL;
}

static rtk_status find_builder(const rtk_plugin *device, const rtk_params *params, const rtk_plugin **out)
{
    const char *name = rtk_params_string(params, "builder");
    pthread_mutex_lock(&registry_lock);
    rtk_status st = builders ? RTK_OK : rtk_registry_create(&builders);
    if (st == RTK_OK)
        st = rtk_registry_find(builders, RTK_KIND_ACCELERATOR, name, out);
    pthread_mutex_unlock(&registry_lock);
    if (st != RTK_OK) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", rtk_error_message());
        return rtk_error(st, "accelerator '%s': builder = \"%s\": %s", device->name, name, msg);
    }
    const char *unfit = rtk_builder_unfit(*out);
    if (unfit)
        return rtk_error(RTK_ERR_INVALID, "accelerator '%s': builder = \"%s\" names an accelerator that %s; name "
                         "one that builds the kernel's tree (median, sah or lbvh)", device->name, name, unfit);
    return RTK_OK;
}

/* Leaf-order corners of one tree for the device, split over threads. */
typedef struct corner_job {
    const rtk_scene *s;
    float *out;
} corner_job;

static void gather_corners(void *ctx, uint32_t begin, uint32_t end)
{
    const corner_job *j = ctx;
    for (uint32_t slot = begin; slot < end; slot++)
        rtk_slot_corners(j->s, slot, j->out + 9 * (size_t)slot);
}

void rtk_device_release(rtk_scene *s)
{
    if (s->device && s->device_state)
        s->device->destroy(s->device_state);
    free(s->device_data);
    s->device = NULL;
    s->device_state = NULL;
    s->device_data = NULL;
    s->device_lights = 0;
    s->device_minor = 0;
}

/* Some triangle of s, or of a mesh it places, needs the per-hit material test. */
static int any_cutouts(const rtk_scene *s)
{
    int cut = s->has_cutouts;
    for (uint32_t i = 0; i < s->mesh_count; i++)
        cut |= s->meshes[i]->has_cutouts;
    return cut;
}

/* Whether m's hits read its materials (as rtk_surface_at does). */
static int reads_materials(const rtk_scene *m)
{
    return m->tri_material && (m->needs & (RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS));
}

/* Whether m's hits read its textures (as rtk_surface_at does). */
static int reads_textures(const rtk_scene *m)
{
    return reads_materials(m) && (m->needs & RTK_NEED_TEXTURES) && m->uvs && m->textures && m->texture_count;
}

/* Where tree views put what they gather, each pointer moved past it. */
typedef struct view_space {
    float *corners;
    rtk_rgb *bases;
    rtk_device_texture *textures;
    const rtk_texture_level **levels; /* each texture's MIP levels or NULL */
} view_space;

/* Bytes of the space the views of s and its meshes take. */
static size_t view_bytes(const rtk_scene *s)
{
    uint64_t triangles = s->triangle_count, materials = s->material_count, textures = s->texture_count;
    for (uint32_t i = 0; i < s->mesh_count; i++) {
        triangles += s->meshes[i]->triangle_count, materials += s->meshes[i]->material_count;
        textures += s->meshes[i]->texture_count;
    }
    return (sizeof(rtk_device_texture) + sizeof(rtk_texture_level *)) * (size_t)textures +
           sizeof(rtk_rgb) * (size_t)materials + sizeof(float) * 9 * (size_t)triangles;
}

/* The space at block, view_bytes of it: textures and their levels first
 * (they hold pointers), then base colours, then corners. */
static view_space space_at(void *block, const rtk_scene *s)
{
    uint64_t textures = s->texture_count, materials = s->material_count;
    for (uint32_t i = 0; i < s->mesh_count; i++)
        textures += s->meshes[i]->texture_count, materials += s->meshes[i]->material_count;
    view_space v;
    v.textures = block;
    v.levels = (const rtk_texture_level **)(void *)(v.textures + textures);
    v.bases = (rtk_rgb *)(void *)(v.levels + textures);
    v.corners = (float *)(void *)(v.bases + materials);
    return v;
}

/* Texture t as device programs read it. */
static rtk_device_texture device_texture(const rtk_texture *t)
{
    rtk_device_texture d;
    memset(&d, 0, sizeof d);
    d.filter = (int32_t)t->filter;
    d.decoded = t->decoded != 0;
    if (t->decoded && !t->missing && t->rgba && t->width > 0 && t->height > 0) {
        d.width = t->width, d.height = t->height, d.rgba = t->rgba;
        d.has_alpha = t->has_alpha != 0;
        d.normal_map = t->normal_map_checked > 0;
        if (t->filter == RTK_TEX_TRILINEAR && t->levels >= 2 && t->mip)
            d.levels = t->levels;
    }
    return d;
}

/* One tree's view for the device, what it gathers (corners, base colours,
 * textures) taken from *space. */
static rtk_device_tree tree_view(const rtk_scene *m, view_space *space, uint32_t threads)
{
    corner_job job = {m, space->corners};
    rtk_parallel_ranges(m->triangle_count, threads ? threads : 1, 65536, gather_corners, &job);
    rtk_device_tree t;
    memset(&t, 0, sizeof t);
    t.size = sizeof t;
    if (m->node_count) {
        t.nodes = m->nodes, t.node_count = m->node_count, t.depth = m->bvh_depth;
        t.prim_ids = m->prim_ids, t.corners = space->corners, t.slot_count = m->triangle_count;
        t.normals = m->normals;
        if (reads_materials(m)) {
            for (uint32_t i = 0; i < m->material_count; i++)
                space->bases[i] = m->materials[i].base_color;
            t.tri_materials = m->tri_material;
            t.materials = m->materials;
            t.base_colors = space->bases;
            t.material_count = m->material_count;
            t.colors = m->colors;
        }
        if (reads_textures(m)) {
            for (uint32_t i = 0; i < m->texture_count; i++) {
                space->textures[i] = device_texture(&m->textures[i]);
                space->levels[i] = space->textures[i].levels ? m->textures[i].mip : NULL;
            }
            t.uvs = m->uvs, t.uvs1 = m->uvs1;
            t.textures = space->textures;
            t.texture_count = m->texture_count;
            t.texture_levels = space->levels;
        }
    }
    space->corners += 9 * (size_t)m->triangle_count;
    space->bases += m->material_count;
    space->textures += m->texture_count;
    space->levels += m->texture_count;
    return t;
}

/* The lights of s (a scene, or a placed mesh: its emitters' light_of)
 * for device programs that sample them (none else). */
static void lights_view(const rtk_scene *s, rtk_device_tree *t)
{
    if (!(s->needs & RTK_NEED_LIGHTS) || !s->lights)
        return;
    t->lights = s->lights;
    t->punctual = s->punctual;
    t->punctual_count = s->punctual_count;
}

rtk_status rtk_device_tree_view(const rtk_scene *s, uint32_t threads, rtk_device_tree *out, void **block)
{
    *block = rtk_alloc(view_bytes(s) + 1);
    if (!*block)
        return rtk_error(RTK_ERR_NOMEM, "out of memory for the device's copy of %u triangles", s->triangle_count);
    view_space space = space_at(*block, s);
    *out = tree_view(s, &space, threads);
    lights_view(s, out);
    return RTK_OK;
}

/* rtk_device_build inside the build log that it opens. */
static rtk_status device_build(rtk_scene *s, const rtk_plugin *device, const rtk_params *params, uint32_t threads,
                               const char *dir, rtk_bvh_cache_use *use)
{
    if (use)
        memset(use, 0, sizeof *use);
    rtk_device_release(s);
    const char *where = s->path ? s->path : "the scene";
    if (any_cutouts(s))
        return rtk_error(RTK_ERR_UNSUPPORTED, "%s: the scene has alpha cut-outs or single-sided materials, which "
                         "device accelerator '%s' does not test: pick median, sah or lbvh", where, device->name);
    const rtk_accelerator_fns *f = device->functions;
    void *state = NULL;
    rtk_status st = f->create(params, &state);
    if (st != RTK_OK) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", rtk_error_message());
        return rtk_error(st, "accelerator '%s' failed to start: %s", device->name, msg);
    }
    const rtk_plugin *builder = NULL;
    rtk_params *builder_params = NULL;
    st = find_builder(device, params, &builder);
    if (st == RTK_OK && !(builder_params = rtk_params_defaults(builder)))
        st = RTK_ERR_NOMEM;
    if (st == RTK_OK) {
        if (dir && use)
            st = rtk_bvh_build_cached(s, builder, builder_params, threads, dir, use);
        else
            st = s->instance_count ? rtk_instances_build(s, builder, builder_params, threads, NULL, NULL)
                                   : rtk_bvh_build(s, builder, builder_params, threads);
    }
    rtk_params_destroy(builder_params);
    if (st != RTK_OK || (s->triangle_count == 0 && s->instance_count == 0)) {
        f->destroy(state); /* nothing to hit: every ray misses without a device */
        return st;
    }
    rtk_build_log_mark(s->build_log, "device: upload", 0, 0);
    /* One block: the meshes' views, the instances' frames, then every
     * tree's textures, materials' base colours and corners. */
    uint64_t triangles = s->triangle_count;
    for (uint32_t i = 0; i < s->mesh_count; i++)
        triangles += s->meshes[i]->triangle_count;
    const size_t views = sizeof(rtk_device_tree) * s->mesh_count + sizeof(rtk_device_frame) * s->instance_count;
    s->device_data = rtk_alloc(views + view_bytes(s));
    if (!s->device_data) {
        f->destroy(state);
        return rtk_error(RTK_ERR_NOMEM, "%s: out of memory for the device's copy of %llu triangles", where,
                         (unsigned long long)triangles);
    }
    rtk_device_tree *meshes = s->device_data;
    rtk_device_frame *frames = (rtk_device_frame *)(void *)(meshes + s->mesh_count);
    view_space space = space_at((char *)s->device_data + views, s);
    rtk_device_tree tree = tree_view(s, &space, threads);
    lights_view(s, &tree);
    for (uint32_t i = 0; i < s->mesh_count; i++) {
        meshes[i] = tree_view(s->meshes[i], &space, threads);
        lights_view(s->meshes[i], &meshes[i]);
    }
    for (uint32_t i = 0; i < s->instance_count; i++) {
        memcpy(frames[i].to_world, s->instances[i].to_world, sizeof frames[i].to_world);
        frames[i].mirrored = s->instances[i].mirrored != 0;
        frames[i].reserved = 0;
    }
    if (s->instance_count) {
        tree.tlas_nodes = s->tlas_nodes, tree.tlas_node_count = s->tlas_node_count, tree.tlas_depth = s->tlas_depth;
        tree.tlas_order = s->tlas_order;
        tree.instances = s->placements, tree.instance_count = s->instance_count;
        tree.meshes = meshes, tree.mesh_count = s->mesh_count;
        tree.frames = frames;
    }
    st = f->attach(state, &tree);
    if (st != RTK_OK) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", rtk_error_message());
        f->destroy(state);
        free(s->device_data);
        s->device_data = NULL;
        return rtk_error(st, "accelerator '%s' could not take the tree of %llu triangles: %s", device->name,
                         (unsigned long long)triangles, msg);
    }
    s->device = f;
    s->device_state = state;
    s->device_lights = tree.lights ? tree.lights->stamp : 0;
    s->device_minor = device->abi_minor;
    return RTK_OK;
}

rtk_status rtk_device_build(rtk_scene *s, const rtk_plugin *device, const rtk_params *params, uint32_t threads,
                            const char *dir, rtk_bvh_cache_use *use)
{
    rtk_build_log_begin(s->build_log);
    rtk_status st = device_build(s, device, params, threads, dir, use);
    rtk_build_log_end(s->build_log);
    return st;
}

rtk_status rtk_device_probe(const rtk_plugin *device, const rtk_params *params)
{
    const rtk_accelerator_fns *f = device->functions;
    void *state = NULL;
    rtk_status st = f->create(params, &state);
    if (st == RTK_OK)
        f->destroy(state);
    return st;
}

int rtk_device_report_of(const rtk_scene *s, rtk_device_report *out)
{
    if (!s->device)
        return 0;
    memset(out, 0, sizeof *out);
    out->size = sizeof *out;
    s->device->report(s->device_state, out);
    return 1;
}

/* The device's shade, when its table has one (ABI 3.6). */
static rtk_status (*shade_fn(const rtk_accelerator_fns *f))(const void *, rtk_shade_batch *)
{
    return f->size >= offsetof(rtk_accelerator_fns, shade) + sizeof f->shade ? f->shade : NULL;
}

int rtk_device_reads_footprints(const rtk_scene *s)
{
    for (uint32_t i = 0; i <= s->mesh_count; i++) {
        const rtk_scene *m = i < s->mesh_count ? s->meshes[i] : s;
        for (uint32_t t = 0; reads_textures(m) && t < m->texture_count; t++)
            if (m->textures[t].decoded && m->textures[t].filter == RTK_TEX_TRILINEAR)
                return 1;
    }
    return 0;
}

const char *rtk_device_runs(const rtk_scene *s, const rtk_device_program *program)
{
    if (!s->device)
        return "no device accelerator traces this scene";
    if (!shade_fn(s->device))
        return "the device accelerator runs no programs";
    if ((s->needs & RTK_NEED_LIGHTS) && s->lights && s->lights->stamp != s->device_lights)
        return "the scene's lights changed after the device took its tree";
    if (rtk_device_reads_footprints(s) && s->device_minor < 9)
        return "textures.filter = \"trilinear\" needs a device accelerator built for plugin ABI 3.9 or later, "
               "which reads MIP levels (rebuild it, or pick \"bilinear\" or \"nearest\")";
    rtk_shade_batch probe;
    memset(&probe, 0, sizeof probe);
    probe.size = sizeof probe;
    probe.program = program;
    return s->device->shade(s->device_state, &probe) == RTK_OK ? NULL : "the device does not run this program";
}

rtk_status rtk_device_shade(const rtk_scene *s, rtk_shade_batch *batch)
{
    return s->device->shade(s->device_state, batch);
}
