/* Textures: decoded once at load time, then looked up from any thread.
 * Lookups use the glTF convention: (u, v) = (0, 0) is the top-left corner of
 * the image and v grows downwards (row = v * height). The OBJ loader flips
 * v to 1 - v on load, so that OBJ/OpenGL uvs (v up) fit this convention. */
#include "internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void rtk_texture_decode(rtk_texture *tex)
{
    if (!tex || tex->decoded)
        return;
    tex->decoded = 1;
    const char *name = tex->name ? tex->name : tex->path ? tex->path : "(unnamed)";
    const char *source = tex->bytes ? name : tex->path;
    rtk_image image;
    rtk_status status = RTK_ERR_INVALID;
    if (source)
        status = rtk_image_read(source, tex->bytes, tex->byte_count, tex->srgb, &image);
    else
        rtk_error(RTK_ERR_INVALID, "it has neither a file nor embedded data");
    if (status != RTK_OK) {
        tex->missing = 1;
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
}

/* Wraps t (finite) to a texel coordinate in [-0.5, size - 0.5) and splits
 * it into the two neighbouring texel indices and the weight of the second. */
static void wrap_axis(float t, int size, int *i0, int *i1, float *frac)
{
    double w = (double)t - floor((double)t);
    if (!(w >= 0.0 && w < 1.0)) /* 1 - tiny rounds to 1 */
        w = 0.0;
    double x = w * size - 0.5;
    double fx = floor(x);
    int a = (int)fx;
    if (a < 0)
        a = size - 1;
    else if (a > size - 1)
        a = size - 1;
    int b = a + 1 < size ? a + 1 : 0;
    *i0 = a;
    *i1 = b;
    *frac = (float)(x - fx);
}

void rtk_texture_lookup(const rtk_texture *tex, float u, float v, float rgba[4])
{
    if (!tex || !tex->decoded || tex->missing || !tex->rgba || tex->width <= 0 || tex->height <= 0) {
        rgba[0] = rgba[1] = rgba[2] = rgba[3] = 1.0f;
        return;
    }
    size_t width = (size_t)tex->width;
    if (!isfinite(u) || !isfinite(v)) {
        memcpy(rgba, tex->rgba, 4 * sizeof(float));
        return;
    }
    int x0, x1, y0, y1;
    float fx, fy;
    wrap_axis(u, tex->width, &x0, &x1, &fx);
    wrap_axis(v, tex->height, &y0, &y1, &fy);
    const float *t00 = tex->rgba + 4 * ((size_t)y0 * width + (size_t)x0);
    const float *t10 = tex->rgba + 4 * ((size_t)y0 * width + (size_t)x1);
    const float *t01 = tex->rgba + 4 * ((size_t)y1 * width + (size_t)x0);
    const float *t11 = tex->rgba + 4 * ((size_t)y1 * width + (size_t)x1);
    float w00 = (1.0f - fx) * (1.0f - fy), w10 = fx * (1.0f - fy);
    float w01 = (1.0f - fx) * fy, w11 = fx * fy;
    for (int c = 0; c < 4; c++)
        rgba[c] = w00 * t00[c] + w10 * t10[c] + w01 * t01[c] + w11 * t11[c];
}

void rtk_texture_free(rtk_texture *tex)
{
    if (!tex)
        return;
    free(tex->name);
    free(tex->path);
    free(tex->bytes);
    free(tex->rgba);
    tex->name = tex->path = NULL;
    tex->bytes = NULL;
    tex->rgba = NULL;
    tex->byte_count = 0;
    tex->width = tex->height = 0;
    tex->decoded = 0;
    tex->missing = 0;
}
