/* Filtered texture lookups in plain C that nvcc compiles too (RTK_HD):
 * wrap modes, nearest, bilinear and trilinear filtering over a texture's
 * levels. texture.c's rtk_texture_sample calls it, and a device reading
 * textures passes its own copy of the levels, so both filter alike
 * (tests/cuda checks nvcc's code against the kernel's bit for bit). */
#ifndef RTK_KERNEL_TEXTURE_SAMPLE_H
#define RTK_KERNEL_TEXTURE_SAMPLE_H

#include "texture.h"

#include <math.h>
#include <stdint.h>

/* A decoded texture as lookups read it: its filter and its levels, level
 * 0 the image (more than one only for trilinear). Host or device
 * pointers alike. */
typedef struct rtk_texture_view {
    rtk_texture_filter filter;
    int levels;                     /* >= 1 */
    const rtk_texture_level *level; /* level 0, then each halved */
} rtk_texture_view;

/* Repeat: wraps t (finite) to a texel coordinate in [-0.5, size - 0.5)
 * and splits it into the two neighbouring texel indices and the weight of
 * the second. */
RTK_HD static inline void rtk_tex_wrap_axis(float t, int size, int *i0, int *i1, float *frac)
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

/* t (finite) folded into [0, 1] by clamp or mirrored repeat. */
RTK_HD static inline double rtk_tex_fold(float t, int wrap)
{
    if (wrap == RTK_WRAP_CLAMP)
        return t < 0.0f ? 0.0 : t > 1.0f ? 1.0 : (double)t;
    double m = (double)t - 2.0 * floor(0.5 * (double)t);
    if (!(m >= 0.0 && m < 2.0))
        m = 0.0;
    return m > 1.0 ? 2.0 - m : m;
}

/* The two texels around t along an axis of size texels and the weight of
 * the second. Clamp and mirror both end on the edge texel: past the edge
 * of a mirrored image lies the edge texel again. */
RTK_HD static inline void rtk_tex_axis_linear(float t, int size, int wrap, int *i0, int *i1, float *frac)
{
    if (wrap != RTK_WRAP_CLAMP && wrap != RTK_WRAP_MIRROR) {
        rtk_tex_wrap_axis(t, size, i0, i1, frac);
        return;
    }
    double x = rtk_tex_fold(t, wrap) * size - 0.5;
    double fx = floor(x);
    int a = (int)fx;
    *i0 = a < 0 ? 0 : a > size - 1 ? size - 1 : a;
    *i1 = a + 1 < 0 ? 0 : a + 1 > size - 1 ? size - 1 : a + 1;
    *frac = (float)(x - fx);
}

/* The texel containing t along an axis of size texels. */
RTK_HD static inline int rtk_tex_axis_nearest(float t, int size, int wrap)
{
    double w;
    if (wrap == RTK_WRAP_CLAMP || wrap == RTK_WRAP_MIRROR) {
        w = rtk_tex_fold(t, wrap);
    } else {
        w = (double)t - floor((double)t);
        if (!(w >= 0.0 && w < 1.0))
            w = 0.0;
    }
    int i = (int)floor(w * size);
    return i < 0 ? 0 : i > size - 1 ? size - 1 : i;
}

RTK_HD static inline void rtk_tex_copy4(const float *from, float rgba[4])
{
    for (int c = 0; c < 4; c++)
        rgba[c] = from[c];
}

RTK_HD static inline void rtk_tex_bilinear(const rtk_texture_level *l, rtk_tex_wrap wrap, float u, float v,
                                           float rgba[4])
{
    size_t width = (size_t)l->width;
    int x0, x1, y0, y1;
    float fx, fy;
    rtk_tex_axis_linear(u, l->width, wrap.s, &x0, &x1, &fx);
    rtk_tex_axis_linear(v, l->height, wrap.t, &y0, &y1, &fy);
    const float *t00 = l->rgba + 4 * ((size_t)y0 * width + (size_t)x0);
    const float *t10 = l->rgba + 4 * ((size_t)y0 * width + (size_t)x1);
    const float *t01 = l->rgba + 4 * ((size_t)y1 * width + (size_t)x0);
    const float *t11 = l->rgba + 4 * ((size_t)y1 * width + (size_t)x1);
    float w00 = (1.0f - fx) * (1.0f - fy), w10 = fx * (1.0f - fy);
    float w01 = (1.0f - fx) * fy, w11 = fx * fy;
    for (int c = 0; c < 4; c++)
        rgba[c] = w00 * t00[c] + w10 * t10[c] + w01 * t01[c] + w11 * t11[c];
}

/* rtk_texture_sample on a decoded texture t (level 0 at least 1 x 1):
 * texel (0, 0) for non-finite (u, v); lod is read only by trilinear (<= 0
 * is level 0). */
RTK_HD static inline void rtk_texture_view_sample(const rtk_texture_view *t, rtk_tex_wrap wrap, float u, float v,
                                                  float lod, float rgba[4])
{
    const rtk_texture_level *base = &t->level[0];
    if (!isfinite(u) || !isfinite(v)) {
        rtk_tex_copy4(base->rgba, rgba);
        return;
    }
    if (t->filter == RTK_TEX_NEAREST) {
        int x = rtk_tex_axis_nearest(u, base->width, wrap.s), y = rtk_tex_axis_nearest(v, base->height, wrap.t);
        rtk_tex_copy4(base->rgba + 4 * ((size_t)y * (size_t)base->width + (size_t)x), rgba);
        return;
    }
    if (t->filter != RTK_TEX_TRILINEAR || t->levels < 2 || !(lod > 0.0f)) {
        rtk_tex_bilinear(base, wrap, u, v, rgba);
        return;
    }
    int last = t->levels - 1;
    if (lod >= (float)last) {
        rtk_tex_bilinear(&t->level[last], wrap, u, v, rgba);
        return;
    }
    int l = (int)floorf(lod);
    float f = lod - (float)l, a[4], b[4];
    rtk_tex_bilinear(&t->level[l], wrap, u, v, a);
    if (f == 0.0f) {
        rtk_tex_copy4(a, rgba);
        return;
    }
    rtk_tex_bilinear(&t->level[l + 1], wrap, u, v, b);
    for (int c = 0; c < 4; c++)
        rgba[c] = (1.0f - f) * a[c] + f * b[c];
}

/* rtk_texture_lod of a texture whose level 0 is width x height texels:
 * log2 of the longer footprint side in texels. The sides are square roots
 * of sums (not hypot), which round alike on every processor. */
RTK_HD static inline float rtk_texture_lod_at(int width, int height, const rtk_uv_footprint *fp)
{
    const double w = width, h = height;
    const double xu = (double)fp->dudx * w, xv = (double)fp->dvdx * h;
    const double yu = (double)fp->dudy * w, yv = (double)fp->dvdy * h;
    const double x = sqrt(xu * xu + xv * xv), y = sqrt(yu * yu + yv * yv);
    const double r = x > y ? x : y;
    if (r == INFINITY)
        return 1e30f;
    if (!(r > 0.0))
        return 0.0f;
    return (float)log2(r);
}

/* rtk_texture_sample(tex, wrap, u, v, lod, rgba) of the texture t shows,
 * whose MIP levels (t->levels of them, level 0 first) are at level. */
RTK_HD static inline void rtk_device_texture_sample(const rtk_device_texture *t, const rtk_texture_level *level,
                                                    rtk_tex_wrap wrap, float u, float v, float lod, float rgba[4])
{
    if (!t->rgba || t->width <= 0 || t->height <= 0) {
        rgba[0] = rgba[1] = rgba[2] = rgba[3] = 1.0f;
        return;
    }
    const rtk_texture_level base = {t->width, t->height, (float *)t->rgba};
    const int pyramid = t->filter == RTK_TEX_TRILINEAR && t->levels >= 2 && level;
    const rtk_texture_view view = {(rtk_texture_filter)t->filter, pyramid ? t->levels : 1, pyramid ? level : &base};
    rtk_texture_view_sample(&view, wrap, u, v, lod, rgba);
}

#endif
