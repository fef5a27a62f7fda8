/* Film accumulation (film.c). Tiles are private to one thread; merging
 * into the film is the caller's to serialise, in a fixed tile order. */
#ifndef RTK_KERNEL_FILM_H
#define RTK_KERNEL_FILM_H

#include "../scene/scene.h"
#include "sample.h"

RTK_EXTERN_C_BEGIN

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

/* Channels the renderer accumulates: RGB, albedo RGB, normal XYZ, depth. */
#define RTK_FILM_CHANNELS 10

/* How samples become pixels. */
typedef enum rtk_reconstruction {
    RTK_RECON_SPLAT = 0,     /* each sample weighted into every pixel its filter reaches */
    RTK_RECON_IMPORTANCE = 1 /* filter importance sampling: a pixel's samples are placed by its
                                filter (|f| tabulated) and weighted f / pdf, into that pixel only */
} rtk_reconstruction;

/* A pixel whose summed weight is at most this fraction of its summed
 * |weight| (negative lobes cancelling the positive ones, at low spp) is
 * resolved with |weight|: a convex combination of its samples. Signed
 * resolution thus never magnifies a sample by more than 1 / this. */
#define RTK_FILM_CANCEL 0.0625

/* Counters of one render. */
typedef struct rtk_render_stats {
    uint64_t rays, invalid_rays, bad_samples;
} rtk_render_stats;

/* One render of a scene into a film, for rtk_render_film. Start from
 * RTK_FILM_RENDER_DEFAULTS and set what differs. */
typedef struct rtk_film_render {
    const rtk_scene *scene;
    const rtk_camera *camera;              /* the film's size is the camera's */
    const rtk_integrator_fns *integrator;  /* prepared for scene */
    const void *integrator_state;
    const rtk_filter_fns *filter;
    const void *filter_state;
    uint32_t spp;                          /* samples per pixel; default 1 */
    rtk_sampler_type sampler;              /* default independent */
    rtk_reconstruction reconstruction;     /* default splatting */
    uint64_t seed;                         /* default 0 */
    uint32_t threads;                      /* default 1 */
    int progress;                          /* 1: progress bar on stderr; default 0 */
    int one_ray_at_a_time;                 /* 1: li for every sample, even where the integrator
                                              has li_batch (rtk conform compares); default 0 */
    const rtk_device_program *device_program; /* the integrator's program, run on the scene's
                                                 device (rtk_device_runs said yes); default NULL */
} rtk_film_render;

#define RTK_FILM_RENDER_DEFAULTS \
    {.spp = 1, .sampler = RTK_SAMPLER_INDEPENDENT, .reconstruction = RTK_RECON_SPLAT, .threads = 1}

/* Renders r into pixels (RTK_FILM_CHANNELS floats per pixel, resolved);
 * stats (may be NULL) gets its counters. */
RTK_KERNEL_API rtk_status rtk_render_film(const rtk_film_render *r, float *pixels, rtk_render_stats *stats);

/* One tile's padded accumulation buffer. */
typedef struct rtk_film_tile {
    int x0, y0, w, h; /* film position of the buffer's first pixel, size */
    uint32_t channels;
    double *sum, *weight;
    double *abs_sum, *abs_weight; /* when the film has them */
} rtk_film_tile;

/* track_abs: also keep |weight| sums (filters with negative lobes); the
 * sums are zeroed on up to threads threads. */
RTK_KERNEL_API rtk_status rtk_film_init(rtk_film *film, uint32_t width, uint32_t height, uint32_t channels, int track_abs,
                                        uint32_t threads);
RTK_KERNEL_API void rtk_film_free(rtk_film *film);
/* The pixels a tile's buffer reaches past its own on each side for a
 * filter of this radius. */
int rtk_film_tile_pad(float radius);
/* Buffer for pixels [x0, x1) x [y0, y1) padded by rtk_film_tile_pad. */
RTK_KERNEL_API rtk_status rtk_film_tile_init(rtk_film_tile *tile, const rtk_film *film, uint32_t x0, uint32_t y0, uint32_t x1,
                                             uint32_t y1, float radius);
RTK_KERNEL_API void rtk_film_tile_free(rtk_film_tile *tile);
/* Adds a sample at film position (fx, fy) to every pixel whose centre is
 * within radius, weighted by the filter. */
RTK_KERNEL_API void rtk_film_tile_splat(rtk_film_tile *tile, const rtk_film *film, float fx, float fy, const float *values,
                                        const rtk_filter_fns *filter, const void *fstate, float radius);
/* Adds a sample to pixel (px, py) alone with weight w (filter importance
 * sampling). */
void rtk_film_tile_add(rtk_film_tile *tile, int px, int py, float w, const float *values);
RTK_KERNEL_API void rtk_film_merge(rtk_film *film, const rtk_film_tile *tile);
/* Weighted averages, channels floats per pixel; 0 where no weight
 * arrived; |weight| averages where signed weights cancel
 * (RTK_FILM_CANCEL). Rows on up to threads threads. */
void rtk_film_resolve(const rtk_film *film, float *out, uint32_t threads);

/* Filter importance sampling (Ernst et al. 2006; pbrt-v4's FilterSampler):
 * |f| tabulated on a grid over the support, sampled cell by cell through
 * a marginal and conditional CDF, uniformly inside the cell. */
typedef struct rtk_filter_sampler {
    const rtk_filter_fns *filter;
    const void *state;
    float radius;
    int n;          /* cells per axis */
    double *marginal; /* n + 1 entries: CDF over rows */
    double *conditional; /* n rows of n + 1 entries: CDF over columns in a row */
    double *cell;   /* n x n tabulated |f| (with a floor) */
    double total;   /* sum of cell, times the cell area: the integral of the density's shape */
} rtk_filter_sampler;

rtk_status rtk_filter_sampler_init(rtk_filter_sampler *fs, const rtk_filter_fns *filter, const void *state,
                                   float radius);
/* Offset (dx, dy) from the pixel centre for u in [0, 1)^2, and its weight
 * f(dx, dy) / pdf(dx, dy) (0 where f is 0). [any thread] */
void rtk_filter_sampler_sample(const rtk_filter_sampler *fs, rtk_vec2 u, float *dx, float *dy, float *weight);
void rtk_filter_sampler_free(rtk_filter_sampler *fs);
/* 1 when the filter is negative somewhere on a fine grid of its support. */
int rtk_filter_has_negative_lobes(const rtk_filter_fns *filter, const void *state, float radius);

RTK_EXTERN_C_END

#endif
