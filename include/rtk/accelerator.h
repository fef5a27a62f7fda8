/* Accelerator plugins build a BVH into the kernel's node format; the
 * kernel validates the result, reorders triangles and traverses it, so
 * builders compare on tree quality alone. A plugin may instead supply its
 * own traversal (closest, any), as a yardstick such as Embree. */
#ifndef RTK_ACCELERATOR_H
#define RTK_ACCELERATOR_H

#include <rtk/math.h>
#include <rtk/plugin.h>
#include <rtk/ray.h>

RTK_EXTERN_C_BEGIN

/* One node. count > 0: leaf over prim_order[offset, offset + count).
 * count == 0: inner node whose children are nodes offset and offset + 1.
 * The root is node 0; bounds enclose everything below. */
typedef struct rtk_bvh_node {
    float lower[3];
    uint32_t offset;
    float upper[3];
    uint32_t count;
} rtk_bvh_node;

/* Input and output of one build; arrays are kernel-owned. */
typedef struct rtk_build_args {
    uint32_t size;                 /* sizeof(rtk_build_args) */
    uint32_t prim_count;           /* >= 1 */
    const rtk_bounds *prim_bounds; /* bounds of each primitive */
    const rtk_vec3 *centroids;     /* centre of each primitive's bounds */
    uint32_t max_nodes;            /* capacity of nodes: 2 * prim_count - 1 */
    rtk_bvh_node *nodes;           /* out: the tree, root at 0 (given uncleared:
                                      write every node counted) */
    uint32_t node_count;           /* out: nodes used, each reachable from the root */
    uint32_t *prim_order;          /* out: permutation of 0 .. prim_count - 1 (given
                                      uncleared) */
    uint32_t thread_count;         /* threads the builder may use */
    const rtk_vec3 *vertices;      /* 3 per primitive: its triangle's corners; NULL
                                      when the primitives are instances (the top
                                      level of an instanced scene), whose boxes
                                      are all there is, and for builders that
                                      declare RTK_BUILD_NO_VERTICES */
    /* ABI 3.2. The triangles as the scene holds them (NULL when the
     * primitives are instances): primitive i has the vertices indices[3 i]
     * .. indices[3 i + 2], vertex j the floats positions[3 j] ..
     * positions[3 j + 2], and one float more follows the last vertex (a
     * 16-byte load of it stays in bounds). They live as long as the scene. */
    const uint32_t *indices;
    const float *positions;
    uint32_t vertex_count;
    /* ABI 3.2. Memory the builder may use as it likes during build (on a
     * 64-byte boundary; NULL and 0 when there is none): the kernel's, in
     * pages it writes anyway afterwards, so that a builder's scratch
     * arrays cost no first touch of their own. For builders that declare
     * RTK_BUILD_NO_VERTICES it is 36 bytes a primitive, less 64; with
     * RTK_BUILD_NO_BOUNDS too, 72 bytes a primitive, unless the
     * accelerator traverses itself (then there is none). */
    void *scratch;
    size_t scratch_bytes;
    /* ABI 3.4. The kernel's record of the build's phases (rtk_build_phase);
     * NULL when nobody records them. Builders pass args, never read it. */
    void *phase_log;
} rtk_build_args;

/* args->scratch when it holds bytes (and the kernel that made args knows
 * of scratch), else NULL: the builder then allocates its own. */
static inline void *rtk_build_scratch(const rtk_build_args *args, size_t bytes)
{
    if (args->size < offsetof(rtk_build_args, scratch_bytes) + sizeof args->scratch_bytes)
        return NULL;
    return args->scratch_bytes >= bytes ? args->scratch : NULL;
}

/* Marks the start of the build's phase name (a static string, e.g.
 * "morton sort") and whether it runs on parallel > 0 threads or on one
 * (parallel 0): the previous phase ends here, the last at the build's
 * return. `rtk bench --verbose` prints each phase's time and share, and
 * the serial fraction (one-thread phases over the whole build). Free when
 * nobody records (args->phase_log NULL, or args from an older kernel).
 * [main thread, the thread that called build] (ABI 3.4) */
RTK_API void rtk_build_phase(rtk_build_args *args, const char *name, int parallel);

/* Flags of rtk_accelerator_fns.build_flags. */
enum {
    /* build reads no args->vertices: the kernel passes NULL and does not
     * gather the corners (half of what it writes for the builder). */
    RTK_BUILD_NO_VERTICES = 1u,
    /* build reads neither args->prim_bounds nor args->centroids: the
     * kernel passes NULL for both and does not compute them (a builder
     * that reads the triangles from indices and positions). The
     * instances of a top level (indices NULL) come with both all the
     * same: their boxes are all there is. */
    RTK_BUILD_NO_BOUNDS = 2u,
    /* On more than one thread, build writes args->nodes sparsely: in
     * regions of which it fills a small part (a fifth or less) before it
     * closes the gaps. The kernel then keeps a large node array in 4 KiB
     * pages, where huge pages would be faulted in whole for the few
     * nodes in each (read by ABI 3.2 kernels and later; older ones ignore it). */
    RTK_BUILD_SPARSE_NODES = 4u
};

/* ABI 3.5. One placement of a mesh, as two-level traversal reads it. */
typedef struct rtk_device_instance {
    double to_object[12]; /* world -> the mesh's space, 3x4 row-major */
    rtk_bvh_node box;     /* its world box, as a node (offset and count 0) */
    uint32_t mesh;        /* which of rtk_device_tree.meshes */
    uint32_t reserved;    /* 0 */
} rtk_device_instance;

/* ABI 3.7. What device programs read of a placement besides
 * rtk_device_instance: where its surfaces go and which side they show. */
typedef struct rtk_device_frame {
    double to_world[12]; /* the mesh's space -> world, 3x4 row-major */
    uint32_t mirrored;   /* 1 when the transform mirrors (negative determinant) */
    uint32_t reserved;   /* 0 */
} rtk_device_frame;

/* ABI 3.5. The kernel's tree as a device accelerator receives it (see
 * rtk_accelerator_fns.attach); the arrays stay valid until its destroy.
 * An instanced scene's tree also has a top level over its instances, and
 * each placed mesh a tree of its own (meshes[i], whose tlas fields are
 * empty). */
typedef struct rtk_device_tree {
    uint32_t size;             /* sizeof(rtk_device_tree) */
    const rtk_bvh_node *nodes; /* the root at 0; node_count 0 when the scene
                                  has no triangles of its own (all placed) */
    uint32_t node_count;
    uint32_t depth;            /* levels, the root's included */
    const uint32_t *prim_ids;  /* leaf slot -> triangle id */
    const float *corners;      /* 9 floats a slot: triangle prim_ids[slot]'s corners */
    uint32_t slot_count;       /* triangles */
    const rtk_bvh_node *tlas_nodes; /* the top level (tlas_node_count 0: none) */
    uint32_t tlas_node_count;
    uint32_t tlas_depth;
    const uint32_t *tlas_order;     /* top-level leaf slot -> instance */
    const rtk_device_instance *instances;
    uint32_t instance_count;
    uint32_t mesh_count;
    const struct rtk_device_tree *meshes;
    /* ABI 3.6, for device programs: 9 floats a triangle id, its corners'
     * shading normals (NULL when the scene has none); where the
     * integrator reads materials, each triangle's material (an index
     * into base_colors; others mean the default material, whose colour
     * is rtk_shade_batch.albedo), each material's base colour and 12
     * floats a triangle, its corners' RGBA vertex colours (each NULL
     * when absent). */
    const float *normals;
    const uint32_t *tri_materials;
    const rtk_rgb *base_colors;
    uint32_t material_count;
    const float *colors;
    /* ABI 3.7, for device programs: where the integrator reads
     * materials, the materials themselves (the kernel's rtk_material,
     * kernel/scene/scene.h, material_count of them; their names mean
     * nothing on a device, their texture slots index textures below);
     * where it samples lights, the scene's lights as they were when the device took the tree (the
     * kernel's rtk_lights, kernel/scene/lights.h: light_of has slot_count
     * entries, inst_first instance_count; a placed mesh's own lights give
     * its light_of alone) and its punctual lights; each instance's frame
     * (instance_count of them). Each NULL, 0 when absent. */
    const struct rtk_material *materials;
    const struct rtk_lights *lights;
    const struct rtk_punctual_light *punctual;
    uint32_t punctual_count;
    const rtk_device_frame *frames;
    /* ABI 3.8, for device programs that read textures (where the
     * integrator reads them and the scene has texture coordinates): 6
     * floats a triangle id, its corners' texture coordinates (uvs1: the
     * second set, NULL when absent), and the textures that the materials'
     * slots index (the kernel's rtk_device_texture,
     * kernel/scene/texture.h, texture_count of them). NULL, 0
     * otherwise. */
    const float *uvs;
    const float *uvs1;
    const struct rtk_device_texture *textures;
    uint32_t texture_count;
    /* ABI 3.9, with textures: each texture's MIP levels (the kernel's
     * rtk_texture_level, kernel/scene/texture.h: level 0 first, its
     * rtk_device_texture.levels of them), NULL for one read at level 0
     * alone (any but a trilinear one). */
    const struct rtk_texture_level *const *texture_levels;
} rtk_device_tree;

/* ABI 3.5. What a device accelerator did so far, summed over its calls. */
typedef struct rtk_device_report {
    uint32_t size;             /* sizeof(rtk_device_report) */
    char device[128];          /* the processor, e.g. "NVIDIA H100 80GB HBM3" */
    double upload_seconds;     /* the tree, then rays, to the device */
    double trace_seconds;      /* traversal on the device */
    double download_seconds;   /* results back */
    uint64_t rays, batches;    /* traced on the device */
    uint64_t cpu_rays;         /* traced on the CPU after a device failure */
    uint64_t device_bytes;     /* device memory held now */
    /* ABI 3.6: camera samples shaded whole by device programs (their rays
     * count in rays), and the programs' time on the device. */
    uint64_t samples;
    double shade_seconds;
} rtk_device_report;

struct rtk_device_program;
struct rtk_li_result;
struct rtk_sample_gen;
struct rtk_sample_pos;

/* ABI 3.6. Camera samples for a device program (rtk_accelerator_fns.shade):
 * the kernel fills the inputs, shade fills out and the counts. The sampler
 * types are the kernel's (kernel/render/sample.h), which device
 * accelerators build with. */
typedef struct rtk_shade_batch {
    uint32_t size;                           /* sizeof(rtk_shade_batch) */
    const struct rtk_device_program *program;
    const struct rtk_sample_gen *gen;        /* the render's sample generator */
    rtk_rgb albedo;                          /* the default material's base colour */
    uint32_t count;
    const rtk_ray *rays;                     /* camera rays */
    const struct rtk_sample_pos *pos;        /* each sample's stream, at li's first draw */
    struct rtk_li_result *out;               /* set by shade: as li's pre-filled result, then by the program */
    uint64_t rays_traced, invalid_rays;      /* what rtk_trace and rtk_occluded would have counted */
    /* ABI 3.9: each camera ray's differentials (rtk_ctx_camera_differential),
     * where some texture the program reads is filtered trilinearly; else NULL. */
    const rtk_ray_differential *diffs;
} rtk_shade_batch;

/* Function table of an accelerator. */
typedef struct rtk_accelerator_fns {
    uint32_t size; /* sizeof(rtk_accelerator_fns) */
    /* Makes an instance from validated params. [main thread] */
    rtk_status (*create)(const rtk_params *params, void **state);
    /* Builds the tree into args on up to args->thread_count threads
     * (rtk_team_run). [main thread] */
    rtk_status (*build)(void *state, rtk_build_args *args);
    /* Frees the instance. [main thread] */
    void (*destroy)(void *state);
    /* Optional, both or neither: the plugin's own traversal. With
     * them, build need not emit nodes (node_count 0 is allowed), the
     * instance lives as long as the scene, and every trace goes through
     * them; hit->prim is the primitive's index in the build arguments.
     * [any thread, concurrently] */
    int (*closest)(const void *state, const rtk_ray *ray, rtk_hit *hit);
    int (*any)(const void *state, const rtk_ray *ray);
    /* RTK_BUILD_* flags (ABI 3.2; older plugins, whose table ends
     * before this, get the vertices). */
    uint32_t build_flags;
    /* ABI 3.4. Optional, both or neither, and only with closest and any:
     * the plugin's own traversal of count rays at once (rays valid, as
     * for closest and any), hits[i] / occluded[i] (0 or 1) as closest /
     * any would give them for rays[i]. Without them the kernel calls
     * closest and any once per ray. [any thread, concurrently] */
    void (*closest_batch)(const void *state, const rtk_ray *rays, uint32_t count, rtk_hit *hits);
    void (*any_batch)(const void *state, const rtk_ray *rays, uint32_t count, uint8_t *occluded);
    /* ABI 3.5. Optional, both or neither: a device accelerator, which
     * traces on another processor (a GPU) the tree another accelerator
     * built. It sets these, closest_batch and any_batch, leaves build,
     * closest and any NULL, and declares a string parameter "builder".
     * The kernel builds the scene's tree with the accelerator that
     * "builder" names (its default parameters, through the BVH cache when
     * one is on), hands it to attach [main thread], sends every batch to
     * closest_batch / any_batch and traces single rays itself over the
     * same tree with the same code (kernel/accel/slab.h), so both give
     * the same hits, instances included (kernel/accel/two_level.h).
     * Scenes with alpha cut-outs are refused. report fills out [any thread]. */
    rtk_status (*attach)(void *state, const rtk_device_tree *tree);
    void (*report)(const void *state, rtk_device_report *out);
    /* ABI 3.6, optional, device accelerators only: runs batch->program
     * (rtk_integrator_fns.device_program) on each camera sample of batch,
     * on the device, tracing the attached tree. RTK_ERR_UNSUPPORTED when
     * the program, or this scene, is not one it runs (a batch of count 0
     * asks without running anything); other errors end the render.
     * [any thread, concurrently] */
    rtk_status (*shade)(const void *state, rtk_shade_batch *batch);
} rtk_accelerator_fns;

RTK_EXTERN_C_END

#endif
