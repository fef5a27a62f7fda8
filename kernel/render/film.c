/* Film: filtered sample accumulation in double precision. Each tile
 * splats into its own padded buffer; every pixel gets the buffers that
 * reach it in tile order (render.c), so the image is the same whatever
 * the thread count. */
#include "render.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

rtk_status rtk_film_init(rtk_film *film, uint32_t width, uint32_t height, uint32_t channels, int track_abs,
                         uint32_t threads)
{
    memset(film, 0, sizeof *film);
    film->width = width;
    film->height = height;
    film->channels = channels;
    size_t pixels = (size_t)width * height;
    /* Tiles are added to the film (rtk_film_merge): rtk_alloc_zeroed. */
    film->sum = rtk_alloc_zeroed(pixels * channels, sizeof(double), threads);
    film->weight = rtk_alloc_zeroed(pixels, sizeof(double), threads);
    if (track_abs) {
        film->abs_sum = rtk_alloc_zeroed(pixels * channels, sizeof(double), threads);
        film->abs_weight = rtk_alloc_zeroed(pixels, sizeof(double), threads);
    }
    if (!film->sum || !film->weight || (track_abs && (!film->abs_sum || !film->abs_weight))) {
        rtk_film_free(film);
        return RTK_ERR_NOMEM;
    }
    return RTK_OK;
}

void rtk_film_free(rtk_film *film)
{
    free(film->sum);
    free(film->weight);
    free(film->abs_sum);
    free(film->abs_weight);
    film->sum = film->weight = film->abs_sum = film->abs_weight = NULL;
}

int rtk_film_tile_pad(float radius)
{
    return (int)ceilf(radius + 0.5f);
}

rtk_status rtk_film_tile_init(rtk_film_tile *t, const rtk_film *film, uint32_t x0, uint32_t y0, uint32_t x1,
                              uint32_t y1, float radius)
{
    memset(t, 0, sizeof *t);
    int pad = rtk_film_tile_pad(radius);
    t->x0 = (int)x0 - pad;
    t->y0 = (int)y0 - pad;
    t->w = (int)(x1 - x0) + 2 * pad;
    t->h = (int)(y1 - y0) + 2 * pad;
    t->channels = film->channels;
    size_t n = (size_t)t->w * (size_t)t->h;
    t->sum = rtk_calloc(n * t->channels, sizeof(double));
    t->weight = rtk_calloc(n, sizeof(double));
    int track_abs = film->abs_sum != NULL;
    if (track_abs) {
        t->abs_sum = rtk_calloc(n * t->channels, sizeof(double));
        t->abs_weight = rtk_calloc(n, sizeof(double));
    }
    if (!t->sum || !t->weight || (track_abs && (!t->abs_sum || !t->abs_weight))) {
        rtk_film_tile_free(t);
        return RTK_ERR_NOMEM;
    }
    return RTK_OK;
}

void rtk_film_tile_free(rtk_film_tile *t)
{
    free(t->sum);
    free(t->weight);
    free(t->abs_sum);
    free(t->abs_weight);
    t->sum = t->weight = t->abs_sum = t->abs_weight = NULL;
}

/* Adds w x values to buffer pixel i (and |w| x values when tracked). */
static void accumulate(rtk_film_tile *t, size_t i, float w, const float *values)
{
    t->weight[i] += w;
    double *s = t->sum + i * t->channels;
    for (uint32_t c = 0; c < t->channels; c++)
        s[c] += (double)w * values[c];
    if (t->abs_sum) {
        double a = fabs((double)w);
        t->abs_weight[i] += a;
        double *as = t->abs_sum + i * t->channels;
        for (uint32_t c = 0; c < t->channels; c++)
            as[c] += a * values[c];
    }
}

void rtk_film_tile_add(rtk_film_tile *t, int px, int py, float w, const float *values)
{
    int lx = px - t->x0, ly = py - t->y0;
    if (lx < 0 || lx >= t->w || ly < 0 || ly >= t->h || w == 0.0f || !isfinite(w))
        return;
    accumulate(t, (size_t)ly * (size_t)t->w + (size_t)lx, w, values);
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
            accumulate(t, (size_t)ly * (size_t)t->w + (size_t)lx, w, values);
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
            if (film->abs_sum && t->abs_sum) {
                film->abs_weight[fi] += t->abs_weight[li];
                for (uint32_t c = 0; c < film->channels; c++)
                    film->abs_sum[fi * film->channels + c] += t->abs_sum[li * t->channels + c];
            }
        }
    }
}

typedef struct resolve_job {
    const rtk_film *film;
    float *out;
} resolve_job;

/* Rows [begin, end) of rtk_film_resolve. */
static void resolve_rows(void *ctx, uint32_t begin, uint32_t end)
{
    const resolve_job *j = ctx;
    const rtk_film *film = j->film;
    const size_t last = (size_t)end * film->width;
    for (size_t i = (size_t)begin * film->width; i < last; i++) {
        double w = film->weight[i];
        const double *sum = film->sum + i * film->channels;
        if (film->abs_sum && !(w > RTK_FILM_CANCEL * film->abs_weight[i])) {
            w = film->abs_weight[i];
            sum = film->abs_sum + i * film->channels;
        }
        for (uint32_t c = 0; c < film->channels; c++)
            j->out[i * film->channels + c] = w != 0.0 ? (float)(sum[c] / w) : 0.0f;
    }
}

void rtk_film_resolve(const rtk_film *film, float *out, uint32_t threads)
{
    resolve_job j = {film, out};
    rtk_parallel_ranges(film->height, threads, 16, resolve_rows, &j);
}

int rtk_filter_has_negative_lobes(const rtk_filter_fns *filter, const void *state, float radius)
{
    const int n = 128;
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++) {
            float dx = radius * (2.0f * (float)i / n - 1.0f), dy = radius * (2.0f * (float)j / n - 1.0f);
            if (filter->eval(state, dx, dy) < 0.0f)
                return 1;
        }
    return 0;
}

void rtk_filter_sampler_free(rtk_filter_sampler *fs)
{
    free(fs->marginal);
    free(fs->conditional);
    free(fs->cell);
    fs->marginal = fs->conditional = fs->cell = NULL;
}

rtk_status rtk_filter_sampler_init(rtk_filter_sampler *fs, const rtk_filter_fns *filter, const void *state,
                                   float radius)
{
    memset(fs, 0, sizeof *fs);
    fs->filter = filter;
    fs->state = state;
    fs->radius = radius;
    /* 32 cells per pixel of support width (pbrt-v4's density), 16 to 256 per axis. */
    int n = (int)ceilf(64.0f * radius);
    fs->n = n < 16 ? 16 : n > 256 ? 256 : n;
    n = fs->n;
    fs->marginal = rtk_alloc(sizeof(double) * (size_t)(n + 1));
    fs->conditional = rtk_alloc(sizeof(double) * (size_t)n * (size_t)(n + 1));
    fs->cell = rtk_alloc(sizeof(double) * (size_t)n * (size_t)n);
    if (!fs->marginal || !fs->conditional || !fs->cell) {
        rtk_filter_sampler_free(fs);
        return RTK_ERR_NOMEM;
    }
    /* |f| at each cell's centre and corners (the largest), floored at
     * 1e-3 of the largest value anywhere: a cell where f crosses zero keeps
     * a density, so no part of the support goes unsampled. */
    double peak = 0.0;
    const double h = 2.0 * radius / n;
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            double m = 0.0;
            for (int k = 0; k < 5; k++) {
                double fx = k == 4 ? 0.5 : (k & 1), fy = k == 4 ? 0.5 : (k >> 1);
                float dx = (float)(-radius + (i + fx) * h), dy = (float)(-radius + (j + fy) * h);
                double v = fabs((double)filter->eval(state, dx, dy));
                m = isfinite(v) && v > m ? v : m;
            }
            fs->cell[(size_t)j * n + i] = m;
            peak = m > peak ? m : peak;
        }
    if (!(peak > 0.0)) {
        rtk_filter_sampler_free(fs);
        return rtk_error(RTK_ERR_PLUGIN, "filter is zero everywhere on its support: nothing to sample");
    }
    fs->marginal[0] = 0.0;
    for (int j = 0; j < n; j++) {
        double *row = fs->conditional + (size_t)j * (n + 1);
        row[0] = 0.0;
        for (int i = 0; i < n; i++) {
            double *c = &fs->cell[(size_t)j * n + i];
            if (*c < 1e-3 * peak)
                *c = 1e-3 * peak;
            row[i + 1] = row[i] + *c;
        }
        fs->marginal[j + 1] = fs->marginal[j] + row[n];
    }
    fs->total = fs->marginal[n] * h * h;
    return RTK_OK;
}

/* Index k with cdf[k] <= x < cdf[k + 1] (cdf ascending, n + 1 entries). */
static int find_interval(const double *cdf, int n, double x)
{
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (cdf[mid] <= x)
            lo = mid;
        else
            hi = mid - 1;
    }
    return lo;
}

void rtk_filter_sampler_sample(const rtk_filter_sampler *fs, rtk_vec2 u, float *dx, float *dy, float *weight)
{
    const int n = fs->n;
    const double h = 2.0 * fs->radius / n;
    double y = u.y * fs->marginal[n];
    int j = find_interval(fs->marginal, n, y);
    const double *row = fs->conditional + (size_t)j * (n + 1);
    double x = u.x * row[n];
    int i = find_interval(row, n, x);
    double cell = fs->cell[(size_t)j * n + i];
    /* The remainders place the point inside the cell. */
    double fx = (x - row[i]) / cell, fy = (y - fs->marginal[j]) / (fs->marginal[j + 1] - fs->marginal[j]);
    fx = fx < 0.0 ? 0.0 : fx > 1.0 ? 1.0 : fx;
    fy = fy < 0.0 ? 0.0 : fy > 1.0 ? 1.0 : fy;
    *dx = (float)(-fs->radius + (i + fx) * h);
    *dy = (float)(-fs->radius + (j + fy) * h);
    double pdf = cell / fs->total;
    double f = fs->filter->eval(fs->state, *dx, *dy);
    *weight = isfinite(f) ? (float)(f / pdf) : 0.0f;
}
