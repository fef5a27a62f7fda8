/* Textures: decoded once at load time, then looked up from any thread.
 * Lookups use the glTF convention: (u, v) = (0, 0) is the top-left corner of
 * the image and v grows downwards (row = v * height). The OBJ loader flips
 * v to 1 - v on load, so that OBJ/OpenGL uvs (v up) fit this convention.
 *
 * Filtering (config textures.filter): nearest and bilinear read level 0;
 * trilinear reads a MIP pyramid, built when the filter is set or the image
 * decoded, whichever comes last, never while rendering. Each level halves
 * the one above (odd sizes round down, to 1 at least) by an exact box
 * filter: a texel of the smaller level is the area-weighted mean of the
 * texels it covers, so every level keeps the image's mean. The lookups
 * themselves are texture_sample.h, plain C shared with a device. */
#include "scene.h"
#include "texture_sample.h"
#include "../image/image.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static rtk_status build_mip(rtk_texture *tex);
static void free_mip(rtk_texture *tex);

void rtk_texture_decode(rtk_texture *tex)
{
    rtk_texture_decode_within(tex, NULL);
}

/* Bytes a decoded texture of w x h takes: float RGBA, and a third more
 * for the MIP levels under trilinear filtering. */
static uint64_t decoded_bytes(int w, int h, int trilinear)
{
    uint64_t bytes = (uint64_t)w * (uint64_t)h * 16u;
    return trilinear ? bytes + bytes / 3 : bytes;
}

/* Opens the texture's image and checks it against the budget: 0 (warned,
 * marked missing) when it cannot be decoded. */
static int open_within(rtk_texture *tex, const char *name, rtk_scene_files *files, rtk_image_source *src)
{
    const char *source = tex->bytes ? name : tex->path;
    rtk_status status = RTK_ERR_INVALID;
    if (tex->problem)
        rtk_error(RTK_ERR_IO, "%s", tex->problem);
    else if (source)
        status = rtk_image_source_open(source, tex->bytes, tex->byte_count, src);
    else
        rtk_error(RTK_ERR_INVALID, "it has neither a file nor embedded data");
    if (status != RTK_OK) {
        rtk_log(RTK_LOG_WARN, "texture '%s' cannot be read (%s): rendering without it", name, rtk_error_message());
        return 0;
    }
    if (!files)
        return 1;
    int trilinear = files->trilinear || tex->filter == RTK_TEX_TRILINEAR;
    uint64_t need = decoded_bytes(src->width, src->height, trilinear);
    uint64_t left = files->texture_budget > files->texture_bytes ? files->texture_budget - files->texture_bytes : 0;
    if (need > left) {
        rtk_log(RTK_LOG_WARN, "texture '%s' (%s, %dx%d) would take %.1f MiB decoded%s, and the scene's texture "
                "budget has %.1f of %.0f MiB left: rendering without it; raise textures.memory in the config or "
                "make the image smaller", name, src->format_label, src->width, src->height, (double)need / 1048576.0,
                trilinear ? " with its MIP levels" : "", (double)left / 1048576.0,
                (double)files->texture_budget / 1048576.0);
        return 0;
    }
    files->texture_bytes += need;
    return 1;
}

void rtk_texture_decode_within(rtk_texture *tex, rtk_scene_files *files)
{
    if (!tex || tex->decoded)
        return;
    tex->decoded = 1;
    tex->missing = 1;
    const char *name = tex->name ? tex->name : tex->path ? tex->path : "(unnamed)";
    rtk_image_source src;
    memset(&src, 0, sizeof src);
    if (!open_within(tex, name, files, &src)) {
        rtk_image_source_close(&src);
        return;
    }
    rtk_image image;
    rtk_status status = rtk_image_source_decode(&src, tex->srgb, &image);
    rtk_image_source_close(&src);
    if (status != RTK_OK) {
        rtk_log(RTK_LOG_WARN, "texture '%s' cannot be read (%s): rendering without it", name,
                rtk_error_message());
        return;
    }
    /* One NaN texel would spread through every pixel that samples it. */
    size_t count = (size_t)image.width * (size_t)image.height * 4;
    size_t bad = 0;
    for (size_t i = 0; i < count; i++) {
        if (!isfinite(image.rgba[i])) {
            image.rgba[i] = 0.0f;
            bad++;
        }
    }
    if (bad)
        rtk_log(RTK_LOG_WARN, "texture '%s' has %zu non-finite values: replaced by 0", name, bad);
    tex->has_alpha = 0;
    for (size_t i = 3; i < count && !tex->has_alpha; i += 4)
        tex->has_alpha = image.rgba[i] < 1.0f;
    tex->width = image.width;
    tex->height = image.height;
    tex->rgba = image.rgba;
    tex->missing = 0;
    if (tex->filter == RTK_TEX_TRILINEAR && build_mip(tex) != RTK_OK) {
        rtk_log(RTK_LOG_WARN, "texture '%s': no memory for its MIP levels: filtered bilinearly", name);
        tex->filter = RTK_TEX_BILINEAR;
    }
}

/* Weight of source texel i in texel j of the level below, along an axis
 * of n source and m = max(1, n / 2) texels: their overlap as a fraction
 * of j's span. Counted in units of 1/m, i spans [i m, (i + 1) m) and j
 * spans [j n, (j + 1) n), so the fractions are exact ratios of integers. */
static double box_weight(int i, int j, int n, int m)
{
    long lo = (long)i * m > (long)j * n ? (long)i * m : (long)j * n;
    long hi = (long)(i + 1) * m < (long)(j + 1) * n ? (long)(i + 1) * m : (long)(j + 1) * n;
    return hi > lo ? (double)(hi - lo) / (double)n : 0.0;
}

/* The level below src: each texel the box-weighted mean of the 2x2 (an
 * odd axis: 2 or 3) source texels it covers, summed in double. */
static float *reduce(const rtk_texture_level *src, int w, int h)
{
    float *dst = rtk_calloc((size_t)w * (size_t)h * 4, sizeof(float));
    if (!dst)
        return NULL;
    int sw = src->width, sh = src->height;
    for (int y = 0; y < h; y++) {
        int y0 = (int)((long)y * sh / h), y1 = (int)(((long)(y + 1) * sh - 1) / h);
        for (int x = 0; x < w; x++) {
            int x0 = (int)((long)x * sw / w), x1 = (int)(((long)(x + 1) * sw - 1) / w);
            double sum[4] = {0.0, 0.0, 0.0, 0.0};
            for (int k = y0; k <= y1; k++) {
                double wy = box_weight(k, y, sh, h);
                for (int i = x0; i <= x1; i++) {
                    double wxy = box_weight(i, x, sw, w) * wy;
                    const float *t = src->rgba + 4 * ((size_t)k * (size_t)sw + (size_t)i);
                    for (int c = 0; c < 4; c++)
                        sum[c] += wxy * t[c];
                }
            }
            for (int c = 0; c < 4; c++)
                dst[4 * ((size_t)y * (size_t)w + (size_t)x) + (size_t)c] = (float)sum[c];
        }
    }
    return dst;
}

static void free_mip(rtk_texture *tex)
{
    for (int l = 1; l < tex->levels; l++)
        free(tex->mip[l].rgba);
    free(tex->mip);
    tex->mip = NULL;
    tex->levels = 0;
}

/* Levels 0 (the image itself) down to 1x1. */
static rtk_status build_mip(rtk_texture *tex)
{
    if (tex->mip || !tex->rgba || tex->width <= 0 || tex->height <= 0)
        return RTK_OK;
    int levels = 1;
    for (int w = tex->width, h = tex->height; w > 1 || h > 1; levels++) {
        w = w > 1 ? w / 2 : 1;
        h = h > 1 ? h / 2 : 1;
    }
    tex->mip = rtk_calloc((size_t)levels, sizeof *tex->mip);
    if (!tex->mip)
        return RTK_ERR_NOMEM;
    tex->mip[0].width = tex->width;
    tex->mip[0].height = tex->height;
    tex->mip[0].rgba = tex->rgba;
    tex->levels = 1;
    for (int l = 1; l < levels; l++) {
        const rtk_texture_level *up = &tex->mip[l - 1];
        int w = up->width > 1 ? up->width / 2 : 1, h = up->height > 1 ? up->height / 2 : 1;
        float *rgba = reduce(up, w, h);
        if (!rgba) {
            free_mip(tex);
            return RTK_ERR_NOMEM;
        }
        tex->mip[l].width = w;
        tex->mip[l].height = h;
        tex->mip[l].rgba = rgba;
        tex->levels = l + 1;
    }
    return RTK_OK;
}

rtk_status rtk_texture_set_filter(rtk_texture *tex, rtk_texture_filter filter)
{
    tex->filter = filter;
    if (filter != RTK_TEX_TRILINEAR) {
        free_mip(tex);
        return RTK_OK;
    }
    if (!tex->decoded || tex->missing)
        return RTK_OK;
    rtk_status st = build_mip(tex);
    if (st != RTK_OK)
        tex->filter = RTK_TEX_BILINEAR;
    return st;
}

rtk_status rtk_scene_set_texture_filter(rtk_scene *scene, rtk_texture_filter filter)
{
    for (uint32_t m = 0; m <= scene->mesh_count; m++) {
        rtk_scene *s = m == 0 ? scene : scene->meshes[m - 1];
        if (m > 0 && s->owner) /* a glTF mesh shares its file's textures */
            continue;
        for (uint32_t i = 0; i < s->texture_count; i++) {
            rtk_status st = rtk_texture_set_filter(&s->textures[i], filter);
            if (st != RTK_OK)
                return rtk_error(st, "%s: no memory for the MIP levels of texture '%s'", s->path,
                                 s->textures[i].name ? s->textures[i].name : "");
        }
    }
    return RTK_OK;
}

int rtk_texture_filter_from_name(const char *name, rtk_texture_filter *filter)
{
    static const struct {
        const char *name;
        rtk_texture_filter filter;
    } names[] = {{"nearest", RTK_TEX_NEAREST}, {"bilinear", RTK_TEX_BILINEAR}, {"trilinear", RTK_TEX_TRILINEAR}};
    for (size_t i = 0; name && i < sizeof names / sizeof names[0]; i++) {
        if (strcmp(name, names[i].name) == 0) {
            *filter = names[i].filter;
            return 1;
        }
    }
    return 0;
}

float rtk_texture_lod(const rtk_texture *tex, const rtk_uv_footprint *fp)
{
    return rtk_texture_lod_at(tex->width, tex->height, fp);
}

void rtk_texture_sample(const rtk_texture *tex, rtk_tex_wrap wrap, float u, float v, float lod, float rgba[4])
{
    if (!tex || !tex->decoded || tex->missing || !tex->rgba || tex->width <= 0 || tex->height <= 0) {
        rgba[0] = rgba[1] = rgba[2] = rgba[3] = 1.0f;
        return;
    }
    const rtk_texture_level base = {tex->width, tex->height, tex->rgba};
    const int pyramid = tex->filter == RTK_TEX_TRILINEAR && tex->levels >= 2 && tex->mip;
    const rtk_texture_view view = {tex->filter, pyramid ? tex->levels : 1, pyramid ? tex->mip : &base};
    rtk_texture_view_sample(&view, wrap, u, v, lod, rgba);
}

void rtk_texture_lookup(const rtk_texture *tex, float u, float v, float rgba[4])
{
    rtk_tex_wrap repeat = {RTK_WRAP_REPEAT, RTK_WRAP_REPEAT};
    rtk_texture_sample(tex, repeat, u, v, 0.0f, rgba);
}

void rtk_texture_free(rtk_texture *tex)
{
    if (!tex)
        return;
    free(tex->name);
    free(tex->path);
    free(tex->bytes);
    free(tex->problem);
    tex->problem = NULL;
    free_mip(tex);
    free(tex->rgba);
    tex->name = tex->path = NULL;
    tex->bytes = NULL;
    tex->rgba = NULL;
    tex->byte_count = 0;
    tex->width = tex->height = 0;
    tex->decoded = 0;
    tex->missing = 0;
}
