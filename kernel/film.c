/* Film: filtered sample accumulation in double precision. Each tile
 * splats into its own padded buffer; buffers are merged into the film in
 * tile order, so the image is the same whatever the thread count. */
#include "film.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

rtk_status rtk_film_init(rtk_film *film, uint32_t width, uint32_t height, uint32_t channels)
{
    memset(film, 0, sizeof *film);
    film->width = width;
    film->height = height;
    film->channels = channels;
    size_t pixels = (size_t)width * height;
    film->sum = rtk_calloc(pixels * channels, sizeof(double));
    film->weight = rtk_calloc(pixels, sizeof(double));
    if (!film->sum || !film->weight) {
        rtk_film_free(film);
        return RTK_ERR_NOMEM;
    }
    return RTK_OK;
}

void rtk_film_free(rtk_film *film)
{
    free(film->sum);
    free(film->weight);
    film->sum = film->weight = NULL;
}

rtk_status rtk_film_tile_init(rtk_film_tile *t, const rtk_film *film, uint32_t x0, uint32_t y0, uint32_t x1,
                              uint32_t y1, float radius)
{
    memset(t, 0, sizeof *t);
    int pad = (int)ceilf(radius + 0.5f);
    t->x0 = (int)x0 - pad;
    t->y0 = (int)y0 - pad;
    t->w = (int)(x1 - x0) + 2 * pad;
    t->h = (int)(y1 - y0) + 2 * pad;
    t->channels = film->channels;
    size_t n = (size_t)t->w * (size_t)t->h;
    t->sum = rtk_calloc(n * t->channels, sizeof(double));
    t->weight = rtk_calloc(n, sizeof(double));
    if (!t->sum || !t->weight) {
        rtk_film_tile_free(t);
        return RTK_ERR_NOMEM;
    }
    return RTK_OK;
}

void rtk_film_tile_free(rtk_film_tile *t)
{
    free(t->sum);
    free(t->weight);
    t->sum = t->weight = NULL;
}

void rtk_film_tile_splat(rtk_film_tile *t, const rtk_film *film, float fx, float fy, const float *values,
                         const rtk_filter_fns *filter, const void *fstate, float radius)
{
    /* Pixel q's centre is q + 0.5; the sample reaches centres within radius. */
    int qx0 = (int)ceilf(fx - 0.5f - radius), qx1 = (int)floorf(fx - 0.5f + radius);
    int qy0 = (int)ceilf(fy - 0.5f - radius), qy1 = (int)floorf(fy - 0.5f + radius);
    if (qx0 < 0)
        qx0 = 0;
    if (qy0 < 0)
        qy0 = 0;
    if (qx1 > (int)film->width - 1)
        qx1 = (int)film->width - 1;
    if (qy1 > (int)film->height - 1)
        qy1 = (int)film->height - 1;
    for (int qy = qy0; qy <= qy1; qy++) {
        int ly = qy - t->y0;
        if (ly < 0 || ly >= t->h)
            continue;
        for (int qx = qx0; qx <= qx1; qx++) {
            int lx = qx - t->x0;
            if (lx < 0 || lx >= t->w)
                continue;
            float w = filter->eval(fstate, fx - ((float)qx + 0.5f), fy - ((float)qy + 0.5f));
            if (w == 0.0f || !isfinite(w))
                continue;
            size_t i = (size_t)ly * (size_t)t->w + (size_t)lx;
            t->weight[i] += w;
            double *s = t->sum + i * t->channels;
            for (uint32_t c = 0; c < t->channels; c++)
                s[c] += (double)w * values[c];
        }
    }
}

void rtk_film_merge(rtk_film *film, const rtk_film_tile *t)
{
    for (int ly = 0; ly < t->h; ly++) {
        int y = t->y0 + ly;
        if (y < 0 || y >= (int)film->height)
            continue;
        for (int lx = 0; lx < t->w; lx++) {
            int x = t->x0 + lx;
            if (x < 0 || x >= (int)film->width)
                continue;
            size_t li = (size_t)ly * (size_t)t->w + (size_t)lx;
            size_t fi = (size_t)y * film->width + (size_t)x;
            film->weight[fi] += t->weight[li];
            for (uint32_t c = 0; c < film->channels; c++)
                film->sum[fi * film->channels + c] += t->sum[li * t->channels + c];
        }
    }
}

void rtk_film_resolve(const rtk_film *film, float *out)
{
    size_t pixels = (size_t)film->width * film->height;
    for (size_t i = 0; i < pixels; i++) {
        double w = film->weight[i];
        for (uint32_t c = 0; c < film->channels; c++)
            out[i * film->channels + c] = w != 0.0 ? (float)(film->sum[i * film->channels + c] / w) : 0.0f;
    }
}
