/* The scene module: materials, the scene's arrays and their builder
 * (scene_build.c), surface queries (scene.c), alpha cutouts and normal
 * maps, the OBJ and glTF loaders (io/), with the camera, textures, lights
 * and the file boundary in their own headers included here. */
#ifndef RTK_KERNEL_SCENE_H
#define RTK_KERNEL_SCENE_H

#include "../core/core.h"
#include "camera.h"
#include "files.h"
#include "texture.h"
#include "surface_geom.h"

RTK_EXTERN_C_BEGIN

/* ---- scene (scene_build.c, scene.c, io/obj.cpp, io/gltf.cpp) ---- */

/* How a texture use reads a triangle's texture coordinates: from uv set
 * set (0: the scene's uvs, glTF TEXCOORD_0; 1: uvs1, TEXCOORD_1), then,
 * when transformed, through the affine map u' = m[0] u + m[1] v + m[2],
 * v' = m[3] u + m[4] v + m[5] (glTF KHR_texture_transform). Zeroed = the
 * uvs as they are. */
typedef struct rtk_tex_map {
    uint8_t set, transformed;
    float m[6];
} rtk_tex_map;

/* Alpha handling of a material. */
typedef enum rtk_alpha_mode { RTK_ALPHA_OPAQUE = 0, RTK_ALPHA_MASK = 1, RTK_ALPHA_BLEND = 2 } rtk_alpha_mode;

/* One texture that multiplies a factor of the BSDF mapping (material.c):
 * the texture (index into scene->textures, or -1), the channel a scalar
 * factor reads (0-3: R, G, B, A; colour factors read RGB), and its wrap
 * modes and texture coordinates as for the other slots. */
typedef struct rtk_tex_slot {
    int tex;
    uint8_t channel;
    rtk_tex_wrap wrap;
    rtk_tex_map uv;
} rtk_tex_slot;

/* The factor textures of a material (rtk_material.maps). */
typedef enum rtk_material_map {
    RTK_MAP_SPECULAR_COLOR = 0, /* MTL map_Ks (x Ks, MTL model only); glTF specularColorTexture RGB */
    RTK_MAP_SHININESS = 1,      /* MTL map_Ns (x Ns) */
    RTK_MAP_ROUGHNESS = 2,      /* MTL map_Pr (x Pr); glTF metallicRoughnessTexture G (x roughnessFactor) */
    RTK_MAP_METALLIC = 3,       /* MTL map_Pm (x Pm); glTF metallicRoughnessTexture B (x metallicFactor) */
    RTK_MAP_TRANSMISSION = 4,   /* glTF transmissionTexture R (x transmissionFactor) */
    RTK_MAP_SPECULAR = 5,       /* glTF specularTexture A (x specularFactor) */
    RTK_MAP_COUNT = 6
} rtk_material_map;

/* Which rule of rtk_surface_bsdf maps a material to a BSDF (include/rtk/bsdf.h). */
typedef enum rtk_material_model {
    RTK_MODEL_DIFFUSE = 0,            /* Lambert of the base colour (the default, materials made in memory) */
    RTK_MODEL_MTL = 1,                /* MTL by illum: Kd, Ks, Ns, Ni, d, Tf */
    RTK_MODEL_METALLIC_ROUGHNESS = 2  /* glTF, and MTL with Pr, Pm, map_Pr or map_Pm */
} rtk_material_model;

/* A material, merged from MTL and glTF conventions. Texture fields are
 * indices into scene->textures, or -1. */
typedef struct rtk_material {
    char *name;
    rtk_rgb base_color;   /* Kd / baseColorFactor (linear) */
    float alpha;          /* d (or 1 - Tr) / baseColorFactor.a */
    rtk_rgb emission;     /* Ke / emissiveFactor x strength */
    rtk_rgb specular;     /* Ks */
    float shininess;      /* Ns */
    float ior;            /* Ni / KHR_materials_ior, default 1.5 */
    float metallic, roughness;
    float transmission;   /* KHR_materials_transmission */
    int illum;            /* MTL illumination model, -1 if none */
    rtk_alpha_mode alpha_mode;
    float alpha_cutoff;   /* for RTK_ALPHA_MASK, default 0.5 */
    int base_tex, alpha_tex, normal_tex, emission_tex;
    /* Wrap modes per texture slot: a glTF sampler or MTL -clamp belongs to
     * the use, not the image, so one decoded image serves every use. */
    rtk_tex_wrap base_wrap, alpha_wrap, normal_wrap, emission_wrap;
    /* Texture coordinates per slot, like the wrap modes. */
    rtk_tex_map base_uv, alpha_uv, normal_uv, emission_uv;
    int coverage;         /* glTF BLEND: alpha is the chance that a ray stops here (alpha.c) */
    int single_sided;     /* glTF doubleSided false: camera rays pass through its back (alpha.c) */
    rtk_material_model model;
    int has_illum;        /* MTL: an illum line was given (illum is 0 without one) */
    rtk_rgb filter;       /* MTL Tf (or Kt): the transmission's colour, when has_filter */
    int has_filter;
    rtk_rgb specular_color; /* KHR_materials_specular specularColorFactor, default white */
    float specular_weight;  /* KHR_materials_specular specularFactor, default 1 */
    rtk_tex_slot maps[RTK_MAP_COUNT]; /* factor textures, tex -1 when absent */
} rtk_material;

/* The texture coordinates map reads on triangle prim of s at barycentrics
 * (u, v) of its corners 1 and 2; (0, 0) when s keeps no uvs. (scene.c) */
rtk_vec2 rtk_tex_map_uv(const struct rtk_scene *s, const rtk_tex_map *map, uint32_t prim, float u, float v);
/* The base colour and alpha triangle prim's vertex colours (glTF COLOR_0)
 * give at barycentrics (u, v): white and 1 without them. (scene.c) */
void rtk_vertex_color(const struct rtk_scene *s, uint32_t prim, float u, float v, float rgba[4]);

/* Material defaults: white diffuse, alpha 1, ior 1.5, no textures. */
RTK_KERNEL_API rtk_material rtk_material_default(void);

/* Value v of key of a material of file path as a loader stores it: a
 * non-finite v gives fallback, a v outside [lo, hi] the nearer bound, each
 * with a warning naming the file, the material (material: its label, as
 * "material 'red'") and the key. (material.c) */
float rtk_material_value(const char *path, const char *material, const char *key, double v, float fallback, float lo,
                         float hi);
/* The same per channel of a colour (r, g, b), each within [lo, hi]. */
rtk_rgb rtk_material_rgb(const char *path, const char *material, const char *key, double r, double g, double b,
                         rtk_rgb fallback, float lo, float hi);

/* ---- normal maps (normalmap.c) ---- */

/* Checks once (at load) that tex can serve as a tangent-space normal map:
 * a grey image is a height map, warned about and not used. */
int rtk_normal_map_usable(rtk_texture *tex);
/* Bends the shading normal ns (unit, on the triangle's authored side) by
 * m's normal map at barycentrics (u, v) of triangle prim, in the tangent
 * frame derived from its positions and the normal map's texture
 * coordinates (m->normal_uv); returns 1 when it did. */
int rtk_apply_normal_map(const struct rtk_scene *s, const rtk_material *m, uint32_t prim, float u, float v,
                         rtk_vec3 *ns);

/* ---- alpha cutouts (alpha.c) ---- */

/* 1 when m cuts out, with its cutoff: MASK; glTF BLEND (coverage) with
 * alpha below 1 or a texture, cutoff -1 (stochastic: rtk_alpha_opaque);
 * other BLEND with a texture, at 0.5. */
int rtk_material_cutout(const rtk_material *m, float *cutoff);
/* Coverage of a texel of an alpha texture: its alpha channel when the
 * image has one that is not all 1, else its first channel (grey masks). */
float rtk_texture_coverage(const rtk_texture *tex, const float texel[4]);
/* Coverage of material m at texture coordinates (u, v): alpha factor x
 * the alpha texture, if decoded. */
float rtk_material_alpha(const struct rtk_scene *s, const rtk_material *m, float u, float v);
/* Whether ray's hit at barycentrics (u, v) on triangle prim counts: 1
 * unless its material cuts out and the coverage there is below the cutoff
 * (for coverage materials, below a number hashed from the ray and prim,
 * so that the same ray always decides the same), or the ray is a camera
 * ray (rtk_alpha_camera_ray) on the back of a single-sided material.
 * Traversal calls it only when scene->has_cutouts. [any thread] */
int rtk_alpha_opaque(const struct rtk_scene *s, const rtk_ray *ray, uint32_t prim, float u, float v);
/* Marks this thread's traversals as tracing a camera ray (on = 1) or not:
 * rtk_alpha_opaque then lets camera rays through the back of single-sided
 * triangles. Set by rtk_trace around a camera ray's traversal. */
void rtk_alpha_camera_ray(int on);

/* One placement of an instanced mesh. Transforms are 3x4, row-major:
 * x' = m[0] x + m[1] y + m[2] z + m[3], and so on. */
typedef struct rtk_instance {
    uint32_t mesh;        /* index into scene->meshes */
    int mirrored;         /* negative determinant: the front side flips (glTF) */
    double to_world[12];  /* object -> world */
    double to_object[12]; /* world -> object, the inverse */
    rtk_bounds bounds;    /* the mesh's bounds in world space */
    rtk_bvh_node box;     /* the same as a node, for the slab test in top-level leaves */
} rtk_instance;

/* The scene. Positions are indexed; normals and uvs are stored per
 * triangle corner (3 per triangle) so that OBJ's separate indices and
 * glTF's shared ones fit the same arrays.
 *
 * Two-level instancing: a mesh placed more than once (a glTF mesh used by
 * several nodes, or a file instanced in the config) is a scene of its own
 * in object space, with its own BVH (the bottom level), in meshes[];
 * instances[] place it, and a top-level BVH over the instances' world
 * boxes finds them. The scene's own triangles are world space and have
 * their own BVH beside it. A scene without instances is traced as before,
 * with no top level. */
struct rtk_scene {
    char *path;                  /* file it came from, for messages */
    uint32_t needs;              /* RTK_NEED_* it was loaded for */
    uint32_t vertex_count, vertex_cap;
    float *positions;            /* 3 per vertex */
    uint32_t triangle_count, triangle_cap;
    uint32_t *indices;           /* 3 per triangle */
    float *normals;              /* 9 per triangle (3 corners) or NULL */
    float *uvs;                  /* 6 per triangle or NULL */
    float *uvs1;                 /* 6 per triangle, a second set (glTF TEXCOORD_1), or NULL */
    float *colors;               /* 12 per triangle, RGBA per corner (glTF COLOR_0), or NULL */
    uint32_t *tri_material;      /* per triangle, RTK_INVALID_ID = default; NULL without materials */
    rtk_material *materials;
    uint32_t material_count, material_cap;
    rtk_texture *textures;
    uint32_t texture_count, texture_cap;
    int has_camera;              /* a camera came with the file (glTF) */
    rtk_camera_desc camera;
    float camera_aspect;         /* the file camera's aspect, 0 if unknown */
    uint32_t dropped_degenerate; /* triangles dropped as zero-area */
    int cutout_materials;        /* a material that cuts out was added: materials and uvs are kept */
    int single_sided;            /* a single-sided material was added: materials are kept */
    int has_cutouts;             /* some triangle's material cuts out or is single-sided:
                                    traversal asks rtk_alpha_opaque per hit */
    rtk_bounds bounds;
    /* BVH (bvh.c) */
    rtk_bvh_node *nodes;
    uint32_t node_count;
    uint32_t bvh_depth;
    uint32_t *prim_ids;          /* leaf slot -> triangle id */
    /* An accelerator with its own traversal (ABI 1.1), kept alive while
     * the scene lives; NULL for kernel traversal. */
    const rtk_accelerator_fns *own_traversal;
    void *own_state;
    /* A device accelerator tracing the tree's batches (ABI 3.5,
     * kernel/accel/device.c), its state and what it was given (the
     * meshes' views, every leaf-order corner: one block); NULL when none. */
    const rtk_accelerator_fns *device;
    void *device_state;
    void *device_data;
    uint64_t device_lights; /* the stamp of the lights it was given (0: none) */
    uint32_t device_minor;  /* its plugin's ABI minor (9 on: it reads MIP levels) */
    /* The binary tree collapsed for SIMD traversal (kernel/accel/bvh_wide_build.c), or NULL. */
    struct rtk_wide_bvh *wide;
    /* Where builds of this scene record their phases (kernel/accel/accel.h),
     * or NULL: not recorded. Set by whoever reads them. [not owned] */
    struct rtk_build_log *build_log;
    /* Emitters and their sampling table (lights.c); NULL unless needed. */
    struct rtk_lights *lights;
    /* Point, spot and directional lights (lights.c). */
    rtk_punctual_light *punctual;
    uint32_t punctual_count;
    /* Instancing (instance.c). */
    struct rtk_scene **meshes;   /* instanced meshes, each owned by this scene */
    uint32_t mesh_count, mesh_cap;
    rtk_instance *instances;
    uint32_t instance_count, instance_cap;
    rtk_device_instance *placements; /* per instance what traversal reads (instance.c) */
    const struct rtk_scene *owner; /* a mesh: the scene whose materials and
                                      textures it shares (glTF), else NULL */
    int finished;                /* rtk_scene_finish has run */
    rtk_bvh_node *tlas_nodes;    /* top level over the instances, or NULL */
    uint32_t tlas_node_count, tlas_depth;
    uint32_t *tlas_order;        /* top-level leaf slot -> instance */
    /* Which files it may read and its texture budget (files.c), shared
     * with the models instanced into it; NULL for a scene built in memory
     * (no boundary, no budget). */
    struct rtk_scene_files *files;
};


/* The corners of triangle prim (scene order), 9 floats. */
static inline void rtk_triangle_corners(const rtk_scene *s, uint32_t prim, float v[9])
{
    const uint32_t *idx = s->indices + 3 * (size_t)prim;
    for (int c = 0; c < 3; c++)
        memcpy(v + 3 * c, s->positions + 3 * (size_t)idx[c], 3 * sizeof(float));
}

/* The corners of leaf slot slot, 9 floats, from the scene's indexed
 * positions: the binary traversal, the leaf check and the wide collapse
 * read them this way, so the scene keeps no second copy of its triangles. */
static inline void rtk_slot_corners(const rtk_scene *s, uint32_t slot, float v[9])
{
    rtk_triangle_corners(s, s->prim_ids[slot], v);
}

/* Empty scene that keeps the data in needs (RTK_NEED_*). [caller frees] */
RTK_KERNEL_API rtk_scene *rtk_scene_new(const char *path, uint32_t needs);
RTK_KERNEL_API void rtk_scene_free(rtk_scene *scene);

/* Builder calls used by the loaders. Each returns RTK_OK or RTK_ERR_NOMEM. */
RTK_KERNEL_API rtk_status rtk_scene_add_vertex(rtk_scene *scene, double x, double y, double z, uint32_t *index);
/* Adds triangle (a, b, c) (vertex indices already range-checked by the
 * loader); normals (9 floats) and uvs (6 floats) may be NULL and are
 * ignored when the scene does not need them. */
RTK_KERNEL_API rtk_status rtk_scene_add_triangle(rtk_scene *scene, uint32_t a, uint32_t b, uint32_t c,
                                                 const float *normals, const float *uvs, uint32_t material);
/* Gives the last triangle added a second uv set (6 floats) and vertex
 * colours (12: RGBA per corner); either may be NULL. Each array is made
 * at its first use, earlier triangles getting zero uvs and white, and
 * only when the scene needs it (uvs1: uvs; colours: materials; both for
 * cutouts). */
rtk_status rtk_scene_set_corners(rtk_scene *scene, const float *uvs1, const float *colors);
RTK_KERNEL_API rtk_status rtk_scene_add_material(rtk_scene *scene, const rtk_material *material, uint32_t *index);
/* Records a texture by file path or by encoded bytes (copied); returns its
 * index. The same path is recorded once. */
rtk_status rtk_scene_add_texture(rtk_scene *scene, const char *name, const char *path,
                                 const void *bytes, size_t byte_count, int srgb, int *index);

/* Finishes loading: rejects non-finite vertices (naming the vertex), drops
 * zero-area triangles with one warning, fills missing normals with
 * geometric ones, computes bounds, decodes textures when needed. */
RTK_KERNEL_API rtk_status rtk_scene_finish(rtk_scene *scene);

/* Loads path by extension (.obj, .gltf, .glb) keeping what needs asks for. */
RTK_KERNEL_API rtk_status rtk_scene_load(const char *path, uint32_t needs, rtk_scene **out);
/* rtk_scene_load reading the files path names as files says (NULL: only
 * under path's folder, the default texture budget); the scene holds a
 * reference to files. */
rtk_status rtk_scene_load_with(const char *path, uint32_t needs, struct rtk_scene_files *files, rtk_scene **out);

/* Format loaders (C++ adapters); they fill scene and call nothing else. */
rtk_status rtk_load_obj(const char *path, rtk_scene *scene);
rtk_status rtk_load_gltf(const char *path, rtk_scene *scene);

#include "lights.h"

RTK_EXTERN_C_END

#endif
