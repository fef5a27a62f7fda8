/* The environment light: a constant colour, or an equirectangular image
 * looked up at the nearest pixel and importance-sampled by a piecewise-
 * constant 2D distribution over its pixels, luminance x sin(theta)
 * (marginal over rows, conditional within each row; pbrt-v3 13.6.5). The
 * mapping between directions and (u, v) is documented in rtk/lights.h. */
#include "light_sample.h"
#include "../image/image.h"

#include <math.h>
#include <stdlib.h>

static double luminance(double r, double g, double b)
{
    return 0.2126 * r + 0.7152 * g + 0.0722 * b;
}

void rtk_environment_free(rtk_environment *env)
{
    if (!env)
        return;
    free(env->rgb);
    free(env->func);
    free(env->row_cdf);
    free(env->col_cdf);
    free(env);
}

/* cos and sin of rotation degrees, exact at multiples of 90. */
static void set_rotation(rtk_environment *env, float rotation)
{
    double r = fmod((double)rotation, 360.0);
    if (r < 0.0)
        r += 360.0;
    static const float c4[4] = {1.0f, 0.0f, -1.0f, 0.0f}, s4[4] = {0.0f, 1.0f, 0.0f, -1.0f};
    if (fmod(r, 90.0) == 0.0) {
        int q = (int)(r / 90.0) & 3;
        env->cos_rot = c4[q], env->sin_rot = s4[q];
    } else {
        env->cos_rot = (float)cos(r * RTK_PI / 180.0), env->sin_rot = (float)sin(r * RTK_PI / 180.0);
    }
}

rtk_status rtk_environment_constant(rtk_rgb color, float strength, rtk_environment **out)
{
    *out = NULL;
    rtk_environment *env = rtk_calloc(1, sizeof *env);
    if (!env)
        return RTK_ERR_NOMEM;
    env->color = rtk_rgb_scale(color, strength);
    env->cos_rot = 1.0f;
    env->mean_radiance = luminance(env->color.r, env->color.g, env->color.b);
    *out = env;
    return RTK_OK;
}

/* Running sums of f[0..n) into cdf[0..n], normalised to end at 1 (a
 * uniform cdf when f sums to 0); returns the sum. */
static double build_cdf(const float *f, int n, float *cdf)
{
    double sum = 0.0;
    for (int i = 0; i < n; i++)
        sum += f[i];
    double run = 0.0;
    for (int i = 0; i < n; i++) {
        cdf[i] = sum > 0.0 ? (float)(run / sum) : (float)i / (float)n;
        run += f[i];
    }
    cdf[n] = 1.0f;
    return sum;
}

rtk_status rtk_environment_from_pixels(const char *name, int width, int height, int nchannels, const float *pixels,
                                       float strength, float rotation, rtk_environment **out)
{
    *out = NULL;
    if (nchannels != 3 && nchannels != 4)
        return rtk_error(RTK_ERR_INVALID,
                         "%s: has %d channel%s; an environment needs RGB (3) or RGBA (4): save it as an RGB EXR or HDR",
                         name, nchannels, nchannels == 1 ? "" : "s");
    if (width <= 0 || height <= 0 || (size_t)width * (size_t)height > ((size_t)1 << 28))
        return rtk_error(RTK_ERR_INVALID, "%s: %d x %d pixels is no size for an environment map", name, width, height);
    size_t n = (size_t)width * (size_t)height;
    for (size_t i = 0; i < n; i++) {
        for (int c = 0; c < 3; c++) {
            float v = pixels[i * (size_t)nchannels + (size_t)c];
            if (!isfinite(v) || v < 0.0f)
                return rtk_error(RTK_ERR_INVALID,
                                 "%s: pixel (%zu, %zu) channel %d is %g; environment radiance must be finite and "
                                 "not negative: fix or clamp the image",
                                 name, i % (size_t)width, i / (size_t)width, c, (double)v);
        }
    }
    rtk_environment *env = rtk_calloc(1, sizeof *env);
    if (!env)
        return RTK_ERR_NOMEM;
    env->width = width, env->height = height;
    env->rgb = rtk_alloc(sizeof *env->rgb * 3 * n);
    env->func = rtk_alloc(sizeof *env->func * n);
    env->row_cdf = rtk_alloc(sizeof *env->row_cdf * ((size_t)height + 1));
    env->col_cdf = rtk_alloc(sizeof *env->col_cdf * (size_t)height * ((size_t)width + 1));
    float *row_mean = rtk_alloc(sizeof *row_mean * (size_t)height);
    if (!env->rgb || !env->func || !env->row_cdf || !env->col_cdf || !row_mean) {
        free(row_mean);
        rtk_environment_free(env);
        return RTK_ERR_NOMEM;
    }
    set_rotation(env, rotation);
    double solid = 0.0; /* integral of luminance over the sphere */
    for (int y = 0; y < height; y++) {
        double t0 = RTK_PI * y / height, t1 = RTK_PI * (y + 1) / height;
        double sin_c = sin(RTK_PI * (y + 0.5) / height);
        double pixel_sr = 2.0 * RTK_PI / width * (cos(t0) - cos(t1));
        for (int x = 0; x < width; x++) {
            size_t i = (size_t)y * (size_t)width + (size_t)x;
            const float *px = pixels + i * (size_t)nchannels;
            float *rgb = env->rgb + 3 * i;
            for (int c = 0; c < 3; c++)
                rgb[c] = px[c] * strength;
            double lum = luminance(rgb[0], rgb[1], rgb[2]);
            env->func[i] = (float)(lum * sin_c);
            solid += lum * pixel_sr;
        }
        double row = build_cdf(env->func + (size_t)y * (size_t)width, width,
                               env->col_cdf + (size_t)y * ((size_t)width + 1));
        row_mean[y] = (float)(row / width);
    }
    env->func_mean = build_cdf(row_mean, height, env->row_cdf) / height;
    env->mean_radiance = solid / (4.0 * RTK_PI);
    free(row_mean);
    if (!isfinite(env->func_mean) || !isfinite(env->mean_radiance)) {
        rtk_environment_free(env);
        return rtk_error(RTK_ERR_INVALID, "%s: its radiance x strength %g overflows a float: lower strength", name,
                         (double)strength);
    }
    *out = env;
    return RTK_OK;
}

rtk_status rtk_environment_load(const char *path, float strength, float rotation, rtk_environment **out)
{
    *out = NULL;
    rtk_image img = {0};
    rtk_status st = rtk_image_read(path, NULL, 0, 0, &img);
    if (st != RTK_OK)
        return st;
    /* rtk_image_read expands to RGBA: check what the file itself holds. */
    if (img.channels != 3 && img.channels != 4)
        st = rtk_error(RTK_ERR_INVALID,
                       "%s: has %d channel%s; an environment needs RGB (3) or RGBA (4): save it as an RGB EXR or HDR",
                       path, img.channels, img.channels == 1 ? "" : "s");
    else
        st = rtk_environment_from_pixels(path, img.width, img.height, 4, img.rgba, strength, rotation, out);
    free(img.rgba);
    return st;
}

rtk_rgb rtk_environment_radiance(const rtk_environment *env, rtk_vec3 dir)
{
    return rtk_env_radiance(env, dir);
}

float rtk_environment_sample(const rtk_environment *env, rtk_vec2 u, rtk_vec3 *wi, rtk_rgb *radiance)
{
    return rtk_env_sample(env, u, wi, radiance);
}

float rtk_environment_pdf(const rtk_environment *env, rtk_vec3 dir)
{
    return rtk_env_pdf(env, dir);
}
