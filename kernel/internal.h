/* Kernel-internal declarations shared by the kernel C files and io adapters.
 * Nothing here is exported: plugins see only include/rtk/, hosts also
 * include/rtk/host.h. */
#ifndef RTK_INTERNAL_H
#define RTK_INTERNAL_H

#include <rtk/host.h>
#include <rtk/rtk.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

RTK_EXTERN_C_BEGIN

/* ---- small utilities (util.c) ---- */

/* malloc/calloc/realloc that record RTK_ERR_NOMEM on failure. */
void *rtk_alloc(size_t size);
void *rtk_calloc(size_t count, size_t size);
void *rtk_realloc_array(void *ptr, size_t count, size_t size);
/* Makes room for item count of *array (capacity *cap, items of size
 * bytes), growing by half; 1 on success, 0 (error set) when out of memory
 * or past 2^31 items, *array left alone. */
int rtk_grow_array(void **array, uint32_t *cap, uint32_t count, size_t size);
/* rtk_alloc for large arrays, on a 64-byte boundary; from 8 MiB on,
 * rounded up to whole 2 MiB pages on a 2 MiB boundary, advised as
 * transparent huge pages, which cuts the cost of first touching it and
 * keeps traversal out of TLB misses. Freed with free(). */
void *rtk_alloc_large(size_t size);
/* glibc's largest threshold for giving an allocation a mapping of its
 * own (DEFAULT_MMAP_THRESHOLD_MAX on 64 bits): arrays above it are fresh
 * memory, first touched page by page, every time they are allocated. */
#define RTK_FRESH_ALLOC_BYTES ((size_t)32 << 20)
/* Gives the whole pages of block[used, size) back to the system (they
 * read as zeros if touched again); the block stays allocated. */
void rtk_release_tail(void *block, size_t used, size_t size);
/* Calls fn(ctx, begin, end) over [0, n) cut into at most threads
 * contiguous ranges, the first on the calling thread, the others on
 * threads of their own (run on the caller when a thread cannot start);
 * returns when all are done. Ranges below min_chunk items are not cut. */
typedef void (*rtk_range_fn)(void *ctx, uint32_t begin, uint32_t end);
void rtk_parallel_ranges(uint32_t n, uint32_t threads, uint32_t min_chunk, rtk_range_fn fn, void *ctx);
/* A file written through a temporary sibling (name.tmp<pid>-<n>.ext, see
 * output.h) and renamed over path only when complete, so that a failed or
 * interrupted write never leaves a half-written file under path. */
typedef struct rtk_out_file {
    FILE *f;          /* write here between open and close */
    char *tmp;
    const char *path; /* borrowed: must outlive the file */
    int slot;         /* interrupt registry slot of tmp */
} rtk_out_file;
/* Opens the temporary file (error set, naming it, on failure). */
rtk_status rtk_out_open(rtk_out_file *out, const char *path);
/* Closes; when ok and every write succeeded renames it over path, else
 * removes it. RTK_ERR_IO (naming path) when ok but writing failed. */
rtk_status rtk_out_close(rtk_out_file *out, int ok);
/* strdup that returns NULL on NULL. [caller frees] */
char *rtk_strdup(const char *s);
/* Joins dir and a relative path; absolute paths are returned as they are. [caller frees] */
char *rtk_path_join(const char *dir, const char *path);
/* Directory part of path ("." when none). [caller frees] */
char *rtk_path_dirname(const char *path);
/* Monotonic seconds. */
double rtk_now(void);
/* Peak resident set size of this process in bytes (0 if unknown). */
size_t rtk_peak_rss(void);
/* Number of online cores (>= 1). */
uint32_t rtk_core_count(void);
/* Edit distance between a and b, for "did you mean" suggestions. */
int rtk_edit_distance(const char *a, const char *b);

/* ---- logging (log.c) ---- */

/* Warns once per key for the life of the process (keys compared by text). */
void rtk_warn_once(const char *key, const char *fmt, ...) RTK_PRINTF(2, 3);
/* Whether lines of this level are printed: to skip work done only for them. */
int rtk_log_enabled(rtk_log_level level);

/* ---- params (params.c) ---- */

/* One value, after validation. */
typedef struct rtk_param_value {
    const rtk_param_desc *desc;
    int64_t i;
    double f;
    char *s;
    int set_by_user;
} rtk_param_value;

/* Validated values for one plugin instance; one entry per schema entry. */
struct rtk_params {
    const rtk_plugin *plugin;
    rtk_param_value *values;
    uint32_t count;
};

/* Params holding every default of plugin's schema. [caller frees] */
rtk_params *rtk_params_defaults(const rtk_plugin *plugin);
/* Sets a declared parameter from its text form ("16", "0.5", "true",
 * "name"), checking type, range and choices; errors name the key. */
rtk_status rtk_params_set_text(rtk_params *params, const char *name, const char *text);
void rtk_params_destroy(rtk_params *params);
/* Checks a schema for sanity (names unique and non-empty, valid types,
 * defaults inside ranges and choices). Errors name the plugin. */
rtk_status rtk_params_check_schema(const rtk_plugin *plugin);
/* Closest declared name to name, or NULL when none is close. */
const char *rtk_params_suggest(const rtk_param_desc *schema, uint32_t count, const char *name);

/* ---- plugins (plugins.c) ---- */

/* Checks a descriptor as the loader does; path is used in messages. */
rtk_status rtk_plugin_check(const rtk_plugin *plugin, const char *path, rtk_plugin_kind expected);

/* ---- camera (camera.c) ---- */

/* A pinhole camera as configured. */
typedef struct rtk_camera_desc {
    rtk_vec3 position, look_at, up;
    float fov_deg; /* vertical field of view */
} rtk_camera_desc;

/* Ready-to-use pinhole camera. */
typedef struct rtk_camera {
    rtk_vec3 eye, forward, right, up; /* right/up scaled by the image plane half-size */
    uint32_t width, height;
} rtk_camera;

/* Camera looking at the bounds' centre from the front-right-above, framing
 * the bounding sphere at the given vertical fov. */
rtk_camera_desc rtk_camera_frame(rtk_bounds bounds, float fov_deg, float aspect);
/* Checks desc (finite, eye != look_at, up not parallel, 0 < fov < 180). */
rtk_status rtk_camera_init(rtk_camera *cam, const rtk_camera_desc *desc, uint32_t width, uint32_t height);
/* Ray through film position (fx, fy) in pixels, (0,0) the top-left corner. */
rtk_ray rtk_camera_ray(const rtk_camera *cam, float fx, float fy);
/* Differentials of that ray: the rays through (fx + 1, fy) and (fx, fy + 1). */
void rtk_camera_differential(const rtk_camera *cam, float fx, float fy, rtk_ray_differential *out);

/* ---- textures (texture.c, io/image.cpp) ---- */

/* How lookups filter a texture (config textures.filter). Zero is bilinear. */
typedef enum rtk_texture_filter {
    RTK_TEX_BILINEAR = 0,  /* the 4 nearest texels of level 0 */
    RTK_TEX_NEAREST = 1,   /* the nearest texel of level 0 */
    RTK_TEX_TRILINEAR = 2  /* bilinear in the two MIP levels around the footprint's level of detail */
} rtk_texture_filter;

/* How texture coordinates outside [0, 1] reach the image, along one axis.
 * Zero is repeat. */
typedef enum rtk_wrap {
    RTK_WRAP_REPEAT = 0,  /* glTF REPEAT, MTL default */
    RTK_WRAP_CLAMP = 1,   /* glTF CLAMP_TO_EDGE, MTL -clamp on */
    RTK_WRAP_MIRROR = 2   /* glTF MIRRORED_REPEAT */
} rtk_wrap;

/* The wrap modes of one use of a texture (a material slot): s along u,
 * t along v (glTF sampler wrapS, wrapT). Zeroed = repeat. */
typedef struct rtk_tex_wrap {
    uint8_t s, t; /* rtk_wrap */
} rtk_tex_wrap;

/* One level of a MIP pyramid. */
typedef struct rtk_texture_level {
    int width, height;
    float *rgba;       /* linear RGBA, row 0 = top */
} rtk_texture_level;

/* Texture-space footprint of a pixel at a hit: the change of (u, v) to
 * the pixel's right (x) and lower (y) neighbour. */
typedef struct rtk_uv_footprint {
    float dudx, dvdx, dudy, dvdy;
} rtk_uv_footprint;

/* An image referenced by a material; decoded only when a plugin needs it. */
typedef struct rtk_texture {
    char *name;        /* for messages: the path or "glb image 3" */
    char *path;        /* file to decode, or NULL when embedded */
    unsigned char *bytes; /* embedded encoded image (glb, data URI) */
    size_t byte_count;
    int srgb;          /* colour data stored sRGB-encoded */
    int decoded;       /* 1 after a decode attempt */
    int missing;       /* decode failed: lookups return white */
    int has_alpha;     /* some texel's alpha is below 1 */
    int normal_map_checked; /* used as a normal map: 1 usable, -1 grey (a height map), 0 not checked */
    int width, height;
    float *rgba;       /* linear RGBA, row 0 = top of the image */
    rtk_texture_filter filter; /* how lookups filter it */
    int levels;        /* MIP levels in mip (trilinear filter only), else 0 */
    rtk_texture_level *mip; /* level 0 is rgba itself, then halved down to 1x1 */
    char *problem;     /* why it may not be read (outside the scene's folders), or NULL */
} rtk_texture;

/* Decodes tex if not yet tried; on failure warns once and marks it missing.
 * Builds the MIP pyramid when tex->filter is trilinear. */
struct rtk_scene_files;
void rtk_texture_decode(rtk_texture *tex);
/* rtk_texture_decode within files' texture budget (NULL: none): a texture
 * whose header says it would not fit is not decoded (warned, missing). */
void rtk_texture_decode_within(rtk_texture *tex, struct rtk_scene_files *files);
/* Sets how tex is filtered: builds its MIP pyramid (if decoded) for
 * trilinear, drops it otherwise. RTK_ERR_NOMEM leaves it bilinear. */
rtk_status rtk_texture_set_filter(rtk_texture *tex, rtk_texture_filter filter);
/* rtk_texture_set_filter on every texture of scene and of its meshes. */
rtk_status rtk_scene_set_texture_filter(rtk_scene *scene, rtk_texture_filter filter);
/* The filter a config names ("nearest", "bilinear", "trilinear"); 0 if none. */
int rtk_texture_filter_from_name(const char *name, rtk_texture_filter *filter);
/* Level of detail of footprint fp on tex: log2 of the longer of the
 * footprint's two sides measured in level-0 texels; 0 when it is not
 * positive and finite, a large value when it is infinite. */
float rtk_texture_lod(const rtk_texture *tex, const rtk_uv_footprint *fp);
/* The texture at (u, v) with its filter and the given wrap modes, at
 * level of detail lod (read only by trilinear; <= 0 is level 0); white
 * when missing, texel (0, 0) for non-finite (u, v). [any thread] */
void rtk_texture_sample(const rtk_texture *tex, rtk_tex_wrap wrap, float u, float v, float lod, float rgba[4]);
/* rtk_texture_sample at level 0 with repeat wrapping. [any thread] */
void rtk_texture_lookup(const rtk_texture *tex, float u, float v, float rgba[4]);
void rtk_texture_free(rtk_texture *tex);

/* Decoded image (io/image.cpp). */
typedef struct rtk_image {
    int width, height;
    float *rgba; /* linear RGBA floats, row-major from the top; [caller frees with free()] */
    int channels;  /* in the file: 1 grey, 2 grey + alpha, 3 RGB, 4 RGBA, more with extra layers */
    int has_alpha; /* the file has an alpha channel (else A reads as 1) */
} rtk_image;

/* Whether this librtk (or the static copy in a test) runs from the build
 * tree (plugins.c): plugins and the image module are then taken from
 * there rather than from the install directories. */
int rtk_running_from_build_tree(void);
/* subpath joined to the directory librtk's own file lies in (plugins.c):
 * how an installed librtk finds its plugins and image module from any
 * prefix; NULL when that file is unknown. [caller frees] */
char *rtk_installed_path(const char *subpath);

/* An encoded image, recognised by its first bytes as one of the formats
 * rtk decodes (image_format.c) and its header checked. */
typedef struct rtk_image_source {
    const char *name;           /* the file, or the embedded image's name, for messages */
    const unsigned char *bytes; /* the encoded image */
    size_t count;
    unsigned char *owned;       /* bytes when they were read from the file */
    const char *format;         /* OpenImageIO's name of the format ("png") */
    const char *format_label;   /* its name in messages ("PNG") */
    int width, height;          /* from the header */
} rtk_image_source;

/* Reads the regular file path (bytes == NULL) or takes the bytes (not
 * copied), and checks them (rtk_image_source_check). [close after] */
rtk_status rtk_image_source_open(const char *path, const void *bytes, size_t byte_count, rtk_image_source *src);
/* Sets format and size from bytes: one of PNG, JPEG, OpenEXR, Radiance
 * HDR, TIFF, BMP, TGA (a .tga name), PNM, with its header walked (a
 * truncated PNG or PNM is refused here); anything else is an error naming
 * the formats. */
rtk_status rtk_image_source_check(rtk_image_source *src);
/* Decodes src through OpenImageIO's reader of src->format alone. */
rtk_status rtk_image_source_decode(const rtk_image_source *src, int srgb, rtk_image *out);
void rtk_image_source_close(rtk_image_source *src);

/* Decodes a file (bytes == NULL) or an in-memory encoded image through
 * OpenImageIO into linear RGBA; srgb: the 8-bit data is sRGB-encoded.
 * This and rtk_image_write load the image module on first use
 * (kernel/image.c); a module that cannot load is an RTK_ERR_IO naming it. */
rtk_status rtk_image_read(const char *path, const void *bytes, size_t byte_count, int srgb,
                          rtk_image *out);

/* Writes pixels (nchannels floats per pixel, linear) to path through
 * OpenImageIO, format from the extension. EXR keeps linear floats (half
 * when half != 0) with the given channel names; PNG/JPEG get the first 3
 * channels sRGB-encoded to 8 bits. Writes path's ".tmp" sibling with the
 * same extension and renames it, so a failure never leaves a partial file. */
rtk_status rtk_image_write(const char *path, int width, int height, int nchannels,
                           const char *const *channel_names, const float *pixels, int half);

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
} rtk_material;

/* The texture coordinates map reads on triangle prim of s at barycentrics
 * (u, v) of its corners 1 and 2; (0, 0) when s keeps no uvs. (scene.c) */
rtk_vec2 rtk_tex_map_uv(const struct rtk_scene *s, const rtk_tex_map *map, uint32_t prim, float u, float v);
/* The base colour and alpha triangle prim's vertex colours (glTF COLOR_0)
 * give at barycentrics (u, v): white and 1 without them. (scene.c) */
void rtk_vertex_color(const struct rtk_scene *s, uint32_t prim, float u, float v, float rgba[4]);

/* Material defaults: white diffuse, alpha 1, ior 1.5, no textures. */
rtk_material rtk_material_default(void);

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
    /* The binary tree collapsed for SIMD traversal (bvh_wide.c), or NULL. */
    struct rtk_wide_bvh *wide;
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

/* The axes of the watertight triangle test (Woop, Benthin, Wald 2013) for
 * direction d: kz that of the largest |component|, kx and ky the next two
 * cyclically, swapped when d[kz] < 0 to keep the winding. The scalar test
 * and the wide traversal's four-lane one take them from here. */
static inline void rtk_shear_axes(const float d[3], int *kx, int *ky, int *kz)
{
    /* In integer arithmetic on comparisons, so that compilers emit no
     * branch: directions of AO and diffuse rays are random, and branches
     * here would be mispredicted every other ray. Same result as
     * z = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2), x and y the
     * next two cyclically, swapped when d[z] < 0. */
    float ax = fabsf(d[0]), ay = fabsf(d[1]), az = fabsf(d[2]);
    int xy = ax > ay;
    int top = (xy ? ax : ay) > az;
    int z = 2 - top * (1 + xy);
    int x = 9 >> (2 * z) & 3;  /* 1, 2, 0 for z = 0, 1, 2 */
    int y = 18 >> (2 * z) & 3; /* 2, 0, 1 */
    int swap = (x ^ y) & -(d[z] < 0.0f);
    *kx = x ^ swap, *ky = y ^ swap, *kz = z;
}

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
rtk_scene *rtk_scene_new(const char *path, uint32_t needs);
void rtk_scene_free(rtk_scene *scene);

/* Builder calls used by the loaders. Each returns RTK_OK or RTK_ERR_NOMEM. */
rtk_status rtk_scene_add_vertex(rtk_scene *scene, double x, double y, double z, uint32_t *index);
/* Adds triangle (a, b, c) (vertex indices already range-checked by the
 * loader); normals (9 floats) and uvs (6 floats) may be NULL and are
 * ignored when the scene does not need them. */
rtk_status rtk_scene_add_triangle(rtk_scene *scene, uint32_t a, uint32_t b, uint32_t c,
                                  const float *normals, const float *uvs, uint32_t material);
/* Gives the last triangle added a second uv set (6 floats) and vertex
 * colours (12: RGBA per corner); either may be NULL. Each array is made
 * at its first use, earlier triangles getting zero uvs and white, and
 * only when the scene needs it (uvs1: uvs; colours: materials; both for
 * cutouts). */
rtk_status rtk_scene_set_corners(rtk_scene *scene, const float *uvs1, const float *colors);
rtk_status rtk_scene_add_material(rtk_scene *scene, const rtk_material *material, uint32_t *index);
/* Records a texture by file path or by encoded bytes (copied); returns its
 * index. The same path is recorded once. */
rtk_status rtk_scene_add_texture(rtk_scene *scene, const char *name, const char *path,
                                 const void *bytes, size_t byte_count, int srgb, int *index);

/* Finishes loading: rejects non-finite vertices (naming the vertex), drops
 * zero-area triangles with one warning, fills missing normals with
 * geometric ones, computes bounds, decodes textures when needed. */
rtk_status rtk_scene_finish(rtk_scene *scene);

/* ---- instancing (instance.c) ---- */

/* A new, empty mesh for scene to instance; it shares scene's materials and
 * textures (same material indices) and is finished with it. [owned by scene] */
rtk_status rtk_scene_add_mesh(rtk_scene *scene, const char *name, uint32_t *index);
/* Places mesh by to_world (3x4 row-major, see rtk_instance). Rejects a
 * non-finite or singular transform, naming where. */
rtk_status rtk_scene_add_instance(rtk_scene *scene, uint32_t mesh, const double to_world[12], const char *where);
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
rtk_status rtk_instances_build(rtk_scene *scene, const rtk_plugin *accelerator, const rtk_params *params,
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
int rtk_instance_local_ray(const rtk_instance *in, const rtk_ray *r, rtk_ray *out);
/* World-space corners of triangle prim of instance inst, in the mesh's
 * order (so the winding turns around when the instance is mirrored). */
void rtk_instance_triangle(const rtk_scene *s, uint32_t inst, uint32_t prim, rtk_vec3 *a, rtk_vec3 *b, rtk_vec3 *c);
/* Bytes of geometry, BVH and instance records (the top level included),
 * counting each mesh once. */
void rtk_scene_memory(const rtk_scene *s, size_t *geometry, size_t *bvh, size_t *instances);

/* Places a config's instances in scene (each model loaded once), then
 * finishes them: world boxes, and the emitter table again when the scene
 * keeps lights. (render.c) */
rtk_status rtk_config_place_instances(const struct rtk_config *cfg, rtk_scene *scene);

/* Loads path by extension (.obj, .gltf, .glb) keeping what needs asks for. */
rtk_status rtk_scene_load(const char *path, uint32_t needs, rtk_scene **out);
/* rtk_scene_load reading the files path names as files says (NULL: only
 * under path's folder, the default texture budget); the scene holds a
 * reference to files. */
rtk_status rtk_scene_load_with(const char *path, uint32_t needs, struct rtk_scene_files *files, rtk_scene **out);

/* ---- files a scene names (files.c) ---- */

/* Decoded texture memory a scene may use when the config says nothing
 * (textures.memory): 2048 MiB. */
#define RTK_TEXTURE_BUDGET_DEFAULT ((uint64_t)2048 << 20)
/* Largest files read whole: an MTL, a glTF's JSON, a buffer or .glb, an
 * encoded image. */
#define RTK_MAX_TEXT_FILE ((uint64_t)256 << 20)
#define RTK_MAX_BUFFER_FILE ((uint64_t)16 << 30)
#define RTK_MAX_IMAGE_FILE ((uint64_t)1 << 30)

/* Where a scene may read and how much its textures may decode to. */
typedef struct rtk_scene_files {
    char *config_dir;        /* the config's folder, readable too; NULL when none */
    int allow_outside;       /* --allow-outside-files: no boundary */
    uint64_t texture_budget; /* bytes decoded textures may take, all together */
    uint64_t texture_bytes;  /* bytes decoded so far */
    int trilinear;           /* MIP levels will be built: each texture counts a third more */
    unsigned refs;
} rtk_scene_files;

/* New settings (texture_budget 0: the default). [caller unrefs] */
rtk_scene_files *rtk_scene_files_new(const char *config_dir, int allow_outside, uint64_t texture_budget);
rtk_scene_files *rtk_scene_files_ref(rtk_scene_files *files);
void rtk_scene_files_unref(rtk_scene_files *files);
/* RTK_OK when scene may read path (see files.c for the boundary; a scene
 * without files, built in memory, may read any), else an error naming
 * what ("texture", "file") and path, the folders allowed and
 * --allow-outside-files; nothing about the file itself. */
rtk_status rtk_scene_file_allowed(const rtk_scene *scene, const char *path, const char *what);
/* Opens a regular file for reading (never blocks on a FIFO; a directory,
 * FIFO or device is an error naming it); *size its size. [caller closes] */
rtk_status rtk_file_open(const char *path, const char *what, int *fd, uint64_t *size);
/* Reads all of the regular file path, refusing one above limit bytes;
 * (*bytes)[*count] is a 0 byte, so text can be read as a string.
 * [caller frees *bytes] */
rtk_status rtk_file_read(const char *path, const char *what, uint64_t limit, unsigned char **bytes, size_t *count);
/* rtk_scene_file_allowed, then rtk_file_read. */
rtk_status rtk_scene_file_read(const rtk_scene *scene, const char *path, const char *what, uint64_t limit,
                               unsigned char **bytes, size_t *count);
/* Loads cfg's scene as rtk_scene_load_with does, with the config's
 * folder, --allow-outside-files and textures group. */
rtk_status rtk_config_load_scene(const struct rtk_config *cfg, uint32_t needs, rtk_scene **out);
/* Absolute path with symbolic links, "." and ".." resolved; the part that
 * does not exist is taken lexically. NULL when it cannot be. [caller frees] */
char *rtk_path_canonical(const char *path);
/* Format loaders (C++ adapters); they fill scene and call nothing else. */
rtk_status rtk_load_obj(const char *path, rtk_scene *scene);
rtk_status rtk_load_gltf(const char *path, rtk_scene *scene);

/* ---- BVH (bvh.c) ---- */

/* Builds scene's BVH with an accelerator plugin, checks the tree the plugin
 * returned, and lays triangles out in leaf order. */
rtk_status rtk_bvh_build(rtk_scene *scene, const rtk_plugin *accelerator, const rtk_params *params,
                         uint32_t threads);
/* Destroys an accelerator instance that traverses itself, if any. */
void rtk_bvh_release(rtk_scene *scene);

/* One scene's tree, moved out of it: the binary nodes and leaf order, the
 * wide tree, an own-traversal accelerator's state. */
typedef struct rtk_tree_slot {
    rtk_bvh_node *nodes;
    uint32_t node_count, bvh_depth;
    uint32_t *prim_ids;
    const rtk_accelerator_fns *own_traversal;
    void *own_state;
    struct rtk_wide_bvh *wide;
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
rtk_status rtk_accel_set_init(rtk_accel_set *set, const rtk_scene *scene);
/* Exchanges scene's trees with set's: a scene without trees and a full set
 * trade places, and the other way round. */
void rtk_accel_swap(rtk_scene *scene, rtk_accel_set *set);
/* Frees set's trees and room; set is left empty. */
void rtk_accel_set_free(rtk_accel_set *set);
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
    uint64_t *prim_bits; /* sets bit sets of words each */
    size_t words;
    uint32_t sets;
} rtk_tree_check;
/* One walk's marks of primitives and counts. */
typedef struct rtk_tree_tally {
    uint64_t *prim_bits;
    uint32_t reached, covered, max_depth;
} rtk_tree_tally;
/* Marks for a tree of node_count >= 1 nodes and walks with sets bit sets
 * (at most RTK_TREE_CHECK_MAX_SETS). 0 when out of memory. */
int rtk_tree_check_init(rtk_tree_check *check, const rtk_bvh_node *nodes, uint32_t node_count,
                        const uint32_t *prim_order, uint32_t prim_count, uint32_t sets);
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
 * every node and slot once, the primitives' bit sets a partition. */
int rtk_tree_check_whole(const rtk_tree_check *check, uint32_t reached, uint32_t covered);
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
int rtk_bvh_closest(const rtk_scene *scene, const rtk_ray *ray, rtk_hit *hit);
int rtk_bvh_any(const rtk_scene *scene, const rtk_ray *ray);
/* Traversal of the scene's own triangles only (hit->inst is not set);
 * work, if not NULL, receives the counts. */
int rtk_bvh_closest_own(const rtk_scene *scene, const rtk_ray *ray, rtk_hit *hit, rtk_trace_work *work);
int rtk_bvh_any_own(const rtk_scene *scene, const rtk_ray *ray, rtk_trace_work *work);
/* 1 when the accelerator supplies its own traversal (closest and any). */
int rtk_accelerator_traverses_itself(const rtk_plugin *accelerator);
/* The accelerator's RTK_BUILD_* flags (0 for a table older than them). */
uint32_t rtk_accelerator_build_flags(const rtk_plugin *accelerator);
/* A builder's inputs for s's triangles, as rtk_bvh_build makes them, on
 * up to threads threads: each triangle's bounds and their centre (both
 * NULL, or both filled) and its three corners (vertices, NULL or filled). */
void rtk_bvh_prepare_inputs(const rtk_scene *s, uint32_t threads, rtk_bounds *bounds, rtk_vec3 *centroids,
                            rtk_vec3 *vertices);
/* 1 if ray has finite origin/direction, non-zero direction, tmin <= tmax. */
int rtk_ray_valid(const rtk_ray *ray);

/* ---- sampler (sampler.c) ---- */

/* PCG32 state (O'Neill 2014). */
typedef struct rtk_pcg32 {
    uint64_t state, inc;
} rtk_pcg32;

void rtk_pcg32_seed(rtk_pcg32 *rng, uint64_t initstate, uint64_t initseq);
uint32_t rtk_pcg32_next(rtk_pcg32 *rng);
/* Uniform float in [0, 1) from the top 24 bits. */
float rtk_pcg32_float(rtk_pcg32 *rng);

/* Sample generators of a config's sampler.type. Zero is independent, so a
 * zeroed rtk_ctx draws PCG32 numbers. */
typedef enum rtk_sampler_type {
    RTK_SAMPLER_INDEPENDENT = 0,
    RTK_SAMPLER_STRATIFIED = 1,
    RTK_SAMPLER_SOBOL = 2
} rtk_sampler_type;

/* The generator a config names ("independent", "stratified", "sobol"); 0 if none. */
int rtk_sampler_type_from_name(const char *name, rtk_sampler_type *type);
/* Nested uniform (Owen) scramble of a 64-bit fraction by hashing (Burley
 * 2020): bit k of the result depends on bits k..63 of x and the seed, so
 * every aligned block of 2^m values maps onto an aligned block. */
uint64_t rtk_owen_scramble(uint64_t x, uint64_t seed);
/* Unscrambled Sobol point index, dimension 0 (van der Corput) or 1, as a
 * 32-bit fraction; index bits past 31 reach dimension 1. */
uint32_t rtk_sobol_sample(uint64_t index, uint32_t dim);
/* The float of a 32-bit fraction, truncated: at most 0x1.fffffep-1. */
float rtk_sampler_float(uint32_t bits);
/* A float in [k/n, (k+1)/n) (for n <= 2^24, where each such range holds
 * floats), near (k + jitter 2^-32) / n, below 1. */
float rtk_sampler_stratum(uint32_t k, uint32_t n, uint32_t jitter);

/* ---- render context (render.c) ---- */

struct rtk_ctx {
    const rtk_scene *scene;
    rtk_pcg32 rng;
    uint64_t seed;
    uint64_t rays;
    uint64_t invalid_rays;
    /* Sampler state (sampler.c): the generator, set once per context... */
    rtk_sampler_type sampler;
    uint32_t spp;              /* samples per pixel the strata are made for */
    uint32_t grid_x, grid_y;   /* stratified 2D grid, grid_x * grid_y = spp */
    /* ... and the current sample, set by rtk_ctx_start_sample. */
    uint64_t pixel, sample;
    uint64_t sample_hash;      /* of (seed, pixel, stratified pass) */
    uint32_t pass_sample;      /* stratified: sample index within its pass of spp */
    uint32_t dim;              /* dimensions drawn so far in this sample */
    /* The current sample's camera ray (render.c), for its differentials:
     * the film position it went through; camera NULL when there is none. */
    const rtk_camera *camera;
    float film_x, film_y;
    rtk_ray camera_ray;        /* that ray itself, as li received it */
};

/* Picks ctx's generator, seed and samples per pixel (0 taken as 1). A
 * zeroed ctx with only seed set is the independent generator. */
void rtk_ctx_set_sampler(rtk_ctx *ctx, rtk_sampler_type type, uint64_t seed, uint32_t spp);
/* Starts sample `sample` of pixel `pixel` and resets the dimension counter. */
void rtk_ctx_start_sample(rtk_ctx *ctx, uint64_t pixel, uint64_t sample);

/* rtk_render_film (film.h) with the sample generator chosen. */
struct rtk_render_stats;
rtk_status rtk_render_film_sampled(const rtk_scene *scene, const rtk_camera *camera, const rtk_integrator_fns *ifn,
                                   const void *istate, const rtk_filter_fns *ffn, const void *fstate, uint32_t spp,
                                   rtk_sampler_type sampler, uint64_t seed, uint32_t threads, int progress,
                                   float *pixels, struct rtk_render_stats *stats);

/* ---- config (config.c) ---- */

/* One entry of a config's instances list: a model and where its copies go. */
typedef struct rtk_config_instance {
    char *file;              /* resolved against the config's directory */
    char where[1100];        /* "scene.cfg:12: instances[0]", for messages */
    double to_world[12];     /* the first copy's transform (3x4 row-major) */
    uint32_t grid[3];        /* copies along x, y, z */
    double spacing[3];       /* offset between copies */
} rtk_config_instance;

/* One plugin slot of a config. */
typedef struct rtk_plugin_slot {
    const rtk_plugin *plugin;
    rtk_params *params;
} rtk_plugin_slot;

struct rtk_config {
    char *path;                  /* the config file */
    char *scene_path;            /* resolved against the config's directory */
    int has_camera;              /* camera group given */
    rtk_camera_desc camera;      /* when has_camera */
    uint32_t width, height, spp;
    char *output;                /* resolved path of the image */
    int half;                    /* EXR as half floats */
    int importance;              /* film.reconstruction = "importance" */
    int aov_albedo, aov_normal, aov_depth;
    char *sampler_type;          /* "independent", "stratified" or "sobol" */
    uint64_t seed;
    uint32_t threads;            /* 0 = all cores */
    char *cache_dir;             /* BVH cache directory, NULL = caching off */
    uint64_t cache_limit;        /* bytes the BVH cache may hold, 0 = no limit */
    rtk_punctual_light *lights;  /* the config's punctual lights */
    uint32_t light_count;
    rtk_config_instance *instances; /* models placed beside the scene */
    uint32_t instance_count;
    rtk_texture_filter texture_filter; /* textures.filter */
    uint64_t texture_budget;     /* textures.memory in bytes */
    int allow_outside_files;     /* rtk_config_options.allow_outside_files */
    rtk_plugin_slot integrator, accelerator, filter;
};

/* Files the last rtk_config_load on this thread read to check the config's
 * text: each once, however often it is @included (tests count work). */
unsigned rtk_config_files_read(void);

/* ---- film (film.c) ---- */

/* Accumulates filtered samples in double precision. */
typedef struct rtk_film {
    uint32_t width, height;
    uint32_t channels;           /* 3 (rgb) + optional AOV channels */
    double *sum;                 /* channels per pixel, weighted sums */
    double *weight;              /* per pixel */
    /* With a filter that has negative lobes: the same sums with |weight|,
     * for pixels whose signed weights nearly cancel (see rtk_film_resolve);
     * NULL otherwise. */
    double *abs_sum, *abs_weight;
} rtk_film;

RTK_EXTERN_C_END

#endif
