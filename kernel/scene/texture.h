/* Textures: decoding on first use, MIP pyramids and filtered lookups (texture.c). */
#ifndef RTK_KERNEL_TEXTURE_H
#define RTK_KERNEL_TEXTURE_H

#include "../core/core.h"

RTK_EXTERN_C_BEGIN

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

/* A texture as device programs read it (rtk_device_tree.textures): its
 * level 0, and for trilinear its MIP levels (rtk_device_tree.texture_levels);
 * texture_sample.h reads it as the kernel reads the texture. */
typedef struct rtk_device_texture {
    int32_t filter;     /* rtk_texture_filter */
    int32_t width, height;
    const float *rgba;  /* linear RGBA, row 0 = top; NULL: missing, read as white */
    int32_t decoded;    /* a decode was tried: the material's slot reads it */
    int32_t has_alpha;  /* some texel's alpha is below 1 (rtk_texture_coverage) */
    int32_t normal_map; /* usable as a tangent-space normal map (rtk_normal_map_usable) */
    int32_t levels;     /* ABI 3.9: MIP levels in texture_levels (level 0 first), else 0 (3.8: reserved, 0) */
} rtk_device_texture;

/* Decodes tex if not yet tried; on failure warns once and marks it missing.
 * Builds the MIP pyramid when tex->filter is trilinear. */
struct rtk_scene_files;
void rtk_texture_decode(rtk_texture *tex);
/* rtk_texture_decode within files' texture budget (NULL: none): a texture
 * whose header says it would not fit is not decoded (warned, missing). */
void rtk_texture_decode_within(rtk_texture *tex, struct rtk_scene_files *files);
/* Sets how tex is filtered: builds its MIP pyramid (if decoded) for
 * trilinear, drops it otherwise. RTK_ERR_NOMEM leaves it bilinear. */
RTK_KERNEL_API rtk_status rtk_texture_set_filter(rtk_texture *tex, rtk_texture_filter filter);
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
RTK_KERNEL_API void rtk_texture_sample(const rtk_texture *tex, rtk_tex_wrap wrap, float u, float v, float lod,
                                       float rgba[4]);
/* rtk_texture_sample at level 0 with repeat wrapping. [any thread] */
void rtk_texture_lookup(const rtk_texture *tex, float u, float v, float rgba[4]);
RTK_KERNEL_API void rtk_texture_free(rtk_texture *tex);

RTK_EXTERN_C_END

#endif
