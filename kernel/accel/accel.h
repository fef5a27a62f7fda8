/* Acceleration structures: building and checking BVHs through an
 * accelerator plugin (bvh.c), the wide BVH (bvh_wide.h), the BVH cache
 * (bvh_cache.h) and two-level instancing (instance.c). */
#ifndef RTK_KERNEL_ACCEL_H
#define RTK_KERNEL_ACCEL_H

#include "../scene/scene.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

RTK_EXTERN_C_BEGIN

/* ---- instancing (instance.c) ---- */

/* A new, empty mesh for scene to instance; it shares scene's materials and
 * textures (same material indices) and is finished with it. [owned by scene] */
RTK_KERNEL_API rtk_status rtk_scene_add_mesh(rtk_scene *scene, const char *name, uint32_t *index);
/* Places mesh by to_world (3x4 row-major, see rtk_instance). Rejects a
 * non-finite or singular transform, naming where. */
RTK_KERNEL_API rtk_status rtk_scene_add_instance(rtk_scene *scene, uint32_t mesh, const double to_world[12], const char *where);
/* Places the model in path (loaded once per path, with scene's needs, its
 * own materials and textures) by to_world. */
rtk_status rtk_scene_instance_file(rtk_scene *scene, const char *path, const double to_world[12],
                                   const char *where);
/* Finishes the meshes not yet finished, drops instances of empty meshes
 * (one warning), computes the instances' world boxes and grows the
 * scene's bounds by them. Run by rtk_scene_finish and after adding
 * instances to a finished scene. */
rtk_status rtk_instances_finish(rtk_scene *scene);
/* Builds the BVH of every mesh (through the cache in dir, NULL = off) and
 * the top level over the instances with the same accelerator, which must
 * use the kernel's traversal. */
RTK_KERNEL_API rtk_status rtk_instances_build(rtk_scene *scene, const rtk_plugin *accelerator, const rtk_params *params,
                                              uint32_t threads, const char *dir, int *from_cache);
/* Frees meshes, instances and the top level. */
void rtk_instances_free(rtk_scene *scene);
/* Two-level traversal: the scene's own triangles, then the instances.
 * Equal distances go to the own triangles, then to the lowest instance,
 * then to the lowest triangle id. work, if not NULL, gets the counts of
 * both levels. [any thread] */
int rtk_instances_closest(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit, rtk_trace_work *work);
int rtk_instances_any(const rtk_scene *s, const rtk_ray *ray, rtk_trace_work *work);
/* rtk_surface_at_footprint for a hit on an instance (diff may be NULL):
 * the mesh's surface in world space. */
void rtk_instance_surface(const rtk_scene *s, const rtk_ray *ray, const rtk_ray_differential *diff, const rtk_hit *hit,
                          rtk_surface *out);
/* The ray in instance in's object space (transformed in double, t kept as
 * the parameter); 0 when it is not a usable ray there (a transform too
 * small or large for float). */
RTK_KERNEL_API int rtk_instance_local_ray(const rtk_instance *in, const rtk_ray *r, rtk_ray *out);
/* World-space corners of triangle prim of instance inst, in the mesh's
 * order (so the winding turns around when the instance is mirrored). */
RTK_KERNEL_API void rtk_instance_triangle(const rtk_scene *s, uint32_t inst, uint32_t prim, rtk_vec3 *a, rtk_vec3 *b, rtk_vec3 *c);
/* Bytes of geometry, BVH and instance records (the top level included),
 * counting each mesh once. */
RTK_KERNEL_API void rtk_scene_memory(const rtk_scene *s, size_t *geometry, size_t *bvh, size_t *instances);

/* ---- device accelerators (device.c) ---- */

struct rtk_bvh_cache_use; /* bvh_cache.h */

/* 1 when accelerator is a device accelerator (ABI 3.5: it sets attach). */
RTK_KERNEL_API int rtk_accelerator_is_device(const rtk_plugin *accelerator);
/* Starts the device accelerator (first, so that a missing device fails
 * before any build), builds s's trees (instances too) with the accelerator
 * its parameter "builder" names (from the plugin directories rtk searches
 * by default and RTK_PLUGIN_PATH; its default parameters; through the
 * cache in dir when dir and use are not NULL) and hands them to the device.
 * Refuses scenes with alpha cut-outs. */
rtk_status rtk_device_build(rtk_scene *s, const rtk_plugin *device, const rtk_params *params, uint32_t threads,
                            const char *dir, struct rtk_bvh_cache_use *use);
/* Why accelerator cannot build a device's tree ("builds no tree", "keeps
 * its tree to itself"), or NULL when it can (it builds the kernel's). */
const char *rtk_builder_unfit(const rtk_plugin *accelerator);
/* Whether device accelerator device starts here with params: RTK_OK, or
 * its error (the message says why). Starts and stops it. */
RTK_KERNEL_API rtk_status rtk_device_probe(const rtk_plugin *device, const rtk_params *params);
/* Destroys s's device accelerator, if any, and what it was given. */
void rtk_device_release(rtk_scene *s);
/* The report of the device accelerator tracing s's batches: 1, or 0 when
 * none does (out untouched). [any thread] */
RTK_KERNEL_API int rtk_device_report_of(const rtk_scene *s, rtk_device_report *out);
/* NULL when s's device accelerator runs program on s (rtk_shade_batch,
 * ABI 3.6), else why not, in a phrase. [main thread] */
RTK_KERNEL_API const char *rtk_device_runs(const rtk_scene *s, const rtk_device_program *program);
/* s's own tree (no top level) as device_build hands it to a device, its
 * lights included, its corners and materials' base colours in *block
 * [caller frees]. Whoever makes it s's device sets s->device_lights to
 * out->lights' stamp. */
RTK_KERNEL_API rtk_status rtk_device_tree_view(const rtk_scene *s, uint32_t threads, rtk_device_tree *out,
                                               void **block);
/* Whether some texture that s's device programs read is filtered
 * trilinearly: their batches then carry camera differentials. */
int rtk_device_reads_footprints(const rtk_scene *s);
/* Runs batch->program on s's device (rtk_device_runs said yes). [any thread] */
rtk_status rtk_device_shade(const rtk_scene *s, rtk_shade_batch *batch);

/* ---- build phases (build_phase.c) ---- */

/* Phases a build log keeps; marks of further phases are counted, their
 * time goes to the last phase kept. */
#define RTK_BUILD_LOG_MAX 64
/* One phase: name (a static string), wall-clock seconds, and where it ran. */
typedef struct rtk_build_phase_time {
    const char *name;
    double seconds;
    int parallel;   /* 1: on several threads, 0: on one, -1: not known */
    int builder;    /* marked by the builder (rtk_build_phase), not the kernel */
    uint32_t marks; /* times it was marked (the meshes of an instanced scene) */
} rtk_build_phase_time;
/* A build's phases in the order they first ran (CLOCK_MONOTONIC), as
 * rtk_bvh_build records them into scene->build_log; a phase marked again
 * with the same name and flags adds to its entry. A build inside
 * another's (an instanced scene's meshes) adds to the open log. A zeroed
 * log is closed. [one build at a time] */
typedef struct rtk_build_log {
    rtk_build_phase_time phases[RTK_BUILD_LOG_MAX];
    uint32_t count;
    uint32_t dropped;  /* marks of phases past RTK_BUILD_LOG_MAX */
    double seconds;    /* from the outermost begin to its end */
    double begun, at;  /* when the build and the open phase started */
    uint32_t open;     /* the entry of the open phase (count: none yet) */
    uint32_t depth;    /* builds open (0: closed, marks are ignored) */
} rtk_build_log;
/* Opens log for a build (NULL: nothing): clears it unless a build is
 * already open, whose log it then extends. */
RTK_KERNEL_API void rtk_build_log_begin(rtk_build_log *log);
/* Ends the open phase and starts phase name (parallel as in
 * rtk_build_phase_time); nothing when log is NULL or closed. */
RTK_KERNEL_API void rtk_build_log_mark(rtk_build_log *log, const char *name, int parallel, int builder);
/* Ends the build that rtk_build_log_begin opened: the outermost closes
 * the open phase and sets seconds. */
RTK_KERNEL_API void rtk_build_log_end(rtk_build_log *log);
/* 1 when rtk_parallel_ranges(n, threads, min_chunk, ...) runs on
 * several threads: a phase's parallel flag. */
int rtk_ranges_parallel(uint32_t n, uint32_t threads, uint32_t min_chunk);

/* ---- BVH (bvh.c) ---- */

/* Builds scene's BVH with an accelerator plugin, checks the tree the plugin
 * returned, and lays triangles out in leaf order. */
RTK_KERNEL_API rtk_status rtk_bvh_build(rtk_scene *scene, const rtk_plugin *accelerator, const rtk_params *params,
                                        uint32_t threads);
/* Destroys an accelerator instance that traverses itself, if any. */
RTK_KERNEL_API void rtk_bvh_release(rtk_scene *scene);

/* One scene's tree, moved out of it: the binary nodes and leaf order, the
 * wide tree, an own-traversal accelerator's state, a device's. */
typedef struct rtk_tree_slot {
    rtk_bvh_node *nodes;
    uint32_t node_count, bvh_depth;
    uint32_t *prim_ids;
    const rtk_accelerator_fns *own_traversal;
    void *own_state;
    struct rtk_wide_bvh *wide;
    const rtk_accelerator_fns *device;
    void *device_state;
    void *device_data;
    uint64_t device_lights;
    uint32_t device_minor;
} rtk_tree_slot;

/* Everything an accelerator built for a scene (its tree, its instanced
 * meshes' trees, the top level), held outside the scene so that another
 * accelerator can build there and either can be swapped in again to
 * trace: `rtk bench` keeps every accelerator's trees at once and
 * alternates their passes. A set is made for one scene (room for its
 * meshes' trees), swapped only with that scene, and freed before it (an
 * own-traversal accelerator may share the scene's arrays). */
typedef struct rtk_accel_set {
    rtk_tree_slot *trees; /* the scene's, then each instanced mesh's */
    uint32_t tree_count;
    rtk_bvh_node *tlas_nodes;
    uint32_t tlas_node_count, tlas_depth;
    uint32_t *tlas_order;
} rtk_accel_set;

/* An empty set with room for scene's trees (RTK_ERR_NOMEM). */
RTK_KERNEL_API rtk_status rtk_accel_set_init(rtk_accel_set *set, const rtk_scene *scene);
/* Exchanges scene's trees with set's: a scene without trees and a full set
 * trade places, and the other way round. */
RTK_KERNEL_API void rtk_accel_swap(rtk_scene *scene, rtk_accel_set *set);
/* Frees set's trees and room; set is left empty. */
RTK_KERNEL_API void rtk_accel_set_free(rtk_accel_set *set);
/* Structural check of a builder's output against args: every primitive in
 * exactly one leaf, indices in range, every node reached once from the
 * root, inner bounds enclosing their children, and with leaf_bounds set,
 * leaf bounds enclosing their primitives' prim_bounds. Sets the depth. */
rtk_status rtk_bvh_validate(const rtk_build_args *args, int leaf_bounds, uint32_t *depth);
/* rtk_bvh_validate of s's tree (nodes, node_count, prim_ids) on threads,
 * as rtk_bvh_build checks a builder's: the message of a fault. */
rtk_status rtk_bvh_validate_scene(const rtk_scene *s, uint32_t threads, uint32_t *depth);
/* The same checks done node by node by a walk of another pass (the wide
 * collapse's plan), quietly: the marks shared by the walks (nodes and
 * slots, relaxed atomics), a bit set of primitives per walk. A walk
 * that meets a fault stops; the caller then runs rtk_bvh_validate_scene
 * for the message. */
#define RTK_TREE_CHECK_MAX_SETS 65u /* walks with a bit set of their own: a top walk and 64 threads */
typedef struct rtk_tree_check {
    const rtk_bvh_node *nodes;
    const uint32_t *prim_order;
    uint32_t node_count, prim_count;
    uint8_t *seen_node, *seen_slot;
    uint64_t *prim_bits; /* sets bit sets of words each; the block that holds the marks too */
    size_t words;
    uint32_t sets;
} rtk_tree_check;
/* One walk's marks of primitives and counts. */
typedef struct rtk_tree_tally {
    uint64_t *prim_bits;
    uint32_t reached, covered, max_depth;
} rtk_tree_tally;
/* Marks for a tree of node_count >= 1 nodes and walks with sets bit sets
 * (at most RTK_TREE_CHECK_MAX_SETS), zeroed on up to threads threads.
 * 0 when out of memory. */
int rtk_tree_check_init(rtk_tree_check *check, const rtk_bvh_node *nodes, uint32_t node_count,
                        const uint32_t *prim_order, uint32_t prim_count, uint32_t sets, uint32_t threads);
void rtk_tree_check_free(rtk_tree_check *check);
/* A walk's tally, with bit set number set. [one walk a set] */
void rtk_tree_tally_init(const rtk_tree_check *check, uint32_t set, rtk_tree_tally *tally);
/* Marks node id, at depth (the root at 1), and checks it: bounds without
 * NaN, a leaf's slots and primitives in range and met once, an inner
 * node's children in range and inside its box, so that its children may
 * be read next. 1 when sound. */
int rtk_tree_check_node(const rtk_tree_check *check, rtk_tree_tally *tally, uint32_t id, uint32_t depth);
/* Adds a tally's counts to sums and a maximum shared by walks (atomic). */
void rtk_tree_tally_add(const rtk_tree_tally *tally, uint32_t *covered, uint32_t *reached, uint32_t *max_depth);
/* After the walks, whether their counts and marks cover the tree exactly:
 * every node and slot once, the primitives' bit sets a partition; the
 * marks scanned on up to threads threads. */
int rtk_tree_check_whole(const rtk_tree_check *check, uint32_t reached, uint32_t covered, uint32_t threads);
/* The leaf check left out above, for triangles: every leaf of s's tree
 * (its structure validated) against its triangles' corners. Leaves are
 * split over threads; the lowest failing leaf is reported. */
rtk_status rtk_bvh_check_leaves(const rtk_scene *s, uint32_t threads);
/* RTK_ERR_PLUGIN with the message of a failed check of leaf (the first
 * triangle it does not enclose). */
rtk_status rtk_bvh_leaf_error(const rtk_scene *s, uint32_t leaf);
/* Ends a build or cache load of s's tree: the wide tree, which checks the
 * leaves as it gathers their corners (spare as rtk_wide_build takes it)
 * and, unless validated says the structure was, validates it as it plans
 * the collapse (setting s->bvh_depth); or validation and the leaf check
 * alone for a plugin's own traversal or when the collapse fails (warned:
 * binary traversal). RTK_ERR_PLUGIN when the tree fails (s->wide left
 * NULL). */
rtk_status rtk_bvh_finish(rtk_scene *s, uint32_t threads, void *spare, size_t spare_bytes, int validated);
/* Traversal of the whole scene, instances included. Return 1 on hit. */
RTK_KERNEL_API int rtk_bvh_closest(const rtk_scene *scene, const rtk_ray *ray, rtk_hit *hit);
RTK_KERNEL_API int rtk_bvh_any(const rtk_scene *scene, const rtk_ray *ray);
/* rtk_bvh_closest / rtk_bvh_any on count valid rays: hits[i] as
 * rtk_bvh_closest fills it for rays[i] (prim RTK_INVALID_ID on a miss),
 * occluded[i] 0 or 1. Through the plugin's batch functions, the wide
 * tree's packets (bvh_wide.h) or one ray at a time. The thread's camera
 * ray mark (rtk_alpha_camera_ray) holds for every ray. [any thread] */
RTK_KERNEL_API void rtk_bvh_closest_batch(const rtk_scene *scene, const rtk_ray *rays, uint32_t count, rtk_hit *hits);
RTK_KERNEL_API void rtk_bvh_any_batch(const rtk_scene *scene, const rtk_ray *rays, uint32_t count, uint8_t *occluded);
/* Traversal of the scene's own triangles only (hit->inst is not set);
 * work, if not NULL, receives the counts. */
int rtk_bvh_closest_own(const rtk_scene *scene, const rtk_ray *ray, rtk_hit *hit, rtk_trace_work *work);
int rtk_bvh_any_own(const rtk_scene *scene, const rtk_ray *ray, rtk_trace_work *work);
/* 1 when the accelerator supplies its own traversal (closest and any). */
RTK_KERNEL_API int rtk_accelerator_traverses_itself(const rtk_plugin *accelerator);
/* The accelerator's RTK_BUILD_* flags (0 for a table older than them). */
uint32_t rtk_accelerator_build_flags(const rtk_plugin *accelerator);
/* A builder's inputs for s's triangles, as rtk_bvh_build makes them, on
 * up to threads threads: each triangle's bounds and their centre (both
 * NULL, or both filled) and its three corners (vertices, NULL or filled). */
void rtk_bvh_prepare_inputs(const rtk_scene *s, uint32_t threads, rtk_bounds *bounds, rtk_vec3 *centroids,
                            rtk_vec3 *vertices);
/* 1 if ray has finite origin/direction, non-zero direction, tmin <= tmax. */
int rtk_ray_valid(const rtk_ray *ray);

/* One coordinate of rtk_offset_ray_origin (Waechter and Binder 2019, Ray
 * Tracing Gems ch. 6): a fixed step near 0, else n x 256 ulps. */
RTK_HD static inline float rtk_offset_component(float p, float n)
{
    const float origin = 1.0f / 32.0f, float_scale = 1.0f / 65536.0f, int_scale = 256.0f;
    if (fabsf(p) < origin)
        return p + float_scale * n;
    int32_t of = (int32_t)(int_scale * n);
    int32_t bits;
    memcpy(&bits, &p, sizeof bits);
    bits += p < 0.0f ? -of : of;
    float out;
    memcpy(&out, &bits, sizeof out);
    return out;
}

/* rtk_offset_ray_origin inlined, for the kernel's own shadow rays. */
RTK_HD static inline rtk_vec3 rtk_offset_point(rtk_vec3 p, rtk_vec3 n)
{
    return rtk_vec3_make(rtk_offset_component(p.x, n.x), rtk_offset_component(p.y, n.y),
                         rtk_offset_component(p.z, n.z));
}

#include "bvh_wide.h"
#include "bvh_cache.h"

RTK_EXTERN_C_END

#endif
