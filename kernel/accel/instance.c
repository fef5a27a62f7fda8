/* Two-level instancing: meshes placed by transforms, one bottom-level BVH
 * per mesh however often it is placed, and a top-level BVH over the
 * instances' world boxes built by the same accelerator plugin. Rays enter
 * a mesh in its object space (transformed in double precision), so the
 * watertight triangle test and the distances it reports are the ones the
 * mesh has on its own; t is the same ray parameter in both spaces. */
#include "accel.h"
#include "two_level.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static rtk_status append_mesh(rtk_scene *scene, rtk_scene *mesh, uint32_t *index)
{
    if (!rtk_grow_array((void **)&scene->meshes, &scene->mesh_cap, scene->mesh_count, sizeof *scene->meshes))
        return rtk_error(RTK_ERR_NOMEM, "%s: out of memory for instanced meshes", scene->path);
    *index = scene->mesh_count;
    scene->meshes[scene->mesh_count++] = mesh;
    return RTK_OK;
}

rtk_status rtk_scene_add_mesh(rtk_scene *scene, const char *name, uint32_t *index)
{
    rtk_scene *mesh = rtk_scene_new(name, scene->needs);
    if (!mesh)
        return RTK_ERR_NOMEM;
    mesh->owner = scene;
    mesh->cutout_materials = scene->cutout_materials;
    mesh->single_sided = scene->single_sided;
    rtk_status st = append_mesh(scene, mesh, index);
    if (st != RTK_OK)
        rtk_scene_free(mesh);
    return st;
}

/* Inverse of the affine map m (3x4 row-major) into inv; returns the
 * determinant of its linear part, 0 when it cannot be inverted. */
static double invert(const double m[12], double inv[12])
{
    double a = m[0], b = m[1], c = m[2], d = m[4], e = m[5], f = m[6], g = m[8], h = m[9], i = m[10];
    double A = e * i - f * h, B = f * g - d * i, C = d * h - e * g;
    double det = a * A + b * B + c * C;
    if (!(det != 0.0) || !isfinite(det))
        return 0.0;
    double r = 1.0 / det;
    double l[9] = {A * r, (c * h - b * i) * r, (b * f - c * e) * r, B * r, (a * i - c * g) * r,
                   (c * d - a * f) * r, C * r, (b * g - a * h) * r, (a * e - b * d) * r};
    for (int row = 0; row < 3; row++) {
        for (int col = 0; col < 3; col++)
            inv[4 * row + col] = l[3 * row + col];
        inv[4 * row + 3] = -(l[3 * row] * m[3] + l[3 * row + 1] * m[7] + l[3 * row + 2] * m[11]);
    }
    for (int k = 0; k < 12; k++) {
        if (!isfinite(inv[k]))
            return 0.0;
    }
    return det;
}

rtk_status rtk_scene_add_instance(rtk_scene *scene, uint32_t mesh, const double to_world[12], const char *where)
{
    if (mesh >= scene->mesh_count)
        return rtk_error(RTK_ERR_INVALID, "%s: instance of mesh %u, but there are %u meshes", where, mesh,
                         scene->mesh_count);
    for (int k = 0; k < 12; k++) {
        if (!isfinite(to_world[k]))
            return rtk_error(RTK_ERR_INVALID, "%s: the instance's transform is not finite", where);
    }
    rtk_instance in;
    memset(&in, 0, sizeof in);
    double det = invert(to_world, in.to_object);
    if (det == 0.0)
        return rtk_error(RTK_ERR_INVALID,
                         "%s: the instance's transform is singular (a zero scale?) and would flatten the mesh", where);
    if (!rtk_grow_array((void **)&scene->instances, &scene->instance_cap, scene->instance_count,
                        sizeof *scene->instances))
        return rtk_error(RTK_ERR_NOMEM, "%s: out of memory for instances", where);
    in.mesh = mesh;
    in.mirrored = det < 0.0;
    memcpy(in.to_world, to_world, sizeof in.to_world);
    in.bounds.lower = rtk_vec3_make(INFINITY, INFINITY, INFINITY);
    in.bounds.upper = rtk_vec3_make(-INFINITY, -INFINITY, -INFINITY);
    scene->instances[scene->instance_count++] = in;
    return RTK_OK;
}

rtk_status rtk_scene_instance_file(rtk_scene *scene, const char *path, const double to_world[12], const char *where)
{
    uint32_t index = RTK_INVALID_ID;
    for (uint32_t i = 0; i < scene->mesh_count && index == RTK_INVALID_ID; i++) {
        if (!scene->meshes[i]->owner && strcmp(scene->meshes[i]->path, path) == 0)
            index = i;
    }
    if (index == RTK_INVALID_ID) {
        rtk_scene *mesh = NULL;
        rtk_status st = rtk_scene_load_with(path, scene->needs, scene->files, &mesh);
        if (st != RTK_OK) {
            char msg[2048];
            snprintf(msg, sizeof msg, "%s", rtk_error_message());
            return rtk_error(st, "%s: %s", where, msg);
        }
        if (mesh->instance_count) {
            rtk_scene_free(mesh);
            return rtk_error(RTK_ERR_UNSUPPORTED,
                             "%s: %s places meshes by instancing itself (glTF nodes sharing a mesh), and rtk "
                             "instances one level deep: use it as the scene, or instance its parts",
                             where, path);
        }
        if ((st = append_mesh(scene, mesh, &index)) != RTK_OK) {
            rtk_scene_free(mesh);
            return st;
        }
    }
    return rtk_scene_add_instance(scene, index, to_world, where);
}

static void apply_point(const double m[12], double x, double y, double z, double out[3])
{
    rtk_affine_point(m, x, y, z, out);
}

static void apply_vector(const double m[12], double x, double y, double z, double out[3])
{
    rtk_affine_vector(m, x, y, z, out);
}

/* World box of an instance: the mesh box's eight corners mapped in double,
 * rounded outwards to float and widened by a few ulps, so that a ray the
 * mesh's own traversal would hit is never culled at the top level. */
static rtk_bounds instance_bounds(const rtk_instance *in, rtk_bounds b)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int corner = 0; corner < 8; corner++) {
        double p[3];
        apply_point(in->to_world, corner & 1 ? b.upper.x : b.lower.x, corner & 2 ? b.upper.y : b.lower.y,
                    corner & 4 ? b.upper.z : b.lower.z, p);
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], p[k]);
            hi[k] = fmax(hi[k], p[k]);
        }
    }
    float l[3], h[3];
    for (int k = 0; k < 3; k++) {
        l[k] = (float)lo[k];
        h[k] = (float)hi[k];
        for (int step = 0; step < 4; step++) {
            l[k] = nextafterf(l[k], -INFINITY);
            h[k] = nextafterf(h[k], INFINITY);
        }
    }
    rtk_bounds out = {rtk_vec3_make(l[0], l[1], l[2]), rtk_vec3_make(h[0], h[1], h[2])};
    return out;
}

rtk_status rtk_instances_finish(rtk_scene *scene)
{
    for (uint32_t i = 0; i < scene->mesh_count; i++) {
        rtk_scene *mesh = scene->meshes[i];
        if (mesh->finished)
            continue;
        if (mesh->owner) {
            mesh->materials = mesh->owner->materials;
            mesh->material_count = mesh->owner->material_count;
            mesh->textures = mesh->owner->textures;
            mesh->texture_count = mesh->owner->texture_count;
        }
        rtk_status st = rtk_scene_finish(mesh);
        if (st != RTK_OK)
            return st;
        /* Camera rays test sides when any placed mesh is single-sided. */
        scene->single_sided |= mesh->single_sided;
    }
    uint32_t kept = 0;
    for (uint32_t i = 0; i < scene->instance_count; i++) {
        rtk_instance in = scene->instances[i];
        const rtk_scene *mesh = scene->meshes[in.mesh];
        if (mesh->triangle_count == 0)
            continue;
        in.bounds = instance_bounds(&in, mesh->bounds);
        memset(&in.box, 0, sizeof in.box);
        for (int k = 0; k < 3; k++) {
            in.box.lower[k] = k == 0 ? in.bounds.lower.x : k == 1 ? in.bounds.lower.y : in.bounds.lower.z;
            in.box.upper[k] = k == 0 ? in.bounds.upper.x : k == 1 ? in.bounds.upper.y : in.bounds.upper.z;
        }
        scene->bounds.lower = rtk_vec3_make(fminf(scene->bounds.lower.x, in.bounds.lower.x),
                                            fminf(scene->bounds.lower.y, in.bounds.lower.y),
                                            fminf(scene->bounds.lower.z, in.bounds.lower.z));
        scene->bounds.upper = rtk_vec3_make(fmaxf(scene->bounds.upper.x, in.bounds.upper.x),
                                            fmaxf(scene->bounds.upper.y, in.bounds.upper.y),
                                            fmaxf(scene->bounds.upper.z, in.bounds.upper.z));
        scene->instances[kept++] = in;
    }
    if (kept != scene->instance_count)
        rtk_log(RTK_LOG_WARN, "%s: dropped %u instance%s of meshes without triangles", scene->path,
                scene->instance_count - kept, scene->instance_count - kept == 1 ? "" : "s");
    scene->instance_count = kept;
    free(scene->placements);
    scene->placements = kept ? rtk_alloc(sizeof *scene->placements * kept) : NULL;
    if (kept && !scene->placements)
        return rtk_error(RTK_ERR_NOMEM, "%s: out of memory for %u instances", scene->path, kept);
    for (uint32_t i = 0; i < kept; i++) {
        const rtk_instance *in = &scene->instances[i];
        rtk_device_instance *p = &scene->placements[i];
        memcpy(p->to_object, in->to_object, sizeof p->to_object);
        p->box = in->box;
        p->mesh = in->mesh;
        p->reserved = 0;
    }
    return RTK_OK;
}

void rtk_instances_free(rtk_scene *scene)
{
    for (uint32_t i = 0; i < scene->mesh_count; i++)
        rtk_scene_free(scene->meshes[i]);
    free(scene->meshes);
    free(scene->instances);
    free(scene->placements);
    free(scene->tlas_nodes);
    free(scene->tlas_order);
    scene->meshes = NULL;
    scene->instances = NULL;
    scene->placements = NULL;
    scene->tlas_nodes = NULL;
    scene->tlas_order = NULL;
    scene->mesh_count = scene->mesh_cap = scene->instance_count = scene->instance_cap = 0;
    scene->tlas_node_count = scene->tlas_depth = 0;
}

/* The top level: the accelerator's tree over the instances' boxes. */
static rtk_status build_top(rtk_scene *s, const rtk_plugin *plugin, const rtk_params *params, uint32_t threads)
{
    free(s->tlas_nodes);
    free(s->tlas_order);
    s->tlas_nodes = NULL, s->tlas_order = NULL;
    s->tlas_node_count = s->tlas_depth = 0;
    uint32_t n = s->instance_count;
    if (n == 0)
        return RTK_OK;
    rtk_build_args a;
    memset(&a, 0, sizeof a);
    a.size = sizeof a;
    a.prim_count = n;
    a.max_nodes = 2 * n - 1;
    a.thread_count = threads ? threads : 1;
    rtk_bounds *bounds = rtk_alloc(sizeof *bounds * n);
    rtk_vec3 *centroids = rtk_alloc(sizeof *centroids * n);
    a.nodes = rtk_calloc(a.max_nodes, sizeof *a.nodes);
    a.prim_order = rtk_calloc(n, sizeof *a.prim_order);
    rtk_status st = RTK_OK;
    if (!bounds || !centroids || !a.nodes || !a.prim_order) {
        st = RTK_ERR_NOMEM;
        goto done;
    }
    for (uint32_t i = 0; i < n; i++) {
        bounds[i] = s->instances[i].bounds;
        centroids[i] = rtk_vec3_scale(rtk_vec3_add(bounds[i].lower, bounds[i].upper), 0.5f);
    }
    a.prim_bounds = bounds;
    a.centroids = centroids;
    const rtk_accelerator_fns *fns = plugin->functions;
    void *state = NULL;
    if ((st = fns->create(params, &state)) != RTK_OK) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", rtk_error_message());
        st = rtk_error(st, "accelerator '%s' failed to start: %s", plugin->name, msg);
        goto done;
    }
    st = fns->build(state, &a);
    fns->destroy(state);
    if (st == RTK_OK)
        st = rtk_bvh_validate(&a, 1, &s->tlas_depth);
    if (st != RTK_OK) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", rtk_error_message());
        st = rtk_error(st, "accelerator '%s' failed on the top level over %u instances: %s", plugin->name, n, msg);
        goto done;
    }
    s->tlas_nodes = a.nodes;
    s->tlas_node_count = a.node_count;
    s->tlas_order = a.prim_order;
    a.nodes = NULL;
    a.prim_order = NULL;
done:
    free(bounds);
    free(centroids);
    free(a.nodes);
    free(a.prim_order);
    return st;
}

rtk_status rtk_instances_build(rtk_scene *s, const rtk_plugin *plugin, const rtk_params *params, uint32_t threads,
                               const char *dir, int *from_cache)
{
    if (rtk_accelerator_is_device(plugin)) {
        rtk_bvh_cache_use use;
        rtk_status st = rtk_device_build(s, plugin, params, threads, dir, dir ? &use : NULL);
        if (st == RTK_OK && from_cache)
            *from_cache = dir && use.from_cache;
        return st;
    }
    if (rtk_accelerator_traverses_itself(plugin))
        return rtk_error(RTK_ERR_UNSUPPORTED,
                         "%s: the scene has %u instances, and accelerator '%s' traverses with its own code, which "
                         "rtk cannot nest under a top level: pick median, sah or lbvh",
                         s->path, s->instance_count, plugin->name);
    /* Phases: the scene's own triangles and every mesh append to the
     * scene's log, so that a phase's time is its sum over the meshes; the
     * top level is one phase (its builder's marks are not recorded). */
    rtk_build_log *log = s->build_log;
    rtk_build_log_begin(log);
    int all_cached = 1;
    rtk_bvh_cache_use use;
    rtk_status st = RTK_OK;
    if (s->triangle_count) {
        st = rtk_bvh_build_cached_own(s, plugin, params, threads, dir, &use);
        all_cached &= st == RTK_OK && use.from_cache;
    }
    for (uint32_t i = 0; i < s->mesh_count && st == RTK_OK; i++) {
        rtk_scene *mesh = s->meshes[i];
        mesh->build_log = log;
        st = rtk_bvh_build_cached_own(mesh, plugin, params, threads, dir, &use);
        mesh->build_log = NULL;
        all_cached &= st == RTK_OK && use.from_cache;
    }
    if (st == RTK_OK && from_cache)
        *from_cache = all_cached && dir;
    if (st == RTK_OK) {
        rtk_build_log_mark(log, "instances: top level", threads > 1 ? -1 : 0, 0);
        st = build_top(s, plugin, params, threads);
    }
    rtk_build_log_end(log);
    return st;
}

int rtk_instance_local_ray(const rtk_instance *in, const rtk_ray *r, rtk_ray *out)
{
    return rtk_local_ray(in->to_object, r, out);
}

/* two_level.h's view of scene s. */
static rtk_two_level top_level(const rtk_scene *s)
{
    const rtk_two_level tl = {s->triangle_count > 0, s->tlas_nodes, s->tlas_node_count, s->tlas_order,
                              s->placements};
    return tl;
}

/* The meshes' traversals for two_level.h: the scene's own trees. */
static int mesh_closest(const void *ctx, uint32_t mesh, const rtk_ray *ray, rtk_hit *hit, rtk_trace_work *work)
{
    const rtk_scene *s = ctx;
    return rtk_bvh_closest_own(mesh == RTK_INVALID_ID ? s : s->meshes[mesh], ray, hit, work);
}

static int mesh_any(const void *ctx, uint32_t mesh, const rtk_ray *ray, rtk_trace_work *work)
{
    const rtk_scene *s = ctx;
    return rtk_bvh_any_own(mesh == RTK_INVALID_ID ? s : s->meshes[mesh], ray, work);
}

int rtk_instances_closest(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit, rtk_trace_work *work)
{
    const rtk_two_level tl = top_level(s);
    return work ? rtk_two_level_closest(&tl, mesh_closest, s, ray, hit, work)
                : rtk_two_level_closest(&tl, mesh_closest, s, ray, hit, NULL);
}

int rtk_instances_any(const rtk_scene *s, const rtk_ray *ray, rtk_trace_work *work)
{
    const rtk_two_level tl = top_level(s);
    return work ? rtk_two_level_any(&tl, mesh_any, s, ray, work) : rtk_two_level_any(&tl, mesh_any, s, ray, NULL);
}

static rtk_vec3 to_float3(const double v[3])
{
    return rtk_vec3_make((float)v[0], (float)v[1], (float)v[2]);
}

void rtk_instance_triangle(const rtk_scene *s, uint32_t inst, uint32_t prim, rtk_vec3 *a, rtk_vec3 *b, rtk_vec3 *c)
{
    const rtk_instance *in = &s->instances[inst];
    rtk_vec3 v[3];
    rtk_scene_triangle(s->meshes[in->mesh], prim, &v[0], &v[1], &v[2]);
    double w[3][3];
    for (int k = 0; k < 3; k++)
        apply_point(in->to_world, v[k].x, v[k].y, v[k].z, w[k]);
    *a = to_float3(w[0]);
    *b = to_float3(w[1]);
    *c = to_float3(w[2]);
}

/* A normal through the instance: the inverse transpose, normalised. */
static rtk_vec3 world_normal(const rtk_instance *in, rtk_vec3 n)
{
    const double *m = in->to_object;
    double w[3];
    for (int k = 0; k < 3; k++)
        w[k] = m[k] * n.x + m[4 + k] * n.y + m[8 + k] * n.z;
    return rtk_vec3_normalize(to_float3(w));
}

void rtk_instance_surface(const rtk_scene *s, const rtk_ray *ray, const rtk_ray_differential *diff, const rtk_hit *hit,
                          rtk_surface *out)
{
    const rtk_instance *in = &s->instances[hit->inst];
    rtk_ray lr;
    double d[3];
    apply_vector(in->to_object, ray->dir.x, ray->dir.y, ray->dir.z, d);
    lr.org = rtk_vec3_make(0.0f, 0.0f, 0.0f);
    lr.dir = to_float3(d);
    lr.tmin = ray->tmin;
    lr.tmax = ray->tmax;
    rtk_hit local = *hit;
    local.inst = RTK_INVALID_ID;
    /* The differential rays go to object space as the ray does; the
     * footprint measured there is the world one (an affine invariant). */
    rtk_ray_differential ld;
    rtk_ray lx, ly;
    int local_diff = 0;
    if (diff) {
        rtk_ray rx = {diff->rx_org, 0.0f, diff->rx_dir, INFINITY}, ry = {diff->ry_org, 0.0f, diff->ry_dir, INFINITY};
        local_diff = rtk_instance_local_ray(in, &rx, &lx) && rtk_instance_local_ray(in, &ry, &ly);
        if (local_diff)
            ld.rx_org = lx.org, ld.rx_dir = lx.dir, ld.ry_org = ly.org, ld.ry_dir = ly.dir;
    }
    rtk_surface_at_footprint(s->meshes[in->mesh], &lr, local_diff ? &ld : NULL, &local, out);
    double p[3];
    apply_point(in->to_world, out->p.x, out->p.y, out->p.z, p);
    out->p = to_float3(p);
    out->ng = world_normal(in, out->ng);
    out->ns = world_normal(in, out->ns);
    /* front_face needs no change: the normal goes through the inverse
     * transpose, so its side of the ray is the one it had in object space,
     * and a mirroring transform keeps the authored side as the front, as
     * glTF asks and as the flattening loader does by swapping corners. */
}

static size_t own_geometry_bytes(const rtk_scene *s)
{
    size_t t = s->triangle_count;
    size_t bytes = (size_t)s->vertex_count * 3 * sizeof(float) + t * 3 * sizeof(uint32_t);
    if (s->normals)
        bytes += t * 9 * sizeof(float);
    if (s->uvs)
        bytes += t * 6 * sizeof(float);
    if (s->uvs1)
        bytes += t * 6 * sizeof(float);
    if (s->colors)
        bytes += t * 12 * sizeof(float);
    if (s->tri_material)
        bytes += t * sizeof(uint32_t);
    return bytes;
}

static size_t own_bvh_bytes(const rtk_scene *s)
{
    size_t bytes = (size_t)s->node_count * sizeof(rtk_bvh_node);
    if (s->prim_ids)
        bytes += (size_t)s->triangle_count * sizeof(uint32_t);
    if (s->wide)
        bytes += (size_t)s->wide->node_count * sizeof(rtk_wide_node) +
                 (size_t)s->wide->tri_block_count * sizeof(rtk_wide_tris);
    return bytes;
}

void rtk_scene_memory(const rtk_scene *s, size_t *geometry, size_t *bvh, size_t *instances)
{
    *geometry = own_geometry_bytes(s);
    *bvh = own_bvh_bytes(s);
    for (uint32_t i = 0; i < s->mesh_count; i++) {
        *geometry += own_geometry_bytes(s->meshes[i]);
        *bvh += own_bvh_bytes(s->meshes[i]);
    }
    *instances = (size_t)s->instance_count * (sizeof(rtk_instance) + sizeof(rtk_device_instance)) +
                 (size_t)s->tlas_node_count * sizeof(rtk_bvh_node) + (size_t)s->instance_count * sizeof(uint32_t);
}
